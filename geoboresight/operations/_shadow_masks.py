"""Shadow and detection masks as files: the binary mask GeoTIFF every shadow operation writes
(1 shadow, 0 not, 255 nodata, styled) and a reader that keeps each band's own validity mask."""

from __future__ import annotations

from ..io.grid import Grid
from ..io.raster import create_class_raster
from ..io.windows import band_reader
from ..shadow import classes


def mask_raster(path, grid: Grid, tags: dict, band_name: str):
    """A binary shadow mask GeoTIFF (1 shadow, 0 not, 255 nodata), styled, written by strips."""
    return create_class_raster(
        path,
        grid,
        tags=tags,
        band_name=band_name,
        colormap=classes.MASK_COLORMAP,
        category_names=classes.MASK_CATEGORIES,
    )


def masked_reader(sources):
    """``read(row0, row1) -> (values, valid, values, valid, ...)``: each (dataset, band) of
    ``sources`` with its own validity mask (unlike :func:`~geoboresight.io.bands_reader`,
    which ands them)."""
    readers = [band_reader(src, band) for src, band in sources]

    def read(row0: int, row1: int):
        return tuple(a for r in readers for a in r(row0, row1))

    return read
