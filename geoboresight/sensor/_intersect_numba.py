"""The compiled march of :mod:`.intersect` (Numba); the same steps as ``march_numpy``.

Imported only when Numba is installed. Numba's cache is written beside this file when its
folder is writable; a read-only install compiles in memory on first use.
"""

from __future__ import annotations

import math
import os

import numba
import numpy as np

from ._refine import REFINE_STEPS, TOLERANCE

CACHE = os.access(os.path.dirname(os.path.abspath(__file__)), os.W_OK)
#: WGS84 semi-axes (m), as in :mod:`.intersect`.
A = 6378137.0
B = 6356752.314245179


@numba.njit(cache=CACHE, nogil=True)
def bilinear(z, col, row):
    ny, nx = z.shape
    x = col - 0.5
    y = row - 0.5
    if not (x >= -0.5 and x <= nx - 0.5 and y >= -0.5 and y <= ny - 0.5):
        return np.nan
    x = min(max(x, 0.0), nx - 1.0)
    y = min(max(y, 0.0), ny - 1.0)
    i0 = min(int(math.floor(x)), max(nx - 2, 0))
    j0 = min(int(math.floor(y)), max(ny - 2, 0))
    i1 = min(i0 + 1, nx - 1)
    j1 = min(j0 + 1, ny - 1)
    fx = x - i0
    fy = y - j0
    return (
        z[j0, i0] * (1 - fx) * (1 - fy)
        + z[j0, i1] * fx * (1 - fy)
        + z[j1, i0] * (1 - fx) * fy
        + z[j1, i1] * fx * fy
    )


@numba.njit(cache=CACHE, nogil=True)
def f(p, z, s):
    col = p[0, 0] + s * (p[0, 1] + s * p[0, 2])
    row = p[1, 0] + s * (p[1, 1] + s * p[1, 2])
    h = p[2, 0] + s * (p[2, 1] + s * p[2, 2])
    return h - bilinear(z, col, row)


@numba.njit(cache=CACHE, nogil=True)
def illinois(p, z, lo, hi, f_lo, f_hi):
    s = hi
    side = 0
    for _ in range(REFINE_STEPS):
        denom = f_lo - f_hi
        if denom != 0:
            c = (lo * (-f_hi) + hi * f_lo) / denom
        else:
            c = 0.5 * (lo + hi)
        if c <= lo or c >= hi:
            c = 0.5 * (lo + hi)
        fc = f(p, z, c)
        s = c
        if fc <= 0:
            hi, f_hi = c, fc
            if side == -1:
                f_lo *= 0.5
            side = -1
        else:
            lo, f_lo = c, fc
            if side == 1:
                f_hi *= 0.5
            side = 1
        if not (abs(fc) > TOLERANCE and hi - lo > 2.0**-40):
            break
    return s


@numba.njit(cache=CACHE, nogil=True)
def march_one(p, z):
    """The first-hit ``s`` of one ray's path ``p`` (3, 3), NaN for none."""
    for i in range(3):
        for j in range(3):
            if not math.isfinite(p[i, j]):
                return np.nan
    span = max(abs(p[0, 1]) + 2 * abs(p[0, 2]), abs(p[1, 1]) + 2 * abs(p[1, 2]))
    n_steps = max(math.ceil(span), 1.0)
    s_prev = 0.0
    f_prev = f(p, z, 0.0)
    if f_prev <= 0:
        return np.nan
    k = 1
    while True:
        s_k = min(k / n_steps, 1.0)
        f_k = f(p, z, s_k)
        if f_k <= 0:
            if not math.isfinite(f_prev):
                return s_k
            return illinois(p, z, s_prev, s_k, f_prev, f_k)
        if s_k >= 1.0:
            return np.nan
        s_prev, f_prev = s_k, f_k
        k += 1


@numba.njit(cache=CACHE, nogil=True)
def march(path, z, out):
    for r in range(path.shape[0]):
        out[r] = march_one(path[r], z)


@numba.njit(cache=CACHE, nogil=True)
def _crossing(o, d, h):
    """The ray parameter where ``o + t d`` enters the ellipsoid inflated by ``h``, and
    whether ``o`` is inside it (NaN when the ray misses)."""
    ra, rb = 1.0 / (A + h), 1.0 / (B + h)
    ox, oy, oz = o[0] * ra, o[1] * ra, o[2] * rb
    dx, dy, dz = d[0] * ra, d[1] * ra, d[2] * rb
    a = dx * dx + dy * dy + dz * dz
    b = 2.0 * (ox * dx + oy * dy + oz * dz)
    c = ox * ox + oy * oy + oz * oz - 1.0
    disc = b * b - 4.0 * a * c
    if disc < 0:
        return np.nan, c
    return (-b - math.sqrt(disc)) / (2.0 * a), c


@numba.njit(cache=CACHE, nogil=True)
def _coefficients(o, d, t0, t1, f0, g, hess, q, coef):
    """The quadratic path (3 values, 3 powers) of ``o + t d``, t0 to t1, under the local
    model (f0, g, hess) around ``q``."""
    # scalars, not arrays: no allocation per ray
    a0, a1, a2 = o[0] + t0 * d[0] - q[0], o[1] + t0 * d[1] - q[1], o[2] + t0 * d[2] - q[2]
    w = t1 - t0
    d0, d1, d2 = w * d[0], w * d[1], w * d[2]
    for k in range(3):
        h = hess[k]
        ha0 = h[0, 0] * a0 + h[0, 1] * a1 + h[0, 2] * a2
        ha1 = h[1, 0] * a0 + h[1, 1] * a1 + h[1, 2] * a2
        ha2 = h[2, 0] * a0 + h[2, 1] * a1 + h[2, 2] * a2
        hd0 = h[0, 0] * d0 + h[0, 1] * d1 + h[0, 2] * d2
        hd1 = h[1, 0] * d0 + h[1, 1] * d1 + h[1, 2] * d2
        hd2 = h[2, 0] * d0 + h[2, 1] * d1 + h[2, 2] * d2
        coef[k, 0] = (
            f0[k] + g[k, 0] * a0 + g[k, 1] * a1 + g[k, 2] * a2
            + 0.5 * (a0 * ha0 + a1 * ha1 + a2 * ha2)
        )  # fmt: skip
        coef[k, 1] = g[k, 0] * d0 + g[k, 1] * d1 + g[k, 2] * d2 + d0 * ha0 + d1 * ha1 + d2 * ha2
        coef[k, 2] = 0.5 * (d0 * hd0 + d1 * hd1 + d2 * hd2)


@numba.njit(cache=CACHE, nogil=True, parallel=True)
def trace_rays(origins, directions, f0, g, hess, centers, z, inv, h_lo, h_hi, pad, out_t):
    """Each ray's first-hit parameter ``t`` (NaN: none): the steps of the NumPy pipeline
    (``crossings``, ``_path``, ``_pixel_path``, ``march_numpy``) fused per ray."""
    ia, ib, id_, ie, c, f_ = inv[0], inv[1], inv[2], inv[3], inv[4], inv[5]
    # lines in parallel (Numba's threads); each line its own scratch arrays
    for li in numba.prange(directions.shape[0]):
        coef = np.empty((3, 3))
        path = np.empty((3, 3))
        o = origins[li]
        q = centers[li]
        for pi in range(directions.shape[1]):
            out_t[li, pi] = np.nan
            d = directions[li, pi]
            t0, c_hi = _crossing(o, d, h_hi + pad)
            t1, _ = _crossing(o, d, h_lo - pad)
            if c_hi <= 0.0 or not math.isfinite(t0):
                t0 = 0.0
            t0 = max(t0, 0.0)
            if not (t1 > t0):
                continue
            moved = False
            for _ in range(4):
                _coefficients(o, d, t0, t1, f0[li], g[li], hess[li], q, coef)
                top = coef[2, 0]
                bottom = coef[2, 0] + coef[2, 1] + coef[2, 2]
                moved = False
                if top < h_hi:
                    t0 = max(t0 - 2.0 * (h_hi - top) - 1.0, 0.0)
                    moved = True
                if bottom > h_lo:
                    t1 = t1 + 2.0 * (bottom - h_lo) + 1.0
                    moved = True
                if not moved:
                    break
            if moved:
                _coefficients(o, d, t0, t1, f0[li], g[li], hess[li], q, coef)
            for k in range(3):
                x = coef[0, k] - (c if k == 0 else 0.0)
                y = coef[1, k] - (f_ if k == 0 else 0.0)
                path[0, k] = ia * x + ib * y
                path[1, k] = id_ * x + ie * y
                path[2, k] = coef[2, k]
            s = march_one(path, z)
            if math.isfinite(s):
                out_t[li, pi] = t0 + s * (t1 - t0)
