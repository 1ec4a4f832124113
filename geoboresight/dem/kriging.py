"""Ordinary kriging of scattered heights onto the image grid, fast and in bounded memory (§3.2).

The paper interpolates the relative DEM by kriging. PyKrige's ordinary kriging builds the full
``N × N`` kriging matrix (and, in its default vectorised mode, an ``N × grid`` distance matrix),
so a flight line with hundreds of thousands of control points does not fit in memory; its
moving-window mode solves one system per pixel, minutes for a flight line. Here:

- the variogram model is fitted once per line, by PyKrige's fitting routine, to the experimental
  variogram of a random subset of the points (``max_fit_points``) with lags up to
  :func:`max_lag` (twice the strip's width: a long line's far pairs say nothing about relief);
- the targets are kriged by *blocks*: every block of targets (about ``BLOCK_PX`` × ``BLOCK_PX``
  pixels of the grid, or a group of nearby scattered targets) shares one neighbourhood, the
  control points nearest its centre within its circumscribed circle widened by the radius that
  holds ``n_closest_points`` (so every target keeps its own nearest points). One
  ordinary-kriging system is solved per block for all of its targets at once (one LU
  factorisation, one matrix product), and the systems of many blocks are solved in one batched
  LAPACK call;
- where the variogram's range is long compared with a pixel, the grid is kriged on nodes every
  ``step`` pixels (:func:`grid_step`: at least ``RANGE_PER_STEP`` nodes per range) and the
  pixels in between are interpolated bilinearly: a kriged surface does not vary at scales far
  below its range.

The kriging system is PyKrige's (``OrdinaryKriging(..., exact_values=False)``: semivariances
with a zero diagonal, the nugget smooths noisy heights; kriging variance ``−xᵀb``), with the
variogram as fitted, ``[psill, range, nugget]``, not handed back to PyKrige as a list: PyKrige
reads a list as ``[sill, range, nugget]``, which would krige with a partial sill of
``psill − nugget``, negative whenever the fitted nugget exceeds the partial sill, and make the
DEM mostly noise (r 0.35, RMSE 15.2 m against the true surface on a 5,000-line simulated line;
r 0.88, RMSE 3.4 m kriged with the fitted model). The tests compare with PyKrige on the same points.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError, ParameterError
from ..progress import Progress, as_progress

MODELS = ("spherical", "exponential", "gaussian", "linear", "power")
#: The variogram model fitted by default.
VARIOGRAM = "spherical"
#: Control points in each local kriging neighbourhood (per target; a block shares twice this).
N_CLOSEST_POINTS = 32
#: Side (pixels) of the blocks of grid targets that share one neighbourhood and one system.
BLOCK_PX = 16
#: At most this many grid nodes along a block's side (a node every pixel: 16 × 16 targets).
MAX_BLOCK_NODES = 16
#: Grid nodes per variogram range at least, when kriging on a coarser grid (:func:`grid_step`).
RANGE_PER_STEP = 40
#: Largest node spacing (pixels) of the kriged grid.
MAX_STEP = 8
#: Kriging systems solved per batched LAPACK call (bounds memory: ≈ 8 · batch · (2n + 1)² bytes).
BATCH = 256


@dataclass(frozen=True)
class Variogram:
    """A fitted PyKrige variogram model (parameters in PyKrige's order)."""

    model: str
    parameters: tuple[float, ...]
    n_points: int  # control points used for the fit

    def describe(self) -> str:
        if self.model in ("linear",):
            names = ("slope", "nugget")
        elif self.model == "power":
            names = ("scale", "exponent", "nugget")
        else:
            names = ("partial_sill", "range_px", "nugget")
        return ", ".join(f"{n}={v:.4g}" for n, v in zip(names, self.parameters, strict=False))

    def __call__(self, d: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
        """Semivariance at distances ``d`` (PyKrige's model functions, vectorised).

        With ``out`` (float64, ``d``'s shape; may be ``d`` itself) the model is evaluated in
        it, operation for operation as PyKrige's formula, without temporaries: kriging builds
        thousands of small systems, and fresh arrays for each step cost more than the
        arithmetic."""
        p = self.parameters
        if out is None:
            v = np.array(d, dtype=np.float64)
        else:
            v = out
            if out is not d:
                np.copyto(out, d)
        if self.model == "linear":  # slope · d + nugget
            v *= p[0]
            v += p[1]
            return v
        if self.model == "power":  # scale · d^exponent + nugget
            np.power(v, p[1], out=v)
            v *= p[0]
            v += p[2]
            return v
        psill, rng, nugget = p
        if self.model == "spherical":  # psill · (1.5 r − 0.5 r³) + nugget, r = min(d / range, 1)
            np.divide(v, rng, out=v)
            np.minimum(v, 1.0, out=v)
            cube = np.multiply(0.5, v)
            cube *= v
            cube *= v
            v *= 1.5
            v -= cube
        elif self.model == "exponential":  # psill · (1 − exp(−d / (range / 3))) + nugget
            np.negative(v, out=v)
            v /= rng / 3.0
            np.exp(v, out=v)
            np.subtract(1.0, v, out=v)
        else:  # gaussian: psill · (1 − exp(−d² / (4 range / 7)²)) + nugget
            np.square(v, out=v)
            np.negative(v, out=v)
            v /= (rng * 4.0 / 7.0) ** 2
            np.exp(v, out=v)
            np.subtract(1.0, v, out=v)
        v *= psill
        v += nugget
        return v

    @property
    def range_px(self) -> float | None:
        """The range (pixels) of a bounded model; None for linear and power."""
        return None if self.model in ("linear", "power") else float(self.parameters[1])


def _check_points(x, y, z):
    """The finite control points, float64 — or float32 when all three are float32 (a flight
    line's points are stored so: memory), without a copy when nothing is dropped."""
    dtype = np.float32 if all(np.asarray(v).dtype == np.float32 for v in (x, y, z)) else np.float64
    x, y, z = (np.asarray(v, dtype).ravel() for v in (x, y, z))
    if not (x.size == y.size == z.size):
        raise InputError("control point coordinates and values differ in length")
    ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(z)
    if ok.all():
        return x, y, z
    return x[ok], y[ok], z[ok]


def max_lag(x: np.ndarray, y: np.ndarray) -> float:
    """The largest lag (pixels) worth a class of the experimental variogram of points ``x, y``.

    A flight line is a strip: across track no lag exceeds the swath, and along track most
    pairs are thousands of pixels apart, far beyond any relief's range. Binned from 0 to the
    largest distance, as PyKrige does, 20 classes of a 20,000-line line are ~1,000 px wide and
    the fit is all nugget. Lags are therefore kept up to twice the strip's narrower extent
    (the across-track width of a line; the whole field of a square scene, where this equals
    PyKrige's binning): pairs up to that distance sample every direction the strip allows.
    """
    extent = min(float(np.ptp(x)), float(np.ptp(y)))
    diagonal = math.hypot(float(np.ptp(x)), float(np.ptp(y)))
    return min(diagonal, 2.0 * extent) if extent > 0 else diagonal


def experimental_variogram(
    x: np.ndarray, y: np.ndarray, z: np.ndarray, nlags: int = 20, lag_max: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Lags and semivariances of ``nlags`` equal distance classes, PyKrige's binning.

    Classes span the pairs' smallest distance to their largest, PyKrige's own scheme
    (``pykrige.core._initialize_variogram_model``); with ``lag_max`` only pairs up to that
    distance are counted (found with a KD-tree, so a long line's points need not be paired
    all with all). Returns the mean distance and the mean of ``(z_i − z_j)² / 2`` per non-empty
    class.
    """
    pts = np.column_stack([x, y]).astype(np.float64)
    zz = np.asarray(z, dtype=np.float64)
    diagonal = math.hypot(float(np.ptp(pts[:, 0])), float(np.ptp(pts[:, 1])))
    if lag_max is None or lag_max >= diagonal:
        from scipy.spatial.distance import pdist

        d = pdist(pts)
        g = 0.5 * pdist(zz[:, None], metric="sqeuclidean")
    else:
        pairs = cKDTree(pts).query_pairs(float(lag_max), output_type="ndarray")
        d = np.hypot(*(pts[pairs[:, 0]] - pts[pairs[:, 1]]).T)
        g = 0.5 * (zz[pairs[:, 0]] - zz[pairs[:, 1]]) ** 2
    if d.size == 0:
        raise InputError("the control points have no pairs to compute a variogram from")
    dmin, dmax = float(d.min()), float(d.max())
    step = (dmax - dmin) / nlags  # PyKrige's arithmetic, so the edges agree to the bit
    edges = np.array([dmin + k * step for k in range(nlags)] + [dmax + 0.001])
    cls = np.searchsorted(edges, d, side="right") - 1
    count = np.bincount(cls, minlength=nlags)[:nlags]
    keep = count > 0
    lags = np.bincount(cls, weights=d, minlength=nlags)[:nlags][keep] / count[keep]
    semi = np.bincount(cls, weights=g, minlength=nlags)[:nlags][keep] / count[keep]
    return lags, semi


def fit_variogram(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    model: str = VARIOGRAM,
    nlags: int = 20,
    max_fit_points: int = 2000,
    seed: int = 0,
    lag_max: float | str | None = "auto",
    min_nugget: float = 0.0,
) -> Variogram:
    """Fit ``model`` to the experimental variogram of (a random subset of) the points.

    The experimental variogram is :func:`experimental_variogram` up to ``lag_max`` ("auto":
    :func:`max_lag`, which on a square scene is PyKrige's own binning; None: all pairs), and
    the model is fitted to it by PyKrige's routine (soft-L1 least squares, shorter lags
    weighted more). On a long line more points are drawn, in proportion to the square root of
    its length over ``lag_max``, so that about as many pairs fall within the lags as in a
    square scene.

    ``min_nugget`` is a floor on the nugget (bounded models, linear and power): the variance of
    a known measurement error of the heights. Matched heights carry the matching noise σ_h,
    but the noise of neighbouring points is correlated (their matching windows overlap), so
    the experimental variogram at short lags underestimates it and the fit may put the nugget
    near 0; kriging then reproduces the noise instead of filtering it (Cressie 1993, §3.2.1:
    the nugget as measurement-error variance).
    """
    from pykrige.ok import OrdinaryKriging

    if model not in MODELS:
        raise ParameterError(f"parameter 'variogram': {model!r} is not one of {', '.join(MODELS)}")
    x, y, z = _check_points(x, y, z)
    if x.size < 10:
        raise InputError(
            f"only {x.size} control points: too few to fit a variogram (at least 10 are needed); "
            "use a larger matching window or lower the reliability thresholds"
        )
    if not np.ptp(z) > 0:
        raise ParameterError(
            "variogram fit failed: all control points have the same height, so there is no "
            "spatial variation to model"
        )
    if lag_max == "auto":
        lag_max = max_lag(x, y)
    diagonal = math.hypot(float(np.ptp(x)), float(np.ptp(y)))
    n_fit = int(max_fit_points)
    if lag_max is not None and 0 < lag_max < diagonal:
        # About as many pairs within lag_max as max_fit_points give in a square scene: a
        # strip's pairs fall within it with a chance ≈ 2 · lag_max / length.
        n_fit = int(max_fit_points * math.sqrt(diagonal / (2.0 * lag_max)))
    if x.size > n_fit:
        pick = np.random.default_rng(seed).choice(x.size, n_fit, replace=False)
        x, y, z = x[pick], y[pick], z[pick]
    try:
        lags, semi = experimental_variogram(x, y, z, int(nlags), lag_max)
        # PyKrige's fitting routine (the one OrdinaryKriging runs on its own classes), so that
        # the fit equals PyKrige's wherever the classes do (tests/test_dem.py).
        function = OrdinaryKriging.variogram_dict[model]
        params = tuple(float(p) for p in _fit_model(lags, semi, model, function, min_nugget))
    except InputError:
        raise
    except Exception as exc:  # PyKrige/SciPy raise assorted errors for degenerate data
        raise ParameterError(
            f"variogram fit failed for the {model} model ({exc}); try another model "
            "(--variogram exponential/linear) or more control points"
        ) from None
    bad = not all(math.isfinite(p) for p in params)
    if model in ("spherical", "exponential", "gaussian"):
        bad = bad or params[0] <= 0 or params[1] <= 0 or params[2] < 0
    else:
        bad = bad or params[0] <= 0 or params[-1] < 0
    if bad:
        raise ParameterError(
            f"variogram fit failed: the {model} model fitted to the control points has "
            f"unusable parameters ({params}); try another model or more control points"
        )
    return Variogram(model, params, int(x.size))


def _fit_model(lags, semi, model, function, min_nugget=0.0) -> np.ndarray:
    """PyKrige's fitting routine (``pykrige.core._calculate_variogram_model``: its start, its
    bounds, soft-L1 least squares on its weighted residuals), with the nugget's lower bound
    ``min_nugget`` instead of 0. With ``min_nugget`` 0 it is PyKrige's fit (tested)."""
    from pykrige.core import _variogram_residuals
    from scipy.optimize import least_squares

    top, bottom = float(np.amax(semi)), float(np.amin(semi))
    # The nugget stays below the largest semivariance (least_squares needs lower < upper).
    # An unknown noise (σ_h not estimable: NaN) sets no floor.
    floor = float(min_nugget) if math.isfinite(min_nugget) else 0.0
    floor = min(max(floor, 0.0), 0.999 * top)
    if model == "linear":
        x0 = [(top - bottom) / (np.amax(lags) - np.amin(lags)), max(bottom, floor)]
        bounds = ([0.0, floor], [np.inf, top])
    elif model == "power":
        x0 = [(top - bottom) / (np.amax(lags) - np.amin(lags)), 1.1, max(bottom, floor)]
        bounds = ([0.0, 0.001, floor], [np.inf, 1.999, top])
    else:
        x0 = [top - bottom, 0.25 * np.amax(lags), max(bottom, floor)]
        bounds = ([0.0, 0.0, floor], [10.0 * top, np.amax(lags), top])
    res = least_squares(
        _variogram_residuals,
        x0,
        bounds=bounds,
        loss="soft_l1",
        args=(lags, semi, function, True),
    )
    return res.x


def grid_step(variogram: Variogram, max_step: int = MAX_STEP) -> int:
    """Node spacing (pixels) of the kriged grid: ``RANGE_PER_STEP`` nodes per variogram range
    at least, at most ``max_step`` pixels; 1 (every pixel) for unbounded models.

    A kriged surface is a weighted sum of the model centred on the control points: it does not
    vary at scales far below the range, so bilinear interpolation between nodes a fortieth of
    the range apart changes it by a small fraction of its relief (measured in the tests and in
    ``benchmarks/dem_kriging.py``).
    """
    r = variogram.range_px
    if r is None or not math.isfinite(r):
        return 1
    return int(max(1, min(int(max_step), r // RANGE_PER_STEP)))


@dataclass(eq=False)
class LocalKriging:
    """Ordinary kriging of control points ``(x, y, z)`` with a fitted variogram, by blocks.

    Build it once per flight line; :meth:`points` krige scattered targets, :meth:`grid_rows`
    the lines ``row0:row1`` of the image grid (``x`` = column, ``y`` = line), so a flight line
    is kriged strip by strip with the same result whatever the strips.

    Parameters
    ----------
    x, y, z : 1-D arrays
        Control points: column, line and value (non-finite points are dropped).
    variogram : Variogram
        The fitted model (:func:`fit_variogram`).
    n_closest_points : int
        Control points per target neighbourhood; each block of targets shares those of all
        its targets (:meth:`_k`).
    step : int, optional
        Node spacing (pixels) of the grid; default :func:`grid_step` of the variogram.

    References
    ----------
    Cressie, N.A.C. Statistics for Spatial Data, revised ed.; Wiley: New York, NY, USA, 1993
    (§3.2, ordinary kriging; local neighbourhoods).
    Murphy, B.; Yurchak, R.; Müller, S. GeoStat-Framework/PyKrige, 2022.
    https://doi.org/10.5281/zenodo.3738604 (the kriging system and variance reproduced here).
    """

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    variogram: Variogram
    n_closest_points: int = N_CLOSEST_POINTS
    step: int | None = None
    _cache: dict = field(default_factory=dict, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def __post_init__(self):
        x, y, z = _check_points(self.x, self.y, self.z)
        if x.size < 2:
            raise InputError(f"only {x.size} control points: too few to krige a surface")
        n = int(self.n_closest_points)
        if n < 2:
            raise ParameterError(f"parameter 'n_closest_points': at least 2, got {n}")
        self.x, self.y, self.z = x, y, z
        self.n = n
        self.model = self.variogram
        self.tree = cKDTree(np.column_stack([x, y]))
        self.step = grid_step(self.variogram) if self.step is None else max(1, int(self.step))
        # Control points per pixel (over their bounding box): a block of ``a`` pixels holds
        # about ``density · a`` of them.
        extent = max(np.ptp(x) + 1.0, 1.0) * max(np.ptp(y) + 1.0, 1.0)
        self.density = x.size / extent

    def _k(self, block_side: float, share: float = 1.0) -> int:
        """Points shared by a block ``block_side`` pixels wide: those within the block's
        circumscribed circle widened by the radius holding ``n_closest_points`` (at the
        line's mean density), so that every target of the block keeps its own nearest
        points."""
        density = self.density * share
        r_n = math.sqrt(self.n / (math.pi * density))
        r = block_side / math.sqrt(2.0) + r_n
        return int(min(self.x.size, max(self.n, math.ceil(density * math.pi * r * r))))

    # -- the systems ------------------------------------------------------------------------
    def _neighbours(self, centres, k, exclude):
        """Indices (blocks × k) of the ``k`` control points nearest each centre, leaving out
        the points where ``exclude`` is True."""
        if exclude is None:
            return self.tree.query(centres, k=k)[1].reshape(-1, k)
        q = k
        while True:
            q = min(self.x.size, 2 * q)
            cand = self.tree.query(centres, k=q)[1].reshape(-1, q)
            keep = ~exclude[cand]
            if q == self.x.size or (keep.sum(axis=1) >= k).all():
                break
        order = np.argsort(~keep, axis=1, kind="stable")[:, :k]
        return np.take_along_axis(cand, order, axis=1)

    def _solve(self, cx, cy, tx, ty, k, exclude=None):
        """Estimate and variance at targets ``(tx, ty)`` (blocks × targets), each block of
        targets kriged from the ``k`` control points nearest its centre ``(cx, cy)`` (leaving
        out the points ``exclude``)."""
        est = np.empty(tx.shape)
        var = np.empty(tx.shape)
        buf = np.empty((min(BATCH, len(cx)), k, k))  # the batch's distances, then semivariances
        for s in range(0, len(cx), BATCH):
            sl = slice(s, s + BATCH)
            idx = self._neighbours(np.column_stack([cx[sl], cy[sl]]), k, exclude)
            px, py = self.x[idx].astype(np.float64), self.y[idx].astype(np.float64)
            nb = len(idx)
            a = np.empty((nb, k + 1, k + 1))
            d = _distance(px, py, px, py, out=buf[:nb])  # then its semivariances, in place
            np.negative(self.model(d, out=d), out=a[:, :k, :k])
            a[:, np.arange(k), np.arange(k)] = 0.0  # PyKrige's matrix: zero diagonal
            a[:, k, :] = 1.0
            a[:, :, k] = 1.0
            a[:, k, k] = 0.0
            b = np.empty((nb, k + 1, tx.shape[1]))
            b[:, :k] = -self.model(_distance(px, py, tx[sl], ty[sl]))
            b[:, k] = 1.0
            try:
                sol = np.linalg.solve(a, b)
            except np.linalg.LinAlgError:  # coincident points: least squares per block
                sol = np.stack(
                    [np.linalg.lstsq(ai, bi, rcond=None)[0] for ai, bi in zip(a, b, strict=True)]
                )
            est[sl] = np.einsum("bk,bkm->bm", self.z[idx].astype(np.float64), sol[:, :k])
            var[sl] = -np.einsum("bkm,bkm->bm", sol, b)
        return est, np.maximum(var, 0.0)

    # -- scattered targets ------------------------------------------------------------------
    def points(
        self, xt: np.ndarray, yt: np.ndarray, exclude: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Estimate and kriging variance at scattered targets; targets in one ``BLOCK_PX``
        cell share a neighbourhood. ``exclude`` (bool per control point): points left out of
        every neighbourhood, e.g. held out for cross-validation (no second tree)."""
        xt = np.asarray(xt, np.float64).ravel()
        yt = np.asarray(yt, np.float64).ravel()
        if xt.size == 0:
            return np.empty(0), np.empty(0)
        cell = np.floor(yt / BLOCK_PX) * 1e9 + np.floor(xt / BLOCK_PX)
        order = np.argsort(cell, kind="stable")
        cells, start, count = np.unique(cell[order], return_index=True, return_counts=True)
        m = int(count.max())
        # Targets of each cell in one row, padded with the cell's first target.
        slot = np.arange(m)[None, :]
        pick = order[start[:, None] + np.minimum(slot, count[:, None] - 1)]
        tx, ty = xt[pick], yt[pick]
        # The neighbourhood covers the widest group (scattered targets: mostly one per cell).
        spread = float(max(np.ptp(tx, axis=1).max(), np.ptp(ty, axis=1).max()))
        k = self._k(spread + 1.0)
        if exclude is not None:
            exclude = np.asarray(exclude, bool)
            kept = int((~exclude).sum())
            if kept < 2:
                raise InputError(f"only {kept} control points left: too few to krige")
            # The points left in have the density of all but the excluded ones.
            k = min(kept, self._k(spread + 1.0, kept / self.x.size))
        e, v = self._solve(tx.mean(axis=1), ty.mean(axis=1), tx, ty, k, exclude)
        est = np.empty(xt.size)
        var = np.empty(xt.size)
        keep = slot < count[:, None]
        est[pick[keep]] = e[keep]
        var[pick[keep]] = v[keep]
        return est, var

    # -- the grid ---------------------------------------------------------------------------
    def _block_nodes(self) -> int:
        """Grid nodes per side of a block: blocks about ``BLOCK_PX`` pixels wide, at most
        ``MAX_BLOCK_NODES`` nodes a side (one system's right-hand sides cost k² each)."""
        return int(min(MAX_BLOCK_NODES, max(1, round(BLOCK_PX / self.step))))

    def _node_rows(self, block_row: int, width: int):
        """Estimate and variance on the node rows of one global row of blocks (cached: the
        strip below needs the last node row again)."""
        with self._lock:
            hit = self._cache.get(block_row)
        if hit is not None:
            return hit
        g = self.step
        bn = self._block_nodes()
        nj = -(-(width - 1) // g) + 1 if g > 1 else width
        rows = (block_row * bn + np.arange(bn)) * g  # node lines of this row of blocks
        cols = np.arange(nj) * g
        nbj = -(-nj // bn)
        jj = np.minimum(np.arange(nbj)[:, None] * bn + np.arange(bn)[None, :], nj - 1)
        tx = np.broadcast_to(cols[jj][:, None, :], (nbj, bn, bn)).reshape(nbj, -1)
        ty = np.broadcast_to(rows[None, :, None], (nbj, bn, bn)).reshape(nbj, -1).astype(float)
        k = self._k(max(bn - 1, 0) * g + 1.0)
        e, v = self._solve(tx.mean(axis=1), ty.mean(axis=1), tx.astype(float), ty, k)
        # back to (node rows, node cols); padded columns repeat the last node (same values)
        e = e.reshape(nbj, bn, bn).transpose(1, 0, 2).reshape(bn, nbj * bn)[:, :nj]
        v = v.reshape(nbj, bn, bn).transpose(1, 0, 2).reshape(bn, nbj * bn)[:, :nj]
        with self._lock:  # strips are kriged by worker threads
            if len(self._cache) >= 4:
                self._cache.pop(next(iter(self._cache)))
            self._cache[block_row] = (e, v)
        return e, v

    def grid_rows(
        self, row0: int, row1: int, width: int, mask: np.ndarray | None = None
    ) -> tuple[np.ndarray, np.ndarray]:
        """Estimate and variance (float64, lines ``row0:row1`` × ``width``) on the image grid;
        NaN where ``mask`` (the strip's lines) is False. Nodes every :attr:`step` pixels are
        kriged, the pixels between them interpolated bilinearly."""
        g = self.step
        bn = self._block_nodes()
        i0 = row0 // g
        i1 = (row1 - 1) // g + (1 if g > 1 else 0)  # the node row below the last line
        parts = [self._node_rows(b, width) for b in range(i0 // bn, i1 // bn + 1)]
        first = (i0 // bn) * bn
        e = np.concatenate([p[0] for p in parts])[i0 - first : i1 - first + 1]
        v = np.concatenate([p[1] for p in parts])[i0 - first : i1 - first + 1]
        if g > 1:
            r = np.arange(row0, row1)
            c = np.arange(width)
            e, v = (_bilinear(a, r - i0 * g, c, g) for a in (e, v))
        if mask is not None:
            e = np.where(mask, e, np.nan)
            v = np.where(mask, v, np.nan)
        return e, v


def _distance(ax, ay, bx, by, out=None) -> np.ndarray:
    """Distances between the points of ``a`` and of ``b``, block by block (blocks × a × b),
    in ``out`` if given."""
    dx = np.subtract(ax[:, :, None], bx[:, None, :], out=out)
    dy = ay[:, :, None] - by[:, None, :]
    dx *= dx
    dy *= dy
    dx += dy
    return np.sqrt(dx, out=dx)


def _bilinear(nodes: np.ndarray, r: np.ndarray, c: np.ndarray, g: int) -> np.ndarray:
    """Values at lines ``r`` and columns ``c`` (pixels from the first node) of a grid of
    ``nodes`` every ``g`` pixels: linear along the lines, then along the columns."""
    i = np.minimum(r // g, nodes.shape[0] - 1)
    f = ((r - i * g) / g)[:, None]
    rows = nodes[i] * (1.0 - f) + nodes[np.minimum(i + 1, nodes.shape[0] - 1)] * f
    j = np.minimum(c // g, nodes.shape[1] - 1)
    f = (c - j * g) / g
    return rows[:, j] * (1.0 - f) + rows[:, np.minimum(j + 1, nodes.shape[1] - 1)] * f


def krige_points(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    xt: np.ndarray,
    yt: np.ndarray,
    variogram: Variogram,
    n_closest_points: int = N_CLOSEST_POINTS,
) -> tuple[np.ndarray, np.ndarray]:
    """Ordinary kriging estimate and variance at scattered targets ``(xt, yt)``
    (:meth:`LocalKriging.points`)."""
    return LocalKriging(x, y, z, variogram, n_closest_points).points(xt, yt)


def krige_grid(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    shape: tuple[int, int],
    variogram: Variogram,
    mask: np.ndarray | None = None,
    n_closest_points: int = N_CLOSEST_POINTS,
    step: int | None = None,
    block_rows: int = 256,
    progress: Progress | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Krige onto every pixel ``(row, col)`` of a ``shape`` grid (x = column, y = row).

    Pixels where ``mask`` is False (clouds, nodata) are returned as NaN. ``step``: node
    spacing (default :func:`grid_step`). Returns float32 (estimate, kriging variance).
    """
    progress = as_progress(progress)
    height, width = shape
    kr = LocalKriging(x, y, z, variogram, n_closest_points, step)
    dem = np.empty(shape, np.float32)
    kv = np.empty(shape, np.float32)
    n = max(1, math.ceil(height / block_rows))
    for i, r0 in enumerate(range(0, height, block_rows)):
        r1 = min(height, r0 + block_rows)
        e, v = kr.grid_rows(r0, r1, width, None if mask is None else mask[r0:r1])
        dem[r0:r1], kv[r0:r1] = e, v
        progress.update((i + 1) / n, "kriging")
    return dem, kv


def cross_validate(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    variogram: Variogram,
    n_closest_points: int = N_CLOSEST_POINTS,
    fraction: float = 0.1,
    max_points: int = 2000,
    seed: int = 0,
    kriging: LocalKriging | None = None,
) -> dict:
    """Hold-out cross-validation: krige a random ``fraction`` of points from the others.

    ``kriging``: the :class:`LocalKriging` of these same points, if built already (the held-out
    points are then left out of its neighbourhoods: no second tree). Returns RMSE, MAE and mean
    error (m), and the mean squared standardised error (error² / kriging variance; ≈ 1 when the
    kriging variance is honest).
    """
    x, y, z = _check_points(x, y, z)
    rng = np.random.default_rng(seed)
    n_test = int(min(max_points, max(1, round(fraction * x.size))))
    if x.size - n_test < 3:
        raise InputError(f"only {x.size} control points: too few for cross-validation")
    test = np.zeros(x.size, bool)
    test[rng.choice(x.size, n_test, replace=False)] = True
    if kriging is None:
        kriging = LocalKriging(x, y, z, variogram, n_closest_points)
    elif kriging.x.size != x.size:
        raise ParameterError("cross_validate: 'kriging' was built on other control points")
    est, var = kriging.points(x[test], y[test], exclude=test)
    err = est - z[test]
    with np.errstate(divide="ignore", invalid="ignore"):
        msse = float(np.nanmean(err**2 / var))
    return {
        "n": int(n_test),
        "rmse_m": float(np.sqrt(np.mean(err**2))),
        "mae_m": float(np.mean(np.abs(err))),
        "mean_error_m": float(np.mean(err)),
        "mean_squared_standardised_error": msse,
    }
