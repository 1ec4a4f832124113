"""The dual VNIR+SWIR instrument: what every application of the boresight effect shares.

- :mod:`~geoboresight.sensor.bands`: the band layout matched between the two detectors (the
  ratio's single bands, or band-range means on each side of the seam);
- :mod:`~geoboresight.sensor.dark`: the dark levels of the two instruments;
- :mod:`~geoboresight.sensor.offset`: the VNIR/SWIR offset (the boresight effect itself);
- :mod:`~geoboresight.sensor.coregister`: the SWIR image resampled onto the VNIR grid;
- :mod:`~geoboresight.sensor.calibration`: radiance from raw DN through the vendor's
  calibration (dark, gain, integration time).

Kernels only (arrays in, arrays and small values out): the kernel packages (``shadow``,
``anomaly``, ``dem``, ``georef``) and ``io`` stand above it. Its modules are imported on
demand, nothing here.
"""
