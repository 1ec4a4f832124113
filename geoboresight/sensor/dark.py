"""The dark levels of the two instruments (DN of zero signal): what the user gives for both
(:class:`DarkLevels`, an operation's parameter group) and what was found for one
(:class:`DarkLevel`: given, a sensor product's dark reference, the ENVI header, or estimated
from the data by dark-object subtraction, :func:`geoboresight.shadow.darkness.dark_level`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


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


@dataclass(frozen=True)
class DarkLevel:
    """The DN of zero signal of one instrument and how it was found."""

    level: float
    source: str  # "estimated (dark object)", "given", "header of PATH", a product's dark source
    #: The dark object's mean DN per band (estimated, ``n_pixels`` > 0), or the level of each
    #: band from a header or a product's dark reference (``n_pixels`` 0).
    band_levels: np.ndarray | None = None
    n_pixels: int = 0
    #: The parameter the user gave the level in ("vnir_dark"), named by the messages; "" if none.
    param: str = ""

    def describe(self, name: str) -> str:
        if self.band_levels is None:
            return f"{name} dark level {self.level:.1f} DN ({self.source})"
        if self.n_pixels == 0:  # per band from a header or a product's dark reference
            return (
                f"{name} dark level {self.level:.1f} DN ({self.source}; per band "
                f"{np.min(self.band_levels):.1f}–{np.max(self.band_levels):.1f} DN)"
            )
        return (
            f"{name} dark level {self.level:.1f} DN ({self.source}: the {self.n_pixels} darkest "
            f"pixels, dimmest band; their band means span {np.min(self.band_levels):.1f}–"
            f"{np.max(self.band_levels):.1f} DN)"
        )

    def for_bands(self, bands, wanted):
        """The level to subtract from the ``wanted`` bands, ``band_levels`` being those of
        ``bands``: one per band when measured per band (a header or a product's dark
        reference: ``n_pixels`` 0), else the one level (given, or the dark object's dimmest
        band)."""
        if self.band_levels is not None and self.n_pixels == 0:
            bands = list(bands)
            return np.asarray(self.band_levels)[[bands.index(b) for b in wanted]]
        return self.level
