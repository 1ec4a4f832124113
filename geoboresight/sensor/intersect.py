"""The first intersection of straight rays (in ECEF) with a DEM, at the DEM's own resolution.

A ray is straight in ECEF but curved in the DEM's map CRS and its heights. Around each line's
ground, the conversion from ECEF to map x, y and ellipsoidal height is a second-order Taylor
model built from 19 points converted exactly by pyproj (central differences over the line's
extent; its remainder is of order ``r³/R²``: about 10 µm at 700 m from the line's centre,
measured against pyproj). Under it, the stretch of each ray between the DEM's highest and
lowest heights is exactly a quadratic in the ray parameter. The ray is marched along it in
steps of at most one DEM cell in columns and rows, against the DEM's bilinear heights; the
first step that goes below the surface is refined by the Illinois false-position method to
1 µm, and the hit's ECEF point is converted exactly by pyproj (one transform per pixel).

The march is a Numba kernel when Numba is installed (compiled on first use, cached where the
package's folder is writable) and its NumPy reference otherwise; the two agree to round-off.
"""

from __future__ import annotations

import numpy as np

from ._refine import REFINE_STEPS, TOLERANCE

#: WGS84 semi-major axis and semi-minor axis (m): the first guess of where a ray crosses a
#: height (refined by pyproj's exact heights).
_A = 6378137.0
_B = 6356752.314245179


def crossings(h_lo, h_hi, origins, directions):
    """Ray parameters (metres along the unit ``directions`` (lines, pixels, 3) from
    ``origins`` (lines, 3)) where each ray enters the ellipsoid inflated by ``h_hi`` (0: the
    origin is inside it) and the one inflated by ``h_lo`` (NaN: the ray misses it)."""
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


def _stencil(delta):
    """The 19 offsets (19, 3) of a second-order central-difference stencil of step ``delta``."""
    e = np.eye(3)
    pts = [np.zeros(3)]
    for i in range(3):
        pts += [e[i], -e[i]]
    for i in range(3):
        for j in range(i + 1, 3):
            pts += [e[i] + e[j], e[i] - e[j], -e[i] + e[j], -e[i] - e[j]]
    return np.array(pts)[None] * np.asarray(delta, dtype=float)[:, None, None]


def local_models(centers, delta, to_map):
    """Second-order Taylor models of ``to_map`` (ECEF to map x, y, height) around each of
    ``centers`` (n, 3): value (n, 3), gradient (n, 3 out, 3 in) and Hessian (n, 3, 3, 3),
    by central differences of step ``delta`` (n,) metres on pyproj's exact values."""
    n = centers.shape[0]
    pts = centers[:, None, :] + _stencil(delta)
    x, y, h = to_map.transform(pts[..., 0].ravel(), pts[..., 1].ravel(), pts[..., 2].ravel())
    f = np.stack([np.reshape(x, (n, 19)), np.reshape(y, (n, 19)), np.reshape(h, (n, 19))], -1)
    d = np.asarray(delta, dtype=float)[:, None]
    f0 = f[:, 0]
    g = np.empty((n, 3, 3))
    hess = np.empty((n, 3, 3, 3))
    for i in range(3):
        fp, fm = f[:, 1 + 2 * i], f[:, 2 + 2 * i]
        g[:, :, i] = (fp - fm) / (2 * d)
        hess[:, :, i, i] = (fp - 2 * f0 + fm) / d**2
    k = 7
    for i in range(3):
        for j in range(i + 1, 3):
            fpp, fpm, fmp, fmm = (f[:, k + m] for m in range(4))
            hess[:, :, i, j] = hess[:, :, j, i] = (fpp - fpm - fmp + fmm) / (4 * d**2)
            k += 4
    return f0, g, hess


def quadratic_path(origins, directions, t0, t1, model, centers):
    """Coefficients (lines, pixels, 3 values, 3 powers) of map x, map y and height as
    quadratics in ``s`` in [0, 1] along ``t = t0 + s (t1 - t0)``, exact under each line's
    local model (:func:`local_models` around ``centers``)."""
    f0, g, hess = model
    a = origins[:, None, :] + t0[..., None] * directions - centers[:, None, :]
    dd = (t1 - t0)[..., None] * directions
    out = np.empty(a.shape[:2] + (3, 3))
    for k in range(3):
        # batched (pixels, 3) @ (3, 3) products per line: BLAS, no large temporaries
        ha = a @ hess[:, k]
        hd = dd @ hess[:, k]
        out[..., k, 0] = f0[:, None, k] + (a @ g[:, k, :, None])[..., 0] + 0.5 * np.sum(ha * a, -1)
        out[..., k, 1] = (dd @ g[:, k, :, None])[..., 0] + np.sum(ha * dd, -1)
        out[..., k, 2] = 0.5 * np.sum(hd * dd, -1)
    return out


def _line_models(origins, directions, lo, hi, to_map):
    """Each line's centre (the mean middle of a sample of its rays' stretches between the
    heights ``hi`` and ``lo``) and its local model, of a step that reaches those stretches'
    ends."""
    n = directions.shape[1]
    idx = np.unique(np.r_[np.arange(0, n, 8), n - 1])
    t0, t1 = crossings(lo, hi, origins, directions[:, idx])
    ok = np.isfinite(t1)
    mid = np.nan_to_num(0.5 * (t0 + t1))
    pts = origins[:, None, :] + mid[..., None] * directions[:, idx]
    w = ok.sum(axis=1, keepdims=True)
    centers = np.where(w > 0, (pts * ok[..., None]).sum(axis=1) / np.maximum(w, 1), origins)
    reach = np.zeros(len(origins))
    for t in (t0, t1):
        ends = origins[:, None, :] + np.nan_to_num(t)[..., None] * directions[:, idx]
        dist = np.linalg.norm(ends - centers[:, None, :], axis=-1)
        reach = np.maximum(reach, np.where(ok, dist, 0.0).max(axis=1))
    # the stencil spans the line's rays, with room for the ends moved by _path
    return centers, local_models(centers, np.maximum(1.2 * reach, 50.0), to_map)


def _path(origins, directions, t0, t1, model, centers, h_lo, h_hi):
    """The quadratic path of every ray between heights ``h_hi`` and ``h_lo`` (its ends moved
    out until the path's own heights bracket them)."""
    ok = np.isfinite(t1)
    moved = np.zeros(t0.shape, bool)
    for _ in range(4):
        coef = quadratic_path(origins, directions, t0, t1, model, centers)
        top = coef[..., 2, 0]
        bottom = coef[..., 2, 0] + coef[..., 2, 1] + coef[..., 2, 2]
        high = ok & (top < h_hi)
        low = ok & (bottom > h_lo)
        moved = high | low
        if not moved.any():
            break
        # the first guess of the crossings missed by more than the margin: move the ends
        t0 = np.where(high, np.maximum(t0 - 2.0 * (h_hi - top) - 1.0, 0.0), t0)
        t1 = np.where(low, t1 + 2.0 * (bottom - h_lo) + 1.0, t1)
    if moved.any():
        coef = quadratic_path(origins, directions, t0, t1, model, centers)
    return coef, t0, t1


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
            f_lo, f_hi = f_prev[hit], f_k[hit]
            direct = ~np.isfinite(f_lo)  # entering the DEM from no data: the step's end
            s_hit = _illinois(lambda s_, i=idx: f(i, s_), lo, hi, np.where(direct, 1.0, f_lo), f_hi)
            out[idx] = np.where(direct, s_k[hit], s_hit)
        done = hit | (s_k >= 1.0)
        active, s_prev, f_prev = active[~done], s_k[~done], f_k[~done]
        k += 1
    return out


def _illinois(func, lo, hi, f_lo, f_hi):
    """The Illinois false-position refinement of brackets [lo, hi] with ``f_lo > 0 >= f_hi``,
    vectorised: the same steps as the compiled kernel."""
    s = hi.copy()
    side = np.zeros(lo.size, np.int8)
    active = np.ones(lo.size, bool)
    for _ in range(REFINE_STEPS):
        if not active.any():
            break
        denom = f_lo - f_hi
        c = np.where(
            denom != 0,
            (lo * (-f_hi) + hi * f_lo) / np.where(denom != 0, denom, 1.0),
            0.5 * (lo + hi),
        )
        c = np.where((c <= lo) | (c >= hi), 0.5 * (lo + hi), c)
        fc = func(c)
        s = np.where(active, c, s)
        below = fc <= 0
        new_hi = active & below
        new_lo = active & ~below
        hi = np.where(new_hi, c, hi)
        f_hi = np.where(new_hi, fc, f_hi)
        f_lo = np.where(new_hi & (side == -1), 0.5 * f_lo, f_lo)
        lo = np.where(new_lo, c, lo)
        f_lo = np.where(new_lo, fc, f_lo)
        f_hi = np.where(new_lo & (side == 1), 0.5 * f_hi, f_hi)
        side = np.where(new_hi, -1, np.where(new_lo, 1, side)).astype(np.int8)
        active &= (np.abs(fc) > TOLERANCE) & (hi - lo > 2.0**-40)
    return s


_NUMBA = None


def _numba_kernel(name: str = "march"):
    """The compiled kernel ``name`` (``march`` or ``trace_rays``), or None without Numba
    (imported on first use)."""
    global _NUMBA
    if _NUMBA is None:
        try:
            from . import _intersect_numba as compiled
        except ImportError:
            compiled = False
        _NUMBA = compiled
    return getattr(_NUMBA, name) if _NUMBA else None


def march(path, z, *, engine: str = "auto"):
    """First-hit ``s`` per ray of ``path`` (rays, 3, 3): the Numba kernel (``engine='numba'``,
    or ``'auto'`` when Numba is installed) or the NumPy reference (``'numpy'``)."""
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
    if engine not in ("auto", "numba", "numpy"):
        raise ValueError(f"engine must be 'auto', 'numba' or 'numpy', not {engine!r}")
    origins = np.asarray(origins, dtype=np.float64)
    directions = np.asarray(directions, dtype=np.float64)
    shape = directions.shape[:2]
    flat = np.isscalar(heights) or np.ndim(heights) == 0
    if flat:
        h_lo = h_hi = float(heights)
    else:
        h_lo, h_hi = float(np.nanmin(heights)), float(np.nanmax(heights))
    pad = 2.0 + 0.001 * max(abs(h_lo), abs(h_hi))
    centers, model = _line_models(origins, directions, h_lo - pad, h_hi + pad, to_map)
    kernel = None if flat or engine == "numpy" else _numba_kernel("trace_rays")
    if engine == "numba" and not flat and kernel is None:
        raise ImportError("engine='numba' needs Numba (pip install numba)")
    if kernel is not None:
        t = np.empty(shape)
        kernel(origins, np.ascontiguousarray(directions), *model, centers,
               np.ascontiguousarray(heights, dtype=np.float64), _inverse(transform),
               h_lo, h_hi, pad, t)  # fmt: skip
    else:
        t0, t1 = crossings(h_lo - pad, h_hi + pad, origins, directions)
        t1f = np.where(np.isfinite(t1), t1, t0 + 1.0)
        coef, t0, t1f = _path(origins, directions, t0, t1f, model, centers, h_lo, h_hi)
        coef[~np.isfinite(t1)] = np.nan
        coef = coef.reshape(-1, 3, 3)
        if flat:
            s = _quadratic_root(coef[:, 2, :], h_lo)
        else:
            s = march_numpy(_pixel_path(coef, transform), heights)
        t = (t0.ravel() + s * (t1f.ravel() - t0.ravel())).reshape(shape)
    p = origins[:, None, :] + t[..., None] * directions
    x, y, h = out_map.transform(p[..., 0].ravel(), p[..., 1].ravel(), p[..., 2].ravel())
    return tuple(np.reshape(v, shape) for v in (x, y, h))


def _inverse(transform):
    """The inverse of a rasterio-order affine ``transform``: (ia, ib, id, ie, c, f) with
    column = ia (x − c) + ib (y − f), row = id (x − c) + ie (y − f)."""
    a, b, c, d, e, f = transform
    det = a * e - b * d
    return np.array([e / det, -b / det, -d / det, a / det, c, f])


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
