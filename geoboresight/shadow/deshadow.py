"""De-shadowing: the sunlit signal of shadowed pixels, from the scene's own shadow edges.

A pixel of reflectance ρ, a share ``f`` of it in cast shadow, receives the direct sunlight on
the rest and the diffuse skylight everywhere; its signal above the dark level is

    L = (E_dir·(1 − f) + E_diff)·ρ,   sunlit: L_sun = (E_dir + E_diff)·ρ.

With the band's sunlit-to-shadow illumination ratio ``k = (E_dir + E_diff) / E_diff`` (the
ratio of a surface's sunlit and fully shadowed signals),

    L_sun = L / (1 − f·(1 − 1/k)),

exact for every ``f`` (at f = 1 it is ``L·k``; the linear ``L·(1 + f·(k − 1))`` agrees only at
f = 0 and 1 and over-corrects partial shadow: by 3.3× at f = 0.5 and k = 10).

``k`` is measured on the scene (:func:`illumination_ratio`): pairs of a fully shadowed pixel
and a sunlit pixel a few pixels away across the shadow edge (:func:`shadow_pairs`); most of
them are the same surface (ground on both sides of a cast shadow), some are not (the caster's
roof beyond the up-sun edge). The pairs whose ratio spectrum is closest to the consensus
(in shape and level) are kept, and the median of their ratios is ``k``.

References
----------
Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens.
2005, 26, 3137–3148 (the shadow function and the scaling of shadowed pixels).
Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
(§3.1: the shadow fraction).
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..errors import InputError, ParameterError

#: A pixel is fully shadowed at or above this fraction, sunlit at or below :data:`LIT`.
FULL = 0.9
LIT = 0.02
#: Pairs: distances (px) from a shadowed pixel to a sunlit one, in the 8 directions; each at
#: least one pixel from the edge (:func:`shadow_pairs`).
DISTANCES = (2, 3, 4)
#: Share of the pairs, the most consistent with the consensus, kept for the ratio.
KEEP = 0.25
#: Fewest pairs to measure the ratio.
MIN_PAIRS = 20
#: Smallest signal (above the dark level) a pair's band may have (log ratios of noise).
MIN_SIGNAL = 1e-6

_DIRECTIONS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def shadow_pairs(
    cube: np.ndarray,
    fraction: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    distances=DISTANCES,
    full: float = FULL,
    lit: float = LIT,
    own: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(shaded, sunlit) spectra, each (n_pairs, n_bands), of the pixel pairs across shadow
    edges: a pixel with ``fraction ≥ full`` and one with ``fraction ≤ lit`` ``d`` pixels
    away in one of the 8 directions, ``d`` in ``distances``.

    ``cube`` is (n_bands, rows, cols) signal above the dark level; NaN fractions are
    invalid. A strip gives the pairs whose shadowed pixel is its own when read with a halo of
    ``max(distances) + 1`` lines and ``own`` (bool, rows × cols) True on its own lines:
    only shadowed pixels in ``own`` start a pair.
    """
    x = np.asarray(cube)
    f = np.asarray(fraction, np.float64)
    ok = np.isfinite(f) & np.isfinite(x).all(axis=0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    with np.errstate(invalid="ignore"):
        shade = ok & (f >= full)
        sun = ok & (f <= lit)
    # One pixel inside each side: an edge pixel mixes in light from the other side (the
    # sensor's blur, a fraction a pixel off), and in the SWIR, where the sunlit signal is
    # 10–30 times the shadowed one, a tenth of sunlit light doubles a shadowed signal.
    ring = np.ones((3, 3), bool)
    shade = ndimage.binary_erosion(shade, ring, border_value=1) & shade
    sun = ndimage.binary_erosion(sun, ring, border_value=1) & sun
    if own is not None:
        shade &= np.asarray(own, bool)
    rows, cols = f.shape
    a_idx, b_idx = [], []
    for d in distances:
        for dy, dx in _DIRECTIONS:
            sy, sx = dy * d, dx * d
            ys = slice(max(0, -sy), rows - max(0, sy))
            xs = slice(max(0, -sx), cols - max(0, sx))
            yt = slice(max(0, sy), rows - max(0, -sy))
            xt = slice(max(0, sx), cols - max(0, -sx))
            hit = shade[ys, xs] & sun[yt, xt]
            r, c = np.nonzero(hit)
            a_idx.append((r + ys.start) * cols + (c + xs.start))
            b_idx.append((r + yt.start) * cols + (c + xt.start))
    a = np.concatenate(a_idx) if a_idx else np.zeros(0, int)
    b = np.concatenate(b_idx) if b_idx else np.zeros(0, int)
    flat = x.reshape(x.shape[0], -1)
    return flat[:, a].T.astype(np.float64), flat[:, b].T.astype(np.float64)


def illumination_ratio(
    shaded: np.ndarray,
    sunlit: np.ndarray,
    valid=None,
    *,
    keep: float = KEEP,
    iterations: int = 5,
    min_pairs: int = MIN_PAIRS,
) -> tuple[np.ndarray, int, float]:
    """Each band's sunlit-to-shadow illumination ratio ``k`` from pairs of shadowed and
    sunlit spectra (:func:`shadow_pairs`).

    The log ratio of each pair is compared with the consensus (first the median over all
    pairs); the ``keep`` share of the pairs with the smallest root-mean-square difference
    over the bands (shape and level: the same surface on both sides) give the next median;
    repeated ``iterations`` times.

    Returns
    -------
    k : array (n_bands,)
        The ratio (1 for a band no pair measures; below 1 only where the pairs say so:
        noise in absorption bands).
    n_pairs : int
        Pairs kept in the end.
    spread : float
        Median RMS log difference of the kept pairs to ``k`` (their consistency).

    Raises
    ------
    InputError
        With fewer than ``min_pairs`` pairs (no shadow edges in the scene).
    """
    a = np.asarray(shaded, np.float64)
    b = np.asarray(sunlit, np.float64)
    if a.shape != b.shape or a.ndim != 2:
        raise InputError(f"pairs must be two (n, bands) arrays, got {a.shape} and {b.shape}")
    if not 0 < keep <= 1:
        raise ParameterError(f"parameter 'keep': {keep} is not in (0, 1]")
    good = (a > MIN_SIGNAL) & (b > MIN_SIGNAL)
    with np.errstate(invalid="ignore", divide="ignore"):
        lr = np.where(good, np.log(b) - np.log(a), np.nan)
    usable = np.isfinite(lr).mean(axis=1) >= 0.8
    if valid is not None:
        usable &= np.asarray(valid, bool)
    lr = lr[usable]
    if lr.shape[0] < min_pairs:
        raise InputError(
            f"only {lr.shape[0]} pairs of shadowed and sunlit pixels across shadow edges "
            f"(need {min_pairs}): the shadow map has too little full shadow next to sunlit "
            "ground to measure the illumination ratio"
        )
    measured = np.isfinite(lr).any(axis=0)
    lr[:, ~measured] = 0.0  # a band no pair measures: ratio 1 (unchanged)
    k = np.nanmedian(lr, axis=0)
    kept = np.ones(lr.shape[0], bool)
    for _ in range(int(iterations)):
        rms = np.sqrt(np.nanmean((lr - k) ** 2, axis=1))
        n = max(min_pairs, int(round(keep * lr.shape[0])))
        kept = np.zeros(lr.shape[0], bool)
        kept[np.argsort(rms, kind="stable")[:n]] = True
        k = np.nanmedian(lr[kept], axis=0)
    spread = float(np.median(np.sqrt(np.nanmean((lr[kept] - k) ** 2, axis=1))))
    return np.exp(k), int(kept.sum()), spread


def deshadow(
    cube: np.ndarray,
    fraction: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    ratio: np.ndarray,
) -> np.ndarray:
    """The sunlit signal of each pixel: ``L / (1 − f·(1 − 1/k))`` per band (float32; NaN
    where invalid; unchanged where ``f`` is 0).

    Parameters
    ----------
    cube : array (n_bands, rows, cols)
        Signal above the dark level (radiance, or DN minus the dark level).
    fraction : array (rows, cols)
        Shadow fraction 0–1 (NaN = invalid); values outside are clipped.
    valid : bool array, optional
    ratio : array (n_bands,)
        The sunlit-to-shadow illumination ratio ``k`` of each band (:func:`illumination_ratio`;
        a NaN or < 1 band is left unchanged: 1).
    """
    x = np.asarray(cube, np.float64)
    k = np.asarray(ratio, np.float64).reshape(-1)
    if k.size != x.shape[0]:
        raise InputError(f"{k.size} illumination ratios for {x.shape[0]} bands")
    k = np.where(np.isfinite(k) & (k >= 1.0), k, 1.0)
    f = np.clip(np.asarray(fraction, np.float64), 0.0, 1.0)
    ok = np.isfinite(f)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    g = 1.0 / (1.0 - np.where(ok, f, 0.0)[None] * (1.0 - 1.0 / k)[:, None, None])
    out = (x * g).astype(np.float32)
    out[:, ~ok] = np.nan
    return out
