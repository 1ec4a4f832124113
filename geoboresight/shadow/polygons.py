"""Shadow polygons from a class raster (paper §3.1, Figures 6–7 as vectors).

Connected pixels of one class become one polygon (``rasterio.features.shapes``, 4-connected),
with the class id, its name, the shadow-fraction interval and the area. Coordinates are the
raster's: map units in its CRS when it is georeferenced; in raw sensor geometry (no CRS, no
geotransform) they are pixel coordinates (x = column, y = −line), and the area is in pixels —
the layer's description says so.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from rasterio.transform import Affine

from .classes import NO_SHADOW, NODATA_CLASS, ClassTable


@dataclass(frozen=True)
class ShadowPolygon:
    geometry: object  # shapely Polygon
    class_id: int
    name: str
    fraction_min: float
    fraction_max: float
    area: float
    pixels: int


def shadow_polygons(
    classes: np.ndarray,
    table: ClassTable,
    transform: Affine | None = None,
    *,
    min_pixels: int = 1,
) -> list[ShadowPolygon]:
    """Polygons of the shadow classes (not 0 = no shadow, not 255 = nodata).

    ``transform`` maps pixels to map coordinates; None keeps raw pixel geometry (x = column,
    y = −line, so that the layer is not upside down). Polygons smaller than ``min_pixels``
    pixels are dropped.
    """
    from rasterio.features import shapes
    from shapely.geometry import shape

    classes = np.asarray(classes, dtype=np.uint8)
    raw = transform is None or transform == Affine.identity()
    tr = Affine(1, 0, 0, 0, -1, 0) if raw else transform
    pixel_area = abs(tr.a * tr.e - tr.b * tr.d)
    by_id = {c.id: c for c in table.classes}
    keep = (classes != NO_SHADOW) & (classes != NODATA_CLASS)
    out: list[ShadowPolygon] = []
    for geom, value in shapes(classes, mask=keep, connectivity=4, transform=tr):
        cid = int(value)
        c = by_id.get(cid)
        poly = shape(geom)
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
