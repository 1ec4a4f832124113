"""The first intersection of straight rays (in ECEF) with a DEM, at the DEM's own resolution.

A ray is straight in ECEF but curved in the DEM's map CRS and its heights. Along the stretch
of each ray between the DEM's highest and lowest heights, its map position and ellipsoidal
height are quadratics in the ray parameter through three points converted exactly by pyproj
(the curvature is of order ``L²/R``: the cubic remainder is below a micrometre for a 3 km
stretch). The ray is then marched in steps of at most one DEM cell in columns and rows,
against the DEM's bilinear heights; the first step that goes below the surface is refined by
bisection to convergence, and the hit's ECEF point is converted exactly by pyproj.

The march is a Numba kernel when Numba is installed (compiled on first use, cached where the
package's folder is writable) and its NumPy reference otherwise; the two agree to round-off.
"""

from __future__ import annotations

import os

import numpy as np

#: WGS84 semi-major axis and semi-minor axis (m): the first guess of where a ray crosses a
#: height (refined by pyproj's exact heights).
_A = 6378137.0
_B = 6356752.314245179
#: Bisection steps on the bracketing step (a step is at most one cell: 2**-48 of a cell).
BISECTIONS = 48


def _to_unit(h_lo, h_hi, origins, directions):
    """Ray parameters (metres along the unit direction) where each ray crosses the inflated
    ellipsoids of heights ``h_hi`` (entry) and ``h_lo`` (exit); NaN exit for a ray that
    misses."""
    o = origins[:, None, :]
    d = directions

    def cross(h):
        s = np.array([1.0 / (_A + h), 1.0 / (_A + h), 1.0 / (_B + h)])
        os_, ds = o * s, d * s
        a = np.sum(ds * ds, axis=-1)
        b = 2.0 * np.sum(os_ * ds, axis=-1)
        c = np.sum(os_ * os_, axis=-1) - 1.0
        disc = b * b - 4.0 * a * c
        with np.errstate(invalid="ignore"):
            t = (-b - np.sqrt(disc)) / (2.0 * a)
        return t, c

    t_hi, c_hi = cross(h_hi)
    t_lo, _ = cross(h_lo)
    # a sensor below the top starts at itself
    t_hi = np.where(np.broadcast_to(c_hi, t_hi.shape) <= 0.0, 0.0, t_hi)
    t_hi = np.maximum(t_hi, 0.0)
    t_lo = np.where(t_lo > t_hi, t_lo, np.nan)
    return t_hi, t_lo


def quadratic_path(origins, directions, t0, t1, to_map):
    """Coefficients (rays, 3 values, 3 powers) of map x, map y and height as quadratics in
    ``s`` in [0, 1] along ``t = t0 + s (t1 - t0)``, through pyproj's exact values at
    s = 0, ½, 1; and the exact values at the two ends."""
    shape = t0.shape
    s = np.array([0.0, 0.5, 1.0])
    t = t0[..., None] + s * (t1 - t0)[..., None]
    p = origins[:, None, None, :] + t[..., None] * directions[..., None, :]
    x, y, h = to_map.transform(p[..., 0].ravel(), p[..., 1].ravel(), p[..., 2].ravel())
    f = np.stack(
        [np.reshape(x, shape + (3,)), np.reshape(y, shape + (3,)), np.reshape(h, shape + (3,))],
        axis=-2,
    )
    f0, fm, f1 = f[..., 0], f[..., 1], f[..., 2]
    c = np.stack([f0, -3.0 * f0 + 4.0 * fm - f1, 2.0 * f0 - 4.0 * fm + 2.0 * f1], axis=-1)
    return c


def _pixel_path(coef, transform):
    """The quadratic path in DEM pixel coordinates (column, row: centres at i + ½) and height:
    (rays, 3, 3)."""
    a, b, c, d, e, f = transform
    det = a * e - b * d
    ia, ib, id_, ie = e / det, -b / det, -d / det, a / det
    x, y, h = coef[..., 0, :], coef[..., 1, :], coef[..., 2, :]
    x = x - np.array([c, 0.0, 0.0])
    y = y - np.array([f, 0.0, 0.0])
    col = ia * x + ib * y
    row = id_ * x + ie * y
    return np.stack([col, row, h], axis=-2)


def _bilinear_np(z, col, row):
    """Bilinear heights at (col, row) (pixel centres at i + ½); NaN outside the centres'
    hull extended by half a cell (clamped) and where a corner is NaN."""
    ny, nx = z.shape
    x = col - 0.5
    y = row - 0.5
    inside = (x >= -0.5) & (x <= nx - 0.5) & (y >= -0.5) & (y <= ny - 0.5)
    x = np.clip(np.where(inside, x, 0.0), 0.0, nx - 1.0)
    y = np.clip(np.where(inside, y, 0.0), 0.0, ny - 1.0)
    i0 = np.minimum(np.floor(x).astype(np.intp), max(nx - 2, 0))
    j0 = np.minimum(np.floor(y).astype(np.intp), max(ny - 2, 0))
    i1 = np.minimum(i0 + 1, nx - 1)
    j1 = np.minimum(j0 + 1, ny - 1)
    fx = x - i0
    fy = y - j0
    v = (
        z[j0, i0] * (1 - fx) * (1 - fy)
        + z[j0, i1] * fx * (1 - fy)
        + z[j1, i0] * (1 - fx) * fy
        + z[j1, i1] * fx * fy
    )
    return np.where(inside, v, np.nan)


def _steps(path):
    """Steps per ray so that no step moves more than one cell in column or row."""
    span = np.maximum(
        np.abs(path[:, 0, 1]) + 2 * np.abs(path[:, 0, 2]),
        np.abs(path[:, 1, 1]) + 2 * np.abs(path[:, 1, 2]),
    )
    return np.maximum(np.ceil(np.nan_to_num(span, nan=0.0)), 1.0).astype(np.int64)


def march_numpy(path, z):
    """NumPy reference of the march: ``path`` (rays, 3, 3) quadratic column, row and height
    in s; ``z`` the DEM (NaN no data). Returns s of the first hit per ray (NaN: none)."""
    n = path.shape[0]
    steps = _steps(path)
    out = np.full(n, np.nan)
    ok = np.isfinite(path).all(axis=(1, 2))

    def f(idx, s):
        p = path[idx]
        col = p[:, 0, 0] + s * (p[:, 0, 1] + s * p[:, 0, 2])
        row = p[:, 1, 0] + s * (p[:, 1, 1] + s * p[:, 1, 2])
        h = p[:, 2, 0] + s * (p[:, 2, 1] + s * p[:, 2, 2])
        return h - _bilinear_np(z, col, row)

    active = np.flatnonzero(ok)
    s_prev = np.zeros(active.size)
    f_prev = f(active, s_prev)
    under = f_prev <= 0  # the ray starts under the surface: no first hit from above
    out[active[under]] = np.nan
    active, s_prev, f_prev = active[~under], s_prev[~under], f_prev[~under]
    k = 1
    while active.size:
        s_k = np.minimum(k / steps[active], 1.0)
        f_k = f(active, s_k)
        hit = f_k <= 0
        if hit.any():
            idx = active[hit]
            lo, hi = s_prev[hit], s_k[hit]
            f_lo = f_prev[hit]
            direct = ~np.isfinite(f_lo)  # entering the DEM from no data: the step's end
            for _ in range(BISECTIONS):
                mid = 0.5 * (lo + hi)
                f_mid = f(idx, mid)
                below = f_mid <= 0
                hi = np.where(below, mid, hi)
                lo = np.where(below, lo, mid)
            out[idx] = np.where(direct, s_k[hit], 0.5 * (lo + hi))
        done = hit | (s_k >= 1.0)
        active, s_prev, f_prev = active[~done], s_k[~done], f_k[~done]
        k += 1
    return out


_NUMBA = None


def _numba_kernel():
    """The compiled march, or None without Numba. Cached on disk only where the package's
    folder is writable (a read-only install compiles in memory)."""
    global _NUMBA
    if _NUMBA is None:
        try:
            import numba  # noqa: F401
        except ImportError:
            _NUMBA = False
        else:
            from . import _intersect_numba

            cache = os.access(os.path.dirname(_intersect_numba.__file__), os.W_OK)
            _NUMBA = _intersect_numba.build(cache=cache, bisections=BISECTIONS)
    return _NUMBA or None


def march(path, z, *, engine: str = "auto"):
    """First-hit ``s`` per ray: the Numba kernel (``engine='numba'``, or ``'auto'`` when
    Numba is installed) or the NumPy reference (``'numpy'``)."""
    if engine not in ("auto", "numba", "numpy"):
        raise ValueError(f"engine must be 'auto', 'numba' or 'numpy', not {engine!r}")
    kernel = None if engine == "numpy" else _numba_kernel()
    if kernel is None:
        if engine == "numba":
            raise ImportError("engine='numba' needs Numba (pip install numba)")
        return march_numpy(path, z)
    out = np.empty(path.shape[0])
    kernel(
        np.ascontiguousarray(path, dtype=np.float64), np.ascontiguousarray(z, dtype=np.float64), out
    )
    return out


def intersect(origins, directions, heights, transform, to_map, out_map, *, engine="auto"):
    """Ground points of rays from ``origins`` (lines, 3) ECEF along ``directions`` (lines,
    pixels, 3) unit ECEF vectors, on the DEM ``heights`` (ny, nx) ellipsoidal metres, NaN no
    data, on ``transform`` (rasterio order) in the CRS of ``to_map`` (a pyproj Transformer
    from ECEF); ``heights`` may be a float (a constant ellipsoidal height, no DEM).

    Returns (x, y, h) in ``out_map``'s CRS, each (lines, pixels); NaN where a ray misses
    (it leaves the DEM or meets only no data before reaching the ground).
    """
    origins = np.asarray(origins, dtype=np.float64)
    directions = np.asarray(directions, dtype=np.float64)
    shape = directions.shape[:2]
    flat = np.isscalar(heights) or np.ndim(heights) == 0
    if flat:
        h_lo = h_hi = float(heights)
    else:
        h_lo, h_hi = float(np.nanmin(heights)), float(np.nanmax(heights))
    pad = 2.0 + 0.01 * max(abs(h_lo), abs(h_hi))
    t0, t1 = _to_unit(h_lo - pad, h_hi + pad, origins, directions)
    t1f = np.where(np.isfinite(t1), t1, t0 + 1.0)
    coef = quadratic_path(origins, directions, t0, t1f, to_map)
    coef[~np.isfinite(t1)] = np.nan
    coef = coef.reshape(-1, 3, 3)
    if flat:
        s = _quadratic_root(coef[:, 2, :], h_lo)
    else:
        s = march(_pixel_path(coef, transform), heights, engine=engine)
    t = t0.ravel() + s * (t1f.ravel() - t0.ravel())
    p = origins[:, None, :] + t.reshape(shape)[..., None] * directions
    x, y, h = out_map.transform(p[..., 0].ravel(), p[..., 1].ravel(), p[..., 2].ravel())
    return tuple(np.reshape(v, shape) for v in (x, y, h))


def _quadratic_root(c, level):
    """The smallest s in [0, 1] where c0 + c1 s + c2 s² = level (NaN: none)."""
    a, b, c0 = c[:, 2], c[:, 1], c[:, 0] - level
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = np.sqrt(b * b - 4 * a * c0)
        # the numerically stable pair of roots
        q = -0.5 * (b + np.copysign(disc, b))
        r1, r2 = q / a, c0 / q
        lin = -c0 / b
    roots = np.stack([r1, r2], axis=1)
    roots = np.where((roots >= -1e-9) & (roots <= 1 + 1e-9), roots, np.nan)
    s = np.nanmin(np.where(np.isnan(roots), np.inf, roots), axis=1)
    s = np.where(np.isinf(s), np.nan, s)
    small = np.abs(a) < 1e-12 * np.maximum(np.abs(b), 1e-300)
    s = np.where(small & (lin >= 0) & (lin <= 1 + 1e-9), lin, s)
    return s
