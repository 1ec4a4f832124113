"""Dense sub-pixel disparity between the VNIR and SWIR images (paper §3.2, "image matching").

For every pixel, the SWIR window that best matches the VNIR window around it is found by
normalised cross-correlation (NCC) over integer shifts within ±``search_along`` lines and
±``search_across`` columns (±3 / ±1 px by default: the paper's matching accuracy), then refined
to sub-pixel by a parabola through the correlation peak and its neighbours. Local means and
variances of every shift come from box filters (:func:`scipy.ndimage.uniform_filter`), so the
whole map costs a few dozen filter passes: no per-pixel Python loop. Parabolic peak fitting is
biased towards whole pixels ("peak locking"); ``refine`` further passes warp the SWIR image by
the smoothed disparity so far and measure the small residual, where that bias vanishes.

Reliability per pixel: the correlation peak (how alike the windows are) and its sharpness (how
well the position is defined: the curvature of the correlation surface at its peak).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import InputError, ParameterError
from ..progress import Progress, as_progress
from .height import not_gross

#: Matching window (odd, pixels): larger matches more pixels reliably but blurs relief.
WINDOW = 15
#: Integer search range around the global offset: the paper's matching accuracy (± px).
SEARCH_ALONG = 3
SEARCH_ACROSS = 1
#: Reliable where the correlation peak is at least this (0–1) ...
MIN_PEAK = 0.6
#: ... and at least this sharp (curvature of the correlation at its peak).
MIN_SHARPNESS = 0.005
#: Sub-pixel refinement passes (warp and re-match: removes the peak-locking bias).
REFINE = 1


@dataclass(frozen=True)
class Matching:
    """How the VNIR and SWIR images are matched pixel by pixel (§3.2): the window, the search
    range around the global offset, the reliability thresholds and the sub-pixel refinement
    (the keyword options of :func:`disparity_map`, as one value).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Matching()
    Matching(window=15, search_along=3, search_across=1, min_peak=0.6, min_sharpness=0.005,
        refine=1)
    >>> gb.Matching(window=21)  # --window 21: fewer, steadier matches
    Matching(window=21, search_along=3, search_across=1, min_peak=0.6, min_sharpness=0.005,
        refine=1)
    """

    window: int = WINDOW
    search_along: int = SEARCH_ALONG
    search_across: int = SEARCH_ACROSS
    min_peak: float = MIN_PEAK
    min_sharpness: float = MIN_SHARPNESS
    refine: int = REFINE


@dataclass(frozen=True)
class Disparity:
    """SWIR position minus VNIR position of each VNIR pixel's neighbourhood, in pixels.

    ``along``/``across`` are NaN where no peak could be found; ``reliable`` is the mask of pixels
    worth using (valid, peak ≥ ``min_peak``, sharp enough, inside the search range).
    """

    along: np.ndarray
    across: np.ndarray
    peak: np.ndarray
    sharpness: np.ndarray
    reliable: np.ndarray
    window: tuple[int, int]
    search: tuple[int, int]


def _window(window) -> tuple[int, int]:
    size = (int(window), int(window)) if np.isscalar(window) else tuple(int(w) for w in window)
    if len(size) != 2 or min(size) < 3 or any(w % 2 == 0 for w in size):
        raise ParameterError(
            f"parameter 'window': an odd number of pixels >= 3 (or two of them), got {window}"
        )
    return size


def _warp(b, coef, vb, rows, cols, dy, dx, all_valid=False):
    """Moving image sampled at (rows + dy, cols + dx); invalid outside the image.

    ``dy``/``dx`` are scalars (integer shifts: exact copies) or arrays (sub-pixel warps: cubic
    spline on ``coef``, the spline coefficients of ``b`` computed once per image).
    ``all_valid``: ``vb`` is known to be True everywhere.
    """
    height, width = b.shape
    r = rows[:, None] + dy
    c = cols[None, :] + dx
    if np.isscalar(dy) and np.isscalar(dx) and float(dy).is_integer() and float(dx).is_integer():
        ri = np.clip(r, 0, height - 1).astype(np.intp)
        ci = np.clip(c, 0, width - 1).astype(np.intp)
        inside = (r >= 0) & (r < height) & (c >= 0) & (c < width)
        return b[ri, ci], vb[ri, ci] & inside
    r, c = np.broadcast_arrays(r, c)
    out = ndimage.map_coordinates(coef, [r, c], order=3, mode="nearest", prefilter=False)
    return out, _warped_valid(vb, r, c, all_valid)


def _warped_valid(vb, r, c, all_valid):
    """Where the moving image sampled at ``(r, c)`` is valid: its validity ``vb`` interpolated
    bilinearly (0 outside the image) at least 0.999."""
    if all_valid:
        # The same, for an all-valid image, without interpolating it: valid within 0.001 px
        # of the image (beyond, the blend with the 0 outside drops under 0.999).
        height, width = vb.shape
        return (r > -1e-3) & (r < height - 1 + 1e-3) & (c > -1e-3) & (c < width - 1 + 1e-3)
    return ndimage.map_coordinates(vb.astype(np.float32), [r, c], order=1, cval=0.0) > 0.999


def _bspline3(t: np.ndarray) -> np.ndarray:
    """The cubic B-spline's four weights at fractional positions ``t`` (taps −1 … +2)."""
    u = 1.0 - t
    t2, t3 = t * t, t * t * t
    return np.stack([u * u * u, 3 * t3 - 6 * t2 + 4, -3 * t3 + 3 * t2 + 3 * t + 1, t3]) / 6.0


def _warps(coef, vb, rows, cols, base_a, base_c, shifts, all_valid=False):
    """:func:`_warp` at ``(base_a + dy, base_c + dx)`` for every integer shift ``(dy, dx)`` of
    ``shifts``, as a dict. The cubic B-spline's weights depend only on the fractional part of
    the position, the same for every integer shift: they are computed once. Each line tap's
    across-track sum (4 gathered coefficients, the edge clamped as ``map_coordinates``'
    "nearest") serves every shift that reaches that line (the ±1 px refinement: 6 line taps
    × 3 columns instead of 9 shifts × 4), with the same sums as one shift alone."""
    height, width = coef.shape
    r, c = np.broadcast_arrays(rows[:, None] + base_a, cols[None, :] + base_c)
    r0, c0 = np.floor(r), np.floor(c)
    wr, wc = _bspline3(r - r0), _bspline3(c - c0)
    r0, c0 = r0.astype(np.intp), c0.astype(np.intp)
    lo_r, lo_c = min(dy for dy, _ in shifts) - 1, min(dx for _, dx in shifts) - 1
    hi_r, hi_c = max(dy for dy, _ in shifts) + 2, max(dx for _, dx in shifts) + 2
    # The line and column offsets of every tap of every shift, clamped once.
    line_at = {k: np.clip(r0 + k, 0, height - 1) * width for k in range(lo_r, hi_r + 1)}
    col_at = {k: np.clip(c0 + k, 0, width - 1) for k in range(lo_c, hi_c + 1)}
    flat = coef.ravel()
    # Each line tap's across-track sums for every dx, from its columns gathered once (the dx's
    # four-column windows overlap): (line taps, lines, columns) per dx, shared by the shifts'
    # dy. Each weighted sum of four is one einsum (the same sum, term after term, without a
    # temporary per term).
    dxs = sorted({dx for _, dx in shifts})
    sums = {dx: np.empty((hi_r - lo_r + 1,) + r.shape) for dx in dxs}
    for i, k in enumerate(range(lo_r, hi_r + 1)):
        gathered = np.stack([flat.take(line_at[k] + col_at[j]) for j in range(lo_c, hi_c + 1)])
        for dx in dxs:
            window = gathered[dx - 1 - lo_c : dx + 3 - lo_c]
            np.einsum("j...,j...->...", wc, window, out=sums[dx][i])
    out = {}
    for dy, dx in shifts:
        value = np.einsum("i...,i...->...", wr, sums[dx][dy - 1 - lo_r : dy + 3 - lo_r])
        out[(dy, dx)] = value, _warped_valid(vb, r + dy, c + dx, all_valid)
    return out


#: Validity patterns whose moments a strip keeps: one per across-track shift of the search
#: (the moving window leaves the image at the strip's side columns), times the lines at the
#: line's first and last strip; each costs four strip-sized arrays.
PATTERNS = 9


class _Stats:
    """The box-filtered moments of the fixed image ``a`` over the pixels ``w`` where both images
    are valid. ``w`` changes with the shift only where the moving window leaves the image (edge
    columns and lines) or meets an invalid moving pixel, so the few distinct patterns of an
    image without invalid pixels are computed once each.

    Every array of a shift's match is a buffer of its own, reused by the next shift (a new
    array per operation was page-faulted in each time); the arithmetic is the same, operation
    by operation."""

    def __init__(self, a, va, size, min_fill):
        self.a, self.va, self.size, self.min_fill = a, va, size, min_fill
        self._cache: dict = {}
        self._scratch: dict = {}

    def buf(self, slot, dtype=np.float64):
        """A strip-sized buffer for ``slot``, reused by every shift."""
        out = self._scratch.get(slot)
        if out is None:
            out = self._scratch[slot] = np.empty(self.a.shape, dtype)
        return out

    def box(self, x, slot):
        """Box mean of ``x`` (zero outside) into the buffer ``slot``."""
        return ndimage.uniform_filter(x, self.size, mode="constant", output=self.buf(slot))

    def moments(self, w):
        """(count, a·w, mean, variance, no match) of ``a`` over the pixels ``w``, box-filtered;
        "no match" where the window holds too few pixels (``min_fill``, a share of the window)
        or no texture of ``a``, which no shift changes. Kept for :data:`PATTERNS` patterns;
        the moments of any other pattern are valid until the next call."""
        key = hash(np.packbits(w).tobytes())
        hit = self._cache.get(key)
        if hit is not None and np.array_equal(hit[0], w):
            return hit[1]
        keep = len(self._cache) < PATTERNS
        n, aa, ma, var_a = (np.empty(self.a.shape) if keep else self.buf(f"m{i}") for i in range(4))
        none = np.empty(self.a.shape, bool) if keep else self.buf("none", bool)
        t, low = self.buf("t"), self.buf("low", bool)
        f = ndimage.uniform_filter
        aa.fill(0.0)
        np.copyto(aa, self.a, where=w)
        np.copyto(t, w)
        f(t, self.size, mode="constant", output=n)
        with np.errstate(invalid="ignore", divide="ignore"):
            np.divide(f(aa, self.size, mode="constant", output=ma), n, out=ma)
            np.multiply(aa, aa, out=t)
            np.divide(f(t, self.size, mode="constant", output=var_a), n, out=var_a)
            np.subtract(var_a, np.multiply(ma, ma, out=t), out=var_a)
            np.multiply(1e-12, np.add(t, 1.0, out=t), out=t)
        np.less_equal(var_a, t, out=none)
        np.logical_or(np.less(n, self.min_fill, out=low), none, out=none)
        moments = (n, aa, ma, var_a, none)
        if keep:
            self._cache[key] = (w.copy(), moments)
        return moments


def _ncc(stats, bs, vbs, known=None):
    """Windowed NCC of ``a`` and ``bs`` over their common valid pixels (box filters), in
    :class:`_Stats`' buffers: valid until the next shift. ``known``: what does not depend on
    the product of the two windows, already computed for this shift (:func:`_moving_moments`):
    the fixed image's moments over the common pixels, and the moving window's mean, variance
    and "no texture" (then ``bs`` is 0 wherever it is not valid)."""
    if known is None:
        w = np.logical_and(stats.va, vbs, out=stats.buf("w", bool))
        n, aa, ma, var_a, none = stats.moments(w)
        bb = stats.buf("bb")
        bb.fill(0.0)
        np.copyto(bb, bs, where=w)
    else:
        (n, aa, ma, var_a, none), mb, var_b, flat = known
        bb = bs
    t, u = stats.buf("t"), stats.buf("u")
    f = stats.box  # the three sums are used before the next shift reuses the buffers
    with np.errstate(invalid="ignore", divide="ignore"):
        if known is None:
            mb = np.divide(f(bb, 0), n, out=stats.buf(0))
            mb2 = np.multiply(mb, mb, out=t)
        cov = np.divide(f(np.multiply(aa, bb, out=u), 1), n, out=stats.buf(1))
        np.subtract(cov, np.multiply(ma, mb, out=u), out=cov)
        if known is None:
            var_b = np.divide(f(np.multiply(bb, bb, out=bb), 2), n, out=stats.buf(2))
            np.subtract(var_b, mb2, out=var_b)
        ncc = np.divide(cov, np.sqrt(np.multiply(var_a, var_b, out=u), out=u), out=u)
        if known is None:
            flat = np.less_equal(var_b, np.multiply(1e-12, np.add(mb2, 1.0, out=t), out=t))
    # Too few valid pixels, or no texture (variance at round-off level): no match.
    bad = np.logical_or(none, flat, out=stats.buf("bad", bool))
    finite = np.isfinite(ncc, out=stats.buf("finite", bool))
    np.logical_or(bad, np.logical_not(finite, out=finite), out=bad)
    np.copyto(ncc, np.nan, where=bad)
    return ncc


def _moving_moments(wb, c0, nc, n, size):
    """The moving window's mean, variance and "no texture" on every line of the warped image
    ``wb``, at its columns ``c0 … c0 + nc − 1`` and over them only (zero beyond them, as a
    slice of them is padded), with ``n`` the share of each window's pixels that are valid
    (one line's: away from the strip's ends every line has it, to its last bits, which
    SciPy's running box mean leaves). An integer shift along-track then reads them as a
    slice: its own values, operation by operation, within those last bits (the disparity
    within a float32 ulp)."""
    part = np.zeros_like(wb)
    part[:, c0 : c0 + nc] = wb[:, c0 : c0 + nc]
    f = ndimage.uniform_filter
    cols = slice(c0, c0 + nc)
    s0, s1 = (f(x, size, mode="constant")[:, cols] for x in (part, part * part))
    with np.errstate(invalid="ignore", divide="ignore"):
        mb = np.divide(s0, n, out=s0)
        mb2 = mb * mb
        var_b = np.subtract(np.divide(s1, n, out=s1), mb2, out=s1)
        flat = np.less_equal(var_b, np.multiply(1e-12, np.add(mb2, 1.0, out=mb2), out=mb2))
    return mb, var_b, flat


def _parabola(cm, c0, cp):
    """Sub-pixel offset of a parabola's vertex through (-1, cm), (0, c0), (1, cp); curvature."""
    denom = cm - 2.0 * c0 + cp
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = np.where(denom < 0, 0.5 * (cm - cp) / denom, np.nan)
    return np.clip(delta, -0.5, 0.5), -denom / 2.0


def _inside_every_shift(rows, base_a, sa, height, open_ends):
    """Where the moving image sampled at line ``rows + base_a + dy`` stays inside it for every
    integer shift ``|dy| <= sa`` (within :func:`_warp`'s 0.001 px), judged only at the ends in
    ``open_ends`` (first line, last line); None when neither end is open."""
    if not any(open_ends):
        return None
    r = np.asarray(rows)[:, None] + base_a
    inside = np.ones(r.shape, bool)
    if open_ends[0]:
        inside &= r - sa > -1e-3
    if open_ends[1]:
        inside &= r + sa < height - 1 + 1e-3
    return inside


def _match(
    a, va, b, coef, vb, rows, cols, base_a, base_c, sa, sc, size, min_fill, open_ends=(False, False)
):
    """Best shift around (base_a, base_c) within ±sa, ±sc; sub-pixel by parabolas."""
    shifts = [(dy, dx) for dy in range(-sa, sa + 1) for dx in range(-sc, sc + 1)]
    stack = np.empty((len(shifts),) + a.shape, dtype=np.float32)
    # Near an open end (the strip goes on beyond it), only pixels whose every shift samples
    # the moving image inside the strip take part: there every shift has the same validity,
    # whose moments are computed once, instead of a pattern of its own per shift. Those lines
    # are the strip's halo. At the image's own ends each shift keeps the pixels it reaches
    # (a short image would lose the lines its search leaves). Folded into the fixed image's
    # validity once, not into each shift's.
    inside = _inside_every_shift(rows, base_a, sa, b.shape[0], open_ends)
    all_valid = bool(vb.all())
    constant = np.ndim(base_a) == 0 and np.ndim(base_c) == 0
    # A strip inside the line (both ends open) of images without invalid pixels, searched
    # around one shift: every shift's moving window is a slice of one warped image, so its
    # moments are slices of that image's, computed once per across-track shift (two box
    # filters and five array operations less per shift). Rows where a slice differs from
    # the shift's own zero-padded sums lie in the halo.
    shared = constant and all_valid and all(open_ends) and bool(va.all()) and len(rows) > size[0]
    stats = _Stats(a, va if inside is None or shared else va & inside, size, min_fill)
    if constant:
        # One shift for the whole image: warp once by it on the lines and columns the search
        # reaches; every integer shift around it is then a slice (the same samples).
        ext_r = np.arange(rows[0] - sa, rows[-1] + sa + 1)
        ext_c = np.arange(cols[0] - sc, cols[-1] + sc + 1)
        wb, wv = _warp(b, coef, vb, ext_r, ext_c, base_a, base_c, all_valid)
        nr, nc = len(rows), len(cols)
        if shared:
            wb = np.where(wv, wb, 0.0)
            # The validity of an all-valid image is where the window stays inside it: its
            # columns (a middle line's) for each across-track shift, the same on every line.
            side = wv[sa + nr // 2]
            known = {}

        def moved(dy, dx):
            win = (slice(sa + dy, sa + dy + nr), slice(sc + dx, sc + dx + nc))
            if not shared:
                return wb[win], wv[win], None
            cols_ok = np.broadcast_to(side[win[1]], (nr, nc))
            if dx not in known:
                # One validity pattern per across-track shift: its moments, and the moving
                # window's, once, with a middle line's n (every line that the strip's own
                # lines depend on has it, to its last bits; the halo holds the rest).
                fixed = stats.moments(np.logical_and(stats.va, cols_ok))
                n = fixed[0][nr // 2].copy()
                known[dx] = fixed, _moving_moments(wb, sc + dx, nc, n, stats.size)
            fixed, moving = known[dx]
            return wb[win], cols_ok, (fixed, *(m[win[0]] for m in moving))
    else:
        warped = _warps(coef, vb, rows, cols, base_a, base_c, shifts, all_valid)

        def moved(dy, dx):
            return *warped.pop((dy, dx)), None

    for k, (dy, dx) in enumerate(shifts):
        stack[k] = _ncc(stats, *moved(dy, dx))
    best, any_peak = _best_shift(stack)
    iy, ix = np.divmod(best, 2 * sc + 1)
    # A peak on the edge of the search range may lie beyond it: no sub-pixel fit there.
    inner = any_peak & (iy > 0) & (iy < 2 * sa)
    flat, pixel = stack.ravel(), np.arange(a.size).reshape(a.shape)

    def at(jy, jx):  # each pixel's correlation at shift (jy, jx) of the search grid
        return flat.take((jy * (2 * sc + 1) + jx) * a.size + pixel)

    c0 = at(iy, ix)
    jy = np.clip(iy, 1, 2 * sa - 1)
    da, curv_a = _parabola(at(jy - 1, ix), c0, at(jy + 1, ix))
    if sc > 0:
        inner &= (ix > 0) & (ix < 2 * sc)
        jx = np.clip(ix, 1, 2 * sc - 1)
        dc, curv_c = _parabola(at(iy, jx - 1), c0, at(iy, jx + 1))
    else:  # across-track fixed at the centre
        dc, curv_c = np.zeros(a.shape), np.full(a.shape, np.inf)
    ok = inner & np.isfinite(da) & np.isfinite(dc)
    along = np.where(ok, base_a + (iy - sa) + da, np.nan)
    across = np.where(ok, base_c + (ix - sc) + dc, np.nan)
    return along, across, np.where(ok, c0, np.nan), np.where(ok, np.minimum(curv_a, curv_c), np.nan)


def _best_shift(stack):
    """``(index of the best shift, any shift finite)`` per pixel of a (shifts, …) stack of
    correlations, NaN where none: ``argmax`` with NaN as −∞ (the first of equal maxima),
    shift after shift along the stack (an ``argmax`` over its first axis copies it
    transposed)."""
    best = np.zeros(stack.shape[1:], np.intp)
    top = np.where(np.isnan(stack[0]), -np.inf, stack[0])
    for k in range(1, len(stack)):
        better = stack[k] > top  # False where NaN
        best[better] = k
        np.copyto(top, stack[k], where=better)
    return best, np.isfinite(top)


def _smooth(values, size):
    """NaN-aware box mean (the disparity a window actually measures)."""
    good = np.isfinite(values)
    num = ndimage.uniform_filter(np.where(good, values, 0.0), size, mode="nearest")
    den = ndimage.uniform_filter(good.astype(np.float64), size, mode="nearest")
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0.2, num / den, np.nan)


def disparity_map(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    window: int | tuple[int, int] = WINDOW,
    search_along: int = SEARCH_ALONG,
    search_across: int = SEARCH_ACROSS,
    center: tuple[float, float] = (0.0, 0.0),
    refine: int = REFINE,
    min_peak: float = MIN_PEAK,
    min_sharpness: float = MIN_SHARPNESS,
    block_rows: int = 256,
    open_ends: tuple[bool, bool] = (False, False),
    progress: Progress | None = None,
) -> Disparity:
    """Dense sub-pixel disparity of ``swir`` relative to ``vnir``.

    Parameters
    ----------
    vnir, swir : 2-D arrays (lines, columns) on the same grid
        E.g. the 920 nm and 1010 nm bands of the boresight ratio (Eq. 3).
    valid : bool array, optional
        Pixels usable in both images: no nodata, no cloud.
    window : odd int or (rows, cols)
        Matching window in pixels. Larger windows match more pixels reliably but blur relief.
    search_along, search_across : int
        Integer search range (±px) around ``center``.
    center : (along, across)
        Where to search, e.g. the global boresight offset from
        :func:`~geoboresight.sensor.offset.estimate_offset`; may be sub-pixel.
    refine : int
        Passes that warp the SWIR by the smoothed disparity and re-match within ±1 px, removing
        the parabola's peak-locking bias.
    min_peak, min_sharpness : float
        Reliability thresholds on the NCC peak (0–1) and on its curvature.
    block_rows : int
        Lines per block (at least 8): memory is bounded by a block, not by the flight line.
    open_ends : (bool, bool)
        Whether the images are a strip whose flight line goes on beyond their first / last
        line (read with :func:`disparity_halo`'s lines). Near such an end, only pixels that
        every shift of the search samples inside the strip take part, so the search's shifts
        share one validity there (computed once); the strip's own lines are unchanged.
    progress : Progress, optional
        Receives the fraction of blocks matched (and can cancel).

    Returns
    -------
    Disparity
        Per pixel (float32, lines × columns): ``along`` and ``across``, the SWIR position minus
        the VNIR position of the pixel's window (NaN where no peak was found), ``peak`` (the NCC
        at the best match) and ``sharpness`` (its curvature); ``reliable`` (bool) where the
        pixel is valid, the peak reaches ``min_peak`` and the sharpness ``min_sharpness``;
        ``window`` and ``search`` as used.

    Raises
    ------
    InputError
        When the images are not 2-D on the same grid.
    ParameterError
        When ``window`` is not odd and ≥ 3, ``search_along`` < 1, ``search_across`` < 0 or
        ``refine`` < 0.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2: the disparity map
    by image matching of the VNIR and SWIR images, ±3 px along-track and ±1 px across-track;
    Figures 8 and 9(B)).
    Lewis, J.P. Fast normalized cross-correlation. In Proceedings of Vision Interface 1995,
    Quebec City, Canada, 1995; pp. 120–123.
    Shimizu, M.; Okutomi, M. Sub-pixel estimation error cancellation on area-based matching.
    Int. J. Comput. Vis. 2005, 63, 207–224.
    """
    progress = as_progress(progress)
    a_full = np.asarray(vnir, dtype=np.float64)
    b_full = np.asarray(swir, dtype=np.float64)
    if a_full.ndim != 2 or a_full.shape != b_full.shape:
        raise InputError(
            f"VNIR band {a_full.shape} and SWIR band {b_full.shape} must be 2-D and on the "
            "same pixel grid"
        )
    size = _window(window)
    sa, sc = int(search_along), int(search_across)
    if sa < 1 or sc < 0:
        raise ParameterError(
            "parameters 'search_along' (>= 1) and 'search_across' (>= 0): "
            f"got {search_along}, {search_across}"
        )
    if refine < 0:
        raise ParameterError(f"parameter 'refine': >= 0 passes, got {refine}")
    ok_a = np.isfinite(a_full)
    ok_b = np.isfinite(b_full)
    if valid is not None:
        ok_a &= valid
        ok_b &= valid
    a_full = np.where(ok_a, a_full, 0.0)
    b_full = np.where(ok_b, b_full, 0.0)
    coef = ndimage.spline_filter(b_full, order=3, mode="nearest")
    height, width = a_full.shape
    min_fill = 0.5
    halo = _block_halo(size, refine, sa)
    out = {k: np.full((height, width), np.nan, np.float32) for k in ("al", "ac", "pk", "sh")}
    cols = np.arange(width, dtype=np.float64)
    block_rows = max(int(block_rows), 8)
    starts = range(0, height, block_rows)
    for i, s in enumerate(starts):
        e = min(s + block_rows, height)
        r0, r1 = max(0, s - halo), min(height, e + halo)
        rows = np.arange(r0, r1, dtype=np.float64)
        a, va = a_full[r0:r1], ok_a[r0:r1]
        # The images and the block's lines: the same for the first match and each pass.
        inputs = (a, va, b_full, coef, ok_b, rows, cols)
        first = (float(center[0]), float(center[1]), sa, sc)
        al, ac, pk, sh = _match(*inputs, *first, size, min_fill, open_ends)
        for _ in range(refine):
            base_a = _smooth(al, size)
            base_c = _smooth(ac, size)
            hole = ~(np.isfinite(base_a) & np.isfinite(base_c))
            base_a[hole] = center[0]
            base_c[hole] = center[1]
            al2, ac2, pk, sh = _match(*inputs, base_a, base_c, 1, 1, size, min_fill, open_ends)
            keep = np.isfinite(al2) & np.isfinite(al)
            al = np.where(keep, al2, np.nan)
            ac = np.where(keep, ac2, np.nan)
        sl = slice(s - r0, e - r0)
        out["al"][s:e], out["ac"][s:e] = al[sl], ac[sl]
        out["pk"][s:e], out["sh"][s:e] = pk[sl], sh[sl]
        progress.update((i + 1) / math.ceil(height / block_rows), "matching VNIR and SWIR")
    reliable = (
        np.isfinite(out["al"]) & ok_a & (out["pk"] >= min_peak) & (out["sh"] >= min_sharpness)
    )
    return Disparity(
        along=out["al"],
        across=out["ac"],
        peak=out["pk"],
        sharpness=out["sh"],
        reliable=reliable,
        window=size,
        search=(sa, sc),
    )


def disparity_halo(
    window: int | tuple[int, int] = WINDOW,
    *,
    search_along: int = SEARCH_ALONG,
    refine: int = REFINE,
    center_along: float = 0.0,
) -> int:
    """Lines a strip must be read with, above and below, for :func:`disparity_map` on the strip
    to give its own lines as on the whole image: a block's own (the matching windows, and the
    disparity smoothed between passes), the lines the search reaches in the SWIR image, the
    cubic spline's support and the decay of its prefilter (0.268ⁿ: 12 lines, < 10⁻⁶)."""
    size = _window(window)
    fixed = _block_halo(size, int(refine), int(search_along))
    reach = math.ceil(abs(float(center_along))) + int(search_along) + int(refine) + 1
    return fixed + reach + 2 + 12


def _block_halo(size, refine: int, search_along: int) -> int:
    """Lines a block of :func:`disparity_map` is matched with, above and below, for its own
    lines to be matched as in the whole image: the first match's window, then per refinement
    pass the window the disparity is smoothed over and the pass's own window (half a window
    each, a line more for the box filters' edge), and the search's reach into the lines that
    every shift excludes at the moving image's ends."""
    return (size[0] // 2 + 1) * (2 * refine + 1) + search_along + 1


def second_differences(
    disparity: np.ndarray,
    reliable: np.ndarray,
    spacing: int,
    *,
    rows: slice | None = None,
) -> np.ndarray:
    """Second differences ``d(x−s) − 2 d(x) + d(x+s)`` of reliable disparities one ``spacing``
    apart, along the lines and along the columns, whose centre ``x`` lies on the lines ``rows``
    (all lines by default; a strip read with its halo gives its own lines' differences).

    Returns the finite differences: centres line by line, along the lines first, then along the
    columns (:func:`disparity_noise` turns them into σ_d).
    """
    d = np.where(reliable, disparity, np.nan).astype(np.float64)
    s = int(spacing)
    lines = range(d.shape[0])[rows if rows is not None else slice(None)]
    r0, r1 = lines.start, lines.stop
    out = []
    lo, hi = max(r0, s), min(r1, d.shape[0] - s)
    if hi > lo:
        out.append((d[lo - s : hi - s] - 2 * d[lo:hi] + d[lo + s : hi + s]).ravel())
    if d.shape[1] > 2 * s and r1 > r0:
        own = d[r0:r1]
        out.append((own[:, : -2 * s] - 2 * own[:, s:-s] + own[:, 2 * s :]).ravel())
    sec = np.concatenate(out) if out else np.empty(0)
    return sec[np.isfinite(sec)]


def noise_from_differences(seconds: np.ndarray, min_pairs: int = 50) -> float:
    """σ_d from second differences of independent disparities (see :func:`disparity_noise`)."""
    sec = np.asarray(seconds, np.float64)
    if sec.size < min_pairs:
        return float("nan")
    # Drop only gross blunders (> 10 robust σ), which the cell medians remove anyway; the
    # relief test's cut.
    sec = sec[not_gross(sec)]
    return float(np.sqrt(np.mean(sec**2) / 6.0))


def disparity_noise(
    disparity: np.ndarray, reliable: np.ndarray, spacing: int, min_pairs: int = 50
) -> float:
    """Matching precision σ_d (px) estimated from the data.

    Disparities one ``spacing`` apart (a matching window) come from independent windows. Their
    second difference ``d(x−s) − 2 d(x) + d(x+s)`` cancels the relief's slope and has variance
    ``6 σ_d²`` for independent errors. The root mean square is used, not a robust spread: the
    occasional bad match is part of the error a DEM inherits (on simulated scenes a robust
    estimate was 2–3× smaller than the true RMS error at small squint). Relief that bends
    within ``2 · spacing`` (building edges) inflates the estimate: it errs on the safe side.
    Both directions are pooled. Returns NaN when fewer than ``min_pairs`` triples are available.
    """
    return noise_from_differences(second_differences(disparity, reliable, spacing), min_pairs)
