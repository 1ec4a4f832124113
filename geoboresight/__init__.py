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
- the dual-sensor reader ``open_dual`` and the windowed map ``map_windows``.

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
    "hillshade": "geoboresight.shadow.illumination",
    "fit_shadow_cluster": "geoboresight.shadow.cluster",
    "fit_dark_pixel": "geoboresight.shadow.darkpixel",
    "fit_fraction_model": "geoboresight.shadow.fraction",
    "dark_level": "geoboresight.shadow.map",
    "calibrate_shadow_map": "geoboresight.shadow.map",
    "shadow_fraction_estimate": "geoboresight.shadow.map",
    "choose_surface": "geoboresight.shadow.surface",
    "estimate_offset": "geoboresight.dem.offset",
    "offset_profile": "geoboresight.dem.offset",
    "coregister": "geoboresight.dem.coregister",
    "disparity_map": "geoboresight.dem.disparity",
    "relative_dem": "geoboresight.dem.relative",
    "band_mean": "geoboresight.dem.bands",
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
}


def _operations() -> dict[str, str]:
    """File-level operations, one per operation of the command line and the QGIS toolbox:
    ``{name: module}`` of every function decorated ``@operation`` in
    :mod:`geoboresight.operations` (read from the modules' text, so that ``import
    geoboresight`` stays light and an operation is declared in one place)."""
    import pathlib
    import re

    found = {}
    folder = pathlib.Path(__file__).parent / "operations"
    declared = re.compile(r"^@operation\(.*?\)\ndef (\w+_file)\(", re.M | re.S)
    for path in sorted(folder.glob("*.py")):
        if path.stem.startswith("_"):
            continue
        for name in declared.findall(path.read_text(encoding="utf-8")):
            found[name] = f"geoboresight.operations.{path.stem}"
    return found


#: File-level operations: one per operation of the command line and the QGIS toolbox.
OPERATIONS = _operations()

#: The I/O entry points a script needs beside the operations.
IO = {
    "open_dual": "geoboresight.io.dual",
    "DualLayout": "geoboresight.io.dual",
    "BandChoice": "geoboresight.io.dual",
    # Frozen option values of the operations (a spec's parameter groups).
    "MatchBands": "geoboresight.io.bands",
    "FlightGeometry": "geoboresight.dem.height",
    "Matching": "geoboresight.dem.disparity",
    "Kriging": "geoboresight.dem.relative",
    "BandSelection": "geoboresight.anomaly.bands",
    "Coregistration": "geoboresight.io.bands",
    "Dipole": "geoboresight.anomaly.physical",
    "Eq3Reference": "geoboresight.anomaly.indicator",
    "RXBackground": "geoboresight.anomaly.rx",
    "OutputGrid": "geoboresight.io.grid",
    "TieMatching": "geoboresight.georef.tiepoints",
    "SimulatedFlight": "geoboresight.simulate.scene",
    "Sky": "geoboresight.simulate.scene",
    "SensorOptions": "geoboresight.simulate.scene",
    "writer_options": "geoboresight.io.raster",
    "open_cube": "geoboresight.io.cube",
    "map_windows": "geoboresight.io.windows",
    "reduce_windows": "geoboresight.io.windows",
    "Grid": "geoboresight.io.grid",
    "write_scene": "geoboresight.io.scene",
    "Progress": "geoboresight.progress",
    "GeoboresightError": "geoboresight.errors",
}

_API = {**KERNELS, **OPERATIONS, **IO}
__all__ = sorted(_API)


def __getattr__(name: str):
    module = _API.get(name)
    if module is None:
        raise AttributeError(f"module 'geoboresight' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later look-ups skip this function
    return value


def __dir__():
    return sorted({*globals(), *_API})
