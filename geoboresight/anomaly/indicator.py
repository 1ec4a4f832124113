"""The boresight band ratio as a sub-pixel anomaly indicator (paper §3.3, Figure 11D).

A sub-pixel target changes the VNIR and the SWIR pixel that see it differently (the two lines of
sight are offset by a fraction of a pixel, and the target's spectrum differs from its
surroundings), so the boresight ratio b(1010 nm)/b(920 nm) of that pixel stands out from the
scene's distribution. The paper classifies the ratio "pixel by pixel"; here that is a robust
z-score against the scene's own distribution,

    z = (r − median(r)) / (1.4826 · MAD(r)),

where MAD is the median absolute deviation (``scipy.stats.median_abs_deviation`` with
``scale="normal"``: 1.4826·MAD estimates σ for Gaussian data without being pulled by the
anomalies themselves), and pixels with |z| (or z, or −z) above a threshold
are flagged. The threshold default 3 follows the paper's 3σ outlier rule (Table 1).

With ``window`` > 1 the reference is local: ``r`` minus the median of the ratio in a
``window`` × ``window`` neighbourhood, scaled by the scene-wide MAD of that difference. A
sub-pixel target shifts the ratio by much less than the difference between materials (soil,
grass, trees), so against the whole scene it hides in the spread of the background; against
its neighbours it stands out.

Streamed over a flight line, the scene's median and MAD come from a first pass
(:func:`robust_location` of the valid values), then each strip is scored with
:func:`indicator_score` (and :func:`local_residual`, given ``window // 2`` lines of halo and the
scene's median as ``fill``): the same numbers as :func:`boresight_indicator` on the whole image.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

TAILS = ("both", "high", "low")
#: Anomaly threshold on the robust z-score (the paper's 3σ rule, Table 1).
THRESHOLD = 3.0


@dataclass(frozen=True)
class IndicatorResult:
    score: np.ndarray  # float32 anomaly score (|z|, z or −z), NaN where invalid
    anomalies: np.ndarray  # bool, score > threshold
    median: float
    sigma: float  # 1.4826 · MAD
    threshold: float
    count: int


def check_options(threshold: float = THRESHOLD, tail: str = "both", window: int = 0) -> None:
    """Raise :class:`ParameterError` for a threshold ≤ 0, an unknown tail or an even window."""
    if window and window > 1 and window % 2 == 0:
        raise ParameterError(f"parameter 'window' must be odd, got {window}")
    if tail not in TAILS:
        raise ParameterError(f"parameter 'tail' must be one of {', '.join(TAILS)}, got {tail!r}")
    if not threshold > 0:
        raise ParameterError(f"parameter 'threshold' must be > 0, got {threshold}")


def robust_location(values: np.ndarray) -> tuple[float, float]:
    """(median, σ = 1.4826·MAD) of a 1-D array of valid values (the standard deviation when
    more than half of them share one value); :func:`robust_location_blocks` of one block."""
    vals = np.asarray(values, dtype=np.float64)
    return robust_location_blocks(lambda: iter((vals,)))


def robust_location_blocks(blocks: Callable[[], Iterator[np.ndarray]]) -> tuple[float, float]:
    """(median, σ = 1.4826·MAD) of a stream of valid values, exact, in bounded memory.

    Equal to ``np.median`` and ``scipy.stats.median_abs_deviation(scale="normal")`` of all the
    values, without holding them: five passes over ``blocks`` (count and extremes, then the
    median and the median absolute deviation as exact order statistics,
    :func:`geoboresight.stats.order_statistics`). When more than half the values share one value
    (MAD 0), σ is their standard deviation.

    Parameters
    ----------
    blocks : callable returning an iterator of 1-D float arrays
        Called once per pass; yields the valid values of each block.

    Returns
    -------
    (float, float)
        The median and σ.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11D).
    Rousseeuw, P.J.; Croux, C. Alternatives to the median absolute deviation. J. Am. Stat. Assoc.
    1993, 88, 1273–1283 (1.4826 · MAD as a consistent estimate of σ).
    """
    from scipy.special import ndtri

    from ..stats import Moments, median_blocks

    m = Moments()
    for v in blocks():
        m = m.merge(Moments.of(np.asarray(v, dtype=np.float64)))
    if m.n < 3:
        raise InputError(f"only {m.n} valid ratio pixel(s): the indicator needs a scene")
    med = median_blocks(blocks, n=m.n, lo=m.minimum, hi=m.maximum)

    def deviations():
        return (np.abs(np.asarray(v, dtype=np.float64) - med) for v in blocks())

    spread = max(m.maximum - med, med - m.minimum)
    # scipy's scale="normal": MAD divided by the standard normal's 75 % quantile.
    sigma = median_blocks(deviations, n=m.n, lo=0.0, hi=spread) / float(ndtri(0.75))
    if sigma <= 0:
        # More than half the pixels share one value: fall back on the standard deviation.
        sigma = math.sqrt(m.m2 / m.n)
        if sigma <= 0:
            raise InputError("the boresight ratio is constant over the scene: nothing stands out")
    return med, sigma


def _ok(r: np.ndarray, valid: np.ndarray | None) -> np.ndarray:
    return np.isfinite(r) if valid is None else (valid & np.isfinite(r))


def valid_values(ratio: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
    """The valid, finite values of a ratio array (1-D): float32 as they are (half the memory
    of a statistic's kept values, the same numbers once widened), any other type as float64."""
    r = np.asarray(ratio)
    if r.dtype != np.float32:
        r = r.astype(np.float64)
    return r[_ok(r, valid)]


def indicator_score(
    ratio: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    median: float,
    sigma: float,
    tail: str = "both",
) -> np.ndarray:
    """float32 score of a ratio (or residual) array against ``median`` and ``sigma``: |z|
    (tail "both"), z ("high") or −z ("low"); NaN where not valid."""
    r = np.asarray(ratio, dtype=np.float64)
    ok = _ok(r, valid)
    z = np.full(r.shape, np.nan, dtype=np.float32)
    z[ok] = (r[ok] - median) / sigma
    return np.abs(z) if tail == "both" else (z if tail == "high" else -z)


def robust_zscore(ratio: np.ndarray, valid: np.ndarray | None = None):
    """(z float32 with NaN where invalid, median, 1.4826·MAD) of a ratio image."""
    med, sigma = robust_location(valid_values(ratio, valid))
    return indicator_score(ratio, valid, median=med, sigma=sigma, tail="high"), med, sigma


def local_residual(
    ratio: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    window: int,
    fill: float | None = None,
) -> np.ndarray:
    """``ratio`` minus its median over a ``window`` × ``window`` neighbourhood; NaN where not
    valid. Invalid pixels enter the median filter as ``fill`` (default: the median of the
    array's valid values; give the scene's median when filtering a strip)."""
    from scipy import ndimage

    r = np.asarray(ratio, dtype=np.float64)
    ok = _ok(r, valid)
    if fill is None:
        fill = float(np.median(r[ok])) if ok.any() else 0.0
    med = ndimage.median_filter(np.where(ok, r, fill), size=window, mode="reflect")
    return np.where(ok, r - med, np.nan)


def boresight_indicator(
    ratio: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    threshold: float = THRESHOLD,
    tail: str = "both",
    window: int = 0,
) -> IndicatorResult:
    """Score and flag boresight-ratio anomalies of a whole image.

    ``tail``: "both" scores |z|, "high" scores z (ratio above the reference), "low" scores −z.
    ``window``: 0 or 1 for the scene-wide reference; an odd size (e.g. 5) for a local median.

    Parameters
    ----------
    ratio : array
        Boresight ratio b(1010 nm)/b(920 nm) (Eq. 3, e.g. from
        :func:`~geoboresight.ratio.boresight_ratio`); non-finite values are invalid.
    valid : bool array, optional
        Pixels to score (same shape as ``ratio``).
    threshold : float
        Score above which a pixel is flagged (> 0; default 3, the 3σ rule).
    tail : {"both", "high", "low"}
        Which side of the reference is anomalous.
    window : int
        0 or 1: the scene's median is the reference; an odd size > 1: the median of a
        ``window`` × ``window`` neighbourhood, ``ratio`` being replaced by its residual.

    Returns
    -------
    IndicatorResult
        ``score`` (float32 robust z-score |z|, z or −z; NaN where not valid), ``anomalies``
        (bool, score > threshold), the ``median`` and ``sigma`` (1.4826·MAD, or the standard
        deviation when the MAD is 0) of the ratio (of its residual with ``window``), the
        ``threshold`` and the ``count`` of flagged pixels.

    Raises
    ------
    ParameterError
        When ``threshold`` ≤ 0, ``tail`` is unknown or ``window`` is even.
    InputError
        When fewer than 3 pixels are valid or the ratio is constant.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3: the boresight band
    ratio as an anomaly indicator, Figure 11(D), compared in Figure 12; the 3σ outlier rule of
    §2 and Table 1).
    Hampel, F.R. The influence curve and its role in robust estimation. J. Am. Stat. Assoc.
    1974, 69, 383–393.
    """
    check_options(threshold, tail, window)
    if window and window > 1:
        ratio = local_residual(ratio, valid, window=window)
    med, sigma = robust_location(valid_values(ratio, valid))
    score = indicator_score(ratio, valid, median=med, sigma=sigma, tail=tail)
    with np.errstate(invalid="ignore"):
        flags = score > threshold
    return IndicatorResult(score, flags, med, sigma, float(threshold), int(flags.sum()))


@dataclass(frozen=True)
class Eq3Reference:
    """What the paper's Eq. 3 z-score compares a pixel's ratio with: the whole scene
    (``window`` 0) or the median of its odd ``window`` × ``window`` neighbourhood, and which
    ``tail`` is anomalous ("both", "high", "low").

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Eq3Reference()  # both tails of the ratio, against the whole scene
    Eq3Reference(tail='both', window=0)
    >>> gb.Eq3Reference(tail="high", window=31)  # --tail high --window 31
    Eq3Reference(tail='high', window=31)
    """

    tail: str = "both"
    window: int = 0
