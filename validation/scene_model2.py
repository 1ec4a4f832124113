"""A second, independent scene model of a dual VNIR + SWIR pushbroom flight line.

It shares no code with :mod:`geoboresight.simulate` (nor with any geoboresight kernel) and is
deliberately simple, so that the shadow map and the relative DEM are not validated only on the
physics of the simulator they were developed on. What differs from ``geoboresight.simulate``:

* **spectra**: single earthlib spectra drawn at random from classes the simulator does not use
  (``road``, ``parking_lot``, ``wood_shingle``, ``tile``, ``paint``, ``char``, ``dirt``,
  individual ``soil`` and ``canopy`` spectra) instead of class medians, and an analytic water
  reflectance (earthlib has no water);
* **illumination**: Bird & Riordan's (1986) SPCTRAL2-style transmittances with an ozone
  Chappuis band, a diffuse sky split into its Rayleigh and aerosol parts with SPCTRAL2's
  formulas, a sky-view factor from the local horizon, and light reflected by the sunlit
  surroundings into shadows (adjacency, which makes shadows less blue than pure skylight);
  path radiance proportional to the diffuse sky;
* **sensor**: HySpex-like band sets (VNIR 400–1,000 nm, SWIR 960–2,500 nm), other spectral
  responses, a dark level that differs from band to band, Poisson shot noise (drawn as Poisson,
  not Gaussian), read noise and 14-bit quantisation; the SWIR sees the ground shifted by a
  boresight offset plus the relief parallax ``h · tan(squint) / GSD``.

Not modelled: occlusion by relief between the two views, BRDF, multiple scattering between
objects beyond the one adjacency term, tree-crown translucency, penumbra.

References
----------
Bird, R.E.; Riordan, C. Simple solar spectral model for direct and diffuse irradiance on
horizontal and tilted planes at the Earth's surface for cloudless atmospheres. J. Clim. Appl.
Meteorol. 1986, 25, 87–97.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from functools import cache

import numpy as np
from scipy import ndimage

FINE = np.arange(350.0, 2551.0, 5.0)  # nm

MATERIALS = {
    1: "road",  # asphalt road (dark)
    2: "parking",  # asphalt parking lot (dark)
    3: "dark_roof",  # wood / composite shingle, darkest quarter
    4: "bright_roof",  # tile or paint
    5: "soil",
    6: "dark_soil",  # darkest soils
    7: "grass",
    8: "tree",
    9: "water",
    10: "char",  # burned ground (very dark)
}
#: The sunlit dark materials of the validation (the dark-pixel detector's failure case).
DARK_MATERIALS = ("road", "parking", "dark_roof", "dark_soil", "water", "char")


@cache
def _library():
    from earthlib import config, read

    spectra, _, sensor = read.envi_library(config.full_endmember_path)
    wl = np.asarray(sensor.band_centers, float)
    if wl.max() < 100:
        wl = np.round(wl, 6) * 1000.0
    classes = config.full_metadata["LEVEL_3"].to_numpy(str)
    return wl, np.asarray(spectra, float), classes


def _pick(rng, cls, lo=0.0, hi=1.0, key_nm=None):
    """One earthlib spectrum of class ``cls`` whose brightness lies in the quantiles lo–hi."""
    wl, spectra, classes = _library()
    sel = spectra[classes == cls]
    key = sel.mean(1) if key_nm is None else sel[:, np.argmin(np.abs(wl - key_nm))]
    a, b = np.quantile(key, [lo, hi])
    sel = sel[(key >= a) & (key <= b)]
    s = sel[rng.integers(len(sel))]
    good = np.isfinite(s) & (s > 0)
    return np.clip(np.interp(FINE, wl[good], s[good]), 0.001, 1.0)


def water_reflectance():
    """Clear water: ~5 % in the blue falling to ~0.5 % in the red edge, ~0 beyond 900 nm,
    plus 2 % of Fresnel surface reflection of the (sky) light, a flat term."""
    body = 0.055 * np.exp(-(((FINE - 480.0) / 110.0) ** 2)) + 0.004 * (FINE < 720)
    return np.clip(body, 0, None) + 0.004


def material_spectra(rng):
    pick = {
        1: lambda: _pick(rng, "road", 0.0, 0.5),
        2: lambda: _pick(rng, "parking_lot", 0.0, 0.6),
        3: lambda: _pick(rng, "comp_shingle", 0.0, 0.25),
        4: lambda: _pick(rng, "tile", 0.3, 1.0),
        5: lambda: _pick(rng, "soil", 0.4, 0.9),
        6: lambda: _pick(rng, "soil", 0.0, 0.08),
        7: lambda: _pick(rng, "canopy", 0.2, 0.5, key_nm=850.0),
        8: lambda: _pick(rng, "canopy", 0.75, 1.0, key_nm=850.0),
        9: water_reflectance,
        10: lambda: _pick(rng, "char", 0.0, 1.0),
    }
    return {k: f() for k, f in pick.items()}


# ----------------------------------------------------------------------------- illumination


def solar(wl):
    """Top-of-atmosphere irradiance (W m-2 nm-1): 5,800 K black body scaled to 1,361 W m-2."""
    h, c, k = 6.626e-34, 2.998e8, 1.381e-23
    lam = wl * 1e-9
    b = 2 * h * c**2 / lam**5 / np.expm1(h * c / (lam * k * 5800.0))
    return b / (b.sum() * (wl[1] - wl[0])) * 1361.0


def spctral2(wl, zenith_deg, aot500=0.2, alpha=1.14, water_cm=1.5, ozone_cm=0.3):
    """Direct-normal and diffuse-horizontal irradiance in SPCTRAL2's simplified form."""
    z = np.radians(zenith_deg)
    m = 1.0 / (np.cos(z) + 0.15 * (93.885 - zenith_deg) ** -1.253)  # Kasten air mass
    um = wl / 1000.0
    t_r = np.exp(-m / (um**4 * (115.6406 - 1.335 / um**2)))
    tau_a = aot500 * (wl / 500.0) ** -alpha
    t_a = np.exp(-tau_a * m)
    t_o = np.exp(-ozone_cm * 21.0 * np.exp(-(((wl - 600.0) / 60.0) ** 2)) * 0.005 * m)
    gas = np.zeros_like(wl)
    for c, s, d in ((760, 4, 1.5), (940, 15, 0.6), (1130, 25, 0.7), (1380, 45, 5), (1870, 50, 7)):
        gas += d * np.exp(-0.5 * ((wl - c) / s) ** 2) * (water_cm / 1.5 if c != 760 else 1.0)
    t_g = np.exp(-gas * m)
    e0 = solar(wl)
    direct = e0 * t_r * t_a * t_o * t_g
    omega, fs = 0.945, 0.82  # single-scattering albedo, forward fraction (SPCTRAL2)
    t_aa = np.exp(-(1 - omega) * tau_a * m)
    t_as = np.exp(-omega * tau_a * m)
    mu = np.cos(z)
    rayleigh = e0 * mu * t_o * t_g * t_aa * 0.5 * (1 - t_r**0.95)
    aerosol = e0 * mu * t_o * t_g * t_aa * t_r**1.5 * (1 - t_as) * fs
    return direct, rayleigh + aerosol


def band_matrix(centres, fwhm):
    s = fwhm / 2.3548
    m = np.exp(-0.5 * ((FINE[None, :] - centres[:, None]) / s[:, None]) ** 2)
    return m / m.sum(1, keepdims=True)


# ------------------------------------------------------------------------------- the scene


@dataclass
class Scene2:
    vnir: np.ndarray  # (bands, rows, cols) uint16 DN
    swir: np.ndarray
    vnir_nm: np.ndarray
    swir_nm: np.ndarray
    dsm: np.ndarray
    material: np.ndarray
    shadow_fraction: np.ndarray
    truth: dict = field(default_factory=dict)


def _layout(rng, rows, cols, relief_m, buildings, trees):
    yy, xx = np.mgrid[0:rows, 0:cols].astype(float)
    terrain = np.zeros((rows, cols))
    for _ in range(3):
        cy, cx = rng.uniform(0, rows), rng.uniform(0, cols)
        sy, sx = rng.uniform(0.25, 0.6) * rows, rng.uniform(0.25, 0.6) * cols
        terrain += rng.uniform(0.3, 1.0) * np.exp(
            -0.5 * (((yy - cy) / sy) ** 2 + ((xx - cx) / sx) ** 2)
        )
    span = np.ptp(terrain)
    terrain = (terrain - terrain.min()) / span * relief_m if span > 0 else terrain * 0
    mat = np.where(ndimage.uniform_filter(rng.random((rows, cols)), 9) > 0.5, 5, 7)
    height = np.zeros((rows, cols))
    # roads: two horizontal, one vertical
    for r in rng.choice(np.arange(10, rows - 10), 2, replace=False):
        mat[r : r + 6, :] = 1
    c = int(rng.integers(20, cols - 20))
    mat[:, c : c + 7] = 1
    # patches: parking, dark soil, char, water
    for m_id, size in ((2, (14, 22)), (6, (16, 16)), (10, (10, 14)), (9, (18, 24))):
        r0, c0 = int(rng.integers(0, rows - size[0])), int(rng.integers(0, cols - size[1]))
        mat[r0 : r0 + size[0], c0 : c0 + size[1]] = m_id
    water = mat == 9
    # buildings (flat roofs, half of them dark)
    for i in range(buildings):
        h, w = int(rng.integers(6, 16)), int(rng.integers(6, 16))
        r0, c0 = int(rng.integers(2, rows - h - 2)), int(rng.integers(2, cols - w - 2))
        if water[r0 : r0 + h, c0 : c0 + w].any():
            continue
        mat[r0 : r0 + h, c0 : c0 + w] = 3 if i % 2 == 0 else 4
        height[r0 : r0 + h, c0 : c0 + w] = rng.uniform(4.0, 14.0)
    # trees: round crowns on open ground
    for _ in range(trees):
        r0, c0 = rng.uniform(3, rows - 3), rng.uniform(3, cols - 3)
        if mat[int(r0), int(c0)] not in (5, 7):
            continue
        rad = rng.uniform(1.5, 3.0)
        d = np.hypot(yy - r0, xx - c0)
        crown = d <= rad
        mat[crown] = 8
        height[crown] = np.maximum(
            height[crown], rng.uniform(5, 9) * np.sqrt(1 - (d[crown] / rad) ** 2 * 0.6)
        )
    return terrain + height, mat, terrain


def _cast(dsm, gsd, zenith, azimuth, sub=4):
    """Sub-pixel cast shadow by marching on a nearest-upsampled DSM (row 0 north)."""
    z = np.kron(dsm, np.ones((sub, sub)))
    cell = gsd / sub
    az = np.radians(azimuth)
    dr, dc = -np.cos(az), np.sin(az)  # one step towards the sun in (row, col)
    rise = cell * np.tan(np.radians(90.0 - zenith))  # sun-line rise per step
    rows, cols = z.shape
    rr, cc = np.mgrid[0:rows, 0:cols].astype(float)
    shade = np.zeros_like(z, bool)
    n_max = int(np.ceil((z.max() - z.min()) / max(rise, 1e-9))) + 1
    for k in range(1, min(n_max, 4 * max(rows, cols)) + 1):
        r = np.rint(rr + k * dr).astype(int)
        c = np.rint(cc + k * dc).astype(int)
        inside = (r >= 0) & (r < rows) & (c >= 0) & (c < cols)
        zz = np.where(inside, z[np.clip(r, 0, rows - 1), np.clip(c, 0, cols - 1)], -np.inf)
        shade |= zz > z + k * rise
    return shade.reshape(dsm.shape[0], sub, dsm.shape[1], sub).mean((1, 3))


def _sky_view(dsm, gsd, reach=12):
    """Sky-view factor: mean over 8 directions of cos² of the horizon elevation."""
    svf = np.zeros_like(dsm)
    for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)):
        best = np.zeros_like(dsm)
        for k in range(1, reach + 1):
            shifted = np.roll(dsm, (-dr * k, -dc * k), axis=(0, 1))
            dist = k * gsd * np.hypot(dr, dc)
            best = np.maximum(best, np.arctan(np.maximum(shifted - dsm, 0) / dist))
        svf += np.cos(best) ** 2
    return svf / 8


def simulate2(
    rows=128,
    cols=160,
    seed=0,
    *,
    gsd=1.0,
    sun_zenith=35.0,
    sun_azimuth=150.0,
    aot500=0.2,
    relief_m=0.0,
    buildings=10,
    trees=12,
    squint_deg=0.0,
    offset_px=(0.6, 0.3),
    vnir_dark=120.0,
    swir_dark=900.0,
    vnir_gain=1.0,
    swir_gain=1.0,
    adjacency=0.5,
    noise=True,
    target_abundance=None,
    target_reflectance=0.30,
    cast_shadows=True,
) -> Scene2:
    """One scene. Azimuth clockwise from north (row 0) towards the sun; offsets in pixels.

    ``target_abundance`` (rows, cols), optional: sub-pixel targets of flat reflectance
    ``target_reflectance`` mixed linearly into each pixel's reflectance with that fill
    fraction, before illumination and the sensors (the SWIR sees them through its offset).

    ``cast_shadows`` False: the scene's sunlit twin (no cast shadow; the same layout, spectra,
    sky view and adjacency light; the noise and the SWIR's dark pattern are other draws, as
    the Poisson draws use the generator differently, so take its dark levels from its own
    truth): each shadowed pixel's own sunlit signal, the reference a de-shadowing is checked
    against."""
    rng = np.random.default_rng(seed)
    dsm, mat, terrain = _layout(rng, rows, cols, relief_m, buildings, trees)
    spectra = material_spectra(rng)
    refl = np.zeros((FINE.size, rows, cols), np.float32)
    bright = 1.0 + 0.06 * ndimage.gaussian_filter(rng.standard_normal((rows, cols)), 1.5) * 3
    for k, s in spectra.items():
        m = mat == k
        refl[:, m] = s[:, None] * bright[m][None, :]
    if target_abundance is not None:
        a = np.asarray(target_abundance, np.float32)[None]
        refl = (1 - a) * refl + a * np.float32(target_reflectance)
    shadow = _cast(dsm, gsd, sun_zenith, sun_azimuth) if cast_shadows else np.zeros(dsm.shape)
    svf = _sky_view(dsm, gsd)
    # self-shading of terrain slopes (cos i / cos z), roofs flat
    gy, gx = np.gradient(terrain, gsd)
    az, zen = np.radians(sun_azimuth), np.radians(sun_zenith)
    sun = np.array([np.sin(zen) * np.sin(az), np.sin(zen) * np.cos(az), np.cos(zen)])
    nrm = np.stack([-gx, gy, np.ones_like(gx)]) / np.sqrt(gx**2 + gy**2 + 1)
    cos_i = np.clip(np.tensordot(sun, nrm, 1), 0, None) / np.cos(zen)
    direct, diffuse = spctral2(FINE, sun_zenith, aot500=aot500)
    e_dir = direct * np.cos(zen)  # on a horizontal surface
    lit = (1 - shadow) * cos_i
    env = ndimage.uniform_filter(refl.mean(0), 15)  # surroundings' mean reflectance
    e = (
        e_dir[:, None, None] * lit[None]
        + diffuse[:, None, None] * svf[None]
        + adjacency * env[None] * (e_dir + diffuse)[:, None, None] * (1 - svf)[None]
    )
    radiance = refl * e / np.pi + (0.03 * diffuse / np.pi)[:, None, None]

    vnir_nm = np.arange(400.0, 1001.0, 6.0)
    swir_nm = np.arange(960.0, 2501.0, 12.0)
    # relative spectral responses: silicon (falling beyond 800 nm) and MCT (cut-on < 1,100 nm)
    r_v = np.interp(vnir_nm, [400, 500, 650, 800, 900, 1000], [0.3, 0.8, 1.0, 0.75, 0.4, 0.12])
    r_s = np.interp(swir_nm, [960, 1000, 1050, 1150, 2200, 2500], [0.05, 0.1, 0.4, 1.0, 1.0, 0.5])

    def sensor(nm, fwhm, resp, gain, dark, shift, e_per_dn, read, psf):
        bm = band_matrix(nm, np.full(nm.size, fwhm))
        L = np.tensordot(bm, radiance, 1)
        if shift is not None:
            dy, dx = shift
            yy, xx = np.mgrid[0:rows, 0:cols].astype(float)
            coords = np.stack([yy - dy, xx - dx])
            L = np.stack([ndimage.map_coordinates(b, coords, order=1, mode="nearest") for b in L])
        L = ndimage.gaussian_filter(L, (0, psf, psf))
        signal = gain * resp[:, None, None] * L
        d = dark * (1 + 0.03 * rng.standard_normal(nm.size))  # band-to-band dark pattern
        if noise:
            signal = rng.poisson(np.maximum(signal, 0) * e_per_dn) / e_per_dn
            signal = signal + read * rng.standard_normal(signal.shape)
        dn = np.clip(np.rint(signal + d[:, None, None]), 0, 2**14 - 1).astype(np.uint16)
        return dn, d

    parallax = terrain * np.tan(np.radians(squint_deg)) / gsd  # relief parallax (px)
    vnir, dv = sensor(vnir_nm, 6.0, r_v, 30000.0 * vnir_gain, vnir_dark, None, 8.0, 4.0, 0.4)
    swir, ds = sensor(
        swir_nm,
        12.0,
        r_s,
        90000.0 * swir_gain,
        swir_dark,
        (offset_px[0] + parallax, offset_px[1]),
        20.0,
        8.0,
        0.5,
    )
    truth = {
        "model": "validation/scene_model2.py",
        "seed": seed,
        "gsd_m": gsd,
        "sun": {"zenith_deg": sun_zenith, "azimuth_deg": sun_azimuth},
        "aot500": aot500,
        "relief_m": float(np.ptp(terrain)),
        "squint_deg": squint_deg,
        "disparity_px_per_m": float(np.tan(np.radians(squint_deg)) / gsd),
        "offset_px": list(offset_px),
        "vnir_dark_dn": dv.round(2).tolist(),
        "swir_dark_dn": ds.round(2).tolist(),
        "materials": MATERIALS,
        "adjacency": adjacency,
    }
    return Scene2(vnir, swir, vnir_nm, swir_nm, dsm, mat, shadow, truth)


# --------------------------------------------------------------------------------- writing


def _write_envi(path, cube, nm, description):
    bands, rows, cols = cube.shape
    cube.astype("<u2").tofile(path + ".img")
    with open(path + ".hdr", "w", encoding="utf-8") as f:
        f.write(
            "ENVI\n"
            f"description = {{{description}}}\n"
            f"samples = {cols}\nlines = {rows}\nbands = {bands}\n"
            "header offset = 0\nfile type = ENVI Standard\ndata type = 12\n"
            "interleave = bsq\nbyte order = 0\n"
            "wavelength units = Nanometers\n"
            "wavelength = {" + ", ".join(f"{w:.1f}" for w in nm) + "}\n"
        )


def _write_tif(path, array, dtype):
    import rasterio

    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=array.shape[1],
        height=array.shape[0],
        count=1,
        dtype=dtype,
    ) as dst:
        dst.write(array.astype(dtype), 1)


def write_scene2(scene: Scene2, folder: str) -> dict:
    """vnir.img/.hdr, swir.img/.hdr (ENVI BSQ uint16), truth_shadow_fraction.tif,
    truth_dsm.tif, truth_material.tif and truth.json in ``folder`` (created)."""
    os.makedirs(folder, exist_ok=False)
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    _write_envi(j("vnir"), scene.vnir, scene.vnir_nm, "scene model 2 VNIR DN")
    _write_envi(j("swir"), scene.swir, scene.swir_nm, "scene model 2 SWIR DN")
    _write_tif(j("truth_shadow_fraction.tif"), scene.shadow_fraction, "float32")
    _write_tif(j("truth_dsm.tif"), scene.dsm, "float32")
    _write_tif(j("truth_material.tif"), scene.material, "uint8")
    with open(j("truth.json"), "w", encoding="utf-8") as f:
        json.dump(scene.truth, f, indent=1)
    return {n: j(n) for n in ("vnir.hdr", "swir.hdr", "truth_shadow_fraction.tif", "truth_dsm.tif")}
