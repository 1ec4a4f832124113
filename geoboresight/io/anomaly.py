"""Files of the anomaly application: groups of flagged pixels as vector geometries in the
raster's coordinates, and ROC curves as a CSV table.

The kernels (:mod:`geoboresight.anomaly`) label pixels and compute curves on arrays; turning
pixels into map coordinates (through the raster's geotransform) and writing tables lives here.
"""

from __future__ import annotations

import csv
import os

import numpy as np
import shapely
from rasterio.transform import Affine

from .vector import trace_shapes
from .write import atomic_output


def label_polygons(labels: np.ndarray, transform=None, *, connectivity: int = 8) -> dict:
    """``{label: geometry}``: the pixel outline of every labelled group (labels > 0).

    ``transform`` maps pixels to map coordinates; None keeps pixel coordinates (x = column,
    y = line). A group whose pixels touch only at corners becomes one MultiPolygon.
    """
    labels = np.asarray(labels, dtype=np.int32)
    parts: dict[int, list] = {}
    for geom, value in trace_shapes(
        labels, mask=labels > 0, transform=transform, connectivity=connectivity
    ):
        parts.setdefault(int(value), []).append(geom)
    return {i: shapely.unary_union(p) for i, p in parts.items()}


def pixel_points(rows, cols, transform=None) -> list:
    """Shapely points at the centres of pixels (``rows``, ``cols``), in map coordinates through
    ``transform`` (None: pixel coordinates)."""
    tr = transform if transform is not None else Affine.identity()
    cx = np.asarray(cols, dtype=float) + 0.5
    cy = np.asarray(rows, dtype=float) + 0.5
    if cx.size == 0:
        return []
    xs = tr.a * cx + tr.b * cy + tr.c
    ys = tr.d * cx + tr.e * cy + tr.f
    return list(shapely.points(np.asarray(xs, float), np.asarray(ys, float)))


def write_roc_csv(path: str | os.PathLike, curves: dict, max_points: int = 2000) -> str:
    """ROC curves (:class:`geoboresight.anomaly.roc.ROC` by detector name) as a long-format
    CSV ``detector, pfa, pd, threshold``, thinned to about ``max_points`` per detector;
    written atomically."""
    with atomic_output(path) as tmp, open(tmp, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["detector", "pfa", "pd", "threshold"])
        for name, c in curves.items():
            for i in c.thinned(max_points):
                w.writerow([name, f"{c.pfa[i]:.8g}", f"{c.pd[i]:.8g}", f"{c.thresholds[i]:.8g}"])
    return os.fspath(path)
