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
def march(path, z, out):
    for r in range(path.shape[0]):
        p = path[r]
        out[r] = np.nan
        finite = True
        for i in range(3):
            for j in range(3):
                if not math.isfinite(p[i, j]):
                    finite = False
        if not finite:
            continue
        span = max(abs(p[0, 1]) + 2 * abs(p[0, 2]), abs(p[1, 1]) + 2 * abs(p[1, 2]))
        n_steps = max(math.ceil(span), 1.0)
        s_prev = 0.0
        f_prev = f(p, z, 0.0)
        if f_prev <= 0:
            continue
        k = 1
        while True:
            s_k = min(k / n_steps, 1.0)
            f_k = f(p, z, s_k)
            if f_k <= 0:
                if not math.isfinite(f_prev):
                    out[r] = s_k
                else:
                    out[r] = illinois(p, z, s_prev, s_k, f_prev, f_k)
                break
            if s_k >= 1.0:
                break
            s_prev, f_prev = s_k, f_k
            k += 1
