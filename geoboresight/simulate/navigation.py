"""A simulated scene placed on a map: its IGM and an orthophoto of its ground.

A scene of :func:`.scene.simulate_scene` lives in a track frame (x across track, y along track,
metres). This module places that frame on a map, as :mod:`.ortho` does for its jittered line
(the same projected CRS, origin and heading), and gives what a processing chain and a national
mapping agency would give for the flight line:

* **the IGM**: map easting and northing of every raw VNIR pixel, the mean ground point of the
  pixel's rays (:class:`.scene.Footprints` ``x``/``y``: relief displacement and occlusion
  included, as an IGM from a DSM has them);
* **the orthophoto**: the same surface seen from straight above on a north-up map grid (true
  ortho: roofs at their footprint), red, green and blue (650, 550, 450 nm, 30 nm wide) as
  8-bit values (gamma 2.2, as photographs are encoded), through another camera (gain 0.9,
  2 % noise), area-averaged over 3 × 3 points per cell. Same sun and shadows as the flight
  (no cloud: another day's clouds are not the flight's); cells beyond the simulated surface
  are masked (``ortho_valid``).

Not modelled: GPS/INS errors (the IGM is exact), the orthophoto's own geolocation error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from .ortho import CRS, HEADING_DEG, ORIGIN, ORTHO_NOISE, _signal, _to_map, _to_track
from .scene import Sun, band_spectra, sun_maps
from .surface import Window

#: The orthophoto's bands (nm: red, green, blue), their width, and its cell size (m).
NAV_ORTHO_NM = (650.0, 550.0, 450.0)
NAV_ORTHO_FWHM = 30.0
NAV_ORTHO_CELL = 1.0
#: Apparent reflectance shown as 255 in the orthophoto, and the encoding gamma.
NAV_ORTHO_WHITE = 0.35
NAV_ORTHO_GAMMA = 2.2
#: Map margin (m) around the image's footprint.
NAV_MARGIN_M = 15.0


@dataclass(frozen=True)
class Navigation:
    """A scene on a map: ``igm`` (2, lines, 286) float64 easting and northing of each VNIR
    pixel; ``ortho`` (3, ny, nx) uint8 red, green, blue (1–255) on ``ortho_transform``
    (rasterio order a, b, c, d, e, f), both in ``crs``, ``ortho_valid`` (ny, nx) its cells
    on the simulated surface; ``truth`` what ``truth.json`` records."""

    igm: np.ndarray
    ortho: np.ndarray
    ortho_valid: np.ndarray
    ortho_transform: tuple
    crs: str
    truth: dict = field(repr=False)


def scene_navigation(
    scene,
    *,
    heading_deg: float = HEADING_DEG,
    origin=ORIGIN,
    crs: str = CRS,
    ortho_cell: float = NAV_ORTHO_CELL,
    seed: int = 0,
) -> Navigation:
    """The IGM and an orthophoto of a simulated scene (one made by
    :func:`.scene.simulate_scene`, which keeps its surface and ground points).

    Parameters
    ----------
    scene : Scene
        The simulated scene.
    heading_deg : float
        Flight heading, clockwise from north.
    origin : (easting, northing)
        Map position of the track frame's origin (first line's nadir point at z = 0).
    crs : str
        The map CRS (projected, metres).
    ortho_cell : float
        Orthophoto cell size (m).
    seed : int
        Seed of the orthophoto's noise (its own generator: the scene is unchanged).

    Returns
    -------
    Navigation

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: no GPS/INS
    on the AISA-Dual; Figure 10: the national orthophoto).
    """
    gx, gy = scene.ground_xy
    e, n = _to_map(gx, gy, heading_deg, origin)
    igm = np.stack([e, n]).astype("float64")
    surface = scene.surface
    names = list(surface.materials)
    sun = Sun(scene.truth["sun"]["zenith_deg"], scene.truth["sun"]["azimuth_deg"])
    # The map grid: north-up, around the footprint.
    e0 = np.floor((e.min() - NAV_MARGIN_M) / ortho_cell) * ortho_cell
    n1 = np.ceil((n.max() + NAV_MARGIN_M) / ortho_cell) * ortho_cell
    nx = int(np.ceil((e.max() + NAV_MARGIN_M - e0) / ortho_cell))
    ny = int(np.ceil((n1 - (n.min() - NAV_MARGIN_M)) / ortho_cell))
    # The surface rendered in the track frame over the map grid's reach, within the extent
    # the surface was built on (sun_maps needs no more: the surface's own margins hold the
    # shadow casters).
    x0, x1, y0, y1 = scene.extent
    ce, cn = (
        np.array([e0, e0 + nx * ortho_cell, e0, e0 + nx * ortho_cell]),
        np.array([n1, n1, n1 - ny * ortho_cell, n1 - ny * ortho_cell]),
    )
    tx, ty = _to_track(ce, cn, heading_deg, origin)
    wx0, wx1 = max(x0, tx.min() - 2), min(x1, tx.max() + 2)
    wy0, wy1 = max(y0, ty.min() - 2), min(y1, ty.max() + 2)
    cell = min(0.5, ortho_cell / 2)
    win = Window(wx0, wy0, int((wx1 - wx0) / cell), int((wy1 - wy0) / cell), cell)
    fine = sun_maps(surface, win, names, sun, None)
    spec = band_spectra(names, np.array(NAV_ORTHO_NM), np.full(len(NAV_ORTHO_NM), NAV_ORTHO_FWHM))
    signal = _signal(fine.maps, np.stack([spec[m] for m in names]), sun.cos_zenith)
    offs = (np.arange(3) + 0.5) / 3
    ortho = np.zeros((len(NAV_ORTHO_NM), ny, nx), "float64")
    inside = np.ones((ny, nx), bool)
    for dy in offs:
        for dx in offs:
            E, N = np.meshgrid(
                e0 + (np.arange(nx) + dx) * ortho_cell, n1 - (np.arange(ny) + dy) * ortho_cell
            )
            X, Y = _to_track(E, N, heading_deg, origin)
            i, j = win.ij(X, Y)
            inside &= (i >= 0) & (i <= win.ny - 1) & (j >= 0) & (j <= win.nx - 1)
            for b in range(len(NAV_ORTHO_NM)):
                ortho[b] += ndimage.map_coordinates(signal[b], [i, j], order=1, mode="nearest")
    ortho = 0.9 * ortho / 9.0
    rng = np.random.default_rng([seed, 505])
    ortho *= 1.0 + ORTHO_NOISE * rng.standard_normal(ortho.shape)
    level = np.clip(ortho / NAV_ORTHO_WHITE, 0.0, 1.0) ** (1.0 / NAV_ORTHO_GAMMA)
    dn = np.clip(np.round(255.0 * level), 1, 255).astype("uint8")
    truth = {
        "crs": crs,
        "heading_deg": heading_deg,
        "origin": [float(v) for v in origin],
        "igm": "igm.tif: easting, northing of each VNIR pixel's mean ground point",
        "ortho": "ortho.tif: red, green, blue (650, 550, 450 nm), true ortho, no cloud",
        "ortho_cell_m": ortho_cell,
    }
    return Navigation(igm, dn, inside, (ortho_cell, 0.0, e0, 0.0, -ortho_cell, n1), crs, truth)


__all__ = ["Navigation", "scene_navigation"]
