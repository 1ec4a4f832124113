"""Shadow polygons from a class raster (paper §3.1, Figures 6–7 as vectors).

Connected pixels of one class become one polygon (4-connected), with the class id, its name,
the shadow-fraction interval, the area and the number of pixels. The outlines are traced in the
raster's coordinates by :func:`geoboresight.operations._shadow_tables.class_shapes`: map units in its CRS when
it is georeferenced; in raw sensor geometry (no CRS, no geotransform) pixel coordinates
(x = column, y = −line), and the area is in pixels — the layer's description says so. This
module decides which pixels are traced and what each polygon says.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from .classes import NO_SHADOW, NODATA_CLASS, ClassTable

#: Polygons smaller than this many pixels are dropped.
MIN_PIXELS = 1
#: Shadow patches are 4-connected (pixels touching only at a corner are separate polygons).
CONNECTIVITY = 4


@dataclass(frozen=True)
class ShadowPolygon:
    geometry: object  # shapely Polygon
    class_id: int
    name: str
    fraction_min: float
    fraction_max: float
    area: float
    pixels: int


def shadow_pixels(classes: np.ndarray) -> np.ndarray:
    """The pixels that belong to a shadow class (not 0 = no shadow, not 255 = nodata)."""
    classes = np.asarray(classes)
    return (classes != NO_SHADOW) & (classes != NODATA_CLASS)


def shadow_polygons(
    shapes: Iterable[tuple[object, int]],
    table: ClassTable,
    *,
    pixel_area: float = 1.0,
    min_pixels: int = MIN_PIXELS,
) -> list[ShadowPolygon]:
    """The polygons of the shadow classes, with their attributes, in a stable order.

    ``shapes`` are (shapely polygon, class id) pairs, the outlines of the 4-connected patches of
    :func:`shadow_pixels`; ``pixel_area`` is the area of one pixel in the polygons' units (1 in
    raw pixel geometry). Polygons smaller than ``min_pixels`` pixels are dropped; a class id
    missing from ``table`` keeps its id with a generic name and NaN fractions.
    """
    by_id = {c.id: c for c in table.classes}
    out: list[ShadowPolygon] = []
    for poly, value in shapes:
        cid = int(value)
        c = by_id.get(cid)
        pixels = int(round(poly.area / pixel_area))
        if pixels < min_pixels:
            continue
        out.append(
            ShadowPolygon(
                poly,
                cid,
                c.name if c else f"class {cid}",
                c.fraction_min if c else float("nan"),
                c.fraction_max if c else float("nan"),
                float(poly.area),
                pixels,
            )
        )
    # GDAL versions trace polygons in different orders (e.g. QGIS's GDAL vs a wheel's): sort so
    # the layer is the same whichever GDAL runs underneath.
    out.sort(key=lambda p: (p.class_id, -p.geometry.bounds[3], *p.geometry.bounds[:3], p.area))
    return out
