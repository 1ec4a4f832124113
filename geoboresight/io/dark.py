"""The dark level of each instrument of a dual-sensor dataset (DN of zero signal), found in one
place: given by the user, else the sensor product's dark reference, else the ENVI header's
'dark level'; when none of them says it, the shadow map estimates it from the data
(:func:`geoboresight.shadow.map.dark_level`, dark-object subtraction).
"""

from __future__ import annotations

import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError, ParameterError
from .dual import SensorFile

if TYPE_CHECKING:
    from ..shadow.map import DarkLevel
from .wavelengths import parse_list


@dataclass(frozen=True)
class DarkLevels:
    """The dark levels the user gives (DN of zero signal) of the VNIR and the SWIR instrument;
    None = from the sensor product's dark reference or the header, else estimated from the
    data. Give 0 for radiance.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.DarkLevels()  # each instrument's dark level found on the scene
    DarkLevels(vnir_dark=None, swir_dark=None)
    >>> gb.DarkLevels(vnir_dark=190, swir_dark=800)  # --vnir-dark 190 --swir-dark 800
    DarkLevels(vnir_dark=190, swir_dark=800)
    """

    vnir_dark: float | None = None
    swir_dark: float | None = None


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


def dark_level_of(
    sensor: SensorFile,
    bands: Sequence[int],
    header: Mapping[str, str],
    n_bands: int,
    given: float | None = None,
) -> DarkLevel | None:
    """The dark level of one instrument, in this order: ``given`` by the user, the sensor
    product's dark reference (:func:`product_dark`), the ENVI header's 'dark level'
    (:func:`header_dark`); None when none says it (the caller estimates it from the data).

    Parameters
    ----------
    sensor : SensorFile
        The instrument (``dual.vnir`` or ``dual.swir``): its ``dark`` and ``dark_source``.
    bands : sequence of int
        The 1-based bands of the file the level is wanted for (the shadow map's sampled bands).
    header : mapping
        The file's ENVI-domain tags.
    n_bands : int
        The file's band count.
    given : float, optional
        The user's level (``DarkLevels.vnir_dark`` or ``swir_dark``).

    Returns
    -------
    DarkLevel or None
        ``level`` (the mean over ``bands`` for per-band levels), ``source`` ("given", the
        product's dark source, "header of PATH") and, for per-band levels, ``band_levels`` in
        the order of ``bands`` with ``n_pixels`` 0.
    """
    from ..shadow.map import DarkLevel

    if given is not None:
        if not (
            isinstance(given, numbers.Real)
            and not isinstance(given, bool)
            and np.isfinite(float(given))
        ):
            raise ParameterError(
                f"parameter '{sensor.name.lower()}_dark': {given!r} is not a number",
                params=(f"{sensor.name.lower()}_dark",),
            )
        return DarkLevel(float(given), "given", param=f"{sensor.name.lower()}_dark")
    levels = product_dark(sensor, bands)
    source = sensor.dark_source or "product"
    if levels is None:
        levels = header_dark(header, bands, n_bands, sensor.path)
        source = f"header of {sensor.path}"
    if levels is None:
        return None
    if np.ndim(levels) == 0:
        return DarkLevel(float(levels), source)
    return DarkLevel(float(levels.mean()), source, levels, 0)
