"""Reading a hyperspectral cube (one file, or VNIR + SWIR side by side) in strips of lines.

Per-pixel spectral work (RX, SVDD, unmixing) needs every band of a strip at once. GDAL reads an
ENVI BIL cube band by band and line by line, which is ~10× slower than the disk; for uncompressed
ENVI files (BSQ, BIL, BIP; any byte order, any header offset) the strip is read with one
sequential read and reordered in NumPy. Other formats go through rasterio.

:meth:`Cube.reader` gives :func:`~geoboresight.io.windows.map_windows` a thread-safe reader
that reuses one buffer per worker thread, so memory stays bounded by a few strips whatever the
flight line's length.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass, field

import numpy as np

from .._threads import default_workers
from ..errors import InputError
from .envi import RawLayout, raw_layout
from .grid import Grid
from .raster import (
    gdal_cache,
    hold_gdal_cache,
    open_dataset,
    open_raster,
    release_gdal_cache,
    tile_row_bytes,
)
from .wavelengths import good_bands, read_wavelengths


@dataclass
class _Part:
    path: str
    count: int
    dtype: np.dtype
    nodata: float | None
    raw: RawLayout | None  # for the fast ENVI path
    tile_row: int = 0  # bytes of a row of GDAL's blocks across the image, all bands
    _fh: object = field(default=None, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, repr=False)


@dataclass(frozen=True)
class RawPart:
    """One file of a :class:`Cube` read straight from disk (:meth:`Cube.raw_parts`): the
    cube's bands ``start:start + count`` (0-based), laid out as ``layout`` says, with the
    file's ``nodata`` value (None when it has none)."""

    path: str
    start: int
    count: int
    nodata: float | None
    layout: RawLayout


class Cube:
    """A cube of ``count`` bands on one pixel grid, read in strips of lines.

    Use :func:`open_cube`. ``wavelengths``/``fwhm`` are in nm (None when the files have none).
    """

    def __init__(self, parts, grid: Grid, wavelengths, fwhm, good=None):
        self._parts = parts
        self.grid = grid
        self.height = grid.height
        self.width = grid.width
        self.crs = grid.crs
        self.transform = grid.transform
        self.wavelengths = wavelengths
        self.fwhm = fwhm
        self.count = sum(p.count for p in parts)
        #: False for the bands an ENVI ``bbl`` marks bad (:func:`good_bands`).
        self.good = np.ones(self.count, bool) if good is None else np.asarray(good, bool)
        self.paths = [p.path for p in parts]
        self._local = threading.local()
        self._selections: dict[bytes, list] = {}
        self._datasets: list = []  # every thread's open datasets, closed by close()
        self._datasets_lock = threading.Lock()
        # A row of tiles of each file read through GDAL for every worker thread (each
        # decodes into its own dataset's blocks) and one more for the next row, which one
        # of them reaches first.
        through_gdal = sum(p.tile_row for p in parts if p.raw is None)
        if through_gdal:
            hold_gdal_cache(self, (default_workers() + 1) * through_gdal)

    def close(self):
        for p in self._parts:
            if p._fh is not None:
                p._fh.close()
                p._fh = None
        with self._datasets_lock:
            datasets, self._datasets = self._datasets, []
        for src in datasets:
            src.close()
        release_gdal_cache(self)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def raw_parts(self) -> tuple[RawPart, ...] | None:
        """The byte layout of each file, in band order, when every file is uncompressed ENVI
        (what a reader that maps the files itself needs); None when any file is read through
        GDAL."""
        if any(p.raw is None for p in self._parts):
            return None
        starts = np.cumsum([0] + [p.count for p in self._parts])
        return tuple(
            RawPart(p.path, int(s), p.count, p.nodata, p.raw)
            for p, s in zip(self._parts, starts, strict=False)
        )

    @property
    def dtype(self) -> np.dtype:
        """The files' own data type (the common type when VNIR and SWIR differ)."""
        return np.result_type(*(p.dtype for p in self._parts))

    def read(self, row0: int, row1: int, bands=None, dtype="float64", out=None):
        """Bands ``bands`` (0-based over all parts) of lines ``row0:row1``.

        Returns ``(data, valid)``: ``data`` of shape (len(bands), rows, width) in ``dtype``
        (None: the files' own type, :attr:`dtype`, which avoids a float copy); ``valid``
        (rows, width) is False where any of those bands is nodata or non-finite. Safe to call
        from several threads.
        """
        dtype = self.dtype if dtype is None else dtype
        bands = np.arange(self.count) if bands is None else np.asarray(bands, dtype=int)
        rows = row1 - row0
        shape = (len(bands), rows, self.width)
        if out is None or out.shape[1] < rows:
            data = np.empty(shape, dtype=dtype)
        else:
            data = out[:, :rows]
        valid = np.ones((rows, self.width), dtype=bool)
        for part, local, sel, runs in self._selection(bands):
            self._read_part(part, row0, row1, local, data, sel, runs)
            for _, j0, n in runs:
                block = data[j0 : j0 + n]
                if part.nodata is not None:
                    valid &= (block != part.nodata).all(axis=0)
                # Integers converted to floats are finite: only a float file needs the check.
                if data.dtype.kind == "f" and part.dtype.kind == "f":
                    valid &= np.isfinite(block).all(axis=0)
        return data, valid

    def _selection(self, bands: np.ndarray):
        """``(part, file bands, output bands, runs)`` of each part holding some of ``bands``
        (:func:`_runs`), worked out once per band list: strips are read many times over."""
        key = bands.tobytes()
        found = self._selections.get(key)
        if found is None:
            found, start = [], 0
            for part in self._parts:
                local = bands - start
                sel = np.flatnonzero((local >= 0) & (local < part.count))
                start += part.count
                if sel.size:
                    found.append((part, local[sel], sel, tuple(_runs(local[sel], sel))))
            self._selections[key] = found
        return found

    def _raw_buffer(self, part, shape):
        """A per-thread, reused buffer for raw reads (a new one per strip would be page-faulted
        in again each time: measured as much time as the read itself)."""
        bufs = self._local.__dict__.setdefault("raw", {})
        n = int(np.prod(shape))
        buf = bufs.get(id(part))
        if buf is None or buf.size < n:
            buf = bufs[id(part)] = np.empty(n, dtype=part.raw.dtype)
        return buf[:n].reshape(shape)

    def _dataset(self, part):
        """This thread's open dataset of a part read through GDAL, opened once: opening a
        product's VRT (and the files it names) for every strip cost a fifth of reading it.
        A dataset is used by one thread only; :meth:`close` closes them all."""
        datasets = self._local.__dict__.setdefault("datasets", {})
        src = datasets.get(id(part))
        if src is None:
            src = datasets[id(part)] = open_dataset(part.path, "image")
            with self._datasets_lock:
                self._datasets.append(src)
        return src

    def _read_part(self, part, row0, row1, local, data, sel, runs):
        if part.raw is None:
            import rasterio
            from rasterio.windows import Window

            with rasterio.Env(**gdal_cache()):
                block = self._dataset(part).read(
                    [int(b) + 1 for b in local], window=Window(0, row0, self.width, row1 - row0)
                )
            for i, j in enumerate(sel):
                data[j] = block[i]
            return
        raw = part.raw
        dt = raw.dtype
        rows, width, count = row1 - row0, self.width, part.count

        def read_at(pos, buf):
            _read_bytes(part, pos, buf)

        if raw.interleave == "bsq":
            buf = self._raw_buffer(part, (rows, width))
            for b, j in zip(local, sel, strict=True):
                read_at(raw.offset + ((int(b) * self.height + row0) * width) * dt.itemsize, buf)
                data[j] = buf
            return
        line = count * width
        buf = self._raw_buffer(part, (rows, line))
        read_at(raw.offset + row0 * line * dt.itemsize, buf)
        if raw.interleave == "bil":
            buf = buf.reshape(rows, count, width)
            # One reordering copy per run of consecutive bands (bad bands left out split them).
            for b0, j0, n in runs:
                np.copyto(
                    data[j0 : j0 + n], buf[:, b0 : b0 + n].transpose(1, 0, 2), casting="unsafe"
                )
        else:  # bip
            buf = buf.reshape(rows, width, count)
            for b0, j0, n in runs:
                np.copyto(
                    data[j0 : j0 + n], buf[:, :, b0 : b0 + n].transpose(2, 0, 1), casting="unsafe"
                )

    @property
    def samples_by_line(self) -> bool:
        """Whether :meth:`pixels` reads sampled pixels line by line: every file is
        uncompressed ENVI with a line's bands together (BIL or BIP)."""
        return all(p.raw is not None and p.raw.interleave != "bsq" for p in self._parts)

    def pixels(self, positions, bands=None, dtype="float64"):
        """Bands ``bands`` of the pixels at sorted flat ``positions`` (line × width + column),
        reading each line that holds one once; None unless every file is BIL or BIP ENVI.

        Returns ``(values (len(bands), n), valid (n,))`` as :meth:`read` would give them at
        those pixels. A line of a band-interleaved file holds every band of every pixel of
        the line, so a random sample of a long flight line costs one small read per line
        drawn, without reordering or converting the line (a strip read does both).
        """
        if not self.samples_by_line:
            return None
        dtype = self.dtype if dtype is None else dtype
        bands = np.arange(self.count) if bands is None else np.asarray(bands, dtype=int)
        pos = np.asarray(positions, dtype=np.int64)
        rows, cols = np.divmod(pos, self.width)
        # Positions are sorted: each line's pixels are one run.
        starts = np.flatnonzero(np.r_[True, rows[1:] != rows[:-1]]) if pos.size else []
        ends = np.r_[starts[1:], pos.size] if pos.size else []
        values = np.empty((len(bands), pos.size), dtype=dtype)
        valid = np.ones(pos.size, bool)
        for part, local, sel, _ in self._selection(bands):
            raw, line = part.raw, part.count * self.width
            buf = np.empty(line, raw.dtype)
            bil = raw.interleave == "bil"
            grid = buf.reshape((part.count, self.width) if bil else (self.width, part.count))
            for a, b in zip(starts, ends, strict=True):
                _read_bytes(part, raw.offset + int(rows[a]) * line * raw.dtype.itemsize, buf)
                got = grid[local[:, None], cols[a:b]] if bil else grid[cols[a:b]][:, local].T
                values[sel, a:b] = got
            if part.nodata is not None:
                valid &= (values[sel] != part.nodata).all(axis=0)
        if values.dtype.kind == "f":
            valid &= np.isfinite(values).all(axis=0)
        return values, valid

    def reader(self, bands=None, dtype="float64"):
        """``read(row0, row1) -> (data, valid)`` for :func:`~geoboresight.io.windows.map_windows`:
        :meth:`read` of ``bands`` in ``dtype`` (None: the files' own type), into one buffer
        reused per thread (a new one per strip would be page-faulted in again each time:
        measured as much time as the read itself). A kernel must not keep the buffer."""
        local = threading.local()

        def read(row0: int, row1: int):
            buf = getattr(local, "buf", None)
            data, valid = self.read(row0, row1, bands, dtype, out=buf)
            if buf is None or buf.shape[1] < data.shape[1]:
                local.buf = data
            return data, valid

        if self.samples_by_line:
            # read_pixels draws a sample through this instead of reading lines as strips.
            read.pixels = lambda positions: self.pixels(positions, bands, dtype)
        else:
            # ... or reads strips of lines, as few as keep a strip's bytes bounded.
            n = self.count if bands is None else len(bands)
            read.line_bytes = n * self.width * np.dtype(dtype or self.dtype).itemsize
        return read


def as_slice(index):
    """``index`` (band indexes) as a slice when it is a contiguous range: a strip's bands are
    then a view of it instead of a copy."""
    index = np.asarray(index)
    if index.size and np.array_equal(index, np.arange(index[0], index[0] + index.size)):
        return slice(int(index[0]), int(index[0]) + index.size)
    return index


def _runs(local: np.ndarray, sel: np.ndarray):
    """``(file band, output band, length)`` of each run where both go up by one."""
    breaks = np.flatnonzero((np.diff(local) != 1) | (np.diff(sel) != 1)) + 1
    for a, b in zip(np.r_[0, breaks], np.r_[breaks, len(local)], strict=True):
        yield int(local[a]), int(sel[a]), int(b - a)


def _read_bytes(part: _Part, pos: int, buf: np.ndarray) -> None:
    """Fill ``buf`` from byte ``pos`` of a part's raw file. One handle per file, read with
    ``pread`` (no shared file position), so worker threads read at once."""
    if part._fh is None:
        with part._lock:
            if part._fh is None:
                part._fh = open(part.raw.file, "rb", buffering=0)
    view, fd, done = memoryview(buf).cast("B"), part._fh.fileno(), 0
    while done < len(view):
        got = os.preadv(fd, [view[done:]], pos + done)
        if got <= 0:
            raise InputError(
                f"{part.raw.file}: the file ends before byte {pos + len(view)} (was it "
                "truncated while being read?)"
            )
        done += got


def open_cube(paths, label: str = "image") -> Cube:
    """Describe one cube, or several files on one grid stacked band-wise (e.g. VNIR then SWIR).

    Raises :class:`InputError` when the files are on different grids.

    Examples
    --------
    Every fourth band of the sample scene's first 64 lines, VNIR then SWIR:

    >>> import numpy as np
    >>> import geoboresight as gb
    >>> with gb.open_cube(["sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr"]) as cube:
    ...     data, valid = cube.read(0, 64, bands=np.arange(0, cube.count, 4))
    >>> data.shape, valid.shape
    ((50, 64, 286), (64, 286))
    """
    if isinstance(paths, str | os.PathLike):
        paths = [paths]
    parts, wls, fws, goods = [], [], [], []
    grid = None
    for path in paths:
        path = os.fspath(path)
        with open_raster(path, label) as src:
            data_path = src.files[0] if src.files else path
            g = Grid.of(src)
            if grid is None:
                grid = g
            else:
                grid.require_same(g, f"{label} {paths[0]}", f"{label} {path}")
            wl, fw = read_wavelengths(src)
            goods.append(good_bands(src))
            wls.append(wl)
            fws.append(fw)
            parts.append(
                _Part(
                    path,
                    src.count,
                    np.dtype(src.dtypes[0]),
                    src.nodata,
                    raw_layout(data_path, src.count, src.height, src.width)
                    if src.driver == "ENVI"
                    else None,
                    tile_row_bytes(src),
                )
            )
    wavelengths = None if any(w is None for w in wls) else np.concatenate(wls)
    fwhm = None if any(f is None for f in fws) else np.concatenate(fws)
    return Cube(parts, grid, wavelengths, fwhm, np.concatenate(goods))


def open_sensors(sensors, label: str = "image"):
    """``(cube, bands, wavelengths, fwhm)`` of the sensors of a dual dataset
    (:class:`~geoboresight.io.dual.SensorFile` values, VNIR first): one cube over what GDAL
    opens for them (their ``reads``; each file once, so a merged cube's two sensors share
    one), the 0-based cube bands of the sensors' (good) bands in the cube's order, and their
    centres and FWHM in nm as the dataset describes them (FWHM None unless every sensor has
    them)."""
    reads = list(dict.fromkeys(s.reads for s in sensors))
    cube = open_cube(reads, label)
    starts = np.cumsum([0] + [p.count for p in cube._parts])[:-1]
    index = np.concatenate(
        [starts[reads.index(s.reads)] + np.asarray(s.bands, int) - 1 for s in sensors]
    )
    wl = np.concatenate([np.asarray(s.wavelengths, float) for s in sensors])
    fw = None
    if all(s.fwhm is not None for s in sensors):
        fw = np.concatenate([np.asarray(s.fwhm, float) for s in sensors])
    order = np.argsort(index, kind="stable")
    return cube, index[order], wl[order], None if fw is None else fw[order]


def raw_bands_reader(vnir: str, swir: str, vbs, sbs):
    """``read(row0, row1) -> ((vnir stack, valid), (swir stack, valid))`` of the 1-based bands
    ``vbs`` of the file ``vnir`` and ``sbs`` of ``swir`` (the same file for a merged cube),
    with the open :class:`Cube`, straight from raw ENVI files; (None, None) when a file is
    not raw ENVI (then GDAL reads band by band: for a BIL file one small read per band and
    line, ~10× slower for a band range on a flight line).

    BIL strips are mapped into memory and only the bands asked for are copied out (the pages
    holding them are all that is read: 2 of 198 bands cost 1/100 of the strip); BSQ and BIP go
    through :class:`~geoboresight.io.cube.Cube` (one read per band; the whole strip)."""
    same = vnir == swir
    cube = open_cube([vnir] if same else [vnir, swir])
    raw = cube.raw_parts()
    if raw is None:
        cube.close()
        return None, None
    parts = [raw[0], raw[0] if same else raw[1]]
    picks = [np.asarray(vbs) - 1, np.asarray(sbs) - 1]

    def one(part, idx, row0, row1):
        if part.layout.interleave != "bil":
            return cube.read(row0, row1, idx + part.start, "float32")
        return _bil_bands(part, idx, row0, row1, cube.width)

    def read(row0: int, row1: int):
        return tuple(one(p, i, row0, row1) for p, i in zip(parts, picks, strict=True))

    return read, cube


def _bil_bands(part: RawPart, idx, row0: int, row1: int, width: int):
    """Bands ``idx`` (0-based) of lines ``row0:row1`` of a raw BIL file, through a memory map
    of the strip (closed before returning): (float32 (bands, lines, columns), valid)."""
    import mmap

    raw = part.layout
    dt = raw.dtype
    line = part.count * width * dt.itemsize
    start = raw.offset + row0 * line
    skip = start % mmap.ALLOCATIONGRANULARITY
    with open(raw.file, "rb") as f:
        mm = mmap.mmap(
            f.fileno(), skip + (row1 - row0) * line, access=mmap.ACCESS_READ, offset=start - skip
        )
    try:
        lines = np.frombuffer(mm, dt, (row1 - row0) * part.count * width, skip)
        # A band range is a view of the map: converted in one copy.
        values = lines.reshape(row1 - row0, part.count, width)[:, as_slice(idx), :]
        values = values.transpose(1, 0, 2)
        del lines
        values = values.astype(np.float32)  # the map is closed below: no view of it is left
    finally:
        mm.close()
    valid = np.ones(values.shape[1:], bool)
    if part.nodata is not None:
        valid &= (values != np.float32(part.nodata)).all(axis=0)
        if np.isnan(part.nodata):
            valid &= ~np.isnan(values).any(axis=0)
    if values.dtype.kind == "f":
        valid &= np.isfinite(values).all(axis=0)
    return values, valid
