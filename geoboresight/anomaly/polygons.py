"""Anomaly score map → vector layer: one feature per connected group of flagged pixels.

Pixels with a score at or above the threshold are grouped 8-connected; each group becomes a
polygon (its pixel outline) or a point (centre of its highest-scoring pixel), with attributes
``n_pixels``, ``score_max``, ``score_mean``, ``row``, ``col`` (of the peak, 0-based). Coordinates
are in the raster's CRS through its geotransform; in raw sensor geometry (no CRS) they are pixel
coordinates (column, row), and the layer has an undefined Cartesian CRS.

Written by :func:`geoboresight.io.vector.write_vector` (GeoPackage through sqlite3, no OGR).
"""

from __future__ import annotations

import numpy as np
import shapely
from rasterio import features
from rasterio.transform import Affine
from scipy import ndimage

from ..errors import ParameterError
from ..io.vector import count_features, write_vector


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
    """Write anomaly features to a new GeoPackage at ``path`` (see :mod:`geoboresight.io.vector`)."""
    fields = {k: table[k] for k in ("n_pixels", "score_max", "score_mean", "row", "col")}
    write_vector(
        path, geoms, fields, crs=crs, layer=layer, description="anomalies (score ≥ threshold)"
    )


def read_gpkg_count(path: str, layer: str = "anomalies") -> int:
    """Number of features in a layer written by :func:`write_gpkg` (for checks)."""
    return count_features(path, layer)
