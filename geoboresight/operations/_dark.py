"""Each instrument's dark level (DN of zero signal) for an operation: given by the user, the
sensor product's dark reference or the ENVI header's (:func:`geoboresight.io.dark.dark_level_of`),
else estimated from a sample of the data by dark-object subtraction
(:func:`geoboresight.shadow.darkness.dark_level`)."""

from __future__ import annotations

import numpy as np

from .. import io
from ..io.dark import dark_level_of
from ..sensor.dark import DarkLevel
from ..shadow.darkness import check_sample, dark_level

#: Bands per instrument read for the dark level besides the signal bands (evenly spaced).
DARK_BANDS = 16


def spread_bands(bands: tuple[int, ...], n: int) -> list[int]:
    """At most ``n`` of ``bands``, evenly spaced over them (the first and last included)."""
    idx = np.unique(np.linspace(0, len(bands) - 1, min(n, len(bands))).round().astype(int))
    return [bands[i] for i in idx]


def instrument_dark_level(sensor, src, bands, given, sample, valid, progress) -> DarkLevel:
    """One instrument's dark level: ``given``, the product's dark reference or the header's
    (:func:`geoboresight.io.dark.dark_level_of`), else the dark object of ``sample``
    (n_bands, n_pixels; :func:`geoboresight.shadow.darkness.dark_level`) in ``bands``."""
    level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        level = dark_level(sample, valid)
    progress.info(level.describe(sensor.name))
    return level


def band_dark_levels(sensor, src, bands, sampled, given, sample, valid, progress) -> np.ndarray:
    """The dark level of each of ``bands``: per band from the product or header when it lists
    them, else the one level (given, or the dark object of ``sample`` in the ``sampled``
    bands: :func:`instrument_dark_level`)."""
    level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        level = instrument_dark_level(sensor, src, sampled, given, sample, valid, progress)
    else:
        progress.info(level.describe(sensor.name))
    # A level below the darkest pixel or above the signal is refused as shadow-map refuses it.
    check_sample(sample, valid, level, name=f"{sensor.name} {sensor.path}")
    if level.band_levels is None:
        return np.full(len(bands), level.level)
    return np.broadcast_to(level.for_bands(bands, bands), (len(bands),)).astype(float)


def saturation_value(src) -> float | None:
    """The value a saturated element reads: the integer data type's largest; None for floats."""
    dtype = np.dtype(src.dtypes[0])
    return float(np.iinfo(dtype).max) if dtype.kind in "iu" else None


def sensor_dark_levels(sensor, bands, given, sample, progress):
    """One instrument's dark level for ``bands`` (1-based file bands), for a detector that
    needs it only when nothing else gives it: given, the product's dark reference or the
    header (:func:`geoboresight.io.dark.dark_level_of`, as :func:`instrument_dark_level`), else the dark
    object of ``sample()`` (n_bands, n_pixels), drawn only then. Returns (level per band,
    :class:`~geoboresight.sensor.dark.DarkLevel`)."""
    with io.open_raster(sensor.reads, sensor.name) as src:
        level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        values, ok = sample()
        level = dark_level(values, ok)
    progress.info(level.describe(sensor.name))
    return np.broadcast_to(np.asarray(level.for_bands(bands, bands), float), (len(bands),)), level
