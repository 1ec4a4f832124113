"""The sky-view factor of a surface model: the share of the sky each cell sees over the
horizon that the surface around it raises, searched along evenly spaced azimuths on the grid
of the cast shadow (:func:`geoboresight.shadow.illumination.grid_matrix`,
:func:`geoboresight.shadow.illumination.shifted`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import ParameterError
from .illumination import grid_matrix, shifted

#: Azimuths of the horizon search of the sky-view factor (evenly spaced).
SKY_DIRECTIONS = 16
#: How far (m) the horizon is searched: an obstacle of height h at distance d hides
#: cos²(atan(h/d)) of the sky in its direction; beyond 100 m a building of 20 m hides under 4 %.
SKY_RADIUS_M = 100.0


def sky_view_factor(
    dsm: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    transform: Any = None,
    cell_size: float | None = None,
    radius: float = SKY_RADIUS_M,
    directions: int = SKY_DIRECTIONS,
    clearance: float = 0.0,
) -> np.ndarray:
    """Share of the isotropic sky's irradiance on a horizontal surface that reaches each cell
    (float32, 0–1; NaN where invalid): 1 on open flat ground.

    For a horizontal surface, the sky above a horizon of elevation ``h`` in azimuth φ gives
    ``cos² h(φ)`` of that azimuth's open-sky irradiance (∫ sin e cos e de from h to 90°), so
    ``V = mean over φ of cos² h(φ)`` (Dozier & Frew 1990, horizontal case). The horizon of
    each of ``directions`` azimuths is the highest elevation angle of the surface seen from
    the cell centre, marching one cell at a time out to ``radius`` metres (nearest cell,
    whole-array shifts as :func:`~geoboresight.shadow.illumination.cast_shadow`); invalid cells and the outside of the grid hide
    nothing. Heights are taken at the cell centres: at the middle of a long trench whose
    walls' first cells are at ±a from it and rise d this gives the analytic 2-D value
    ``a/√(a² + d²)`` (within the quadrature of ``directions`` azimuths).

    Parameters
    ----------
    dsm : 2-D array
        Surface heights (m); non-finite = invalid.
    valid : bool array, optional
    transform, cell_size
        The grid, as :func:`~geoboresight.shadow.illumination.cast_shadow`.
    radius : float
        Search distance (m, > 0).
    directions : int
        Azimuths searched (≥ 4).
    clearance : float
        Height (m) an obstacle must rise above the cell to hide sky, as in
        :func:`~geoboresight.shadow.illumination.cast_shadow`: a noisy DSM's bumps would otherwise each hide a little sky of
        their neighbours (0.3 m of noise takes 5–10 % off open ground without it).

    References
    ----------
    Dozier, J.; Frew, J. Rapid calculation of terrain parameters for radiation modeling from
    digital elevation data. IEEE Trans. Geosci. Remote Sens. 1990, 28, 963–969.
    Richter, R.; Müller, A. Int. J. Remote Sens. 2005, 26, 3137–3148 (the sky-view factor in
    de-shadowing; ATCOR-4's illumination model).
    """
    m = grid_matrix(transform, cell_size)
    if not (radius > 0) or not math.isfinite(radius):
        raise ParameterError(f"parameter 'radius': {radius!r} must be a positive distance (m)")
    n_dir = int(directions)
    if n_dir < 4:
        raise ParameterError(f"parameter 'directions': {directions!r} must be at least 4")
    z = np.asarray(dsm, dtype=np.float64)
    ok = np.isfinite(z) if valid is None else (np.asarray(valid, bool) & np.isfinite(z))
    occluder = np.where(ok, z, -np.inf)
    total = np.zeros(z.shape)
    cell = float(np.sqrt(abs(np.linalg.det(m))))
    for j in range(n_dir):
        phi = 2.0 * math.pi * j / n_dir
        # One cell per step, along the azimuth (clockwise from north) in (row, col).
        dcol, drow = np.linalg.solve(m, np.array([math.sin(phi), math.cos(phi)]) * cell)
        best = np.zeros(z.shape)  # tangent of the horizon elevation (≥ 0: the open horizon)
        steps = int(math.ceil(radius / cell))
        for k in range(1, steps + 1):
            sr, sc = int(np.floor(k * drow + 0.5)), int(np.floor(k * dcol + 0.5))
            if abs(sr) >= z.shape[0] or abs(sc) >= z.shape[1]:
                break
            dist = float(np.hypot(*(m @ np.array([sc, sr]))))
            with np.errstate(invalid="ignore"):
                rise = shifted(occluder, sr, sc, -np.inf) - z - clearance
                best = np.maximum(best, rise / dist)
        total += 1.0 / (1.0 + best * best)  # cos² of the horizon elevation
    return np.where(ok, total / n_dir, np.nan).astype(np.float32)
