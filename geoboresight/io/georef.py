"""Files of georeferencing: IGM, GLT and GDAL geolocation arrays, GCP tables (CSV and QGIS
Georeferencer ``.points``), CRS strings, and the warps that put a raw-geometry product on a map
grid (GDAL's geolocation-array warper through rasterio) or a product onto a reference's grid.

Every reader raises :class:`~geoboresight.errors.InputError` or
:class:`~geoboresight.errors.ParameterError` with one line naming the file or parameter.
"""

from __future__ import annotations

import csv
import os
import re
from dataclasses import dataclass
from xml.etree import ElementTree

import numpy as np

from ..errors import InputError, ParameterError
from .grid import FLOAT_NODATA, Grid
from .raster import create_raster, open_raster
from .wavelengths import read_wavelengths

#: Bands warped at a time (memory: this many raw bands plus their map-grid copies).
BANDS_PER_WARP = 8
RESAMPLINGS = ("auto", "nearest", "bilinear", "cubic")


# --------------------------------------------------------------------------------------- CRS
def parse_crs(value, label: str = "parameter 'crs'"):
    """A rasterio CRS from a user string (``EPSG:32636``, a PROJ string, WKT) via pyproj, or a
    clear error naming ``label``."""
    from pyproj import CRS as PyCRS
    from pyproj.exceptions import CRSError
    from rasterio.crs import CRS

    if value is None or value == "":
        return None
    if not isinstance(value, str):
        return CRS.from_user_input(value)
    try:
        wkt = PyCRS.from_user_input(value.strip()).to_wkt()
    except CRSError:
        raise ParameterError(
            f"{label}: unknown CRS {value!r}: give an EPSG code (e.g. EPSG:32636), a PROJ "
            "string or WKT"
        ) from None
    return CRS.from_wkt(wkt)


def transform_xy(x, y, src_crs, dst_crs):
    """Coordinates transformed between two CRSs with pyproj (always x = easting/longitude)."""
    from pyproj import Transformer

    if src_crs is None or dst_crs is None or src_crs == dst_crs:
        return np.asarray(x, "float64"), np.asarray(y, "float64")
    tr = Transformer.from_crs(src_crs.to_wkt(), dst_crs.to_wkt(), always_xy=True)
    xx, yy = tr.transform(np.asarray(x, "float64"), np.asarray(y, "float64"))
    return np.asarray(xx), np.asarray(yy)


# ------------------------------------------------------------------------------- IGM and GLT
@dataclass(frozen=True)
class Coordinates:
    """Per-pixel map coordinates of a raw product (pixel centres), from an IGM or a GDAL
    geolocation array: ``x``, ``y`` (lines, columns) float64 (NaN where the file has nodata),
    ``crs``, the file and a description of the source."""

    x: np.ndarray
    y: np.ndarray
    crs: object
    path: str
    source: str


def _geolocation_metadata(src) -> dict:
    try:
        return src.tags(ns="GEOLOCATION") or {}
    except Exception:  # a driver without metadata domains
        return {}


def read_coordinates(path, *, crs=None, label: str = "IGM") -> Coordinates:
    """Read an IGM (bands 1 and 2: easting and northing, or longitude and latitude, of every
    raw pixel's centre; band 3, height, is not needed) or a dataset with a GDAL
    ``GEOLOCATION`` metadata domain (X and Y arrays, any step and offset).

    ``crs`` (a user string) is used when the file carries none, and overrides it otherwise.
    """
    path = os.fspath(path)
    user_crs = parse_crs(crs, "parameter 'igm_crs'") if crs else None
    with open_raster(path, label) as src:
        geo = _geolocation_metadata(src)
        if geo.get("X_DATASET") and geo.get("Y_DATASET"):
            return _read_geolocation(src, geo, path, user_crs, label)
        if src.count < 2:
            raise InputError(
                f"{label} {path} has {src.count} band: an IGM needs easting (band 1) and "
                "northing (band 2) of every pixel"
            )
        x = src.read(1, masked=True).astype("float64").filled(np.nan)
        y = src.read(2, masked=True).astype("float64").filled(np.nan)
        file_crs = src.crs
    use = user_crs or file_crs
    if use is None:
        raise InputError(
            f"{label} {path} carries no CRS in its header: give it with --igm-crs (e.g. EPSG:32636)"
        )
    return Coordinates(x, y, use, path, f"IGM {os.path.basename(path)}")


def _read_geolocation(src, geo: dict, path: str, user_crs, label: str) -> Coordinates:
    arrays = []
    for axis in ("X", "Y"):
        name = geo[f"{axis}_DATASET"]
        band = int(geo.get(f"{axis}_BAND", 1))
        try:
            with open_raster(name, f"{label} {path}: geolocation {axis} array") as g:
                arrays.append(g.read(band, masked=True).astype("float64").filled(np.nan))
        except InputError:
            raise
        except Exception as exc:  # noqa: BLE001 - GDAL's reason, in one line
            raise InputError(
                f"{label} {path}: cannot read its {axis} geolocation array ({exc})"
            ) from None
    x, y = arrays
    p_off, l_off = float(geo.get("PIXEL_OFFSET", 0)), float(geo.get("LINE_OFFSET", 0))
    p_step, l_step = float(geo.get("PIXEL_STEP", 1)), float(geo.get("LINE_STEP", 1))
    centre = geo.get("GEOREFERENCING_CONVENTION", "TOP_LEFT_CORNER").upper() == "PIXEL_CENTER"
    if (
        (p_off, l_off, p_step, l_step) != (0, 0, 1, 1)
        or not centre
        or x.shape != (src.height, src.width)
    ):
        # Array value [i, j] sits at pixel (offset + j·step): interpolate it at the pixel
        # centres, linearly, extrapolating beyond the last array value.
        from scipy.interpolate import RegularGridInterpolator

        half = 0.0 if centre else 0.5
        rows = (np.arange(src.height) + half - l_off) / l_step
        cols = (np.arange(src.width) + half - p_off) / p_step
        rr, cc = np.meshgrid(rows, cols, indexing="ij")
        axes = (np.arange(x.shape[0], dtype="float64"), np.arange(x.shape[1], dtype="float64"))
        x, y = (
            RegularGridInterpolator(axes, a, bounds_error=False, fill_value=None)((rr, cc))
            for a in (x, y)
        )
    file_crs = parse_crs(geo["SRS"], f"{label} {path}: geolocation SRS") if geo.get("SRS") else None
    use = user_crs or file_crs
    if use is None:
        raise InputError(f"{label} {path}: its geolocation arrays carry no SRS: give --igm-crs")
    return Coordinates(x, y, use, path, f"GDAL geolocation arrays of {os.path.basename(path)}")


@dataclass(frozen=True)
class GLT:
    """A geometry lookup table: one-based ``sample`` and ``line`` indices on the map ``grid``."""

    sample: np.ndarray
    line: np.ndarray
    valid: np.ndarray
    grid: Grid
    path: str


def read_glt(path, *, crs=None) -> GLT:
    """Read a GLT (band 1: sample, band 2: line; one-based; 0 or nodata: nothing seen)."""
    path = os.fspath(path)
    with open_raster(path, "GLT") as src:
        if src.count < 2:
            raise InputError(f"GLT {path} has {src.count} band: it needs sample (1) and line (2)")
        if src.transform is None or src.transform.is_identity:
            raise InputError(f"GLT {path} has no geotransform: a GLT is a map grid")
        s = src.read(1, masked=True)
        line = src.read(2, masked=True)
        valid = ~(np.ma.getmaskarray(s) | np.ma.getmaskarray(line))
        grid = Grid(
            src.width, src.height, parse_crs(crs, "parameter 'igm_crs'") or src.crs, src.transform
        )
    if grid.crs is None:
        raise InputError(f"GLT {path} carries no CRS: give it with --igm-crs")
    if np.any(np.asarray(s.filled(0)) % 1) or np.any(np.asarray(line.filled(0)) % 1):
        raise InputError(
            f"GLT {path} holds non-integer indices: a GLT holds sample and line numbers"
        )
    return GLT(
        np.asarray(s.filled(0)).astype("int64"),
        np.asarray(line.filled(0)).astype("int64"),
        valid,
        grid,
        path,
    )


# ---------------------------------------------------------------------------------- GCP files
@dataclass(frozen=True)
class GCPs:
    """Ground control points: continuous ``pixel_line`` (n, 2), map ``xy`` (n, 2), ``enabled``
    (n,), ``crs`` (or None when the file and the user give none) and the file."""

    pixel_line: np.ndarray
    xy: np.ndarray
    enabled: np.ndarray
    crs: object
    path: str


_CRS_LINE = re.compile(r"^\s*#\s*CRS\s*[:=]\s*(.+)$", re.I)


def read_gcps(path, *, crs=None) -> GCPs:
    """Read GCPs from a CSV (``pixel,line,x,y``, optionally ``enable``; a ``# CRS: ...``
    comment line may give the CRS) or a QGIS Georeferencer ``.points`` file (``mapX, mapY,
    pixelX, pixelY, enable, ...``; QGIS counts lines downwards as negative ``pixelY``; QGIS ≥
    3.26 writes ``#CRS: <WKT>`` first). ``crs`` (a user string) overrides the file's CRS."""
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"GCP file {path} does not exist: check the path")
    with open(path, encoding="utf-8-sig", errors="replace") as f:
        text = f.read()
    file_crs = None
    rows = []
    for line in text.splitlines():
        m = _CRS_LINE.match(line)
        if m:
            file_crs = m.group(1).strip()
        elif line.strip() and not line.lstrip().startswith("#"):
            rows.append(line)
    table = list(csv.reader(rows))
    if not table:
        raise InputError(f"GCP file {path} holds no GCPs")
    header = [h.strip().lower() for h in table[0]]
    qgis = {"mapx", "mapy", "pixelx", "pixely"} <= set(header)
    plain = {"pixel", "line", "x", "y"} <= set(header)
    if not (qgis or plain):
        raise InputError(
            f"GCP file {path}: the first line must name the columns pixel,line,x,y (CSV) or "
            "mapX,mapY,pixelX,pixelY (QGIS .points); found " + ",".join(table[0])
        )
    cols = ("pixelx", "pixely", "mapx", "mapy") if qgis else ("pixel", "line", "x", "y")
    idx = [header.index(c) for c in cols]
    en = header.index("enable") if "enable" in header else None
    values, enabled = [], []
    for n, row in enumerate(table[1:], start=2):
        try:
            values.append([float(row[i]) for i in idx])
            enabled.append(bool(int(float(row[en]))) if en is not None and en < len(row) else True)
        except (ValueError, IndexError):
            raise InputError(
                f"GCP file {path}, line {n}: expected numbers in {', '.join(cols)}, got "
                f"{','.join(row)!r}"
            ) from None
    v = np.array(values, "float64").reshape(-1, 4)
    pl = v[:, :2].copy()
    if qgis:
        pl[:, 1] = -pl[:, 1]  # QGIS: y = -line
    user = parse_crs(crs, "parameter 'gcp_crs'") if crs else None
    fcrs = parse_crs(file_crs, f"GCP file {path}: its CRS line") if file_crs else None
    return GCPs(pl, v[:, 2:], np.array(enabled, bool), user or fcrs, path)


def corner_gcps(corners: str, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """GCPs from the map coordinates of the four image corners: ``"x1,y1,...,x4,y4"`` for the
    top-left (first line, first pixel), top-right, bottom-right and bottom-left corners."""
    try:
        v = [float(t) for t in re.split(r"[,\s;]+", corners.strip()) if t]
    except ValueError:
        v = []
    if len(v) != 8 or not np.all(np.isfinite(v)):
        raise ParameterError(
            "parameter 'corners': give 8 numbers, x,y of the top-left, top-right, bottom-right "
            f"and bottom-left corners; got {corners!r}"
        )
    pl = np.array([[0, 0], [width, 0], [width, height], [0, height]], "float64")
    return pl, np.array(v, "float64").reshape(4, 2)


# --------------------------------------------------------------------------------- rasters
def product_is_classes(src) -> bool:
    """A class raster (nearest-neighbour only): a colour table, category names, or class tags
    (``CLASS_k`` band tags, a ``CLASSES`` tag) on an integer band."""
    if np.dtype(src.dtypes[0]).kind not in "iu":
        return False
    try:
        if src.colormap(1):
            return True
    except ValueError:
        pass
    if _category_names(src.name):
        return True
    tags = {k.upper() for k in src.tags(1)} | {k.upper() for k in src.tags()}
    return any(k.startswith("CLASS") for k in tags)


def choose_resampling(src, resampling: str) -> str:
    """``auto``: nearest for class rasters, bilinear for continuous data."""
    if resampling not in RESAMPLINGS:
        raise ParameterError(
            f"parameter 'resampling': {resampling!r} is not one of {', '.join(RESAMPLINGS)}"
        )
    if resampling != "auto":
        return resampling
    return "nearest" if product_is_classes(src) else "bilinear"


def _category_names(path: str) -> dict[int, str] | None:
    aux = path + ".aux.xml"
    if not os.path.isfile(aux):
        return None
    try:
        root = ElementTree.parse(aux).getroot()
    except ElementTree.ParseError:
        return None
    cats = root.findall(".//PAMRasterBand[@band='1']/CategoryNames/Category")
    names = {i: (c.text or "") for i, c in enumerate(cats)}
    return {k: v for k, v in names.items() if v} or None


def _nodata_for(src) -> float | int:
    if src.nodata is not None:
        return src.nodata
    dt = np.dtype(src.dtypes[0])
    if dt.kind == "f":
        return FLOAT_NODATA
    return int(np.iinfo(dt).max)


def _metadata(src) -> dict:
    """What a warped copy carries over: tags, band names and tags, colour table, categories,
    wavelengths."""
    colormap = None
    try:
        colormap = src.colormap(1)
    except ValueError:
        pass
    try:
        wl, fwhm = read_wavelengths(src)
    except InputError:
        wl, fwhm = None, None
    band_tags = [dict(src.tags(b)) for b in range(1, src.count + 1)]
    if wl is not None:
        for b, t in enumerate(band_tags):
            t["wavelength"] = f"{wl[b]:.4f}"
            t["wavelength_units"] = "nm"
            if fwhm is not None:
                t["fwhm"] = f"{fwhm[b]:.4f}"
    tags = {k: v for k, v in src.tags().items() if k.upper() != "GEOBORESIGHT_VERSION"}
    return {
        "tags": tags,
        "band_names": [d or f"band {b}" for b, d in enumerate(src.descriptions, start=1)],
        "band_tags": band_tags,
        "colormap": colormap,
        "category_names": _category_names(src.name),
        "wavelengths": wl,
        "fwhm": fwhm,
    }


def _write_imagery(dst, meta: dict) -> None:
    """Wavelengths also in GDAL's IMAGERY domain (CENTRAL_WAVELENGTH_UM, FWHM_UM, GDAL ≥ 3.10),
    which QGIS and GDAL tools read."""
    if meta["wavelengths"] is None:
        return
    for b, wl in enumerate(meta["wavelengths"], start=1):
        extra = {"FWHM_UM": f"{meta['fwhm'][b - 1] / 1000:.6f}"} if meta["fwhm"] is not None else {}
        dst.update_tags(b, ns="IMAGERY", CENTRAL_WAVELENGTH_UM=f"{wl / 1000:.6f}", **extra)


def pixel_spacing(x: np.ndarray, y: np.ndarray, valid: np.ndarray) -> float:
    """The median ground distance between neighbouring pixels (across and along the track)."""
    steps = []
    for axis in (0, 1):
        d = np.hypot(np.diff(x, axis=axis), np.diff(y, axis=axis))
        ok = np.diff(valid.astype(np.int8), axis=axis) == 0
        ok &= np.take(valid, range(1, valid.shape[axis]), axis=axis)
        if ok.any():
            steps.append(np.median(d[ok]))
    if not steps or not np.isfinite(steps).all() or min(steps) <= 0:
        raise InputError("the coordinates do not advance from pixel to pixel")
    return float(np.sqrt(steps[0] * steps[-1]))


def map_grid(x, y, valid, crs, resolution: float | None) -> Grid:
    """A north-up grid covering the pixel centres ``x``, ``y`` (plus one cell), its cells
    aligned on multiples of ``resolution`` (default: the median pixel spacing)."""
    from rasterio.transform import from_origin

    res = float(resolution) if resolution else float(f"{pixel_spacing(x, y, valid):.3g}")
    xs, ys = x[valid], y[valid]
    left = np.floor((xs.min() - res) / res) * res
    top = np.ceil((ys.max() + res) / res) * res
    width = int(np.ceil((xs.max() + res - left) / res))
    height = int(np.ceil((top - ys.min() + res) / res))
    if width * height > 2e9:
        raise ParameterError(
            f"parameter 'resolution': {res:g} gives a {width} × {height} grid: choose a coarser "
            "resolution (in the units of the output CRS)"
        )
    return Grid(width, height, crs, from_origin(left, top, res, res))


def write_igm(path: str, x: np.ndarray, y: np.ndarray, crs, tags: dict) -> str:
    """An IGM as a float64 GeoTIFF in raw geometry: band 1 x (easting), band 2 y (northing) of
    every pixel's centre, the CRS in its header and no geotransform."""
    from .raster import write_raster

    return write_raster(
        path,
        np.stack([x, y]).astype("float64"),
        Grid(x.shape[1], x.shape[0], crs, None),
        nodata=None,
        dtype="float64",
        tags={**tags, "PRODUCT": "IGM: map coordinates of each raw pixel centre"},
        band_names=["x (easting)", "y (northing)"],
    )


def warp_geoloc(
    product: str,
    output: str,
    geoloc: np.ndarray,
    grid: Grid,
    *,
    source_valid: np.ndarray | None,
    resampling: str,
    tags: dict,
    progress,
    label: str = "input",
) -> dict:
    """Warp every band of ``product`` onto ``grid`` through GDAL's geolocation-array warper.

    ``geoloc`` (2, lines + 1, columns + 1): pixel-corner coordinates in ``grid.crs``
    (:func:`geoboresight.georef.geoloc.corner_geoloc`); the source is padded with one line and
    one column of nodata to match, so that the last line and column are drawn whole.
    ``source_valid``: raw pixels to draw (others are nodata). Written block of bands by block
    of bands, atomically.
    """
    from rasterio.enums import Resampling
    from rasterio.warp import reproject

    with open_raster(product, label) as src:
        if (src.height + 1, src.width + 1) != geoloc.shape[1:]:
            raise InputError(
                f"the coordinates ({geoloc.shape[2] - 1} × {geoloc.shape[1] - 1}, columns × lines) and "
                f"{label} {product} ({src.width} × {src.height}) differ in size: they must "
                "describe the same raw pixels"
            )
        method = choose_resampling(src, resampling)
        meta = _metadata(src)
        nodata = _nodata_for(src)
        dtype = src.dtypes[0]
        count = src.count
        valid_pixels = 0
        with create_raster(
            output,
            grid,
            count=count,
            dtype=dtype,
            nodata=nodata,
            tags={**meta["tags"], **tags, "RESAMPLING": method},
            band_names=meta["band_names"],
            band_tags=meta["band_tags"],
            colormap=meta["colormap"],
            category_names=meta["category_names"],
        ) as dst:
            for b0 in range(1, count + 1, BANDS_PER_WARP):
                bands = list(range(b0, min(b0 + BANDS_PER_WARP, count + 1)))
                data = src.read(bands, masked=True)
                mask = np.ma.getmaskarray(data)
                if source_valid is not None:
                    mask = mask | ~source_valid[None]
                arr = np.full((len(bands), src.height + 1, src.width + 1), nodata, dtype=dtype)
                arr[:, :-1, :-1] = np.where(mask, nodata, np.ma.getdata(data))
                out = np.full((len(bands), grid.height, grid.width), nodata, dtype=dtype)
                reproject(
                    arr,
                    out,
                    src_geoloc_array=geoloc,
                    src_crs=grid.crs,
                    src_nodata=nodata,
                    dst_transform=grid.transform,
                    dst_crs=grid.crs,
                    dst_nodata=nodata,
                    resampling=Resampling[method],
                )
                dst.write(out, bands)
                if b0 == 1:
                    valid_pixels = int((out[0] != nodata).sum())
                progress.update(bands[-1] / count, "warp")
            _write_imagery(dst, meta)
    return {"resampling": method, "valid_pixels": valid_pixels, "bands": count}


def lookup_glt(
    product: str, output: str, glt: GLT, rows, cols, valid, *, tags: dict, progress
) -> dict:
    """Write every band of ``product`` on the GLT's grid: each map cell takes the raw pixel
    the GLT names (nearest by construction), nodata where it names none."""
    with open_raster(product, "input") as src:
        meta = _metadata(src)
        nodata = _nodata_for(src)
        dtype = src.dtypes[0]
        with create_raster(
            output,
            glt.grid,
            count=src.count,
            dtype=dtype,
            nodata=nodata,
            tags={**meta["tags"], **tags, "RESAMPLING": "nearest (GLT lookup)"},
            band_names=meta["band_names"],
            band_tags=meta["band_tags"],
            colormap=meta["colormap"],
            category_names=meta["category_names"],
        ) as dst:
            for b in range(1, src.count + 1):
                data = src.read(b, masked=True)
                seen = valid & ~np.ma.getmaskarray(data)[rows, cols]
                out = np.where(seen, np.ma.getdata(data)[rows, cols], nodata).astype(dtype)
                dst.write(out, b)
                progress.update(b / src.count, "GLT lookup")
            _write_imagery(dst, meta)
    return {"valid_pixels": int(seen.sum()), "bands": src.count}


def reproject_onto(product: str, reference: str, output: str, *, resampling: str, progress) -> dict:
    """Write ``product`` on the exact grid (CRS, transform, size) of ``reference``."""
    from rasterio import band as rio_band
    from rasterio.enums import Resampling
    from rasterio.warp import reproject

    with open_raster(reference, "reference") as ref:
        if ref.crs is None:
            raise InputError(
                f"reference {reference} has no CRS: give an orthophoto or map with its CRS "
                "(e.g. a GeoTIFF, or a .prj/.aux.xml beside it)"
            )
        grid = Grid.of(ref)
    with open_raster(product, "input") as src:
        if src.crs is None or Grid.of(src).transform is None:
            raise InputError(
                f"input {product} is in raw sensor geometry (no CRS): put it on a map first "
                "with geolocate (IGM/GLT) or georeference (GCPs)"
            )
        method = choose_resampling(src, resampling)
        meta = _metadata(src)
        nodata = _nodata_for(src)
        with create_raster(
            output,
            grid,
            count=src.count,
            dtype=src.dtypes[0],
            nodata=nodata,
            tags={
                **meta["tags"],
                "GEOREFERENCE": f"reprojected onto the grid of {reference}",
                "RESAMPLING": method,
            },
            band_names=meta["band_names"],
            band_tags=meta["band_tags"],
            colormap=meta["colormap"],
            category_names=meta["category_names"],
        ) as dst:
            for b in range(1, src.count + 1):
                reproject(
                    rio_band(src, b),
                    rio_band(dst.dataset, b),
                    src_nodata=nodata,
                    dst_nodata=nodata,
                    resampling=Resampling[method],
                )
                progress.update(b / src.count, "reproject")
            _write_imagery(dst, meta)
    return {
        "resampling": method,
        "crs": grid.crs.to_string(),
        "width": grid.width,
        "height": grid.height,
    }


# ---------------------------------------------------------------------------------- vectors
def read_vector(path: str):
    """``(geoms, fields, crs, layer)`` of a GeoPackage (first layer with geometries) or GeoJSON
    file, read through pyogrio; ``crs`` is None for a layer without one (raw sensor geometry:
    GeoPackage's "undefined" SRSs)."""
    import pyogrio
    import shapely
    from pyogrio.errors import DataLayerError, DataSourceError

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"vector {path} does not exist: check the path")
    ext = os.path.splitext(path)[1].lower()
    if ext not in (".gpkg", ".geojson", ".json"):
        raise InputError(f"vector {path}: use a GeoPackage (.gpkg) or GeoJSON (.geojson) file")
    kind = "GeoPackage" if ext == ".gpkg" else "GeoJSON"
    try:
        layers = [name for name, gtype in pyogrio.list_layers(path) if gtype is not None]
        if not layers:
            raise InputError(f"vector {path} has no layer with geometries")
        meta, _, wkb, columns = pyogrio.raw.read(path, layer=layers[0])
    except (DataSourceError, DataLayerError) as exc:
        raise InputError(f"vector {path} is not a readable {kind} ({exc})") from None
    geoms = list(shapely.from_wkb(wkb))
    fields = {str(n): list(v) for n, v in zip(meta["fields"], columns, strict=True)}
    text = meta["crs"]
    undefined = text is None or (text.startswith("LOCAL_CS") and "Undefined" in text)
    crs = None if undefined else parse_crs(text, f"vector {path}")
    return geoms, fields, crs, layers[0]


def reproject_geoms(geoms, src_crs, dst_crs):
    """Shapely geometries transformed between CRSs with pyproj."""
    import shapely
    from pyproj import Transformer

    tr = Transformer.from_crs(src_crs.to_wkt(), dst_crs.to_wkt(), always_xy=True)
    return [
        shapely.transform(g, lambda xy: np.column_stack(tr.transform(xy[:, 0], xy[:, 1])))
        for g in geoms
    ]
