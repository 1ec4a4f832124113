"""Files of georeferencing: IGM, GLT and GDAL geolocation arrays, GCP tables (CSV and QGIS
Georeferencer ``.points``), CRS strings, and the warps that put a raw-geometry product on a map
grid (GDAL's geolocation-array warper through rasterio) or a product onto a reference's grid.

Every reader raises :class:`~geoboresight.errors.InputError` or
:class:`~geoboresight.errors.ParameterError` with one line naming the file or parameter.

Coordinates are checked against their CRS before use (:func:`check_coordinates`): UTM metres
labelled EPSG:4326, or degrees labelled as a projected CRS, are refused with the input named.
Geographic coordinates (APL's lon/lat IGMs, EMIT-style geolocation arrays, GCPs in WGS 84) are
put on a metric grid, the UTM zone of the data (:func:`output_crs`), unless ``--crs`` says
otherwise.
"""

from __future__ import annotations

import contextlib
import os
import re
from dataclasses import dataclass
from xml.etree import ElementTree

import numpy as np

from ..errors import InputError, ParameterError, shown
from .grid import FLOAT_NODATA, Grid
from .image import open_raster
from .raster import create_raster
from .tables import parse_number, read_table
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
            f"{label}: unknown CRS {shown(value)}: give an EPSG code (e.g. EPSG:32636), a PROJ "
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


def _pyproj(crs):
    """pyproj's CRS of a rasterio CRS (from its EPSG code when it has one: rasterio's WKT
    drops the area of use)."""
    from pyproj import CRS as PyCRS

    if not hasattr(crs, "to_wkt"):
        return PyCRS.from_user_input(crs)
    try:
        code = crs.to_epsg()
    except Exception:  # noqa: BLE001
        code = None
    return PyCRS.from_epsg(code) if code else PyCRS.from_wkt(crs.to_wkt())


def crs_units(crs) -> str:
    """The unit of a CRS's first axis, in the plural (``metres``, ``degrees``, ``US survey
    feet``)."""
    try:
        name = _pyproj(crs).axis_info[0].unit_name
    except Exception:  # noqa: BLE001 - an engineering CRS without axes
        name = ""
    if not name:
        return "CRS units"
    return name[:-4] + "feet" if name.endswith("foot") else name + "s"


def crs_name(crs) -> str:
    """A short name: the EPSG code when there is one, else the CRS's own name."""
    try:
        code = crs.to_epsg()
    except Exception:  # noqa: BLE001
        code = None
    return f"EPSG:{code}" if code else _pyproj(crs).name


#: APL's ``datum ellipsoid`` names of WGS 84 (aplcorr writes ``WGS-84``, apltran ``WGS84``).
_WGS84_NAMES = {"wgs-84", "wgs84", "wgs 84"}


def envi_header_crs(src, label: str):
    """The CRS an ENVI header states where GDAL finds none (no ``map info`` or ``coordinate
    system string``), as NERC-ARF APL writes its IGMs (arsf/APL ``src/geolocation.cpp``,
    ``src/transform.cpp``):

    * aplcorr: ``projection = Geographic Lat/Lon`` and ``datum ellipsoid = WGS-84``, bands
      {Longitude, Latitude, Height}: EPSG:4326 (longitude first, as the bands are);
    * apltran: ``proj4 projection string = +proj=...`` (taken as it is), else
      ``projection = UTM <zone> North|South`` with ``datum ellipsoid = WGS84``.

    None when the header says nothing of its CRS (or the file is not ENVI); an APL header
    that names a projection this reader does not know is refused (give ``--igm-crs``).
    """
    if src.driver != "ENVI":
        return None
    try:
        env = {k.lower(): v.strip() for k, v in (src.tags(ns="ENVI") or {}).items()}
    except Exception:  # noqa: BLE001 - no ENVI domain
        return None
    proj4 = env.get("proj4_projection_string")
    if proj4:
        return parse_crs(proj4, f"{label} {src.name}: its 'proj4 projection string'")
    projection = env.get("projection", "")
    if not projection:
        return None
    ellipsoid = env.get("datum_ellipsoid", "WGS-84").lower()
    words = projection.replace("/", " ").split()
    if ellipsoid in _WGS84_NAMES:
        if projection.lower().startswith("geographic"):
            return parse_crs("EPSG:4326")
        if len(words) == 3 and words[0].upper() == "UTM" and words[1].isdigit():
            zone = int(words[1])
            if 1 <= zone <= 60 and words[2].lower() in ("north", "south"):
                base = 32600 if words[2].lower() == "north" else 32700
                return parse_crs(f"EPSG:{base + zone}")
    raise InputError(
        f"{label} {src.name}: its header says 'projection = {projection}', 'datum ellipsoid = "
        f"{env.get('datum_ellipsoid', '')}', which this reader does not translate: give its CRS "
        "with --igm-crs (e.g. EPSG:27700 for the British National Grid)"
    )


def centre_lonlat(x, y, crs) -> tuple[float, float]:
    """The median position of coordinates ``x``, ``y`` in ``crs``, as WGS 84 lon/lat."""
    xs, ys = np.asarray(x, "float64").ravel(), np.asarray(y, "float64").ravel()
    ok = np.isfinite(xs) & np.isfinite(ys)
    if not ok.any():
        raise InputError("no finite coordinates")
    cx, cy = float(np.median(xs[ok])), float(np.median(ys[ok]))
    if not _pyproj(crs).is_geographic:
        from rasterio.crs import CRS

        lon, lat = transform_xy(np.array([cx]), np.array([cy]), crs, CRS.from_epsg(4326))
        cx, cy = float(lon[0]), float(lat[0])
    return (cx + 180.0) % 360.0 - 180.0, cy


def true_north_bearing(lon: float, lat: float, crs) -> float:
    """The bearing of true north on the grid of ``crs`` at (``lon``, ``lat``), in degrees
    clockwise from the grid's up (the meridian convergence, from two points 10 m apart
    along the meridian: any projection, no formula per projection). A true azimuth ``A``
    is ``A + bearing`` on the grid."""
    from rasterio.crs import CRS

    if _pyproj(crs).is_geographic:
        return 0.0
    dlat = 10.0 / 111_320.0
    x, y = transform_xy(
        np.array([lon, lon]), np.array([lat - dlat, lat + dlat]), CRS.from_epsg(4326), crs
    )
    return float(np.degrees(np.arctan2(x[1] - x[0], y[1] - y[0])))


def metric_matrix(grid: Grid, label: str) -> np.ndarray | None:
    """The 2 × 2 matrix taking a step of (Δcol, Δrow) on ``grid`` to (Δeast, Δnorth) in
    metres, for casting shadows with heights in metres; None when the grid has no
    geotransform.

    * No CRS, or a projected CRS in metres: the geotransform's own matrix.
    * Geographic (longitude, latitude: SRTM, Copernicus DEM): degrees scaled to metres at the
      grid's centre on the CRS's ellipsoid, as ``gdaldem``'s ``-s`` does for the whole
      raster, but exact at the centre and for rotated grids. Over a raster 1° high the east
      scale changes by about 2 % at 45° of latitude; reproject larger ones.
    * A projected CRS in feet or any other unit is refused (``label`` names the file): the
      heights are then most likely in feet too, which the shadow's length depends on.
    """
    t = grid.transform
    if t is None:
        return None
    m = np.array([[t.a, t.b], [t.d, t.e]], dtype=float)
    if grid.crs is None:
        return m
    crs = _pyproj(grid.crs)
    if crs.is_geographic:
        c, r = grid.width / 2.0, grid.height / 2.0
        lon, lat = t.a * c + t.b * r + t.c, t.d * c + t.e * r + t.f
        if not (-90.0 < lat < 90.0):
            raise InputError(f"{label}: its centre is at latitude {lat:g}°, not on the Earth")
        geod = crs.get_geod()
        step = 1e-4  # degrees: about 11 m, where the ellipsoid is flat to 1e-9
        _, _, east = geod.inv(lon - step / 2, lat, lon + step / 2, lat)
        _, _, north = geod.inv(lon, lat - step / 2, lon, lat + step / 2)
        return np.diag([east / step, north / step]) @ m
    factor = crs.axis_info[0].unit_conversion_factor if crs.axis_info else 1.0
    if abs(factor - 1.0) > 1e-9:
        raise InputError(
            f"{label}: its CRS ({crs_name(grid.crs)}) is in {crs_units(grid.crs)}, but cells "
            "and heights must be in metres: reproject it to a CRS in metres (gdalwarp -t_srs "
            "EPSG:326xx, or QGIS's Warp) and give the heights in metres"
        )
    return m


def utm_crs(x, y, crs):
    """The UTM zone (pyproj's ``query_utm_crs_info``) holding the median position of
    coordinates ``x``, ``y`` given in ``crs``: on the CRS's datum when it is NAD83 or NAD27
    (and the position is in North America), else on WGS 84; beyond UTM's latitudes (84°N,
    80°S) the polar stereographic grid of WGS 84 (UPS, EPSG:5041/5042)."""
    from pyproj.aoi import AreaOfInterest
    from pyproj.database import query_utm_crs_info

    lon, lat = centre_lonlat(x, y, crs)
    datum = (_pyproj(crs).datum.name if _pyproj(crs).datum else "") or ""
    names = ["WGS 84"]
    if "North American Datum 1983" in datum:
        names.insert(0, "NAD83")
    elif "North American Datum 1927" in datum:
        names.insert(0, "NAD27")
    for name in names:
        found = query_utm_crs_info(
            datum_name=name, area_of_interest=AreaOfInterest(lon, lat, lon, lat)
        )
        if found:
            # The zone of the data's hemisphere (a northern zone's area starts at the
            # equator), nearest to its central meridian.
            best = min(
                found,
                key=lambda i: (
                    (i.area_of_use.south >= 0) != (lat >= 0),
                    abs(lon - 0.5 * (i.area_of_use.west + i.area_of_use.east)),
                ),
            )
            return parse_crs(f"{best.auth_name}:{best.code}")
    return parse_crs("EPSG:5041" if lat > 0 else "EPSG:5042")


def output_crs(crs, src_crs, x, y):
    """The output CRS of a warp: ``crs`` (a user string) when given; else ``src_crs`` when it
    is projected; else (coordinates in degrees: APL's lon/lat IGMs, geolocation arrays or GCPs
    in WGS 84) the UTM zone of the data (:func:`utm_crs`), so that the grid is metric and
    ``--resolution`` is in metres."""
    if crs:
        out = parse_crs(crs)
        if src_crs is not None:
            # A CRS for another part of the world (a zone picked from a list) would still
            # give a raster, skewed and scaled by a projection used far beyond its area.
            x, y = np.ravel(x), np.ravel(y)
            ok = np.flatnonzero(np.isfinite(x) & np.isfinite(y))
            ok = ok[:: max(1, ok.size // 10_000)]
            if ok.size:
                xo, yo = transform_xy(x[ok], y[ok], src_crs, out)
                check_coordinates(
                    xo,
                    yo,
                    out,
                    what=f"parameter 'crs': the product, at {crs_name(out)},",
                    fix="choose a CRS for the product's area (or leave 'crs' empty for its UTM "
                    "zone)",
                )
        return out
    if src_crs is None or not _pyproj(src_crs).is_geographic:
        return src_crs
    return utm_crs(x, y, src_crs)


#: Largest coordinate of any CRS, in its units (the Earth's circumference is 4e7 m, 1.3e8 US
#: survey feet): beyond it the values are not coordinates.
COORDINATE_LIMIT = 1e9

#: Plausible ground distance between neighbouring pixels of an imaging spectrometer (m):
#: from drone and lab-rail scanners (about a centimetre, 1 mm allowed) to spaceborne ones
#: (30 m EnMAP/PRISMA, 60 m EMIT; 10 km allowed).
GROUND_SPACING_M = (1e-3, 1e4)


def _ground_spacing_m(x, y, valid, crs) -> float | None:
    """The median distance between neighbouring pixels in metres (None when it cannot be
    told), degrees converted at the data's latitude."""
    c = _pyproj(crs)
    try:
        if c.is_geographic:
            lat0 = np.radians(np.clip(np.nanmedian(y[valid]), -89.0, 89.0))
            return pixel_spacing(x * 111_320.0 * np.cos(lat0), y * 110_574.0, valid)
        factor = c.axis_info[0].unit_conversion_factor if c.axis_info else 1.0
        return pixel_spacing(x, y, valid) * float(factor or 1.0)
    except (InputError, ValueError, IndexError):
        return None


def check_coordinates(x, y, crs, *, what: str, fix: str, valid=None, spacing: bool = False):
    """Refuse coordinates that contradict their CRS, naming ``what`` holds them and saying
    what to do (``fix``).

    * geographic CRS: longitude beyond ±360° or latitude beyond ±90° (e.g. UTM metres
      labelled EPSG:4326: a latitude of 3.45 million);
    * projected CRS: a position outside the CRS's area of use (pyproj) widened by the area's
      own width and height on every side (a generous margin: a line in the next UTM zone
      passes);
    * with ``spacing`` (per-pixel coordinates: IGMs, geolocation arrays), a median distance
      between neighbouring pixels outside :data:`GROUND_SPACING_M` once converted to metres
      (degrees labelled as metres advance micrometres from pixel to pixel).

    The test is on the median position (one corrupt pixel is masked later, not refused).
    """
    x = np.asarray(x, "float64")
    y = np.asarray(y, "float64")
    ok = np.isfinite(x) & np.isfinite(y)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    if not ok.any():
        return
    mx, my = float(np.median(x[ok])), float(np.median(y[ok]))
    span = (
        f"x {np.min(x[ok]):.10g} … {np.max(x[ok]):.10g}, y {np.min(y[ok]):.10g} … "
        f"{np.max(y[ok]):.10g}"
    )
    c = _pyproj(crs)
    name = crs_name(crs)
    big = max(abs(mx), abs(my))
    if big > COORDINATE_LIMIT:
        raise InputError(
            f"{what}: coordinates of {big:.3g} {crs_units(crs)} are outside any CRS's range "
            f"({span}): the file holds other values than coordinates (a nodata value, an "
            "offset or a scale factor not applied?)"
        )
    if c.is_geographic:
        if abs(my) > 90 or abs(mx) > 360:
            raise InputError(
                f"{what} holds {span}, which cannot be longitude and latitude in {name} "
                f"(latitude within ±90°, longitude within ±360°): these are not degrees; {fix}"
            )
    else:
        aou = c.area_of_use
        if aou is not None:
            from pyproj import Transformer

            try:
                tr = Transformer.from_crs("EPSG:4326", c, always_xy=True)
                x0, y0, x1, y1 = tr.transform_bounds(
                    aou.west, aou.south, aou.east, aou.north, densify_pts=21
                )
            except Exception:  # noqa: BLE001 - a CRS PROJ cannot bound: no area test
                x0 = None
            if x0 is not None and np.all(np.isfinite([x0, y0, x1, y1])):
                dx, dy = x1 - x0, y1 - y0
                if not (x0 - dx <= mx <= x1 + dx and y0 - dy <= my <= y1 + dy):
                    if x0 - dx <= my <= x1 + dx and y0 - dy <= mx <= y1 + dy:
                        raise InputError(
                            f"{what} holds {span}, far outside the area where {name} is used "
                            f"({aou.name.split('.')[0]}), but inside it with x and y swapped: "
                            "put the easting first (an IGM's band 1, a GCP file's x column) "
                            "and the northing second"
                        )
                    raise InputError(
                        f"{what} holds {span}, far outside the area where {name} is used "
                        f"({aou.name.split('.')[0]}): the coordinates are in another CRS; {fix}"
                    )
    if spacing:
        try:
            pixel_spacing(x, y, ok)
        except InputError as exc:
            raise InputError(f"{what}: {exc}") from None
        step = _ground_spacing_m(x, y, ok, crs)
        lo, hi = GROUND_SPACING_M
        if step is not None and not lo <= step <= hi:
            units = crs_units(crs)
            raise InputError(
                f"{what}: neighbouring pixels lie {step:.3g} m apart when read in {name} "
                f"({units}), outside the {lo:g} m to {hi:g} m of any imaging spectrometer: the "
                f"values are in other units than {name} says (degrees read as metres, or "
                f"metres as degrees); {fix}"
            )


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
    An ENVI header without ``map info`` is read for APL's CRS lines (:func:`envi_header_crs`).
    The coordinates are checked against the CRS (:func:`check_coordinates`).
    """
    path = os.fspath(path)
    user_crs = parse_crs(crs, "parameter 'igm_crs'") if crs else None
    with open_raster(path, label) as src:
        geo = _geolocation_metadata(src)
        if geo.get("X_DATASET") and geo.get("Y_DATASET"):
            coords = _read_geolocation(src, geo, path, user_crs, label)
            _check(coords, label, "from its SRS" if user_crs is None else "from --igm-crs")
            return coords
        if src.count < 2:
            raise InputError(
                f"{label} {path} has {src.count} band: an IGM needs easting (band 1) and "
                "northing (band 2) of every pixel"
            )
        x = src.read(1, masked=True).astype("float64").filled(np.nan)
        y = src.read(2, masked=True).astype("float64").filled(np.nan)
        file_crs = src.crs or (None if user_crs else envi_header_crs(src, label))
    use = user_crs or file_crs
    if use is None:
        raise InputError(
            f"{label} {path} carries no CRS in its header: give it with --igm-crs (e.g. EPSG:32636)"
        )
    coords = Coordinates(x, y, use, path, f"IGM {os.path.basename(path)}")
    _check(coords, label, "from its header" if user_crs is None else "from --igm-crs")
    return coords


def _check_zero_fill(coords: Coordinates, label: str) -> None:
    """Refuse pixels whose x and y hold one same value far from all the others: a fill value
    the file does not declare as nodata ((0, 0), (−9999, −9999): IGMs of pixels the processor
    could not locate), which would be taken for positions thousands of kilometres away (a map
    grid of the size of a continent, or an affine fit of the line pulled towards them)."""
    x, y = coords.x, coords.y
    finite = np.isfinite(x) & np.isfinite(y)
    same = finite & (x == y)
    if not same.any():
        return
    values = np.unique(x[same])
    rest = finite & ~same
    if values.size != 1 or not rest.any():
        return
    v = float(values[0])
    x0, x1, y0, y1 = x[rest].min(), x[rest].max(), y[rest].min(), y[rest].max()
    w, h = x1 - x0, y1 - y0
    if x0 - w <= v <= x1 + w and y0 - h <= v <= y1 + h:
        return  # a line that does pass near (v, v)
    raise InputError(
        f"{label} {coords.path}: {int(same.sum())} pixel(s) sit at ({v:g}, {v:g}), far from "
        f"the others (x {x0:.10g} … {x1:.10g}, y {y0:.10g} … {y1:.10g}): {v:g} marks pixels "
        f"without a position; declare it the file's nodata value (e.g. gdal_edit.py "
        f"-a_nodata {v:g})"
    )


def _check(coords: Coordinates, label: str, origin: str) -> None:
    _check_zero_fill(coords, label)
    fix = (
        "give the right CRS with --igm-crs (e.g. EPSG:32636 for UTM 36N metres, EPSG:4326 for "
        "longitude/latitude)"
        if origin != "from --igm-crs"
        else "check --igm-crs (e.g. EPSG:32636 for UTM 36N metres, EPSG:4326 for "
        "longitude/latitude)"
    )
    check_coordinates(
        coords.x,
        coords.y,
        coords.crs,
        what=f"{label} {coords.path} (CRS {crs_name(coords.crs)} {origin})",
        fix=fix,
        spacing=True,
    )


def coordinates_for(input, igm=None, crs=None) -> Coordinates:
    """The per-pixel coordinates of ``input``: its IGM (``igm``) when given, else its own GDAL
    geolocation arrays. A product without them is refused: its bands are data, not
    coordinates, whatever ``crs`` (``--igm-crs``, the CRS of an IGM) says."""
    for path, label in ((igm, "IGM"), (None if igm else input, "input")):
        coords = product_coordinates(path, crs, label) if path else None
        if coords is not None:
            return coords
    if igm:
        return read_coordinates(igm, crs=crs, label="IGM")
    input = os.fspath(input)
    with open_raster(input, "input") as src:
        has_arrays = bool(_geolocation_metadata(src).get("X_DATASET"))
    if not has_arrays:
        extra = " (--igm-crs gives the CRS of an IGM: it needs --igm)" if crs else ""
        raise InputError(
            f"input {input} has no GDAL geolocation arrays (GEOLOCATION metadata): give its "
            f"coordinates with --igm (an IGM) or --glt (a GLT){extra}"
        )
    return read_coordinates(input, crs=crs, label="input")


def product_coordinates(path, crs=None, label: str = "IGM") -> Coordinates | None:
    """The geolocation a sensor product carries (PRISMA L1's latitude and longitude arrays:
    :class:`geoboresight.io.products.Geolocation`) as coordinates, checked against their CRS;
    None when ``path`` is no such product. ``crs`` (``--igm-crs``) overrides theirs."""
    from .products import recognise

    path = os.fspath(path)
    if not os.path.exists(path):
        return None
    product = recognise(path)
    if product is not None and product.geolocation is None and product.geolocation_problem:
        raise InputError(
            f"{label} {path} ({product.kind}): {product.geolocation_problem}; give its "
            "coordinates with 'igm' (an IGM) or 'glt' (a GLT)",
            params=("igm", "glt"),
        )
    if product is None or product.geolocation is None:
        return None
    geo = product.geolocation
    arrays = []
    for source, band, axis in ((geo.x, geo.x_band, "x"), (geo.y, geo.y_band, "y")):
        with open_raster(source, f"{label} {path}: {product.kind} geolocation {axis}") as g:
            arrays.append(g.read(band, masked=True).astype("float64").filled(np.nan))
    use = parse_crs(crs, "parameter 'igm_crs'") if crs else parse_crs(geo.crs, f"{label} {path}")
    coords = Coordinates(
        arrays[0], arrays[1], use, path, f"{product.kind} geolocation ({geo.source or geo.crs})"
    )
    _check(coords, label, "from its product" if not crs else "from --igm-crs")
    return coords


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
    """Read a GLT (band 1: sample, band 2: line; one-based; 0 or nodata: nothing seen; a
    negative index is ENVI's infill from a neighbouring cell, its absolute value the index:
    :func:`geoboresight.georef.geoloc.glt_indices`), as ENVI, AVIRIS-NG and EMIT (emit-sds
    ``emit_utils/reformat.py``: ``glt_x``, ``glt_y`` on an EPSG:4326 grid) write it."""
    path = os.fspath(path)
    with open_raster(path, "GLT") as src:
        if src.count < 2:
            raise InputError(f"GLT {path} has {src.count} band: it needs sample (1) and line (2)")
        if src.transform is None or src.transform.is_identity:
            raise InputError(f"GLT {path} has no geotransform: a GLT is a map grid")
        s = src.read(1, masked=True)
        line = src.read(2, masked=True)
        valid = ~(np.ma.getmaskarray(s) | np.ma.getmaskarray(line))
        # NaN (a float GLT without a declared nodata) shows no pixel, as 0 does.
        nan = ~(np.isfinite(np.ma.getdata(s)) & np.isfinite(np.ma.getdata(line)))
        if nan.any():
            valid &= ~nan
            s = np.ma.masked_where(nan, s)
            line = np.ma.masked_where(nan, line)
        grid = Grid(
            src.width, src.height, parse_crs(crs, "parameter 'igm_crs'") or src.crs, src.transform
        )
    if grid.crs is None:
        raise InputError(f"GLT {path} carries no CRS: give it with --igm-crs")
    t = grid.transform
    col = np.array([0.0, grid.width, grid.width, 0.0])
    row = np.array([0.0, 0.0, grid.height, grid.height])
    cx, cy = t.c + t.a * col + t.b * row, t.f + t.d * col + t.e * row
    check_coordinates(
        cx,
        cy,
        grid.crs,
        what=f"GLT {path}: its map grid (CRS {crs_name(grid.crs)})",
        fix="give the right CRS with --igm-crs",
    )
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


_CRS_LINE = re.compile(r"^CRS\s*[:=]\s*(.*)$", re.I)


def read_gcps(path, *, crs=None) -> GCPs:
    """Read GCPs from a CSV or a QGIS Georeferencer ``.points`` file.

    * CSV: a header naming ``pixel,line,x,y`` (any order, optionally ``enable``); a comment
      line ``# CRS: EPSG:...`` may give the CRS.
    * QGIS ``.points`` (every QGIS 3.x; recognised by a header starting ``mapX,mapY``): columns
      by position, as QGIS reads them (``QgsGCPList::loadGcps``): map x, map y, source x,
      source y, then ``enable`` (0: skipped), and QGIS's residuals (ignored). The header
      names the source columns ``pixelX,pixelY`` (earlier releases) or ``sourceX,sourceY``
      (recent ones, ``QgsGCPList::saveGcps``); a first line ``#CRS: <WKT>`` (about 3.26
      on) is the GCPs' CRS. For a
      raster without a geotransform, as raw products are, QGIS's source coordinates are the
      pixel column and the negative line (its source layer's y axis points up): line =
      −sourceY.

    Comma, semicolon or tab separated, with or without a byte-order mark
    (:mod:`geoboresight.io.tables`). ``crs`` (a user string) overrides the file's CRS.
    """
    path = os.fspath(path)
    table = read_table(path, "GCP file")
    file_crs = None
    for comment in table.comments:
        m = _CRS_LINE.match(comment)
        if m and m.group(1).strip():
            file_crs = m.group(1).strip()
    header = [h.strip().lower() for h in table.header]
    qgis = header[:2] == ["mapx", "mapy"] and len(header) >= 4
    plain = {"pixel", "line", "x", "y"} <= set(header)
    if not (qgis or plain):
        raise InputError(
            f"GCP file {path}: the first line must name the columns pixel,line,x,y (CSV) or "
            "mapX,mapY,sourceX,sourceY (QGIS .points); found " + ",".join(table.header)
        )
    if qgis:
        cols, idx, en = ("sourceX", "sourceY", "mapX", "mapY"), [2, 3, 0, 1], 4
    else:
        cols = ("pixel", "line", "x", "y")
        idx = [header.index(c) for c in cols]
        en = header.index("enable") if "enable" in header else None
    values, enabled = [], []
    for n, row in zip(table.line_numbers, table.rows, strict=True):
        try:
            values.append([parse_number(row[i], table.delimiter) for i in idx])
            on = en is not None and en < len(row) and row[en] != ""
            enabled.append(bool(int(parse_number(row[en], table.delimiter))) if on else True)
        except (ValueError, IndexError):
            raise InputError(
                f"GCP file {path}, line {n}: expected numbers in {', '.join(cols)}, got "
                f"{shown(table.delimiter.join(row))}"
            ) from None
    if not values:
        raise InputError(f"GCP file {path} holds no GCPs")
    v = np.array(values, "float64").reshape(-1, 4)
    pl = v[:, :2].copy()
    if qgis:
        pl[:, 1] = -pl[:, 1]  # QGIS: sourceY = -line
    user = parse_crs(crs, "parameter 'gcp_crs'") if crs else None
    fcrs = parse_crs(file_crs, f"GCP file {path}: its CRS line") if file_crs else None
    gcps = GCPs(pl, v[:, 2:], np.array(enabled, bool), user or fcrs, path)
    if gcps.crs is not None and gcps.enabled.any():
        origin = "from --gcp-crs" if user else "from its CRS line"
        check_coordinates(
            gcps.xy[gcps.enabled, 0],
            gcps.xy[gcps.enabled, 1],
            gcps.crs,
            what=f"GCP file {path} (CRS {crs_name(gcps.crs)} {origin}): its map coordinates",
            fix="give the right CRS with --gcp-crs (or in the file's '# CRS:' line)",
        )
    return gcps


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
            f"and bottom-left corners; got {shown(corners)}"
        )
    pl = np.array([[0, 0], [width, 0], [width, height], [0, height]], "float64")
    return pl, np.array(v, "float64").reshape(4, 2)


def reference_window(ref, bounds, reference: str):
    """The window of the open raster ``ref`` covering map ``bounds`` (left, bottom, right,
    top, in its CRS), clipped to the raster; a placement that misses the raster is refused,
    naming both extents."""
    from rasterio.windows import Window, from_bounds

    left, bottom, right, top = (float(b) for b in bounds)
    win = None
    if all(np.isfinite([left, bottom, right, top])):
        win = from_bounds(left, bottom, right, top, ref.transform).round_offsets().round_lengths()
        c0, r0 = max(win.col_off, 0), max(win.row_off, 0)
        c1 = min(win.col_off + win.width, ref.width)
        r1 = min(win.row_off + win.height, ref.height)
        win = Window(c0, r0, c1 - c0, r1 - r0) if c1 > c0 and r1 > r0 else None
    if win is None:
        b = ref.bounds
        raise InputError(
            f"the rough placement (--gcps or --corners) puts the product at x {left:.10g} … "
            f"{right:.10g}, y {bottom:.10g} … {top:.10g} ({crs_name(ref.crs)}), which does not "
            f"overlap reference {reference} (x {b.left:.10g} … {b.right:.10g}, y "
            f"{b.bottom:.10g} … {b.top:.10g}): check the placement's coordinates and their CRS "
            "(--gcp-crs), or give the orthophoto that covers this line"
        )
    return win


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
            f"parameter 'resampling': {shown(resampling)} is not one of {', '.join(RESAMPLINGS)}"
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
        raise InputError(_no_advance(x, y, valid, steps))
    return float(np.sqrt(steps[0] * steps[-1]))


def _no_advance(x, y, valid, steps) -> str:
    """Why the pixel spacing cannot be told, in words."""
    if not np.any(valid):
        return "no pixel has coordinates (all NaN or nodata)"
    xs, ys = np.asarray(x)[valid], np.asarray(y)[valid]
    if not steps:
        return "no two neighbouring pixels both have coordinates"
    if np.ptp(xs) == 0 and np.ptp(ys) == 0:
        return (
            f"every pixel has the same coordinates ({xs[0]:.10g}, {ys[0]:.10g}): they do not "
            "advance from pixel to pixel"
        )
    big = float(max(np.abs(xs).max(), np.abs(ys).max()))
    if big > COORDINATE_LIMIT:
        return (
            f"coordinates of {big:.3g} do not advance from pixel to pixel (too large for the "
            "precision of a number): they are outside any CRS's range"
        )
    which = "along the lines" if len(steps) > 1 and steps[1] <= 0 else "from line to line"
    return f"the coordinates do not advance {which} (the median step between neighbours is 0)"


#: Fewest output cells along each side of the grid (or the product's own pixels less one,
#: for a product narrower than that): coarser cells show the product as a blob, and are
#: almost always a unit mistake (degrees for metres).
MIN_CELLS = 16
#: Share of the available memory a warp may plan to use (GDAL's buffers and the rest of the
#: process need the remainder).
MEMORY_SHARE = 0.75


def map_grid(x, y, valid, crs, resolution: float | None) -> Grid:
    """A north-up grid covering the pixel centres ``x``, ``y`` (plus one cell), its cells
    aligned on multiples of ``resolution`` (default: the median pixel spacing).

    Refused, naming the coarsest resolution that would do: a resolution that covers the
    footprint with fewer than :data:`MIN_CELLS` cells along either side (fewer than the
    product's lines or columns less one, for a product narrower than that).
    """
    from rasterio.transform import from_origin

    res = float(resolution) if resolution else float(f"{pixel_spacing(x, y, valid):.3g}")
    xs, ys = x[valid], y[valid]
    need = max(1, min(MIN_CELLS, min(np.shape(x)) - 1))
    ext_x, ext_y = float(xs.max() - xs.min()), float(ys.max() - ys.min())
    if min(ext_x, ext_y) / res < need:
        coarsest = _round_sig(min(ext_x, ext_y) / need, up=False)
        units = crs_units(crs)
        raise ParameterError(
            f"parameter 'resolution': {res:g} ({units} of {crs_name(crs)}) would cover the "
            f"product's {ext_x:.4g} × {ext_y:.4g} footprint with {ext_x / res:.3g} × "
            f"{ext_y / res:.3g} cells (at least {need} along each side): give --resolution "
            f"{coarsest:g} or finer"
        )
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


def _round_sig(v: float, up: bool) -> float:
    """``v`` rounded to two significant digits, up or down (a limit stays on its side)."""
    if not np.isfinite(v) or v <= 0:
        return v
    step = 10.0 ** (np.floor(np.log10(v)) - 1)
    return float(f"{(np.ceil(v / step) if up else np.floor(v / step)) * step:.6g}")


def available_memory() -> int:
    """Bytes of memory available to this process now (psutil, which Dask brings; else the
    physical pages the OS reports free)."""
    try:
        import psutil

        return int(psutil.virtual_memory().available)
    except Exception:  # noqa: BLE001 - psutil absent: the OS's count
        try:
            return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
        except (ValueError, OSError, AttributeError):
            return 1 << 62  # unknown: do not refuse


def _human_bytes(n: float) -> str:
    for unit in ("B", "KB", "MB", "GB", "TB"):
        if n < 1000 or unit == "TB":
            return f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} TB"


def check_warp_memory(grid: Grid, raw_shape, bands: int, dtype) -> None:
    """Refuse a warp whose buffers would not fit in memory, before any of it is done, naming
    the resolution that would fit and the memory the asked one needs.

    A block of :data:`BANDS_PER_WARP` bands is warped at a time: the block on the map grid,
    and the raw block with its padded copy (``2 × (lines + 1) × (columns + 1)``), each in the
    product's data type. The plan may use :data:`MEMORY_SHARE` of the available memory.
    """
    nb = min(BANDS_PER_WARP, max(int(bands), 1))
    item = np.dtype(dtype).itemsize * nb
    cells = float(grid.width) * float(grid.height)
    raw = 2.0 * (raw_shape[0] + 1) * (raw_shape[1] + 1) * item
    need = cells * item + raw
    have = MEMORY_SHARE * available_memory()
    if need <= have:
        return
    res = abs(float(grid.transform.a))
    units = crs_units(grid.crs)
    room = have - raw
    if room <= 0:
        raise ParameterError(
            f"the warp of {nb} band(s) of the {raw_shape[1]} × {raw_shape[0]} product needs "
            f"{_human_bytes(raw)} for the product alone, {_human_bytes(have)} of memory "
            "available: close other programs or use a machine with more memory"
        )
    fit = _round_sig(1.05 * res * float(np.sqrt(cells * item / room)), up=True)
    raise ParameterError(
        f"parameter 'resolution': {res:g} ({units} of {crs_name(grid.crs)}) gives a "
        f"{grid.width:,} × {grid.height:,} grid whose warp needs {_human_bytes(need)} of memory "
        f"({nb} band(s) at a time), {_human_bytes(have)} at hand: give --resolution {fit:g} or "
        "coarser (or close other programs)"
    )


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
        check_warp_memory(grid, (src.height, src.width), src.count, src.dtypes[0])
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
    if os.path.getsize(path) == 0:
        raise InputError(f"vector {path} is empty (0 bytes): give a {kind} file with features")
    if kind == "GeoJSON":
        _check_geojson(path)
    try:
        layers = [name for name, gtype in pyogrio.list_layers(path) if gtype is not None]
        if not layers:
            raise InputError(f"vector {path} has no layer with geometries")
        meta, _, wkb, columns = pyogrio.raw.read(path, layer=layers[0])
    except (DataSourceError, DataLayerError) as exc:
        # GDAL's reason, without its advice on driver prefixes (which does not apply here).
        reason = str(exc).split("; It might help")[0].replace(f"'{path}' ", "")[:300]
        raise InputError(f"vector {path} is not a readable {kind} ({reason})") from None
    # A feature without geometry (GeoJSON's "geometry": null) stays one, as ogr2ogr keeps it.
    geoms = [None if g is None else shapely.from_wkb(g) for g in wkb]
    fields = {str(n): list(v) for n, v in zip(meta["fields"], columns, strict=True)}
    text = meta["crs"]
    if text is None and kind == "GeoPackage":
        _check_gpkg_srs(path, layers[0])
    undefined = text is None or (text.startswith("LOCAL_CS") and "Undefined" in text)
    crs = None if undefined else parse_crs(text, f"vector {path}")
    return geoms, fields, crs, layers[0]


#: GeoPackage's own "undefined" spatial reference systems (-1 Cartesian, 0 geographic) and
#: the one GDAL writes for a layer without a CRS.
_GPKG_UNDEFINED = (-1, 0, 99999)


def _check_gpkg_srs(path: str, layer: str) -> None:
    """Refuse a GeoPackage layer whose declared spatial reference system cannot be resolved
    (GDAL then gives it no CRS, as if it were in raw sensor geometry)."""
    import sqlite3

    try:
        with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
            row = db.execute(
                "SELECT c.srs_id, s.definition FROM gpkg_geometry_columns c LEFT JOIN "
                "gpkg_spatial_ref_sys s ON s.srs_id = c.srs_id WHERE c.table_name = ?",
                (layer,),
            ).fetchone()
    except sqlite3.Error:
        return  # GDAL read it; its tables are its business
    if row is None or row[0] in _GPKG_UNDEFINED:
        return
    srs_id, definition = row
    said = "no definition" if definition is None else f"the definition {shown(definition)}"
    raise InputError(
        f"vector {path}: layer {layer} declares the spatial reference system {srs_id} with "
        f"{said}, which cannot be resolved: correct its gpkg_spatial_ref_sys entry (e.g. "
        "ogr2ogr -a_srs EPSG:32636)"
    )


#: Largest GeoJSON file parsed with Python's json module to say what is wrong with it (a
#: larger one goes to GDAL directly).
GEOJSON_CHECK_BYTES = 64 << 20
_GEOJSON_TYPES = {
    "FeatureCollection",
    "Feature",
    "Point",
    "MultiPoint",
    "LineString",
    "MultiLineString",
    "Polygon",
    "MultiPolygon",
    "GeometryCollection",
}


def _check_geojson(path: str) -> None:
    """Refuse, saying what is wrong, a GeoJSON file GDAL would reject with "not recognized as
    being in a supported file format": not JSON, a bare array, an object of no GeoJSON type,
    features that are not objects."""
    import json

    if os.path.getsize(path) > GEOJSON_CHECK_BYTES:
        return
    try:
        with open(path, encoding="utf-8-sig") as f:
            doc = json.load(f)
    except UnicodeDecodeError:
        raise InputError(f"vector {path} is not text (UTF-8): give a GeoJSON file") from None
    except json.JSONDecodeError as exc:
        raise InputError(
            f"vector {path} is not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
    if isinstance(doc, list):
        raise InputError(
            f"vector {path} holds a JSON array of {len(doc)} item(s), not a GeoJSON object: wrap "
            'the features as {"type": "FeatureCollection", "features": [...]}'
        )
    if not isinstance(doc, dict) or doc.get("type") not in _GEOJSON_TYPES:
        got = doc.get("type") if isinstance(doc, dict) else type(doc).__name__
        raise InputError(
            f'vector {path} is not GeoJSON: its "type" is {shown(got)}, not '
            "FeatureCollection, Feature or a geometry type"
        )
    _check_geojson_crs(path, doc.get("crs"))
    if doc["type"] == "FeatureCollection":
        features = doc.get("features")
        if not isinstance(features, list):
            raise InputError(f'vector {path}: its FeatureCollection has no "features" list')
        for n, feature in enumerate(features, 1):
            if not isinstance(feature, dict):
                raise InputError(
                    f"vector {path}: feature {n} is {shown(feature)}, not a GeoJSON Feature object"
                )


def _check_geojson_crs(path: str, member) -> None:
    """Refuse a GeoJSON ``crs`` member (the 2008 specification's named CRS, which GDAL still
    reads) naming a CRS that cannot be resolved: GDAL would read the coordinates as WGS84."""
    if member is None:
        return
    props = member.get("properties") if isinstance(member, dict) else None
    name = props.get("name") if isinstance(props, dict) else None
    if not isinstance(name, str) or not name.strip():
        raise InputError(
            f'vector {path}: its "crs" member {shown(member)} names no CRS: give '
            '{"type": "name", "properties": {"name": "EPSG:32636"}}, or leave "crs" out for '
            "WGS84 longitude/latitude"
        )
    from pyproj import CRS as PyCRS
    from pyproj.exceptions import CRSError

    try:
        PyCRS.from_user_input(name.strip())
    except CRSError:
        raise InputError(
            f"vector {path} declares the CRS {shown(name)}, which is not known (PROJ's "
            'database has no such CRS): correct its "crs" member (e.g. EPSG:32636, '
            "urn:ogc:def:crs:EPSG::32636), or leave it out for WGS84 longitude/latitude"
        ) from None


def reproject_geoms(geoms, src_crs, dst_crs):
    """Shapely geometries transformed between CRSs with pyproj (None, a feature without
    geometry, stays None)."""
    import shapely
    from pyproj import Transformer

    tr = Transformer.from_crs(src_crs.to_wkt(), dst_crs.to_wkt(), always_xy=True)
    return [
        None
        if g is None
        else shapely.transform(g, lambda xy: np.column_stack(tr.transform(xy[:, 0], xy[:, 1])))
        for g in geoms
    ]


def grid_place(grid) -> tuple[float, float, object] | None:
    """(lon, lat, CRS) of the centre of a grid with a CRS and a geotransform, else None: where
    the sun is computed from the acquisition time (:func:`sun_angles`)."""
    if grid.crs is None or grid.transform is None:
        return None
    t, c, r = grid.transform, grid.width / 2.0, grid.height / 2.0
    cx, cy = t.a * c + t.b * r + t.c, t.d * c + t.e * r + t.f
    lon, lat = centre_lonlat(np.array([cx]), np.array([cy]), grid.crs)
    return lon, lat, grid.crs
