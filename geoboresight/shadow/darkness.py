"""A shadow map that separates shadow from dark materials (paper §3.1, made physical).

On raw DN the boresight ratio ``b(1010 nm) / b(920 nm)`` of every dim pixel, shadowed or just
dark, tends to the ratio of the two instruments' dark offsets: no threshold on it separates a
sunlit asphalt road from a shaded lawn. A dual-sensor cube carries what does:

1. **Each instrument's dark level** (:func:`dark_level`): the DN of zero signal, taken from the
   user or the header, or estimated from the data by dark-object subtraction (Chavez 1988):
   the darkest pixels of the instrument (by their mean over its bands), averaged band by band;
   the band in which that dark object is dimmest gives the level. Everything below is computed
   on *signal*, DN minus the level.
2. **The signature of diffuse skylight**: a shadowed pixel is lit by the sky alone. The sky is
   blue (Rayleigh scattering): it gives a shadow a fifth to a third of the sunlit blue signal,
   but only a twentieth to a tenth in the near infrared and a few per cent in the SWIR. Material
   brightness spans a factor of about ten. So a pixel whose near-infrared *and* SWIR signals are
   both at most a fifth of the scene's sunlit mode (:data:`CORE_DARKNESS`) is core shadow, while
   a sunlit dark roof or road (reflectance 5–10 %, flat) stays above it in the SWIR.
3. **The boresight effect itself**: the SWIR sees the ground shifted by the boresight offset
   (:func:`geoboresight.sensor.offset.estimate_offset`); the SWIR signal is resampled onto the
   VNIR grid before it is compared, so that shadow edges line up.
4. **Spatial context**: a pixel next to core shadow (within :data:`EDGE_PIXELS`) is shadow when
   its signal is below the midpoint of its neighbourhood's sunlit and shadowed means (more than
   half of it shaded), which recovers the 50–80 % shadow along edges.

The scene calibrates itself: the sunlit mode of each signal is the median above Otsu's (1979)
threshold of its log-histogram, and the shadow-fraction classes of Table 2 are scaled by the
sunlit mode of the boresight ratio (:func:`~geoboresight.shadow.classes.scale_table`).

References
----------
Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2, Figure 4).
Chavez, P.S. An improved dark-object subtraction technique for atmospheric scattering
correction of multispectral data. Remote Sens. Environ. 1988, 24, 459–479.
Otsu, N. A threshold selection method from gray-level histograms. IEEE Trans. Syst. Man Cybern.
1979, 9, 62–66.
Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens. 2005,
26, 3137–3148 (skylight in shadow, the spectral ratio of shadowed to sunlit pixels).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError
from ..sensor.dark import DarkLevel
from .classes import MASK_NODATA, MASK_NOT_SHADOW, MASK_SHADOW, NO_SHADOW, NODATA_CLASS, ClassTable
from .context import sunlit_blue_levels, sunlit_dark

#: Darkest share of the pixels taken as the dark object of an instrument.
DARK_FRACTION = 5e-4
#: Fewest pixels averaged into the dark object.
MIN_DARK_PIXELS = 20
#: Wavelength ranges (nm) of the blue, near-infrared and SWIR signals.
BLUE_NM = (430.0, 500.0)
NIR_NM = (780.0, 900.0)
SWIR_NM = (1550.0, 1750.0)
#: Core shadow: the SWIR signal at most a sixth of its sunlit mode (ln 1/6). Skylight gives a
#: shadow 3–15 % (with light from sunlit surroundings) of the sunlit SWIR signal, while sunlit
#: dark roofs and asphalt (SWIR reflectance 6–12 %) keep a fifth to a half of the scene's mode.
CORE_DARKNESS = math.log(1 / 6)
#: The NIR may be this factor (as a log) less dark than the SWIR in a shadow: the sky carries
#: about twice as much of the sun's light at 860 nm as at 1,650 nm (Rayleigh + aerosol).
NIR_ALLOWANCE = math.log(2.0)
#: Water test: a core pixel whose blue/NIR signal ratio is more than this many times the 90th
#: percentile of the sunlit pixels' is not shadow. Skylight raises a surface's blue/NIR 2.5–5×
#: over sunlight (Rayleigh sky); clear water's blue/NIR is ≥ 10× that of sunlit grey ground.
WATER_FACTOR = 6.0
#: Partial shadow is looked for this many pixels around the core.
EDGE_PIXELS = 2
#: Side (pixels) of the neighbourhood whose sunlit and shadowed means decide an edge pixel.
EDGE_WINDOW = 5
#: With a surface model (:func:`dsm_shadow_fraction`): a pixel within :data:`DSM_TOLERANCE` of
#: the predicted cast shadow but outside it is shadow when at most a third of the sunlit mode
#: (ln 1/3: looser than the core, since a surface model rules out dark materials elsewhere).
RIM_DARKNESS = math.log(1 / 3)
#: A pixel brighter than half the sunlit mode is spectrally lit, whatever the surface model
#: predicts: sky and adjacency light give a shadow at most about a third of the sunlit signal.
LIT_DARKNESS = math.log(1 / 2)
#: Tiles per side of the block the registration is checked on, and how many standard errors
#: the mean gain in correlation over the tiles must reach for the move to be kept.
TILES = 4
REGISTRATION_T = 2.0
#: How far (px) a cast shadow predicted from a surface model may be off (registration).
DSM_TOLERANCE = 1
#: A cell the surface model shades at least this much is in its predicted shadow: more than
#: half of it shaded, the share at which the shadow mask counts a pixel as shadow.
PREDICTED_SHADOW = 0.5
#: The sunlit ratio of the paper's scenes: Figure 5(B)'s line at shadow fraction 0 (1.31).
PAPER_SUNLIT_RATIO = 1.31
#: Smallest signal (DN above the dark level) used in logarithms.
MIN_SIGNAL = 0.5


def log_fraction_text(darkness: float) -> str:
    """A darkness (natural log of a signal over its sunlit mode) as the provenance gives it:
    ``"ln 1/3"`` for ``log(1/3)``, else the number (``"-0.800"``)."""
    n = 1.0 / math.exp(darkness)
    if abs(n - round(n)) < 1e-9 and round(n) >= 1:
        return f"ln 1/{round(n)}"
    return f"{darkness:.3f}"


@dataclass(frozen=True)
class SampleCheck:
    """What :func:`check_sample` found in one instrument's calibration sample."""

    usable: np.ndarray  # bool (n_pixels,): valid, not saturated
    saturated: int  # sampled pixels with a band at the saturation value
    above_dark: int  # usable pixels with signal above the dark level in their brightest band


def check_sample(
    bands: np.ndarray,
    valid: np.ndarray,
    dark: DarkLevel | None,
    *,
    name: str,
    saturation: float | None = None,
    min_pixels: int = 10,
) -> SampleCheck:
    """Check that a calibration sample carries signal the shadow map can use (§3.1 needs sunlit
    signal above the dark level): refuse a dark level outside the data's range, a saturated or
    signal-less cube, instead of reporting "no shadow".

    Parameters
    ----------
    bands : array (n_bands, n_pixels)
        DN of the sampled pixels in the instrument's bands.
    valid : bool array (n_pixels,)
    dark : DarkLevel, optional
        The dark level the map would subtract; None checks saturation and signal only.
    name : str
        The instrument and file, for the messages (e.g. "VNIR v.img").
    saturation : float, optional
        The value a saturated detector element reads (the integer data type's largest value);
        pixels with any band at it are not used.
    min_pixels : int
        Fewest usable pixels (valid, not saturated, above the dark level) to calibrate.

    Raises
    ------
    InputError
        Naming the instrument and what is wrong: every pixel saturated, no signal at all, a
        dark level below the data or above its signal.
    """
    values = np.asarray(bands, np.float64)
    valid = np.asarray(valid, bool) & np.isfinite(values).all(axis=0)
    n = int(valid.sum())
    saturated = np.zeros(valid.shape, bool)
    if saturation is not None:
        saturated = (values >= saturation).any(axis=0) & valid
    usable = valid & ~saturated
    if n and int(usable.sum()) < min_pixels:
        raise InputError(
            f"{name}: {int(saturated.sum())} of {n} sampled pixels are saturated (a band at "
            f"{saturation:g}): too few usable pixels to calibrate the shadow map; use an "
            "acquisition with a shorter integration time, or mask the saturated lines"
        )
    data = values[:, usable]
    if data.size and float(np.ptp(data)) == 0.0:
        raise InputError(
            f"{name}: every sampled pixel reads {float(data.flat[0]):g} in every band: the cube "
            "holds no signal (an empty or zero-filled file?); check the file"
        )
    if dark is None:
        return SampleCheck(usable, int(saturated.sum()), int(usable.sum()))
    level = np.asarray(dark.level if dark.band_levels is None else dark.band_levels, float)
    low = float(np.nanmin(data)) if data.size else 0.0
    where, params = (f" in '{dark.param}'", (dark.param,)) if dark.param else ("", ())
    if data.size and float(np.min(level)) < low - max(1.0, 0.5 * abs(low)):
        raise InputError(
            f"{name}: the dark level {float(np.min(level)):g} ({dark.source}) is far below the "
            f"darkest sampled value ({low:g}): a dark level is the DN of zero signal, within the "
            f"data's range; give the instrument's dark level{where}, or leave it empty to "
            "estimate it",
            params=params,
        )
    brightest = data.max(axis=0) if data.size else np.zeros(0)
    above = int((brightest > float(np.max(level))).sum())
    if data.size and above < min_pixels:
        raise InputError(
            f"{name}: only {above} of {data.shape[1]} usable sampled pixels are brighter than the "
            f"dark level {float(np.max(level)):g} ({dark.source}): the dark level is above the "
            f"signal; give the instrument's dark level{where} (0 for radiance), or leave it "
            "empty to estimate it",
            params=params,
        )
    return SampleCheck(usable, int(saturated.sum()), above)


def dark_level(
    bands: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    fraction: float = DARK_FRACTION,
    min_pixels: int = MIN_DARK_PIXELS,
) -> DarkLevel:
    """Estimate an instrument's dark level from its data (dark-object subtraction).

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
    DarkLevel
        ``level``: the lowest of the dark object's band means; ``band_levels``: all of them.
        The level is an upper bound of the true offset by the dark object's own signal in its
        dimmest band (deep shadow or water, a few DN): it also removes the path radiance there.

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
    levels = x[:, darkest].mean(axis=1)
    return DarkLevel(float(levels.min()), "estimated (dark object)", levels, n)


def signal(values: np.ndarray, level) -> np.ndarray:
    """Mean over the bands (axis 0) of DN minus the dark level, at least :data:`MIN_SIGNAL`.

    ``values`` is (n_bands, ...); ``level`` one number or one per band.
    """
    v = np.asarray(values, np.float64)
    lv = np.asarray(level, np.float64)
    if lv.ndim:
        lv = lv.reshape((-1,) + (1,) * (v.ndim - 1))
    return np.maximum((v - lv).mean(axis=0), MIN_SIGNAL)


def sunlit_mode(values: np.ndarray, valid: np.ndarray | None = None) -> tuple[float, float]:
    """(log sunlit mode, Otsu threshold) of a positive signal or ratio.

    The histogram of a scene with shadow is bimodal in log signal; Otsu's threshold splits it
    and the median above it is the sunlit mode (a scene without shadow gives the upper half's
    median: still sunlit).
    """
    from skimage.filters import threshold_otsu

    x = np.asarray(values, np.float64)
    ok = np.isfinite(x) & (x > 0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    logs = np.log(x[ok])
    if logs.size < 10:
        raise InputError(f"only {logs.size} valid pixels to find the sunlit mode (need 10)")
    t = float(threshold_otsu(logs)) if np.ptp(logs) > 0 else float(logs[0])
    upper = logs[logs >= t]
    return float(np.median(upper)), t


@dataclass(frozen=True)
class SceneCalibration:
    """Everything :func:`shadow_fraction_estimate` needs, found on a sample of the scene."""

    vnir_dark: DarkLevel
    swir_dark: DarkLevel
    nir_mode: float  # log of the sunlit NIR signal
    swir_mode: float  # log of the sunlit SWIR signal
    ratio_mode: float  # sunlit mode of the boresight ratio (DN, as Eq. 3)
    table: ClassTable  # Table 2 scaled to the scene
    blue_limit: float = math.inf  # log(blue / NIR) above which a pixel is too blue (water)
    offset_along: float = 0.0  # SWIR position minus VNIR position (px)
    offset_across: float = 0.0
    core: float = CORE_DARKNESS
    n_sample: int = 0
    blue_level: float = math.nan  # log of the sunlit blue signal (context.sunlit_blue_levels)
    blue_nir_level: float = math.nan  # log of the sunlit ground's blue / NIR

    def as_dict(self) -> dict:
        return {
            "vnir_dark_dn": round(self.vnir_dark.level, 3),
            "vnir_dark_source": self.vnir_dark.source,
            "swir_dark_dn": round(self.swir_dark.level, 3),
            "swir_dark_source": self.swir_dark.source,
            "sunlit_nir_signal_dn": round(math.exp(self.nir_mode), 3),
            "sunlit_swir_signal_dn": round(math.exp(self.swir_mode), 3),
            "sunlit_ratio": round(self.ratio_mode, 4),
            "class_scale": round(self.ratio_mode / PAPER_SUNLIT_RATIO, 4),
            "core_darkness": round(self.core, 4),
            "water_blue_nir_limit": round(math.exp(self.blue_limit), 4)
            if math.isfinite(self.blue_limit)
            else None,
            "offset_along_px": round(self.offset_along, 3),
            "offset_across_px": round(self.offset_across, 3),
            "sample_pixels": self.n_sample,
            "sunlit_blue_signal_dn": round(math.exp(self.blue_level), 3)
            if math.isfinite(self.blue_level)
            else None,
        }


def calibrate_shadow_map(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    ratio: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    vnir_dark: DarkLevel,
    swir_dark: DarkLevel,
    table: ClassTable,
    offset: tuple[float, float] = (0.0, 0.0),
    core: float = CORE_DARKNESS,
) -> SceneCalibration:
    """Calibrate the shadow map on a sample of pixels.

    Parameters
    ----------
    blue, nir, swir : arrays
        Signals (DN above the dark level, :func:`signal`) of the blue, NIR and SWIR ranges.
    ratio : array
        The boresight ratio (DN, Eq. 3) of the same pixels.
    valid : bool array, optional
    vnir_dark, swir_dark : DarkLevel
    table : ClassTable
        The class table to scale (Table 2 by default in the operation).
    offset : (float, float)
        Boresight offset, SWIR minus VNIR position (px), along- and across-track.
    core : float
        Core-shadow darkness (natural log of the signal over its sunlit mode), < 0.

    Returns
    -------
    SceneCalibration
        The sunlit modes of the NIR and SWIR signals (logs) and of the ratio, the class table
        scaled by ``ratio_mode / PAPER_SUNLIT_RATIO`` (the ratio bounds Table 2 would have on
        this scene), the water test's limit (:data:`WATER_FACTOR` × the 90th percentile of the
        sunlit pixels' blue/NIR) and the inputs.

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1, Table 2; Figure 5(B)'s line at fraction 0 as the paper's sunlit ratio).
    Otsu, N. IEEE Trans. Syst. Man Cybern. 1979, 9, 62–66.
    """
    from .classes import scale_table

    if not core < 0:
        raise ParameterError(
            f"parameter 'core_darkness': {core} must be below 0 (a log ratio to the sunlit mode)"
        )
    nir = np.asarray(nir, np.float64)
    swir = np.asarray(swir, np.float64)
    ok = np.isfinite(nir) & np.isfinite(swir)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    nir_mode, _ = sunlit_mode(nir, ok)
    swir_mode, _ = sunlit_mode(swir, ok)
    d = np.maximum(np.log(nir) - nir_mode - NIR_ALLOWANCE, np.log(swir) - swir_mode)
    # The sunlit ratio: pixels within a factor e^0.5 of the sunlit modes.
    r = np.asarray(ratio, np.float64)
    lit = ok & np.isfinite(r) & (r > 0) & (np.abs(d) < 0.5)
    if lit.sum() < 10:
        lit = ok & np.isfinite(r) & (r > 0) & (d > core)
    if lit.sum() < 10:
        raise InputError("fewer than 10 sunlit pixels with a valid ratio: cannot calibrate")
    ratio_mode = float(np.median(r[lit]))
    b = np.asarray(blue, np.float64)
    sunlit = lit & np.isfinite(b)
    limit = math.inf
    if sunlit.sum() >= 10:
        bn = np.log(np.maximum(b[sunlit], MIN_SIGNAL) / nir[sunlit])
        limit = float(np.percentile(bn, 90)) + math.log(WATER_FACTOR)
    levels = sunlit_blue_levels(b, nir, ok & (d > core))
    return SceneCalibration(
        vnir_dark=vnir_dark,
        swir_dark=swir_dark,
        nir_mode=nir_mode,
        swir_mode=swir_mode,
        ratio_mode=ratio_mode,
        table=scale_table(table, ratio_mode / PAPER_SUNLIT_RATIO),
        blue_limit=limit,
        offset_along=float(offset[0]),
        offset_across=float(offset[1]),
        core=float(core),
        n_sample=int(ok.sum()),
        blue_level=levels[0],
        blue_nir_level=levels[1],
    )


def darkness(
    nir: np.ndarray, swir: np.ndarray, calibration: SceneCalibration, valid=None
) -> np.ndarray:
    """The lesser darkness of the SWIR and NIR signals: ``max(ln(swir / swir mode), ln(nir /
    nir mode) − NIR_ALLOWANCE)`` (0 = sunlit mode, ln 1/6 = a sixth of it); NaN where invalid.
    A shadow is dark in both (skylight is weak beyond 700 nm, weakest in the SWIR); sunlit
    vegetation is bright in the NIR though dark in the SWIR (leaf water), sunlit asphalt and
    dark roofs keep more of the SWIR. ``swir`` must already be on the VNIR grid."""
    d = np.maximum(
        _over_mode(nir, calibration.nir_mode) - NIR_ALLOWANCE,
        _over_mode(swir, calibration.swir_mode),
    )
    return _where_valid(d, valid)


def _over_mode(signal: np.ndarray, mode: float) -> np.ndarray:
    """ln of a signal (at least :data:`MIN_SIGNAL`) over its sunlit mode (``mode``, ln)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.log(np.maximum(np.asarray(signal, np.float64), MIN_SIGNAL)) - mode


def _where_valid(x: np.ndarray, valid=None) -> np.ndarray:
    """``x`` where it is finite and ``valid``, NaN elsewhere."""
    ok = np.isfinite(x)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    return np.where(ok, x, np.nan)


def _local_mean(x: np.ndarray, weight: np.ndarray, size: int) -> np.ndarray:
    from scipy import ndimage

    num = ndimage.uniform_filter(np.where(weight, x, 0.0), size, mode="nearest")
    den = ndimage.uniform_filter(weight.astype(np.float64), size, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 1e-9, num / den, np.nan)


def shadow_fraction_estimate(
    dark: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    core: float = CORE_DARKNESS,
    edge_pixels: int = EDGE_PIXELS,
    window: int = EDGE_WINDOW,
    water: np.ndarray | None = None,
) -> np.ndarray:
    """Estimated shadow fraction (float32, 0–1; NaN where invalid) from :func:`darkness`.

    Core shadow is ``dark <= core`` (but not ``water``, pixels too blue for skylight).
    Around it (within ``edge_pixels``), a pixel's signal ``s = exp(dark)`` is unmixed between
    the mean signal of the core pixels in its ``window × window`` neighbourhood and that of the
    sunlit pixels beyond the edge zone in a ``window + 2`` neighbourhood: ``(lit − s) /
    (lit − shade)``, the shaded share of a mixed pixel (signal is linear in it). Core pixels
    get at least 0.5 (they are shadow by definition); pixels further from the core, 0. Strips
    need a halo of ``edge_pixels + window // 2 + 1`` lines.

    Parameters
    ----------
    dark : array
        :func:`darkness` (natural log of the signal over its sunlit mode).
    valid : bool array, optional
    core : float
        Core-shadow darkness (< 0).
    edge_pixels : int
        Width of the zone around the core where partial shadow is unmixed (0 = core only).
    window : int
        Side of the neighbourhood of the core-shadow mean (the sunlit mean uses ``window + 2``).
    water : bool array, optional
        Pixels that cannot be core shadow (:func:`too_blue`).

    Returns
    -------
    float32 array
        The estimated shadow fraction (0–1), NaN where invalid.

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1, Table 2: shadow fraction classes; the mask is fraction ≥ 50 %).
    """
    d = np.asarray(dark, np.float64)
    ok = np.isfinite(d)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    if edge_pixels < 0 or window < 1:
        raise ParameterError("parameters 'edge_pixels' ≥ 0 and 'edge_window' ≥ 1 are required")
    with np.errstate(invalid="ignore"):
        core_px = ok & (d <= core)
    if water is not None:
        core_px &= ~np.asarray(water, bool)
    return _unmix(d, ok, core_px, edge_pixels, window)


def _unmix(d, ok, core_px, edge_pixels, window, allowed=None, whole=None) -> np.ndarray:
    """Shadow fraction: core pixels at least 0.5 (only those of ``whole`` when given; the
    others get their unmixed fraction), pixels within ``edge_pixels`` of the core unmixed
    between the local sunlit and core-shadow signals (``exp(d)``), 0 elsewhere and outside
    ``allowed``; NaN where not ``ok``."""
    from scipy import ndimage

    f = np.zeros(d.shape, np.float64)
    if core_px.any():
        s = np.exp(np.where(ok, d, 0.0))
        zone = (
            ndimage.binary_dilation(core_px, iterations=int(edge_pixels))
            if edge_pixels
            else core_px
        )
        lit = _local_mean(s, ok & ~zone, window + 2)
        fallback = _local_mean(s, ok & ~core_px, window)
        lit = np.where(np.isfinite(lit), lit, fallback)
        shade = _local_mean(s, core_px, window)
        with np.errstate(invalid="ignore", divide="ignore"):
            est = np.clip((lit - s) / (lit - shade), 0.0, 1.0)
        est = np.where(np.isfinite(est) & (lit > shade), est, 0.0)
        near = zone & ok & ~core_px
        if allowed is not None:
            near &= allowed
        f[near] = est[near]
        at_least = (
            np.maximum(est, 0.5) if whole is None else np.where(whole, np.maximum(est, 0.5), est)
        )
        f[core_px] = np.where(np.isfinite(lit[core_px]), at_least[core_px], 1.0)
    out = f.astype(np.float32)
    out[~ok] = np.nan
    return out


def dsm_shadow_fraction(
    dark: np.ndarray,
    prior: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    edge_pixels: int = EDGE_PIXELS,
    window: int = EDGE_WINDOW,
    water: np.ndarray | None = None,
    tolerance: int = DSM_TOLERANCE,
    rim: float = RIM_DARKNESS,
    lit: float = LIT_DARKNESS,
    heights: np.ndarray | None = None,
    clearance: float = 0.0,
    unseen: np.ndarray | None = None,
    ray: tuple[float, float, int] | None = None,
    core: float = CORE_DARKNESS,
    reach: float = 0.0,
) -> np.ndarray:
    """Estimated shadow fraction (float32, 0–1; NaN where invalid) from :func:`darkness` with
    the cast shadow a surface model predicts as the prior.

    Shadow can only be where the surface model puts it, give or take ``tolerance`` pixels of
    registration: outside that zone the fraction is 0, however dark the pixel (a black roof
    or road in the sun), except in a cell the model shades in part (``prior`` > 0: a shaded
    sub-cell) that is as dark as core shadow (``core``), which is at least half shaded: shade
    below the model's resolution (a crown beside a taller one) that it cannot rule out.
    Inside it:

    * a pixel the model shades (``prior`` ≥ 0.5) is shadow unless it is spectrally lit
      (``dark`` > ``lit``, more than half the sunlit mode: the surface model is wrong there,
      e.g. of another date);
    * a pixel within ``tolerance`` of that but not shaded by the model is shadow when it is
      at most ``exp(rim)`` of the sunlit mode and not water (a shadow edge the model puts a
      pixel off), unless (with ``heights``) it stands more than ``clearance`` above the
      lowest predicted-shadow cell within ``tolerance``: then it is the top of the caster
      (a roof or crown beside its own shadow), lit by the sun whatever its darkness;
    * around those, within ``edge_pixels`` (and the zone), the fraction is unmixed between the
      local sunlit and shadowed signals as in :func:`shadow_fraction_estimate`. Those more
      than ``tolerance + 1`` pixels inside the predicted shadow get at least the model's
      fraction (1 inside a cast shadow), and shadow pixels as dark as core shadow (``core``)
      at least 0.5; the others (the predicted shadow's edges and the
      rim) keep their unmixed fraction, so that a mixed edge pixel is shadow when more than
      half of it is shaded, not because it is darker than ``lit``;
    * a pixel beside the predicted shadow (within the zone, not shaded by the model) is
      shaded at most as much as its signal says against the darkest pixel next to it outside
      the zone, taken as its sunlit end: registered within ``tolerance``, no shadow reaches
      that pixel, so a dark material running on past the zone is as dark there in the sun and
      its pixel beside the shadow is not taken for shade.

    With ``ray`` and ``reach`` (cells), the zone of the rim also reaches ``reach`` cells
    down-sun of the predicted shadow, then ``tolerance``: the clearance shortens a shadow by
    ``clearance · tan(zenith)`` at its far end on level ground (``reach`` = the clearance over
    the sun's rise per cell). Beyond the tolerance a shadow goes on from the predicted one
    along the sun's direction, so a rim pixel there is shadow only when the pixel next to it
    towards the sun is shadow too, and is unmixed only next to such a pixel: a dark material
    cut from the shadow by a lit pixel is not taken.

    Where the surface model cannot rule shadow out (``unseen``: a caster beyond its edge could
    shade the pixel, :func:`geoboresight.shadow.illumination.unseen_casters`), the fraction is
    at least the spectral estimate without a surface model (:func:`shadow_fraction_estimate`
    with ``core``), provided (with ``ray``) that no pixel on the way towards the sun to the
    grid's edge is spectrally lit: the shadow of a caster beyond the edge covers the ground
    between the caster and the pixel it shades (on level ground), so it reaches the edge; a
    dark material alone near the edge does not.

    Strips need a halo of ``edge_pixels + window // 2 + tolerance + 1`` lines (and the prior's
    own, :func:`geoboresight.shadow.illumination.halo_rows`).

    Parameters
    ----------
    dark : array
        :func:`darkness` (natural log of the signal over its sunlit mode).
    prior : array
        Cast-shadow fraction from the surface model
        (:func:`geoboresight.shadow.illumination.shadow_fraction`) on the same grid; NaN = 0.
    valid : bool array, optional
    edge_pixels, window : int
        As :func:`shadow_fraction_estimate`.
    water : bool array, optional
        Pixels too blue for skylight (:func:`too_blue`): not shadow outside the prior.
    tolerance : int
        Registration tolerance of the surface model (px).
    rim, lit : float
        Darkness (natural log over the sunlit mode) at or below which a pixel next to the
        predicted shadow is shadow, and above which a predicted one is lit.
    heights : array, optional
        The surface model's heights (m) on the same grid: without them no rim pixel is
        taken for a caster.
    clearance : float
        Height (m) above the predicted shadow's ground beyond which a rim pixel is a caster
        (the prior's clearance: the surface model's height noise).
    unseen : bool array, optional
        Pixels whose casters the surface model may not hold (same grid).
    ray : (Δrow, Δcol, steps), optional
        The march towards the sun (:func:`geoboresight.shadow.illumination.along_ray`);
        strips need :func:`geoboresight.shadow.illumination.halo_rows` lines towards it.
    core : float
        Core-shadow darkness (natural log over the sunlit mode): a shadow pixel this dark is
        at least half shaded, and the spectral estimate on ``unseen`` pixels uses it.
    reach : float
        How far (cells) the clearance shortens a shadow's far end on level ground (0: no
        sweep; used with ``ray``). Strips need ``ceil(reach · |Δrow|) + 1`` more lines towards
        the sun.

    Returns
    -------
    float32 array

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1: the shadow simulated from a surface model and the sun).
    """
    from scipy import ndimage

    d, ok, p, z = _checked_inputs(dark, valid, prior, heights, edge_pixels, window, tolerance)
    shaded = p >= PREDICTED_SHADOW
    # Where the model shades at least half a pixel, give or take the tolerance (sub-cells
    # shaded by height noise on open ground stay out), and down-sun of it by the ``reach`` the
    # clearance takes off a shadow's far end (on level ground).
    base = np.where(shaded & np.isfinite(z), z, np.inf) if z is not None else None
    swept, base = _down_sun(shaded, ray, reach, base)
    near = ndimage.binary_dilation(shaded, iterations=tolerance) if tolerance else shaded
    zone = ndimage.binary_dilation(swept, iterations=tolerance) if tolerance else swept
    # Water (too blue for skylight) is not shadow outside the prior.
    dry = ok if water is None else ok & ~np.asarray(water, bool)
    with np.errstate(invalid="ignore"):
        core_px = ok & shaded & (d <= lit)
        rim_px = dry & zone & ~shaded & (d <= rim)
        # Outside the zone, a cell the model shades in part (a shaded sub-cell: a crown
        # beside a taller one, below the model's resolution) and as dark as core shadow is
        # shadow: the model cannot rule that shade out, and the spectrum says it is there. A
        # dark surface the model does not shade at all stays lit.
        part_px = dry & (p > 0) & ~zone & (d <= core)
    if z is not None:
        with np.errstate(invalid="ignore"):
            ground = ndimage.minimum_filter(base, size=2 * tolerance + 1)
            rim_px &= ~(z - ground > clearance)
    allowed = zone
    if swept is not shaded:
        rim_px, allowed = _connected_rim(core_px, rim_px, near, zone, ray, reach, tolerance)
    # Away from the predicted edges (by more than the tolerance) the model's shade is whole.
    deep = core_px & ndimage.binary_erosion(shaded, iterations=tolerance + 1)
    with np.errstate(invalid="ignore"):
        whole = deep | (d <= core)
    f = _unmix(d, ok, core_px | rim_px | part_px, edge_pixels, window, allowed=allowed, whole=whole)
    f[deep] = np.maximum(f[deep], p[deep]).astype(np.float32)
    _cap_beside_zone(f, d, ok, zone, shaded, core_px | rim_px, window)
    if unseen is not None:
        spectral = dict(core=core, edge_pixels=edge_pixels, window=window, water=water)
        _unseen_at_least_spectral(f, d, ok, unseen, ray, lit, spectral)
    return f


def _unseen_at_least_spectral(f, d, ok, unseen, ray, lit, spectral: dict) -> None:
    """Raise ``f`` (in place) to the spectral estimate (:func:`shadow_fraction_estimate` with
    ``spectral``) on the ``unseen`` pixels whose way towards the sun along ``ray`` to the
    grid's edge is not lit (darker than ``lit``): the shadow of a caster beyond the edge
    covers the ground between them."""
    u = np.asarray(unseen, bool)
    if u.shape != d.shape:
        raise InputError(f"parameter 'unseen': shape {u.shape} is not the image's {d.shape}")
    if ray is not None and u.any():
        from .illumination import along_ray

        with np.errstate(invalid="ignore"):
            u = u & along_ray(~(d > lit), ray)
    if u.any():
        f0 = shadow_fraction_estimate(d, ok, **spectral)
        f[u] = np.fmax(f[u], f0[u])


def _checked_inputs(dark, valid, prior, heights, edge_pixels, window, tolerance):
    """:func:`dsm_shadow_fraction`'s arrays checked: (darkness, valid, prior with NaN as 0,
    heights or None), float64, each of the darkness's shape."""
    d = np.asarray(dark, np.float64)
    ok = np.isfinite(d)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    if edge_pixels < 0 or window < 1 or tolerance < 0:
        raise ParameterError(
            "parameters 'edge_pixels' ≥ 0, 'edge_window' ≥ 1 and 'tolerance' ≥ 0 are required"
        )
    return d, ok, *_checked_prior(prior, heights, d.shape)


def _checked_prior(prior, heights, shape):
    """(prior with NaN as 0, heights or None) as float64, each of the image's ``shape``."""
    p = np.nan_to_num(np.asarray(prior, np.float64), nan=0.0)
    if p.shape != shape:
        raise InputError(f"the prior's shape {p.shape} is not the image's {shape}")
    if heights is None:
        return p, None
    z = np.asarray(heights, np.float64)
    if z.shape != shape:
        raise InputError(f"parameter 'heights': shape {z.shape} is not the image's {shape}")
    return p, z


def _connected_rim(core_px, rim_px, near, zone, ray, reach, tolerance):
    """(rim, where unmixing is allowed) beyond the tolerance: a shadow the clearance
    shortened goes on from the predicted shadow along the sun's direction, so a cell there is
    shadow only when the cell next to it towards the sun is, and it is unmixed only next to
    such a cell."""
    step = _toward_sun(ray)
    extra = rim_px & ~near
    taken = core_px | (rim_px & near)
    for _ in range(int(math.ceil(reach)) + tolerance):
        grow = extra & ~taken & _shift(taken, step)
        if not grow.any():
            break
        taken |= grow
    return taken & ~core_px, near | (zone & _shift(taken, step))


def _cap_beside_zone(f, d, ok, zone, shaded, shadow_px, window) -> None:
    """Cap ``f`` (in place) beside the predicted shadow (in the ``zone``, not ``shaded``).
    Outside the zone no shadow reaches (registration within the tolerance): a pixel there is
    lit. A rim pixel is shaded at most as much as its signal says against the darkest such
    pixel beside it, taken as its sunlit end: a dark material running on past the zone is as
    dark there, in the sun, so it is not taken for shade; a shaded pixel beside brighter lit
    ground keeps its fraction."""
    from scipy import ndimage

    beside = ok & ~zone
    if not beside.any():
        return
    ref = ndimage.minimum_filter(np.where(beside, d, np.inf), size=3, mode="constant", cval=np.inf)
    s = np.exp(np.where(ok, d, 0.0))
    sun = np.exp(np.where(np.isfinite(ref), ref, 0.0))
    shade = _local_mean(s, shadow_px, window)
    with np.errstate(invalid="ignore", divide="ignore"):
        beside_est = np.clip((sun - s) / (sun - shade), 0.0, 1.0)
        cap = ok & zone & ~shaded & np.isfinite(ref) & (sun > shade) & np.isfinite(beside_est)
    f[cap] = np.minimum(f[cap], beside_est[cap]).astype(np.float32)


def _toward_sun(ray) -> tuple[int, int]:
    """The neighbouring cell (Δrow, Δcol) nearest the sun's direction (``ray``'s)."""
    drow, dcol = float(ray[0]), float(ray[1])
    n = max(abs(drow), abs(dcol), 1e-12)
    return int(np.floor(drow / n + 0.5)) if abs(drow) / n >= 0.5 else 0, (
        int(np.floor(dcol / n + 0.5)) if abs(dcol) / n >= 0.5 else 0
    )


def _shift(mask: np.ndarray, step: tuple[int, int]) -> np.ndarray:
    """``mask`` at the cell ``step`` away from each cell (False beyond the grid)."""
    from .illumination import _shifted

    return _shifted(mask, step[0], step[1], False)


def _down_sun(mask, ray, reach, base=None):
    """(``mask`` swept up to ``reach`` cells away from the sun along ``ray``'s direction, the
    least ``base`` met on the way): a cell is in the sweep when a cell ``t ≤ reach`` cells
    towards the sun is in ``mask``."""
    if ray is None or not reach > 0:
        return mask, base
    from .illumination import _shifted

    drow, dcol = float(ray[0]), float(ray[1])
    out = mask.copy()
    low = None if base is None else base.copy()
    for k in range(1, int(math.ceil(2 * reach)) + 1):
        t = min(k / 2, reach)
        sr, sc = int(np.floor(t * drow + 0.5)), int(np.floor(t * dcol + 0.5))
        out |= _shifted(mask, sr, sc, False)
        if low is not None:
            low = np.fmin(low, _shifted(base, sr, sc, np.inf))
    return out, low


def prior_agreement(
    dark: np.ndarray,
    prior: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    max_shift: int = 3,
    rim: float = RIM_DARKNESS,
) -> dict:
    """How well a surface model's cast shadow matches the image's darkness: the shift (rows,
    columns, within ``max_shift``) of the predicted shadow (``prior`` ≥ 0.5) that best
    overlaps the dark pixels (``dark`` ≤ ``rim``), by intersection over union, and the IoU
    at that shift and unshifted. A best shift other than (0, 0) that gains much says the
    model and the image are not registered."""
    d = np.asarray(dark, np.float64)
    ok = np.isfinite(d)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    with np.errstate(invalid="ignore"):
        dk = ok & (d <= rim)
    pr = np.nan_to_num(np.asarray(prior, np.float64), nan=0.0) >= PREDICTED_SHADOW
    m = int(max_shift)
    h, w = d.shape
    inner = np.zeros(d.shape, bool)
    inner[m : h - m, m : w - m] = True
    inner &= ok
    best = (0, 0, -1.0)
    iou0 = float("nan")
    shifts = sorted(
        ((dy, dx) for dy in range(-m, m + 1) for dx in range(-m, m + 1)),
        key=lambda s: s[0] ** 2 + s[1] ** 2,
    )
    for dy, dx in shifts:  # nearest first: a tie keeps the smaller shift
        sh = np.roll(pr, (dy, dx), axis=(0, 1))
        union = ((sh | dk) & inner).sum()
        iou = float((sh & dk & inner).sum() / union) if union else float("nan")
        if (dy, dx) == (0, 0):
            iou0 = iou
        if np.isfinite(iou) and iou > best[2] + 1e-9:
            best = (dy, dx, iou)
    return {
        "dsm_shift_rows": best[0],
        "dsm_shift_columns": best[1],
        "dsm_iou_at_shift": round(best[2], 4) if best[2] >= 0 else None,
        "dsm_iou": round(iou0, 4) if np.isfinite(iou0) else None,
    }


def nir_darkness(nir: np.ndarray, calibration: SceneCalibration, valid=None) -> np.ndarray:
    """How far below its sunlit mode the NIR signal is (``max(ln(nir / nir mode), …)``
    negated, ≥ 0; NaN where invalid): shadow evidence on the VNIR's own grid, without the
    SWIR's resampling by the boresight offset and its relief parallax."""
    return _where_valid(-np.minimum(_over_mode(nir, calibration.nir_mode), 0.0), valid)


def prior_registration(
    evidence: np.ndarray,
    fine: np.ndarray,
    supersample: int,
    valid: np.ndarray | None = None,
    *,
    max_shift: float = DSM_TOLERANCE,
) -> dict:
    """The sub-pixel shift of a surface model's cast shadow onto the image: the move (rows,
    columns; whole sub-cells, within ``max_shift`` cells each way) of the shadow cast on the
    sub-cell grid (``fine``, :func:`geoboresight.shadow.illumination.sub_cell_shadow`) whose
    cell fractions correlate best (Pearson) with the shadow ``evidence`` on the image's grid
    (:func:`nir_darkness`: the SWIR's darkness would bring in its own registration, the
    boresight offset and the relief's parallax).

    Moving the cast on its own sub-cell grid undoes a registration error without resampling
    the surface model, which would smooth its walls. At a high sun a shadow is a pixel or two
    wide, and half a pixel of registration is a large share of it. What is matched is the
    prior as the refinement uses it, cast with the clearance, whose far ends are shortened:
    the move also takes up that shortening, so it is not the DSM's own offset (on model 2 it
    went 0.5–1 px further down-sun, where ``clearance · tan(zenith)`` was 0.5–0.7 px).

    The move is kept only when the image's parts agree on it: on each of :data:`TILES` ×
    :data:`TILES` tiles the gain in correlation over the unmoved prediction is taken, and
    their mean must exceed :data:`REGISTRATION_T` standard errors (else the move is 0).

    Returns
    -------
    dict
        ``dsm_registration_rows`` / ``_columns`` (cells, the move kept), the correlation there
        and unmoved (``dsm_registration_r`` / ``dsm_registration_r0``), and the tiles' t
        (``dsm_registration_t``); None where undefined.
    """
    n = int(supersample)
    e = np.asarray(evidence, np.float64)
    ok = np.isfinite(e)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    m = int(math.floor(float(max_shift) * n + 1e-9))
    edge = int(math.ceil(float(max_shift))) + 1
    inner = np.zeros(e.shape, bool)
    inner[edge : e.shape[0] - edge, edge : e.shape[1] - edge] = True
    inner &= ok
    from .illumination import cell_fraction

    def corr(sr, sc):
        return _pearson(cell_fraction(fine, n, (sr / n, sc / n))[inner], e[inner])

    still = cell_fraction(fine, n)
    r0 = _pearson(still[inner], e[inner])
    best = (0, 0, r0)
    if np.isfinite(r0):
        shifts = sorted(
            ((a, b) for a in range(-m, m + 1) for b in range(-m, m + 1)),
            key=lambda t: t[0] ** 2 + t[1] ** 2,
        )
        for a, b in shifts[1:]:  # nearest first: a tie keeps the smaller move
            r = corr(a, b)
            if np.isfinite(r) and r > best[2] + 1e-9:
                best = (a, b, r)
    # The move is kept only where the image's parts agree that it helps: the gain in
    # correlation on each of TILES × TILES tiles, its mean over twice its standard error.
    t = 0.0  # no move found that gains: nothing to agree on
    if best[:2] != (0, 0):
        t = float("nan")
        moved = cell_fraction(fine, n, (best[0] / n, best[1] / n))
        gains = []
        for rows in np.array_split(np.arange(edge, e.shape[0] - edge), TILES):
            for cols in np.array_split(np.arange(edge, e.shape[1] - edge), TILES):
                if rows.size == 0 or cols.size == 0:
                    continue
                tile = np.ix_(rows, cols)
                ok_t = inner[tile]
                g = _pearson(moved[tile][ok_t], e[tile][ok_t]) - _pearson(
                    still[tile][ok_t], e[tile][ok_t]
                )
                if np.isfinite(g):
                    gains.append(g)
        if len(gains) >= 3:
            g = np.asarray(gains)
            se = max(float(g.std(ddof=1)) / math.sqrt(g.size), 1e-12)
            t = float(g.mean()) / se
        if not t > REGISTRATION_T:
            best = (0, 0, r0)
    fin = lambda v: round(v, 4) if np.isfinite(v) else None  # noqa: E731
    return registration_result(best[0] / n, best[1] / n, fin(best[2]), fin(r0), fin(t))


def registration_result(rows=0.0, columns=0.0, r=None, r0=None, t=None) -> dict:
    """What :func:`prior_registration` reports; the defaults: no move, nothing measured (the
    registration turned off)."""
    return {
        "dsm_registration_rows": rows,
        "dsm_registration_columns": columns,
        "dsm_registration_r": r,
        "dsm_registration_r0": r0,
        "dsm_registration_t": t,
    }


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    a = a - a.mean() if a.size else a
    b = b - b.mean() if b.size else b
    den = float(np.sqrt((a @ a) * (b @ b))) if a.size else 0.0
    return float(a @ b) / den if den > 0 else float("nan")


def shadow_mask(fraction: np.ndarray, threshold: float = 0.5) -> np.ndarray:
    """uint8 shadow mask (1 shadow, 0 not, 255 nodata): estimated fraction ≥ ``threshold``."""
    f = np.asarray(fraction)
    ok = np.isfinite(f)
    with np.errstate(invalid="ignore"):
        out = np.where(f >= threshold, MASK_SHADOW, MASK_NOT_SHADOW).astype(np.uint8)
    out[~ok] = MASK_NODATA
    return out


def too_blue(blue: np.ndarray, nir: np.ndarray, limit: float) -> np.ndarray:
    """Pixels whose log(blue / NIR) signal exceeds ``limit``: bluer than skylight makes a
    shadow (clear water, whose NIR and SWIR are near zero while its blue is sunlit)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.log(np.maximum(blue, MIN_SIGNAL) / np.maximum(nir, MIN_SIGNAL)) > limit


def shadow_classes(fraction: np.ndarray, table: ClassTable) -> np.ndarray:
    """uint8 class of each pixel by the table's shadow-fraction intervals (Table 2's 10–20,
    20–50, 50–80, 80–100 %): 0 below them all, 255 where the fraction is NaN."""
    f = np.asarray(fraction, np.float64)
    ok = np.isfinite(f)
    out = np.full(f.shape, NO_SHADOW, np.uint8)
    top = max(c.fraction_max for c in table.classes)
    with np.errstate(invalid="ignore"):
        for c in sorted(table.classes, key=lambda c: c.fraction_min):
            inside = (f >= c.fraction_min) & ((f < c.fraction_max) | (c.fraction_max == top))
            out[inside & ok] = c.id
    out[~ok] = NODATA_CLASS
    return out


def shadow_map_halo(calibration: SceneCalibration, edge_pixels: int = EDGE_PIXELS) -> int:
    """Lines above and below a block that :func:`shadow_map_block` needs to give, on the
    block, the values of the whole image: the SWIR's along-track shift and its bilinear
    reach, and the edge search (``edge_pixels`` and half the unmixing window)."""
    return (
        math.ceil(abs(calibration.offset_along))
        + 3
        + int(edge_pixels)
        + EDGE_WINDOW // 2
        + DSM_TOLERANCE
    )


def shadow_map_block(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    calibration: SceneCalibration,
    dark_levels: tuple = (0.0, 0.0, 0.0),
    edge_pixels: int = EDGE_PIXELS,
    prior: np.ndarray | None = None,
    heights: np.ndarray | None = None,
    clearance: float = 0.0,
    unseen: np.ndarray | None = None,
    ray: tuple[float, float, int] | None = None,
    reach: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Shadow classes and shadow mask of a block of lines: the shadow map's per-pixel pipeline.

    1. **Signal**: DN minus the instrument's dark level, averaged over the bands of each range
       (:func:`signal`; blue, NIR, SWIR).
    2. **Co-registration**: the SWIR signal is resampled onto the VNIR grid by the boresight
       offset of ``calibration`` (bilinear; invalid pixels filled with the sunlit SWIR signal,
       so they carry no edge), so that shadow edges line up.
    3. **Darkness** against the scene's sunlit modes (:func:`darkness`).
    4. **Shadow fraction**: core shadow at or below ``calibration.core``, not water
       (:func:`too_blue`), unmixed between sunlit and shadowed neighbours within
       ``edge_pixels`` (:func:`shadow_fraction_estimate`).
    5. **Mask**: fraction ≥ 50 % (:func:`shadow_mask`).
    6. **Classes**: Table 2's shadow-fraction intervals (:func:`shadow_classes` with
       ``calibration.table``).

    A block read with :func:`shadow_map_halo` lines above and below gives, on its own lines,
    what the whole image gives.

    Parameters
    ----------
    blue, nir, swir : arrays (n_bands, lines, columns)
        DN (or radiance) of the bands of :data:`BLUE_NM` and :data:`NIR_NM` (VNIR) and of
        :data:`SWIR_NM` (SWIR, on its own grid: not yet shifted).
    valid : bool array (lines, columns), optional
        Pixels valid in every band read.
    calibration : SceneCalibration
        From :func:`calibrate_shadow_map` on a sample of the whole flight line.
    dark_levels : (blue, nir, swir)
        The dark level to subtract from each range: one number, or one per band
        (:meth:`DarkLevel.for_bands`).
    edge_pixels : int
        Partial shadow is looked for this many pixels around the core (0 = core only).
    prior : array (lines, columns), optional
        The cast-shadow fraction a surface model predicts on the block: step 4 is then
        :func:`dsm_shadow_fraction` (no shadow away from it; needs :data:`DSM_TOLERANCE` more
        lines of halo).
    heights : array (lines, columns), optional
        With ``prior``: the surface model's heights, and ``clearance`` its height tolerance
        (m), so that the top of a caster beside its shadow is not taken for shadow, and
        ``unseen`` the pixels a caster beyond the surface model could shade, where the
        spectral estimate holds if the way to the edge along ``ray`` is not lit
        (:func:`dsm_shadow_fraction`). ``reach``: how far (cells) the clearance shortens a
        shadow's far end, down-sun along ``ray`` (:func:`dsm_shadow_fraction`).

    Returns
    -------
    classes : uint8 array (lines, columns)
        0 no shadow, the class ids of ``calibration.table``, 255 nodata.
    mask : uint8 array (lines, columns)
        1 shadow, 0 not, 255 nodata.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2: the
    shadow-fraction classes, 80–100, 50–80, 20–50 and 10–20 % shadow).
    Chavez, P.S. Remote Sens. Environ. 1988, 24, 459–479 (dark-object subtraction).
    """
    f, _ = shadow_fraction_block(
        blue,
        nir,
        swir,
        valid,
        calibration=calibration,
        dark_levels=dark_levels,
        edge_pixels=edge_pixels,
        prior=prior,
        heights=heights,
        clearance=clearance,
        unseen=unseen,
        ray=ray,
        reach=reach,
    )
    return shadow_classes(f, calibration.table), shadow_mask(f)


def shadow_fraction_block(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    calibration: SceneCalibration,
    dark_levels: tuple = (0.0, 0.0, 0.0),
    edge_pixels: int = EDGE_PIXELS,
    prior: np.ndarray | None = None,
    heights: np.ndarray | None = None,
    clearance: float = 0.0,
    unseen: np.ndarray | None = None,
    ray: tuple[float, float, int] | None = None,
    reach: float = 0.0,
    tolerance: int = DSM_TOLERANCE,
    sky_blue: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(shadow fraction, darkness) of a block: steps 1–4 of :func:`shadow_map_block`; with
    ``prior`` (a surface model's cast-shadow fraction on the block; ``heights``,
    ``clearance``, ``unseen``, ``ray``, ``reach`` and ``tolerance``, the surface model's) by
    :func:`dsm_shadow_fraction` instead of :func:`shadow_fraction_estimate`. Without
    ``prior``, ``sky_blue`` (a limit) also keeps the dark pixels whose blue is sunlit out of
    the core (:func:`geoboresight.shadow.context.sunlit_dark`; needs
    :data:`~geoboresight.shadow.context.HALO` more lines of halo)."""
    from ..sensor.coregister import coregister

    blue_level, nir_level, swir_level = dark_levels
    b = signal(blue, blue_level)
    n = signal(nir, nir_level)
    s = signal(swir, swir_level)
    ok = np.ones(n.shape, bool) if valid is None else np.asarray(valid, bool)
    s, s_ok = coregister(
        s,
        calibration.offset_along,
        calibration.offset_across,
        ok,
        order=1,
    )
    good = ok & s_ok
    d = darkness(n, s, calibration, good)
    water = too_blue(b, n, calibration.blue_limit)
    if prior is not None:
        f = dsm_shadow_fraction(
            d,
            prior,
            good,
            edge_pixels=edge_pixels,
            water=water,
            heights=heights,
            clearance=clearance,
            unseen=unseen,
            ray=ray,
            core=calibration.core,
            reach=reach,
            tolerance=tolerance,
        )
    else:
        if sky_blue is not None:
            levels = (calibration.blue_level, calibration.blue_nir_level)
            water = water | sunlit_dark(
                b, n, d, good, core=calibration.core, levels=levels, limit=sky_blue
            )
        f = shadow_fraction_estimate(
            d, good, core=calibration.core, edge_pixels=edge_pixels, water=water
        )
    return f, d
