"""A pushbroom line with attitude jitter over a scene, its true IGM, and a map-geometry
orthophoto of the same scene: the truth for geolocation and automatic georeferencing.

The scene's surface (:mod:`.surface`, :mod:`.presets`) and sun geometry (:func:`.scene.sun_maps`)
are the simulator's. What this module adds:

* **attitude jitter**: roll, pitch and yaw change along the track as smooth random series
  (Gaussian-correlated over ``jitter_lines`` lines, standard deviation ``jitter_deg``), the
  wobble of a light aircraft without a stabilised mount; each line's rays go through the
  line's own rotation (:class:`.geometry.Instrument`) and meet the DSM by ray marching
  (:func:`.geometry.intersect`, relief displacement and occlusion included);
* **the true IGM**: map easting, northing and height of each raw pixel centre's ray hit,
  the track frame placed on a map by a heading and an origin in a projected CRS;
* **the raw band**: apparent reflectance at one wavelength, averaged over ``supersample²``
  rays per pixel (IFOV and line period), lit by the direct sun (cos i, cast shadows) and the
  sky, with multiplicative noise;
* **the orthophoto**: the same surface seen from straight above on a north-up map grid (true
  ortho: roofs at their footprint), at its own cell size and bands, through a different
  camera (its own gain and noise), area-averaged over 3 × 3 points per cell.

Not modelled: position errors of the aircraft (only attitude), different acquisition times
(same sun and shadows in both), lens distortion, the orthophoto's own geolocation error.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from ..errors import ParameterError
from .geometry import COLS, Instrument, intersect
from .scene import (
    Z_BOUND_M,
    _sun,
    band_spectra,
    flight_geometry,
    preset_surface,
    scene_extent,
    sun_maps,
)
from .spectra import aisa_dual_bands
from .surface import Window

#: A projected CRS and the map position of the track frame's origin (UTM 36N, the Negev).
CRS = "EPSG:32636"
ORIGIN = (660000.0, 3450000.0)
#: Flight heading, degrees clockwise from north: the raw lines are rotated on the map.
HEADING_DEG = 35.0
#: Attitude jitter: standard deviation (deg) and correlation length (lines).
JITTER_DEG = 0.05
JITTER_LINES = 24.0
#: The raw band and the orthophoto's bands (nm): a NIR band, and red, green, blue, NIR.
BAND_NM = 860.0
ORTHO_NM = (650.0, 550.0, 450.0, 860.0)
ORTHO_CELL = 1.0
#: Relative noise of the raw band and of the orthophoto.
NOISE = 0.01
ORTHO_NOISE = 0.02
#: Diffuse share of the light (sky) beside the direct sun.
SKY_SHARE = 0.2


@dataclass(frozen=True)
class OrthoScene:
    """A jittered raw band, its true IGM and a map-geometry orthophoto.

    ``raw`` (lines, 286) float32: apparent reflectance at ``band_nm`` in raw geometry;
    ``igm`` (3, lines, 286) float64: easting, northing, height of each pixel centre;
    ``attitude`` (3, lines): roll, pitch, yaw jitter (deg); ``ortho`` (bands, ny, nx)
    float32 on ``ortho_transform`` (rasterio order a, b, c, d, e, f) in ``crs``.
    """

    raw: np.ndarray
    igm: np.ndarray
    attitude: np.ndarray
    ortho: np.ndarray
    ortho_transform: tuple
    ortho_nm: tuple
    band_nm: float
    crs: str
    truth: dict = field(repr=False)


def attitude_jitter(
    lines: int, amplitude_deg: float = JITTER_DEG, correlation_lines: float = JITTER_LINES, rng=None
) -> np.ndarray:
    """(3, lines) roll, pitch and yaw (deg): Gaussian-correlated series, std ``amplitude_deg``.

    Parameters
    ----------
    lines : int
        Number of lines.
    amplitude_deg : float
        Standard deviation of each angle (0: no jitter).
    correlation_lines : float
        Gaussian correlation length (lines): the wobble's time scale.
    rng : numpy Generator, optional

    Returns
    -------
    (3, lines) float64 array

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: "variations
    in the mechanical structure of the sensor or the INS during the flight").
    """
    rng = np.random.default_rng(0) if rng is None else rng
    if amplitude_deg == 0:
        return np.zeros((3, lines))
    pad = int(4 * correlation_lines) + 1
    noise = rng.standard_normal((3, lines + 2 * pad))
    f = ndimage.gaussian_filter1d(noise, correlation_lines, axis=1, mode="wrap")[:, pad:-pad]
    f = (f - f.mean(axis=1, keepdims=True)) / (f.std(axis=1, keepdims=True) + 1e-12)
    return amplitude_deg * f


def _line_rays(geo, attitude, lines: int, sub: int):
    """Line times and (u, v) of ``sub²`` rays per pixel through each line's attitude."""
    base = geo.vnir
    offs = (np.arange(sub) + 0.5) / sub - 0.5 if sub > 1 else np.zeros(1)
    cols = (np.arange(COLS)[:, None] + offs[None, :]).ravel()  # (COLS·sub)
    u = np.empty((lines, COLS, sub, sub))
    v = np.empty_like(u)
    for t in range(lines):
        inst = Instrument(
            base.roll_deg + attitude[0, t],
            base.pitch_deg + attitude[1, t],
            base.yaw_deg + attitude[2, t],
            base.ifov_mrad,
            base.cols,
        )
        ut, vt = inst.uv(cols)
        u[t] = ut.reshape(COLS, 1, sub)
        v[t] = vt.reshape(COLS, 1, sub)
    t = np.arange(lines, dtype="float64")[:, None, None, None] + offs[None, None, :, None]
    t = np.broadcast_to(t, u.shape)
    return t, u, v


def _to_map(x, y, heading_deg: float, origin):
    h = np.radians(heading_deg)
    e = origin[0] + x * np.cos(h) + y * np.sin(h)
    n = origin[1] - x * np.sin(h) + y * np.cos(h)
    return e, n


def _to_track(e, n, heading_deg: float, origin):
    h = np.radians(heading_deg)
    de, dn = np.asarray(e) - origin[0], np.asarray(n) - origin[1]
    return de * np.cos(h) - dn * np.sin(h), de * np.sin(h) + dn * np.cos(h)


def _signal(maps: np.ndarray, spectra: np.ndarray, cos_zen: float) -> np.ndarray:
    """Apparent reflectance per band on the fine grid: Σ_m f_m ρ_m · texture · light."""
    k = spectra.shape[0]
    frac, direct, sky, bright = maps[:k], maps[k], maps[k + 1], maps[k + 3]
    light = (1 - SKY_SHARE) * direct / cos_zen + SKY_SHARE * sky
    return np.einsum("kb,kyx->byx", spectra, frac) * (bright * light)[None]


def simulate_ortho(
    preset: str = "urban",
    lines: int = 128,
    *,
    jitter_deg: float = JITTER_DEG,
    jitter_lines: float = JITTER_LINES,
    heading_deg: float = HEADING_DEG,
    origin=ORIGIN,
    crs: str = CRS,
    band_nm: float = BAND_NM,
    ortho_nm=ORTHO_NM,
    ortho_cell: float = ORTHO_CELL,
    supersample: int = 3,
    noise: float = NOISE,
    seed: int = 0,
) -> OrthoScene:
    """Simulate a jittered raw band, its true IGM and an orthophoto of the same scene.

    Parameters
    ----------
    preset : {"urban", "dunes", "glade", "mixed"}
        The surface (:data:`.presets.SCENES`).
    lines : int
        Lines of the raw band (286 columns, 1.5 m pixels at 1,500 m).
    jitter_deg, jitter_lines : float
        Attitude jitter: standard deviation of roll, pitch and yaw (deg) and correlation
        length (lines).
    heading_deg : float
        Flight heading, clockwise from north.
    origin : (easting, northing)
        Map position of the track frame's origin (first line's nadir point at z = 0).
    crs : str
        The map CRS (projected, metres).
    band_nm : float
        Wavelength of the raw band.
    ortho_nm : sequence of float
        Wavelengths of the orthophoto's bands.
    ortho_cell : float
        Orthophoto cell size (m).
    supersample : int
        Rays per pixel side for the raw band.
    noise : float
        Relative noise of the raw band.
    seed : int
        Same seed, same scene.

    Returns
    -------
    OrthoScene

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: AISA-Dual
    1.5 m pixels, 286 columns, no GPS/INS; Figure 10: the national orthophoto).
    """
    if not 8 <= int(lines) <= 20000:
        raise ParameterError(f"parameter 'lines': {lines} is outside 8–20,000")
    if not 0 <= jitter_deg <= 2:
        raise ParameterError(f"parameter 'jitter_deg': {jitter_deg}° is outside 0–2°")
    if not 0.2 <= ortho_cell <= 20:
        raise ParameterError(f"parameter 'ortho_cell': {ortho_cell} m is outside 0.2–20 m")
    lines = int(lines)
    rng = np.random.default_rng([seed, 1212])
    geo = flight_geometry()
    sun = _sun(preset, None, None)
    attitude = attitude_jitter(lines, jitter_deg, jitter_lines, rng)
    t1, u1, v1 = _line_rays(geo, attitude, lines, 1)
    H = geo.flying_height
    # The layout: the ground every jittered ray can reach, plus the nominal layout's margins.
    extent, core = scene_extent(geo, lines, sun)
    xs = np.concatenate([((H - z) * u1).ravel() for z in (0.0, Z_BOUND_M)])
    ys = np.concatenate([(t1 * geo.line_spacing + (H - z) * v1).ravel() for z in (0.0, Z_BOUND_M)])
    core = (
        min(core[0], xs.min()),
        max(core[1], xs.max()),
        min(core[2], ys.min()),
        max(core[3], ys.max()),
    )
    # The orthophoto: a north-up map grid around the footprint, 20 m beyond it.
    ce, cn = _to_map(
        np.array([core[0], core[1], core[0], core[1]]),
        np.array([core[2], core[2], core[3], core[3]]),
        heading_deg,
        origin,
    )
    margin = 20.0
    e0 = np.floor((ce.min() - margin) / ortho_cell) * ortho_cell
    n1 = np.ceil((cn.max() + margin) / ortho_cell) * ortho_cell
    nx = int(np.ceil((ce.max() + margin - e0) / ortho_cell))
    ny = int(np.ceil((n1 - (cn.min() - margin)) / ortho_cell))
    oe = np.array([e0, e0 + nx * ortho_cell, e0, e0 + nx * ortho_cell])
    on = np.array([n1, n1, n1 - ny * ortho_cell, n1 - ny * ortho_cell])
    tx, ty = _to_track(oe, on, heading_deg, origin)
    extent = (
        min(extent[0], tx.min() - 5),
        max(extent[1], tx.max() + 5),
        min(extent[2], ty.min() - 5),
        max(extent[3], ty.max() + 5),
    )
    surface = preset_surface(preset, rng, extent, core, seed=seed)
    names = surface.materials
    cell = min(0.5, ortho_cell / 2)
    win = Window(
        extent[0],
        extent[2],
        int((extent[1] - extent[0]) / cell),
        int((extent[3] - extent[2]) / cell),
        cell,
    )
    fine = sun_maps(surface, win, names, sun, None)
    vnir_wl, vnir_fwhm, swir_wl, swir_fwhm = aisa_dual_bands()
    raw_fwhm = float(vnir_fwhm[0] if band_nm < swir_wl[0] else swir_fwhm[0])
    spectra = band_spectra(names, np.array([band_nm]), np.array([raw_fwhm]))
    signal = _signal(fine.maps, np.stack([spectra[n] for n in names]), sun.cos_zenith)[0]
    # The true IGM: the ray through each pixel centre, to its first hit on the DSM.
    x, y, z = intersect(t1.ravel(), u1.ravel(), v1.ravel(), geo, fine.heights, fine.z_lo, fine.z_hi)
    e, n = _to_map(x, y, heading_deg, origin)
    igm = np.stack([e.reshape(lines, COLS), n.reshape(lines, COLS), z.reshape(lines, COLS)])
    # The raw band: supersample² rays per pixel, block by block of lines (bounded memory).
    raw = np.empty((lines, COLS), "float32")
    for l0 in range(0, lines, 64):
        l1 = min(l0 + 64, lines)
        ts, us, vs = _line_rays(geo, attitude[:, l0:l1], l1 - l0, supersample)
        ts = ts + l0
        hx, hy, _ = intersect(
            ts.ravel(), us.ravel(), vs.ravel(), geo, fine.heights, fine.z_lo, fine.z_hi
        )
        i, j = win.ij(hx, hy)
        val = ndimage.map_coordinates(signal, [i, j], order=1, mode="nearest")
        raw[l0:l1] = val.reshape(l1 - l0, COLS, -1).mean(axis=2)
    raw *= 1.0 + noise * rng.standard_normal(raw.shape).astype("float32")
    # The orthophoto: 3 × 3 points per cell, another camera (gain 0.9, its own noise).
    ortho_nm = tuple(float(w) for w in ortho_nm)
    o_fwhm = np.full(len(ortho_nm), 30.0)
    o_spec = band_spectra(names, np.array(ortho_nm), o_fwhm)
    o_signal = _signal(fine.maps, np.stack([o_spec[n] for n in names]), sun.cos_zenith)
    offs = (np.arange(3) + 0.5) / 3
    ortho = np.zeros((len(ortho_nm), ny, nx), "float64")
    for dy in offs:
        for dx in offs:
            ee = e0 + (np.arange(nx) + dx) * ortho_cell
            nn = n1 - (np.arange(ny) + dy) * ortho_cell
            E, N = np.meshgrid(ee, nn)
            X, Y = _to_track(E, N, heading_deg, origin)
            i, j = win.ij(X, Y)
            for b in range(len(ortho_nm)):
                ortho[b] += ndimage.map_coordinates(o_signal[b], [i, j], order=1, mode="nearest")
    ortho = 0.9 * ortho / 9.0
    ortho *= 1.0 + ORTHO_NOISE * rng.standard_normal(ortho.shape)
    transform = (ortho_cell, 0.0, e0, 0.0, -ortho_cell, n1)
    truth = {
        "crs": crs,
        "heading_deg": heading_deg,
        "origin": list(origin),
        "gsd_m": geo.gsd_m,
        "line_spacing_m": geo.line_spacing,
        "flying_height_m": H,
        "jitter_deg": jitter_deg,
        "jitter_lines": jitter_lines,
        "attitude_std_deg": [float(a.std()) for a in attitude],
        "band_nm": band_nm,
        "ortho_nm": list(ortho_nm),
        "ortho_cell_m": ortho_cell,
        "preset": preset,
        "lines": lines,
        "seed": seed,
    }
    return OrthoScene(
        raw=raw,
        igm=igm,
        attitude=attitude,
        ortho=ortho.astype("float32"),
        ortho_transform=transform,
        ortho_nm=ortho_nm,
        band_nm=float(band_nm),
        crs=crs,
        truth=truth,
    )
