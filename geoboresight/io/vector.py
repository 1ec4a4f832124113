"""Vector layers (shadow and anomaly polygons or points): GeoPackage and GeoJSON through
pyogrio (GDAL's OGR), written atomically.

The engine runs in its own process, never inside QGIS's (where a second GDAL writing vectors
beside QGIS's own was a risk), so GDAL's OGR writes the files: a layer named as asked, the
attribute columns typed from their NumPy dtype (integer, float, text; NaN as null), the
geometry type (``MultiPolygon`` for polygons, ``Point``, or ``Unknown`` for a mix) and the CRS
(in GeoJSON, one without an EPSG code as WKT in the ``crs`` member). In raw sensor geometry
there is no CRS: the layer gets none (GDAL's "undefined" SRS in a GeoPackage, no ``crs`` member
in GeoJSON) and its description says so.
"""

from __future__ import annotations

import json
import os
import warnings
from collections.abc import Mapping, Sequence

import numpy as np
import shapely
import shapely.geometry

from ..errors import InputError, ParameterError
from .write import atomic_output, output_error

FORMATS = {".gpkg": "GPKG", ".geojson": "GeoJSON", ".json": "GeoJSON"}


def trace_shapes(values, *, mask=None, transform=None, connectivity: int = 4) -> list:
    """``[(shapely polygon, value), ...]``: the pixel outline of every connected patch of equal
    ``values`` inside ``mask`` (rasterio.features.shapes), in the coordinates of ``transform``
    (None: pixel coordinates, x = column, y = line)."""
    from rasterio.features import shapes
    from rasterio.transform import Affine

    tr = Affine.identity() if transform is None else transform
    traced = shapes(values, mask=mask, transform=tr, connectivity=connectivity)
    return [(shapely.geometry.shape(g), v) for g, v in traced]


def vector_format(path: str) -> str:
    """'GPKG' or 'GeoJSON' from the file name; a clear error otherwise."""
    ext = os.path.splitext(path)[1].lower()
    if ext not in FORMATS:
        raise ParameterError(f"output {path}: use a .gpkg (GeoPackage) or .geojson file name")
    return FORMATS[ext]


def write_vector(
    path: str,
    geoms: Sequence,
    fields: Mapping[str, Sequence],
    *,
    crs=None,
    layer: str = "features",
    description: str = "",
    overwrite: bool = True,
) -> str:
    """Write shapely geometries with attribute columns to a GeoPackage or GeoJSON, atomically.

    ``fields`` maps column names to sequences as long as ``geoms``; integer, float and text
    columns are recognised from their NumPy dtype. ``crs`` is a rasterio/pyproj CRS or None
    (raw sensor geometry).
    """
    fmt = vector_format(path)
    cols = {k: np.asarray(v) for k, v in fields.items()}
    for k, v in cols.items():
        if len(v) != len(geoms):
            raise ValueError(f"field {k} has {len(v)} values for {len(geoms)} geometries")
    from pyogrio import errors

    ogr_errors = (
        errors.DataSourceError,
        errors.DataLayerError,
        errors.FieldError,
        errors.GeometryError,
        errors.FeatureError,
        errors.CRSError,
    )
    with atomic_output(path, overwrite=overwrite) as tmp:
        try:
            _write_ogr(tmp, fmt, list(geoms), cols, crs, layer, description)
            # GDAL may report a failed flush at close only on stderr: read the count back.
            written = _feature_count(tmp, layer)
        except ogr_errors as exc:
            raise output_error(OSError(str(exc)), path, tmp, mine=True) from exc
        if written != len(geoms):
            raise output_error(
                OSError(f"{written} of {len(geoms)} features written"), path, tmp, mine=True
            )
    return path


def _feature_count(path: str, layer: str) -> int:
    import pyogrio

    return int(pyogrio.read_info(path, layer=layer, force_feature_count=True)["features"])


def _column(v: np.ndarray) -> np.ndarray:
    """A column as OGR takes it: integers (and booleans) as int64, floats as float64 (NaN and
    ±inf written as null), anything else as text (None stays null)."""
    if v.dtype.kind in "iub":
        return v.astype(np.int64)
    if v.dtype.kind == "f":
        return np.where(np.isfinite(v), v, np.nan).astype(np.float64)
    return np.array([None if x is None else str(x) for x in v.tolist()], dtype=object)


def _geometry_type(geoms) -> str:
    kinds = {g.geom_type for g in geoms if g is not None}
    if kinds <= {"Point"} and kinds:
        return "Point"
    if kinds <= {"Polygon", "MultiPolygon"}:
        return "MultiPolygon"
    return "Unknown"


def _write_ogr(path, fmt, geoms, cols, crs, layer, description) -> None:
    from pyogrio.raw import write

    gtype = _geometry_type(geoms)
    # output_dimension=2: the layers are 2-D (shapely's default WKB would keep a stray z).
    wkb = np.array(
        [None if g is None else shapely.to_wkb(g, byte_order=1, output_dimension=2) for g in geoms],
        dtype=object,
    )
    options = {"DESCRIPTION": description} if description else {}
    with warnings.catch_warnings():
        # No CRS is deliberate in raw sensor geometry (the description says so).
        warnings.filterwarnings("ignore", "'crs' was not provided", UserWarning)
        write(
            path,
            wkb,
            [_column(v) for v in cols.values()],
            list(cols),
            layer=layer,
            driver=fmt,
            geometry_type=gtype,
            crs=None if crs is None else crs.to_wkt(),
            promote_to_multi=gtype == "MultiPolygon",
            layer_options=options,
        )
    if fmt == "GeoJSON" and crs is not None and crs.to_epsg() is None:
        _name_geojson_crs(path, crs)


def _name_geojson_crs(path: str, crs) -> None:
    """GDAL names a GeoJSON layer's CRS only by an EPSG code; any other CRS (a local
    engineering CRS of raw geometry with a GSD, a custom projection) is written as WKT in the
    older ``crs`` member that GDAL and QGIS read, rather than left for WGS 84 to be assumed."""
    with open(path, encoding="utf-8") as f:
        doc = json.load(f)
    if "crs" in doc:
        return
    doc["crs"] = {"type": "name", "properties": {"name": crs.to_wkt()}}
    with open(path, "w", encoding="utf-8") as f:
        json.dump(doc, f)


def count_features(path: str, layer: str) -> int:
    """Number of features in layer ``layer`` of a vector file written by :func:`write_vector`
    (for checks)."""
    from pyogrio.errors import DataLayerError, DataSourceError

    try:
        return _feature_count(path, layer)
    except (DataSourceError, DataLayerError) as exc:
        raise InputError(f"{path} is not a vector file with layer {layer}: {exc}") from None
