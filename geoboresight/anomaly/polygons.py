"""Anomaly score map → vector layer: one feature per connected group of flagged pixels.

Pixels with a score at or above the threshold are grouped 8-connected; each group becomes a
polygon (its pixel outline) or a point (centre of its highest-scoring pixel), with attributes
``n_pixels``, ``score_max``, ``score_mean``, ``row``, ``col`` (of the peak, 0-based). Coordinates
are in the raster's CRS through its geotransform; in raw sensor geometry (no CRS) they are pixel
coordinates (column, row), and the layer has an undefined Cartesian CRS.

GeoPackage is written with the standard library's sqlite3 (OGC 12-128r18: the required metadata
tables, "GP" geometry blobs holding little-endian WKB), so no GDAL/OGR Python binding is needed.
"""

from __future__ import annotations

import sqlite3
import struct

import numpy as np
import shapely
from rasterio import features
from rasterio.transform import Affine
from scipy import ndimage

from ..errors import InputError, ParameterError


def label_anomalies(score: np.ndarray, threshold: float, min_pixels: int = 1):
    """(labels int32, table dict of arrays) for groups of pixels with score ≥ threshold."""
    s = np.asarray(score, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        hot = np.isfinite(s) & (s >= threshold)
    labels, n = ndimage.label(hot, structure=np.ones((3, 3), bool))
    if n == 0:
        return labels.astype(np.int32), {
            k: np.array([]) for k in ("id", "n_pixels", "score_max", "score_mean", "row", "col")
        }
    ids = np.arange(1, n + 1)
    filled = np.where(hot, s, 0.0)
    count = ndimage.sum_labels(hot, labels, ids).astype(int)
    smax = ndimage.maximum(filled, labels, ids)
    smean = ndimage.sum_labels(filled, labels, ids) / count
    peaks = np.array(ndimage.maximum_position(np.where(hot, s, -np.inf), labels, ids)).reshape(
        -1, 2
    )
    keep = count >= min_pixels
    if not keep.all():
        relabel = np.zeros(n + 1, np.int32)
        relabel[ids[keep]] = np.arange(1, keep.sum() + 1)
        labels = relabel[labels]
    table = {
        "id": np.arange(1, keep.sum() + 1),
        "n_pixels": count[keep],
        "score_max": smax[keep],
        "score_mean": smean[keep],
        "row": peaks[keep, 0],
        "col": peaks[keep, 1],
    }
    return labels.astype(np.int32), table


def anomaly_features(score, threshold, transform=None, geometry="polygon", min_pixels=1):
    """(shapely geometries, attribute table) for :func:`label_anomalies` groups."""
    if geometry not in ("polygon", "point"):
        raise ParameterError(f"parameter 'geometry' must be 'polygon' or 'point', got {geometry!r}")
    tr = transform if transform is not None else Affine.identity()
    labels, table = label_anomalies(score, threshold, min_pixels)
    n = table["id"].size
    if geometry == "point":
        cx, cy = table["col"] + 0.5, table["row"] + 0.5
        xs = tr.a * cx + tr.b * cy + tr.c
        ys = tr.d * cx + tr.e * cy + tr.f
        geoms = list(shapely.points(np.asarray(xs, float), np.asarray(ys, float))) if n else []
    else:
        parts: dict[int, list] = {}
        for geom, value in features.shapes(labels, mask=labels > 0, transform=tr, connectivity=8):
            parts.setdefault(int(value), []).append(shapely.geometry.shape(geom))
        geoms = [shapely.unary_union(parts[i]) for i in table["id"]]
    return geoms, table


def write_gpkg(path: str, geoms, table: dict, crs=None, layer: str = "anomalies") -> None:
    """Write features to a new GeoPackage at ``path`` (use through atomic_output)."""
    if crs is not None:
        epsg = crs.to_epsg()
        srs_id = epsg if epsg else 100000
        org, org_id, wkt = ("EPSG", epsg, crs.to_wkt()) if epsg else ("NONE", srs_id, crs.to_wkt())
    else:
        srs_id, org, org_id, wkt = -1, "NONE", -1, "undefined"
    gtype = "POINT" if geoms and geoms[0].geom_type == "Point" else "MULTIPOLYGON"
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
            (
                "WGS 84 geodetic",
                4326,
                "EPSG",
                4326,
                'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]]',
                None,
            ),
        ]
        if srs_id not in (-1, 0, 4326):
            rows.append((crs.to_string(), srs_id, org, org_id, wkt, None))
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
        cur.execute(
            f'CREATE TABLE "{layer}" (fid INTEGER PRIMARY KEY AUTOINCREMENT NOT NULL, geom {gtype},'
            " n_pixels INTEGER, score_max DOUBLE, score_mean DOUBLE, row INTEGER, col INTEGER)"
        )
        bounds = shapely.total_bounds(geoms) if geoms else [None] * 4
        cur.execute(
            "INSERT INTO gpkg_contents (table_name, data_type, identifier, min_x, min_y, max_x, max_y, srs_id)"
            " VALUES (?, 'features', ?, ?, ?, ?, ?, ?)",
            (layer, layer, *[None if b is None else float(b) for b in bounds], srs_id),
        )
        cur.execute(
            "INSERT INTO gpkg_geometry_columns VALUES (?, 'geom', ?, ?, 0, 0)",
            (layer, gtype, srs_id),
        )
        recs = []
        for i, g in enumerate(geoms):
            if gtype == "MULTIPOLYGON" and g.geom_type == "Polygon":
                g = shapely.MultiPolygon([g])
            recs.append(
                (
                    _gpkg_blob(g, srs_id),
                    int(table["n_pixels"][i]),
                    float(table["score_max"][i]),
                    float(table["score_mean"][i]),
                    int(table["row"][i]),
                    int(table["col"][i]),
                )
            )
        cur.executemany(
            f'INSERT INTO "{layer}" (geom, n_pixels, score_max, score_mean, row, col) VALUES (?,?,?,?,?,?)',
            recs,
        )
        con.commit()
    finally:
        con.close()


def _gpkg_blob(geom, srs_id: int) -> bytes:
    minx, miny, maxx, maxy = geom.bounds
    # magic "GP", version 0, flags: little endian (bit 0) + envelope [minx, maxx, miny, maxy] (1 << 1)
    header = b"GP" + struct.pack("<BBi4d", 0, 0b00000011, srs_id, minx, maxx, miny, maxy)
    # output_dimension=2: inside QGIS the shapely wheel may run on an older system GEOS (3.11)
    # that rejects the wheel's default of 4 ("WKB output dimension must be 2 or 3")
    return header + shapely.to_wkb(geom, byte_order=1, output_dimension=2)


def read_gpkg_count(path: str, layer: str = "anomalies") -> int:
    """Number of features in a layer written by :func:`write_gpkg` (for checks)."""
    con = sqlite3.connect(path)
    try:
        return int(con.execute(f'SELECT count(*) FROM "{layer}"').fetchone()[0])
    except sqlite3.Error as exc:
        raise InputError(f"{path} is not a GeoPackage with layer {layer}: {exc}") from None
    finally:
        con.close()
