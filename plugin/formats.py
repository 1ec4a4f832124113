"""File types of the sensor products a raster input takes besides GDAL's rasters (Specim raw,
HySpex, EnMAP L1B, PRISMA L1): the file dialog's filter and the paths handed to the engine as
they are. Standard library only (tested without QGIS); the list itself comes from the engine's
operation list (a raster parameter's ``formats``: ``[label, "*.a *.b"]`` pairs).
"""

from __future__ import annotations

import fnmatch
import os

#: Qt's "all files" entry.
ALL_FILES = "All files (*)"


def _patterns(formats) -> list[str]:
    return [pat for _label, patterns in formats or () for pat in patterns.split()]


def product_filter(formats, gdal_filter: str = "") -> str:
    """The file dialog filter of a raster input: the products and GDAL's rasters together
    first, then each product, then GDAL's own entries (``gdal_filter``, QGIS's
    ``fileRasterFilters()``), then all files."""
    entries = [f"{label} ({patterns})" for label, patterns in formats or ()]
    gdal = [e for e in (gdal_filter or "").split(";;") if e.strip()]
    gdal_all = [e for e in gdal if e.lower().startswith("all ") and "(" in e]
    gdal = [e for e in gdal if e not in gdal_all and not e.startswith("All files")]
    together = _patterns(formats)
    for entry in gdal_all[:1]:  # GDAL's "All supported files (*.tif *.img ...)"
        together += [p for p in entry[entry.index("(") + 1 : entry.rindex(")")].split() if p]
    together = list(dict.fromkeys(together))
    head = [f"Sensor products and rasters ({' '.join(together)})"] if together else []
    return ";;".join([*head, *entries, *gdal, ALL_FILES])


def is_product_path(value, formats) -> bool:
    """True for a path the engine reads itself: an existing folder (an EnMAP product) or an
    existing file named like one of the products (QGIS cannot open most of them as a layer)."""
    if not isinstance(value, str) or not value or not formats:
        return False
    if os.path.isdir(value):
        return True
    if not os.path.isfile(value):
        return False
    name = os.path.basename(value).lower()
    return any(fnmatch.fnmatch(name, pat.lower()) for pat in _patterns(formats))


__all__ = ["ALL_FILES", "is_product_path", "product_filter"]
