"""The sky-light test of dark pixels: is a dark pixel in shadow, or a sunlit dark material?

Without a surface model the spectral map (:mod:`geoboresight.shadow.darkness`) calls a pixel
core shadow when its near-infrared and SWIR signals are both far below the scene's sunlit
modes. A sunlit dark material (a fresh parking lot, a dark roof, burnt ground) can be as dark
there. The blue separates them:

* a shadow is lit by the sky alone. Even the blue sky gives a shadow only a fifth to a half of
  the blue irradiance in the sun (the rest is the direct beam), so a shadow's blue signal is
  well below the blue of the sunlit ground around it;
* most sunlit materials reflect little blue (soil, vegetation, roofs: 3–10 %), and a dark
  material's reflectance is flat: its blue is about that of the scene's sunlit ground. In the
  sun a dark material keeps its blue while its near infrared and SWIR are dark.

So a pixel dark enough for core shadow is a sunlit dark material, not shadow
(:func:`sunlit_dark`), when

1. its blue signal is at least ``exp(limit)`` times the scene's sunlit blue level
   (:data:`SKY_BLUE`: three quarters of it), and
2. its blue/NIR balance is at least ``exp(BLUE_NIR_RISE)`` (about 2.5) times the median of
   the scene's sunlit pixels: the flat spectrum of a dark material against NIR-bright
   vegetation and soil. A shadow raises its ground's balance by the sky's blue/NIR (about 2
   under a bright hazy or low-sun sky, up to 5 under a clear one), so a shadow on ground like
   the scene's, whose blue a bright sky keeps near the sunlit level, stays shadow.

Both are averaged over the pixel's dark neighbours (:data:`BLUE_WINDOW`), so that noise in
a dim blue band does not decide alone. The limit trades shadow recall against dark false
alarms: lower flags fewer dark materials and misses more shadow on blue-bright ground. A
material dark in the blue too (char) stays shadow-like: only geometry tells it apart.

References
----------
Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens. 2005,
26, 3137–3148 (skylight in shadow: its share of the irradiance by wavelength).
Adeline, K.R.M.; Chen, M.; Briottet, X.; Pang, S.K.; Paparoditis, N. Shadow detection in very
high spatial resolution aerial images: a comparative study. ISPRS J. Photogramm. Remote Sens.
2013, 80, 21–38 (shadow against dark surfaces).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ParameterError

#: Default limit (natural log of the blue signal over the scene's sunlit blue level) at or
#: above which a pixel dark in the near infrared and SWIR can be a sunlit dark material.
SKY_BLUE = -0.3
#: Least rise of ln(blue / NIR) over the scene's sunlit ground's for a sunlit dark material.
BLUE_NIR_RISE = 0.9
#: Side of the neighbourhood whose dark pixels' blue signals are averaged.
BLUE_WINDOW = 3
#: Lines of halo the test needs above and below a strip.
HALO = BLUE_WINDOW // 2
#: Smallest signal (DN) whose log is taken.
MIN_SIGNAL = 0.5


def sunlit_blue_levels(blue: np.ndarray, nir: np.ndarray, lit: np.ndarray) -> tuple:
    """The scene's sunlit levels: the medians of ``ln(blue)`` and of ``ln(blue / NIR)`` over
    the ``lit`` pixels (not dark enough for core shadow); NaN when there are none."""
    lit = np.asarray(lit, bool)
    b = np.asarray(blue, np.float64)[lit]
    n = np.asarray(nir, np.float64)[lit]
    ok = np.isfinite(b) & np.isfinite(n)
    if not ok.any():
        return math.nan, math.nan
    lb = np.log(np.maximum(b[ok], MIN_SIGNAL))
    return float(np.median(lb)), float(np.median(lb - np.log(np.maximum(n[ok], MIN_SIGNAL))))


def check_limit(limit: float) -> float:
    """``limit`` as a float, or a :class:`~geoboresight.errors.ParameterError`."""
    try:
        value = float(limit)
    except (TypeError, ValueError):
        value = math.nan
    if not math.isfinite(value):
        raise ParameterError(
            f"parameter 'sky_blue': {limit!r} must be a finite number (natural log of the "
            "blue signal over the scene's sunlit blue; 0 = as bright as the sunlit blue)"
        )
    return value


def sunlit_dark(
    blue: np.ndarray,
    nir: np.ndarray,
    dark: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    core: float,
    levels: tuple,
    limit: float = SKY_BLUE,
) -> np.ndarray:
    """Pixels dark enough for core shadow whose blue says they are in the sun.

    Parameters
    ----------
    blue, nir : arrays (lines, columns)
        Blue and NIR signals (DN above the dark level).
    dark : array (lines, columns)
        The darkness of the near infrared and SWIR
        (:func:`geoboresight.shadow.darkness.darkness`): core shadow at or below ``core``.
    valid : bool array, optional
    core : float
        Core-shadow darkness (natural log, < 0).
    levels : (float, float)
        The scene's sunlit levels of ``ln(blue)`` and ``ln(blue / NIR)``
        (:func:`sunlit_blue_levels`); NaN: no test.
    limit : float
        A dark pixel whose blue, averaged over the dark pixels of its :data:`BLUE_WINDOW`
        neighbourhood, is at least ``exp(limit)`` times the sunlit blue (default
        :data:`SKY_BLUE`), and whose blue/NIR (averaged so) is at least
        ``exp(BLUE_NIR_RISE)`` times the sunlit ground's, is a sunlit dark material. A strip
        needs :data:`HALO` lines of halo.

    Returns
    -------
    bool array
        The dark pixels that are not shadow.

    References
    ----------
    Richter, R.; Müller, A. Int. J. Remote Sens. 2005, 26, 3137–3148.
    """
    limit = check_limit(limit)
    d = np.asarray(dark, np.float64)
    ok = np.isfinite(d) & np.isfinite(blue) & np.isfinite(nir)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    with np.errstate(invalid="ignore"):
        candidate = ok & (d <= core)
    blue_level, balance = levels
    if not (math.isfinite(blue_level) and math.isfinite(balance)) or not candidate.any():
        return np.zeros(d.shape, bool)
    own = np.log(np.maximum(_mean(blue, candidate, BLUE_WINDOW), MIN_SIGNAL))
    own_nir = np.log(np.maximum(_mean(nir, candidate, BLUE_WINDOW), MIN_SIGNAL))
    with np.errstate(invalid="ignore"):
        sunlit = (own - blue_level >= limit) & (own - own_nir - balance >= BLUE_NIR_RISE)
    return candidate & sunlit


def _mean(x, weight, size):
    """Mean of ``x`` over the ``weight`` pixels of each ``size × size`` neighbourhood (NaN
    where there are none)."""
    from scipy import ndimage

    num = ndimage.uniform_filter(np.where(weight, x, 0.0), size, mode="nearest")
    den = ndimage.uniform_filter(weight.astype(np.float64), size, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 1e-9, num / den, np.nan)
