"""A DEM for direct georeferencing: its heights (ellipsoidal), read in the window a line
needs, with its CRS checked (metres, present) and a geoid-referenced DEM converted to
ellipsoidal heights through pyproj's vertical CRS."""

from __future__ import annotations

import os

import numpy as np

from ..errors import InputError
from ..sensor.georeference import Surface


def _check_crs(crs, path):
    from pyproj import CRS

    if crs is None:
        raise InputError(
            f"DEM {path} carries no CRS: give it one (gdal_edit.py -a_srs EPSG:…); heights "
            "cannot be placed without it"
        )
    pc = CRS.from_user_input(crs.to_wkt() if hasattr(crs, "to_wkt") else crs)
    units = {a.unit_name.lower() for a in pc.axis_info}
    if any("foot" in u or "feet" in u for u in units):
        raise InputError(
            f"DEM {path} is in feet ({', '.join(sorted(units))}): reproject it to a CRS in "
            "metres (gdalwarp -t_srs EPSG:… -s_srs … with the vertical unit in metres)"
        )
    return pc


def dem_overview(path, *, rows: int = 512):
    """(low, high, bounds, crs) of the DEM at ``path``: its lowest and highest heights (read
    ``rows`` rows at a time), padded by one fiftieth of the range and a metre, and its
    bounds."""
    from rasterio.windows import Window

    from .image import open_raster

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise InputError(f"DEM {path} does not exist: check the path")
    lo, hi = np.inf, -np.inf
    with open_raster(path, "DEM") as src:
        crs = _check_crs(src.crs, path)
        for r0 in range(0, src.height, rows):
            win = Window(0, r0, src.width, min(rows, src.height - r0))
            z = src.read(1, window=win, masked=True)
            if z.count():
                lo, hi = min(lo, float(z.min())), max(hi, float(z.max()))
        bounds = tuple(src.bounds)
    if not np.isfinite(lo):
        raise InputError(f"DEM {path} holds no height (every cell is no data)")
    pad = 0.02 * (hi - lo) + 1.0
    return lo - pad, hi + pad, bounds, crs


def read_surface(path, *, bounds=None, vertical_crs=None) -> Surface:
    """The DEM at ``path`` as a :class:`Surface` (float64, no data as NaN), only the window
    covering ``bounds`` (left, bottom, right, top in its CRS) plus two cells; heights above
    the geoid of ``vertical_crs`` (e.g. ``EPSG:5773``, EGM96) converted to ellipsoidal."""
    from rasterio.windows import Window, from_bounds

    from .image import open_raster

    path = os.fspath(path)
    with open_raster(path, "DEM") as src:
        crs = _check_crs(src.crs, path)
        if bounds is None:
            win = Window(0, 0, src.width, src.height)
        else:
            w = from_bounds(*bounds, transform=src.transform)
            c0, r0 = int(np.floor(w.col_off)) - 2, int(np.floor(w.row_off)) - 2
            c1 = int(np.ceil(w.col_off + w.width)) + 2
            r1 = int(np.ceil(w.row_off + w.height)) + 2
            c0, r0 = max(c0, 0), max(r0, 0)
            c1, r1 = min(c1, src.width), min(r1, src.height)
            if c1 <= c0 or r1 <= r0:
                raise InputError(f"DEM {path} does not reach the line's swath")
            win = Window(c0, r0, c1 - c0, r1 - r0)
        z = src.read(1, window=win, masked=True).astype(np.float64).filled(np.nan)
        transform = src.window_transform(win)
    if vertical_crs:
        z = _to_ellipsoid(z, transform, crs, vertical_crs, path)
    return Surface(z, tuple(transform)[:6], crs, source=f"DEM {path}")


def _to_ellipsoid(z, transform, crs, vertical_crs, path):
    """Heights above the geoid of ``vertical_crs`` to ellipsoidal heights, through pyproj
    (the geoid grid must be installed: PROJ's data or ``projsync``)."""
    from pyproj import CRS, Transformer
    from pyproj.crs import CompoundCRS

    try:
        vertical = CRS.from_user_input(vertical_crs)
    except Exception:
        raise InputError(
            f"DEM {path}: {vertical_crs!r} is not a vertical CRS pyproj knows"
        ) from None
    if not vertical.is_vertical:
        raise InputError(f"DEM {path}: {vertical_crs!r} is not a vertical CRS (e.g. EPSG:5773)")
    horizontal = crs.sub_crs_list[0] if crs.is_compound else crs
    compound = CompoundCRS(f"{horizontal.name} + {vertical.name}", [horizontal, vertical])
    to_3d = Transformer.from_crs(compound, horizontal.to_3d(), always_xy=True)
    rows, cols = np.indices(z.shape)
    a, b, c, d, e, f = tuple(transform)[:6]
    x = c + a * (cols + 0.5) + b * (rows + 0.5)
    y = f + d * (cols + 0.5) + e * (rows + 0.5)
    zero = np.zeros(1)
    _, _, probe = to_3d.transform(x.ravel()[:1], y.ravel()[:1], zero)
    if not np.isfinite(probe).all() or np.all(probe == 0):
        raise InputError(
            f"DEM {path}: pyproj has no geoid grid for {vertical.name} here (install it: "
            "projsync --file …, or PROJ_NETWORK=ON); heights above the geoid cannot be "
            "made ellipsoidal without it"
        )
    _, _, h = to_3d.transform(x.ravel(), y.ravel(), np.nan_to_num(z).ravel())
    out = np.reshape(h, z.shape)
    out[~np.isfinite(z)] = np.nan
    return out
