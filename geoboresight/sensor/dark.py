"""The dark levels of the two instruments (DN of zero signal): one value, :class:`DarkLevels`,
for what the user gives (an operation's parameter group) and what is found (given, a sensor
product's dark reference, the ENVI header, or estimated from the data by dark-object
subtraction, :func:`dark_object`), and the one rule that chooses between them
(:func:`find_dark_levels`).
"""

from __future__ import annotations

import dataclasses
import numbers
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError, ParameterError

#: The detectors, as the fields of :class:`DarkLevels` name them.
DETECTORS = ("vnir", "swir")
#: Darkest share of the pixels taken as the dark object of an instrument.
DARK_FRACTION = 5e-4
#: Fewest pixels averaged into the dark object.
MIN_DARK_PIXELS = 20
#: Where an estimated level comes from.
ESTIMATED = "estimated (dark object)"


@dataclass(frozen=True)
class DarkLevels:
    """The dark levels (DN of zero signal) of the VNIR and the SWIR instrument: for each, one
    level or one per band, and where it comes from.

    What the user gives is one level per instrument (``vnir_dark``, ``swir_dark``; source
    "given"); None = from the sensor product's dark reference or the header, else estimated
    from the data. Give 0 for radiance. What is found (:func:`find_dark_levels`) is the same
    value with every level set.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.DarkLevels()  # each instrument's dark level found on the scene
    DarkLevels(vnir_dark=None, swir_dark=None, vnir_source='given', swir_source='given')
    >>> gb.DarkLevels(vnir_dark=190, swir_dark=800)  # --vnir-dark 190 --swir-dark 800
    DarkLevels(vnir_dark=190, swir_dark=800, vnir_source='given', swir_source='given')
    """

    vnir_dark: float | None = None
    swir_dark: float | None = None
    #: "given", "estimated (dark object)", "header of PATH", or a product's dark source.
    vnir_source: str = "given"
    swir_source: str = "given"
    #: One level per band, in the order of the bands they were found for: from a header or a
    #: product's dark reference (``*_pixels`` 0: subtracted band by band), or the dark
    #: object's band means (``*_pixels`` its size: the level is the dimmest of them,
    #: subtracted from every band).
    vnir_bands: np.ndarray | None = field(default=None, repr=False)
    swir_bands: np.ndarray | None = field(default=None, repr=False)
    vnir_pixels: int = field(default=0, repr=False)
    swir_pixels: int = field(default=0, repr=False)

    def level(self, detector: str) -> float | None:
        """The detector's one level (the mean over the bands when per band)."""
        return getattr(self, f"{detector}_dark")

    def source(self, detector: str) -> str:
        return getattr(self, f"{detector}_source")

    def param(self, detector: str) -> str:
        """The parameter the user gave the level in ("vnir_dark"), named by the messages;
        "" when it was found."""
        return f"{detector}_dark" if self.source(detector) == "given" else ""

    def band_levels(self, detector: str) -> np.ndarray | None:
        return getattr(self, f"{detector}_bands")

    def levels(self, detector: str) -> np.ndarray:
        """The level, or every band's (a file's levels, or the dark object's band means): what
        a sample's values are checked against."""
        bands = self.band_levels(detector)
        return np.asarray(self.level(detector) if bands is None else bands, float)

    def for_bands(self, detector: str, bands: Sequence[int], wanted: Sequence[int]):
        """The level to subtract from the ``wanted`` bands, the levels being found for
        ``bands``: one per band when measured per band (a header or a product's dark
        reference: ``*_pixels`` 0), else the one level (given, or the dark object's dimmest
        band)."""
        levels = self.band_levels(detector)
        if levels is not None and getattr(self, f"{detector}_pixels") == 0:
            bands = list(bands)
            return np.asarray(levels)[[bands.index(b) for b in wanted]]
        return self.level(detector)

    def per_band(self, detector: str, bands: Sequence[int]) -> np.ndarray:
        """The level of each of ``bands``, the levels being found for them (one per band when
        measured per band, else the one level repeated)."""
        level = np.asarray(self.for_bands(detector, bands, bands), float)
        return np.broadcast_to(level, (len(bands),)).astype(float)

    def describe(self, detector: str, name: str) -> str:
        return describe_level(
            name,
            self.level(detector),
            self.source(detector),
            self.band_levels(detector),
            getattr(self, f"{detector}_pixels"),
        )

    def with_level(self, detector, level, source, bands=None, pixels=0) -> DarkLevels:
        """This value with one detector's level replaced."""
        return dataclasses.replace(
            self,
            **{
                f"{detector}_dark": level,
                f"{detector}_source": source,
                f"{detector}_bands": bands,
                f"{detector}_pixels": pixels,
            },
        )


def describe_level(name, level, source, band_levels=None, n_pixels=0) -> str:
    """One line on a level and where it comes from, for the log."""
    if band_levels is None:
        return f"{name} dark level {level:.1f} DN ({source})"
    if n_pixels == 0:  # per band from a header or a product's dark reference
        return (
            f"{name} dark level {level:.1f} DN ({source}; per band "
            f"{np.min(band_levels):.1f}–{np.max(band_levels):.1f} DN)"
        )
    return (
        f"{name} dark level {level:.1f} DN ({source}: the {n_pixels} darkest "
        f"pixels, dimmest band; their band means span {np.min(band_levels):.1f}–"
        f"{np.max(band_levels):.1f} DN)"
    )


def dark_object(
    bands: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    fraction: float = DARK_FRACTION,
    min_pixels: int = MIN_DARK_PIXELS,
) -> tuple[np.ndarray, int]:
    """The dark object of an instrument's data (dark-object subtraction): its band means, the
    lowest of which is the instrument's dark level.

    Parameters
    ----------
    bands : array (n_bands, n_pixels)
        DN of a sample of pixels in several bands of one instrument (the more bands, and the
        darker the dimmest of them, the closer the estimate).
    valid : bool array (n_pixels,), optional
        Pixels to use; pixels with a non-finite value are always left out.
    fraction : float
        Share (0–0.5) of the pixels, the darkest by their mean over ``bands``, that form the
        dark object.
    min_pixels : int
        Fewest pixels in the dark object (noise averages out over them).

    Returns
    -------
    band_means : array (n_bands,)
        The dark object's mean DN in each band. Their lowest is the level: an upper bound of
        the true offset by the dark object's own signal in its dimmest band (deep shadow or
        water, a few DN): it also removes the path radiance there.
    n_pixels : int
        The dark object's size.

    Raises
    ------
    InputError
        When fewer than ``min_pixels`` pixels are valid.

    References
    ----------
    Chavez, P.S. An improved dark-object subtraction technique for atmospheric scattering
    correction of multispectral data. Remote Sens. Environ. 1988, 24, 459–479.
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1: the ratio of raw DN whose offsets this removes).
    """
    x = np.asarray(bands, np.float64)
    if x.ndim != 2:
        raise InputError(f"dark level: bands must be (n_bands, n_pixels), got shape {x.shape}")
    if not (0 < fraction <= 0.5):
        raise ParameterError(f"parameter 'dark_fraction': {fraction} is not in (0, 0.5]")
    ok = np.isfinite(x).all(axis=0)
    if valid is not None:
        ok &= np.asarray(valid, bool).ravel()
    x = x[:, ok]
    if x.shape[1] < min_pixels:
        raise InputError(
            f"only {x.shape[1]} valid pixels to estimate the dark level (need {min_pixels}): "
            "check the nodata value, or give the dark level"
        )
    n = max(int(min_pixels), int(round(fraction * x.shape[1])))
    darkest = np.argsort(x.mean(axis=0), kind="stable")[:n]
    return x[:, darkest].mean(axis=1), n


def given_level(given, param: str) -> float | None:
    """The user's level as a float (None when not given); anything but a finite number is
    refused naming ``param``."""
    if given is None:
        return None
    if not (
        isinstance(given, numbers.Real)
        and not isinstance(given, bool)
        and np.isfinite(float(given))
    ):
        raise ParameterError(f"parameter '{param}': {given!r} is not a number", params=(param,))
    return float(given)


def find_dark_levels(
    given: DarkLevels,
    recorded: DarkLevels,
    samples: Mapping[str, np.ndarray],
    valid: np.ndarray | None = None,
) -> DarkLevels:
    """Each instrument's dark level, in this order: ``given`` by the user, else what its
    files record (``recorded``: the sensor product's dark reference, else the ENVI header's
    'dark level'), else the dark object of its sample (:func:`dark_object`).

    Parameters
    ----------
    given : DarkLevels
        The user's levels (None: not given).
    recorded : DarkLevels
        The files' levels (:func:`geoboresight.io.dark.recorded_dark_levels`; None: none
        recorded).
    samples : mapping
        Per detector ("vnir", "swir") left to estimate: the DN of its sampled pixels
        (n_bands, n_pixels).
    valid : bool array (n_pixels,), optional

    Returns
    -------
    DarkLevels
        Every detector of ``samples`` and every one given or recorded with its level.
    """
    found = DarkLevels()
    for d in DETECTORS:
        level = given_level(given.level(d), f"{d}_dark")
        if level is not None:
            found = found.with_level(d, level, "given")
        elif recorded.level(d) is not None:
            found = found.with_level(
                d, recorded.level(d), recorded.source(d), getattr(recorded, f"{d}_bands")
            )
        elif d in samples:
            means, n = dark_object(samples[d], valid)
            found = found.with_level(d, float(means.min()), ESTIMATED, means, n)
    return found
