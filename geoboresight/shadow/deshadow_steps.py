"""De-shadowing a flight line in steps on arrays (:mod:`geoboresight.shadow.deshadow`).

A first pass gathers, block by block, the pairs of shadowed and sunlit pixels across the
shadow edges (:func:`edge_pairs`, merged by :func:`merge_edge_pairs`) and each instrument's
darkest pixels; the scene's illumination ratio of each band is fitted on them
(:func:`fit_illumination`); a second pass scales each block's shadowed pixels to their sunlit
signal (:func:`deshadow_block`).

References
----------
Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens.
2005, 26, 3137–3148.
Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..sensor.coregister import coregister, coregister_stack
from . import deshadow, region
from .illumination import sun_step
from .incidence import plane_incidence
from .prior import SurfacePrior

#: Pixels of a flight line whose pairs are looked for (a fixed share of a longer line, so
#: that the pairs held stay bounded: about 1 % of pixels are at a shadow edge).
PAIR_PIXELS = 250_000
#: The spatial hash that picks that share of the pixels by their position, so that strips
#: give the pairs of the whole image whatever their size: the large primes of Teschner et
#: al. (2003, "Optimized spatial hashing for collision detection of deformable objects",
#: VMV 2003, 47–54), whose products spread neighbouring cells evenly over the buckets.
PAIR_HASH = (73856093, 19349663)
#: Buckets of that hash: the share is kept to a thousandth.
PAIR_BUCKETS = 1000
#: Pixels of a flight line looked at for the noise in shadow (:func:`shadow_steps`): the
#: fully shadowed ones among them, a few thousand, give each band's noise to a few per cent.
NOISE_PIXELS = 40_000


def pair_share(shape: tuple[int, int], pixels: int = PAIR_PIXELS) -> int:
    """How many of the :data:`PAIR_BUCKETS` buckets of pixels a flight line looks for pairs
    in, so that about ``pixels`` of it are looked at.

    Parameters
    ----------
    shape : (int, int)
        Lines and columns of the flight line.
    pixels : int
        Pixels to look at.

    Returns
    -------
    int
        At least 1, at most :data:`PAIR_BUCKETS` (every pixel).
    """
    n = shape[0] * shape[1]
    return max(1, min(PAIR_BUCKETS, round(PAIR_BUCKETS * pixels / n)))


def picked_pixels(row0: int, shape: tuple[int, int], share: int) -> np.ndarray:
    """The pixels of a block whose spatial hash falls in the first ``share`` buckets: the
    same pixels whatever the strips a line is read in.

    Parameters
    ----------
    row0 : int
        The block's first line in the flight line.
    shape : (int, int)
        The block's lines and columns.
    share : int
        Buckets of :data:`PAIR_BUCKETS` kept (:func:`pair_share`).

    Returns
    -------
    bool array (lines, columns)
        ``(row·h₁ XOR column·h₂) mod`` :data:`PAIR_BUCKETS` ``< share``, ``(h₁, h₂)`` =
        :data:`PAIR_HASH`.

    References
    ----------
    Teschner, M.; Heidelberger, B.; Müller, M.; Pomeranets, D.; Gross, M. H. Optimized
    spatial hashing for collision detection of deformable objects. VMV 2003, 47–54.
    """
    rr, cc = np.mgrid[row0 : row0 + shape[0], 0 : shape[1]]
    return (rr * PAIR_HASH[0] ^ cc * PAIR_HASH[1]) % PAIR_BUCKETS < share


def darkest_pixels(
    signal: np.ndarray, valid: np.ndarray | None = None, *, n: int = deshadow.DARK_PIXELS
) -> np.ndarray:
    """The dark object's candidates: the ``n`` darkest valid pixels by their mean over the
    bands (:func:`geoboresight.shadow.deshadow.dark_object`).

    Parameters
    ----------
    signal : array (bands, lines, columns)
    valid : bool array (lines, columns), optional
        Pixels to look at; a pixel with a non-finite band is always left out.
    n : int

    Returns
    -------
    float32 array (pixels, bands)
        At most ``n`` rows, in no particular order.
    """
    use = np.isfinite(signal).all(axis=0)
    if valid is not None:
        use &= np.asarray(valid, bool)
    x = signal[:, use].T
    if x.shape[0] > n:
        x = x[np.argpartition(x.mean(axis=1), n - 1)[:n]]
    return x.astype(np.float32)


def keep_darkest(pixels: np.ndarray, n: int = deshadow.DARK_PIXELS) -> np.ndarray:
    """The ``n`` darkest rows of ``pixels`` (pixels, bands) by their mean over the bands
    (a stable sort: ties keep their order); all of them when there are no more than ``n``."""
    if pixels.shape[0] <= n:
        return pixels
    return pixels[np.argsort(pixels.mean(axis=1), kind="stable")[:n]]


class EdgePairs(NamedTuple):
    """Pairs across the shadow edges (float32 rows, one per pair) and the darkest pixels."""

    shaded: np.ndarray  # (pairs, bands): signal of the shaded pixel
    sunlit: np.ndarray  # (pairs, bands): signal of the sunlit one
    views: np.ndarray  # (3, pairs): sky view of each, cos i of the sunlit one
    dark_vnir: np.ndarray  # (pixels, VNIR bands): the darkest VNIR pixels
    dark_swir: np.ndarray  # (pixels, SWIR bands): the darkest SWIR pixels
    around_shaded: np.ndarray  # (pairs, bands or 0): sunlit surroundings of the shaded pixel
    around_sunlit: np.ndarray  # (pairs, bands or 0): and of the sunlit one
    # (2, pixels, bands) of each instrument on its own grid: the mean signal and the
    # difference of neighbouring fully shadowed pixels (:func:`shadow_steps`); None: none.
    steps_vnir: np.ndarray | None = None
    steps_swir: np.ndarray | None = None
    # (2, pairs) int: the shaded pixel's line and column in the flight line, for each
    # region's own ratio (:mod:`geoboresight.shadow.region`); None: not gathered.
    where: np.ndarray | None = None
    # (pairs,) bool: the shaded pixel is a pixel inside its shadow (not on its edge); the
    # edge's pairs measure the ratio only where a scene has too few of the others.
    inset: np.ndarray | None = None
    # Pairs from the shadows' edge pixels counted, not kept: a block (or blocks merged)
    # with enough inset pairs (:data:`geoboresight.shadow.deshadow.MIN_PAIRS`) already
    # rules them out of the fit, and their spectra (often tens of times the inset pairs')
    # would be copied at every merge and held to the end.
    skipped: int = 0

    @property
    def count(self) -> int:
        """The pairs found across the shadow edges, the edge pixels' skipped ones included."""
        return int(self.shaded.shape[0]) + self.skipped

    @classmethod
    def empty(cls, n_bands: int, n_vnir: int, adjacency: bool) -> EdgePairs:
        """No pairs: the start of :func:`merge_edge_pairs`."""
        n_sur = n_bands if adjacency else 0
        z = lambda *shape: np.zeros(shape, np.float32)  # noqa: E731
        return cls(
            z(0, n_bands),
            z(0, n_bands),
            z(3, 0),
            z(0, n_vnir),
            z(0, n_bands - n_vnir),
            z(0, n_sur),
            z(0, n_sur),
            z(2, 0, n_vnir),
            z(2, 0, n_bands - n_vnir),
            np.zeros((2, 0), np.int64),
            np.zeros(0, bool),
        )


def edge_pairs(
    signal: np.ndarray,
    fraction: np.ndarray,
    heights: np.ndarray | None,
    sky_view: np.ndarray | None,
    valid: np.ndarray | None = None,
    *,
    own: np.ndarray,
    picked: np.ndarray,
    n_vnir: int,
    offset: tuple[float, float],
    surface_prior: SurfacePrior | None = None,
    adjacency_size: int = 0,
    quiet: np.ndarray | None = None,
    row0: int = 0,
) -> EdgePairs:
    """The pairs of shadowed and sunlit pixels across the shadow edges of a block, on the
    VNIR grid, and each instrument's darkest pixels on its own grid.

    The SWIR bands of ``signal`` are resampled onto the VNIR grid by the boresight ``offset``
    (along, across; px) before the pairs are taken
    (:func:`geoboresight.shadow.deshadow.pair_indices`: shaded pixels of the block's own
    lines, ``own``, of the ``picked`` share; with a surface model, down-sun or lateral and of
    about the same height).

    Parameters
    ----------
    signal : array (bands, lines, columns)
        Signal above the dark level, VNIR bands then SWIR bands (each on its own grid).
    fraction : array (lines, columns)
        Shadow fraction (0–1, NaN unknown) on the VNIR grid.
    heights, sky_view : arrays (lines, columns) or None
        The surface model's heights (NaN none) and sky-view factor; None without a model.
    valid : bool array (lines, columns), optional
    own : bool array (lines, columns)
        The block's own lines (not its halo): each pixel is taken by one block.
    picked : bool array (lines, columns)
        The share of the pixels looked at (:func:`picked_pixels`).
    n_vnir : int
        VNIR bands, the first of ``signal``.
    offset : (float, float)
        Boresight offset of the SWIR (px, along and across).
    surface_prior : SurfacePrior, optional
        The sun and the grid's geometry (with ``heights``).
    adjacency_size : int
        Side (px) of the window of sunlit surroundings gathered for each pair
        (:func:`geoboresight.shadow.deshadow.surround_signal`); 0 = none.
    quiet : bool array (lines, columns), optional
        The share of the pixels looked at for the noise in shadow (:func:`shadow_steps`, on
        each instrument's own grid, the block's own lines); None = none.
    row0 : int
        The block's first line in the flight line (the pairs' positions, ``where``).

    Returns
    -------
    EdgePairs
        With the pairs whose shaded pixel is on its shadow's edge too (``inset`` False), for
        a scene whose shadows are too narrow to hold a pixel inside them; when the block
        holds :data:`~geoboresight.shadow.deshadow.MIN_PAIRS` inset pairs, these are only
        counted (``skipped``): the fit will not use them.
    """
    sig = np.array(signal, np.float64)
    ok = np.ones(fraction.shape, bool) if valid is None else np.asarray(valid, bool)
    dark_v = darkest_pixels(sig[:n_vnir], ok & own)
    dark_s = darkest_pixels(sig[n_vnir:], ok & own)
    steps_v = steps_s = None
    if quiet is not None:
        # Each instrument's noise on its own grid, before the SWIR is resampled (which
        # averages its noise down); the fraction moved onto the SWIR's grid.
        look = own & np.asarray(quiet, bool)
        steps_v = shadow_steps(sig[:n_vnir], fraction, ok, look)
        fs = fraction_on_swir_grid(fraction, offset, np.isfinite(fraction))
        steps_s = shadow_steps(sig[n_vnir:], fs, ok, look)
    # The SWIR bands onto the VNIR grid together (one mask): NaN where a tap is invalid.
    swir = sig[n_vnir:]
    s_ok = ok & np.isfinite(swir).all(axis=0)
    shifted, s_ok = coregister_stack(np.where(s_ok, swir, 0.0), *offset[:2], s_ok, order=1)
    sig[n_vnir:] = np.where(s_ok, shifted, np.nan)
    toward_sun = None
    if surface_prior is not None:
        p = surface_prior
        toward_sun = sun_step(p.zenith, p.azimuth, p.matrix)[:2]
    look = dict(own=own & picked, toward_sun=toward_sun, heights=heights)
    usable = ok & np.isfinite(sig).all(axis=0)
    # Every pair, then the inset ones (shaded pixel inside its shadow) first and those from
    # the shadows' edge pixels after them (kept apart: they mix in sunlit light, and are used
    # only when a scene has too few inset pairs, so only counted when this block has enough).
    ea, eb = deshadow.pair_indices(fraction, usable, inset=False, **look)
    inside = deshadow.inside_shadow(fraction, usable).reshape(-1)[ea]
    n_inset = int(inside.sum())
    ia, ib = ea[inside], eb[inside]
    skipped = ea.size - n_inset
    if n_inset < deshadow.MIN_PAIRS:
        ia, ib = np.concatenate([ia, ea[~inside]]), np.concatenate([ib, eb[~inside]])
        skipped = 0
    inset = np.arange(ia.size) < n_inset
    flat = sig.reshape(sig.shape[0], -1)
    sky = np.ones(fraction.size) if sky_view is None else sky_view.reshape(-1)
    cos_i = _incidence(heights, surface_prior, fraction.size)
    if adjacency_size:
        with np.errstate(invalid="ignore"):
            lit_px = ok & (fraction <= deshadow.LIT)
        sur = deshadow.surround_signal(sig, lit_px, adjacency_size).reshape(sig.shape[0], -1)
        sur_a, sur_b = sur[:, ia].T, sur[:, ib].T
    else:
        sur_a = sur_b = np.zeros((ia.size, 0))
    return EdgePairs(
        flat[:, ia].T.astype(np.float32),
        flat[:, ib].T.astype(np.float32),
        np.stack([sky[ia], sky[ib], cos_i[ib]]).astype(np.float32),
        dark_v,
        dark_s,
        sur_a.astype(np.float32),
        sur_b.astype(np.float32),
        steps_v,
        steps_s,
        np.stack(np.divmod(ia, fraction.shape[1])) + np.array([[row0], [0]]),
        inset,
        skipped,
    )


def shadow_steps(
    signal: np.ndarray, fraction: np.ndarray, valid: np.ndarray, look: np.ndarray
) -> np.ndarray:
    """Mean and difference of each fully shadowed pixel of ``look`` and its right-hand
    neighbour, when that is fully shadowed too (fraction ≥
    :data:`geoboresight.shadow.deshadow.FULL`, both valid and finite): the sample of
    :func:`geoboresight.shadow.deshadow.shadow_noise`.

    Parameters
    ----------
    signal : array (bands, lines, columns)
        Signal above the dark level on the instrument's own grid.
    fraction : array (lines, columns)
        Shadow fraction on that grid (NaN unknown).
    valid, look : bool arrays (lines, columns)
        Valid pixels; the pixels looked at.

    Returns
    -------
    float32 array (2, pixels, bands)
        ``[0]`` the pair's mean signal, ``[1]`` the right one minus the left one.
    """
    with np.errstate(invalid="ignore"):
        full = np.asarray(valid, bool) & (fraction >= deshadow.FULL)
    full &= np.isfinite(signal).all(axis=0)
    left = np.zeros(full.shape, bool)
    left[:, :-1] = full[:, :-1] & full[:, 1:] & np.asarray(look, bool)[:, :-1]
    r, c = np.nonzero(left)
    a, b = signal[:, r, c].T, signal[:, r, c + 1].T
    return np.stack([(a + b) / 2.0, b - a]).astype(np.float32)


def _incidence(heights, surface_prior, n: int) -> np.ndarray:
    """cos i of each pixel's plane (flat: 1 everywhere without a surface model)."""
    if heights is None:
        return np.ones(n)
    p = surface_prior
    return plane_incidence(
        heights,
        np.isfinite(heights),
        sun_zenith=p.zenith,
        sun_azimuth=p.azimuth,
        transform=p.matrix,
    ).reshape(-1)


def merge_edge_pairs(a: EdgePairs, b: EdgePairs, n_dark: int = deshadow.DARK_PIXELS) -> EdgePairs:
    """The pairs of two blocks together (``a``'s first) and the ``n_dark`` darkest pixels of
    both instruments (:func:`keep_darkest`): the merge of
    :func:`geoboresight.io.windows.reduce_windows` over :func:`edge_pairs`."""
    a, b = _inset_only(a, b), _inset_only(b, a)
    return EdgePairs(
        np.concatenate([a.shaded, b.shaded]),
        np.concatenate([a.sunlit, b.sunlit]),
        np.concatenate([a.views, b.views], axis=-1),
        keep_darkest(np.concatenate([a.dark_vnir, b.dark_vnir]), n_dark),
        keep_darkest(np.concatenate([a.dark_swir, b.dark_swir]), n_dark),
        np.concatenate([a.around_shaded, b.around_shaded]),
        np.concatenate([a.around_sunlit, b.around_sunlit]),
        _join(a.steps_vnir, b.steps_vnir),
        _join(a.steps_swir, b.steps_swir),
        _join(a.where, b.where),
        _join(a.inset, b.inset, axis=0),
        a.skipped + b.skipped,
    )


def _inset_only(pairs: EdgePairs, other: EdgePairs) -> EdgePairs:
    """``pairs`` without its edge pixels' pairs (counted in ``skipped``) once it and ``other``
    together hold :data:`geoboresight.shadow.deshadow.MIN_PAIRS` inset pairs: the fit
    (:func:`fit_illumination`) then uses only the inset ones, whatever the other blocks hold."""
    m = pairs.inset
    if m is None or m.all():
        return pairs
    n_other = 0 if other.inset is None else int(other.inset.sum())
    if int(m.sum()) + n_other < deshadow.MIN_PAIRS:
        return pairs
    return _subset(pairs, m)._replace(skipped=pairs.skipped + int(m.size - m.sum()))


def _join(a, b, axis=1):
    """Two blocks' samples of :func:`shadow_steps` (or pair positions) together (None: none
    gathered)."""
    if a is None or b is None:
        return b if a is None else a
    return np.concatenate([a, b], axis=axis)


@dataclass(frozen=True)
class IlluminationFit:
    """The scene's illumination ratio of each band and what it was measured above."""

    ratio: np.ndarray  # k per band (≥ 1: 1 where no ratio above 1 was measured)
    pairs_used: int
    spread: float  # median RMS log difference of the pairs used
    additive: np.ndarray  # additive signal per band (0 without it)
    additive_error: np.ndarray  # its error (inf without it)
    line: np.ndarray  # the line's intercept per band (the pairs of one surface)
    line_error: np.ndarray
    dark_object: np.ndarray  # the dark object per band (NaN without the additive signal)
    adjacency_scale: np.ndarray  # the share of the surroundings' light per band, scaled
    adjacency_share: np.ndarray  # η per band (0 without it)
    one_surface: int = 0  # pairs of one surface (with the additive signal)
    unchanged: int = 0  # bands left unchanged (no ratio above 1)
    # Each band's median signal and noise (σ) in full shadow (:func:`shadow_noise`; NaN
    # unknown), and whether the noise resolves the signal (:func:`resolved_bands`): a band
    # it does not resolve keeps ratio 1, left as measured. None: not measured.
    shadow_signal: np.ndarray | None = None
    shadow_noise: np.ndarray | None = None
    resolved: np.ndarray | None = None
    # Each tile's scale of ``k − 1`` from its own shadows' edges
    # (:func:`geoboresight.shadow.region.region_scale`; NaN: the scene's ratio); None: one
    # ratio for the scene.
    region_scale: np.ndarray | None = None
    # The pairs include the shadows' edge pixels: the scene has too few pixels inside them.
    edge_pairs: bool = False

    @property
    def regions(self) -> int:
        """Tiles of :data:`geoboresight.shadow.region.TILE` px with their own ratio."""
        return 0 if self.region_scale is None else int(np.isfinite(self.region_scale).sum())

    @property
    def unresolved(self) -> int:
        """Bands the noise does not resolve in shadow, left as measured."""
        return 0 if self.resolved is None else int((~self.resolved).sum())


def fit_illumination(
    pairs: EdgePairs,
    wavelengths: np.ndarray,
    *,
    surface: bool = False,
    additive: bool = False,
    adjacency: bool = False,
    min_snr: float = deshadow.MIN_SHADOW_SNR,
    shape: tuple[int, int] | None = None,
    regions: bool = True,
) -> IlluminationFit:
    """The scene's sunlit-to-shadow illumination ratio of each band from the ``pairs``.

    :func:`geoboresight.shadow.deshadow.illumination_ratio` on all the pairs (with a
    ``surface`` model, the sky view of each and all the pairs kept). With ``additive``, the
    additive signal of each band first (:func:`geoboresight.shadow.deshadow.additive_signal`
    on the pairs of one surface, combined with the dark object by
    :func:`geoboresight.shadow.deshadow.combine_additive`), the ratio then measured above it.
    With ``adjacency``, the light of the sunlit surroundings fitted with the ratio
    (:func:`geoboresight.shadow.deshadow.adjacency_ratio`). A band whose pairs do not say the
    sun brightens it (noise, absorption bands) is left as it is: ratio 1; so is a band whose
    signal in full shadow is below ``min_snr`` × its noise there (the pairs' noise samples,
    :func:`shadow_steps`; :func:`geoboresight.shadow.deshadow.resolved_bands`): the data cannot
    resolve its sunlit signal, and scaling it would amplify the noise.

    Parameters
    ----------
    pairs : EdgePairs
        Of the whole flight line (:func:`edge_pairs`, :func:`merge_edge_pairs`).
    wavelengths : array (bands,)
        Band centres (nm): the pairs of one surface have a smooth ratio spectrum.
    surface, additive, adjacency : bool
        A surface model gave the pairs' sky views and incidence; estimate the additive
        signal; the light of the surroundings.
    min_snr : float
        Smallest signal-to-noise ratio in full shadow of a band that is de-shadowed.
    shape : (int, int), optional
        Lines and columns of the flight line: with ``regions`` (and without ``adjacency``),
        each neighbourhood's scale of ``k − 1`` from the pairs of its own shadows
        (:mod:`geoboresight.shadow.region`), the scene's ratio where it has too few.
    regions : bool

    Returns
    -------
    IlluminationFit

    References
    ----------
    Richter, R.; Müller, A. Int. J. Remote Sens. 2005, 26, 3137–3148 (de-shadowing).
    """
    pairs, edge_only = _inset_pairs(pairs)
    a, b, pv = pairs.shaded, pairs.sunlit, pairs.views
    wl = np.asarray(wavelengths, float)
    sky = (pv[0], pv[1]) if surface else None
    direct = pv[2] if surface else None
    keep = deshadow.KEEP_WITH_SURFACE if surface else deshadow.KEEP
    # The pairs that agree are chosen on the bands the noise resolves in shadow: the others
    # would only add their noise to each pair's disagreement (and keep ratio 1 anyway).
    cols = _resolved(pairs, np.zeros(len(wl)), min_snr)[2]
    if cols.sum() < 2:
        cols = np.ones(len(wl), bool)
    k = np.ones(len(wl))
    k[cols], n_pairs, spread = deshadow.illumination_ratio(
        a[:, cols], b[:, cols], sky_view=sky, keep=keep
    )
    c, c_err = np.zeros(len(wl)), np.full(len(wl), np.inf)
    c_line, e_line, dark_obj, n_one = c, c_err, np.full(len(wl), np.nan), 0
    if additive:
        one = deshadow.same_surface(a, b, wl)
        n_one = int(one.sum())
        sky1 = None if sky is None else (sky[0][one], sky[1][one])
        c_line, e_line = deshadow.additive_signal(
            a[one], b[one], k, sky_view=sky1, direct=None if direct is None else direct[one]
        )
        dark_v, dark_s = pairs.dark_vnir, pairs.dark_swir
        dark_obj = np.concatenate(
            [
                deshadow.dark_object(
                    dark_v.T.astype(np.float64), min(deshadow.DARK_PIXELS, len(dark_v))
                ),
                deshadow.dark_object(
                    dark_s.T.astype(np.float64), min(deshadow.DARK_PIXELS, len(dark_s))
                ),
            ]
        )
        c, c_err = deshadow.combine_additive(c_line, e_line, dark_obj, np.median(a, axis=0))
        k, n_pairs, spread = deshadow.illumination_ratio(
            a - c, b - c, sky_view=sky, direct=direct, keep=keep
        )
    adj_scale, eta = np.zeros(len(wl)), np.zeros(len(wl))
    if adjacency:
        around = (pairs.around_shaded - c, pairs.around_sunlit - c)
        k, adj_scale, eta = deshadow.adjacency_ratio(
            a - c, b - c, around, sky_view=sky, direct=direct if additive else None
        )
    brightens = np.isfinite(k) & (k >= 1.0)
    s_sig, s_noise, resolved = _resolved(pairs, c, min_snr)
    k = np.where(brightens & resolved, k, 1.0)
    grid = None
    if regions and shape is not None and pairs.where is not None and not adjacency:
        ratios = region.open_ratios(a - c, b - c, sky_view=sky, direct=direct if additive else None)
        s, rms = region.pair_scales(ratios, k, resolved)
        with np.errstate(invalid="ignore"):
            one = rms <= region.SAME_SURFACE_RMS
        grid = region.region_scale(pairs.where[0], pairs.where[1], s, shape, one)[0]
    return IlluminationFit(
        k,
        n_pairs,
        spread,
        c,
        c_err,
        c_line,
        e_line,
        dark_obj,
        adj_scale,
        eta,
        n_one,
        int((~brightens).sum()),
        s_sig,
        s_noise,
        resolved if pairs.steps_vnir is not None else None,
        grid,
        edge_only,
    )


def _inset_pairs(pairs: EdgePairs) -> tuple[EdgePairs, bool]:
    """The pairs whose shaded pixel is inside its shadow when there are enough of them
    (:data:`geoboresight.shadow.deshadow.MIN_PAIRS`), else all of them (and True)."""
    if pairs.inset is None:
        return pairs, False
    m = np.asarray(pairs.inset, bool)
    if m.sum() < deshadow.MIN_PAIRS and m.size > m.sum():
        return pairs, True
    return _subset(pairs, m), False


def _subset(pairs: EdgePairs, m: np.ndarray) -> EdgePairs:
    """The pairs where ``m`` (bool, one per pair)."""
    return pairs._replace(
        shaded=pairs.shaded[m],
        sunlit=pairs.sunlit[m],
        views=pairs.views[:, m],
        around_shaded=pairs.around_shaded[m],
        around_sunlit=pairs.around_sunlit[m],
        where=None if pairs.where is None else pairs.where[:, m],
        inset=m[m],
    )


def _resolved(pairs: EdgePairs, additive: np.ndarray, min_snr: float):
    """(signal, noise, resolved) of each band in full shadow, the signal above the additive
    signal; all resolved when the pairs carry no noise sample."""
    n = additive.size
    if pairs.steps_vnir is None or pairs.steps_swir is None:
        return np.full(n, np.nan), np.full(n, np.nan), np.ones(n, bool)
    sv, nv = deshadow.shadow_noise(pairs.steps_vnir[0], pairs.steps_vnir[1])
    ss, ns = deshadow.shadow_noise(pairs.steps_swir[0], pairs.steps_swir[1])
    sig = np.concatenate([sv, ss]) - additive
    noise = np.concatenate([nv, ns])
    return sig, noise, deshadow.resolved_bands(sig, noise, min_snr)


def fraction_on_swir_grid(fraction: np.ndarray, offset: tuple[float, float], valid=None):
    """A raster of the VNIR grid (the shadow fraction, the sky view) on the SWIR's grid.

    Parameters
    ----------
    fraction : array (lines, columns)
    offset : (float, float)
        Boresight offset of the SWIR (px, along and across): the raster is moved back by it
        (:func:`geoboresight.sensor.coregister.coregister`, bilinear).
    valid : bool array (lines, columns), optional
        Cells with a value (default: the finite ones).

    Returns
    -------
    array (lines, columns)
        NaN where the moved raster has no value.
    """
    ok = np.isfinite(fraction) if valid is None else valid
    g, g_ok = coregister(np.where(ok, fraction, 0.0), -offset[0], -offset[1], ok, order=1)
    return np.where(g_ok, g, np.nan)


def _surroundings(signal, fraction, valid, sky_view, scale, size):
    """Each pixel's light from its sunlit surroundings, ``scale·(1 − V)·S̄``."""
    if not size:
        return None
    with np.errstate(invalid="ignore"):
        lit_px = valid & (fraction <= deshadow.LIT)
    s_bar = deshadow.surround_signal(signal, lit_px, size)
    return scale[:, None, None] * (1.0 - sky_view)[None] * s_bar


def deshadow_block(
    cube: np.ndarray,
    fraction: np.ndarray,
    sky_view: np.ndarray | None,
    valid: np.ndarray | None = None,
    *,
    base: np.ndarray,
    fit: IlluminationFit,
    n_vnir: int,
    offset: tuple[float, float],
    adjacency_size: int = 0,
    row0: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """The de-shadowed block: each instrument on its own grid (the fraction and the sky view
    moved onto the SWIR's by the boresight ``offset``), each band's signal above ``base``
    (its dark level and additive signal, added back) scaled by
    :func:`geoboresight.shadow.deshadow.deshadow` with ``fit``'s ratio (and the light of the
    sunlit surroundings within ``adjacency_size`` px when it was fitted); with ``fit``'s
    region scales, each pixel's own ratio (:func:`geoboresight.shadow.region.pixel_scale`,
    ``row0`` the block's first line in the flight line).

    Returns
    -------
    (cube, shaded)
        The float32 cube (bands, lines, columns; NaN where invalid) and the valid pixels with
        a shadow fraction above 0.
    """
    ok = np.ones(fraction.shape, bool) if valid is None else np.asarray(valid, bool)
    fs = fraction_on_swir_grid(fraction, offset, np.isfinite(fraction))
    vs = None if sky_view is None else fraction_on_swir_grid(sky_view, offset)
    k, scale = fit.ratio, fit.adjacency_scale
    bv, bs = base[:n_vnir], base[n_vnir:]
    sv, ss = cube[:n_vnir] - bv, cube[n_vnir:] - bs
    av = _surroundings(sv, fraction, ok, sky_view, scale[:n_vnir], adjacency_size)
    as_ = _surroundings(ss, fs, ok, vs, scale[n_vnir:], adjacency_size)
    # The scale varies over tens of pixels: the VNIR grid's serves the SWIR's.
    px = None
    if fit.region_scale is not None:
        px = region.pixel_scale(fit.region_scale, row0, fraction.shape)
    out_v = (
        deshadow.deshadow(
            sv, fraction, ok, ratio=k[:n_vnir], sky_view=sky_view, adjacency=av, scale=px
        )
        + bv
    )
    out_s = (
        deshadow.deshadow(ss, fs, ok, ratio=k[n_vnir:], sky_view=vs, adjacency=as_, scale=px) + bs
    )
    with np.errstate(invalid="ignore"):
        shaded = ok & (fraction > 0)
    return np.concatenate([out_v, out_s]), shaded
