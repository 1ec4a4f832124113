"""The sun's incidence on each slope of a surface model: the hillshade (paper §3.1) and the
direct light on a smoothed slope.

- :func:`hillshade` — the cosine of the solar incidence angle on each cell, from Horn's (1981)
  3 × 3 gradient, the algorithm GDAL's ``gdaldem hillshade`` uses by default; negative values
  (slopes facing away from the sun) are *self* shadow.
- :func:`plane_incidence` — ``cos i / cos Z`` from the least-squares plane of a window, the
  direct light on a slope relative to level ground.

The sun and the grid as for the cast shadow (:func:`geoboresight.shadow.illumination.check_sun`,
:func:`geoboresight.shadow.illumination.grid_matrix`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .illumination import check_sun, grid_matrix

#: Vertical exaggeration of the hillshade (as ``gdaldem -z``).
Z_FACTOR = 1.0


def horn_gradient(dsm: np.ndarray, matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(∂z/∂east, ∂z/∂north) by Horn's 3 × 3 weighted differences; edges replicated."""
    z = np.pad(np.asarray(dsm, dtype=np.float64), 1, mode="edge")
    # Horn (1981): 1-2-1 weighted central differences along columns and rows.
    dcol = (
        (z[:-2, 2:] + 2 * z[1:-1, 2:] + z[2:, 2:]) - (z[:-2, :-2] + 2 * z[1:-1, :-2] + z[2:, :-2])
    ) / 8.0
    drow = (
        (z[2:, :-2] + 2 * z[2:, 1:-1] + z[2:, 2:]) - (z[:-2, :-2] + 2 * z[:-2, 1:-1] + z[:-2, 2:])
    ) / 8.0
    return _ground_gradient(dcol, drow, matrix)


def _ground_gradient(dcol, drow, matrix: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(∂z/∂east, ∂z/∂north) from the height's change per column and per row."""
    # dz/dcol = a·zx + d·zy, dz/drow = b·zx + e·zy  →  solve with Mᵀ.
    inv_t = np.linalg.inv(matrix.T)
    zx = inv_t[0, 0] * dcol + inv_t[0, 1] * drow
    zy = inv_t[1, 0] * dcol + inv_t[1, 1] * drow
    return zx, zy


def _filled(dsm: np.ndarray, valid) -> tuple[np.ndarray, np.ndarray]:
    """(heights, ok): invalid cells (``valid`` False or not finite) filled with the mean valid
    height, so that they do not tilt their neighbours' gradients."""
    ok = np.isfinite(dsm) if valid is None else (np.asarray(valid, bool) & np.isfinite(dsm))
    if not ok.all():
        dsm = np.where(ok, dsm, dsm.dtype.type(np.mean(dsm[ok])) if ok.any() else 0)
    return dsm, ok


def _cos_incidence(zx, zy, zenith: float, azimuth: float) -> np.ndarray:
    """cos i of surfaces of gradient (zx, zy) for the sun at (zenith, azimuth) degrees."""
    zr, ar = math.radians(zenith), math.radians(azimuth)
    sun = (math.sin(zr) * math.sin(ar), math.sin(zr) * math.cos(ar), math.cos(zr))
    return (-zx * sun[0] - zy * sun[1] + sun[2]) / np.sqrt(1.0 + zx * zx + zy * zy)


def hillshade(
    dsm: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    sun_zenith: float,
    sun_azimuth: float,
    transform: Any = None,
    cell_size: float | None = None,
    z_factor: float = Z_FACTOR,
) -> np.ndarray:
    """Cosine of the solar incidence angle on each cell (float32, −1..1; NaN where invalid).

    ``cos i = cos Z cos S + sin Z sin S cos(A − aspect)`` written with the surface normal
    (−∂z/∂x, −∂z/∂y, 1) and Horn's gradient; ≤ 0 means the slope faces away from the sun
    (self shadow). ``gdaldem hillshade`` reports ``1 + 254·max(cos i, 0)`` as a byte.
    Invalid cells (``valid`` False or not finite) are filled with the mean valid height for the
    gradient of their neighbours.

    Parameters
    ----------
    dsm : 2-D array (rows, cols)
        Surface model heights (terrain plus buildings), in the ground units of the grid
        (metres); non-finite heights are invalid.
    valid : bool array, optional
        Cells with a usable height (same shape as ``dsm``); by default the finite ones.
    sun_zenith : float
        Sun zenith angle in degrees from the vertical, 0–90 (90° minus the sun's elevation).
    sun_azimuth : float
        Sun azimuth in degrees clockwise from north towards the sun (as ``gdaldem -az``).
    transform : affine.Affine or 2 × 2 array, optional
        The grid's affine transform (rotation allowed), or the matrix taking (Δcol, Δrow) to
        (Δeast, Δnorth). Without one (or with the identity), ``cell_size`` is used and row 0 is
        the northern edge.
    cell_size : float, optional
        Cell side in ground units when there is no ``transform``.
    z_factor : float
        Vertical exaggeration of the heights (as ``gdaldem -z``).

    Returns
    -------
    cos_i : float32 array (rows, cols)
        Cosine of the solar incidence angle, −1..1: 1 where the slope faces the sun, ≤ 0 in self
        shadow; NaN where not valid.

    Raises
    ------
    ParameterError
        When the sun position is out of range, or the cell size is unknown (no transform and no
        ``cell_size``) or not positive.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the "hillshade
    map and shadow model" behind the ground-truth shadow map of Figures 4–5 and Table 2).
    Horn, B.K.P. Hill shading and the reflectance map. Proc. IEEE 1981, 69, 14–47.
    """
    z, a = check_sun(sun_zenith, sun_azimuth)
    m = grid_matrix(transform, cell_size)
    dsm, ok = _filled(np.asarray(dsm), valid)
    zx, zy = horn_gradient(dsm, m)
    zx *= z_factor
    zy *= z_factor
    cos_i = _cos_incidence(zx, zy, z, a)
    return np.where(ok, cos_i, np.nan).astype(np.float32)


#: Half-width (cells) of the window whose least-squares plane gives a slope for
#: :func:`plane_incidence`: 5 × 5 cells. Horn's 3 × 3 gradient of a DSM with 0.3 m of height
#: noise on 1 m cells has a slope noise of 0.13 (7°, cos i ± 0.1 at 45°), as large as the
#: relief it should measure; the 5 × 5 plane's is σ_z / (cell·√(5·Σr²)) = 0.04.
PLANE_HALF = 2


def plane_incidence(
    dsm: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    sun_zenith: float,
    sun_azimuth: float,
    transform: Any = None,
    cell_size: float | None = None,
    half: int = PLANE_HALF,
) -> np.ndarray:
    """Direct light on each cell's slope relative to level ground, ``cos i / cos Z``
    (float64; NaN where invalid; ≥ 0, 0 where the slope faces away from the sun), the slope
    from the least-squares plane of the ``(2·half + 1)²`` cells around it (a smoother slope
    than :func:`hillshade`'s 3 × 3, whose noise on a noisy DSM is as large as the relief).
    Invalid cells are filled with the mean valid height."""
    from scipy import ndimage

    z, a = check_sun(sun_zenith, sun_azimuth)
    m = grid_matrix(transform, cell_size)
    d, ok = _filled(np.asarray(dsm, np.float64), valid)
    r = np.arange(-half, half + 1, dtype=np.float64)
    w = np.tile(r, (r.size, 1)) / (r.size * float((r**2).sum()))
    dcol = ndimage.correlate(d, w, mode="nearest")
    drow = ndimage.correlate(d, w.T, mode="nearest")
    zx, zy = _ground_gradient(dcol, drow, m)
    cos_i = _cos_incidence(zx, zy, z, a)
    rel = np.clip(cos_i, 0.0, None) / max(math.cos(math.radians(z)), 1e-6)
    return np.where(ok, rel, np.nan)
