"""Refusals of the values read from an input file that no face can check before reading it:
a raster without a valid pixel, a surface model whose heights are not heights on Earth or
whose cell size contradicts its geotransform, a shadow fraction that is not 0–1. Each names
the file."""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ParameterError


def no_valid_error(path: str, what: str = "ratio raster") -> InputError:
    """The error of an input whose every pixel is nodata."""
    return InputError(
        f"{what} {path} has no valid pixel (every pixel is nodata or not finite): check the "
        "file and its nodata value"
    )


#: Heights (m) beyond any surface a surface model shows (dry land reaches −430 m at the Dead
#: Sea and 8,849 m at Everest): a fill value not declared as nodata (−9999, −32768, 3.4e38),
#: or heights not in metres.
LOWEST_HEIGHT_M, HIGHEST_HEIGHT_M = -1_000.0, 9_000.0


def check_heights(lo: float, hi: float, path: str, what: str = "surface model") -> None:
    """Refuse a surface model whose lowest or highest valid height (m) is not a height on
    Earth: an undeclared fill value (−9999 in the holes of a DSM whose nodata is unset) would
    be taken for a pit 10 km deep, and the shadows cast into it and the relief (how far every
    shadow is searched) would silently be wrong."""
    for value, bad in ((lo, lo < LOWEST_HEIGHT_M), (hi, hi > HIGHEST_HEIGHT_M)):
        if bad:
            raise InputError(
                f"{what} {path} holds a height of {value:g} m, beyond the Earth's surface (−430 to 8,849 m): "
                f"if {value:g} marks missing cells, declare it the file's nodata value (e.g. "
                f"gdal_edit.py -a_nodata {value:g}); else give heights in metres"
            )


def check_cell_size(cell_size, matrix, what: str) -> None:
    """Refuse a ``cell_size`` (m) the user gave for a grid whose geotransform already gives its
    cells (``matrix``: :func:`geoboresight.shadow.illumination.grid_matrix`, metres) and says
    otherwise: one of the two is wrong, and using either silently would scale every shadow."""
    if not cell_size:
        return
    sides = np.hypot(*np.asarray(matrix, float).reshape(2, 2))  # column and row steps (m)
    if np.all(np.abs(sides - float(cell_size)) <= 0.01 * sides):
        return
    raise ParameterError(
        f"parameter 'cell_size': {float(cell_size):g} m, but {what} has cells of "
        f"{sides[0]:.4g} × {sides[1]:.4g} m from its geotransform: leave 'cell_size' empty (it "
        "is for a surface model without a geotransform), or fix the geotransform"
    )


#: How far an estimated shadow fraction may stray outside 0–1 (an unmixed or fitted fraction's
#: noise) before the file is taken for something else: a percentage, classes, a ratio.
FRACTION_SLACK = 0.05


def check_fraction_nodata(src, path: str, what: str = "shadow fraction") -> None:
    """Refuse a shadow-fraction raster whose declared nodata is a fraction (0–1): with nodata
    0, every sunlit pixel would be read as missing (no shadow edge next to sunlit ground is
    left, or the sunlit ground is written as nodata)."""
    nd = src.nodata
    if nd is not None and np.isfinite(nd) and 0.0 <= nd <= 1.0:
        raise InputError(
            f"{what} {path} declares {nd:g} as its nodata value, but {nd:g} is a shadow fraction "
            "(0 sunlit, 1 full shadow): its pixels would be read as missing; remove the nodata "
            "value or set one outside 0–1 (e.g. gdal_edit.py -unsetnodata, or -a_nodata -9999)"
        )


def check_fraction(f: np.ndarray, ok: np.ndarray, path: str, what: str = "shadow fraction"):
    """Refuse a shadow-fraction strip with values outside 0–1 (beyond :data:`FRACTION_SLACK`):
    a percentage or a class raster given as a fraction would otherwise be clipped to 0–1 and
    silently give a wrong result."""
    v = np.asarray(f)[np.asarray(ok, bool)]
    if not v.size:
        return
    lo, hi = float(v.min()), float(v.max())
    if lo >= -FRACTION_SLACK and hi <= 1.0 + FRACTION_SLACK:
        return
    if lo >= -FRACTION_SLACK and hi <= 100.0 + FRACTION_SLACK:
        hint = "a percentage? divide it by 100 (e.g. gdal_calc.py, or QGIS's Raster calculator)"
    elif lo >= 0 and hi <= 255 and float(hi).is_integer():
        hint = (
            "bytes scaled 0–255? divide it by 255 (e.g. gdal_calc.py, or QGIS's Raster calculator)"
        )
    else:
        hint = "give a fraction: shadow-map's 'fraction' or sun-shadow's output"
    raise InputError(
        f"{what} {path} holds values from {lo:g} to {hi:g}, but a shadow fraction is 0–1 "
        f"(nodata aside): {hint}"
    )
