"""A shadow map that separates shadow from dark materials (paper §3.1, made physical).

On raw DN the boresight ratio ``b(1010 nm) / b(920 nm)`` of every dim pixel, shadowed or just
dark, tends to the ratio of the two instruments' dark offsets: no threshold on it separates a
sunlit asphalt road from a shaded lawn. A dual-sensor cube carries what does:

1. **Each instrument's dark level** (:class:`~geoboresight.sensor.dark.DarkLevels`): the DN
   of zero signal, taken from the user or the header, or estimated from the data by
   dark-object subtraction (Chavez 1988, :func:`~geoboresight.sensor.dark.dark_object`): the
   darkest pixels of the instrument (by their mean over its bands), averaged band by band;
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
from ..sensor.dark import DarkLevels
from .classes import (
    MASK_NODATA,
    MASK_NOT_SHADOW,
    MASK_SHADOW,
    NO_SHADOW,
    NODATA_CLASS,
    ClassTable,
    scale_table,
)
from .context import local_mean, sunlit_blue_levels, sunlit_tilt_level

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
#: With a surface model (:func:`geoboresight.shadow.prior.dsm_shadow_fraction`): a pixel
#: within :data:`DSM_TOLERANCE` of the predicted cast shadow but outside it is shadow when at
#: most a third of the sunlit mode (ln 1/3: looser than the core, since a surface model rules
#: out dark materials elsewhere).
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
    dark: DarkLevels | None,
    detector: str = "vnir",
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
    dark : DarkLevels, optional
        The dark levels the map would subtract; None checks saturation and signal only.
    detector : {"vnir", "swir"}
        The instrument of ``bands``, whose level ``dark`` holds.
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
    level, source, param = dark.levels(detector), dark.source(detector), dark.param(detector)
    low = float(np.nanmin(data)) if data.size else 0.0
    where, params = (f" in '{param}'", (param,)) if param else ("", ())
    if data.size and float(np.min(level)) < low - max(1.0, 0.5 * abs(low)):
        raise InputError(
            f"{name}: the dark level {float(np.min(level)):g} ({source}) is far below the "
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
            f"dark level {float(np.max(level)):g} ({source}): the dark level is above the "
            f"signal; give the instrument's dark level{where} (0 for radiance), or leave it "
            "empty to estimate it",
            params=params,
        )
    return SampleCheck(usable, int(saturated.sum()), above)


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

    dark: DarkLevels  # both instruments' levels
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
    tilt_level: float = math.nan  # log of the sunlit ground's long SWIR / SWIR (NaN: none)

    def as_dict(self) -> dict:
        return {
            "vnir_dark_dn": round(self.dark.level("vnir"), 3),
            "vnir_dark_source": self.dark.source("vnir"),
            "swir_dark_dn": round(self.dark.level("swir"), 3),
            "swir_dark_source": self.dark.source("swir"),
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
            "sunlit_swir_tilt": round(self.tilt_level, 4)
            if math.isfinite(self.tilt_level)
            else None,
        }


def calibrate_shadow_map(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    ratio: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    dark: DarkLevels,
    table: ClassTable,
    offset: tuple[float, float] = (0.0, 0.0),
    core: float = CORE_DARKNESS,
    long_swir: np.ndarray | None = None,
) -> SceneCalibration:
    """Calibrate the shadow map on a sample of pixels.

    Parameters
    ----------
    blue, nir, swir : arrays
        Signals (DN above the dark level, :func:`signal`) of the blue, NIR and SWIR ranges.
    ratio : array
        The boresight ratio (DN, Eq. 3) of the same pixels.
    valid : bool array, optional
    dark : DarkLevels
        The instruments' dark levels (what the signals are above).
    table : ClassTable
        The class table to scale (Table 2 by default in the operation).
    offset : (float, float)
        Boresight offset, SWIR minus VNIR position (px), along- and across-track.
    core : float
        Core-shadow darkness (natural log of the signal over its sunlit mode), < 0.
    long_swir : array, optional
        The long-SWIR signal (:data:`~geoboresight.shadow.context.LONG_SWIR_NM`) of the same
        pixels, for the sunlit tilt (:func:`~geoboresight.shadow.context.sunlit_tilt_level`).

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
    tilt = math.nan if long_swir is None else sunlit_tilt_level(swir, long_swir, ok & (d > core))
    return SceneCalibration(
        dark=dark,
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
        tilt_level=tilt,
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
    return unmix_edges(d, ok, core_px, edge_pixels, window)


def unmix_edges(d, ok, core_px, edge_pixels, window, *, allowed=None, whole=None) -> np.ndarray:
    """Shadow fraction from the darkness ``d`` (float) where ``ok`` and the shadow's pixels
    ``core_px``: these at least 0.5 (only those of ``whole`` when given; the others get their
    unmixed fraction), pixels within ``edge_pixels`` of them unmixed between the local sunlit
    and shadow signals (``exp(d)``: means over ``window + 2`` and ``window`` pixels), 0
    elsewhere and outside ``allowed``; NaN where not ``ok``. The one unmixing of the spectral
    estimate (:func:`shadow_fraction_estimate`) and of the surface prior's refinement
    (:func:`geoboresight.shadow.prior.dsm_shadow_fraction`)."""
    from scipy import ndimage

    f = np.zeros(d.shape, np.float64)
    if core_px.any():
        s = np.exp(np.where(ok, d, 0.0))
        zone = (
            ndimage.binary_dilation(core_px, iterations=int(edge_pixels))
            if edge_pixels
            else core_px
        )
        lit = local_mean(s, ok & ~zone, window + 2)
        fallback = local_mean(s, ok & ~core_px, window)
        lit = np.where(np.isfinite(lit), lit, fallback)
        shade = local_mean(s, core_px, window)
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


def nir_darkness(nir: np.ndarray, calibration: SceneCalibration, valid=None) -> np.ndarray:
    """How far below its sunlit mode the NIR signal is (``max(ln(nir / nir mode), …)``
    negated, ≥ 0; NaN where invalid): shadow evidence on the VNIR's own grid, without the
    SWIR's resampling by the boresight offset and its relief parallax."""
    return _where_valid(-np.minimum(_over_mode(nir, calibration.nir_mode), 0.0), valid)


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
