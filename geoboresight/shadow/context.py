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

So a pixel dark enough for core shadow whose blue signal is at least the scene's sunlit blue
level times ``exp(limit)`` (:data:`SKY_BLUE`: at least the sunlit blue) is a sunlit dark
material, not shadow (:func:`sunlit_dark`). The blue is averaged over the pixel's dark
neighbours (:data:`BLUE_WINDOW`), so that noise in a dim blue band does not decide alone. The
limit trades shadow recall against dark false alarms: lower flags fewer dark materials and
misses more shadow on blue-reflecting surfaces (a shadow on bright soil can keep the blue of
the scene's sunlit grass).

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
#: above which a pixel dark in the near infrared and SWIR is a sunlit dark material.
SKY_BLUE = 0.0
#: Side of the neighbourhood whose dark pixels' blue signals are averaged.
BLUE_WINDOW = 3
#: Lines of halo the test needs above and below a strip.
HALO = BLUE_WINDOW // 2
#: Smallest signal (DN) whose log is taken.
MIN_SIGNAL = 0.5


def sunlit_blue_level(blue: np.ndarray, lit: np.ndarray) -> float:
    """The scene's sunlit blue level: the median of ``ln(blue)`` over the ``lit`` pixels (not
    dark enough for core shadow); NaN when there are none."""
    b = np.asarray(blue, np.float64)[np.asarray(lit, bool)]
    b = b[np.isfinite(b)]
    if b.size == 0:
        return math.nan
    return float(np.median(np.log(np.maximum(b, MIN_SIGNAL))))


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
    dark: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    core: float,
    blue_level: float,
    limit: float = SKY_BLUE,
) -> np.ndarray:
    """Pixels dark enough for core shadow whose blue says they are in the sun.

    Parameters
    ----------
    blue : array (lines, columns)
        Blue signal (DN above the dark level).
    dark : array (lines, columns)
        The darkness of the near infrared and SWIR
        (:func:`geoboresight.shadow.darkness.darkness`): core shadow at or below ``core``.
    valid : bool array, optional
    core : float
        Core-shadow darkness (natural log, < 0).
    blue_level : float
        The scene's sunlit blue level (:func:`sunlit_blue_level`, natural log); NaN: no test.
    limit : float
        A dark pixel whose blue, averaged over the dark pixels of its :data:`BLUE_WINDOW`
        neighbourhood, is at least ``exp(limit)`` times the sunlit blue (default
        :data:`SKY_BLUE`) is a sunlit dark material. A strip needs :data:`HALO` lines of
        halo.

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
    ok = np.isfinite(d) & np.isfinite(blue)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    with np.errstate(invalid="ignore"):
        candidate = ok & (d <= core)
    if not math.isfinite(blue_level) or not candidate.any():
        return np.zeros(d.shape, bool)
    own = np.log(np.maximum(_mean(blue, candidate, BLUE_WINDOW), MIN_SIGNAL))
    with np.errstate(invalid="ignore"):
        sunlit = own - blue_level >= limit
    return candidate & sunlit


def _mean(x, weight, size):
    """Mean of ``x`` over the ``weight`` pixels of each ``size × size`` neighbourhood (NaN
    where there are none)."""
    from scipy import ndimage

    num = ndimage.uniform_filter(np.where(weight, x, 0.0), size, mode="nearest")
    den = ndimage.uniform_filter(weight.astype(np.float64), size, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 1e-9, num / den, np.nan)
