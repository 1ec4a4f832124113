"""Each shadow's own illumination ratio, from the pairs across its own edges.

One sunlit-to-shadow ratio per band for a whole scene (:func:`geoboresight.shadow.deshadow.
illumination_ratio`) is the ratio of the average shadow. A shadow that sees less sky (a
courtyard, a narrow street, the foot of a wall) or gets more light from its surroundings has
its own. Its sky enters every band alike: with ``k − 1 = E_dir/(V·E_sky)`` a shadow whose
sky-view factor is V instead of the scene's V̄ has ``k − 1`` scaled by ``s = V̄/V`` in every
band. So each neighbourhood's ratio is the scene's with one scale, ``k_local = 1 + s·(k − 1)``,
measured on the pairs across the edges of the shadows in it (:func:`pair_scales`, a median
over the neighbourhood's pairs of one surface, :func:`region_scale`), the scene's where too
few pairs are near (s = 1). One number per neighbourhood, measured on every band the noise
resolves, is what a handful of pairs can measure; a ratio per band per neighbourhood is not.

With a surface model the scale is measured on the open-ground ratio the pairs give with their
own sky views (:func:`geoboresight.shadow.deshadow.illumination_ratio`): it then corrects what
the sky-view factor leaves, the surroundings' light and the surface model's own errors.

References
----------
Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens.
2005, 26, 3137–3148 (the shadow's sky view V·E_sky).
Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from . import deshadow

#: Side (px) of the tiles the scale is held on; each tile's scale is the median over the
#: pairs of its neighbourhood, :data:`REACH` tiles on each side (96 px with 32 and 1): a few
#: shadows, the ground they lie on and the sky they see. Set on the development scenes:
#: tiles of 16 px were too few pairs for the materials across an edge to be outvoted (the
#: simulator's materials' brightness with the surface model 11 % off against each pixel's
#: own sunlit signal, 6 % with 32, 48 or 64 px).
TILE = 32
REACH = 1
#: Fewest pairs of one surface in a neighbourhood that measure its scale; with fewer the
#: scene's ratio (s = 1). The median of 12 pairs whose scales scatter by 30 % is good to
#: about 10 % (1.25·σ/√n).
MIN_REGION_PAIRS = 12
#: The bands a pair's scale is measured on: resolved in shadow, with ``k − 1`` at least this
#: (where ``k − 1`` is small a scale is the ratio of two small numbers).
MIN_EXCESS = 0.5
#: A pair whose ratio spectrum departs from ``1 + s·(k − 1)`` by more than this RMS in log
#: (about 16 %) is not one surface on both sides (a different material across the edge) and
#: does not measure the scale. A brighter or darker material of the same spectral shape
#: passes: only the median over the neighbourhood outvotes it (0.25 and 0.10 did worse on
#: the development scenes).
SAME_SURFACE_RMS = 0.15
#: The scale is kept within this range: a neighbourhood whose shadows see half or twice the
#: sky of the scene's average shadow (a street canyon against open ground) is as far as the
#: median of a few pairs, some of other materials, is trusted.
SCALE_RANGE = (0.5, 2.0)


def open_ratios(
    shaded: np.ndarray,
    sunlit: np.ndarray,
    *,
    sky_view: tuple[np.ndarray, np.ndarray] | None = None,
    direct: np.ndarray | None = None,
) -> np.ndarray:
    """Each pair's open-ground ratio per band, ``(V_a·r − V_b)·cos Z/cos i + 1`` (``r`` its
    sunlit-to-shadowed ratio; without a surface model ``r``), as
    :func:`geoboresight.shadow.deshadow.illumination_ratio` averages it.

    Parameters
    ----------
    shaded, sunlit : arrays (pairs, bands)
        Signal above the dark level (and the additive signal).
    sky_view : (array (pairs,), array (pairs,)), optional
        Sky-view factor of the shaded and of the sunlit pixel.
    direct : array (pairs,), optional
        ``cos i / cos Z`` of the sunlit pixel.

    Returns
    -------
    array (pairs, bands)
        NaN where a signal is below :data:`geoboresight.shadow.deshadow.MIN_SIGNAL`.
    """
    a = np.asarray(shaded, np.float64)
    b = np.asarray(sunlit, np.float64)
    good = (a > deshadow.MIN_SIGNAL) & (b > deshadow.MIN_SIGNAL)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = np.where(good, b / a, np.nan)
        if sky_view is None and direct is None:
            return r
        va, vb = deshadow.pair_sky_views(sky_view, a.shape[0])
        d = deshadow.pair_direct(direct, a.shape[0])
        return (va * r - vb) / d + 1.0


def pair_scales(
    ratios: np.ndarray, ratio: np.ndarray, bands: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Each pair's scale ``s`` of the scene's ``k − 1`` and how far its ratio spectrum departs
    from ``1 + s·(k − 1)``.

    Parameters
    ----------
    ratios : array (pairs, bands)
        The pairs' (open-ground) ratios (:func:`open_ratios`).
    ratio : array (bands,)
        The scene's ratio ``k``.
    bands : bool array (bands,), optional
        The bands to measure on (those the noise resolves in shadow); of them, those with
        ``k − 1 ≥`` :data:`MIN_EXCESS`.

    Returns
    -------
    scale : array (pairs,)
        The median over the bands of ``(r − 1)/(k − 1)``; NaN for a pair with fewer than 3
        such bands.
    rms : array (pairs,)
        RMS over those bands of ``log r − log(1 + s·(k − 1))``.
    """
    r = np.asarray(ratios, np.float64)
    k = np.asarray(ratio, np.float64).reshape(-1)
    use = np.isfinite(k) & (k - 1.0 >= MIN_EXCESS)
    if bands is not None:
        use &= np.asarray(bands, bool)
    n = r.shape[0]
    if use.sum() < 3 or n == 0:
        return np.full(n, np.nan), np.full(n, np.nan)
    r, k = r[:, use], k[use]
    with np.errstate(invalid="ignore", divide="ignore"):
        each = (r - 1.0) / (k - 1.0)
        enough = np.isfinite(each).sum(axis=1) >= 3
        s = np.full(n, np.nan)
        s[enough] = np.nanmedian(each[enough], axis=1)
        model = 1.0 + s[:, None] * (k - 1.0)
        res = np.log(r) - np.log(model)
        rms = np.sqrt(np.nanmean(np.where(np.isfinite(res), res, np.nan) ** 2, axis=1))
    rms[~enough] = np.nan
    return s, rms


def region_scale(
    rows: np.ndarray,
    cols: np.ndarray,
    scale: np.ndarray,
    shape: tuple[int, int],
    valid: np.ndarray | None = None,
    *,
    tile: int = TILE,
    reach: int = REACH,
    min_pairs: int = MIN_REGION_PAIRS,
) -> tuple[np.ndarray, np.ndarray]:
    """The scale of each tile of the image: the median over the pairs whose shaded pixel lies
    within ``reach`` tiles of it.

    Parameters
    ----------
    rows, cols : int arrays (pairs,)
        The shaded pixel of each pair in the image.
    scale : array (pairs,)
        Each pair's scale (:func:`pair_scales`; NaN: none).
    shape : (int, int)
        Lines and columns of the image.
    valid : bool array (pairs,), optional
        The pairs that measure (one surface on both sides).
    tile, reach, min_pairs : int

    Returns
    -------
    grid : array (tile rows, tile columns)
        The scale, within :data:`SCALE_RANGE`; NaN where fewer than ``min_pairs`` pairs
        measure it (the scene's ratio there).
    count : int array (tile rows, tile columns)
        The pairs that measured each tile's scale.
    """
    s = np.asarray(scale, np.float64)
    ok = np.isfinite(s) & (s > 0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    ty, tx = -(-shape[0] // tile), -(-shape[1] // tile)
    grid = np.full((ty, tx), np.nan)
    count = np.zeros((ty, tx), int)
    if not ok.any():
        return grid, count
    iy = np.asarray(rows)[ok] // tile
    ix = np.asarray(cols)[ok] // tile
    ls = np.log(s[ok])
    key = iy * tx + ix
    order = np.argsort(key, kind="stable")
    key, ls = key[order], ls[order]
    starts = np.searchsorted(key, np.arange(ty * tx))
    ends = np.searchsorted(key, np.arange(ty * tx), side="right")
    # The tiles with a pair in their neighbourhood: the pairs' tiles dilated by ``reach``.
    has = np.zeros((ty, tx), bool)
    has[iy, ix] = True
    near = ndimage.binary_dilation(has, np.ones((2 * reach + 1,) * 2, bool))
    for y, x in zip(*np.nonzero(near), strict=True):
        y0, y1 = max(0, y - reach), min(ty, y + reach + 1)
        parts = [
            ls[starts[yy * tx + max(0, x - reach)] : ends[yy * tx + min(tx, x + reach + 1) - 1]]
            for yy in range(y0, y1)
        ]
        vals = np.concatenate(parts)
        count[y, x] = vals.size
        if vals.size >= min_pairs:
            grid[y, x] = np.exp(np.median(vals))
    return np.clip(grid, *SCALE_RANGE), count


def pixel_scale(
    grid: np.ndarray, row0: int, shape: tuple[int, int], *, tile: int = TILE
) -> np.ndarray:
    """Each pixel's scale of ``k − 1`` for a block of the image: the tiles' scales
    (:func:`region_scale`) interpolated bilinearly between the tiles' centres, 1 (the scene's
    ratio) where a tile has none.

    Parameters
    ----------
    grid : array (tile rows, tile columns)
    row0 : int
        The block's first line in the image.
    shape : (int, int)
        The block's lines and columns.
    tile : int

    Returns
    -------
    array (lines, columns)
    """
    g = np.where(np.isfinite(grid), np.log(np.asarray(grid, np.float64)), 0.0)
    rr = (np.arange(row0, row0 + shape[0]) + 0.5) / tile - 0.5
    cc = (np.arange(shape[1]) + 0.5) / tile - 0.5
    yy, xx = np.meshgrid(rr, cc, indexing="ij")
    return np.exp(ndimage.map_coordinates(g, [yy, xx], order=1, mode="nearest"))
