"""Opening rasters, reading blocks with their validity mask, and writing GeoTIFF/ENVI outputs.

Raw sensor geometry (no CRS, no geotransform) is common for pushbroom data: it is read without
``NotGeoreferencedWarning`` noise and written back without inventing a CRS or transform.
"""

from __future__ import annotations

import contextlib
import contextvars
import logging
import os
import re
import threading
import warnings
import weakref
from xml.sax.saxutils import escape

import numpy as np
import rasterio
import rasterio.shutil
from rasterio.enums import Resampling
from rasterio.errors import NotGeoreferencedWarning, RasterioIOError
from rasterio.transform import Affine
from rasterio.windows import Window

from .._version import __version__
from ..errors import InputError, OutputError, ParameterError, shown
from .envi import ENVI_DTYPES, data_for_header, envi_header, is_compressed
from .grid import DEFLATE_LEVEL, FLOAT_NODATA, TILE, Grid
from .wavelengths import format_wavelengths, unit_scale
from .write import atomic_output, output_error, scrub, temp_name

#: GDAL's block cache (MB): the tiles a single-band product's strip shares with the next
#: strips and its halo. GDAL's default (5 % of RAM) would fill up as a flight line streams by.
GDAL_CACHE_MB = 8
#: The most the block cache holds for the open cubes' rows of tiles (MB): a bound on the
#: memory it adds to a run, whatever the tiles (a cube tiled wider is decoded again in part).
GDAL_CACHE_MAX_MB = 512
#: Bytes of GDAL's block cache that each open cube needs (GDAL has one cache per process).
_cache_needs: dict[int, int] = {}
_cache_lock = threading.Lock()


def gdal_cache() -> dict:
    """The options of a ``rasterio.Env`` sizing GDAL's block cache: :data:`GDAL_CACHE_MB`, or
    what an open cube needs (:func:`hold_gdal_cache`) up to :data:`GDAL_CACHE_MAX_MB`, so
    memory stays bounded whatever the line's length. None when the user sets
    ``GDAL_CACHEMAX``: theirs wins."""
    if os.environ.get("GDAL_CACHEMAX"):
        return {}
    with _cache_lock:
        need = max(_cache_needs.values(), default=0)
    size = min(max(need, GDAL_CACHE_MB << 20), GDAL_CACHE_MAX_MB << 20)
    # rasterio hands an integer GDAL_CACHEMAX to GDALSetCacheMax64, which counts bytes.
    return {"GDAL_CACHEMAX": size}


def hold_gdal_cache(owner, nbytes: int) -> None:
    """Let :func:`gdal_cache` keep ``nbytes`` while ``owner`` lives or until
    :func:`release_gdal_cache`: a cube read in strips through GDAL needs the row of tiles a
    strip lies in (the next strips read the same tiles), or every strip decodes its tiles
    again (a 256-line tile, read 16 lines at a time, 16 times)."""
    key = id(owner)
    with _cache_lock:
        _cache_needs[key] = int(nbytes)
    weakref.finalize(owner, _forget, key)


def release_gdal_cache(owner) -> None:
    """What :func:`hold_gdal_cache` kept for ``owner`` is no longer needed."""
    _forget(id(owner))


def _forget(key: int) -> None:
    with _cache_lock:
        _cache_needs.pop(key, None)


def tile_row_bytes(src) -> int:
    """Bytes of one row of ``src``'s blocks across the image, all bands (what GDAL decodes
    for a strip of lines that lies in one row of tiles); 0 for a VRT, whose blocks GDAL
    reads from its sources' (caching the VRT's own would only copy them)."""
    if src.driver == "VRT":
        return 0
    rows, cols = src.block_shapes[0]
    across = -(-src.width // max(1, cols))
    return across * rows * cols * sum(np.dtype(d).itemsize for d in src.dtypes)


#: How GeoTIFF outputs are written in this context: (Cloud-Optimised?, creation options,
#: ground sample distance in metres for raw-geometry outputs or None).
_WRITER: contextvars.ContextVar[tuple[bool, dict, float | None]] = contextvars.ContextVar(
    "geoboresight_writer", default=(False, {}, None)
)

#: The local engineering CRS of a raw-geometry output written with a known GSD: metres across
#: (x) and along (y, line 0 at the top) the track from the first pixel, no Earth position
#: (no datum, no ellipsoid). GDAL writes it as a user-defined GeoTIFF model; QGIS (3.22 and
#: later) reads it as a valid, non-geographic CRS in metres, so distances are right and the 3D
#: view, which refuses geographic CRSs, accepts it.
RAW_LOCAL_WKT = (
    'LOCAL_CS["geoboresight raw sensor geometry (metres from the GSD, no Earth position)",'
    'LOCAL_DATUM["none",32767],UNIT["metre",1],AXIS["X",EAST],AXIS["Y",NORTH]]'
)


def raw_local_grid(grid: Grid, gsd_m: float) -> Grid:
    """``grid`` (raw sensor geometry) in :data:`RAW_LOCAL_WKT`: pixels ``gsd_m`` metres wide,
    column c at x = c·GSD, line r at y = −r·GSD (north-up display, line 0 on top)."""
    from rasterio.crs import CRS

    return Grid(
        grid.width, grid.height, CRS.from_wkt(RAW_LOCAL_WKT), Affine(gsd_m, 0, 0, 0, -gsd_m, 0)
    )


_CO_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")


def parse_creation_options(co, label: str = "co") -> dict:
    """GDAL creation options from rio's ``NAME=VALUE`` convention: a text
    ``"NAME=VALUE,NAME=VALUE"``, a list of such texts, or a dict; names upper-cased.
    Raise :class:`ParameterError` naming ``label`` for an entry without ``=``."""
    if not co:
        return {}
    if isinstance(co, dict):
        items = [f"{k}={v}" for k, v in co.items()]
    else:
        texts = [co] if isinstance(co, str) else list(co)
        items = [i.strip() for t in texts for i in str(t).split(",") if i.strip()]
    out = {}
    for item in items:
        name, sep, value = item.partition("=")
        name, value = name.strip(), value.strip()
        if not sep or not _CO_NAME.match(name) or not value:
            raise ParameterError(
                f"parameter '{label}': {shown(item)} is not NAME=VALUE (e.g. COMPRESS=LZW,"
                "BLOCKSIZE=512); see GDAL's GTiff and COG driver pages for the names"
            )
        out[name.upper()] = value
    return out


def check_creation_options(driver: str, options: dict, label: str = "co") -> None:
    """Raise :class:`ParameterError` when GDAL's ``driver`` does not know an option or value.

    GDAL only logs a warning and ignores such an option, so the output would silently not be
    what was asked: a 1 × 1 file is created in memory and GDAL's complaints are collected.
    """
    if not options:
        return
    complaints: list[str] = []

    class _Collect(logging.Handler):
        def emit(self, record):
            msg = record.getMessage()
            if "creation option" in msg or "not recognised" in msg or "unexpected value" in msg:
                complaints.append(msg.split(" in ", 1)[-1])

    logger = logging.getLogger("rasterio._env")
    handler = _Collect(logging.WARNING)
    logger.addHandler(handler)
    # A logger configured quieter than WARNING would drop the complaints before the handler.
    level = logger.level
    if logger.getEffectiveLevel() > logging.WARNING:
        logger.setLevel(logging.WARNING)
    probe = f"/vsimem/geoboresight_co_{os.getpid()}_{id(options)}.tif"
    try:
        with quiet_georef(), rasterio.Env():
            if driver == "COG":
                with rasterio.open(
                    "/vsimem/src_" + probe[8:],
                    "w",
                    driver="GTiff",
                    width=1,
                    height=1,
                    count=1,
                    dtype="uint8",
                ) as src:
                    src.write(np.zeros((1, 1, 1), "uint8"))
                rasterio.shutil.copy("/vsimem/src_" + probe[8:], probe, driver="COG", **options)
            else:
                with rasterio.open(
                    probe,
                    "w",
                    driver=driver,
                    width=1,
                    height=1,
                    count=1,
                    dtype="uint8",
                    **options,
                ) as dst:
                    dst.write(np.zeros((1, 1, 1), "uint8"))
    except rasterio.errors.RasterioError as exc:
        complaints.append(str(exc))
    finally:
        logger.removeHandler(handler)
        logger.setLevel(level)
        for f in (probe, "/vsimem/src_" + probe[8:]):
            with contextlib.suppress(Exception):
                rasterio.shutil.delete(f)
    if complaints:
        given = ", ".join(f"{k}={v}" for k, v in options.items())
        given = given if len(given) <= 200 else given[:199] + "…"
        said = "; ".join(complaints)
        said = said if len(said) <= 300 else said[:299] + "…"
        raise ParameterError(
            f"parameter '{label}': GDAL's {driver} driver refuses {given} ({said}): "
            f"check the names and values on GDAL's {driver} driver page"
        )


@contextlib.contextmanager
def writer_options(cog: bool = False, co=None, raw_gsd=None):
    """Within this context every GeoTIFF output is written as a Cloud-Optimised GeoTIFF when
    ``cog`` (GDAL's COG driver) and with the GDAL creation options ``co`` (rio's
    ``NAME=VALUE`` convention, :func:`parse_creation_options`). Options are checked against
    the driver before any work, so a misspelt one is refused rather than silently ignored.
    With ``raw_gsd`` (metres), outputs in raw sensor geometry are written in the local
    engineering CRS :data:`RAW_LOCAL_WKT` with that pixel size (:func:`raw_local_grid`):
    no Earth position is claimed, but a GIS measures metres instead of reading pixels as degrees.
    """
    options = parse_creation_options(co)
    check_creation_options("COG" if cog else "GTiff", options)
    if raw_gsd is not None:
        try:
            raw_gsd = float(raw_gsd)
        except (TypeError, ValueError):
            raw_gsd = float("nan")
        if not (raw_gsd > 0 and np.isfinite(raw_gsd)):
            raise ParameterError(
                "parameter 'raw_gsd': expected the ground sample distance in metres (> 0), e.g. 1.5"
            )
    token = _WRITER.set((bool(cog), options, raw_gsd))
    try:
        yield
    finally:
        _WRITER.reset(token)


def overview_factors(width: int, height: int) -> list[int]:
    """Overview decimation factors 2, 4, 8, … until the smallest level fits in one tile (the
    levels GDAL's COG driver makes with OVERVIEWS=AUTO); none for a raster of one tile."""
    factors, f = [], 2
    while max(width, height) / (f // 2) > TILE:
        factors.append(f)
        f *= 2
    return factors


def _gdal_threads() -> dict:
    """GDAL options that compress a GeoTIFF's blocks, and build its overviews, in as many
    threads as the strips' workers: the thread that writes the strips then does not compress
    them one after another (`ratio` of a 20,000-line line: 1.27 s → 1.01 s, alternating), and
    a 20,000 × 286 float32 score's overviews take 0.24 s instead of 0.35 s on 2 cores. A
    user's GDAL_NUM_THREADS wins."""
    if os.environ.get("GDAL_NUM_THREADS"):
        return {}
    from .._threads import default_workers

    return {"GDAL_NUM_THREADS": str(default_workers())}


def overview_resampling(dtype: str, colormap) -> Resampling:
    """Average for continuous (float) data; nearest for integer data, whose values may be
    classes that an average would turn into classes that do not exist."""
    return (
        Resampling.average if np.dtype(dtype).kind == "f" and not colormap else Resampling.nearest
    )


@contextlib.contextmanager
def quiet_georef():
    """Silence NotGeoreferencedWarning: raw sensor geometry is normal here, not a mistake."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotGeoreferencedWarning)
        yield


@contextlib.contextmanager
def scratch_raster(path: str, width: int, height: int, *, dtype="float32", nodata=float("nan")):
    """Open a one-band raster of intermediate data (raw geometry, tiled, uncompressed) for
    block-by-block writing, to be read back within the same run: no CRS and none of the
    writer options of :func:`create_raster` (those are for the user's outputs); ``path``
    lies in a temporary folder of the caller's, so the file is not written atomically."""
    profile = dict(
        driver="GTiff",
        width=width,
        height=height,
        count=1,
        dtype=dtype,
        nodata=nodata,
        tiled=True,
        blockxsize=TILE,
        blockysize=TILE,
    )
    with quiet_georef(), rasterio.open(path, "w", **profile) as dst:
        yield dst


def open_dataset(path: str | os.PathLike, label: str = "raster"):
    """``path`` opened for reading (the caller closes it), with a clear error when it is
    missing or unreadable."""
    path = os.fspath(path)
    # A GDAL virtual file (/vsimem/ of rasterio's MemoryFile, /vsizip/, ...) is GDAL's to find.
    if not path.startswith("/vsi") and not os.path.exists(path):
        raise InputError(f"{label} {path} does not exist: check the path")
    if path.lower().endswith(".hdr"):
        # ENVI: GDAL opens the data file, not the header.
        data = data_for_header(path)
        if data is None:
            raise InputError(
                f"{label} {path} is an ENVI header but no data file sits beside it "
                "(expected the same name without .hdr, or .img/.dat/.raw/.bsq/.bil/.bip)"
            )
        path = data
    # GDAL's block cache defaults to 5 % of RAM and fills up while a flight line streams by:
    # cap it so memory stays bounded by a block (a user's own GDAL_CACHEMAX wins).
    with rasterio.Env(**gdal_cache()):
        try:
            with quiet_georef():
                src = rasterio.open(path)
        except RasterioIOError as exc:
            raise InputError(f"{label} {path} cannot be read as a raster ({exc})") from None
        try:
            check_raw_size(src, label)
        except BaseException:
            src.close()
            raise
    return src


@contextlib.contextmanager
def open_raster(path: str | os.PathLike, label: str = "raster"):
    """Open ``path`` for reading with a clear error when it is missing or unreadable."""
    src = open_dataset(path, label)
    try:
        with rasterio.Env(**gdal_cache()), quiet_georef():
            yield src
    finally:
        src.close()


def check_raw_size(src, label: str = "raster") -> None:
    """Raise :class:`InputError` when an uncompressed ENVI file is shorter or longer than its
    header says (GDAL would read the missing lines as zeros, and a longer file means the
    header's size or type is wrong: both give silently wrong numbers)."""
    if src.driver != "ENVI" or not src.files:
        return
    data = src.files[0]
    keys = envi_header(data)
    if keys is None or is_compressed(keys):
        return
    hdr = next((f for f in src.files[1:] if f.lower().endswith(".hdr")), "its header")
    try:
        offset = int(keys.get("header offset", "0"))
        itemsize = np.dtype(ENVI_DTYPES[int(keys["data type"])]).itemsize
    except (KeyError, ValueError):
        return  # GDAL opened it, so it knows the layout; nothing more to compare
    expected = offset + src.count * src.height * src.width * itemsize
    actual = os.path.getsize(data)
    if actual == expected:
        return
    layout = (
        f"{src.count} bands × {src.height} lines × {src.width} samples × {itemsize} bytes"
        + (f" + {offset} header bytes" if offset else "")
        + f" = {expected} bytes"
    )
    if actual < expected:
        raise InputError(
            f"{label} {data} is {actual} bytes but {hdr} describes {layout}: the file is "
            "truncated (copy it again) or the header's lines/samples/bands/data type are wrong"
        )
    raise InputError(
        f"{label} {data} is {actual} bytes, longer than the {layout} that {hdr} describes: "
        "check 'lines', 'samples', 'bands', 'data type' and 'header offset' in the header"
    )


def base_tags(**extra) -> dict:
    tags = {"GEOBORESIGHT_VERSION": __version__}
    tags.update({k.upper(): str(v) for k, v in extra.items()})
    return tags


def write_raster(
    path: str,
    arrays: np.ndarray | list[np.ndarray],
    like=None,
    *,
    crs=None,
    transform=None,
    nodata=FLOAT_NODATA,
    dtype: str | None = None,
    tags: dict | None = None,
    band_names: list[str] | None = None,
    overwrite: bool = True,
    colormap: dict | None = None,
    band_tags: list[dict] | None = None,
) -> str:
    """Write one or more bands (2-D arrays, or a 3-D stack) to a GeoTIFF atomically.

    The grid comes from ``like`` (an open dataset or a :class:`Grid`), or from ``crs`` and
    ``transform``. Masked entries of ``numpy.ma`` arrays are written as ``nodata``.
    """
    stack = np.ma.asarray(arrays)
    if stack.ndim == 2:
        stack = stack[np.newaxis]
    dtype = dtype or str(stack.dtype if stack.dtype != np.float64 else np.dtype("float32"))
    height, width = stack.shape[1:]
    if like is not None:
        grid = Grid.of(like)
        crs = grid.crs if crs is None else crs
        transform = grid.transform if transform is None else transform
    grid = Grid(width, height, crs, transform)
    data = (
        stack.filled(nodata if nodata is not None else 0) if np.ma.isMaskedArray(stack) else stack
    )
    with create_raster(
        path,
        grid,
        count=stack.shape[0],
        dtype=dtype,
        nodata=nodata,
        tags=tags,
        band_names=band_names,
        band_tags=band_tags,
        colormap=colormap,
        overwrite=overwrite,
    ) as dst:
        dst.write(np.asarray(data).astype(dtype, copy=False))
    return path


def write_envi(
    path: str,
    cube: np.ndarray,
    wavelengths_nm,
    fwhm_nm=None,
    *,
    interleave: str = "bil",
    nodata=None,
    crs=None,
    transform=None,
    description: str = "",
    overwrite: bool = True,
) -> str:
    """Write a (bands, rows, cols) cube as ENVI with ``wavelength``/``fwhm`` in nanometres.

    ``path`` is the data file (e.g. ``scene_vnir.img``); GDAL writes ``scene_vnir.hdr``
    beside it. Raw geometry (no ``crs``/``transform``) stays raw.
    """
    cube = np.asarray(cube)
    profile = {
        "driver": "ENVI",
        "width": cube.shape[2],
        "height": cube.shape[1],
        "count": cube.shape[0],
        "dtype": str(cube.dtype),
        "interleave": interleave,
    }
    if nodata is not None:
        profile["nodata"] = nodata
    if crs is not None:
        profile["crs"] = crs
    if transform is not None and transform != Affine.identity():
        profile["transform"] = transform
    envi = {
        "wavelength": format_wavelengths(wavelengths_nm),
        "wavelength_units": "Nanometers",
    }
    if fwhm_nm is not None:
        envi["fwhm"] = format_wavelengths(fwhm_nm)
    with atomic_output(path, overwrite=overwrite) as tmp, quiet_georef():
        with rasterio.open(tmp, "w", **profile) as dst:
            dst.write(cube)
            dst.update_tags(ns="ENVI", **envi)
            for i, wl in enumerate(wavelengths_nm, start=1):
                dst.set_band_description(i, f"{wl:.2f} nm")
            if description:
                dst.update_tags(description=description)
        verify_written(tmp, path, profile)
    return path


#: Largest buffer (bytes) TileRowWriter gathers before writing; wider rows are written as they come.
TILE_ROW_BUFFER = 64 << 20


class TileRowWriter:
    """An open GeoTIFF whose consecutive full-width writes reach GDAL as whole rows of tiles.

    GDAL's GeoTIFF driver compresses a tile whenever a write moves on to another tile, and a
    tile written again is compressed again and appended: written strip by strip (16 lines, as
    the cube operations do), each 256-line tile of a compressed output was compressed 16
    times, the file was 4× its size and the write took 4.9 s for a 20,000 × 286 float32 score
    (0.2 s in whole tile rows). Full-width writes of consecutive lines are therefore gathered
    here up to the next tile-row boundary; any other write goes straight through (after what is
    gathered). Other attributes are the dataset's; calling one of its methods writes what is
    gathered first.
    """

    def __init__(self, dst, max_bytes: int = TILE_ROW_BUFFER):
        self._dst = dst
        self._block = int(dst.block_shapes[0][0]) if dst.block_shapes else 1
        self._max_bytes = max_bytes
        self._buf = None  # (bands, lines, width) gathered lines
        self._start = self._next = self._end = 0
        self._indexes: tuple[int, ...] = ()

    @property
    def dataset(self):
        """The rasterio dataset itself (e.g. for ``rasterio.band`` in a warp), after what is
        gathered is written."""
        self.flush()
        return self._dst

    def __getattr__(self, name):
        attr = getattr(self._dst, name)
        if callable(attr):
            self.flush()
        return attr

    def _gatherable(self, arr, window, kwargs) -> bool:
        return (
            isinstance(window, Window)
            and not kwargs
            and type(arr) is np.ndarray
            and arr.ndim in (2, 3)
            and window.col_off == 0
            and window.width == self._dst.width
            and arr.shape[-2:] == (window.height, window.width)
            and self._block > 1
        )

    def write(self, arr, indexes=None, window=None, **kwargs):
        if not self._gatherable(arr, window, kwargs):
            self.flush()
            return self._dst.write(arr, indexes, window=window, **kwargs)
        data = arr if arr.ndim == 3 else arr[None]
        if indexes is None:
            indexes = tuple(range(1, self._dst.count + 1))
        idx = (int(indexes),) if np.ndim(indexes) == 0 else tuple(int(i) for i in indexes)
        if len(idx) != data.shape[0]:
            self.flush()
            return self._dst.write(arr, indexes, window=window)
        row = int(window.row_off)
        if self._buf is not None and (
            idx != self._indexes or row != self._next or data.dtype != self._buf.dtype
        ):
            self.flush()
        done, n = 0, data.shape[1]
        while done < n:
            if self._buf is None:
                start = row + done
                end = min(self._dst.height, (start // self._block + 1) * self._block)
                shape = (len(idx), end - start, self._dst.width)
                if int(np.prod(shape)) * data.dtype.itemsize > self._max_bytes:
                    part = data[:, done:]
                    win = Window(0, start, self._dst.width, part.shape[1])
                    return self._dst.write(part, list(idx), window=win)
                self._buf = np.empty(shape, dtype=data.dtype)
                self._start = self._next = start
                self._end, self._indexes = end, idx
            take = min(n - done, self._end - self._next)
            at = self._next - self._start
            self._buf[:, at : at + take] = data[:, done : done + take]
            self._next += take
            done += take
            if self._next == self._end:
                self.flush()

    def flush(self) -> None:
        """Write the gathered lines."""
        if self._buf is None:
            return
        buf, self._buf = self._buf, None
        lines = self._next - self._start
        win = Window(0, self._start, self._dst.width, lines)
        self._dst.write(buf[:, :lines], list(self._indexes), window=win)


@contextlib.contextmanager
def create_raster(
    path: str,
    grid: Grid,
    *,
    count: int = 1,
    dtype: str = "float32",
    nodata=FLOAT_NODATA,
    tags: dict | None = None,
    band_names: list[str] | None = None,
    band_tags: list[dict] | None = None,
    colormap: dict | None = None,
    category_names: dict[int, str] | None = None,
    overwrite: bool = True,
    overviews: bool = True,
    compression: dict | None = None,
):
    """Open a new GeoTIFF on ``grid`` for block-by-block writing; atomic on success.
    ``overviews=False`` leaves out the overviews (a raster of coordinates, which no viewer
    draws and whose averages mean nothing); ``compression`` (creation options) replaces the
    profile's compression (a user's options still win).

    The profile is :meth:`Grid.profile`'s (tiled, compressed, predictor, nodata); raw sensor
    geometry stays raw. Tags, band names and a colour table are written once the caller's
    block has run; category names go in the GDAL PAM sidecar (.aux.xml), where GDAL and QGIS
    read them. Yields the open dataset, wrapped in a :class:`TileRowWriter` (strip-by-strip
    writes reach GDAL as whole tile rows).
    """
    extra = {"photometric": "palette"} if colormap else {}
    cog, options, raw_gsd = _WRITER.get()
    grid = Grid.of(grid)
    if raw_gsd is not None and not grid.georeferenced:
        grid = raw_local_grid(grid, raw_gsd)
        tags = {**(tags or {}), "raw_geometry_gsd_m": f"{raw_gsd:g}"}
    profile = grid.profile(count=count, dtype=dtype, nodata=nodata, **extra)
    if compression:
        profile = {k: v for k, v in profile.items() if k != "zlevel"} | compression
    if options and not cog:
        # The user's NAME=VALUE replace ours of the same name (rasterio's keys are lower case).
        profile = {k: v for k, v in profile.items() if k.upper() not in options} | options
    resampling = overview_resampling(profile["dtype"], colormap)
    # GDAL's block cache (5 % of RAM by default) would hold every written block, then the
    # whole base level while the overviews are built: cap it as for reading, so memory stays
    # bounded by a strip whatever the line's length (a user's own GDAL_CACHEMAX wins).
    cache = gdal_cache()
    with atomic_output(path, overwrite=overwrite) as tmp, quiet_georef(), rasterio.Env(**cache):
        with rasterio.Env(**_gdal_threads()), rasterio.open(tmp, "w", **profile) as dst:
            if colormap:
                dst.write_colormap(1, colormap)
            writer = TileRowWriter(dst)
            yield writer
            writer.flush()
            dst.update_tags(**base_tags(**(tags or {})))
            for i, name in enumerate(band_names or (), start=1):
                dst.set_band_description(i, name)
            for i, bt in enumerate(band_tags or (), start=1):
                dst.update_tags(i, **{k: str(v) for k, v in bt.items()})
                imagery = _imagery_tags(bt)
                if imagery:
                    dst.update_tags(i, ns="IMAGERY", **imagery)
        # Overviews, so that a map viewer (QGIS) draws a whole flight line quickly. Built on
        # the closed file reopened: then GDAL reads, resamples and compresses the levels'
        # blocks in threads of its own (on the handle that wrote the file it does not).
        factors = overview_factors(profile["width"], profile["height"]) if overviews else []
        if factors:
            # GDAL's threads compress the blocks, and a write error met there (a full disk)
            # reaches only stderr: the file is checked before it is reopened to add to it.
            verify_written(tmp, path, profile)
            with rasterio.Env(**_gdal_threads()), rasterio.open(tmp, "r+") as dst:
                dst.build_overviews(factors, resampling)
                dst.update_tags(ns="rio_overview", resampling=resampling.name)
        verify_written(tmp, path, profile)
        if cog:
            _to_cog(tmp, path, profile, options, resampling)
        if category_names:
            # After the TIFF is closed (GDAL would rewrite its PAM file on close), beside the
            # temporary file so that it is renamed along with it.
            with open(tmp + ".aux.xml", "w", encoding="utf-8") as f:
                f.write(_pam_categories(category_names))


def _imagery_tags(band_tags: dict) -> dict:
    """A cube band's ``wavelength``/``fwhm`` tags also in GDAL's IMAGERY domain
    (CENTRAL_WAVELENGTH_UM, FWHM_UM; GDAL ≥ 3.10), where GDAL tools and QGIS look."""
    if "wavelength" not in band_tags:
        return {}
    try:
        wl = float(band_tags["wavelength"])
        nm = unit_scale(band_tags.get("wavelength_units"), np.array([wl]))
    except (InputError, ValueError):
        return {}  # not a wavelength this package can read: leave the IMAGERY domain alone
    out = {"CENTRAL_WAVELENGTH_UM": f"{wl * nm / 1000:.6f}"}
    if "fwhm" in band_tags:
        with contextlib.suppress(ValueError):
            out["FWHM_UM"] = f"{float(band_tags['fwhm']) * nm / 1000:.6f}"
    return out


def _to_cog(tmp: str, path: str, profile: dict, options: dict, resampling: Resampling) -> None:
    """Rewrite the verified GeoTIFF ``tmp`` in place as a Cloud-Optimised GeoTIFF (GDAL's COG
    driver: tiles, then overviews, in the order a reader streams them), inside the atomic
    write of ``path``; the overviews already built are reused (OVERVIEWS=AUTO)."""
    cog_options = {
        "COMPRESS": "DEFLATE",
        "LEVEL": str(DEFLATE_LEVEL),
        "PREDICTOR": "YES",
        "BLOCKSIZE": str(TILE),
        "BIGTIFF": "IF_SAFER",
        "OVERVIEWS": "AUTO",
        "RESAMPLING": "AVERAGE" if resampling == Resampling.average else "NEAREST",
    } | options
    cog = temp_name(path)
    try:
        with quiet_georef():
            rasterio.shutil.copy(tmp, cog, driver="COG", **cog_options)
        verify_written(cog, path, profile)
        os.replace(cog, tmp)
    finally:
        for leftover in (cog, cog + ".aux.xml"):
            with contextlib.suppress(OSError):
                os.remove(leftover)


def verify_written(tmp: str, path: str, profile: dict) -> None:
    """Raise :class:`OutputError` unless the closed file ``tmp`` is complete.

    GDAL reports some write errors at close only on stderr (libtiff's ``_tiffWriteProc: No
    space left on device``) and the close returns normally: the file is then unreadable or
    its blocks point past its end. So before the rename the file is reopened, its size and
    type compared with ``profile``, and every GeoTIFF block's offset + size checked against
    the file's length (a metadata read, no pixels are decoded); raw ENVI data must have the
    header's length.
    """
    problem = None
    try:
        with quiet_georef(), rasterio.open(tmp) as chk:
            shape = (chk.count, chk.height, chk.width)
            if shape != (profile["count"], profile["height"], profile["width"]):
                problem = f"it holds {shape} instead of the bands × lines × columns written"
            elif chk.driver == "GTiff":
                problem = _tiff_blocks_problem(chk, os.path.getsize(tmp))
            elif chk.driver == "ENVI":
                need = chk.count * chk.height * chk.width * np.dtype(chk.dtypes[0]).itemsize
                if os.path.getsize(chk.files[0]) < need:
                    problem = "its data file is shorter than its header says"
    except (rasterio.errors.RasterioError, OSError) as exc:
        problem = f"it cannot be read back ({exc})"
    if problem is None:
        return
    err = output_error(OSError(problem), path, tmp, mine=True)
    if err is not None and "full" in str(err):
        raise err
    raise OutputError(
        f"output {path} could not be written completely ({scrub(problem, tmp, path)}): GDAL "
        "reported a write error; check the disk's free space and permissions. Any previous "
        "file of that name is unchanged"
    )


def _tiff_blocks_problem(src, size: int) -> str | None:
    """Why the GeoTIFF ``src`` of ``size`` bytes is incomplete, or None."""
    for b in range(1, src.count + 1):
        bh, bw = src.block_shapes[b - 1]
        for y in range(-(-src.height // bh)):
            for x in range(-(-src.width // bw)):
                off = src.get_tag_item(f"BLOCK_OFFSET_{x}_{y}", "TIFF", bidx=b)
                n = src.get_tag_item(f"BLOCK_SIZE_{x}_{y}", "TIFF", bidx=b)
                if off is None or n is None or int(off) + int(n) > size or int(off) == 0:
                    return f"block {x},{y} of band {b} is missing"
    return None


def _pam_categories(names: dict[int, str]) -> str:
    top = max(names)
    cats = "".join(
        f"      <Category>{escape(names.get(i, ''))}</Category>\n" for i in range(top + 1)
    )
    return (
        '<PAMDataset>\n  <PAMRasterBand band="1">\n    <CategoryNames>\n'
        f"{cats}    </CategoryNames>\n  </PAMRasterBand>\n</PAMDataset>\n"
    )


def create_class_raster(
    path, grid, *, tags, band_name, colormap, category_names, band_tags=None, nodata=255
):
    """A uint8 class GeoTIFF (nodata 255) with a colour table and category names, written
    block by block; atomic (a :func:`create_raster` context)."""
    return create_raster(
        path,
        grid,
        dtype="uint8",
        nodata=nodata,
        tags=tags,
        band_names=[band_name],
        band_tags=[band_tags] if band_tags else None,
        colormap=colormap,
        category_names=category_names,
    )
