"""The boresight indicator made physical, and the detectability of a scene.

The paper's indicator (Eq. 3, :mod:`.indicator`) takes the ratio b(1010)/b(920) of raw DN and
scores it two-sided against the whole scene. Three things hide a sub-pixel target there:

* with the dark offsets in, brightness texture leaks into the ratio:
  Δln r ≈ (η_s − η_v)·Δk, η each band's share of signal above its dark level, Δk a change of
  brightness;
* a grey target (same relative contrast c in both bands) changes the *co-registered* log ratio
  not at all: it only shows through the boresight offset δ, as a dipole, −f·c at its VNIR pixel
  p and +f·c spread over the SWIR pixels around p + δ (f its fill fraction);
* the offset turns every edge of the scene into such a dipole too (clutter).

The physical indicator therefore works on the log ratio of *dark-corrected* band means
(VNIR 900–975 nm, SWIR 1,000–1,100 nm; :data:`VNIR_NM`, :data:`SWIR_NM`),

    y = ln(S̄ − d_s) − ln(V̄ − d_v),

applies the filter matched to the dipole along δ,

    D(p) = y(p) − y(p + δ)          (y at p + δ interpolated bilinearly),

which adds the two lobes: a target of fill f and contrast c (negative: darker) gives
E[D(p)] = −f·c·‖e₀ − w‖², w the bilinear weights of p + δ over the pixels around p
(:func:`dipole_gain`: 2 for an integer offset, 1.745 for 1.15 px, 0.5 for 0.5 px, 0 for no
offset: at zero offset a grey target leaves no trace in any ratio), and removes the local
background: z = (D − median) / (1.4826 · MAD), both over a ``window`` × ``window``
neighbourhood (:func:`local_z`), so that a target on quiet open ground is scored against its
own surroundings rather than against the scene's edges. One-sided when the target's sign is
known: "darker" targets give D > 0, "brighter" ones D < 0.

Detectability. For a target of fill fraction f and relative contrast c (its signal above dark
is (1 + c) times the background's), the expected separation of the best linear statistic, in
units of the background's spread, is

* spectral (RX, SVDD), a = m − d the scene mean above the dark levels, Σ the scene covariance
  (noise *and* clutter): d′ = f·|c|·√(Σ_b a_b² (Σ⁻¹)_bb) for a target whose contrast has a
  spectral shape unlike the background's, and f·|c|·√(aᵀ Σ⁻¹ a) for a grey one, whose change
  lies along brightness, the clutter's own direction (:func:`spectral_dprime`);
* dipole indicator: d′ = f·|c|·‖e₀ − w‖² / σ_D, σ_D the median local spread of D
  (:func:`dipole_dprime`);
* Eq. 3 ratio at the VNIR pixel: d′ = f·|c|·|η_v − w₀·η_s| / σ_ln r (:func:`eq3_dprime`).

Below :data:`DPRIME_MIN` (3) no detector can flag such targets at useful false-alarm rates; the
operations say so.

References
----------
Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eq. 3, Figure 11D).
Kay, S.M. Fundamentals of Statistical Signal Processing, Vol. II: Detection Theory.
Prentice Hall, 1998 (§4.3: the deflection d′² = ΔᵀΣ⁻¹Δ of the matched filter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

#: VNIR and SWIR band ranges (nm) whose dark-corrected means form the log ratio.
VNIR_NM = (900.0, 975.0)
SWIR_NM = (1000.0, 1100.0)
#: Local background window of D (pixels, odd): wider than the dipole, narrow enough to follow
#: the clutter's changes (open ground against edges).
WINDOW = 7
#: Smallest local spread of D (log-ratio units, 0.01 %): where more than half a window is
#: nodata its median absolute deviation can vanish; no sensor's ratio is that quiet.
SIGMA_FLOOR = 1e-4
#: Target sign: "unknown" scores |z|; "darker" z (D > 0); "brighter" −z.
SIGNS = ("unknown", "darker", "brighter")
#: Typical sub-pixel target: 9 % of a pixel, 30 % contrast.
TARGET_FRACTION = 0.09
TARGET_CONTRAST = 0.3
#: Below this d′ a detector cannot separate such targets from the background.
DPRIME_MIN = 3.0


@dataclass(frozen=True)
class Detectability:
    """The target a scene's detectability is computed for: ``target_fraction`` of a pixel
    filled (0–1], ``target_contrast`` its signal above dark relative to the background's
    minus 1 (−0.3: 30 % darker; the sign does not change d′).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Detectability()  # the target whose expected d′ an anomaly operation reports
    Detectability(target_fraction=0.09, target_contrast=0.3)
    """

    target_fraction: float = TARGET_FRACTION
    target_contrast: float = TARGET_CONTRAST


def check_target(det: Detectability) -> None:
    if not 0 < det.target_fraction <= 1:
        raise ParameterError(
            f"parameter 'target_fraction' must be in (0, 1], got {det.target_fraction}"
        )
    if not (math.isfinite(det.target_contrast) and det.target_contrast != 0):
        raise ParameterError(
            f"parameter 'target_contrast' must be a non-zero number, got {det.target_contrast}"
        )


def check_sign(sign: str) -> None:
    if sign not in SIGNS:
        raise ParameterError(
            f"parameter 'target_sign' must be one of {', '.join(SIGNS)}, got {sign!r}"
        )


def lobe_weights(along: float, across: float) -> dict[tuple[int, int], float]:
    """Bilinear weights of the point p + δ over the pixels around p: ``{(dr, dc): w}``."""
    r0, c0 = math.floor(along), math.floor(across)
    fr, fc = along - r0, across - c0
    out: dict[tuple[int, int], float] = {}
    for dr, wr in ((r0, 1 - fr), (r0 + 1, fr)):
        for dc, wc in ((c0, 1 - fc), (c0 + 1, fc)):
            if wr * wc > 0:
                out[(dr, dc)] = out.get((dr, dc), 0.0) + wr * wc
    return out


def dipole_gain(along: float, across: float) -> float:
    """‖e₀ − w‖²: the dipole filter's response to a grey target of unit f·|c| at its VNIR pixel
    (w: :func:`lobe_weights`)."""
    w = lobe_weights(along, across)
    w0 = w.get((0, 0), 0.0)
    return 1.0 - 2.0 * w0 + sum(v * v for v in w.values())


def log_ratio(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    vnir_dark: float,
    swir_dark: float,
) -> tuple[np.ndarray, np.ndarray]:
    """``(y, ok)``: y = ln(S̄ − d_s) − ln(V̄ − d_v) of the band means, NaN (and ok False) where
    a mean is at or below its dark level, not finite, or not valid."""
    v = np.asarray(vnir, np.float64) - vnir_dark
    s = np.asarray(swir, np.float64) - swir_dark
    ok = np.isfinite(v) & np.isfinite(s) & (v > 0) & (s > 0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    y = np.full(v.shape, np.nan)
    y[ok] = np.log(s[ok]) - np.log(v[ok])
    return y, ok


def dipole(
    y: np.ndarray, ok: np.ndarray, *, along: float, across: float
) -> tuple[np.ndarray, np.ndarray]:
    """``(D, ok)``: the log ratio ``y`` minus itself at p + δ (bilinear,
    :func:`geoboresight.sensor.coregister.coregister` with order 1): the filter matched to a
    grey target's dipole, which adds its two lobes."""
    from ..sensor.coregister import coregister

    shifted, sok = coregister(y, along, across, ok, order=1)
    good = ok & sok
    return np.where(good, y - shifted.astype(np.float64), np.nan), good


def local_z(
    d: np.ndarray, ok: np.ndarray, *, window: int = WINDOW
) -> tuple[np.ndarray, np.ndarray]:
    """``(z, σ)``: D against its local background, z = (D − med_W D) / σ_W with σ_W = 1.4826 ×
    the local median absolute deviation, both over a ``window`` × ``window`` neighbourhood
    (invalid pixels count as D = 0, edges mirrored). A target is scored against the clutter
    around it, not the scene's: open ground is quiet, edges are loud. NaN where not ok."""
    from scipy import ndimage

    dd = np.where(ok, d, 0.0)
    med = ndimage.median_filter(dd, size=window, mode="reflect")
    sig = 1.4826 * ndimage.median_filter(np.abs(dd - med), size=window, mode="reflect")
    sig = np.maximum(sig, SIGMA_FLOOR)
    z = np.where(ok, (dd - med) / sig, np.nan)
    return z, np.where(ok, sig, np.nan)


def score_of(z: np.ndarray, sign: str) -> np.ndarray:
    """float32 score of the local z: z ("darker"), −z ("brighter") or |z| ("unknown")."""
    z = np.asarray(z, np.float32)
    return z if sign == "darker" else (-z if sign == "brighter" else np.abs(z))


def halo(along: float, across: float, window: int = WINDOW) -> int:
    """Lines above and below a strip that :func:`physical_indicator` needs for the strip's
    values to equal the whole image's: the dipole's reach, then twice the window's half (the
    local median, then the local median of deviations from it)."""
    return int(math.ceil(abs(along))) + 2 + 2 * (window // 2)


@dataclass(frozen=True)
class PhysicalResult:
    score: np.ndarray  # float32, NaN where invalid
    dipole: np.ndarray  # D, float64, NaN where invalid
    sigma: float  # the median local spread of D (σ_W)
    dprime: float


def physical_indicator(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    vnir_dark: float,
    swir_dark: float,
    along: float,
    across: float,
    window: int = WINDOW,
    sign: str = "unknown",
    target: Detectability = Detectability(),
) -> PhysicalResult:
    """The physical boresight indicator of a whole image (see the module's text).

    Parameters
    ----------
    vnir, swir : 2-D arrays
        The VNIR band mean (900–975 nm) and the SWIR band mean (1,000–1,100 nm), raw DN, on
        the VNIR pixel grid (SWIR as recorded: not co-registered).
    valid : bool array, optional
    vnir_dark, swir_dark : float
        Dark level of each mean (DN of zero signal; 0 for radiance).
    along, across : float
        The boresight offset δ (px): a feature at VNIR (r, c) is at SWIR (r + along, c + across).
    window : int
        Odd local-background window (pixels, ≥ 3) of the median and spread of D.
    sign : {"unknown", "darker", "brighter"}
        The targets' sign at 900–1,100 nm against their background, when known.
    target : Detectability
        The target d′ is computed for.

    Returns
    -------
    PhysicalResult
        ``score`` (local z of D, one- or two-sided), ``dipole`` (D), ``sigma`` (the median
        local spread of D) and the expected ``dprime`` (:func:`dipole_dprime`).

    Raises
    ------
    ParameterError
        For an even or too small window or an unknown sign.
    InputError
        When fewer than 3 pixels are valid.
    """
    check_sign(sign)
    check_window(window)
    y, ok = log_ratio(vnir, swir, valid, vnir_dark=vnir_dark, swir_dark=swir_dark)
    if ok.sum() < 3:
        raise InputError(
            "fewer than 3 pixels above the dark levels: check the dark levels ('vnir_dark', "
            "'swir_dark')",
            params=("vnir_dark", "swir_dark"),
        )
    d, dok = dipole(y, ok, along=along, across=across)
    z, sig = local_z(d, dok, window=window)
    sigma = float(np.median(sig[dok])) if dok.any() else float("nan")
    return PhysicalResult(score_of(z, sign), d, sigma, dipole_dprime(target, along, across, sigma))


def check_window(window: int) -> None:
    if window < 3 or window % 2 == 0:
        raise ParameterError(f"parameter 'window' must be odd and at least 3, got {window}")


# ------------------------------------------------------------------------------- detectability


def dipole_dprime(target: Detectability, along: float, across: float, sigma: float) -> float:
    """Expected d′ of the dipole statistic: f·|c|·‖e₀ − w‖² / σ_D."""
    if not sigma > 0:
        return 0.0
    return target.target_fraction * abs(target.target_contrast) * dipole_gain(along, across) / sigma


def eq3_dprime(
    target: Detectability, eta_vnir: float, eta_swir: float, w0: float, sigma_log: float
) -> float:
    """Expected d′ of the Eq. 3 ratio at a grey target's VNIR pixel: f·|c|·|η_v − w₀·η_s| /
    σ_ln r (η: each band's share of signal above dark; w₀ the SWIR lobe's weight on the VNIR
    pixel; σ_ln r the robust spread of the (residual) log ratio)."""
    if not sigma_log > 0:
        return 0.0
    return (
        target.target_fraction
        * abs(target.target_contrast)
        * abs(eta_vnir - w0 * eta_swir)
        / sigma_log
    )


def spectral_dprime(
    mean: np.ndarray,
    cov: np.ndarray,
    dark: np.ndarray | float,
    target: Detectability,
    *,
    shape: str = "spectral",
) -> float:
    """Expected d′ of the matched filter (the best linear statistic) for a target of fill f
    and contrast c, under the scene's covariance Σ (noise and clutter), a = m − d the scene's
    mean signal above dark:

    * ``shape="grey"``: the target changes every band by c (Δ = f·c·a, the direction of
      brightness, which is also the clutter's): d′ = f·|c|·√(aᵀ Σ⁻¹ a);
    * ``shape="spectral"`` (default): the target differs by ±c per band in a shape unrelated
      to the background's (Δ_b = f·c·a_b·s_b, s_b = ±1 at random); the mean of d′² over the
      shapes gives d′ = f·|c|·√(Σ_b a_b² (Σ⁻¹)_bb).

    Σ⁻¹ by Cholesky; a singular covariance gives the pseudo-inverse's value."""
    a = np.asarray(mean, np.float64) - np.asarray(dark, np.float64)
    cov = np.atleast_2d(np.asarray(cov, np.float64))
    try:
        L = np.linalg.cholesky(cov)
        inv = np.linalg.solve(L.T, np.linalg.solve(L, np.eye(len(a))))
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(cov)
    if shape == "grey":
        q = float(a @ inv @ a)
    elif shape == "spectral":
        q = float(np.sum(a * a * np.diag(inv)))
    else:
        raise ParameterError(f"shape must be 'grey' or 'spectral', got {shape!r}")
    return target.target_fraction * abs(target.target_contrast) * math.sqrt(max(q, 0.0))


def describe(name: str, dprime: float, target: Detectability) -> tuple[str, bool]:
    """(message, low): the log line of a detector's detectability, and whether it is below
    :data:`DPRIME_MIN`."""
    low = not dprime >= DPRIME_MIN
    msg = (
        f"{name}: expected d′ {dprime:.2f} for a target filling {target.target_fraction:g} of a "
        f"pixel with contrast {target.target_contrast:+g} (measured noise and clutter)"
    )
    if low:
        msg += (
            f"; WARNING: below {DPRIME_MIN:g}, such targets cannot be told from the background "
            "at useful false-alarm rates"
        )
    return msg, low


@dataclass(frozen=True)
class Dipole:
    """How the physical indicator scores the dipole (docs/anomaly.md): one-sided by
    ``target_sign`` where known, against the median and spread of an odd ``dipole_window``
    neighbourhood, along the boresight offset (``offset_along``, ``offset_across`` px; both
    None: measured).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Dipole()  # a target brighter or darker than its ground, the offset measured
    Dipole(target_sign='unknown', dipole_window=7, offset_along=None, offset_across=None)
    """

    target_sign: str = "unknown"
    dipole_window: int = WINDOW
    offset_along: float | None = None
    offset_across: float | None = None
