"""Cast shadow: a surface model's shadow from the sun, marched along the sun's ray (paper §3.1).

The paper builds its ground-truth shadow map from a surface model (DTM + buildings) and the
illumination geometry: "hillshade map and shadow model". The shadow model is here; the
incidence on each slope (:func:`geoboresight.shadow.incidence.hillshade`) and the sky-view
factor (:mod:`geoboresight.shadow.skyview`) stand beside it, on the same grid geometry
(:func:`grid_matrix`, :func:`check_sun`):

- :func:`cast_shadow` — cells whose line of sight to the sun is blocked by higher ground,
  found by **ray marching** towards the sun through the surface model (the method of GRASS
  ``r.sunmask``): a cell is shadowed when some cell along the ray rises above the sun line.
  Each step of the march is a whole-array shift, so it costs O(cells × steps) with no per-pixel
  Python loop.
- :func:`shadow_fraction` — the fraction of each cell in shadow, by marching on a supersampled
  surface (each cell split into ``n × n`` sub-cells).

Conventions: the sun zenith is degrees from the vertical (0–90), the azimuth degrees clockwise
from north towards the sun (as in ``gdaldem -az`` and ``r.sunmask azimuth=``). A grid is given
by a rasterio ``Affine`` transform; without one, ``cell_size`` says how big a cell is and row 0
is taken as the northern edge (image top = north, columns run east).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError

#: The first six coefficients of the identity geotransform: no georeferencing.
IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
#: Sub-cells per cell side for the shadow fraction.
SUPERSAMPLE = 4
#: How the surface between cell centres is modelled → the march's interpolation:
#: flat-topped blocks (buildings, as GRASS r.sunmask) or smooth terrain.
SURFACES = {"blocks": "nearest", "smooth": "bilinear"}
SURFACE = "blocks"
#: A cell is in the shadow mask when its shadow fraction reaches this.
MASK_FRACTION = 0.5


def check_sun(sun_zenith: float, sun_azimuth: float) -> tuple[float, float]:
    """Validate the sun position; return (zenith, azimuth mod 360) in degrees."""
    try:
        z = float(sun_zenith)
        a = float(sun_azimuth)
    except (TypeError, ValueError):
        raise ParameterError(
            f"sun zenith/azimuth must be numbers, got {sun_zenith!r}, {sun_azimuth!r}"
        ) from None
    if not (0.0 <= z <= 90.0) or not math.isfinite(z):
        raise ParameterError(
            f"parameter 'sun_zenith': {z:g}° is outside 0–90° (0 = sun overhead, "
            "90 = sun on the horizon); the zenith is 90° minus the sun's elevation"
        )
    if not math.isfinite(a):
        raise ParameterError(f"parameter 'sun_azimuth': {a!r} is not a finite angle")
    return z, a % 360.0


def grid_matrix(transform: Any = None, cell_size: float | None = None) -> np.ndarray:
    """The 2 × 2 matrix taking (Δcol, Δrow) to (Δeast, Δnorth) in ground units.

    From the affine ``transform`` when given (rotation allowed), else a north-up grid of square
    cells of ``cell_size``. Raises ParameterError when neither gives a usable cell size.
    """
    if isinstance(transform, np.ndarray):
        return np.asarray(transform, dtype=float).reshape(2, 2)
    if transform is not None and tuple(transform)[:6] != IDENTITY:
        m = np.array([[transform.a, transform.b], [transform.d, transform.e]], dtype=float)
        if abs(np.linalg.det(m)) == 0:
            raise ParameterError("the surface model's geotransform is degenerate (zero cell size)")
        return m
    if cell_size is None:
        raise ParameterError(
            "the surface model has no geotransform, so its cell size is unknown: give the "
            "cell size in metres (--cell-size / cell_size=)"
        )
    s = float(cell_size)
    if not (s > 0) or not math.isfinite(s):
        raise ParameterError(f"parameter 'cell_size': {cell_size!r} must be a positive number")
    return np.array([[s, 0.0], [0.0, -s]])


def sun_step(
    sun_zenith: float,
    sun_azimuth: float,
    matrix: np.ndarray,
    step: float = 0.5,
) -> tuple[float, float, float]:
    """(Δrow, Δcol, rise) per march step: ``step`` cells towards the sun, rising ``rise`` m."""
    z, a = check_sun(sun_zenith, sun_azimuth)
    cell = float(np.sqrt(abs(np.linalg.det(matrix))))
    ground = step * cell
    ar = math.radians(a)
    toward = np.array([math.sin(ar), math.cos(ar)]) * ground
    dcol, drow = np.linalg.solve(matrix, toward)
    elevation = math.radians(90.0 - z)
    rise = ground * math.tan(elevation) if z < 90.0 else 0.0
    return float(drow), float(dcol), float(rise)


def march_steps(
    relief: float, rise: float, shape: tuple[int, int], drow: float, dcol: float
) -> int:
    """How many steps a ray needs before it clears ``relief`` or leaves the grid."""
    per = max(abs(drow), abs(dcol), 1e-12)
    across = int(math.ceil(math.hypot(*shape) / per)) + 1
    if rise <= 0:
        return across
    return min(across, int(math.ceil(max(relief, 0.0) / rise)) + 1)


def shifted(a: np.ndarray, sr: int, sc: int, fill: float) -> np.ndarray:
    """``a`` sampled at (r + sr, c + sc), whole cells; ``fill`` outside the grid (the march
    towards the sun, and the moves of a mask along it)."""
    rows, cols = a.shape
    out = np.full(a.shape, fill, dtype=a.dtype)
    if abs(sr) >= rows or abs(sc) >= cols:
        return out
    out[max(0, -sr) : rows - max(0, sr), max(0, -sc) : cols - max(0, sc)] = a[
        max(0, sr) : rows + min(0, sr), max(0, sc) : cols + min(0, sc)
    ]
    return out


INTERPOLATIONS = ("nearest", "bilinear")


def cast_shadow(
    dsm: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    sun_zenith: float,
    sun_azimuth: float,
    transform: Any = None,
    cell_size: float | None = None,
    step: float = 1.0,
    relief: float | None = None,
    interpolation: str = "nearest",
    clearance: float = 0.0,
) -> np.ndarray:
    """Cells in cast shadow (bool), by marching towards the sun through the surface model.

    At step k the ray from each cell centre is k·``step`` cells towards the sun and has risen
    k·``step``·cell·tan(elevation); the cell is shadowed when the surface there is strictly
    higher than the ray. With ``interpolation="nearest"`` and ``step=1`` this is exactly
    GRASS ``r.sunmask`` (cells are flat-topped blocks sampled at whole-cell steps: a box of
    height h shades the ground beyond its sunward wall for h·tan(zenith), to within one cell);
    ``"bilinear"`` treats the surface as smooth terrain.
    Slopes facing away from the sun more steeply than the sun's elevation are caught too (the
    next sample sunward is above the sun line), so this is cast *and* self shadow. Rays leaving
    the grid are unblocked (as in ``r.sunmask``); invalid cells never cast shadow and are False.
    ``relief`` (max − min height of the larger raster this is a strip of) bounds the march.

    Parameters
    ----------
    dsm : 2-D array (rows, cols)
        Surface model heights (terrain plus buildings), in the ground units of the grid
        (metres); non-finite heights are invalid.
    valid : bool array, optional
        Cells with a usable height (same shape as ``dsm``); by default the finite ones.
    sun_zenith : float
        Sun zenith angle in degrees from the vertical, 0–90; at 0 nothing is shadowed.
    sun_azimuth : float
        Sun azimuth in degrees clockwise from north towards the sun (as ``r.sunmask azimuth=``).
    transform : affine.Affine or 2 × 2 array, optional
        The grid's affine transform (rotation allowed), or the matrix taking (Δcol, Δrow) to
        (Δeast, Δnorth). Without one (or with the identity), ``cell_size`` is used and row 0 is
        the northern edge.
    cell_size : float, optional
        Cell side in ground units when there is no ``transform``.
    step : float
        Length of one march step in cells (> 0); 1 with ``"nearest"`` is ``r.sunmask``.
    relief : float, optional
        Highest minus lowest valid height, which bounds the number of steps; by default that of
        ``dsm``. Give the whole raster's relief when ``dsm`` is a strip of it.
    interpolation : {"nearest", "bilinear"}
        How the surface is sampled along the ray: flat-topped blocks (buildings) or smooth
        terrain.
    clearance : float
        Height (ground units) by which a caster must rise above the sun line to cast shadow:
        0 is ``r.sunmask``; a noisy surface model (decimetres of height noise) needs about
        three times its noise, or every bump on open ground shades its neighbour's sub-cells.
        It shortens a true shadow by ``clearance·tan(zenith)``.

    Returns
    -------
    shadow : bool array (rows, cols)
        True where the cell's line of sight to the sun is blocked (cast and steep self shadow);
        False elsewhere and on invalid cells.

    Raises
    ------
    ParameterError
        When the sun position is out of range, the cell size is unknown or not positive,
        ``step`` is not positive or ``interpolation`` is unknown.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the "shadow model"
    from the surface model and the illumination geometry, the ground truth of Figures 4–5 and
    Table 2).
    GRASS Development Team. r.sunmask: calculates cast shadow areas from sun position and
    elevation raster map. GRASS GIS Reference Manual.
    https://grass.osgeo.org/grass-stable/manuals/r.sunmask.html
    """
    m = grid_matrix(transform, cell_size)
    check_sun(sun_zenith, sun_azimuth)
    if not step > 0:
        raise ParameterError(f"parameter 'step': {step!r} must be positive (cells per step)")
    if interpolation not in INTERPOLATIONS:
        raise ParameterError(
            f"parameter 'interpolation': {interpolation!r} is not one of {', '.join(INTERPOLATIONS)}"
        )
    z = np.array(dsm, dtype=np.float64)
    ok = np.isfinite(z) if valid is None else (np.asarray(valid, bool) & np.isfinite(z))
    shadow = np.zeros(z.shape, dtype=bool)
    if not ok.any() or float(sun_zenith) == 0.0:
        return shadow
    drow, dcol, rise = sun_step(sun_zenith, sun_azimuth, m, step)
    occluder = np.where(ok, z, -np.inf)
    if relief is None:
        relief = float(z[ok].max() - z[ok].min())
    n = march_steps(relief, rise, z.shape, drow, dcol)
    rows, cols = z.shape
    for k in range(1, n + 1):
        # Every cell's ray is at the same offset (k·drow, k·dcol): one step is a shifted slice.
        fr, fc = k * drow, k * dcol
        if abs(fr) >= rows + 1 or abs(fc) >= cols + 1:
            break
        if interpolation == "nearest":
            sample = shifted(occluder, int(np.floor(fr + 0.5)), int(np.floor(fc + 0.5)), -np.inf)
        else:
            r0, c0 = int(np.floor(fr)), int(np.floor(fc))
            wr, wc = fr - r0, fc - c0
            sample = np.zeros(z.shape)
            for dr, dc, w in (
                (0, 0, (1 - wr) * (1 - wc)),
                (1, 0, wr * (1 - wc)),
                (0, 1, (1 - wr) * wc),
                (1, 1, wr * wc),
            ):
                if w > 0:
                    sample += w * shifted(occluder, r0 + dr, c0 + dc, -np.inf)
            sample[np.isnan(sample)] = -np.inf
        shadow |= (sample - z) > k * rise + clearance
    return shadow & ok


def shadow_fraction(
    dsm: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    sun_zenith: float,
    sun_azimuth: float,
    transform: Any = None,
    cell_size: float | None = None,
    supersample: int = SUPERSAMPLE,
    relief: float | None = None,
    interpolation: str = "nearest",
    clearance: float = 0.0,
    shift: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """Fraction (0–1, float32) of each cell in shadow: the ground-truth shadow map.

    Each cell is split into ``supersample`` × ``supersample`` sub-cells (copies of the cell for
    ``"nearest"``: flat-topped blocks; bilinearly interpolated for ``"bilinear"``), the shadow
    is marched on that finer grid (:func:`cast_shadow`), and the fraction of shaded sub-cells is
    the cell's shadow fraction. Invalid cells are NaN.

    Parameters
    ----------
    dsm : 2-D array (rows, cols)
        Surface model heights (terrain plus buildings), in the ground units of the grid
        (metres); non-finite heights are invalid.
    valid : bool array, optional
        Cells with a usable height (same shape as ``dsm``); by default the finite ones.
    sun_zenith : float
        Sun zenith angle in degrees from the vertical, 0–90.
    sun_azimuth : float
        Sun azimuth in degrees clockwise from north towards the sun.
    transform : affine.Affine or 2 × 2 array, optional
        The grid's affine transform, or the matrix taking (Δcol, Δrow) to (Δeast, Δnorth);
        without one, ``cell_size`` is used and row 0 is the northern edge.
    cell_size : float, optional
        Cell side in ground units when there is no ``transform``.
    supersample : int
        Sub-cells per cell side (≥ 1); 1 gives a 0/1 shadow map.
    relief : float, optional
        Highest minus lowest valid height, which bounds the march (see :func:`cast_shadow`).
    interpolation : {"nearest", "bilinear"}
        Sub-cells are copies of their cell (flat-topped blocks) or bilinearly interpolated
        (smooth terrain); the march samples the surface the same way.
    clearance : float
        As :func:`cast_shadow` (a noisy surface model's height tolerance).
    shift : (float, float)
        Rows and columns (cells) by which the cast shadow is moved before it is counted, to
        the nearest sub-cell (:func:`cell_fraction`): a surface model's registration error
        undone without resampling (and so smoothing) its walls.

    Returns
    -------
    fraction : float32 array (rows, cols)
        Fraction of each cell in shadow, 0–1 (multiples of 1/``supersample``²); NaN where not
        valid.

    Raises
    ------
    ParameterError
        When ``supersample`` is below 1, or as :func:`cast_shadow`.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the ground-truth
    shadow fraction of Figure 5(B) and Table 2).
    GRASS Development Team. r.sunmask: calculates cast shadow areas from sun position and
    elevation raster map. GRASS GIS Reference Manual.
    https://grass.osgeo.org/grass-stable/manuals/r.sunmask.html
    """
    n = int(supersample)
    z = np.asarray(dsm, dtype=np.float64)
    ok = np.isfinite(z) if valid is None else (np.asarray(valid, bool) & np.isfinite(z))
    fine = sub_cell_shadow(
        z,
        ok,
        sun_zenith=sun_zenith,
        sun_azimuth=sun_azimuth,
        transform=transform,
        cell_size=cell_size,
        supersample=n,
        relief=relief,
        interpolation=interpolation,
        clearance=clearance,
    )
    return cell_fraction(fine, n, shift, ok).astype(np.float32)


def sub_cell_shadow(
    dsm: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    sun_zenith: float,
    sun_azimuth: float,
    transform: Any = None,
    cell_size: float | None = None,
    supersample: int = SUPERSAMPLE,
    relief: float | None = None,
    interpolation: str = "nearest",
    clearance: float = 0.0,
) -> np.ndarray:
    """The cast shadow on the grid of sub-cells (bool, ``supersample`` times the rows and
    columns) that :func:`shadow_fraction` counts; same parameters."""
    n = int(supersample)
    if n < 1:
        raise ParameterError(f"parameter 'supersample': {supersample!r} must be at least 1")
    m = grid_matrix(transform, cell_size)
    z = np.asarray(dsm, dtype=np.float64)
    ok = np.isfinite(z) if valid is None else (np.asarray(valid, bool) & np.isfinite(z))
    if n == 1:
        fine, fine_ok = np.where(ok, z, np.nan), ok
    elif interpolation == "bilinear":
        from scipy.ndimage import map_coordinates

        # Sub-cell centres in coarse pixel coordinates: (i + 0.5)/n − 0.5.
        rr = (np.arange(z.shape[0] * n) + 0.5) / n - 0.5
        cc = (np.arange(z.shape[1] * n) + 0.5) / n - 0.5
        filled = np.where(ok, z, np.nanmean(z) if ok.any() else 0.0)
        r2, c2 = np.meshgrid(rr, cc, indexing="ij")
        fine = map_coordinates(filled, [r2, c2], order=1, mode="nearest")
        fine_ok = np.kron(ok, np.ones((n, n), dtype=bool))
    else:
        fine = np.kron(np.where(ok, z, np.nan), np.ones((n, n)))
        fine_ok = np.kron(ok, np.ones((n, n), dtype=bool))
    cast = cast_shadow(
        fine,
        fine_ok,
        sun_zenith=sun_zenith,
        sun_azimuth=sun_azimuth,
        transform=m / n,
        relief=relief,
        interpolation=interpolation,
        clearance=clearance,
    )
    return cast


def cell_fraction(
    fine: np.ndarray,
    supersample: int,
    shift: tuple[float, float] = (0.0, 0.0),
    valid: np.ndarray | None = None,
) -> np.ndarray:
    """Each cell's share of shaded sub-cells (float64) in ``fine`` (:func:`sub_cell_shadow`),
    with the shadow first moved by ``shift`` (rows, columns; cells) rounded to whole sub-cells;
    nothing is shaded beyond the grid; NaN where ``valid`` (cells) is False."""
    n = int(supersample)
    sr, sc = (int(round(float(v) * n)) for v in shift)
    if sr or sc:
        # shifted samples at (r + sr, c + sc): moving the shadow by +s samples at −s.
        fine = shifted(np.asarray(fine, bool), -sr, -sc, False)
    rows, cols = fine.shape[0] // n, fine.shape[1] // n
    frac = fine.reshape(rows, n, cols, n).mean(axis=(1, 3))
    return frac if valid is None else np.where(valid, frac, np.nan)


def unseen_casters(
    dsm: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    sun_zenith: float,
    sun_azimuth: float,
    top: float,
    transform: Any = None,
    cell_size: float | None = None,
    row0: int = 0,
    height: int | None = None,
    clearance: float = 0.0,
) -> np.ndarray:
    """Cells whose shadow the surface model cannot rule out (bool): the ray from the cell
    towards the sun leaves the grid while still more than ``clearance`` below ``top`` (the
    grid's highest surface), so a caster of that height just beyond the grid's edge could
    shade the cell. A surface model cut to the image's extent sees no caster beyond it.

    ``dsm`` may be a strip of lines ``row0`` to ``row0 + len(dsm)`` of a grid of ``height``
    lines (by default the strip is the whole grid); the answer depends only on each cell's
    height and position. Invalid cells are False.

    Parameters
    ----------
    dsm : 2-D array
        Heights (ground units of the grid, metres).
    valid : bool array, optional
    sun_zenith, sun_azimuth : float
        As :func:`cast_shadow`; at zenith 0 nothing is unseen.
    top : float
        The highest valid height of the whole grid.
    transform, cell_size
        As :func:`cast_shadow`.
    row0, height : int
        First line of the strip and lines of the whole grid.
    clearance : float
        As :func:`cast_shadow`.

    Returns
    -------
    bool array, the shape of ``dsm``
    """
    z = np.asarray(dsm, dtype=np.float64)
    ok = np.isfinite(z) if valid is None else (np.asarray(valid, bool) & np.isfinite(z))
    m = grid_matrix(transform, cell_size)
    check_sun(sun_zenith, sun_azimuth)
    if float(sun_zenith) == 0.0:
        return np.zeros(z.shape, bool)
    rows, cols = z.shape
    total = rows if height is None else int(height)
    drow, dcol, rise = sun_step(sun_zenith, sun_azimuth, m, 1.0)
    r = (np.arange(rows) + int(row0))[:, None].astype(np.float64)
    c = np.arange(cols)[None, :].astype(np.float64)
    # Steps (of one cell) from each cell's centre to the grid's edge along the ray.
    with np.errstate(divide="ignore", invalid="ignore"):
        if abs(drow) > 1e-12:
            to_row = ((total - 0.5 - r) if drow > 0 else (r + 0.5)) / abs(drow)
        else:
            to_row = np.full(r.shape, np.inf)
        if abs(dcol) > 1e-12:
            to_col = ((cols - 0.5 - c) if dcol > 0 else (c + 0.5)) / abs(dcol)
        else:
            to_col = np.full(c.shape, np.inf)
    steps = np.minimum(to_row, to_col)
    with np.errstate(invalid="ignore"):
        return ok & (z + steps * rise + float(clearance) < float(top))


def along_ray(mask: np.ndarray, ray: tuple[float, float, int]) -> np.ndarray:
    """True where ``mask`` holds at the cell and at every sample of its ray towards the sun:
    ``ray`` = (Δrow, Δcol, steps), the samples at k·(Δrow, Δcol), k = 1…steps (nearest cell;
    :func:`sun_step` with ``step`` 1 and :func:`march_steps`). Samples beyond the grid hold.
    A strip gives the whole grid's answer on its lines when read with :func:`halo_rows`
    lines towards the sun."""
    m = np.asarray(mask, bool)
    drow, dcol, steps = ray
    out = m.copy()
    for k in range(1, int(steps) + 1):
        sr, sc = int(np.floor(k * drow + 0.5)), int(np.floor(k * dcol + 0.5))
        if abs(sr) >= m.shape[0] and abs(sc) >= m.shape[1]:
            break
        out &= shifted(m, sr, sc, True)
    return out


def halo_rows(
    relief: float,
    sun_zenith: float,
    sun_azimuth: float,
    matrix: np.ndarray,
    shape: tuple[int, int],
) -> tuple[int, int]:
    """Rows (above, below) a strip must be read with so its cast shadows are complete."""
    drow, dcol, rise = sun_step(sun_zenith, sun_azimuth, matrix, 1.0)
    if float(sun_zenith) == 0.0:
        return 1, 1
    reach = int(math.ceil(march_steps(relief, rise, shape, drow, dcol) * abs(drow))) + 2
    reach = min(reach, shape[0])
    return (reach, 1) if drow < 0 else (1, reach)


def height_range(dsm: np.ndarray, valid: np.ndarray | None = None) -> tuple[float, float, int]:
    """(lowest, highest, count) of the valid heights; (inf, −inf, 0) when there are none.
    Ranges of strips merge by min, max and sum; the relief is highest − lowest."""
    z = np.asarray(dsm)
    ok = np.isfinite(z) if valid is None else (np.asarray(valid, bool) & np.isfinite(z))
    if not ok.any():
        return math.inf, -math.inf, 0
    return float(z[ok].min()), float(z[ok].max()), int(ok.sum())
