"""The dual VNIR+SWIR instrument: what every application of the boresight effect shares.

- :mod:`~geoboresight.sensor.bands`: the band layout matched between the two detectors (the
  ratio's single bands, or band-range means on each side of the seam);
- :mod:`~geoboresight.sensor.dark`: the dark levels of the two instruments;
- :mod:`~geoboresight.sensor.offset`: the VNIR/SWIR offset (the boresight effect itself);
- :mod:`~geoboresight.sensor.coregister`: the SWIR image resampled onto the VNIR grid;
- :mod:`~geoboresight.sensor.calibration`: radiance from raw DN through the vendor's
  calibration (dark, gain, integration time);
- the sensor's geometry: :mod:`~geoboresight.sensor.navigation` (the trajectory, brought to
  each line's time), :mod:`~geoboresight.sensor.boresight` (boresight angles and lever arm),
  :mod:`~geoboresight.sensor.model` (each pixel's look direction),
  :mod:`~geoboresight.sensor.intersect` and :mod:`~geoboresight.sensor.georeference` (direct
  georeferencing, Brook & Ben-Dor 2011, §2, Eq. 1–2) and :mod:`~geoboresight.sensor.calibrate`
  (the boresight angles measured on tie points).

Kernels only (arrays in, arrays and small values out): the kernel packages (``shadow``,
``anomaly``, ``dem``, ``georef``) and ``io`` stand above it. Its modules are imported on
demand, nothing here.

The geometry's conventions (held by ``tests/test_direct_georef.py``):

* WGS84, ellipsoidal heights; ECEF is EPSG:4978, geodetic EPSG:4979, every conversion through
  pyproj.
* Body frame x forward, y right, z down. ``R_nb = Rz(heading)·Ry(pitch)·Rx(roll)`` takes the
  body frame to the local north-east-down frame; roll positive right wing down, pitch positive
  nose up, heading clockwise from true north.
* The boresight ``R_bs = Rz(dh)·Ry(dp)·Rx(dr)`` takes the sensor frame to the body frame.
* The lever arm runs from the navigation's reference point to the sensor, in body-frame
  metres.
* A pixel's across-track angle is positive to the right, its along-track angle positive
  forward; its look vector in the sensor frame is ``[tan along, tan across, 1]`` (normalised).
* A line recorded at time ``t`` sees the navigation at ``t + time_offset``.
"""
