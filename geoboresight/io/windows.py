"""The one windowed map: every block loop of the project goes through :func:`map_windows`.

A flight line is processed in full-width strips of ``block_rows`` lines (pushbroom lines run
along rows), so memory is bounded by a few strips whatever the line's length. A strip may be
read with a *halo* of extra lines above and below for neighbourhood work (a cast shadow reaching
across strips, a local RX window); the kernel sees the strip with its halo, and only the strip's
own lines are kept. Strips may go to worker threads (NumPy and BLAS release the GIL); results
always come back in order.

This follows xarray-spatial's pattern (one kernel, written for a NumPy array, reused blockwise):
the kernel never knows it runs on a strip, and the tests compare window-by-window results with
one call on the whole array.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np
from rasterio.enums import MaskFlags
from rasterio.windows import Window

# default_workers: the worker count the operations use, kept here beside map_windows.
from .._threads import default_workers as default_workers
from .._threads import single_threaded_blas
from ..progress import Progress, as_progress

#: Rows per block when streaming a flight line.
DEFAULT_BLOCK_ROWS = 256


def row_windows(height: int, width: int, block_rows: int = DEFAULT_BLOCK_ROWS) -> Iterator[Window]:
    """Full-width strips of ``block_rows`` lines: memory bounded by a strip, not a flight line."""
    block_rows = max(1, int(block_rows))
    for row in range(0, height, block_rows):
        yield Window(0, row, width, min(block_rows, height - row))


@dataclass(frozen=True)
class Block:
    """Where a strip sits: its own lines (``window``), the first image line read (``row0``,
    the halo included) and the strip's own lines inside what was read (``inner``)."""

    window: Window
    row0: int
    inner: slice
    height: int
    width: int

    @property
    def rows(self) -> tuple[int, int]:
        """(first, stop) image lines of the strip itself."""
        return self.window.row_off, self.window.row_off + self.window.height


def _crop(result, inner: slice, rows_read: int):
    """The strip's own lines of a kernel's result computed on the strip and its halo."""
    if isinstance(result, tuple):
        return tuple(_crop(r, inner, rows_read) for r in result)
    if isinstance(result, np.ndarray) and result.ndim >= 2 and result.shape[-2] == rows_read:
        return result[..., inner, :]
    return result


def map_windows(
    read: Callable[[int, int], Any],
    func: Callable[..., Any],
    *,
    height: int,
    width: int,
    block_rows: int = DEFAULT_BLOCK_ROWS,
    halo: tuple[int, int] = (0, 0),
    workers: int = 1,
    progress: Progress | None = None,
    message: str | None = None,
    pass_block: bool = False,
) -> Iterator[tuple[Window, Any]]:
    """Yield ``(window, func(*read(r0, r1)))`` for every strip of a raster, in order.

    Parameters
    ----------
    read : callable(row0, row1) -> tuple of arrays (or one array)
        Reads image lines ``row0:row1`` (e.g. :func:`band_reader`, :meth:`Cube.reader`).
    func : callable
        The kernel, called on what ``read`` returned. Its array results (or a tuple of them)
        computed on a strip with a halo are cropped to the strip's own lines. With
        ``pass_block=True`` it also gets ``block=`` (a :class:`Block`) and returns the strip's
        own lines itself (for kernels that need image coordinates, e.g. local RX).
    height, width : int
        Size of the raster in lines and columns.
    block_rows : int
        Lines per strip.
    halo : (int, int)
        Extra lines read above and below each strip (clipped at the raster's edges).
    workers : int
        Worker threads; 1 runs in the calling thread. ``func`` and ``read`` must be thread-safe
        for more. At most two strips per worker are in flight, and BLAS runs one thread per
        worker: each strip is a matrix product, and a threaded BLAS splitting a product with a
        long inner dimension stalls whenever another process holds a core (measured: 5× slower
        on a loaded 2-core machine).
    progress : Progress, optional
        Updated once per strip (and so checked for cancellation within one strip).
    message : str, optional
        The progress message.

    Examples
    --------
    A kernel over strips of 4 lines of an array (a raster's reader in practice):

    >>> import numpy as np
    >>> import geoboresight as gb
    >>> image = np.arange(12.0).reshape(6, 2)
    >>> for window, part in gb.map_windows(
    ...     lambda row0, row1: image[row0:row1], lambda x: 2 * x, height=6, width=2, block_rows=4
    ... ):
    ...     print(window.row_off, window.height, part.sum())
    0 4 56.0
    4 2 76.0
    """
    progress = as_progress(progress)
    above, below = (max(0, int(h)) for h in halo)
    windows = list(row_windows(height, width, block_rows))
    n = len(windows)

    def task(win: Window):
        r0 = max(0, win.row_off - above)
        r1 = min(height, win.row_off + win.height + below)
        data = read(r0, r1)
        data = data if isinstance(data, tuple) else (data,)
        inner = slice(win.row_off - r0, win.row_off - r0 + win.height)
        if pass_block:
            return func(*data, block=Block(win, r0, inner, height, width))
        result = func(*data)
        return result if (above, below) == (0, 0) else _crop(result, inner, r1 - r0)

    if workers <= 1:
        for i, win in enumerate(windows):
            progress.check()
            result = task(win)
            yield win, result
            progress.update((i + 1) / n, message)
        return

    pending: deque = deque()
    done = 0
    with single_threaded_blas(), ThreadPoolExecutor(int(workers)) as pool:
        try:
            for win in windows:
                progress.check()
                pending.append((win, pool.submit(task, win)))
                if len(pending) >= 2 * workers:
                    win0, fut = pending.popleft()
                    yield win0, fut.result()
                    done += 1
                    progress.update(done / n, message)
            while pending:
                win0, fut = pending.popleft()
                yield win0, fut.result()
                done += 1
                progress.update(done / n, message)
        finally:
            for _, fut in pending:
                fut.cancel()


def reduce_windows(
    read: Callable[[int, int], Any],
    func: Callable[..., Any],
    merge: Callable[[Any, Any], Any],
    initial: Any,
    **options,
) -> Any:
    """Fold ``func``'s per-strip results with ``merge``, starting from ``initial``, in strip
    order (exact merged statistics: moments, histograms, counts). ``options`` are
    :func:`map_windows`'s.

    Examples
    --------
    A sum merged over strips of 4 lines equals the sum of the whole:

    >>> import numpy as np
    >>> import geoboresight as gb
    >>> image = np.arange(12.0).reshape(6, 2)
    >>> total = gb.reduce_windows(
    ...     lambda row0, row1: image[row0:row1], np.sum, lambda a, b: a + b, 0.0,
    ...     height=6, width=2, block_rows=4,
    ... )
    >>> float(total), float(image.sum())
    (66.0, 66.0)
    """
    total = initial
    for _, part in map_windows(read, func, **options):
        total = merge(total, part)
    return total


def read_masked(
    src,
    band: int,
    window: Window | None = None,
    out_shape: tuple[int, int] | None = None,
    *,
    read_mask: bool | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(float32 values, valid mask) of one band: invalid where nodata, masked or non-finite.

    With ``out_shape`` the band is read decimated (nearest neighbour, from the overviews when
    the file has them): a quick look of a whole flight line without reading it all.
    ``read_mask`` says whether a band without nodata has a mask to read (its flags lack
    ``all_valid``), as :func:`masks_to_read` found it; ``None`` looks it up at this call.
    """
    data = src.read(band, window=window, out_shape=out_shape)
    valid = np.ones(data.shape, dtype=bool)
    if src.nodata is not None:
        valid &= data != src.nodata
        if np.isnan(src.nodata):
            valid &= ~np.isnan(data)
    else:
        # Honour an internal mask band (e.g. a GeoTIFF with a per-dataset mask).
        if read_mask is None:
            read_mask = MaskFlags.all_valid not in src.mask_flag_enums[band - 1]
        if read_mask:
            valid &= src.read_masks(band, window=window, out_shape=out_shape) > 0
    values = data.astype("float32", copy=False)
    valid &= np.isfinite(values)
    return values, valid


def masks_to_read(sources) -> list[bool | None]:
    """For each (dataset, band) of ``sources``: whether :func:`read_masked` reads its mask
    band, to pass as its ``read_mask``.

    Looked up once per dataset: ``mask_flag_enums`` asks GDAL for the flags of every band of
    the file at each call, which for a reader of one band strip after strip of a 300-band
    file is 300 look-ups per band per strip. ``None`` (looked up at the read, as without
    ``read_mask``) for a band the file does not have, so that the read fails as it would,
    and for a dataset open for writing, whose nodata or mask may change between reads."""
    flags: dict[int, list] = {}
    found: list[bool | None] = []
    for src, band in sources:
        if getattr(src, "mode", "r") != "r":
            found.append(None)
        elif src.nodata is not None:
            found.append(False)  # the nodata value decides; the mask is not read
        else:
            if id(src) not in flags:
                flags[id(src)] = src.mask_flag_enums
            of_file = flags[id(src)]
            found.append(
                MaskFlags.all_valid not in of_file[band - 1] if 1 <= band <= len(of_file) else None
            )
    return found


def band_reader(src, band: int) -> Callable[[int, int], tuple[np.ndarray, np.ndarray]]:
    """``read(row0, row1) -> (values, valid)`` of one band of an open dataset."""
    (read_mask,) = masks_to_read([(src, band)])

    def read(row0: int, row1: int):
        window = Window(0, row0, src.width, row1 - row0)
        return read_masked(src, band, window, read_mask=read_mask)

    return read


def bands_reader(sources) -> Callable[[int, int], tuple[np.ndarray, np.ndarray]]:
    """``read(row0, row1) -> (values (n, rows, cols), valid)`` of several (dataset, band)
    pairs on one grid: valid where every band is valid. Thread-safe: an open dataset is one
    GDAL handle, so worker threads read one at a time (and compute at once)."""
    lock = threading.Lock()
    sources = list(sources)
    read_masks = masks_to_read(sources)

    def read(row0: int, row1: int):
        vals, valid = [], None
        with lock:
            for (src, band), read_mask in zip(sources, read_masks, strict=True):
                window = Window(0, row0, src.width, row1 - row0)
                v, ok = read_masked(src, band, window, read_mask=read_mask)
                vals.append(v)
                valid = ok if valid is None else valid & ok
        return np.stack(vals), valid

    return read


#: Bytes of a statistic's per-strip values kept in memory after its first pass, so that the
#: later passes do not read and decode the raster again (a compressed GeoTIFF's every tile):
#: a 20,000-line, 286-column float32 band holds 23 MB. A longer line is streamed at every
#: pass, so memory stays bounded whatever the line's length.
KEEP_BYTES = 64 << 20


def value_passes(
    read: Callable[[int, int], Any],
    func: Callable[..., np.ndarray],
    *,
    height: int,
    width: int,
    block_rows: int = DEFAULT_BLOCK_ROWS,
    progress: Progress | None = None,
    message: str | None = None,
    passes: int = 1,
    keep_bytes: int = KEEP_BYTES,
) -> Callable[[], Iterator[np.ndarray]]:
    """``blocks()`` for a statistic that takes several passes over a raster
    (:func:`geoboresight.stats.describe_blocks`, :func:`~geoboresight.stats.order_statistics`):
    each call yields ``func(*read(r0, r1))`` (the strip's values) strip by strip. With
    ``progress``, the k-th call reports in the k-th of ``passes`` equal shares (later calls in
    the last).

    The first complete pass keeps the strips' values (read-only) while they total at most
    ``keep_bytes``; the later calls then yield those instead of reading the raster again.
    Beyond that bound every call streams the raster, in memory bounded by a few strips."""
    done = [0]
    kept: list[list[np.ndarray]] = []  # the values of a complete pass, once they fit

    def blocks() -> Iterator[np.ndarray]:
        k = min(done[0], passes - 1)
        done[0] += 1
        sub = None if progress is None else progress.sub(k / passes, (k + 1) / passes)
        text = f"{message} (pass {done[0]})" if message else None
        if kept:
            return _replay(kept[0], as_progress(sub), text)
        strips = map_windows(
            read,
            func,
            height=height,
            width=width,
            block_rows=block_rows,
            progress=sub,
            message=text,
        )
        return _keeping(strips, kept, keep_bytes)

    return blocks


def _keeping(strips, kept: list, keep_bytes: int) -> Iterator[np.ndarray]:
    """Yield each strip's values; once the pass is complete and they total at most
    ``keep_bytes``, put them in ``kept`` (read-only: a consumer must not change them)."""
    values: list[np.ndarray] | None = []
    size = 0
    for _, v in strips:
        if values is not None:
            size += v.nbytes
            if size <= keep_bytes:
                # A kernel's view of a buffer that its reader reuses would change under us.
                v = v if v.flags.owndata else v.copy()
                v.flags.writeable = False
                values.append(v)
            else:
                values = None
        yield v
    if values is not None and not kept:
        kept.append(values)


def _replay(values: list, progress: Progress, message: str | None) -> Iterator[np.ndarray]:
    """A kept pass, with the progress and the cancellation check a read pass has."""
    n = len(values)
    for i, v in enumerate(values):
        progress.check()
        yield v
        progress.update((i + 1) / n, message)


#: read_pixels reads a strip's lines one by one when fewer than one line in this many is needed:
#: one read per line costs about a millisecond through GDAL (measured: a 50,000-pixel sample of
#: an 80,000-line line, half its lines read one by one, took 3× longer than whole strips).
LINE_READS_BELOW = 8
#: ... and strips of at most this many bytes (a reader's ``line_bytes`` says a line's): a
#: sample of a wide cube read through GDAL in 256-line float64 strips held 0.46 GB per strip
#: (a 1,000-column EnMAP scene, 224 bands).
SAMPLE_STRIP_BYTES = 32 << 20


def read_pixels(
    read: Callable[[int, int], tuple[np.ndarray, np.ndarray]],
    positions: np.ndarray,
    *,
    height: int,
    width: int,
    block_rows: int = DEFAULT_BLOCK_ROWS,
    progress: Progress | None = None,
    message: str | None = "sampling",
) -> tuple[np.ndarray, np.ndarray]:
    """The pixels at sorted flat ``positions`` (line × width + column), reading only the lines
    that hold them.

    ``read`` returns ``(values (n_bands, rows, cols) or (rows, cols), valid (rows, cols))``
    (:func:`bands_reader`, :func:`band_reader`, :meth:`Cube.reader`). A strip of which at most
    one line in :data:`LINE_READS_BELOW` holds a position has those lines read one by one;
    other strips are read whole: a sample of a thousand pixels of a 20,000-line flight line
    reads a thousand lines, not the line. A reader that says its ``line_bytes`` is read in
    strips of at most :data:`SAMPLE_STRIP_BYTES`. Returns ``(values (n_bands, n) or (n,),
    valid (n,))`` in the order of ``positions``.
    """
    pos = np.asarray(positions, dtype=np.int64)
    direct = getattr(read, "pixels", None)
    if direct is not None and pos.size:
        # A reader of band-interleaved files reads the sampled pixels itself (Cube.pixels).
        progress = as_progress(progress)
        progress.check()
        values, ok = direct(pos)
        progress.update(1.0, message)
        return values, ok
    rows = np.unique(pos // width)
    line_bytes = getattr(read, "line_bytes", None)
    if line_bytes:
        block_rows = min(block_rows, max(1, SAMPLE_STRIP_BYTES // int(line_bytes)))

    def take(data, row0, flat):
        # Fancy indexing copies: a reader may reuse its buffer for the next read.
        values, valid = data
        r, c = np.divmod(flat - row0 * width, width)
        return values[..., r, c], valid[r, c]

    def read_strip(row0, row1):
        flat = pos[np.searchsorted(pos, row0 * width) : np.searchsorted(pos, row1 * width)]
        need = rows[np.searchsorted(rows, row0) : np.searchsorted(rows, row1)]
        if need.size * LINE_READS_BELOW > row1 - row0:
            return [take(read(row0, row1), row0, flat)]
        line = flat // width
        return [take(read(r, r + 1), r, flat[line == r]) for r in need]

    parts = [
        part
        for _, strip in map_windows(
            read_strip,
            lambda parts: parts,
            height=height,
            width=width,
            block_rows=block_rows,
            progress=progress,
            message=message,
        )
        for part in strip
    ]
    if not parts:  # no position at all: the bands' shape from one line
        parts = [take(read(0, 1), 0, pos)]
    return (
        np.concatenate([v for v, _ in parts], axis=-1),
        np.concatenate([ok for _, ok in parts]),
    )


@dataclass(frozen=True)
class Sample:
    """How a statistical fit draws its random sample of the whole flight line
    (:func:`sample_windows`): about ``sample_size`` pixels, the same ones for the same
    ``seed``. The default size is the shadow cluster's and the dark-pixel baseline's; an
    operation with another default declares a subclass with it (e.g. the shadow map's
    ``MapSample``).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Sample()
    Sample(sample_size=50000, seed=0)
    """

    sample_size: int = 50_000
    seed: int = 0


def sample_windows(
    read: Callable[[int, int], tuple[np.ndarray, np.ndarray]],
    *,
    height: int,
    width: int,
    size: int,
    seed: int = 0,
    block_rows: int = DEFAULT_BLOCK_ROWS,
    progress: Progress | None = None,
    message: str | None = "sampling",
) -> tuple[np.ndarray, np.ndarray]:
    """A reproducible random sample of about ``size`` pixels of a raster, streamed.

    ``read`` returns ``(values (n_bands, rows, cols), valid (rows, cols))`` (see
    :func:`bands_reader`). Every pixel is drawn with the same probability, so the sample is
    uniform over the whole flight line; only the lines holding drawn pixels are read
    (:func:`read_pixels`). Returns ``(values (n_bands, n), valid (n,))``.
    """
    rng = np.random.default_rng(seed)
    n = height * width
    p = min(1.0, size / max(1, n))
    # The draw is one uniform number per pixel in image order, made a million at a time: the
    # same numbers, so the same sample, as drawing strip by strip while reading.
    chunk = 1 << 20
    positions = np.concatenate(
        [np.flatnonzero(rng.random(min(chunk, n - k)) < p) + k for k in range(0, n, chunk)]
        or [np.empty(0, np.int64)]
    )
    return read_pixels(
        read,
        positions,
        height=height,
        width=width,
        block_rows=block_rows,
        progress=progress,
        message=message,
    )
