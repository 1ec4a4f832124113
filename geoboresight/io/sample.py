"""A map raster read at the raw pixels of a flight line: a surface model on the image's grid.

``shadow-map --dsm`` casts shadows on the image's own grid. A DSM is usually on a map grid; with
the line's IGM (each raw pixel's map coordinates) it is read at every raw pixel, bilinearly,
as GDAL's ``gdallocationinfo -r bilinear`` or GRASS's ``r.what -i`` would read it, and the
raw grid's local geometry (metres per column and per line, rotation) is the affine fit of the
IGM, in which the sun's azimuth from north is then read.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..errors import InputError
from .georef import Coordinates, crs_units, output_crs, transform_xy, utm_crs

#: Raw lines read (and written) at a time.
BLOCK_LINES = 256
#: Pixels of the affine fit (an evenly spaced sample of the line's valid pixels).
FIT_PIXELS = 20_000


def sample_bilinear(src, x: np.ndarray, y: np.ndarray, band: int = 1) -> np.ndarray:
    """Band ``band`` of dataset ``src`` at map coordinates (``x``, ``y``) in its CRS,
    bilinear between cell centres (float64; NaN off the raster or next to its nodata).

    Only the window the coordinates cover is read.
    """
    x = np.asarray(x, np.float64)
    y = np.asarray(y, np.float64)
    out = np.full(x.shape, np.nan)
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        return out
    inv = ~src.transform
    col = inv.a * x[ok] + inv.b * y[ok] + inv.c - 0.5  # cell centres at integers
    row = inv.d * x[ok] + inv.e * y[ok] + inv.f - 0.5
    c0 = max(0, int(np.floor(col.min())) - 1)
    r0 = max(0, int(np.floor(row.min())) - 1)
    c1 = min(src.width, int(np.ceil(col.max())) + 2)
    r1 = min(src.height, int(np.ceil(row.max())) + 2)
    if c1 <= c0 or r1 <= r0:
        return out
    from rasterio.windows import Window

    block = src.read(band, window=Window(c0, r0, c1 - c0, r1 - r0), masked=True)
    z = block.astype(np.float64).filled(np.nan)
    # NaN (nodata) spreads to every sample that touches it: no height is made up.
    out[ok] = ndimage.map_coordinates(
        z, [row - r0, col - c0], order=1, mode="constant", cval=np.nan, prefilter=False
    )
    return out


def raw_grid_matrix(coords: Coordinates) -> tuple[np.ndarray, object, float]:
    """The raw grid's local geometry from its IGM: the 2 × 2 matrix taking (Δcolumn, Δline)
    to (Δeast, Δnorth) in metres (:func:`geoboresight.shadow.illumination.grid_matrix`'s
    form), fitted by least squares to the pixels' coordinates in a metric CRS (the IGM's
    when projected, else the UTM zone of the line), that CRS, and the fit's RMS residual
    in metres (how far the line departs from an affine grid: roll and yaw wobble).
    """
    crs = output_crs(None, coords.crs, coords.x, coords.y)
    if crs_units(crs) != "metres":  # heights are in metres: so must the steps be
        crs = utm_crs(coords.x, coords.y, coords.crs)
    ok = np.isfinite(coords.x) & np.isfinite(coords.y)
    rows, cols = np.nonzero(ok)
    if rows.size < 3:
        raise InputError(f"IGM {coords.path} has fewer than 3 valid pixels")
    step = max(1, rows.size // FIT_PIXELS)
    rows, cols = rows[::step], cols[::step]
    x, y = coords.x[rows, cols], coords.y[rows, cols]
    if crs != coords.crs:
        x, y = transform_xy(x, y, coords.crs, crs)
    design = np.column_stack([cols, rows, np.ones(rows.size)]).astype(np.float64)
    xy = np.column_stack([x, y])
    coef, _, rank, _ = np.linalg.lstsq(design, xy, rcond=None)  # (3, 2): a, b, c per axis
    m = coef[:2].T  # [[∂x/∂col, ∂x/∂row], [∂y/∂col, ∂y/∂row]]
    if rank < 3 or abs(np.linalg.det(m)) == 0:
        raise InputError(
            f"IGM {coords.path}: its pixels do not span an area (all on one line or point)"
        )
    rms = float(np.sqrt(np.mean(np.sum((xy - design @ coef) ** 2, axis=1))))
    return m, crs, rms


def surface_on_raw_grid(src, coords: Coordinates, dst, progress=None) -> int:
    """Write ``src``'s band 1 (a DSM on a map grid) read at every raw pixel of ``coords``
    into band 1 of the open dataset ``dst`` (the raw grid, float32, NaN nodata), block by
    block; returns the number of raw pixels the DSM covers."""
    if src.crs is None:
        raise InputError(
            f"surface model {src.name} has no CRS: a DSM read through the line's IGM needs its "
            "map CRS (assign it with gdal_edit.py -a_srs, or in QGIS: Assign projection)"
        )
    from rasterio.windows import Window

    height, width = coords.x.shape
    covered = 0
    for r0 in range(0, height, BLOCK_LINES):
        r1 = min(height, r0 + BLOCK_LINES)
        x, y = coords.x[r0:r1], coords.y[r0:r1]
        if src.crs != coords.crs:
            ok = np.isfinite(x) & np.isfinite(y)
            tx, ty = np.full(x.shape, np.nan), np.full(y.shape, np.nan)
            tx[ok], ty[ok] = transform_xy(x[ok], y[ok], coords.crs, src.crs)
            x, y = tx, ty
        z = sample_bilinear(src, x, y)
        covered += int(np.isfinite(z).sum())
        dst.write(z.astype(np.float32), 1, window=Window(0, r0, width, r1 - r0))
        if progress is not None:
            progress.update(r1 / height, "surface model onto the image's grid")
    return covered
