"""Descriptive statistics as SPSS reports them (Brook & Ben-Dor 2011, Table 1 and Figure 3).

Exact for rasters of any length: moments are accumulated block by block and merged with the
pairwise update formulas of Pébay (2008, Sandia report SAND2008-6212), which are exact in exact
arithmetic (float64 here); outlier counts and the histogram take a second pass; percentiles are
exact order statistics found with a fine histogram (second pass) and the values of the few bins
that hold them (third pass). Memory is bounded by one block.

Definitions (SPSS "Descriptives"/"Frequencies", identical to ``scipy.stats`` with
``bias=False``): with central sums M_k = Σ(x − x̄)^k,

- variance s² = M₂/(n−1); SE of the mean = s/√n;
- skewness G₁ = √(n(n−1))/(n−2) · g₁, g₁ = √n·M₃/M₂^{3/2}; its SE =
  √(6n(n−1)/((n−2)(n+1)(n+3))) — 0.153 for the paper's N = 255;
- kurtosis (excess) G₂ = ((n+1)g₂ + 6)(n−1)/((n−2)(n−3)), g₂ = n·M₄/M₂² − 3; its SE =
  2·SE(G₁)·√((n²−1)/((n−3)(n+5)));
- z = statistic / SE, two-sided p from the standard normal (the paper's z test of skewness).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import asdict, dataclass, field

import numpy as np

from .errors import InputError
from .progress import Progress, as_progress

DEFAULT_PERCENTILES = (1.0, 5.0, 25.0, 50.0, 75.0, 95.0, 99.0)
_FINE_BINS = 65536
#: Most values :func:`order_statistics` gathers from one histogram bin (8 MB of float64).
MAX_HELD = 1 << 20


@dataclass
class Moments:
    """Count, mean and central sums M₂..M₄ of a stream of values, mergeable (Pébay 2008)."""

    n: int = 0
    mean: float = 0.0
    m2: float = 0.0
    m3: float = 0.0
    m4: float = 0.0
    minimum: float = math.inf
    maximum: float = -math.inf

    @classmethod
    def of(cls, values: np.ndarray) -> Moments:
        v = np.asarray(values, dtype="float64").ravel()
        if v.size == 0:
            return cls()
        mean = float(v.mean())
        d = v - mean
        d2 = d * d
        return cls(
            n=int(v.size),
            mean=mean,
            m2=float(d2.sum()),
            m3=float((d2 * d).sum()),
            m4=float((d2 * d2).sum()),
            minimum=float(v.min()),
            maximum=float(v.max()),
        )

    def merge(self, other: Moments) -> Moments:
        """The moments of the union of both samples."""
        if other.n == 0:
            return self
        if self.n == 0:
            return other
        na, nb = self.n, other.n
        n = na + nb
        delta = other.mean - self.mean
        d_n = delta / n
        m2 = self.m2 + other.m2 + delta * d_n * na * nb
        m3 = (
            self.m3
            + other.m3
            + delta * d_n * d_n * na * nb * (na - nb)
            + 3.0 * d_n * (na * other.m2 - nb * self.m2)
        )
        m4 = (
            self.m4
            + other.m4
            + delta * d_n**3 * na * nb * (na * na - na * nb + nb * nb)
            + 6.0 * d_n * d_n * (na * na * other.m2 + nb * nb * self.m2)
            + 4.0 * d_n * (na * other.m3 - nb * self.m3)
        )
        return Moments(
            n=n,
            mean=self.mean + d_n * nb,
            m2=m2,
            m3=m3,
            m4=m4,
            minimum=min(self.minimum, other.minimum),
            maximum=max(self.maximum, other.maximum),
        )


def se_skewness(n: int) -> float:
    """SPSS standard error of skewness: √(6n(n−1)/((n−2)(n+1)(n+3)))."""
    if n < 3:
        return math.nan
    return math.sqrt(6.0 * n * (n - 1) / ((n - 2) * (n + 1) * (n + 3)))


def se_kurtosis(n: int) -> float:
    """SPSS standard error of kurtosis: 2·SE(skew)·√((n²−1)/((n−3)(n+5)))."""
    if n < 4:
        return math.nan
    return 2.0 * se_skewness(n) * math.sqrt((n * n - 1.0) / ((n - 3) * (n + 5)))


@dataclass(frozen=True)
class Descriptives:
    """Table 1 of the paper, plus kurtosis, percentiles, 3σ outliers and a histogram."""

    n: int
    mean: float
    se_mean: float
    std: float
    variance: float
    skewness: float
    se_skewness: float
    z_skewness: float
    p_skewness: float
    kurtosis: float
    se_kurtosis: float
    z_kurtosis: float
    p_kurtosis: float
    minimum: float
    maximum: float
    percentiles: dict[str, float]
    n_outliers_3sd: int
    fraction_outliers_3sd: float
    histogram_counts: list[int] = field(repr=False)
    histogram_edges: list[float] = field(repr=False)

    def to_dict(self) -> dict:
        return asdict(self)


def _two_sided_p(z: float) -> float:
    """Two-sided p of a standard normal z: 2·(1 − Φ(|z|)) = erfc(|z|/√2)."""
    return math.erfc(abs(z) / math.sqrt(2.0))


def _from_moments(m: Moments) -> dict:
    n = m.n
    var = m.m2 / (n - 1) if n > 1 else math.nan
    std = math.sqrt(var) if n > 1 else math.nan
    if n > 2 and m.m2 > 0:
        g1 = math.sqrt(n) * m.m3 / m.m2**1.5
        skew = g1 * math.sqrt(n * (n - 1)) / (n - 2)
    else:
        skew = math.nan
    if n > 3 and m.m2 > 0:
        g2 = n * m.m4 / (m.m2 * m.m2) - 3.0
        kurt = ((n + 1) * g2 + 6.0) * (n - 1) / ((n - 2) * (n - 3))
    else:
        kurt = math.nan
    se_s, se_k = se_skewness(n), se_kurtosis(n)
    z_s, z_k = skew / se_s, kurt / se_k
    return {
        "n": n,
        "mean": m.mean,
        "se_mean": std / math.sqrt(n) if n > 1 else math.nan,
        "std": std,
        "variance": var,
        "skewness": skew,
        "se_skewness": se_s,
        "z_skewness": z_s,
        "p_skewness": _two_sided_p(z_s) if math.isfinite(z_s) else math.nan,
        "kurtosis": kurt,
        "se_kurtosis": se_k,
        "z_kurtosis": z_k,
        "p_kurtosis": _two_sided_p(z_k) if math.isfinite(z_k) else math.nan,
        "minimum": m.minimum,
        "maximum": m.maximum,
    }


def _fine_bin(v: np.ndarray, lo: float, hi: float) -> np.ndarray:
    # One binning function for every pass, so all passes agree on every value's bin.
    if hi <= lo:
        return np.zeros(v.shape, dtype=np.int64)
    # Clip before the cast: far outside a narrow range, the float index overflows int64.
    idx = np.clip((v - lo) * (_FINE_BINS / (hi - lo)), 0, _FINE_BINS - 1)
    return idx.astype(np.int64)


def fine_histogram(values: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Counts of ``values`` in the fine bins of ``[lo, hi]`` that :func:`order_statistics` uses
    (values outside the range fall into the end bins)."""
    v = np.asarray(values, dtype="float64")
    return np.bincount(_fine_bin(v, lo, hi), minlength=_FINE_BINS)


@dataclass
class _Cell:
    """The stream's values in bin ``b`` of range ``(lo, hi)`` at every level of ``chain``:
    ``size`` values, ``below`` of the stream's values before them, ranks ``ranks`` among them."""

    chain: tuple[tuple[float, float, int], ...]
    below: int
    size: int
    ranks: list[int]
    value: float | None = None  # set when every member is the same value

    def members(self, v: np.ndarray) -> np.ndarray:
        keep = np.ones(v.shape, dtype=bool)
        for lo, hi, b in self.chain:
            keep &= _fine_bin(v, lo, hi) == b
        return v[keep]

    def child_range(self) -> tuple[float, float]:
        lo, hi, b = self.chain[-1]
        width = (hi - lo) / _FINE_BINS
        return lo + b * width, lo + (b + 1) * width


def _split(chain, lo, hi, counts, below, ranks) -> list[_Cell]:
    # The bins of (lo, hi) that hold the wanted ranks, as cells one level deeper.
    cum = np.cumsum(counts) + below
    cells: dict[int, _Cell] = {}
    for k in ranks:
        b = int(np.searchsorted(cum, k, side="right"))
        if b not in cells:
            start = int(cum[b - 1]) if b > 0 else below
            cells[b] = _Cell(chain + ((lo, hi, b),), start, int(counts[b]), [])
        cells[b].ranks.append(k)
    return list(cells.values())


def order_statistics(
    blocks: Callable[[], Iterator[np.ndarray]],
    ranks: Iterable[int],
    *,
    lo: float,
    hi: float,
    counts: np.ndarray | None = None,
    max_held: int = MAX_HELD,
    progress: Progress | None = None,
) -> dict[int, float]:
    """Exact order statistics of a stream of values, in memory bounded by ``max_held`` values.

    The ``k``-th smallest value (0-based) for each ``k`` in ``ranks``, equal to
    ``np.sort(all_values)[k]``, found without holding the stream: a fine histogram of
    ``[lo, hi]`` locates the bin of each rank; a bin holding more than ``max_held`` values is
    histogrammed again over its own width (one more pass for all such bins, repeated while
    needed: outliers that stretch ``[lo, hi]`` cost passes, not memory); a last pass gathers the
    values of the located bins and sorts them.

    Parameters
    ----------
    blocks : callable returning an iterator of 1-D float arrays
        Called once per pass; yields the values of each block (valid values only).
    ranks : iterable of int
        0-based ranks, each in ``[0, n)`` for the stream's ``n`` values.
    lo, hi : float
        The stream's minimum and maximum (from a previous pass, e.g. :class:`Moments`).
    counts : int array, optional
        :func:`fine_histogram` of the whole stream over ``[lo, hi]``, if a previous pass made
        it (saves one pass).
    max_held : int
        Most values gathered per located bin before it is split further.

    Returns
    -------
    dict
        ``{k: value}``.

    References
    ----------
    Knuth, D.E. The Art of Computer Programming, vol. 3, 2nd ed., 1998, §5.3.3 (selection);
    the radix-select scheme here needs no more memory than one block and the bins.
    """
    progress = as_progress(progress)
    ranks = sorted({int(k) for k in ranks})
    if counts is None:
        counts = np.zeros(_FINE_BINS, dtype=np.int64)
        for v in blocks():
            counts += fine_histogram(v, lo, hi)
            progress.check()
    n = int(np.sum(counts))
    if ranks and not 0 <= ranks[0] <= ranks[-1] < n:
        raise ValueError(f"ranks must lie in [0, {n}), got {ranks[0]}..{ranks[-1]}")
    cells = _split((), lo, hi, counts, 0, ranks)
    # Split the crowded bins until each holds at most max_held values or a single value. Each
    # level divides a bin's width by _FINE_BINS, so float64 ends this within a few levels.
    for _level in range(8):
        crowded = [c for c in cells if c.size > max_held and c.value is None]
        if not crowded:
            break
        sub = [np.zeros(_FINE_BINS, dtype=np.int64) for _ in crowded]
        extremes = [[math.inf, -math.inf] for _ in crowded]
        for v in blocks():
            v = np.asarray(v, dtype="float64")
            for c, h, ext in zip(crowded, sub, extremes, strict=True):
                m = c.members(v)
                if m.size:
                    h += fine_histogram(m, *c.child_range())
                    ext[0] = min(ext[0], float(m.min()))
                    ext[1] = max(ext[1], float(m.max()))
            progress.check()
        for c, h, ext in zip(crowded, sub, extremes, strict=True):
            cells.remove(c)
            if ext[0] == ext[1]:  # all equal: nothing to split
                c.value = ext[0]
                cells.append(c)
            else:
                cells.extend(_split(c.chain, *c.child_range(), h, c.below, c.ranks))
    # Gather the located bins' values; sort each bin and read the ranks off it.
    open_cells = [c for c in cells if c.value is None]
    held: list[list[np.ndarray]] = [[] for _ in open_cells]
    if open_cells:
        for v in blocks():
            v = np.asarray(v, dtype="float64")
            for c, h in zip(open_cells, held, strict=True):
                m = c.members(v)
                if m.size:
                    h.append(m)
            progress.check()
    out: dict[int, float] = {}
    for c in cells:
        if c.value is not None:
            out.update({k: c.value for k in c.ranks})
    for c, h in zip(open_cells, held, strict=True):
        vals = np.sort(np.concatenate(h))
        out.update({k: float(vals[k - c.below]) for k in c.ranks})
    return out


def median_blocks(
    blocks: Callable[[], Iterator[np.ndarray]], *, n: int, lo: float, hi: float, **options
) -> float:
    """Exact median (``np.median``) of a stream of ``n`` values in ``[lo, hi]``
    (:func:`order_statistics`)."""
    pos = (n - 1) / 2
    ks = {math.floor(pos), math.ceil(pos)}
    got = order_statistics(blocks, ks, lo=lo, hi=hi, **options)
    return (got[math.floor(pos)] + got[math.ceil(pos)]) / 2


def describe_blocks(
    blocks: Callable[[], Iterator[np.ndarray]],
    bins: int = 50,
    percentiles: Iterable[float] = DEFAULT_PERCENTILES,
    progress: Progress | None = None,
    label: str = "the raster",
) -> Descriptives:
    """Exact descriptive statistics of a stream of value blocks.

    Parameters
    ----------
    blocks : callable returning an iterator of 1-D float arrays
        Called once per pass (three passes); yields the valid values of each block.
    bins : int
        Histogram bins between the minimum and the maximum (Figure 3).
    percentiles : iterable of float
        Percentiles (0–100) to report; NumPy's default (linear) definition.
    """
    progress = as_progress(progress)
    qs = [float(q) for q in percentiles]
    # Pass 1: merged moments.
    m = Moments()
    for v in blocks():
        m = m.merge(Moments.of(v))
        progress.check()
    progress.update(1 / 3, "moments")
    if m.n == 0:
        raise InputError(f"{label} has no valid pixels (everything is nodata or non-finite)")
    base = _from_moments(m)
    lo, hi = m.minimum, m.maximum
    # Pass 2: 3σ outliers, display histogram, fine histogram for order statistics.
    counts = np.zeros(bins, dtype=np.int64)
    fine = np.zeros(_FINE_BINS, dtype=np.int64)
    n_out = 0
    std = base["std"]
    for v in blocks():
        v = np.asarray(v, dtype="float64")
        if math.isfinite(std):
            n_out += int(np.count_nonzero(np.abs(v - m.mean) > 3.0 * std))
        counts += np.histogram(v, bins=bins, range=(lo, hi) if hi > lo else (lo - 0.5, lo + 0.5))[0]
        fine += fine_histogram(v, lo, hi)
        progress.check()
    progress.update(2 / 3, "histogram")
    # Ranks needed for NumPy-style linear interpolation: floor and ceil of q/100·(n−1).
    wanted_ranks = set()
    for q in qs:
        pos = q / 100.0 * (m.n - 1)
        wanted_ranks |= {math.floor(pos), math.ceil(pos)}
    # Pass 3: the values of the bins holding those ranks.
    order = order_statistics(blocks, wanted_ranks, lo=lo, hi=hi, counts=fine, progress=progress)
    pct = {}
    for q in qs:
        pos = q / 100.0 * (m.n - 1)
        lo_k, hi_k = math.floor(pos), math.ceil(pos)
        frac = pos - lo_k
        pct[f"p{q:g}"] = order[lo_k] + (order[hi_k] - order[lo_k]) * frac
    progress.update(1.0, "percentiles")
    edges = np.histogram_bin_edges(
        [], bins=bins, range=(lo, hi) if hi > lo else (lo - 0.5, lo + 0.5)
    )
    return Descriptives(
        **base,
        percentiles=pct,
        n_outliers_3sd=n_out,
        fraction_outliers_3sd=n_out / m.n,
        histogram_counts=counts.tolist(),
        histogram_edges=edges.tolist(),
    )


def describe(
    values: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    bins: int = 50,
    percentiles: Iterable[float] = DEFAULT_PERCENTILES,
) -> Descriptives:
    """SPSS-style descriptive statistics of an array (Table 1): :func:`describe_blocks` on one
    block.

    Parameters
    ----------
    values : array
        Any shape; non-finite values are ignored.
    valid : bool array, optional
        Pixels to describe (same shape as ``values``).
    bins : int
        Histogram bins between the minimum and the maximum (Figure 3).
    percentiles : iterable of float
        Percentiles (0–100) to report (NumPy's linear definition).

    Returns
    -------
    Descriptives
        N, mean and its SE, std, variance, skewness and kurtosis with SEs and z tests, 3σ
        outliers, percentiles and the histogram.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (Table 1, Figure 3).
    Pébay, P. Formulas for robust, one-pass parallel computation of covariances and
    arbitrary-order statistical moments. Sandia report SAND2008-6212, 2008.

    Examples
    --------
    >>> import numpy as np
    >>> import geoboresight as gb
    >>> d = gb.describe(np.array([1.0, 2.0, 3.0, 4.0, 10.0]))
    >>> d.n, d.mean, round(d.std, 4), round(d.skewness, 4), round(d.se_skewness, 4)
    (5, 4.0, 3.5355, 1.6971, 0.9129)
    """
    v = np.asarray(values, dtype="float64")
    v = v[valid] if valid is not None else v.ravel()
    v = v[np.isfinite(v)]
    return describe_blocks(lambda: iter([v]), bins=bins, percentiles=percentiles, label="the array")
