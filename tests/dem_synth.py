"""Synthetic VNIR/SWIR band pairs with a known offset and relief, for the DEM tests."""

from __future__ import annotations

import numpy as np
from scipy import ndimage


def texture(rows: int, cols: int, seed: int = 0, sigma: float = 1.2, pad: int = 24) -> np.ndarray:
    """Smooth random texture (cubic-spline coefficients) on a padded grid."""
    rng = np.random.default_rng(seed)
    tex = ndimage.gaussian_filter(rng.normal(size=(rows + 2 * pad, cols + 2 * pad)), sigma)
    return ndimage.spline_filter(tex * 400.0 + 2000.0)


def bump(rows: int, cols: int, relief: float = 30.0) -> np.ndarray:
    """A relief of ``relief`` m: a smooth hill plus a flat-roofed block, lowest ground 0."""
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    hill = (
        relief
        * 0.6
        * np.exp(-((r - rows * 0.4) ** 2 + (c - cols * 0.35) ** 2) / (2 * (rows / 6) ** 2))
    )
    block = np.zeros((rows, cols))
    block[int(rows * 0.6) : int(rows * 0.8), int(cols * 0.55) : int(cols * 0.8)] = relief * 0.4
    h = hill + ndimage.gaussian_filter(block, 2.0)
    return h - h.min()


def pair(
    rows: int = 160,
    cols: int = 120,
    offset=(0.4, -0.3),
    dsm: np.ndarray | None = None,
    k_along: float = 1 / 30,
    seed: int = 0,
    noise: float = 0.0,
    gain: float = 0.9,
    pad: int = 24,
):
    """(vnir, swir) 2-D float arrays: a feature at VNIR (r, c) is at SWIR (r + d_a, c + d_c),
    with d_a = offset[0] + k_along · h, d_c = offset[1]."""
    coef = texture(rows, cols, seed=seed, pad=pad)
    r, c = np.mgrid[0:rows, 0:cols].astype(float)
    h = np.zeros((rows, cols)) if dsm is None else dsm
    d_a = offset[0] + k_along * h
    d_c = offset[1] + 0 * h
    vn = ndimage.map_coordinates(coef, [r + pad, c + pad], prefilter=False)
    # SWIR at (r, c) sees the feature that sits at VNIR (r - d_a, c - d_c) (d smooth).
    sw = ndimage.map_coordinates(coef, [r + pad - d_a, c + pad - d_c], prefilter=False)
    rng = np.random.default_rng(seed + 1)
    if noise:
        vn = vn + rng.normal(0, noise, vn.shape)
        sw = sw + rng.normal(0, noise, sw.shape)
    return vn, gain * sw + 50.0, d_a, d_c
