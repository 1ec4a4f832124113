"""Vector layers (shadow and anomaly polygons or points) written without a GDAL binding.

GeoPackage is written with the standard library's sqlite3 (OGC 12-128r18: the required
metadata tables and "GP" geometry blobs holding little-endian WKB); GeoJSON with ``json``.
Avoiding OGR here is deliberate: inside ``qgis_process`` a second GDAL (a wheel's) writing
vectors next to QGIS's own crashed the process (docs/qgis.md). In raw sensor geometry there is
no CRS: the GeoPackage layer gets GeoPackage's "undefined Cartesian" SRS (-1), the GeoJSON no
``crs`` member, and the layer description says so.
"""

from __future__ import annotations

import json
import os
import sqlite3
import struct
from collections.abc import Mapping, Sequence

import numpy as np
import shapely
import shapely.geometry

from ..errors import InputError, ParameterError
from .write import atomic_output

_WGS84_WKT = (
    'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],'
    'PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]]'
)
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
    with atomic_output(path, overwrite=overwrite) as tmp:
        if fmt == "GPKG":
            _write_gpkg(tmp, list(geoms), cols, crs, layer, description)
        else:
            _write_geojson(tmp, list(geoms), cols, crs, layer, description)
    return path


def _sql_type(v: np.ndarray) -> str:
    if v.dtype.kind in "iub":
        return "INTEGER"
    if v.dtype.kind == "f":
        return "DOUBLE"
    return "TEXT"


def _py(x):
    if isinstance(x, np.integer | np.bool_):
        return int(x)
    if isinstance(x, np.floating):
        return None if not np.isfinite(x) else float(x)
    return x if x is None or isinstance(x, int | float) else str(x)


def _geometry_type(geoms) -> str:
    kinds = {g.geom_type for g in geoms}
    if kinds <= {"Point"} and kinds:
        return "POINT"
    if kinds <= {"Polygon", "MultiPolygon"}:
        return "MULTIPOLYGON"
    return "GEOMETRY"


def _srs(crs) -> tuple[int, tuple | None]:
    if crs is None:
        return -1, None
    epsg = crs.to_epsg()
    if epsg in (4326,):
        return 4326, None
    srs_id = epsg if epsg else 100000
    org, org_id = ("EPSG", epsg) if epsg else ("NONE", srs_id)
    return srs_id, (crs.to_string(), srs_id, org, org_id, crs.to_wkt(), None)


def _write_gpkg(path, geoms, cols, crs, layer, description) -> None:
    srs_id, extra = _srs(crs)
    gtype = _geometry_type(geoms)
    con = sqlite3.connect(path)
    try:
        cur = con.cursor()
        cur.execute("PRAGMA application_id = 1196444487")  # 'GPKG'
        cur.execute("PRAGMA user_version = 10200")
        cur.execute(
            "CREATE TABLE gpkg_spatial_ref_sys (srs_name TEXT NOT NULL, srs_id INTEGER PRIMARY KEY,"
            " organization TEXT NOT NULL, organization_coordsys_id INTEGER NOT NULL,"
            " definition TEXT NOT NULL, description TEXT)"
        )
        rows = [
            ("Undefined cartesian SRS", -1, "NONE", -1, "undefined", "raw sensor geometry"),
            ("Undefined geographic SRS", 0, "NONE", 0, "undefined", None),
            ("WGS 84 geodetic", 4326, "EPSG", 4326, _WGS84_WKT, None),
        ]
        if extra is not None:
            rows.append(extra)
        cur.executemany("INSERT INTO gpkg_spatial_ref_sys VALUES (?,?,?,?,?,?)", rows)
        cur.execute(
            "CREATE TABLE gpkg_contents (table_name TEXT NOT NULL PRIMARY KEY, data_type TEXT NOT NULL,"
            " identifier TEXT UNIQUE, description TEXT DEFAULT '', last_change DATETIME NOT NULL"
            " DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ','now')), min_x DOUBLE, min_y DOUBLE,"
            " max_x DOUBLE, max_y DOUBLE, srs_id INTEGER)"
        )
        cur.execute(
            "CREATE TABLE gpkg_geometry_columns (table_name TEXT NOT NULL, column_name TEXT NOT NULL,"
            " geometry_type_name TEXT NOT NULL, srs_id INTEGER NOT NULL, z TINYINT NOT NULL,"
            " m TINYINT NOT NULL, CONSTRAINT pk_geom_cols PRIMARY KEY (table_name, column_name))"
        )
        defs = "".join(f', "{k}" {_sql_type(v)}' for k, v in cols.items())
        cur.execute(
            f'CREATE TABLE "{layer}" (fid INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL, geom {gtype}{defs})'
        )
        bounds = shapely.total_bounds(geoms) if geoms else [None] * 4
        cur.execute(
            "INSERT INTO gpkg_contents (table_name, data_type, identifier, description,"
            " min_x, min_y, max_x, max_y, srs_id) VALUES (?, 'features', ?, ?, ?, ?, ?, ?, ?)",
            (layer, layer, description, *[None if b is None else float(b) for b in bounds], srs_id),
        )
        cur.execute(
            "INSERT INTO gpkg_geometry_columns VALUES (?, 'geom', ?, ?, 0, 0)",
            (layer, gtype, srs_id),
        )
        names = list(cols)
        recs = []
        for i, g in enumerate(geoms):
            if gtype == "MULTIPOLYGON" and g.geom_type == "Polygon":
                g = shapely.MultiPolygon([g])
            recs.append((_gpkg_blob(g, srs_id), *[_py(cols[k][i]) for k in names]))
        marks = ",".join("?" * (len(names) + 1))
        quoted = "".join(f', "{k}"' for k in names)
        cur.executemany(f'INSERT INTO "{layer}" (geom{quoted}) VALUES ({marks})', recs)
        con.commit()
    finally:
        con.close()


def _gpkg_blob(geom, srs_id: int) -> bytes:
    minx, miny, maxx, maxy = geom.bounds
    # magic "GP", version 0, flags: little endian (bit 0) + envelope [minx, maxx, miny, maxy]
    header = b"GP" + struct.pack("<BBi4d", 0, 0b00000011, srs_id, minx, maxx, miny, maxy)
    # output_dimension=2: inside QGIS the shapely wheel may run on an older system GEOS (3.11)
    # that rejects the wheel's default of 4 ("WKB output dimension must be 2 or 3").
    return header + shapely.to_wkb(geom, byte_order=1, output_dimension=2)


def _write_geojson(path, geoms, cols, crs, layer, description) -> None:
    names = list(cols)
    feats = [
        {
            "type": "Feature",
            "id": i + 1,
            "properties": {k: _py(cols[k][i]) for k in names},
            "geometry": json.loads(shapely.to_geojson(g)),
        }
        for i, g in enumerate(geoms)
    ]
    doc = {
        "type": "FeatureCollection",
        "name": layer,
        "description": description,
        "features": feats,
    }
    if crs is not None and crs.to_epsg() != 4326:
        # RFC 7946 assumes WGS 84; GDAL and QGIS honour the older "crs" member for others.
        epsg = crs.to_epsg()
        name = f"urn:ogc:def:crs:EPSG::{epsg}" if epsg else crs.to_wkt()
        doc["crs"] = {"type": "name", "properties": {"name": name}}
    with open(path, "w", encoding="utf-8") as f:
        json.dump(doc, f)


def count_features(path: str, layer: str) -> int:
    """Number of features in a GeoPackage layer written by :func:`write_vector` (for checks)."""
    con = sqlite3.connect(path)
    try:
        return int(con.execute(f'SELECT count(*) FROM "{layer}"').fetchone()[0])
    except sqlite3.Error as exc:
        raise InputError(f"{path} is not a GeoPackage with layer {layer}: {exc}") from None
    finally:
        con.close()
