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

With a surface model the geometry chooses the pairs (:func:`pair_indices`: not towards the
sun, where the caster is; about the same height on both sides), and each pixel's light from
the sky is its sky-view factor V times the open sky's (Richter & Müller 2005; ATCOR-4):
shadow ``V·E_sky``, sun ``E_dir + V·E_sky``. The pairs then measure the open-ground ratio
``k = (E_dir + E_sky)/E_sky = V_a·r − V_b + 1`` (r a pair's ratio), and each pixel is scaled
by ``(k − 1 + V)/((k − 1)·(1 − f) + V)`` with its own V.

References
----------
Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens.
2005, 26, 3137–3148 (the shadow function and the scaling of shadowed pixels).
Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
(§3.1: the shadow fraction).
"""

from __future__ import annotations

import warnings

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
#: … and with a surface model, whose sun and heights choose the pairs (the same surface on
#: both sides, mostly): the median of all of them. The consensus would pick one cluster of
#: the remaining mixed pairs as readily as the true one (dev scenes: worst SA 7.7–11.2° with
#: all pairs, 9.9–11.1° with a quarter, on the five model-2 development scenes with the
#: truth fraction).
KEEP_WITH_SURFACE = 1.0
#: Fewest pairs to measure the ratio.
MIN_PAIRS = 20
#: Smallest signal (above the dark level) a pair's band may have (log ratios of noise).
MIN_SIGNAL = 1e-6
#: A pair whose sunlit pixel lies within this angle (°) of the sun's azimuth from the
#: shadowed one is dropped: up-sun of a cast shadow is its caster. Of the 8 directions, 2 or 3
#: are dropped, the down-sun and lateral ones kept.
UP_SUN_DEG = 60.0
#: With heights, a pair is the same surface when its heights differ by at most this (m): half
#: the smallest wall of :mod:`geoboresight.shadow.surface`, over 3 × the 0.3 m noise of a
#: good DSM's difference of two cells.
SAME_HEIGHT_M = 1.0
#: Smallest direct light on a sunlit side's slope (cos i / cos Z) for a pair to measure the
#: ratio or the additive signal: below it the side is in its slope's own shadow, not sunlit.
MIN_DIRECT = 0.05
#: Smallest sky-view factor a pixel is de-shadowed with (its factor stays finite).
MIN_SKY = 0.01
#: Tukey's bisquare tuning constant (in robust standard deviations of the residuals): 95 %
#: efficiency for normal errors (Holland & Welsch 1977), the usual choice.
BISQUARE = 4.685
#: Iterations of the reweighted line fit of :func:`additive_signal`.
ADDITIVE_ITERATIONS = 20
#: Pixels averaged into the dark object of :func:`dark_object` (as ``shadow-map``'s).
DARK_PIXELS = 20
#: Median RMS log difference of the pairs used above which they are reported to agree
#: poorly: 0.2 (about 22 % between two pairs' ratio spectra) is more than skylight varies
#: over a scene, and says the pairs mix materials or the fraction is off.
POOR_SPREAD = 0.2
#: Wavelengths (nm) over which a pair's ratio spectrum must be smooth to be one surface
#: (:func:`same_surface`): silicon's range with signal in shadow, the blue to the NIR …
SMOOTH_NM = (420.0, 900.0)
#: … without the O2 A band (its ratio dips: the direct beam's path is longer than the sky's).
O2_NM = (745.0, 775.0)
#: Side (m) of the square of surroundings whose mean sunlit signal is the light they reflect
#: into a shadow (:func:`surround_signal`): the ground around a shadow that its casters'
#: heights (4–14 m on the validation scenes) hide part of the sky behind, of the order of
#: that height on either side; model 2's own term averages 15 m as well.
ADJACENCY_M = 15.0
#: The adjacency term's share η = A·ρ̄ (the hemisphere's share the surroundings fill times
#: their reflectance, relative to the typical sunlit surface) is searched on this grid,
#: 0–1 (:func:`adjacency_ratio`), then refined.
ADJACENCY_GRID = np.linspace(0.0, 1.0, 26)

#: A band's shadowed signal is resolved when it is at least this many times its noise (σ) in
#: the shadow: a 3σ detection, the signal told from zero at 99.9 % (one-sided, normal noise).
#: Below it the sunlit signal cannot be recovered: the band is flagged and left as measured,
#: since scaling it by the ratio would amplify noise and the dark level's error.
MIN_SHADOW_SNR = 3.0
#: Fewest pairs of neighbouring, fully shadowed pixels that measure a band's noise in shadow;
#: with fewer, no band is flagged.
MIN_NOISE_PIXELS = 30
#: The median absolute deviation's factor to a normal distribution's standard deviation.
MAD_TO_SIGMA = 1.4826

_DIRECTIONS = ((-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1))


def pair_indices(
    fraction: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    distances=DISTANCES,
    full: float = FULL,
    lit: float = LIT,
    own: np.ndarray | None = None,
    toward_sun: tuple[float, float] | None = None,
    heights: np.ndarray | None = None,
    same_height: float = SAME_HEIGHT_M,
    inset: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices (shaded, sunlit) of the pixel pairs across shadow edges: a pixel with
    ``fraction ≥ full`` and one with ``fraction ≤ lit`` ``d`` pixels away in one of the 8
    directions, ``d`` in ``distances``, each at least a pixel from the edge.

    ``toward_sun`` (Δrow, Δcol) points towards the sun on the grid: a pair whose sunlit pixel
    lies within :data:`UP_SUN_DEG` of it is dropped (up-sun of a shadow is its caster: a roof
    or wall, not the shadowed surface). ``heights`` (rows × cols, m): a pair whose two heights
    differ by more than ``same_height`` is dropped (ground next to a roof). ``own`` as
    :func:`shadow_pairs`. ``inset`` False: the shaded pixel may be on its shadow's edge (a
    shadow one or two pixels wide has no pixel inside it).
    """
    f = np.asarray(fraction, np.float64)
    ok = np.isfinite(f)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    with np.errstate(invalid="ignore"):
        shade = ok & (f >= full)
        sun = ok & (f <= lit)
    # One pixel inside each side: an edge pixel mixes in light from the other side (the
    # sensor's blur, a fraction a pixel off), and in the SWIR, where the sunlit signal is
    # 10–30 times the shadowed one, a tenth of sunlit light doubles a shadowed signal.
    if inset:
        shade = _inside(shade)
    sun = _inside(sun)
    if own is not None:
        shade &= np.asarray(own, bool)
    directions = _DIRECTIONS
    if toward_sun is not None:
        t = np.asarray(toward_sun, float)
        t = t / max(float(np.hypot(*t)), 1e-12)
        limit = np.cos(np.radians(UP_SUN_DEG))
        directions = tuple(
            (dy, dx) for dy, dx in _DIRECTIONS if (dy * t[0] + dx * t[1]) / np.hypot(dy, dx) < limit
        )
    z = None if heights is None else np.asarray(heights, np.float64)
    rows, cols = f.shape
    a_idx, b_idx = [], []
    for d in distances:
        for dy, dx in directions:
            sy, sx = dy * d, dx * d
            ys = slice(max(0, -sy), rows - max(0, sy))
            xs = slice(max(0, -sx), cols - max(0, sx))
            yt = slice(max(0, sy), rows - max(0, -sy))
            xt = slice(max(0, sx), cols - max(0, -sx))
            hit = shade[ys, xs] & sun[yt, xt]
            if z is not None:
                with np.errstate(invalid="ignore"):
                    hit &= np.abs(z[ys, xs] - z[yt, xt]) <= same_height
            r, c = np.nonzero(hit)
            a_idx.append((r + ys.start) * cols + (c + xs.start))
            b_idx.append((r + yt.start) * cols + (c + xt.start))
    a = np.concatenate(a_idx) if a_idx else np.zeros(0, int)
    b = np.concatenate(b_idx) if b_idx else np.zeros(0, int)
    return a, b


def inside_shadow(
    fraction: np.ndarray, valid: np.ndarray | None = None, *, full: float = FULL
) -> np.ndarray:
    """The fully shadowed pixels (``fraction ≥ full``, valid) at least a pixel inside their
    shadow: the shaded pixels of :func:`pair_indices` with ``inset`` (bool, rows × cols).

    Its pairs with ``inset`` False whose shaded pixel is one of these are its pairs with
    ``inset`` True, in the same order.
    """
    f = np.asarray(fraction, np.float64)
    ok = np.isfinite(f)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    with np.errstate(invalid="ignore"):
        return _inside(ok & (f >= full))


def _inside(mask: np.ndarray) -> np.ndarray:
    """The pixels of ``mask`` whose 8 neighbours are in it too (the image's border counts as
    in it)."""
    return ndimage.binary_erosion(mask, np.ones((3, 3), bool), border_value=1) & mask


def shadow_pairs(
    cube: np.ndarray,
    fraction: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    distances=DISTANCES,
    full: float = FULL,
    lit: float = LIT,
    own: np.ndarray | None = None,
    toward_sun: tuple[float, float] | None = None,
    heights: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(shaded, sunlit) spectra, each (n_pairs, n_bands), of the pixel pairs across shadow
    edges (:func:`pair_indices`).

    ``cube`` is (n_bands, rows, cols) signal above the dark level; NaN fractions are
    invalid. A strip gives the pairs whose shadowed pixel is its own when read with a halo of
    ``max(distances) + 1`` lines and ``own`` (bool, rows × cols) True on its own lines:
    only shadowed pixels in ``own`` start a pair.
    """
    x = np.asarray(cube)
    ok = np.isfinite(x).all(axis=0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    a, b = pair_indices(
        fraction,
        ok,
        distances=distances,
        full=full,
        lit=lit,
        own=own,
        toward_sun=toward_sun,
        heights=heights,
    )
    flat = x.reshape(x.shape[0], -1)
    return flat[:, a].T.astype(np.float64), flat[:, b].T.astype(np.float64)


def illumination_ratio(
    shaded: np.ndarray,
    sunlit: np.ndarray,
    valid=None,
    *,
    sky_view: tuple[np.ndarray, np.ndarray] | None = None,
    direct: np.ndarray | None = None,
    keep: float = KEEP,
    iterations: int = 5,
    min_pairs: int = MIN_PAIRS,
) -> tuple[np.ndarray, int, float]:
    """Each band's sunlit-to-shadow illumination ratio ``k`` from pairs of shadowed and
    sunlit spectra (:func:`shadow_pairs`).

    The log ratio of each pair is compared with the consensus (first the median over all
    pairs); the ``keep`` share of the pairs with the smallest root-mean-square difference
    over the bands (shape and level: the same surface on both sides) give the next median;
    repeated ``iterations`` times (``keep`` 1: the median of all pairs).

    ``sky_view`` (V_shaded, V_sunlit), each (n,): the pairs' sky-view factors. A shadowed
    pixel gets ``V_a·E_sky``, a sunlit one ``E_dir + V_b·E_sky``, so a pair's ratio ``r``
    gives the open-ground ratio ``k = (E_dir + E_sky)/E_sky = V_a·r − V_b + 1``; that is
    what is averaged and returned (without ``sky_view`` every V is 1: ``k = r``).

    ``direct`` (n,): the direct light on each sunlit side's slope relative to level ground,
    ``cos i / cos Z`` (:func:`geoboresight.shadow.incidence.plane_incidence`); the sunlit
    side then gets ``cos i/cos Z·E_dir + V_b·E_sky`` and ``k = (V_a·r − V_b)·cos Z/cos i + 1``
    (pairs with no direct light on the sunlit side are not used).

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
    a, b = _pair_arrays(shaded, sunlit)
    if not 0 < keep <= 1:
        raise ParameterError(f"parameter 'keep': {keep} is not in (0, 1]")
    good = (a > MIN_SIGNAL) & (b > MIN_SIGNAL)
    with np.errstate(invalid="ignore", divide="ignore"):
        lr = np.where(good, np.log(b) - np.log(a), np.nan)
        if sky_view is not None or direct is not None:
            va, vb = pair_sky_views(sky_view, a.shape[0])
            d = pair_direct(direct, a.shape[0])
            k_open = (va * np.exp(lr) - vb) / d + 1.0
            lr = np.where(k_open > MIN_SIGNAL, np.log(k_open), np.nan)
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
    for _ in range(int(iterations) if keep < 1 else 0):
        rms = np.sqrt(np.nanmean((lr - k) ** 2, axis=1))
        n = max(min_pairs, int(round(keep * lr.shape[0])))
        kept = np.zeros(lr.shape[0], bool)
        kept[np.argsort(rms, kind="stable")[:n]] = True
        with warnings.catch_warnings():
            # A band none of the kept pairs measures keeps the previous estimate.
            warnings.simplefilter("ignore", RuntimeWarning)
            k = np.where(np.isfinite(lr[kept]).any(axis=0), np.nanmedian(lr[kept], axis=0), k)
    spread = float(np.median(np.sqrt(np.nanmean((lr[kept] - k) ** 2, axis=1))))
    return np.exp(k), int(kept.sum()), spread


def _pair_arrays(shaded, sunlit) -> tuple[np.ndarray, np.ndarray]:
    """The pairs' shadowed and sunlit signals as float64 (n, bands) arrays of one shape."""
    a = np.asarray(shaded, np.float64)
    b = np.asarray(sunlit, np.float64)
    if a.shape != b.shape or a.ndim != 2:
        raise InputError(f"pairs must be two (n, bands) arrays, got {a.shape} and {b.shape}")
    return a, b


def pair_sky_views(sky_view, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The pairs' sky-view factors (V_a, V_b), each as (n, 1); 1 without."""
    if sky_view is None:
        return np.ones((n, 1)), np.ones((n, 1))
    va, vb = (np.asarray(v, np.float64).reshape(-1, 1) for v in sky_view)
    if va.shape[0] != n or vb.shape[0] != n:
        raise InputError(f"{va.shape[0]} and {vb.shape[0]} sky-view factors for {n} pairs")
    return va, vb


def pair_direct(direct, n: int) -> np.ndarray:
    """The pairs' ``cos i / cos Z`` as (n, 1); 1 without; NaN where the sunlit side's slope gets
    no direct light (the pair is not used)."""
    if direct is None:
        return np.ones((n, 1))
    d = np.asarray(direct, np.float64).reshape(-1, 1)
    if d.shape[0] != n:
        raise InputError(f"{d.shape[0]} direct-light factors for {n} pairs")
    return np.where(d > MIN_DIRECT, d, np.nan)


def same_surface(
    shaded: np.ndarray, sunlit: np.ndarray, wavelengths: np.ndarray, *, min_pairs: int = MIN_PAIRS
) -> np.ndarray:
    """Which pairs are one surface on both sides, by the smoothness of their ratio spectrum.

    The ratio of a pair of the same surface is the illumination's, smooth in wavelength
    between 420 and 900 nm (E_dir/E_sky falls smoothly with the sky's scattering; the
    O2 band at 760 nm is left out). A pair of two surfaces carries the ratio of their
    reflectances too, with its features (the red edge of vegetation against soil or asphalt).
    The roughness of a pair is the RMS residual of its log ratio over those bands from a
    quadratic in wavelength; the pairs split in two by Otsu's threshold on the log roughness
    (the smooth mode kept). Returns True for every pair when fewer than 5 bands lie in the
    range, or fewer than ``2·min_pairs`` pairs are given (no split)."""
    a = np.asarray(shaded, np.float64)
    b = np.asarray(sunlit, np.float64)
    wl = np.asarray(wavelengths, np.float64).reshape(-1)
    use = (wl >= SMOOTH_NM[0]) & (wl <= SMOOTH_NM[1]) & ~((wl > O2_NM[0]) & (wl < O2_NM[1]))
    n = a.shape[0]
    if use.sum() < 5 or n < 2 * min_pairs:
        return np.ones(n, bool)
    with np.errstate(invalid="ignore", divide="ignore"):
        lr = np.log(b[:, use]) - np.log(a[:, use])
    good = np.isfinite(lr).all(axis=1)
    x = (wl[use] - wl[use].mean()) / max(float(np.ptp(wl[use])), 1e-9)
    design = np.vander(x, 3)
    coef, *_ = np.linalg.lstsq(design, np.where(good[:, None], lr, 0.0).T, rcond=None)
    rough = np.sqrt(((lr.T - design @ coef) ** 2).mean(axis=0))
    t = np.log(np.maximum(rough[good], 1e-12))
    if t.size < 2 * min_pairs:
        return good
    s = np.sort(t)
    i = np.arange(1, s.size)
    c = np.cumsum(s)[:-1]
    w0 = i / s.size
    m0 = c / i
    m1 = (s.sum() - c) / (s.size - i)
    between = w0 * (1 - w0) * (m0 - m1) ** 2
    between[(i < min_pairs)] = -1.0  # the smooth mode holds at least min_pairs
    cut = s[int(np.argmax(between))]
    return good & (np.log(np.maximum(rough, 1e-12)) <= cut)


def additive_signal(
    shaded: np.ndarray,
    sunlit: np.ndarray,
    ratio: np.ndarray,
    *,
    sky_view: tuple[np.ndarray, np.ndarray] | None = None,
    direct: np.ndarray | None = None,
    iterations: int = ADDITIVE_ITERATIONS,
    min_pairs: int = MIN_PAIRS,
) -> tuple[np.ndarray, np.ndarray]:
    """Each band's additive signal ``c``: the part of every pixel's signal that the sun does
    not scale (path radiance, and the remainder of a dark level that differs from band to band
    when one level per instrument was subtracted), from the intercept of a robust line fit of
    the pairs' sunlit signals on their shadowed signals.

    A surface of reflectance ρ reads ``x = ρ·E·g + c`` (E its light, g the gain), so across
    pairs of the same surface ``x_sun − c = k·(x_shade − c)``: the sunlit signals of pairs of
    several materials lie on the line ``x_sun = k·x_shade + (1 − k)·c``, whose intercept
    carries ``c``. Both sides of a pair are measured with error, mostly the texture of the
    surface (the two pixels' reflectances differ by a few per cent), which is the same share
    of either signal: the error of the sunlit side is k times the shadowed side's. That is
    Deming regression with an error-variance ratio of k², whose slope is the ratio of the
    standard deviations (the reduced major axis); ordinary least squares of the sunlit on the
    shadowed signal would flatten the line (errors in the regressor) and bias ``c``. Fitted
    for each band with Tukey's bisquare weights (:data:`BISQUARE` robust standard deviations;
    pairs of two different surfaces are the outliers), reweighted :data:`ADDITIVE_ITERATIONS`
    times from the slope ``ratio`` (:func:`illumination_ratio`) and the median intercept. A
    ``c`` above the dimmest shadowed signal the line fits contradicts the model (every
    surface adds its own positive signal to ``c``): that band is not measured. With
    ``sky_view`` (V_shaded, V_sunlit) the pair's relation is
    ``V_a·(x_sun − c) = (k − 1 + V_b)·(x_shade − c)``, fitted as
    ``V_a·x_sun − (V_b − 1)·x_shade = k·x_shade + (1 − k)·c + (V_a − V_b)·c`` (the last term
    from the previous iteration's ``c``). With ``direct`` (each sunlit side's ``cos i/cos Z``,
    as :func:`illumination_ratio`) the sunlit side's direct light is scaled by its slope:
    ``V_a·(x_sun − c) = ((k − 1)·cos i/cos Z + V_b)·(x_shade − c)``, the same fit with both
    V divided by ``cos i/cos Z``. Without it, pairs on slopes facing the sun more or less than
    level ground lie off the line by their direct light, and where slope and brightness go
    together (relief) the intercept follows them (model 2, relief 15 m: c 200 DN too low in
    the VNIR without, 45 DN too high with the slope).

    The fit needs pairs of surfaces of different brightness (one material alone fixes a point,
    not the line), and pairs of one surface (:func:`same_surface`). Its standard error is
    returned: the weighted least-squares error of the intercept, over ``k − 1`` (so a band
    where ``k`` is about 1, an absorption band, measures ``c`` poorly); the bias that
    light the model leaves out (adjacency, slopes) puts in the line is not in it.

    Returns
    -------
    c : array (n_bands,)
        The additive signal (in the pairs' units; 0 for a band no pair measures).
    error : array (n_bands,)
        Its standard error (inf where not measured).
    """
    a, b = _pair_arrays(shaded, sunlit)
    k0 = np.asarray(ratio, np.float64).reshape(-1)
    if k0.size != a.shape[1]:
        raise InputError(f"{k0.size} illumination ratios for {a.shape[1]} bands")
    va, vb = pair_sky_views(sky_view, a.shape[0])
    d = pair_direct(direct, a.shape[0])
    va, vb = va / d, vb / d
    ok = np.isfinite(a) & np.isfinite(b) & np.isfinite(va) & np.isfinite(vb)
    n_bands = a.shape[1]
    c = np.zeros(n_bands)
    err = np.full(n_bands, np.inf)
    if a.shape[0] < min_pairs:
        return c, err
    z = np.where(ok, a, 0.0)
    u0 = np.where(ok, va * b - (vb - 1.0) * a, 0.0)
    dv = np.where(ok, va - vb, 0.0)
    k = np.where(np.isfinite(k0), k0, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        icpt = np.nanmedian(np.where(ok, u0 - k * z, np.nan), axis=0)
    icpt = np.where(np.isfinite(icpt), icpt, 0.0)
    w = ok.astype(np.float64)
    for _ in range(int(iterations)):
        u = u0 - dv * c
        res = np.where(ok, u - k * z - icpt, np.nan)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            scale = 1.4826 * np.nanmedian(np.abs(res), axis=0)
        scale = np.where(np.isfinite(scale) & (scale > 0), scale, 1.0)
        t = np.where(ok, res / (BISQUARE * scale), 2.0)
        w = np.where(np.abs(t) < 1.0, (1.0 - t**2) ** 2, 0.0)
        sw = w.sum(axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            zm = (w * z).sum(axis=0) / sw
            um = (w * u).sum(axis=0) / sw
            szz = (w * (z - zm) ** 2).sum(axis=0)
            suu = (w * (u - um) ** 2).sum(axis=0)
            k = np.where(szz > 0, np.sqrt(suu / szz), k)
            icpt = um - k * zm
            c = np.where(np.abs(k - 1.0) > 1e-9, icpt / (1.0 - k), 0.0)
        c = np.where(np.isfinite(c), c, 0.0)
    res = np.where(ok, u0 - dv * c - k * z - icpt, 0.0)
    sw = w.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        s2 = (w * res**2).sum(axis=0) / np.maximum(sw - 2.0, 1.0)
        se_icpt = np.sqrt(s2 * (1.0 / sw + zm**2 / szz))
        err = np.where((sw >= min_pairs) & (szz > 0), se_icpt / np.abs(1.0 - k), np.inf)
        # Every surface's shadowed signal is c plus its own (ρ·V·E_sky·g > 0): a line whose
        # c lies above the dimmest pair it fits contradicts the model (not measured).
        floor = np.where(w > 0, z, np.inf).min(axis=0)
    err = np.where(np.isfinite(err) & (c < floor), err, np.inf)
    c = np.where(np.isfinite(err), c, 0.0)
    return c, err


def dark_object(signal: np.ndarray, n: int = DARK_PIXELS) -> np.ndarray:
    """Each band's mean over the ``n`` darkest pixels (by their mean over the bands) of
    ``signal`` (bands, pixels): Chavez's (1988) dark object, per band. Every pixel reads
    ``c`` plus its own positive signal, so this is an upper bound of the additive signal
    ``c``, high by the dark object's own (shadowed) signal. NaN pixels are left out; NaN
    with fewer than ``n`` pixels."""
    x = np.asarray(signal, np.float64)
    x = x[:, np.isfinite(x).all(axis=0)]
    if x.shape[1] < n:
        return np.full(x.shape[0], np.nan)
    idx = np.argpartition(x.mean(axis=0), n - 1)[:n]
    return x[:, idx].mean(axis=1)


def combine_additive(
    line: np.ndarray, line_error: np.ndarray, dark: np.ndarray, shadowed: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each band's additive signal from the line's intercept and the dark object, each
    weighted by its estimated error.

    ``line``, ``line_error``: :func:`additive_signal` (error inf where not measured).
    ``dark``: :func:`dark_object`, c plus the dark object's own signal ``ρ_d·S_b`` (S_b the
    light in shadow times the gain). ``shadowed``: a typical shadowed signal per band (the
    median of the pairs' shadowed sides), ``c + ρ̄·S_b``. The dark object's own signal is
    taken as a share ``α`` of the typical shadowed signal above c, ``α·(shadowed − c)`` (c
    from the line where its error is below ``shadowed − dark``, else ``dark``): the
    bias of a dark surface is its reflectance times the shadow's light, small where the
    shadow gets little light (the SWIR: k 10–30) and large where the sky lights the shadow
    (the blue). ``α`` is the median of ``(dark − c_line)/(shadowed − c_line)`` over the
    bands, weighted by the line's precision there; its scatter over the bands (robust
    standard deviation, the dark object's spectrum differs from the typical shadow's) times
    ``shadowed − c`` is that estimate's error. Per band the two estimates are averaged with
    inverse-variance weights, and the result is kept at or below ``dark`` (no pixel's
    signal above c may be negative). With fewer than 3 bands measured by the line,
    ``dark`` is not used (``line``, 0 where not measured). Returns (c, standard error)."""
    c_l = np.asarray(line, np.float64)
    e_l = np.asarray(line_error, np.float64)
    d = np.asarray(dark, np.float64)
    s = np.asarray(shadowed, np.float64)
    meas = np.isfinite(e_l) & (e_l > 0) & np.isfinite(c_l)
    if meas.sum() < 3 or not np.isfinite(d).all() or not np.isfinite(s).all():
        return np.where(meas, c_l, 0.0), np.where(meas, e_l, np.inf)
    # The line's intercept says where c is only where its error is below the shadowed
    # signal above the dark object; beyond (a band without shadow contrast, e.g. in a water
    # absorption, where the fit is singular) it would move the dark object's estimate by its
    # own noise, and the dark object stands for it.
    informative = meas & (e_l < np.maximum(s - d, MIN_SIGNAL))
    above = np.maximum(s - np.where(informative, c_l, d), MIN_SIGNAL)
    share = (d - c_l)[meas] / above[meas]
    w = (above[meas] / e_l[meas]) ** 2
    order = np.argsort(share)
    cw = np.cumsum(w[order])
    alpha = float(share[order][np.searchsorted(cw, cw[-1] / 2.0)])
    scatter = 1.4826 * float(np.median(np.abs(share - alpha)))
    c_d = d - alpha * above
    e_d = np.maximum(scatter * above, MIN_SIGNAL)
    w_l = np.where(meas, 1.0 / np.where(meas, e_l, 1.0) ** 2, 0.0)
    w_d = 1.0 / e_d**2
    c = (w_l * np.where(meas, c_l, 0.0) + w_d * c_d) / (w_l + w_d)
    return np.minimum(c, d), 1.0 / np.sqrt(w_l + w_d)


def surround_signal(cube: np.ndarray, sunlit: np.ndarray, size: int) -> np.ndarray:
    """Each band's mean signal of the sunlit pixels (``sunlit``, rows × cols) in the
    ``size`` × ``size`` window around each pixel (bands × rows × cols; NaN where the window
    holds no sunlit pixel): the surroundings' ρ̄·E_global·g of ATCOR's terrain-reflected
    light. Pixels beyond the array are not counted (a strip read with ``size // 2`` lines of
    halo gives the whole image's values on its own lines)."""
    x = np.asarray(cube, np.float64)
    m = np.asarray(sunlit, bool) & np.isfinite(x).all(axis=0)
    n = ndimage.uniform_filter(m.astype(np.float64), int(size), mode="constant")
    out = np.empty(x.shape)
    for i in range(x.shape[0]):
        out[i] = ndimage.uniform_filter(np.where(m, x[i], 0.0), int(size), mode="constant")
    with np.errstate(invalid="ignore", divide="ignore"):
        out /= n
    out[:, n < 0.5 / float(size) ** 2] = np.nan
    return out


def adjacency_ratio(
    shaded: np.ndarray,
    sunlit: np.ndarray,
    surround: tuple[np.ndarray, np.ndarray],
    *,
    sky_view: tuple[np.ndarray, np.ndarray],
    direct: np.ndarray | None = None,
    grid: np.ndarray = ADJACENCY_GRID,
    min_pairs: int = MIN_PAIRS,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The open-ground ratio ``k`` and the light reflected by the sunlit surroundings into
    each pixel (ATCOR-4's terrain-reflected term, Richter & Müller 2005), per band, from the
    pairs.

    A pixel of sky-view factor V gets ``V·E_sky`` from the sky and ``(1 − V)·ρ̄·E_global``
    from the surroundings that hide the rest of its hemisphere, ρ̄ their reflectance. The
    surroundings' mean sunlit signal S̄ (:func:`surround_signal`, above any additive signal)
    is ``ρ̄·E_global·g``; relative to a typical sunlit signal S_ref (the median of the
    pairs' sunlit sides, ``ρ_ref·E_global·g``) and with ``E_global/E_sky = k``, the term in
    units of the open sky's light is ``η·k·(1 − V)·S̄/S_ref``, ``η = A·ρ_ref`` (A ≤ 1 the
    share of that light the model gives; ATCOR's A is 1). A pair's ratio is then
    ``r = ((k − 1)·cos i/cos Z + V_b + η·t_b)/(V_a + η·t_a)``, ``t = k·(1 − V)·S̄/S_ref``
    (k from the pairs without the term). For each η of ``grid`` (0–1, then refined about the
    best) the open-ground ratio is the median over the pairs, and η is the one whose
    predicted log ratios leave the least median absolute residual: each band its own.

    ``shaded``, ``sunlit`` (n, bands): signals above the dark level (and additive signal);
    ``surround`` (S̄ at the shadowed and sunlit pixel, each (n, bands); NaN: no term);
    ``sky_view`` (V_a, V_b), ``direct`` as :func:`illumination_ratio`.

    Returns
    -------
    k : array (bands,)
        The open-ground ratio (1 where no pair measures it).
    scale : array (bands,)
        ``η·k₀/S_ref``: the term at a pixel is ``scale·(1 − V)·S̄`` (:func:`deshadow`'s
        ``adjacency``).
    eta : array (bands,)
    """
    a = np.asarray(shaded, np.float64)
    b = np.asarray(sunlit, np.float64)
    n, nb = a.shape
    va, vb = pair_sky_views(sky_view, n)
    s_a, s_b = (np.asarray(s, np.float64) for s in surround)
    if s_a.shape != a.shape or s_b.shape != a.shape:
        raise InputError(f"surroundings of shapes {s_a.shape}, {s_b.shape} for pairs {a.shape}")
    d = pair_direct(direct, n)
    good = (a > MIN_SIGNAL) & (b > MIN_SIGNAL) & np.isfinite(d)
    with np.errstate(invalid="ignore", divide="ignore"):
        lr = np.where(good, np.log(b) - np.log(a), np.nan)
    r = np.exp(lr)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        s_ref = np.nanmedian(np.where(good, b, np.nan), axis=0)
        k0 = np.nanmedian((va * r - vb) / d, axis=0) + 1.0
    k0 = np.where(np.isfinite(k0) & (k0 > 1.0), k0, 1.0)
    ok_ref = np.isfinite(s_ref) & (s_ref > MIN_SIGNAL)
    unit = np.where(ok_ref, k0 / np.where(ok_ref, s_ref, 1.0), 0.0)
    t_a = np.nan_to_num((1.0 - va) * np.clip(s_a, 0.0, None) * unit, nan=0.0)
    t_b = np.nan_to_num((1.0 - vb) * np.clip(s_b, 0.0, None) * unit, nan=0.0)

    def fit(eta):
        pa, pb = va + eta * t_a, vb + eta * t_b
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            rr = np.nanmedian((pa * r - pb) / d, axis=0)
            with np.errstate(invalid="ignore", divide="ignore"):
                pred = np.log(np.maximum(rr * d + pb, MIN_SIGNAL)) - np.log(pa)
            return rr, np.nanmedian(np.abs(lr - pred), axis=0)

    if np.isfinite(lr).any(axis=1).sum() < min_pairs:
        raise InputError(
            f"only {int(np.isfinite(lr).any(axis=1).sum())} pairs of shadowed and sunlit "
            f"pixels to measure the light of the surroundings (need {min_pairs})"
        )
    grid = np.asarray(grid, np.float64)
    best = np.full(nb, np.inf)
    eta = np.zeros(nb)
    step = float(grid[1] - grid[0]) if grid.size > 1 else 0.0
    for e in grid:
        _, disp = fit(np.full(nb, e))
        better = np.nan_to_num(disp, nan=np.inf) < best
        best = np.where(better, disp, best)
        eta = np.where(better, e, eta)
    lo, hi = float(grid.min()), float(grid.max())
    for j in np.linspace(-1.0, 1.0, 11):
        e = np.clip(eta + j * step, lo, hi)
        _, disp = fit(e)
        better = np.nan_to_num(disp, nan=np.inf) < best
        best = np.where(better, disp, best)
        eta = np.where(better, e, eta)
    rr, _ = fit(eta)
    k = np.where(np.isfinite(rr), rr + 1.0, 1.0)
    eta = np.where(ok_ref & np.isfinite(rr), eta, 0.0)
    return k, eta * unit, eta


def deshadow(
    cube: np.ndarray,
    fraction: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    ratio: np.ndarray,
    sky_view: np.ndarray | None = None,
    adjacency: np.ndarray | None = None,
    scale: np.ndarray | None = None,
) -> np.ndarray:
    """The sunlit signal of each pixel: ``L / (1 − f·(1 − 1/k))`` per band (float32; NaN
    where invalid; unchanged where ``f`` is 0).

    With the pixel's sky-view factor V (``sky_view``, rows × cols; ``ratio`` then the
    open-ground ratio, :func:`illumination_ratio` with ``sky_view``) the pixel gets
    ``E_dir·(1 − f) + V·E_sky`` and, in the sun, ``E_dir + V·E_sky``: with ``R = k − 1``
    (E_dir/E_sky) the factor is ``(R + V)/(R·(1 − f) + V)``; V = 1 is the formula above.

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
    sky_view : array (rows, cols), optional
        Sky-view factor of each pixel, 0–1
        (:func:`geoboresight.shadow.skyview.sky_view_factor`; NaN = invalid).
    adjacency : array (n_bands, rows, cols), optional
        The light the sunlit surroundings reflect into each pixel, in units of the open sky's
        (:func:`adjacency_ratio`: ``scale·(1 − V)·S̄``; NaN = none): added to V in both the
        shadowed and the sunlit illumination, so each pixel gets its own ratio.
    scale : array (rows, cols), optional
        Each pixel's scale of ``k − 1`` (its region's own ratio,
        :func:`geoboresight.shadow.region.pixel_scale`): ``R = s·(k − 1)``.
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
    if sky_view is None:
        v = np.ones((1,) + f.shape)
    else:
        v = np.asarray(sky_view, np.float64)[None]
        if v.shape[1:] != f.shape:
            raise InputError(f"sky-view factor of shape {v.shape[1:]} for a {f.shape} image")
        ok &= np.isfinite(v[0])
        # A cell that sees no sky gets nothing from it: a floor keeps the factor finite.
        v = np.clip(np.where(np.isfinite(v), v, 1.0), MIN_SKY, 1.0)
    if adjacency is not None:
        extra = np.asarray(adjacency, np.float64)
        if extra.shape != x.shape:
            raise InputError(f"adjacency term of shape {extra.shape} for a {x.shape} cube")
        v = v + np.clip(np.nan_to_num(extra, nan=0.0), 0.0, None)
    r = (k - 1.0)[:, None, None]
    if scale is not None:
        r = r * np.asarray(scale, np.float64)[None]
    ff = np.where(ok, f, 0.0)[None]
    g = (r + v) / (r * (1.0 - ff) + v)
    out = (x * g).astype(np.float32)
    out[:, ~ok] = np.nan
    return out


def shadow_noise(
    level: np.ndarray, step: np.ndarray, min_pixels: int = MIN_NOISE_PIXELS
) -> tuple[np.ndarray, np.ndarray]:
    """The signal and the noise of each band in full shadow, from neighbouring shadowed pixels.

    Two neighbours of one surface differ by their noise alone, ``Var(Δ) = 2σ²``, so the
    noise is the robust spread of their differences, ``σ = 1.4826·median|Δ| / √2`` (texture
    and the odd edge in the sample only raise it: a band is then flagged sooner, never
    amplified). Measured in shadow, it is the noise at the shadow's own signal (photon noise
    grows with the signal).

    Parameters
    ----------
    level : array (pixels, bands)
        The mean signal (above the dark level) of each pair of neighbours.
    step : array (pixels, bands)
        Their difference.
    min_pixels : int
        Fewest pairs; with fewer, the noise is NaN.

    Returns
    -------
    (signal, noise) : arrays (bands,)
        The median shadowed signal and σ; NaN where fewer than ``min_pixels`` pairs are finite.

    References
    ----------
    Gao, B.-C. An operational method for estimating signal to noise ratios from data acquired
    with imaging spectrometers. Remote Sens. Environ. 1993, 43, 23–33 (local differences).
    Rousseeuw, P.J.; Croux, C. Alternatives to the median absolute deviation. J. Am. Stat.
    Assoc. 1993, 88, 1273–1283 (the MAD's normal consistency factor).
    """
    lv = np.asarray(level, np.float64)
    st = np.asarray(step, np.float64)
    if lv.shape != st.shape or lv.ndim != 2:
        raise InputError(f"levels of shape {lv.shape} for steps of shape {st.shape}")
    n = np.isfinite(lv).sum(axis=0)
    enough = n >= max(int(min_pixels), 1)
    sig = np.full(lv.shape[1], np.nan)
    noise = np.full(lv.shape[1], np.nan)
    if enough.any():
        # Columns with enough finite pairs: no all-NaN slice.
        sig[enough] = np.nanmedian(lv[:, enough], axis=0)
        mad = np.nanmedian(np.abs(st[:, enough]), axis=0)
        noise[enough] = MAD_TO_SIGMA * mad / np.sqrt(2.0)
    return sig, noise


def resolved_bands(
    signal: np.ndarray, noise: np.ndarray, min_snr: float = MIN_SHADOW_SNR
) -> np.ndarray:
    """Bands whose shadowed ``signal`` is at least ``min_snr`` × its ``noise``
    (:func:`shadow_noise`); a band whose noise is unknown (NaN) counts as resolved (nothing
    says otherwise), a band without noise (0) as resolved when its signal is above 0."""
    s = np.asarray(signal, np.float64)
    e = np.asarray(noise, np.float64)
    if not min_snr > 0:
        raise ParameterError(f"parameter 'min_snr': {min_snr} must be above 0")
    with np.errstate(invalid="ignore", divide="ignore"):
        low = np.isfinite(e) & (np.nan_to_num(s, nan=-np.inf) < min_snr * e)
        low |= np.isfinite(e) & (e == 0) & ~(s > 0)
    return ~low
