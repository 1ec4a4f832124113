"""A line's GLT read and checked against the product it places (a GLT of another product,
whose cells beyond this one would be dropped in silence, is refused)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..georef.geoloc import glt_indices
from ..io.georef import GLT, read_glt

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
