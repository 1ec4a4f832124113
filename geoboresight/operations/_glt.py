"""A line's geolocation for an operation on its raw image: its GLT read and checked against
the product it places (a GLT of another product, whose cells beyond this one would be dropped
in silence, is refused), and each raw pixel's map coordinates from the GLT or the IGM."""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ParameterError
from ..georef.geoloc import glt_coordinates, glt_indices
from ..io.georef import GLT, Coordinates, coordinates_for, read_glt

#: Positive values GLT writers fill empty cells with (a negative index beyond the product is
#: a fill too: ENVI's negative indices, infill from a neighbour, lie within it).
GLT_FILL_VALUES = (9999, 32767, 65535, 99999, 2147483647)


def glt_for(path, product: str, *, width: int, height: int, crs=None) -> GLT:
    """:func:`read_glt`, refused when any of its cells points outside ``product`` (a label,
    e.g. "input x.tif", of ``width`` × ``height`` pixels): the GLT of another product, whose
    cells beyond this one would be dropped in silence and the rest misplaced."""
    glt = read_glt(path, crs=crs)
    outside = glt_indices(glt.sample, glt.line, glt.valid, width=width, height=height)[3]
    if outside:
        s, r = np.abs(glt.sample), np.abs(glt.line)
        beyond = glt.valid & (s > 0) & (r > 0) & ((s > width) | (r > height))
        fills = np.unique(np.concatenate([glt.sample[beyond], glt.line[beyond]]))
        fills = fills[(np.abs(fills) > width) & (np.abs(fills) > height)]
        fills = fills[(fills < 0) | np.isin(fills, GLT_FILL_VALUES)]
        if fills.size == 1 and np.all(
            (glt.sample[beyond] == fills[0]) | (glt.line[beyond] == fills[0])
        ):
            v = int(fills[0])
            raise InputError(
                f"GLT {path}: {outside} cell(s) hold {v}, beyond {product} ({width} × "
                f"{height}, columns × lines): if {v} marks cells that show no pixel, declare "
                f"it the GLT's nodata value (e.g. gdal_edit.py -a_nodata {v}); else the GLT "
                "belongs to another product"
            )
        raise InputError(
            f"GLT {path}: {outside} cell(s) point outside {product} ({width} × {height}, "
            "columns × lines): the GLT belongs to another product"
        )
    return glt


def line_coordinates(dual, *, igm=None, glt=None, crs=None) -> tuple[Coordinates, str]:
    """Each raw pixel's map coordinates of the image ``dual`` from the line's IGM or its GLT
    (checked by :func:`glt_for`; ``crs`` their CRS when the file carries none), and what names
    them in messages ("IGM igm.tif", "GLT glt.tif")."""
    if igm and glt:
        raise ParameterError(
            "parameters 'igm' and 'glt': give the line's geolocation once, its IGM or its GLT"
        )
    if glt:
        table = glt_for(
            glt,
            f"image {dual.vnir.path}",
            width=dual.width,
            height=dual.height,
            crs=crs,
        )
        x, y = glt_coordinates(
            table.sample,
            table.line,
            table.valid,
            table.grid.transform,
            width=dual.width,
            height=dual.height,
        )
        if not np.isfinite(x).any():
            raise InputError(
                f"GLT {glt} shows fewer than 3 pixels of the {dual.height} × "
                f"{dual.width} image: give the GLT of this flight line"
            )
        coords = Coordinates(x, y, table.grid.crs, glt, f"GLT {glt}")
        return coords, f"GLT {glt}"
    coords = coordinates_for(dual.vnir.path, igm=igm, crs=crs)
    if coords.x.shape != (dual.height, dual.width):
        raise InputError(
            f"IGM {igm} has {coords.x.shape[0]} × {coords.x.shape[1]} pixels but the "
            f"image {dual.height} × {dual.width}: give the IGM of this flight line"
        )
    return coords, f"IGM {igm}"
