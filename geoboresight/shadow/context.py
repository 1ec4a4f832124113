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
a dim blue band does not decide alone.

The long SWIR adds a test that does not depend on the material's brightness
(:func:`swir_tilt`). The sky's share of the irradiance falls with wavelength (Rayleigh and
aerosol scattering), so a shadow is darker, against the sunlit ground, at 2.0–2.3 µm than at
1.55–1.75 µm: ``ln(long / its sunlit level) − ln(swir / its sunlit level)`` is −0.5 to −1
in a shadow. A sunlit material has there the tilt of its own reflectance against the sunlit
ground's; vegetation (leaf water) and soil (clay, water) are darker at 2.2 µm than at
1.65 µm, while man-made dark materials and char are flat or rising, so a sunlit dark
material's tilt is about 0 or above. A dark pixel is therefore also a sunlit dark material
when

3. its tilt, averaged over the dark pixels of a :data:`TILT_WINDOW` neighbourhood (the long
   SWIR of a shadow holds a few DN), is at least :data:`SWIR_TILT`, and its blue is at
   least ``exp(limit − TILT_BLUE_MARGIN)`` times the sunlit blue (0.6 of it with the
   default limit): a shadow's blue is mostly below that, so a shadow whose long SWIR the
   noise lifts stays shadow.

The limit trades shadow recall against dark false alarms: lower flags fewer dark materials
and misses more shadow on blue-bright ground. A material dark in the blue too (char,
reflectance ≤ 5 % everywhere) is declined only by its tilt, where its blue reaches the lower
limit of test 3.

References
----------
Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens. 2005,
26, 3137–3148 (skylight in shadow: its share of the irradiance by wavelength).
Gueymard, C.A. SMARTS2, a simple model of the atmospheric radiative transfer of sunshine.
Florida Solar Energy Center, 1995 (the diffuse share of the irradiance falling with
wavelength through the SWIR).
Clark, R.N. et al. USGS Spectral Library Version 7. USGS Data Series 1035, 2017 (vegetation's
and soils' reflectance lower at 2.2 µm than at 1.65 µm; asphalt, roofing and char flat).
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
#: Smallest signal (DN) whose log is taken.
MIN_SIGNAL = 0.5
#: Wavelength range (nm) of the long-SWIR signal: 2.0–2.3 µm between the water-vapour bands.
LONG_SWIR_NM = (2030.0, 2250.0)
#: Least tilt (natural log) of a sunlit dark material: long SWIR over SWIR against the sunlit
#: ground's. A shadow's is the sky's (−0.5 to −1); a flat or rising material's, 0 or above.
SWIR_TILT = -0.15
#: Side of the neighbourhood whose dark pixels' SWIR signals the tilt is taken on.
TILT_WINDOW = 5
#: Test 3's blue limit is this much (natural log) below ``limit``.
TILT_BLUE_MARGIN = 0.2
#: Lines of halo the tests need above and below a strip.
HALO = max(BLUE_WINDOW, TILT_WINDOW) // 2


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


def sunlit_tilt_level(swir: np.ndarray, long_swir: np.ndarray, lit: np.ndarray) -> float:
    """The scene's sunlit tilt: the median of ``ln(long_swir / swir)`` over the ``lit``
    pixels (not dark enough for core shadow); NaN when there are none."""
    lit = np.asarray(lit, bool)
    s = np.asarray(swir, np.float64)[lit]
    g = np.asarray(long_swir, np.float64)[lit]
    ok = np.isfinite(s) & np.isfinite(g)
    if not ok.any():
        return math.nan
    return float(np.median(np.log(np.maximum(g[ok], MIN_SIGNAL) / np.maximum(s[ok], MIN_SIGNAL))))


def swir_tilt(swir: np.ndarray, long_swir: np.ndarray, dark: np.ndarray, level: float):
    """The tilt of each pixel: ``ln(long_swir / swir)`` over the sunlit ground's (``level``,
    :func:`sunlit_tilt_level`), both signals averaged over the ``dark`` pixels of its
    :data:`TILT_WINDOW` neighbourhood (NaN where there are none)."""
    g = local_mean(long_swir, dark, TILT_WINDOW)
    s = local_mean(swir, dark, TILT_WINDOW)
    with np.errstate(invalid="ignore"):
        return np.log(np.maximum(g, MIN_SIGNAL)) - np.log(np.maximum(s, MIN_SIGNAL)) - level


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
    swir: np.ndarray | None = None,
    long_swir: np.ndarray | None = None,
) -> np.ndarray:
    """Pixels dark enough for core shadow whose blue or long SWIR says they are in the sun.

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
    levels : (float, float) or (float, float, float)
        The scene's sunlit levels of ``ln(blue)`` and ``ln(blue / NIR)``
        (:func:`sunlit_blue_levels`; NaN: no test), and of ``ln(long_swir / swir)``
        (:func:`sunlit_tilt_level`; NaN or left out: no tilt test).
    limit : float
        A dark pixel whose blue, averaged over the dark pixels of its :data:`BLUE_WINDOW`
        neighbourhood, is at least ``exp(limit)`` times the sunlit blue (default
        :data:`SKY_BLUE`), and whose blue/NIR (averaged so) is at least
        ``exp(BLUE_NIR_RISE)`` times the sunlit ground's, is a sunlit dark material; so is one
        whose blue is at least ``exp(limit − TILT_BLUE_MARGIN)`` times the sunlit blue and
        whose tilt (:func:`swir_tilt`) is at least :data:`SWIR_TILT`. A strip needs
        :data:`HALO` lines of halo.
    swir, long_swir : arrays (lines, columns), optional
        SWIR (:data:`~geoboresight.shadow.darkness.SWIR_NM`) and long-SWIR
        (:data:`LONG_SWIR_NM`) signals on the blue's grid, for the tilt test.

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
    blue_level, balance, *tilt = levels
    if not (math.isfinite(blue_level) and math.isfinite(balance)) or not candidate.any():
        return np.zeros(d.shape, bool)
    own = np.log(np.maximum(local_mean(blue, candidate, BLUE_WINDOW), MIN_SIGNAL)) - blue_level
    own_nir = np.log(np.maximum(local_mean(nir, candidate, BLUE_WINDOW), MIN_SIGNAL))
    with np.errstate(invalid="ignore"):
        sunlit = (own >= limit) & (own + blue_level - own_nir - balance >= BLUE_NIR_RISE)
    if tilt and math.isfinite(tilt[0]) and swir is not None and long_swir is not None:
        t = swir_tilt(swir, long_swir, candidate, tilt[0])
        with np.errstate(invalid="ignore"):
            sunlit |= (own >= limit - TILT_BLUE_MARGIN) & (t >= SWIR_TILT)
    return candidate & sunlit


def local_mean(x: np.ndarray, weight: np.ndarray, size: int) -> np.ndarray:
    """Mean of ``x`` over the ``weight`` pixels of each ``size × size`` neighbourhood (NaN
    where there are none; the grid's edge repeated beyond it)."""
    from scipy import ndimage

    num = ndimage.uniform_filter(np.where(weight, x, 0.0), size, mode="nearest")
    den = ndimage.uniform_filter(weight.astype(np.float64), size, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 1e-9, num / den, np.nan)
