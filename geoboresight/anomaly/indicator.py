"""The boresight band ratio as a sub-pixel anomaly indicator (paper §3.3, Figure 11D).

A sub-pixel target changes the VNIR and the SWIR pixel that see it differently (the two lines of
sight are offset by a fraction of a pixel, and the target's spectrum differs from its
surroundings), so the boresight ratio b(1010 nm)/b(920 nm) of that pixel stands out from the
scene's distribution. The paper classifies the ratio "pixel by pixel"; here that is a robust
z-score against the scene's own distribution,

    z = (r − median(r)) / (1.4826 · MAD(r)),

where MAD is the median absolute deviation (1.4826·MAD estimates σ for Gaussian data without
being pulled by the anomalies themselves), and pixels with |z| (or z, or −z) above a threshold
are flagged. The threshold default 3 follows the paper's 3σ outlier rule (Table 1).

With ``window`` > 1 the reference is local: ``r`` minus the median of the ratio in a
``window`` × ``window`` neighbourhood, scaled by the scene-wide MAD of that difference. A
sub-pixel target shifts the ratio by much less than the difference between materials (soil,
grass, trees), so against the whole scene it hides in the spread of the background; against
its neighbours it stands out.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

MAD_TO_SIGMA = 1.4826
TAILS = ("both", "high", "low")


@dataclass(frozen=True)
class IndicatorResult:
    score: np.ndarray  # float32 anomaly score (|z|, z or −z), NaN where invalid
    anomalies: np.ndarray  # bool, score > threshold
    median: float
    sigma: float  # 1.4826 · MAD
    threshold: float
    count: int


def robust_zscore(ratio: np.ndarray, valid: np.ndarray | None = None):
    """(z float32 with NaN where invalid, median, 1.4826·MAD) of a ratio image."""
    r = np.asarray(ratio, dtype=np.float64)
    ok = np.isfinite(r) if valid is None else (valid & np.isfinite(r))
    vals = r[ok]
    if vals.size < 3:
        raise InputError(f"only {vals.size} valid ratio pixel(s): the indicator needs a scene")
    med = float(np.median(vals))
    sigma = MAD_TO_SIGMA * float(np.median(np.abs(vals - med)))
    if sigma <= 0:
        # More than half the pixels share one value: fall back on the standard deviation.
        sigma = float(vals.std())
        if sigma <= 0:
            raise InputError("the boresight ratio is constant over the scene: nothing stands out")
    z = np.full(r.shape, np.nan, dtype=np.float32)
    z[ok] = (vals - med) / sigma
    return z, med, sigma


def local_residual(ratio: np.ndarray, valid: np.ndarray | None, window: int) -> np.ndarray:
    """``ratio`` minus its median over a ``window`` × ``window`` neighbourhood of valid pixels."""
    from scipy import ndimage

    r = np.asarray(ratio, dtype=np.float64)
    ok = np.isfinite(r) if valid is None else (valid & np.isfinite(r))
    fill = float(np.median(r[ok])) if ok.any() else 0.0
    med = ndimage.median_filter(np.where(ok, r, fill), size=window, mode="reflect")
    return np.where(ok, r - med, np.nan)


def boresight_indicator(
    ratio: np.ndarray,
    valid: np.ndarray | None = None,
    threshold: float = 3.0,
    tail: str = "both",
    window: int = 0,
) -> IndicatorResult:
    """Score and flag boresight-ratio anomalies.

    ``tail``: "both" scores |z|, "high" scores z (ratio above the reference), "low" scores −z.
    ``window``: 0 or 1 for the scene-wide reference; an odd size (e.g. 5) for a local median.
    """
    if window and window > 1:
        if window % 2 == 0:
            raise ParameterError(f"parameter 'window' must be odd, got {window}")
        ratio = local_residual(ratio, valid, window)
    if tail not in TAILS:
        raise ParameterError(f"parameter 'tail' must be one of {', '.join(TAILS)}, got {tail!r}")
    if not threshold > 0:
        raise ParameterError(f"parameter 'threshold' must be > 0, got {threshold}")
    z, med, sigma = robust_zscore(ratio, valid)
    score = np.abs(z) if tail == "both" else (z if tail == "high" else -z)
    with np.errstate(invalid="ignore"):
        flags = score > threshold
    return IndicatorResult(score, flags, med, sigma, float(threshold), int(flags.sum()))
