"""Each instrument's dark level (DN of zero signal) for an operation, in one call: what the
files record (:func:`geoboresight.io.dark.recorded_dark_levels`), chosen against the user's
level and the estimate from a sample of the data
(:func:`geoboresight.sensor.dark.find_dark_levels`), logged and checked against the sample
(:func:`geoboresight.shadow.darkness.check_sample`)."""

from __future__ import annotations

import numpy as np

from .. import io
from ..io.dark import recorded_dark_levels
from ..sensor.dark import DarkLevels, find_dark_levels
from ..shadow.darkness import check_sample

#: Bands per instrument read for the dark level besides the signal bands (evenly spaced).
DARK_BANDS = 16


def spread_bands(bands: tuple[int, ...], n: int) -> list[int]:
    """At most ``n`` of ``bands``, evenly spaced over them (the first and last included)."""
    idx = np.unique(np.linspace(0, len(bands) - 1, min(n, len(bands))).round().astype(int))
    return [bands[i] for i in idx]


def dual_dark_levels(dual, sources, bands, given: DarkLevels, samples, valid, progress):
    """Both instruments' dark levels: given, else the product's dark reference or the
    header's for ``bands`` (VNIR, SWIR: the 1-based file bands the levels are wanted for),
    else the dark object of ``samples`` ("vnir"/"swir": the DN of the sampled pixels in
    each instrument's sampled bands (n_bands, n_pixels)). A level below the darkest sampled pixel or above the signal is refused.

    Returns
    -------
    DarkLevels
    """
    v_src, s_src = sources
    sensors = {"vnir": (dual.vnir, v_src, bands[0]), "swir": (dual.swir, s_src, bands[1])}
    recorded = recorded_dark_levels(sensors, given)
    found = find_dark_levels(given, recorded, samples, valid)
    for detector, (sensor, _, _) in sensors.items():
        progress.info(found.describe(detector, sensor.name))
    for detector, (sensor, _, _) in sensors.items():
        name = f"{sensor.name} {sensor.path}"
        check_sample(samples[detector], valid, found, detector, name=name)
    return found


def saturation_value(src) -> float | None:
    """The value a saturated element reads: the integer data type's largest; None for floats."""
    dtype = np.dtype(src.dtypes[0])
    return float(np.iinfo(dtype).max) if dtype.kind in "iu" else None


def sensor_dark_levels(sensor, detector, bands, given: DarkLevels, sample, progress):
    """One instrument's dark level for each of ``bands`` (1-based file bands), for a detector
    that needs it only when nothing else gives it: given, the product's dark reference or the
    header, else the dark object of ``sample()`` (n_bands, n_pixels), drawn only then."""
    with io.open_raster(sensor.reads, sensor.name) as src:
        recorded = recorded_dark_levels({detector: (sensor, src, bands)}, given)
    samples, valid = {}, None
    if given.level(detector) is None and recorded.level(detector) is None:
        values, valid = sample()
        samples[detector] = values
    found = find_dark_levels(given, recorded, samples, valid)
    progress.info(found.describe(detector, sensor.name))
    return found.per_band(detector, bands)
