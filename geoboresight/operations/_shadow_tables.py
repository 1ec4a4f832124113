"""Files of the shadow application: the class table (CSV or JSON), the shadow-fraction model
(the JSON report of ``shadow-fraction-fit``), and class patches as polygons in the raster's
coordinates.

The kernels (:mod:`geoboresight.shadow`) validate the rows and say which pixels make a polygon
and what it holds; reading and writing files and tracing outlines through the raster's
geotransform live here.
"""

from __future__ import annotations

import csv
import io
import json
import os

import numpy as np
from rasterio.transform import Affine

from ..errors import InputError
from ..io.vector import trace_shapes
from ..io.write import write_text
from ..shadow.classes import (
    COLUMNS,
    ClassTable,
    class_from_row,
    default_table,
    format_ratio,
    validate_classes,
)
from ..shadow.polygons import (
    CONNECTIVITY,
    MIN_PIXELS,
    ShadowPolygon,
    shadow_pixels,
    shadow_polygons,
)

#: Raw sensor geometry as polygons: x = column, y = −line (so a layer is not upside down).
RAW_TRANSFORM = Affine(1, 0, 0, 0, -1, 0)


def read_class_table(path: str | os.PathLike) -> ClassTable:
    """Read and validate a class table from CSV (header row) or JSON (list of objects, or an
    object with a ``classes`` list).

    Raises :class:`InputError` for a missing or unreadable file and
    :class:`~geoboresight.errors.ParameterError` naming the bad row for a bad table.
    """
    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"class table {path} does not exist: check the path")
    with open(path, encoding="utf-8-sig") as f:
        text = f.read()
    source = f"class table {path}"
    if path.lower().endswith(".json") or text.lstrip().startswith(("[", "{")):
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise InputError(f"{source} is not valid JSON ({exc})") from None
        if isinstance(data, dict):
            data = data.get("classes", [])
        rows = list(data)
        classes = [class_from_row(r, f"{source}, entry {i + 1}") for i, r in enumerate(rows)]
    else:
        reader = csv.DictReader(io.StringIO(text))
        fields = [f.strip().lower() for f in (reader.fieldnames or [])]
        if "min" not in fields or "max" not in fields or "class" not in fields:
            raise InputError(
                f"{source}: the first line must name the columns {','.join(COLUMNS)} "
                f"(found {','.join(fields) or 'nothing'})"
            )
        classes = []
        for i, raw in enumerate(reader, start=2):
            row = {(k or "").strip().lower(): (v or "").strip() for k, v in raw.items()}
            if not any(row.values()):
                continue
            classes.append(class_from_row(row, f"{source}, line {i}"))
    return validate_classes(classes, source)


def class_table(path=None) -> ClassTable:
    """The class table in ``path`` (CSV or JSON), or Table 2 when None."""
    return read_class_table(path) if path else default_table()


def class_table_csv(table: ClassTable) -> str:
    """The class table as CSV text (the format :func:`read_class_table` reads)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for c in table.classes:
        w.writerow(
            [
                c.id,
                format_ratio(c.min),
                format_ratio(c.max),
                format_ratio(c.fraction_min),
                format_ratio(c.fraction_max),
                c.name,
                c.hex,
            ]
        )
    return buf.getvalue()


def write_class_table(path: str | os.PathLike, table: ClassTable) -> str:
    """Write the class table as CSV, atomically."""
    return write_text(path, class_table_csv(table))


def read_fraction_model(path: str | os.PathLike) -> tuple[float, float]:
    """(slope, intercept) from the JSON report of ``shadow-fraction-fit``."""
    path = os.fspath(path)
    try:
        with open(path, encoding="utf-8") as fh:
            data = json.load(fh)
        return float(data["slope"]), float(data["intercept"])
    except FileNotFoundError:
        raise InputError(f"model {path} does not exist: check the path") from None
    except (ValueError, KeyError, TypeError):
        raise InputError(
            f"model {path} is not a report of 'shadow-fraction-fit' (JSON with 'slope' and "
            "'intercept')"
        ) from None


def class_shapes(
    classes: np.ndarray, transform=None, *, mask: np.ndarray | None = None
) -> tuple[list[tuple[object, int]], float]:
    """(shapely polygon, class) of every 4-connected patch of one class inside ``mask``, and
    the area of one pixel in the polygons' units.

    ``transform`` maps pixels to map coordinates; None (or the identity) keeps raw pixel
    geometry (x = column, y = −line), where a pixel's area is 1.
    """
    classes = np.asarray(classes, dtype=np.uint8)
    raw = transform is None or transform == Affine.identity()
    tr = RAW_TRANSFORM if raw else transform
    traced = trace_shapes(classes, mask=mask, transform=tr, connectivity=CONNECTIVITY)
    return [(g, int(v)) for g, v in traced], abs(tr.a * tr.e - tr.b * tr.d)


def class_polygons(
    classes: np.ndarray, table: ClassTable, transform=None, *, min_pixels: int = MIN_PIXELS
) -> list[ShadowPolygon]:
    """Polygons of the shadow classes of a class raster (not 0 = no shadow, not 255 = nodata)
    with their attributes (:func:`geoboresight.shadow.polygons.shadow_polygons`)."""
    found, pixel_area = class_shapes(classes, transform, mask=shadow_pixels(classes))
    return shadow_polygons(found, table, pixel_area=pixel_area, min_pixels=min_pixels)
