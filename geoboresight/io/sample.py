"""A surface model on the image's grid: :func:`surface_on_image_grid`, the one way an
operation that casts shadows opens its DSM.

``shadow-map --dsm`` casts shadows on the image's own grid. A DSM on that grid is opened as it
is, checked against the image's grid, with the metres of its steps and its place. A DSM is
usually on a map grid; with the line's IGM (each raw pixel's map coordinates) it is read at
every raw pixel, bilinearly, as GDAL's ``gdallocationinfo -r bilinear`` or GRASS's ``r.what
-i`` would read it, and the raw grid's local geometry (metres per column and per line,
rotation) is the affine fit of the IGM, in which the sun's azimuth from north is then read.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import InputError, ParameterError
from .checks import check_cell_size
from .georef import (
    Coordinates,
    centre_lonlat,
    crs_name,
    crs_units,
    grid_place,
    metric_matrix,
    output_crs,
    transform_xy,
    utm_crs,
)
from .grid import Grid
from .image import open_raster
from .raster import scratch_raster

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


@dataclass(frozen=True)
class SurfaceOnGrid:
    """A surface model opened on an image's grid: its raster (``src``, open until the
    caller's stack closes), the 2 × 2 matrix taking a step of (Δcolumn, Δline) to (Δeast,
    Δnorth) in metres (None when neither the DSM nor the image has a geotransform: the cell
    size given says it) and the place of the grid (lon, lat, CRS) for the sun, or None."""

    src: object
    matrix: np.ndarray | None
    place: tuple | None


def surface_on_image_grid(
    dsm,
    grid: Grid,
    stack,
    *,
    image: str,
    coords=None,
    geolocation: str = "",
    cell_size=None,
    progress=None,
) -> SurfaceOnGrid:
    """The surface model ``dsm`` on the image's ``grid`` (``image`` names the image).

    Without ``coords`` the DSM is on the image's grid: of its size and, when both have one,
    its geotransform and CRS; ``cell_size`` (m) is then checked against a geotransform, and
    needed without one. With ``coords`` (the line's :class:`Coordinates`, from its IGM or GLT,
    which ``geolocation`` names, e.g. "IGM igm.tif") the DSM on its map grid is read at every raw pixel into a
    temporary raster on the image's grid, which ``stack`` removes.
    """
    if coords is not None:
        return _through_geolocation(dsm, grid, stack, coords, geolocation, progress)
    src = open_dsm(dsm, stack)
    if (src.height, src.width) != (grid.height, grid.width):
        raise InputError(
            f"surface model {dsm} has {src.height} × {src.width} cells but the "
            f"image {grid.height} × {grid.width} pixels: give a DSM on the image's grid, or "
            "the line's IGM ('igm') to read a DSM on a map grid at the image's pixels"
        )
    own = Grid.of(src)
    # Of the image's size but on another map grid (shifted, rotated, south-up, another
    # CRS): its cells are not the image's pixels.
    grid.require_same(own, image, f"surface model {dsm}")
    for placed, label in ((own, f"surface model {dsm}"), (grid, image)):
        if placed.transform is not None:
            matrix = metric_matrix(placed, label)
            check_cell_size(cell_size, matrix, label)
            return SurfaceOnGrid(src, matrix, grid_place(placed))
    if cell_size:
        return SurfaceOnGrid(src, None, None)
    raise ParameterError(
        f"surface model {dsm} and the image have no geotransform: give "
        "'cell_size' (the DSM's cell size in metres)"
    )


def _through_geolocation(dsm, grid: Grid, stack, coords, geolocation, progress) -> SurfaceOnGrid:
    """The DSM (on a map grid) read at every raw pixel of ``coords``: a temporary raster on
    the image's grid, the raw grid's metric matrix, and the line's place for the sun."""
    import tempfile

    matrix, crs, rms = raw_grid_matrix(coords)
    src = open_dsm(dsm, stack)
    folder = stack.enter_context(tempfile.TemporaryDirectory(prefix="geoboresight-dsm-"))
    path = f"{folder}/dsm_raw.tif"
    with scratch_raster(path, grid.width, grid.height) as dst:
        covered = surface_on_raw_grid(src, coords, dst, progress.sub(0.0, 0.05))
    if covered == 0:
        raise InputError(
            f"surface model {dsm} does not cover the flight line: none of the "
            f"{geolocation}'s pixels fall on it (check both files' CRS)"
        )
    share = covered / float(grid.height * grid.width)
    cell = float(np.sqrt(abs(np.linalg.det(matrix))))
    progress.info(
        f"surface model {dsm} read at the raw pixels through the {geolocation}: "
        f"{100 * share:.1f} % covered; raw grid {cell:.2f} m pixels, affine within "
        f"{rms:.2f} m RMS ({crs_name(crs)})"
    )
    if rms > cell:
        progress.info(
            f"warning: the flight line departs from an affine grid by {rms:.1f} m RMS (more "
            "than a pixel): its shadows are cast on the line's mean geometry"
        )
    lon, lat = centre_lonlat(coords.x, coords.y, coords.crs)
    raw = stack.enter_context(open_raster(path, "surface model"))
    return SurfaceOnGrid(raw, matrix, (lon, lat, crs))


def open_dsm(path, stack):
    """The surface model opened; refused when it has more than one band: its first band would
    be used without a word (a DSM and a DTM in one file, or an image given for the DSM)."""
    src = stack.enter_context(open_raster(path, "surface model"))
    if src.count != 1:
        raise InputError(
            f"surface model {path} has {src.count} bands: give a single-band DSM (heights in "
            f"metres), e.g. its band 1 with gdal_translate -b 1 {path} dsm.tif"
        )
    return src
