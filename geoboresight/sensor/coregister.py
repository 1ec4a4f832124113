"""Co-registration: resample SWIR bands onto the VNIR pixel grid (removing the boresight offset).

The method of the paper uses the boresight effect first (ratio, shadow, relief); the same tool
then corrects it: with the offset measured by :func:`geoboresight.sensor.offset.estimate_offset`
(a constant, or a profile along the flight line to follow drift), SWIR pixel values are
interpolated at ``(r + along, c + across)`` so that they line up with VNIR pixel ``(r, c)``.

The interpolation is a separable convolution with a kernel of a few taps: linear (2 taps per
axis) or Keys' cubic convolution (4 taps, ``a = −1/2``, the cubic GDAL and most resamplers
use). A constant offset gives the same taps to every pixel and every band, so a whole strip of
bands is shifted by two matrix products (BLAS, float32: across-track by a band matrix in
tiles of columns, then along-track), and the valid mask is shifted once for all bands. The
kernel is finite, so a strip's halo is the shift plus two lines, and a valid output never
depends on an invalid input pixel.
"""

from __future__ import annotations

import functools

import numpy as np

from ..errors import InputError, ParameterError

#: Interpolation orders: 0 nearest pixel, 1 linear, 3 Keys' cubic convolution.
ORDERS = {0: "nearest", 1: "linear", 3: "cubic convolution (Keys, a = -0.5)"}
#: The default: cubic convolution keeps a sub-pixel target's peak sharper than linear
#: interpolation, which averages two pixels' noise at half a pixel.
DEFAULT_ORDER = 3
#: Lines and bands shifted at a time. Every NumPy call holds Python's lock for a few
#: microseconds: a strip of a detector (16 lines, all its SWIR bands) is one chunk, so its
#: shift is about ten products, and the strips' worker threads shift at once (16-band groups
#: made five times as many calls, and the threads queued on the lock: 2.4 s against 1.4 s for
#: a pass over 20,000 lines). A whole image goes 32 lines at a time, its temporaries a few MB.
CHUNK_LINES = 32
BAND_GROUP = 128
#: Output columns per across-track product: each is a (lines × (TILE + taps − 1)) by
#: ((TILE + taps − 1) × TILE) matrix product, so the zeros of the band matrix cost (taps − 1)
#: / TILE extra work while each product stays large enough for BLAS (measured on 80 bands ×
#: 16 lines × 286 columns: 0.29 ms with 16 columns, 0.36 ms with 8, 0.38 ms with 24).
TILE = 16
#: Keys' parameter: −1/2 makes the cubic convolution third-order accurate (it reproduces
#: quadratics exactly); Keys (1981), Eq. 15.
KEYS_A = -0.5


def _keys(t: np.ndarray) -> np.ndarray:
    """Keys' cubic convolution kernel at distances ``t`` (Keys 1981, Eq. 15)."""
    t = np.abs(t)
    a = KEYS_A
    near = ((a + 2) * t - (a + 3)) * t * t + 1
    far = ((a * t - 5 * a) * t + 8 * a) * t - 4 * a
    return np.where(t <= 1, near, np.where(t < 2, far, 0.0))


def shift_taps(shift: np.ndarray, order: int = DEFAULT_ORDER) -> tuple[np.ndarray, np.ndarray]:
    """The taps that sample a line at ``i + shift``: ``value = Σ_j w_j · line[i + first + j]``.

    Parameters
    ----------
    shift : float or 1-D array
        Sub-pixel positions to sample, relative to the output index (one per output line).
    order : {0, 1, 3}
        Nearest, linear, or Keys' cubic convolution.

    Returns
    -------
    first : int array (same shape as ``shift``)
        Offset of the first tap.
    weights : float64 array (``shift``'s shape + (taps,))
        The taps' weights; they sum to 1.

    References
    ----------
    Keys, R. Cubic convolution interpolation for digital image processing. IEEE Trans.
    Acoust. Speech Signal Process. 1981, 29, 1153–1160.
    """
    shift = np.asarray(shift, dtype=np.float64)
    if order == 0:
        return np.floor(shift + 0.5).astype(np.int64), np.ones(shift.shape + (1,))
    base = np.floor(shift)
    frac = (shift - base)[..., None]
    if order == 1:
        return base.astype(np.int64), np.concatenate([1 - frac, frac], axis=-1)
    return (base - 1).astype(np.int64), _keys(frac - np.arange(-1, 3))


def tap_lines(along: float | np.ndarray, order: int = DEFAULT_ORDER) -> tuple[int, int]:
    """``(first, stop)``: output line ``r`` of :func:`coregister_stack` reads input lines
    ``r + first … r + stop − 1`` (of the smallest and the largest along-track shift; taps of
    zero weight left out, so a whole-pixel shift reads one line)."""
    along = np.asarray(along, dtype=np.float64)
    low, _ = _live(*shift_taps(along.min(), order))
    high, high_w = _live(*shift_taps(along.max(), order))
    return low, high + len(high_w)


def pixel_taps(
    positions, along: float, across: float, height: int, width: int, order=DEFAULT_ORDER
):
    """The input pixels a constant shift reads for the output pixels at flat ``positions``
    (line × width + column), as :func:`coregister_stack` reads them: for a sample of pixels
    of a long flight line, without shifting the lines that hold them.

    Returns
    -------
    taps : int64 array (n, line taps, column taps)
        Flat positions of the input pixels, clipped into the image.
    weights : (line weights, column weights), float32
        :func:`shift_sampled` combines the taps' values with them.
    inside : bool array (n,)
        Output pixels whose every tap lies inside the image (the others are invalid).
    """
    r_first, r_w, c_first, c_w = _constant_taps(float(along), float(across), order)
    rows, cols = np.divmod(np.asarray(positions, np.int64), width)
    tr = rows[:, None] + r_first + np.arange(len(r_w))
    tc = cols[:, None] + c_first + np.arange(len(c_w))
    inside = (tr.min(1) >= 0) & (tr.max(1) < height) & (tc.min(1) >= 0) & (tc.max(1) < width)
    taps = np.clip(tr, 0, height - 1)[:, :, None] * width + np.clip(tc, 0, width - 1)[:, None, :]
    return taps, (np.asarray(r_w, np.float32), np.asarray(c_w, np.float32)), inside


def shift_sampled(values: np.ndarray, valid: np.ndarray, weights) -> tuple[np.ndarray, np.ndarray]:
    """``(values (k, n) float32, valid (n,))`` of sampled output pixels from their taps'
    ``values`` (k, n, line taps, column taps) and ``valid`` (n, line taps, column taps), with
    :func:`pixel_taps`' weights: across-track, then along-track, in float32, as the strips are
    shifted (equal to them to float32 rounding). An output is valid when all its taps are."""
    r_w, c_w = weights
    ok = valid.all(axis=(1, 2))
    # A zero weight times a NaN is still NaN: invalid taps count as 0 (their outputs are
    # invalid anyway).
    x = np.where(valid, np.asarray(values, np.float32), np.float32(0))
    return (x @ c_w) @ r_w, ok


def coregister_halo(along: float | np.ndarray, order: int = DEFAULT_ORDER) -> tuple[int, int]:
    """``(above, below)``: the lines above and below a strip that :func:`coregister_stack`
    reads to give, on the strip, the values of the whole image (the taps of the smallest and
    the largest along-track shift)."""
    first, stop = tap_lines(along, order)
    return max(0, -first), max(0, stop - 1)


def _check(stack, along, across, order):
    if order not in ORDERS:
        raise ParameterError(
            f"parameter 'order': 0 (nearest), 1 (linear) or 3 (cubic convolution), got {order}"
        )
    rows = stack.shape[-2]
    along = np.asarray(along, dtype=np.float64)
    across = np.asarray(across, dtype=np.float64)
    if not (np.all(np.isfinite(along)) and np.all(np.isfinite(across))):
        raise ParameterError("the offset has non-finite values: fill gaps in the profile first")
    for name, v in (("along", along), ("across", across)):
        if v.ndim > 1 or (v.ndim == 1 and v.shape[0] != rows):
            raise InputError(
                f"the {name}-track offset has {v.size} values for {rows} lines: give one "
                "value, or one per line"
            )
    return along, across


def _live(first, weights) -> tuple[int, np.ndarray]:
    """One constant shift's taps with the zero-weight ones at either end dropped (a whole-pixel
    shift is one tap), as float32."""
    weights = np.asarray(weights)
    nz = np.flatnonzero(weights != 0)
    return int(first) + int(nz[0]), weights[nz[0] : nz[-1] + 1].astype(np.float32)


def _span(first: int, taps: int, n: int) -> tuple[int, int]:
    """Output indices ``[i0, i1)`` whose taps ``i + first … i + first + taps − 1`` are all
    inside ``[0, n)``."""
    i0, i1 = max(0, -first), min(n, n - first - taps + 1)
    return i0, max(i0, i1)


@functools.lru_cache(maxsize=32)
def _constant_taps(along: float, across: float, order: int):
    """``(first line, line weights, first column, column weights)`` of a constant shift, the
    weights as tuples (:func:`_band_matrix`'s cache key): worked out once per offset, since a
    flight line is shifted strip after strip."""
    r_first, r_w = _live(*shift_taps(along, order))
    c_first, c_w = _live(*shift_taps(across, order))
    return r_first, tuple(r_w), c_first, tuple(c_w)


@functools.lru_cache(maxsize=32)
def _band_matrix(weights: tuple, n: int) -> np.ndarray:
    """The ``(n + taps − 1, n)`` matrix ``M`` with ``(x @ M)[j] = Σ_t w_t x[j + t]`` (cached:
    every strip of a line uses the same few; read-only)."""
    taps = len(weights)
    m = np.zeros((n + taps - 1, n), np.float32)
    for t, w in enumerate(weights):
        m[np.arange(n) + t, np.arange(n)] = w
    m.flags.writeable = False
    return m


def _constant(stack, ok, along, across, order, out, lines):
    """The constant-offset case: the same taps for every pixel and band, so the shift is two
    matrix products per chunk of :data:`CHUNK_LINES` lines and :data:`BAND_GROUP` bands, one
    across-track (tiles of :data:`TILE` columns) and one along-track, in float32 with BLAS
    (a handful of multiply–adds per value, without Python's lock); the mask once, for all
    bands. Only output lines ``lines`` are computed."""
    k, rows, cols = stack.shape
    l0, l1 = lines
    r_first, r_w, c_first, c_w = _constant_taps(float(along), float(across), order)
    i0, i1 = _span(r_first, len(r_w), rows)
    i0, i1 = max(i0, l0), max(min(i1, l1), max(i0, l0))
    j0, j1 = _span(c_first, len(c_w), cols)
    valid = np.zeros((l1 - l0, cols), bool)
    # Lines and columns whose taps leave the image are invalid, and 0.
    out[:, : i0 - l0] = 0.0
    out[:, i1 - l0 :] = 0.0
    out[:, :, :j0] = 0.0
    out[:, :, j1:] = 0.0
    if i1 <= i0 or j1 <= j0:
        return out, valid
    n, x0, m = i1 - i0, i0 + r_first, j1 - j0
    nr, nc = len(r_w), len(c_w)
    bad = None if ok is None else ~ok[x0 : x0 + n + nr - 1]
    if bad is not None and not bad.any():
        bad = None
    g, lines_in = min(k, BAND_GROUP), min(CHUNK_LINES, n) + nr - 1
    # Flat buffers, viewed at each chunk's shape: the products need contiguous rows.
    x_buf, u_buf = np.empty(g * lines_in * cols, np.float32), np.empty(g * lines_in * m, np.float32)
    across_m = _band_matrix(c_w, min(TILE, m))
    for a in range(0, n, CHUNK_LINES):
        h = min(CHUNK_LINES, n - a)
        along_m = _band_matrix(r_w, h).T  # (h, h + nr − 1): output line i reads i … i + nr − 1
        for b0 in range(0, k, g):
            kb = min(g, k - b0)
            hin = h + nr - 1
            us = u_buf[: kb * hin * m].reshape(kb, hin, m)
            xs = stack[b0 : b0 + kb, x0 + a : x0 + a + hin]
            if bad is not None or xs.dtype != np.float32 or not xs.flags.c_contiguous:
                # The products read a contiguous float32 chunk: converted once into it
                # (a float32 strip read with its halo is used as it is).
                chunk = x_buf[: kb * hin * cols].reshape(kb, hin, cols)
                np.copyto(chunk, xs, casting="unsafe")
                xs = chunk
            if bad is not None:
                # A zero weight times a NaN is still NaN: invalid values must not reach the
                # products (their outputs are invalid anyway; their neighbours are not).
                xs[:, bad[a : a + hin]] = 0.0
            flat_x, flat_u = xs.reshape(-1, cols), us.reshape(-1, m)
            for c in range(0, m, TILE):
                w = min(TILE, m - c)
                src = flat_x[:, j0 + c_first + c : j0 + c_first + c + w + nc - 1]
                np.matmul(src, across_m[: w + nc - 1, :w], out=flat_u[:, c : c + w])
            o = out[b0 : b0 + kb, i0 - l0 + a : i0 - l0 + a + h, j0:j1]
            np.matmul(along_m, us, out=o)
    inside = valid[i0 - l0 : i1 - l0, j0:j1]
    if ok is None:
        inside[:] = True
        return out, valid
    # An output is valid when every tap it uses is: AND over the taps, along then across.
    v_r = np.logical_and.reduce([ok[x0 + j : x0 + j + n] for j in range(nr)])
    inside[:] = np.logical_and.reduce(
        [v_r[:, j0 + c_first + j : j1 + c_first + j] for j in range(nc)]
    )
    return out, valid


def _per_line(stack, ok, along, across, order, out, lines):
    """An offset per line (drift): each output line gathers its own taps."""
    k, rows, cols = stack.shape
    line = np.arange(*lines)
    r_first, r_w = shift_taps(line + along[line], order)
    c_first, c_w = shift_taps(across[line], order)
    r_idx = r_first[:, None] + np.arange(r_w.shape[1])  # (rows, taps): input line of each tap
    c_idx = c_first[:, None, None] + np.arange(cols)[None, :, None] + np.arange(c_w.shape[1])
    r_in = (r_idx >= 0) & (r_idx < rows)
    c_in = (c_idx >= 0) & (c_idx < cols)  # (rows, cols, taps)
    r_idx, c_idx = np.clip(r_idx, 0, rows - 1), np.clip(c_idx, 0, cols - 1)
    used_r, used_c = r_w != 0, (c_w != 0)[:, None, :]
    # A tap of zero weight neither contributes nor invalidates.
    r_ok = np.all(~used_r | r_in, axis=1)[:, None]
    valid = np.ones((rows, cols), bool) if ok is None else ok
    v_r = np.all(~used_r[:, :, None] | valid[r_idx], axis=1) & r_ok
    v_out = np.all(~used_c | (c_in & np.take_along_axis(v_r[:, :, None], c_idx, axis=1)), axis=2)
    rr = np.arange(len(line))[:, None, None]
    w_r, w_c = r_w.astype(np.float32), c_w.astype(np.float32)
    for b in range(k):
        tmp = np.einsum("rtc,rt->rc", stack[b][r_idx].astype(np.float32), w_r)
        out[b] = np.einsum("rct,rt->rc", tmp[rr, c_idx], w_c)
    out[:, ~v_out] = 0.0
    return out, v_out


def coregister_stack(
    stack: np.ndarray,
    along: float | np.ndarray,
    across: float | np.ndarray,
    valid: np.ndarray | None = None,
    *,
    order: int = DEFAULT_ORDER,
    out: np.ndarray | None = None,
    lines: tuple[int, int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Resample a stack of SWIR bands that share one valid mask onto the VNIR grid.

    Parameters
    ----------
    stack : array (bands, lines, columns), any numeric type
        The SWIR bands (DN or radiance); read as they are, converted to float32 on the fly.
    along, across : float, or 1-D array with one value per line
        Offset of the SWIR image relative to VNIR (see :class:`~geoboresight.sensor.offset.Offset`):
        output ``(r, c)`` is the input at ``(r + along, c + across)``. Per-line values (an
        interpolated :class:`~geoboresight.sensor.offset.OffsetProfile`) follow drift.
    valid : bool array (lines, columns), optional
        Valid SWIR pixels (all bands). The values of invalid pixels are never used.
    order : {0, 1, 3}
        Nearest pixel, linear, or Keys' cubic convolution (the default).
    out : float32 array (bands, output lines, columns), optional
        Where to write the result.
    lines : (start, stop), optional
        The output lines to compute (all by default): a strip read with a halo gives back
        only its own lines.

    Returns
    -------
    resampled : float32 array (bands, output lines, columns)
        The bands interpolated at ``(r + along, c + across)``; values where not valid are
        unspecified (0 where the taps leave the image).
    valid : bool array (output lines, columns)
        Pixels whose every tap (of non-zero weight) is a valid pixel inside the image.

    Raises
    ------
    InputError
        When ``stack`` is not 3-D or a per-line offset has another length than the lines.
    ParameterError
        When ``order`` is not 0, 1 or 3, or the offset has non-finite values.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Figure 1: the
    boresight shift between the VNIR and SWIR images, "automatically corrected prior to data
    analysis" (§5)).
    Keys, R. Cubic convolution interpolation for digital image processing. IEEE Trans.
    Acoust. Speech Signal Process. 1981, 29, 1153–1160.
    """
    stack = np.asarray(stack)
    if stack.ndim != 3:
        raise InputError(f"expected a stack of 2-D bands, got an array of shape {stack.shape}")
    along, across = _check(stack, along, across, order)
    k, rows, cols = stack.shape
    lines = (0, rows) if lines is None else (max(0, lines[0]), lines[1])
    if lines[1] > rows and (np.ptp(along) or np.ptp(across)):
        raise InputError(f"lines {lines} of a per-line offset beyond the stack's {rows} lines")
    if out is None:
        out = np.empty((k, lines[1] - lines[0], cols), np.float32)
    ok = None if valid is None else np.asarray(valid, bool)
    if np.ptp(along) == 0 and np.ptp(across) == 0:
        return _constant(stack, ok, along.flat[0], across.flat[0], order, out, lines)
    along, across = np.broadcast_to(along, (rows,)), np.broadcast_to(across, (rows,))
    return _per_line(stack, ok, along, across, order, out, lines)


def coregister(
    swir: np.ndarray,
    along: float | np.ndarray,
    across: float | np.ndarray,
    valid: np.ndarray | None = None,
    *,
    order: int = DEFAULT_ORDER,
) -> tuple[np.ndarray, np.ndarray]:
    """Resample one SWIR band onto the VNIR grid: :func:`coregister_stack` of one band, with
    non-finite values invalid and NaN where the result is invalid.

    Parameters
    ----------
    swir : 2-D array (lines, columns)
        The SWIR band (non-finite values are invalid).
    along, across : float, or 1-D array with one value per line
        Offset of the SWIR image relative to VNIR.
    valid : bool array, optional
        Valid SWIR pixels.
    order : {0, 1, 3}
        Nearest pixel, linear, or Keys' cubic convolution (the default).

    Returns
    -------
    resampled : float32 array (lines, columns)
        The SWIR values interpolated at ``(r + along, c + across)``; NaN where invalid.
    valid : bool array (lines, columns)
        Pixels whose interpolation used only valid SWIR pixels inside the image.

    Raises
    ------
    InputError
        When ``swir`` is not one 2-D band.
    ParameterError
        When ``order`` is not 0, 1 or 3, or the offset has non-finite values.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Figure 1; §5).
    Keys, R. Cubic convolution interpolation for digital image processing. IEEE Trans.
    Acoust. Speech Signal Process. 1981, 29, 1153–1160.
    """
    img = np.asarray(swir)
    if img.ndim != 2:
        raise InputError(f"expected one 2-D SWIR band, got an array of shape {img.shape}")
    ok = np.isfinite(img) if img.dtype.kind == "f" else np.ones(img.shape, bool)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    # Invalid values are never used, but a NaN times a zero weight is still NaN.
    img = np.where(ok, img, 0) if not ok.all() else img
    out, out_ok = coregister_stack(img[None], along, across, ok, order=order)
    return np.where(out_ok, out[0], np.float32(np.nan)), out_ok


def profile_to_lines(rows: np.ndarray, values: np.ndarray, height: int) -> np.ndarray:
    """Interpolate a per-block offset profile to one value per line (constant beyond the ends)."""
    rows = np.asarray(rows, dtype=float)
    values = np.asarray(values, dtype=float)
    good = np.isfinite(values)
    if not good.any():
        raise InputError("no block of the flight line gave an offset (all clouded or nodata?)")
    return np.interp(np.arange(height, dtype=float), rows[good], values[good])
