"""Simulating a dual pushbroom scene (:func:`simulate_scene`) and writing it (:func:`write_scene`).

The simulation runs in along-track blocks of lines, so memory is bounded by a block:

1. the surface (:mod:`.surface`) is rasterised on a fine grid (a third of a pixel) covering the
   block's footprints, plus the up-sun margin whose objects can cast shadows into it;
2. sun geometry on the fine grid (:mod:`.shadow`): cos i, cast shadows, sky view, cloud shadows;
3. each instrument's pixels are sampled by ``supersample²`` rays spread over the pixel's
   IFOV and line period, intersected with the DSM (:mod:`.geometry`); at each hit the material
   fractions and illumination are interpolated from the fine grid;
4. per pixel and material: the mean direct-light and sky-light coefficients, times the
   sub-material brightness factor of each ray's ground cell (the texture within a material,
   :data:`.presets.TEXTURE`; it scales the signal, not the truth abundances); sub-pixel targets
   replace a fraction of the pixel exactly (footprint ∩ target rectangle); clouds above the
   ground are seen at each instrument's own footprint on the cloud layer;
5. the instrument PSF blurs the coefficient images; radiance per band follows from the
   material spectra and the atmosphere (:mod:`.atmosphere`):
   ``L = T_up/π · Σ_m (D_m ρ_m E_dir + F_m ρ_m E_sky) + L_path``;
6. the detectors turn radiance into noisy 12-bit DN (:mod:`.sensor`).

The truth rasters are computed from the VNIR rays of step 3 (box footprint, no PSF).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from ..errors import OutputError, ParameterError
from ..progress import Progress, as_progress
from . import presets as _presets
from .atmosphere import illumination
from .geometry import COLS, IFOV_MRAD, Geometry, Heights, Instrument, intersect
from .sensor import SWIR, VNIR
from .shadow import cast_shadow, incidence, sky_view, sun_vector
from .spectra import MATERIAL_IDS, MATERIALS, aisa_dual_bands, band_average, material_spectrum
from .surface import Surface, Window, smooth_field

#: The paper's targets: 24 gray plastic bags of 35 × 55 cm (section 3.3).
BAG_SIZE_M = (0.35, 0.55)
BLOCK_LINES = 96
NOISE_BLOCK_LINES = 256
OPEN_GROUND = ("grass", "soil", "dark_soil", "sand", "dry_vegetation")


@dataclass(frozen=True)
class Scene:
    """A simulated AISA-Dual scene in raw geometry, with its ground truth.

    ``vnir``/``swir``: (bands, lines, 286) uint16 DN, SWIR co-registered to VNIR by the vendor
    shift for the nominal altitude (so a residual offset and relief parallax remain).
    Truth arrays are on the VNIR pixel grid: ``dsm`` (m above the lowest ground, z = 0),
    ``shadow_fraction`` (0–1, part of the footprint in cast shadow or self-shade from the direct
    sun, cloud shadows included), ``target_abundance`` (0–1), ``cloud_mask``, ``material``
    (dominant material id, names in ``material_names``), ``abundances`` (per material,
    ``abundance_names``; they sum to 1 with the target and cloud layers), and
    ``endmember_spectra`` (name → reflectance at the 198 band centres). ``truth`` is what
    ``truth.json`` holds.
    """

    vnir: np.ndarray
    swir: np.ndarray
    vnir_wavelengths: np.ndarray
    swir_wavelengths: np.ndarray
    vnir_fwhm: np.ndarray
    swir_fwhm: np.ndarray
    dsm: np.ndarray
    shadow_fraction: np.ndarray
    target_abundance: np.ndarray
    cloud_mask: np.ndarray
    material: np.ndarray
    material_names: dict
    abundances: np.ndarray
    abundance_names: tuple
    endmember_spectra: dict
    truth: dict = field(repr=False)

    @property
    def wavelengths(self) -> np.ndarray:
        return np.concatenate([self.vnir_wavelengths, self.swir_wavelengths])

    @property
    def fwhm(self) -> np.ndarray:
        return np.concatenate([self.vnir_fwhm, self.swir_fwhm])

    @property
    def lines(self) -> int:
        return self.vnir.shape[1]

    def reflectance(self) -> np.ndarray:
        """(198, lines, cols) true surface reflectance of each VNIR footprint (linear mixture)."""
        spectra = np.stack([self.endmember_spectra[n] for n in self.abundance_names])
        return np.einsum("kb,klc->blc", spectra, self.abundances).astype("float32")


def _geometry(geometry, squint_deg, flying_height, nominal_altitude, line_spacing, bore_v, bore_s):
    if geometry not in _presets.GEOMETRIES:
        raise ParameterError(
            f"parameter 'geometry': {geometry!r} is not one of {', '.join(_presets.GEOMETRIES)}"
        )
    g = _presets.GEOMETRIES[geometry]
    squint = g["squint_deg"] if squint_deg is None else float(squint_deg)
    H = g["flying_height"] if flying_height is None else float(flying_height)
    Hn = nominal_altitude if nominal_altitude is not None else g["nominal_altitude"]
    Hn = H if Hn is None else float(Hn)
    if not 100.0 <= H <= 10000.0:
        raise ParameterError(f"parameter 'flying_height': {H} m is outside 100–10,000 m")
    if abs(squint) > 10:
        raise ParameterError(f"parameter 'squint_deg': {squint}° is outside ±10°")
    spacing = H * IFOV_MRAD * 1e-3 if line_spacing is None else float(line_spacing)
    bv = tuple(bore_v) if bore_v is not None else (0.0, 0.0, 0.0)
    bs = tuple(bore_s) if bore_s is not None else (0.0, bv[1] + squint, 0.0)
    return Geometry(
        flying_height_m=H,
        nominal_altitude_m=Hn,
        vnir=Instrument(*bv),
        swir=Instrument(*bs),
        line_spacing_m=spacing,
    )


def _bilinear(maps: np.ndarray, win: Window, x, y) -> np.ndarray:
    """Sample (K, ny, nx) maps at points (x, y): (K, n), bilinear, edges clamped."""
    i, j = win.ij(x, y)
    i = np.clip(i, 0, win.ny - 1.000001)
    j = np.clip(j, 0, win.nx - 1.000001)
    i0 = np.floor(i).astype(np.intp)
    j0 = np.floor(j).astype(np.intp)
    fi = (i - i0).astype("float32")
    fj = (j - j0).astype("float32")
    flat = maps.reshape(maps.shape[0], -1)
    k00 = i0 * win.nx + j0
    out = flat[:, k00] * ((1 - fi) * (1 - fj))
    out += flat[:, k00 + 1] * ((1 - fi) * fj)
    out += flat[:, k00 + win.nx] * (fi * (1 - fj))
    out += flat[:, k00 + win.nx + 1] * (fi * fj)
    return out


def _clouds(rng, extent, image_area, count, cell=4.0):
    """Cloud opacity field (0–1) on a coarse grid over ``extent``: ``count`` fractal blobs."""
    x0, x1, y0, y1 = extent
    nx, ny = int((x1 - x0) / cell) + 2, int((y1 - y0) / cell) + 2
    Y, X = np.mgrid[0:ny, 0:nx] * cell
    X, Y = X + x0, Y + y0
    opacity = np.zeros((ny, nx))
    texture = smooth_field(rng, (ny, nx), 2.5)
    for _ in range(count):
        cx, cy = rng.uniform(*image_area[:2]), rng.uniform(*image_area[2:])
        rx, ry = rng.uniform(25, 70), rng.uniform(25, 70)
        d = np.sqrt(((X - cx) / rx) ** 2 + ((Y - cy) / ry) ** 2)
        opacity = np.maximum(opacity, np.clip(2.5 * (1 - d) + 0.4 * texture, 0, 1))
    return Window(x0 - 0.5 * cell, y0 - 0.5 * cell, nx, ny, cell), opacity.astype("float32")


def simulate_scene(
    preset: str = "urban",
    lines: int = 128,
    seed: int = 0,
    *,
    geometry: str = "realistic",
    squint_deg: float | None = None,
    flying_height: float | None = None,
    nominal_altitude: float | None = None,
    line_spacing: float | None = None,
    boresight_vnir_deg=None,
    boresight_swir_deg=None,
    sun_zenith: float | None = None,
    sun_azimuth: float | None = None,
    targets: int | None = None,
    clouds: int = 0,
    cloud_height: float | None = None,
    aot550: float = 0.15,
    water_vapour_cm: float = 2.0,
    noise: bool = True,
    supersample: int = 3,
    surface: Surface | None = None,
    texture: bool = True,
    progress: Progress | None = None,
) -> Scene:
    """Simulate a VNIR + SWIR pushbroom scene with its ground truth.

    Parameters
    ----------
    preset : {"urban", "dunes", "glade", "mixed"}
        The surface (see :mod:`.presets`); ignored for the surface when ``surface`` is given,
        but still sets the default sun angles and target count.
    lines : int
        Along-track lines (286 across-track pixels each).
    seed : int
        Seed of every random choice (surface, targets, clouds, noise): same seed, same scene.
    geometry : {"realistic", "large-squint"}
        Flight and squint defaults (see :mod:`.presets`); ``squint_deg``, ``flying_height``,
        ``nominal_altitude`` (m; the vendor's co-registration altitude) and ``line_spacing``
        (m, default = flying height × IFOV) override them. ``boresight_*_deg`` give full
        (roll, pitch, yaw) angles per instrument instead of the squint.
    sun_zenith, sun_azimuth : float
        Degrees; azimuth clockwise from the flight direction. Defaults from the paper's scenes.
    targets : int
        Number of sub-pixel gray plastic bags (35 × 55 cm) on open ground.
    clouds : int
        Number of cloud blobs at ``cloud_height`` (m above ground, default 40 % of the flying
        height), seen with each instrument's parallax and casting shadows.
    aot550, water_vapour_cm : float
        Aerosol optical depth at 550 nm and water-vapour column.
    noise : bool
        False gives noise-free, unquantised DN (float32): for tests and planning.
    supersample : int
        Rays per pixel side (footprint integration and sub-pixel shadow fraction).
    surface : Surface
        A custom surface instead of the preset's (its own ``brightness`` fields, if any, are
        used; ``texture`` does not add any).
    texture : bool
        Give a preset's materials their sub-material brightness texture (soil moisture and
        stones, grass density, sand patches, stains; :data:`.presets.TEXTURE`, drawn from
        its own generator so the scene's layout is the same either way). False gives
        uniform materials (each exactly its library spectrum): for tests and comparisons.
    """
    if preset not in _presets.SCENES:
        raise ParameterError(
            f"parameter 'preset': {preset!r} is not one of {', '.join(_presets.SCENES)}"
        )
    lines = int(lines)
    if lines < 8:
        raise ParameterError(f"parameter 'lines': {lines} is too few; simulate at least 8 lines")
    progress = as_progress(progress)
    geo = _geometry(
        geometry,
        squint_deg,
        flying_height,
        nominal_altitude,
        line_spacing,
        boresight_vnir_deg,
        boresight_swir_deg,
    )
    zen = _presets.SUN[preset][0] if sun_zenith is None else float(sun_zenith)
    azi = _presets.SUN[preset][1] if sun_azimuth is None else float(sun_azimuth)
    if not 0.0 <= zen < 85.0:
        raise ParameterError(f"parameter 'sun_zenith': {zen}° is outside 0–85°")
    n_targets = _presets.DEFAULT_TARGETS[preset] if targets is None else int(targets)
    H = geo.flying_height_m
    z_cloud = 0.4 * H if cloud_height is None else float(cloud_height)
    sub = int(supersample)
    rng = np.random.default_rng(seed)

    # The world: every ray's ground point, for heights up to a generous bound, plus margins.
    z_bound = 100.0
    tan_z = np.tan(np.radians(zen))
    sun = sun_vector(zen, azi)
    shadow_reach = min(z_bound * tan_z, 400.0)
    ext = []
    for inst in ("vnir", "swir"):
        t, u, v = geo.rays(inst, np.array([0, lines - 1]), np.array([0, COLS - 1]), 1)
        for z in (0.0, z_bound):
            ext.append(((H - z) * u, t * geo.line_spacing_m + (H - z) * v))
    xs = np.concatenate([e[0].ravel() for e in ext])
    ys = np.concatenate([e[1].ravel() for e in ext])
    pad = 10.0 + geo.line_spacing_m * 2
    # Objects up to shadow_reach away (any direction) may cast shadows into the image.
    extent = (
        xs.min() - pad - shadow_reach,
        xs.max() + pad + shadow_reach,
        ys.min() - pad - shadow_reach,
        ys.max() + pad + shadow_reach,
    )
    if surface is None:
        surface = _presets.BUILDERS[preset](
            rng, extent, core=(xs.min(), xs.max(), ys.min(), ys.max())
        )
        if texture:
            surface = _presets.add_texture(surface, np.random.default_rng([seed, 303]))
    progress.update(0.05, "surface built")

    names = list(surface.materials)
    if n_targets:
        names.append("plastic_bag")
    K = len(names)
    # Cloud centres over the image as seen at the cloud layer (the swath narrows with height).
    shrink = (H - z_cloud) / H
    image_area = (xs.min() * shrink, xs.max() * shrink, ys.min(), ys.max())
    cloud_win, cloud_op = _clouds(rng, extent, image_area, int(clouds)) if clouds else (None, None)

    # Spectra and atmosphere at the band set.
    vwl, vfw, swl, sfw = aisa_dual_bands()
    all_wl, all_fw = np.concatenate([vwl, swl]), np.concatenate([vfw, sfw])
    spectra = {n: band_average(material_spectrum(n), all_wl, all_fw) for n in names}
    spectra["cloud"] = band_average(material_spectrum("cloud"), all_wl, all_fw)
    ill = illumination(all_wl, all_fw, zen, H, aot550=aot550, water_cm=water_vapour_cm)

    cell = geo.gsd_m / 3.0
    z_top = surface.max_height() + 0.5
    cos_z = float(np.cos(np.radians(zen)))
    acc = {
        inst: {
            "D": np.zeros((K, lines, COLS), "float32"),
            "F": np.zeros((K, lines, COLS), "float32"),
            "Dc": np.zeros((lines, COLS), "float32"),
            "Fc": np.zeros((lines, COLS), "float32"),
            "Du": np.zeros((lines, COLS), "float32"),  # D and F of a factor-1 surface
            "Fu": np.zeros((lines, COLS), "float32"),
            "x": np.zeros((lines, COLS), "float64"),
            "y": np.zeros((lines, COLS), "float64"),
        }
        for inst in ("vnir", "swir")
    }
    truth_a = np.zeros((K, lines, COLS), "float32")
    truth_shadow = np.zeros((lines, COLS), "float32")
    truth_z = np.zeros((lines, COLS), "float32")
    truth_cloud = np.zeros((lines, COLS), "float32")
    cols = np.arange(COLS)
    nblocks = -(-lines // BLOCK_LINES)
    for b in range(nblocks):
        l0, l1 = b * BLOCK_LINES, min((b + 1) * BLOCK_LINES, lines)
        blk = np.arange(l0, l1)
        rays = {inst: geo.rays(inst, blk, cols, sub) for inst in ("vnir", "swir")}
        # Fine window: all rays of the block at z in [0, z_top], plus the up-sun margin.
        px, py = [], []
        for t, u, v in rays.values():
            for z in (0.0, z_top):
                px.append(((H - z) * u).ravel())
                py.append((t * geo.line_spacing_m + (H - z) * v).ravel())
        px, py = np.concatenate(px), np.concatenate(py)
        reach = min(z_top * tan_z, 400.0)
        m = 3 * cell
        # Extend the window towards the sun: objects there cast shadows into the block.
        wx0 = px.min() - m - reach * (sun[0] < 0)
        wx1 = px.max() + m + reach * (sun[0] > 0)
        wy0 = py.min() - m - reach * (sun[1] < 0)
        wy1 = py.max() + m + reach * (sun[1] > 0)
        win = Window(
            wx0, wy0, int(np.ceil((wx1 - wx0) / cell)), int(np.ceil((wy1 - wy0) / cell)), cell
        )
        dsm, frac, ground_z = surface.rasterize(win, names[: K - 1] if n_targets else names)
        heights = Heights(ground_z, dsm, win)
        if n_targets:
            frac = np.concatenate([frac, np.zeros((1, *dsm.shape), "float32")])
        cos_i = incidence(dsm, cell, zen, azi, ground_z)
        lit = (~cast_shadow(dsm, cell, zen, azi)) & (cos_i > 0)
        if cloud_op is not None:
            gx, gy = win.xy(np.arange(win.ny)[:, None], np.arange(win.nx)[None, :])
            d = np.clip(z_cloud - dsm, 0, None) * tan_z / max(np.hypot(*sun[:2]), 1e-9)
            cx = gx + d * sun[0]
            cy = gy + d * sun[1]
            c_sh = _bilinear(cloud_op[None], cloud_win, cx.ravel(), cy.ravel())[0].reshape(
                dsm.shape
            )
            sunlit = lit * (1.0 - c_sh)
        else:
            sunlit = lit.astype("float32")
        direct = (np.clip(cos_i, 0, None) * sunlit).astype("float32")
        sky = sky_view(dsm, cell, ground_z).astype("float32")
        bright = surface.brightness_on(win, frac, names)
        maps = np.concatenate(
            [
                frac,
                direct[None],
                sky[None],
                (1.0 - sunlit)[None].astype("float32"),
                bright[None],
            ]
        )
        del bright
        z_lo = float(dsm.min()) - 0.01
        z_hi = float(dsm.max()) + 0.01
        for inst, (t, u, v) in rays.items():
            tt, uu, vv = t.ravel(), u.ravel(), v.ravel()
            x, y, z = intersect(tt, uu, vv, geo, heights, z_lo, z_hi)
            s = _bilinear(maps, win, x, y)
            fr, di, sk = s[:K], s[K], s[K + 1]
            if cloud_op is not None:
                c = _bilinear(
                    cloud_op[None],
                    cloud_win,
                    (H - z_cloud) * uu,
                    tt * geo.line_spacing_m + (H - z_cloud) * vv,
                )[0]
            else:
                c = np.zeros_like(di)
            shape = (K, l1 - l0, COLS, sub * sub)
            a = acc[inst]
            ground = 1.0 - c
            br = s[K + 3]
            a["D"][:, l0:l1] = (fr * (di * ground * br)).reshape(shape).mean(-1)
            a["F"][:, l0:l1] = (fr * (sk * ground * br)).reshape(shape).mean(-1)
            a["Du"][l0:l1] = (di * ground).reshape(shape[1:]).mean(-1)
            a["Fu"][l0:l1] = (sk * ground).reshape(shape[1:]).mean(-1)
            a["Dc"][l0:l1] = (c * cos_z).reshape(shape[1:]).mean(-1)
            a["Fc"][l0:l1] = c.reshape(shape[1:]).mean(-1)
            a["x"][l0:l1] = x.reshape(shape[1:]).mean(-1)
            a["y"][l0:l1] = y.reshape(shape[1:]).mean(-1)
            if inst == "vnir":
                truth_a[:, l0:l1] = fr.reshape(shape).mean(-1)
                truth_shadow[l0:l1] = s[K + 2].reshape(shape[1:]).mean(-1)
                truth_z[l0:l1] = z.reshape(shape[1:]).mean(-1)
                truth_cloud[l0:l1] = c.reshape(shape[1:]).mean(-1)
        progress.update(0.05 + 0.6 * (b + 1) / nblocks, f"ray-traced lines {l0}-{l1 - 1}")

    # Sub-pixel targets: exact footprint ∩ bag rectangle, for each instrument's pixels.
    target_list = []
    truth_target = np.zeros((lines, COLS), "float32")
    if n_targets:
        target_list = _place_targets(
            rng,
            n_targets,
            names,
            truth_a,
            truth_shadow,
            truth_z,
            truth_cloud,
            acc["vnir"],
        )
        if len(target_list) < n_targets:
            progress.info(
                f"only {len(target_list)} of {n_targets} targets fit on open, flat, sunlit ground "
                "at least 6 pixels apart: simulate more lines for more targets"
            )
        k = names.index("plastic_bag")
        for inst in ("vnir", "swir"):
            a = acc[inst]
            cover = _target_cover(target_list, a["x"], a["y"], geo)
            # The bag has its own reflectance: the ground's texture does not apply to it.
            total_d = a["Du"]
            total_f = a["Fu"]
            a["D"] *= 1.0 - cover
            a["F"] *= 1.0 - cover
            a["D"][k] += cover * total_d
            a["F"][k] += cover * total_f
            if inst == "vnir":
                truth_target = cover.astype("float32")
                for t in target_list:
                    t["abundance"] = float(cover[t["row"], t["col"]])
                truth_a *= 1.0 - cover
                truth_a[k] += cover
    # Radiance and DN, blockwise over lines, per instrument.
    out = {}
    spec = np.stack([spectra[n] for n in names])  # (K, 198)
    nv = len(vwl)
    for n_inst, (inst, det, sl) in enumerate(
        (("vnir", VNIR, slice(0, nv)), ("swir", SWIR, slice(nv, None)))
    ):
        a = acc[inst]
        sig = det.psf_sigma_px
        for key in ("D", "F"):
            a[key] = ndimage.gaussian_filter(a[key], (0, sig, sig), mode="nearest")
        for key in ("Dc", "Fc"):
            a[key] = ndimage.gaussian_filter(a[key], sig, mode="nearest")
        e_dir = ill.direct[sl]
        e_sky = ill.diffuse[sl]
        rho = spec[:, sl]
        rho_c = spectra["cloud"][sl]
        nrng = np.random.default_rng([seed, 101 + n_inst]) if noise else None
        cube = np.zeros((rho.shape[1], lines, COLS), "uint16" if noise else "float32")
        for l0 in range(0, lines, NOISE_BLOCK_LINES):
            l1 = min(l0 + NOISE_BLOCK_LINES, lines)
            rad = np.einsum("kb,klc->blc", rho * e_dir, a["D"][:, l0:l1])
            rad += np.einsum("kb,klc->blc", rho * e_sky, a["F"][:, l0:l1])
            rad += (rho_c * e_dir)[:, None, None] * a["Dc"][None, l0:l1]
            rad += (rho_c * e_sky)[:, None, None] * a["Fc"][None, l0:l1]
            rad = rad * (ill.t_up[sl] / np.pi)[:, None, None] + ill.path[sl][:, None, None]
            cube[:, l0:l1] = det.to_dn(rad.astype("float32"), all_wl[sl], nrng)
        out[inst] = cube
    progress.update(0.95, "radiometry done")

    material_ids = np.array([MATERIAL_IDS[n] for n in names], "uint8")
    material = material_ids[np.argmax(truth_a[: K - 1] if n_targets else truth_a, axis=0)]
    used = sorted(set(np.unique(material).tolist()) | {int(i) for i in material_ids})
    material_names = {int(i): MATERIALS[int(i)] for i in used}
    cloud_mask = truth_cloud > 0.5
    abundances = np.concatenate([truth_a * (1 - truth_cloud), truth_cloud[None]])
    ab_names = (*names, "cloud")
    truth = _truth_dict(
        preset,
        seed,
        lines,
        geo,
        zen,
        azi,
        material_names,
        target_list,
        noise,
        aot550,
        water_vapour_cm,
        clouds,
        z_cloud,
        supersample,
        geometry,
    )
    endmembers = {n: spectra[n].astype("float64") for n in ab_names}
    return Scene(
        vnir=out["vnir"],
        swir=out["swir"],
        vnir_wavelengths=vwl,
        swir_wavelengths=swl,
        vnir_fwhm=vfw,
        swir_fwhm=sfw,
        dsm=np.maximum(truth_z, 0.0),  # bisection leaves < 1 cm; heights are >= 0
        shadow_fraction=np.clip(truth_shadow, 0, 1),
        target_abundance=np.clip(truth_target, 0, 1),
        cloud_mask=cloud_mask,
        material=material,
        material_names=material_names,
        abundances=np.clip(abundances, 0, 1).astype("float32"),
        abundance_names=ab_names,
        endmember_spectra=endmembers,
        truth=truth,
    )


def _place_targets(rng, n, names, ab, shadow, z, cloud, vnir_acc):
    """Bags at VNIR pixel centres on open, sunlit, flat ground, at least 6 px apart."""
    open_ids = [names.index(m) for m in OPEN_GROUND if m in names]
    openness = ab[open_ids].sum(0) if open_ids else np.zeros(shadow.shape)
    ok = (openness > 0.99) & (shadow < 0.01) & (cloud < 0.01)
    # Flat: no height change within 3 pixels (no building or tree nearby).
    zmax = ndimage.maximum_filter(z, 7)
    zmin = ndimage.minimum_filter(z, 7)
    ok &= (zmax - zmin) < 2.0
    ok[:4] = ok[-4:] = False
    ok[:, :4] = ok[:, -4:] = False
    rows, cols = np.nonzero(ok)
    order = rng.permutation(len(rows))
    chosen = []
    for k in order:
        r, c = rows[k], cols[k]
        if all(max(abs(r - r2), abs(c - c2)) >= 6 for r2, c2 in chosen):
            chosen.append((int(r), int(c)))
        if len(chosen) == n:
            break
    out = []
    for r, c in chosen:
        out.append(
            {
                "row": r,
                "col": c,
                "x_m": float(vnir_acc["x"][r, c]),
                "y_m": float(vnir_acc["y"][r, c]),
                "size_m": list(BAG_SIZE_M),
                "material": "plastic_bag",
            }
        )
    return out


def _target_cover(targets, x, y, geo: Geometry) -> np.ndarray:
    """Fraction of each pixel's footprint covered by the bags (rectangle overlap)."""
    cover = np.zeros(x.shape, "float64")
    lines, cols = x.shape
    for t in targets:
        bx0, bx1 = t["x_m"] - BAG_SIZE_M[0] / 2, t["x_m"] + BAG_SIZE_M[0] / 2
        by0, by1 = t["y_m"] - BAG_SIZE_M[1] / 2, t["y_m"] + BAG_SIZE_M[1] / 2
        # Pixels whose footprint centres are near the bag.
        d = (x - t["x_m"]) ** 2 + (y - t["y_m"]) ** 2
        r, c = np.unravel_index(np.argmin(d), d.shape)
        r0, r1 = max(r - 3, 0), min(r + 4, lines)
        c0, c1 = max(c - 3, 0), min(c + 4, cols)
        px, py = x[r0:r1, c0:c1], y[r0:r1, c0:c1]
        # Footprint size from the neighbouring pixel centres (box = one pixel pitch).
        wx = np.gradient(x, axis=1)[r0:r1, c0:c1]
        wy = np.gradient(y, axis=0)[r0:r1, c0:c1]
        ox = np.clip(np.minimum(px + wx / 2, bx1) - np.maximum(px - wx / 2, bx0), 0, None)
        oy = np.clip(np.minimum(py + wy / 2, by1) - np.maximum(py - wy / 2, by0), 0, None)
        cover[r0:r1, c0:c1] += ox * oy / (wx * wy)
    return np.clip(cover, 0, 1)


def _truth_dict(
    preset,
    seed,
    lines,
    geo,
    zen,
    azi,
    material_names,
    targets,
    noise,
    aot,
    wv,
    clouds,
    zc,
    sub,
    geometry,
):
    gt = geo.truth()
    squint = round(float(np.degrees(np.arctan(gt["tan_squint"]))), 9)
    return {
        "preset": preset,
        "geometry": geometry,
        "seed": int(seed),
        "lines": int(lines),
        "cols": COLS,
        "bands": {"vnir": 96, "swir": 102},
        "gsd_m": geo.gsd_m,
        "line_spacing_m": geo.line_spacing_m,
        "ifov_mrad": geo.vnir.ifov_mrad,
        "flying_height_m": geo.flying_height_m,
        "nominal_altitude_m": geo.nominal_altitude_m,
        "squint_deg": squint,
        "boresight_deg": {
            "vnir": [geo.vnir.roll_deg, geo.vnir.pitch_deg, geo.vnir.yaw_deg],
            "swir": [geo.swir.roll_deg, geo.swir.pitch_deg, geo.swir.yaw_deg],
        },
        "vendor_coregistration_px": dict(
            zip(("along", "across"), geo.coregistration(), strict=True)
        ),
        "offset_px": gt["offset_px"],
        "offset_convention": (
            "SWIR relative to VNIR on flat ground at height 0, in VNIR pixels: a feature at "
            "VNIR row r, column c appears at SWIR row r + along, column c + across"
        ),
        "disparity_px_per_m": gt["disparity_px_per_m"],
        "height_precision_m_per_px": gt["height_precision_m_per_px"],
        "sun": {"zenith_deg": zen, "azimuth_deg": azi, "azimuth_reference": "flight direction"},
        "atmosphere": {"aot550": aot, "water_vapour_cm": wv},
        "materials": {str(k): v for k, v in material_names.items()},
        "targets": targets,
        "clouds": {"count": int(clouds), "height_m": zc if clouds else None},
        "noise": {
            "enabled": bool(noise),
            "vnir": {
                "dark_dn": VNIR.dark_dn,
                "gain": VNIR.gain,
                "electrons_per_dn": VNIR.electrons_per_dn,
                "read_noise_dn": VNIR.read_noise_dn,
                "psf_sigma_px": VNIR.psf_sigma_px,
            },
            "swir": {
                "dark_dn": SWIR.dark_dn,
                "gain": SWIR.gain,
                "electrons_per_dn": SWIR.electrons_per_dn,
                "read_noise_dn": SWIR.read_noise_dn,
                "psf_sigma_px": SWIR.psf_sigma_px,
            },
            "bits": 12,
        },
        "supersample": int(sub),
        "heights": "metres above the lowest ground of the simulated area (z = 0)",
    }


#: Colours of the material classes in truth_material.tif (QGIS shows the colour table).
MATERIAL_COLOURS = {
    0: (0, 0, 0, 0),
    1: (60, 60, 60, 255),
    2: (190, 190, 180, 255),
    3: (140, 70, 50, 255),
    4: (200, 110, 70, 255),
    5: (150, 170, 200, 255),
    6: (160, 120, 80, 255),
    7: (100, 75, 50, 255),
    8: (230, 210, 150, 255),
    9: (120, 190, 80, 255),
    10: (30, 110, 40, 255),
    11: (180, 160, 100, 255),
    12: (150, 140, 130, 255),
    13: (255, 0, 255, 255),
    14: (255, 255, 255, 255),
}

SCENE_FILES = (
    "vnir.img",
    "vnir.hdr",
    "swir.img",
    "swir.hdr",
    "truth_dsm.tif",
    "truth_shadow_fraction.tif",
    "truth_target_abundance.tif",
    "truth_cloud_mask.tif",
    "truth_material.tif",
    "truth.json",
    "endmembers.csv",
)


def write_scene(scene: Scene, folder, merged: bool = False, overwrite: bool = False) -> str:
    """Write a scene to ``folder`` (created; written whole or not at all).

    Files: ``vnir.img/.hdr`` and ``swir.img/.hdr`` (ENVI, BIL, uint16 DN, wavelengths and FWHM
    in nm, raw geometry), optionally ``merged.img/.hdr`` (all 198 bands), the truth rasters
    on the VNIR grid as GeoTIFF (``truth_dsm.tif``, ``truth_shadow_fraction.tif``,
    ``truth_target_abundance.tif``, ``truth_cloud_mask.tif``, ``truth_material.tif`` with a
    colour table and class names in its tags), ``truth.json`` and ``endmembers.csv``
    (``wavelength_nm`` + one reflectance column per material).
    """
    import rasterio

    from ..io import atomic_output, write_envi, write_raster

    folder = os.fspath(folder)
    if os.path.lexists(folder) and not overwrite:
        raise OutputError(
            f"output folder {folder} already exists: choose another folder, or pass "
            "--overwrite (overwrite=True) to replace it"
        )
    parent = os.path.dirname(os.path.abspath(folder))
    if not os.path.isdir(parent):
        raise OutputError(
            f"output folder {folder}: its parent {parent} does not exist; create it first"
        )
    truth = scene.truth
    # The ENVI headers hold wavelengths, FWHM and band names: no redundant .aux.xml sidecars
    # (which GDAL applications would rewrite when they open the scene).
    with atomic_output(folder, overwrite=overwrite) as tmp, rasterio.Env(GDAL_PAM_ENABLED="NO"):
        os.makedirs(tmp)
        vnir, swir = _as_dn(scene.vnir), _as_dn(scene.swir)
        dtype = vnir.dtype
        desc = f"geoboresight simulate preset={truth['preset']} seed={truth['seed']}"
        write_envi(
            os.path.join(tmp, "vnir.img"),
            vnir,
            scene.vnir_wavelengths,
            scene.vnir_fwhm,
            description=desc + " VNIR",
        )
        write_envi(
            os.path.join(tmp, "swir.img"),
            swir,
            scene.swir_wavelengths,
            scene.swir_fwhm,
            description=desc + " SWIR",
        )
        for name in ("vnir", "swir"):
            _fix_envi_description(os.path.join(tmp, name + ".hdr"), f"{desc} {name.upper()}")
        if merged:
            cube = np.concatenate([vnir, swir]).astype(dtype, copy=False)
            write_envi(
                os.path.join(tmp, "merged.img"),
                cube,
                scene.wavelengths,
                scene.fwhm,
                description=desc + " VNIR+SWIR",
            )
            _fix_envi_description(os.path.join(tmp, "merged.hdr"), f"{desc} VNIR+SWIR")
        tags = {
            "preset": truth["preset"],
            "seed": truth["seed"],
            "grid": "VNIR pixel grid (raw geometry)",
        }
        continuous = (
            ("dsm", scene.dsm, "float32", {"units": "m above the lowest ground"}, "dsm_m"),
            ("shadow_fraction", scene.shadow_fraction, "float32", {}, "shadow_fraction"),
            ("target_abundance", scene.target_abundance, "float32", {}, "target_abundance"),
            ("cloud_mask", scene.cloud_mask, "uint8", {}, "cloud_mask"),
        )
        for name, array, dtype, extra, band in continuous:
            write_raster(
                os.path.join(tmp, f"truth_{name}.tif"),
                array.astype(dtype),
                nodata=None,
                dtype=dtype,
                tags={**tags, **extra},
                band_names=[band],
            )
        classes = {f"CLASS_{k}": v for k, v in scene.material_names.items()}
        write_raster(
            os.path.join(tmp, "truth_material.tif"),
            scene.material.astype("uint8"),
            nodata=0,
            dtype="uint8",
            tags={**tags, **classes},
            band_names=["material"],
            band_tags=[classes],
            colormap=MATERIAL_COLOURS,
        )
        with open(os.path.join(tmp, "truth.json"), "w", encoding="utf-8") as f:
            json.dump(truth, f, indent=2, sort_keys=False)
            f.write("\n")
        names = list(scene.abundance_names)
        with open(os.path.join(tmp, "endmembers.csv"), "w", encoding="utf-8", newline="\n") as f:
            f.write(",".join(["wavelength_nm", "fwhm_nm", *names]) + "\n")
            for b, (wl, fw) in enumerate(zip(scene.wavelengths, scene.fwhm, strict=True)):
                vals = [f"{scene.endmember_spectra[n][b]:.6f}" for n in names]
                f.write(",".join([f"{wl:.3f}", f"{fw:.3f}", *vals]) + "\n")
    return folder


def _fix_envi_description(hdr: str, text: str) -> None:
    """Replace GDAL's ENVI ``description`` (the temporary file's path) by ``text``.

    Keeps the header free of machine-specific paths, so that the same seed gives the same bytes.
    """
    import re

    with open(hdr, encoding="utf-8") as f:
        content = f.read()
    content = re.sub(r"description = \{[^}]*\}", "description = {" + text + "}", content, count=1)
    with open(hdr, "w", encoding="utf-8", newline="\n") as f:
        f.write(content)


def _as_dn(cube: np.ndarray) -> np.ndarray:
    """uint16 DN: noise-free (float) cubes are rounded and clipped to 12 bits."""
    if cube.dtype == np.uint16:
        return cube
    return np.clip(np.rint(cube), 0, 4095).astype("uint16")
