"""Sun geometry on a surface model: incidence (self-shading), cast shadows, sky view.

* **Self-shading**: ``cos i = n · s`` between the surface normal (from the DSM gradient) and the
  sun vector; a cell facing away from the sun (``cos i ≤ 0``) gets no direct light.
* **Cast shadows** (:func:`cast_shadow`): a cell at horizontal position ``p`` and height ``z``
  is shadowed when some point of the DSM along the ray towards the sun rises above it:
  ``z(p + a·ŝ) > z(p) + a / tan(zenith)`` for some ``a > 0``. With ``w(a) = z − a / tan(zenith)``
  along a sun-aligned line this is ``max_{a' > a} w(a') > w(a)``: one reverse running maximum
  per line (O(N)), computed on a grid rotated to the sun azimuth.
* **Sky view**: the diffuse (sky) light a cell receives is scaled by ``(1 + cos slope) / 2``
  (an isotropic sky seen by a tilted plane).

The sub-pixel **shadow fraction** is the mean of this per-cell shadow over each pixel's ground
footprint: the fine grid supersamples the pixel (see :mod:`.scene`).

* **Sky obstruction** (:func:`horizon_sky`, with ``sky_obstruction``): the surfaces around a
  cell that rise above it hide the sky behind them; the sky view of a horizontal surface under
  a horizon of elevation ``h(φ)`` is the mean over azimuth of ``cos² h(φ)`` (Dozier & Frew
  1990), multiplied into the tilt's share.

Not modelled: sky obstruction unless asked for (by default street canyons get the full sky),
penumbra (the sun is a point), light reflected from sunlit walls into shadows, transparency of
tree crowns.
"""

from __future__ import annotations

import numpy as np


def sun_vector(zenith_deg: float, azimuth_deg: float) -> np.ndarray:
    """Unit vector towards the sun in the track frame (x right of track, y along track, z up).

    ``azimuth_deg`` is measured clockwise from the flight direction (equal to the compass
    azimuth when the aircraft flies north).
    """
    z, a = np.radians(zenith_deg), np.radians(azimuth_deg)
    return np.array([np.sin(z) * np.sin(a), np.sin(z) * np.cos(a), np.cos(z)])


def raw_grid_azimuth(azimuth_deg: float) -> float:
    """The simulator's sun azimuth as ``sun-shadow`` and ``shadow-map`` take it on the
    simulated raw grid: degrees clockwise from the grid's up (row 0 at the top).

    The simulator measures the azimuth clockwise from the flight direction in the track frame
    (:func:`sun_vector`). Its raw image has row 0 at the start of the line and the columns to
    the right of the track, so the image is the ground seen mirrored: the flight runs down
    the image and the azimuth from the image's up is 180° − ``azimuth_deg``.
    """
    return (180.0 - float(azimuth_deg)) % 360.0


#: Slopes steeper than this (rise per run) are walls: vertical, of no horizontal extent.
WALL_SLOPE = 2.5


def normals(dsm: np.ndarray, cell: float, ground=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit surface normal components (nx, ny, nz) from the DSM gradient; rows run along +y.

    Where the DSM jumps by a wall (slope > :data:`WALL_SLOPE`), a cell is a flat roof or
    street cell beside a vertical wall, not part of a ramp: it takes the normal of the
    terrain ``ground`` (or of a flat plane).
    """
    dzdy, dzdx = np.gradient(dsm.astype("float64"), cell)
    wall = np.hypot(dzdx, dzdy) > WALL_SLOPE
    if wall.any():
        if ground is not None:
            gy, gx = np.gradient(np.asarray(ground, "float64"), cell)
        else:
            gy = gx = np.zeros_like(dzdx)
        dzdx = np.where(wall, gx, dzdx)
        dzdy = np.where(wall, gy, dzdy)
    norm = np.sqrt(dzdx**2 + dzdy**2 + 1.0)
    return -dzdx / norm, -dzdy / norm, 1.0 / norm


def incidence(dsm, cell: float, zenith_deg: float, azimuth_deg: float, ground=None) -> np.ndarray:
    """cos i between the surface normal and the sun (may be negative: self-shade)."""
    nx, ny, nz = normals(dsm, cell, ground)
    s = sun_vector(zenith_deg, azimuth_deg)
    return nx * s[0] + ny * s[1] + nz * s[2]


def sky_view(dsm: np.ndarray, cell: float, ground=None) -> np.ndarray:
    """Fraction of an isotropic sky seen by each cell's tilted plane, (1 + cos slope) / 2."""
    return 0.5 * (1.0 + normals(dsm, cell, ground)[2])


def horizon_sky(
    dsm: np.ndarray, cell: float, reach_m: float, directions: int = 16, step_m: float = 1.0
) -> np.ndarray:
    """Share of the open sky's light on a horizontal surface that the surroundings leave each
    cell: the mean over ``directions`` azimuths of ``cos²`` of the horizon's elevation, the
    horizon being the steepest rise of the DSM seen from the cell centre, sampled every
    ``step_m`` out to ``reach_m`` (nearest cell; beyond the array nothing hides the sky).

    References
    ----------
    Dozier, J.; Frew, J. Rapid calculation of terrain parameters for radiation modeling from
    digital elevation data. IEEE Trans. Geosci. Remote Sens. 1990, 28, 963–969.
    """
    z = np.asarray(dsm, dtype="float64")
    ny, nx = z.shape
    total = np.zeros(z.shape)
    for k in range(int(directions)):
        phi = 2.0 * np.pi * (k + 0.5) / directions
        dx, dy = np.cos(phi), np.sin(phi)
        best = np.zeros(z.shape)  # tan of the horizon's elevation (0: open horizon)
        for d in np.arange(step_m, reach_m + 1e-9, step_m):
            di, dj = int(round(d * dy / cell)), int(round(d * dx / cell))
            if abs(di) >= ny or abs(dj) >= nx:
                break
            other = np.full(z.shape, -np.inf)
            src = z[max(di, 0) : ny + min(di, 0), max(dj, 0) : nx + min(dj, 0)]
            other[max(-di, 0) : ny + min(-di, 0), max(-dj, 0) : nx + min(-dj, 0)] = src
            np.maximum(best, (other - z) / d, out=best)
        total += 1.0 / (1.0 + best * best)  # cos² of the elevation whose tan is ``best``
    return total / directions


def cast_shadow(
    dsm: np.ndarray,
    cell: float,
    zenith_deg: float,
    azimuth_deg: float,
    tolerance_m: float = 0.02,
) -> np.ndarray:
    """Boolean cast-shadow map of a DSM (rows along +y, columns along +x, square cells).

    Objects outside the array cast no shadow: pad the DSM upstream of the sun by
    ``max relief · tan(zenith)`` to include them.
    """
    dsm = np.asarray(dsm, dtype="float64")
    if zenith_deg <= 0.0:
        return np.zeros(dsm.shape, bool)
    ny, nx = dsm.shape
    s = sun_vector(zenith_deg, azimuth_deg)
    ux, uy = s[0], s[1]
    h = np.hypot(ux, uy)
    ux, uy = ux / h, uy / h  # horizontal unit vector towards the sun
    vx, vy = -uy, ux  # perpendicular
    cot = 1.0 / np.tan(np.radians(zenith_deg))
    # Rotated grid covering the array: coordinates a (along the sun) and b (across).
    corners_x = np.array([0, nx - 1, 0, nx - 1]) * cell
    corners_y = np.array([0, 0, ny - 1, ny - 1]) * cell
    a_c = corners_x * ux + corners_y * uy
    b_c = corners_x * vx + corners_y * vy
    step = cell / 4.0  # finer along the sun ray than the cells: edges within cell/8
    a = np.arange(a_c.min() - step, a_c.max() + 2 * step, step)
    b = np.arange(b_c.min() - cell, b_c.max() + 2 * cell, cell)
    A, B = np.meshgrid(a.astype("float32"), b.astype("float32"))  # rows: sun lines (b)
    # Nearest cell of every rotated sample (the DSM is constant over a cell).
    ii = np.rint((A * uy + B * vy) / cell).astype(np.intp)
    jj = np.rint((A * ux + B * vx) / cell).astype(np.intp)
    inside = (ii >= 0) & (ii < ny) & (jj >= 0) & (jj < nx)
    z = dsm[np.clip(ii, 0, ny - 1), np.clip(jj, 0, nx - 1)].astype("float32")
    w = np.where(inside, z - A * cot, -np.inf).astype("float32")
    del A, B, ii, jj, z, inside
    # Highest w strictly up-sun of each sample: reverse running max, shifted by one step.
    up = np.maximum.accumulate(w[:, ::-1], axis=1)[:, ::-1]
    up = np.concatenate([up[:, 1:], np.full((up.shape[0], 1), -np.inf, "float32")], axis=1)
    up = np.where(np.isfinite(up), up, -1e9).astype("float32")
    # Back to the cells: each cell's (a, b) position in the rotated grid; the highest up-sun
    # point is read on the cell's nearest sun line, linearly interpolated along it.
    yy, xx = np.mgrid[0:ny, 0:nx] * cell
    ca = xx * ux + yy * uy
    cb = xx * vx + yy * vy
    ia = np.clip((ca - a[0]) / step, 0, len(a) - 1.000001)
    ib = np.clip(np.rint((cb - b[0]) / cell).astype(np.intp), 0, len(b) - 1)
    i0 = np.floor(ia).astype(np.intp)
    f = ia - i0
    top = up[ib, i0] * (1 - f) + up[ib, i0 + 1] * f
    wcell = dsm - ca * cot
    return top > wcell + tolerance_m
