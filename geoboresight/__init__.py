"""geoboresight: the boresight effect of dual pushbroom hyperspectral sensors as information.

Implements Brook & Ben-Dor, "Advantages of the boresight effect in hyperspectral data
analysis", Remote Sensing 3 (2011) 484–502, https://doi.org/10.3390/rs3030484: the boresight
band ratio b(1010 nm)/b(920 nm) (Eq. 3) and its statistics, a shadow map, a relative DEM and a
sub-pixel anomaly indicator.

One flat public API, loaded lazily (``import geoboresight`` imports neither NumPy nor GDAL):

- kernels, on NumPy arrays and a validity mask: ``boresight_ratio``, ``describe``, ``rx``, ...
  (``KERNELS``);
- file-level operations, on whole flight lines: ``ratio_file``, ``shadow_classes_file``, ...
  (``OPERATIONS``), the same functions the command line, ``rio boresight`` and QGIS run;
- the values those operations take: ``BandChoice``, ``SurfaceModel``, ... (``VALUES``);
- the dual-sensor reader ``open_dual``, the windowed map ``map_windows``, ... (``IO``).

>>> import geoboresight as gb                                   # doctest: +SKIP
>>> gb.ratio_file("line_vnir.hdr", "line_swir.hdr", output="ratio.tif")   # doctest: +SKIP
"""

from __future__ import annotations

import importlib

from ._version import __version__ as __version__

#: Kernels: arrays in, arrays (or small frozen dataclasses) out; ``f(data..., valid=None, *,
#: options)``.
KERNELS = {
    "boresight_ratio": "geoboresight.ratio",
    "describe": "geoboresight.stats",
    "cast_shadow": "geoboresight.shadow.illumination",
    "shadow_fraction": "geoboresight.shadow.illumination",
    "hillshade": "geoboresight.shadow.incidence",
    "fit_shadow_cluster": "geoboresight.shadow.cluster",
    "fit_dark_pixel": "geoboresight.shadow.darkpixel",
    "fit_fraction_model": "geoboresight.shadow.fraction",
    "dark_object": "geoboresight.sensor.dark",
    "calibrate_shadow_map": "geoboresight.shadow.darkness",
    "shadow_fraction_estimate": "geoboresight.shadow.darkness",
    "choose_surface": "geoboresight.shadow.surface",
    "estimate_offset": "geoboresight.sensor.offset",
    "offset_profile": "geoboresight.sensor.offset",
    "coregister": "geoboresight.sensor.coregister",
    "disparity_map": "geoboresight.dem.disparity",
    "relative_dem": "geoboresight.dem.relative",
    "band_mean": "geoboresight.sensor.bands",
    "rx": "geoboresight.anomaly.rx",
    "local_rx": "geoboresight.anomaly.rx",
    "fit_svdd": "geoboresight.anomaly.svdd",
    "boresight_indicator": "geoboresight.anomaly.indicator",
    "unmix": "geoboresight.anomaly.unmix",
    "unmix_cube": "geoboresight.anomaly.unmix",
    "roc_curve": "geoboresight.anomaly.roc",
    "label_anomalies": "geoboresight.anomaly.polygons",
    "fit_transform": "geoboresight.georef.transforms",
    "clean_igm": "geoboresight.georef.geoloc",
    "corner_geoloc": "geoboresight.georef.geoloc",
    "glt_indices": "geoboresight.georef.geoloc",
    "match_tie_points": "geoboresight.georef.tiepoints",
    "place_reference": "geoboresight.georef.tiepoints",
    "simulate_ortho": "geoboresight.simulate.ortho",
    "attitude_jitter": "geoboresight.simulate.ortho",
    "simulate_scene": "geoboresight.simulate.scene",
    "radiance": "geoboresight.sensor.calibration",
    "ground_points": "geoboresight.sensor.georeference",
    "calibrate_boresight": "geoboresight.sensor.calibrate",
    "tie_point_ground": "geoboresight.sensor.calibrate",
    "transfer_tie_points": "geoboresight.georef.transfer",
}


def _operations() -> dict[str, str]:
    """File-level operations, one per operation of the command line and the QGIS toolbox:
    ``{name_file: spec module}`` for every operation of :data:`geoboresight.algorithms.SPECS`
    (its spec wraps the function: checked arguments, guarded outputs, ``overwrite``)."""
    specs = importlib.import_module("geoboresight.algorithms").SPECS  # the standard library only
    return {
        f"{name.replace('-', '_')}_file": f"geoboresight.algorithms.{module}"
        for module, names in specs.items()
        for name in names
    }


#: File-level operations: one per operation of the command line and the QGIS toolbox.
OPERATIONS = _operations()

#: The values the operations take: small frozen dataclasses, each a spec's parameter group
#: (flat on the command line and in QGIS, one value in Python: ``bands=gb.BandChoice(...)``).
#: Every class an operation's signature names is here (tests/test_house.py checks it).
VALUES = {
    "BandChoice": "geoboresight.io.dual",
    "DualLayout": "geoboresight.io.dual",
    "MatchBands": "geoboresight.io.bands",
    "Coregistration": "geoboresight.io.bands",
    "BoresightOffset": "geoboresight.io.bands",
    "DarkLevels": "geoboresight.sensor.dark",
    "Sample": "geoboresight.io.windows",
    "OutputGrid": "geoboresight.io.grid",
    "FlightGeometry": "geoboresight.dem.height",
    "Matching": "geoboresight.dem.disparity",
    "Kriging": "geoboresight.dem.relative",
    "BandSelection": "geoboresight.anomaly.bands",
    "Detectability": "geoboresight.anomaly.physical",
    "Dipole": "geoboresight.anomaly.physical",
    "Eq3Reference": "geoboresight.anomaly.indicator",
    "RXBackground": "geoboresight.anomaly.rx",
    "TieMatching": "geoboresight.georef.tiepoints",
    "SimulatedFlight": "geoboresight.simulate.scene",
    "Sky": "geoboresight.simulate.scene",
    "SensorOptions": "geoboresight.simulate.scene",
    "MapCalibration": "geoboresight.operations.shadow_map",
    "Detection": "geoboresight.operations.shadow_map",
    "SurfaceModel": "geoboresight.operations.shadow_map",
    "LightModel": "geoboresight.operations.deshadow",
    "NirBand": "geoboresight.operations.shadow",
    "SensorGeometry": "geoboresight.operations.direct_georef",
    "Terrain": "geoboresight.operations.direct_georef",
    "TieSources": "geoboresight.operations.boresight_calibrate",
    "BoresightFit": "geoboresight.operations.boresight_calibrate",
    "Calibration": "geoboresight.sensor.calibration",
}

#: What a script needs beside the operations: readers, writers, the block loop, progress and
#: the errors it may catch.
IO = {
    "open_dual": "geoboresight.io.dual",
    "open_cube": "geoboresight.io.cube",
    "recognise": "geoboresight.io.products",
    "read_calibration": "geoboresight.io.calibration",
    "writer_options": "geoboresight.io.raster",
    "map_windows": "geoboresight.io.windows",
    "reduce_windows": "geoboresight.io.windows",
    "Grid": "geoboresight.io.grid",
    "write_scene": "geoboresight.io.scene",
    "Navigation": "geoboresight.sensor.navigation",
    "SensorModel": "geoboresight.sensor.model",
    "Surface": "geoboresight.sensor.georeference",
    "Boresight": "geoboresight.sensor.boresight",
    "LeverArm": "geoboresight.sensor.boresight",
    "read_navigation": "geoboresight.io.navigation",
    "read_sensor_model": "geoboresight.io.navigation",
    "Progress": "geoboresight.progress",
    "GeoboresightError": "geoboresight.errors",
    "InputError": "geoboresight.errors",
    "ParameterError": "geoboresight.errors",
    "OutputError": "geoboresight.errors",
    "ResourceError": "geoboresight.errors",
    "Cancelled": "geoboresight.errors",
}

_API = {**KERNELS, **OPERATIONS, **VALUES, **IO}
__all__ = sorted(_API)


def __getattr__(name: str):
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'geoboresight' has no attribute {name!r}")
    if name in OPERATIONS:  # the function its spec wraps
        specs = importlib.import_module(module).ALGORITHMS
        value = next(a.operation for a in specs if a.run.__name__ == name)
    else:
        value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__():
    return sorted({*globals(), *_API})
