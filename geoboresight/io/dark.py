"""What the files record of each instrument's dark level (DN of zero signal): the sensor
product's dark reference, else the ENVI header's 'dark level', read into the value of
:mod:`geoboresight.sensor.dark`, which chooses between them, the user's level and the
estimate from the data (:func:`geoboresight.sensor.dark.find_dark_levels`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from ..errors import InputError
from ..sensor.dark import DarkLevels
from .dual import SensorFile
from .wavelengths import parse_list


def header_dark(
    header: Mapping[str, str], bands: Sequence[int], n_bands: int, path: str
) -> float | np.ndarray | None:
    """The 'dark level' of an ENVI header: one value, or the values of ``bands`` (1-based
    band numbers of the file) when it lists one per band; None when the header has none.

    Parameters
    ----------
    header : mapping
        The file's ENVI-domain tags (``src.tags(ns="ENVI")``).
    bands : sequence of int
        The bands whose levels are wanted.
    n_bands : int
        The file's band count (a per-band list must hold one value per band).
    path : str
        The file, for messages.
    """
    text = header.get("dark_level")
    if not text:
        return None
    values = parse_list(text, f"{path}: ENVI header 'dark level'")
    if values.size == 1:
        return float(values[0])
    if values.size != n_bands:
        raise InputError(
            f"{path}: its header's 'dark level' lists {values.size} values for {n_bands} "
            "bands; give one value, or one per band"
        )
    return values[[b - 1 for b in bands]]


def product_dark(sensor: SensorFile, bands: Sequence[int]) -> np.ndarray | None:
    """The sensor product's dark reference (:attr:`SensorFile.dark`: Specim dark frames or
    DARKREF file, HySpex background matrix; per band and column) as one level per band of
    ``bands``: the mean over the columns, since the shadow map subtracts one level per band
    from pixels of every column. Non-finite columns (not image) are left out; None when the
    sensor carries no dark reference, or a band has no finite column."""
    if sensor.dark is None:
        return None
    dark = np.asarray(sensor.dark, np.float64)[[sensor.bands.index(b) for b in bands]]
    dark = dark.reshape(len(bands), -1)
    count = np.isfinite(dark).sum(axis=1)
    if (count == 0).any():
        return None
    return np.where(np.isfinite(dark), dark, 0.0).sum(axis=1) / count


def recorded_dark(sensor: SensorFile, src, bands: Sequence[int]):
    """What one instrument's files record of its dark level for ``bands`` (1-based band
    numbers of the file): the sensor product's dark reference (:func:`product_dark`), else the
    ENVI header's 'dark level' (:func:`header_dark`) of ``src`` (the open file). Returns
    (level or one per band of ``bands``, source), or None when neither says it."""
    levels = product_dark(sensor, bands)
    source = sensor.dark_source or "product"
    if levels is None:
        levels = header_dark(src.tags(ns="ENVI"), bands, src.count, sensor.path)
        source = f"header of {sensor.path}"
    return None if levels is None else (levels, source)


def recorded_dark_levels(
    sensors: Mapping[str, tuple[SensorFile, object, Sequence[int]]], given: DarkLevels
) -> DarkLevels:
    """The dark levels the files record, for the instruments whose level the user did not
    give (:func:`recorded_dark`: the product's dark reference, else the header's).

    Parameters
    ----------
    sensors : mapping
        Per detector ("vnir", "swir"): (the instrument, ``dual.vnir`` or ``dual.swir``; its
        open file; the bands the level is wanted for).
    given : DarkLevels
        The user's levels: a detector given is not read.

    Returns
    -------
    DarkLevels
        ``*_dark`` the level (the mean over the bands for per-band levels), ``*_source`` the
        product's dark source or "header of PATH", ``*_bands`` the levels of its bands; None where
        the files record nothing.
    """
    found = DarkLevels()
    for detector, (sensor, src, bands) in sensors.items():
        if given.level(detector) is not None:
            continue
        recorded = recorded_dark(sensor, src, bands)
        if recorded is None:
            continue
        levels, source = recorded
        if np.ndim(levels) == 0:
            found = found.with_level(detector, float(levels), source)
        else:
            found = found.with_level(detector, float(levels.mean()), source, levels)
    return found
