"""Physics of the scene simulator, checked against independent truth (not just shapes).

- flat-ground offset between the 920 and 1,010 nm images (phase correlation, written here with
  NumPy FFTs) equals the configured offset; on raised ground it changes by h × disparity/m;
- the truth offset follows (H_nom − H)·tan θ / Δ (computed independently);
- cast shadows agree with a brute-force ray march and with h·tan(zenith) for a box;
- shadowed pixels have a higher b1010/b920 DN ratio than sunlit pixels of the same material;
- abundances, shadow fractions and reflectances stay in their physical ranges;
- the same seed gives the same scene.
"""

from __future__ import annotations

import numpy as np
import pytest

from geoboresight.simulate import Surface, simulate_scene
from geoboresight.simulate.geometry import NOMINAL_ALTITUDE_M
from geoboresight.simulate.scene import BAG_SIZE_M
from geoboresight.simulate.shadow import cast_shadow
from geoboresight.simulate.surface import smooth_field


def _pc_once(ref, moved, search=1.5, step=0.005, cutoff=0.2):
    ny, nx = ref.shape
    win = np.outer(np.hanning(ny), np.hanning(nx))
    a = np.fft.fft2((ref - ref.mean()) * win)
    b = np.fft.fft2((moved - moved.mean()) * win)
    cross = b * np.conj(a)
    cross /= np.abs(cross) + 1e-12
    # Only frequencies below ``cutoff`` cycles/pixel: above it, noise and aliasing dominate.
    f = np.hypot(np.fft.fftfreq(ny)[:, None], np.fft.fftfreq(nx)[None, :])
    cross *= f < cutoff
    corr = np.fft.ifft2(cross).real
    py, px = np.unravel_index(np.argmax(corr), corr.shape)
    py = py - ny if py > ny // 2 else py
    px = px - nx if px > nx // 2 else px
    fy = np.fft.fftfreq(ny)
    fx = np.fft.fftfreq(nx)
    dys = py + np.arange(-search, search + step / 2, step)
    dxs = px + np.arange(-search, search + step / 2, step)
    ey = np.exp(2j * np.pi * np.outer(dys, fy))
    ex = np.exp(2j * np.pi * np.outer(fx, dxs))
    fine = (ey @ cross @ ex).real
    iy, ix = np.unravel_index(np.argmax(fine), fine.shape)
    return float(dys[iy]), float(dxs[ix])


def phase_correlation(ref: np.ndarray, moved: np.ndarray, margin: int = 8, rounds: int = 4):
    """(dy, dx) such that ``moved(y + dy, x + dx) ≈ ref(y, x)``.

    Phase correlation (normalised cross-power spectrum, Hann window, frequencies below 0.2
    cycles/pixel, where the signal dominates noise and aliasing) with the peak refined on
    a 0.005 px grid by a matrix-multiply inverse DFT (Guizar-Sicairos et al. 2008). The window
    pulls the peak towards zero, so ``moved`` is shifted back by the estimate (cubic spline)
    and the residual is measured again, a few rounds.
    """
    from scipy import ndimage

    ref = np.asarray(ref, float)
    moved = np.asarray(moved, float)
    dy = dx = 0.0
    for _ in range(rounds):
        back = ndimage.shift(moved, (-dy, -dx), order=3, mode="nearest")
        my = margin + int(np.ceil(abs(dy)))  # rows filled in by the shift are not data
        mx = margin + int(np.ceil(abs(dx)))
        inner = (slice(my, -my), slice(mx, -mx))
        ry, rx = _pc_once(ref[inner], back[inner])
        dy, dx = dy + ry, dx + rx
        if abs(ry) < 0.002 and abs(rx) < 0.002:
            break
    return dy, dx


def test_phase_correlation_recovers_a_known_subpixel_shift():
    from scipy import ndimage

    big = smooth_field(np.random.default_rng(1), (256, 256), 2.0)
    ref = big[64:192, 64:192]
    for shift in ((2.37, -0.61), (0.3, 0.0), (-11.5, 0.2)):
        moved = ndimage.shift(big, shift, order=3)[64:192, 64:192]
        dy, dx = phase_correlation(ref, moved)
        assert dy == pytest.approx(shift[0], abs=0.02)
        assert dx == pytest.approx(shift[1], abs=0.02)


def textured_flat(height: float = 0.0, seed: int = 5, extent=(-400, 400, -200, 800)) -> Surface:
    """Flat ground at ``height`` m, an asphalt/concrete mixture with contrast at 920 and 1,010 nm."""
    rng = np.random.default_rng(seed)
    nx, ny = extent[1] - extent[0] + 1, extent[3] - extent[2] + 1
    mix = 1.0 / (1.0 + np.exp(-2.0 * smooth_field(rng, (ny, nx), 4.0)))
    return Surface(
        x0=extent[0],
        y0=extent[2],
        cell=1.0,
        terrain=np.full((ny, nx), float(height)),
        ground={"asphalt": mix, "concrete": 1.0 - mix},
    )


def measured_offset(scene, vnir_nm=920.0, swir_nm=1010.0) -> tuple[float, float]:
    v = scene.vnir[np.argmin(np.abs(scene.vnir_wavelengths - vnir_nm))].astype(float)
    s = scene.swir[np.argmin(np.abs(scene.swir_wavelengths - swir_nm))].astype(float)
    # A feature at VNIR (r, c) is at SWIR (r + along, c + across): swir(r + d) = vnir(r).
    m = 16  # keep away from the image edges
    dy, dx = phase_correlation(v[m:-m, m:-m], s[m:-m, m:-m])
    return dy, dx


@pytest.fixture(scope="module")
def flat_realistic():
    # Noise-free: this checks the geometry; noise is added in the next test.
    return simulate_scene(
        "urban", lines=96, seed=2, surface=textured_flat(), targets=0, noise_free=True
    )


def test_truth_offset_follows_the_residual_formula(flat_realistic):
    t = flat_realistic.truth
    H, Hn, gsd = 1500.0, 6000 * 0.3048, 1.5
    tan = np.tan(np.radians(0.3))
    assert t["flying_height_m"] == H and t["nominal_altitude_m"] == pytest.approx(Hn)
    assert t["offset_px"]["along"] == pytest.approx((Hn - H) * tan / gsd, rel=1e-6)
    assert t["disparity_px_per_m"]["along"] == pytest.approx(tan / gsd, rel=1e-6)
    assert t["height_precision_m_per_px"] == pytest.approx(gsd / tan, rel=1e-6)
    assert 1.0 < t["offset_px"]["along"] < 2.0  # the paper's regime: a pixel or two


def test_flat_ground_shift_equals_configured_offset(flat_realistic):
    dy, dx = measured_offset(flat_realistic)
    assert dy == pytest.approx(flat_realistic.truth["offset_px"]["along"], abs=0.1)
    assert dx == pytest.approx(flat_realistic.truth["offset_px"]["across"], abs=0.1)


def test_noise_does_not_move_the_measured_offset():
    """With shot/read noise the dim 1,010 nm band is noisy (as in the paper); a bright SWIR
    band (1,250 nm) against 920 nm still gives the configured offset."""
    sc = simulate_scene("urban", lines=96, seed=3, surface=textured_flat(seed=9), targets=0)
    dy, dx = measured_offset(sc, swir_nm=1250.0)
    assert dy == pytest.approx(sc.truth["offset_px"]["along"], abs=0.1)
    assert dx == pytest.approx(0.0, abs=0.1)


def test_shift_changes_by_disparity_per_metre_on_raised_ground():
    kw = dict(
        lines=96,
        seed=2,
        geometry="large-squint",
        nominal_altitude=NOMINAL_ALTITUDE_M,
        targets=0,
        noise_free=True,
    )
    low = simulate_scene("urban", surface=textured_flat(0.0), **kw)
    high = simulate_scene("urban", surface=textured_flat(40.0), **kw)
    t = low.truth
    assert t["disparity_px_per_m"]["along"] == pytest.approx(
        np.tan(np.radians(3.0)) / 1.5, rel=1e-6
    )
    d_low, _ = measured_offset(low)
    d_high, x_high = measured_offset(high)
    assert d_low == pytest.approx(t["offset_px"]["along"], abs=0.1)
    assert d_high == pytest.approx(
        t["offset_px"]["along"] + 40.0 * t["disparity_px_per_m"]["along"], abs=0.1
    )
    assert x_high == pytest.approx(0.0, abs=0.1)
    assert np.allclose(high.dsm, 40.0, atol=0.05)


def test_relief_parallax_on_a_raised_block_moves_roof_not_street():
    """A 20 m block: its edge moves by 20 m × disparity in SWIR relative to VNIR, the street doesn't."""
    base = textured_flat()
    block = np.array([[-60.0, 60.0, 60.0, 120.0, 20.0, 2.0]])  # concrete roof, 20 m high
    street = {"asphalt": np.ones_like(base.terrain)}
    surf = Surface(base.x0, base.y0, base.cell, base.terrain, street, buildings=block)
    sc = simulate_scene(
        "urban",
        lines=128,
        seed=1,
        surface=surf,
        geometry="large-squint",
        targets=0,
        sun_zenith=0.0,
        noise_free=True,
    )
    t = sc.truth
    v = sc.vnir[np.argmin(np.abs(sc.vnir_wavelengths - 920.0))]
    s = sc.swir[np.argmin(np.abs(sc.swir_wavelengths - 1010.0))]
    col = 143
    roof_v = sc.dsm[:, col] > 10
    rows = np.nonzero(roof_v)[0]
    # The roof's far edge in each image, by the half-way crossing of the roof's DN.

    def edge(profile, roof_value, ground_value, start):
        half = 0.5 * (roof_value + ground_value)
        i = start
        while (profile[i] - half) * (profile[i + 1] - half) > 0:
            i += 1
        return i + (half - profile[i]) / (profile[i + 1] - profile[i])

    pv = v[:, col - 3 : col + 4].mean(1)
    ps = s[:, col - 3 : col + 4].mean(1)
    mid = int(rows.mean())
    ev = edge(pv, pv[mid], pv[rows.max() + 4 : rows.max() + 8].mean(), mid)
    es = edge(ps, ps[mid], ps[rows.max() + 4 : rows.max() + 8].mean(), mid)
    expected = t["offset_px"]["along"] + 20.0 * t["disparity_px_per_m"]["along"]
    assert es - ev == pytest.approx(expected, abs=0.15)


def brute_force_shadow(dsm, cell, zenith, azimuth, step=0.1):
    """Independent ray march: walk from each cell towards the sun in small steps."""
    ny, nx = dsm.shape
    sx = np.sin(np.radians(azimuth))
    sy = np.cos(np.radians(azimuth))
    rise = 1.0 / np.tan(np.radians(zenith))
    out = np.zeros(dsm.shape, bool)
    top = dsm.max()
    for i in range(ny):
        for j in range(nx):
            z = dsm[i, j]
            d = step
            while z + d * rise <= top:
                x = j + d * sx / cell
                y = i + d * sy / cell
                ii, jj = int(round(y)), int(round(x))
                if not (0 <= ii < ny and 0 <= jj < nx):
                    break
                if dsm[ii, jj] > z + d * rise + 0.02:
                    out[i, j] = True
                    break
                d += step
    return out


@pytest.mark.parametrize("azimuth", [180.0, 137.6, 250.0])
def test_cast_shadow_matches_brute_force_ray_march(azimuth):
    cell, h, zen = 0.5, 8.0, 40.0
    dsm = np.zeros((70, 70))
    dsm[25:40, 28:42] = h
    fast = cast_shadow(dsm, cell, zen, azimuth)
    slow = brute_force_shadow(dsm, cell, zen, azimuth)
    disagree = fast != slow
    # Only cells on the shadow's outline may differ (sub-cell sampling of the edge).
    edge = np.zeros_like(slow)
    edge[1:-1, 1:-1] = slow[1:-1, 1:-1] != (
        slow[:-2, 1:-1] & slow[2:, 1:-1] & slow[1:-1, :-2] & slow[1:-1, 2:]
    ) | (slow[1:-1, 1:-1] != (slow[:-2, 1:-1] | slow[2:, 1:-1] | slow[1:-1, :-2] | slow[1:-1, 2:]))
    assert slow.sum() > 150
    assert disagree.sum() <= 0.1 * slow.sum()
    assert not (disagree & ~edge).any()


def test_scene_shadow_truth_has_length_h_tan_zenith():
    """A 12 m box, sun behind the aircraft: the shadow is 12·tan(45°) = 12 m = 8 lines long."""
    base = textured_flat()
    h = 12.0
    box = np.array([[-30.0, 30.0, 30.0, 60.0, h, 2.0]])
    surf = Surface(
        base.x0,
        base.y0,
        base.cell,
        base.terrain,
        {"concrete": np.ones_like(base.terrain)},
        buildings=box,
    )
    sc = simulate_scene(
        "urban",
        lines=96,
        seed=0,
        surface=surf,
        sun_zenith=45.0,
        sun_azimuth=180.0,
        targets=0,
        noise_free=True,
    )
    col = 143
    roof = np.nonzero(sc.dsm[:, col] > h / 2)[0]
    beyond = sc.shadow_fraction[roof.max() + 1 :, col]
    # Shadow behind the box (the sun is at azimuth 180°: shadows point along +rows).
    length_px = beyond[:20].sum()
    assert length_px * 1.5 == pytest.approx(h * np.tan(np.radians(45.0)), abs=1.0)
    assert sc.shadow_fraction[: roof.min() - 1, col].sum() == pytest.approx(0.0, abs=0.05)


@pytest.fixture(scope="module")
def urban():
    return simulate_scene("urban", lines=96, seed=0)


def band(scene, nm):
    if nm < 975:
        return scene.vnir[np.argmin(np.abs(scene.vnir_wavelengths - nm))].astype(float)
    return scene.swir[np.argmin(np.abs(scene.swir_wavelengths - nm))].astype(float)


def test_shadowed_pixels_have_higher_ratio_than_sunlit_of_same_material(urban):
    ratio = band(urban, 1010) / band(urban, 920)
    sf = urban.shadow_fraction
    # Stay away from edges, where the boresight offset mixes shadow and sun between the bands.
    core = (sf > 0.95) & (np.abs(np.gradient(sf)[0]) < 0.01)
    sun = sf < 0.01
    checked = 0
    for mat_id, name in urban.material_names.items():
        pure = (urban.material == mat_id) & (
            urban.abundances[urban.abundance_names.index(name)] > 0.8
        )
        shade, lit = pure & core, pure & sun
        if shade.sum() >= 10 and lit.sum() >= 10:
            assert np.median(ratio[shade]) > np.median(ratio[lit]) * 1.3, name
            checked += 1
    assert checked >= 3


def test_ranges_and_mixtures(urban):
    assert urban.vnir.dtype == np.uint16 and urban.vnir.shape == (96, 96, 286)
    assert urban.swir.shape == (102, 96, 286)
    assert urban.vnir.max() <= 4095 and urban.swir.max() <= 4095
    assert 0 <= urban.shadow_fraction.min() and urban.shadow_fraction.max() <= 1
    assert np.allclose(urban.abundances.sum(0), 1.0, atol=1e-4)
    assert urban.abundances.min() >= 0 and urban.abundances.max() <= 1
    refl = urban.reflectance()
    assert refl.shape == (198, 96, 286)
    assert refl.min() >= 0.0 and refl.max() <= 1.0
    for name, spec in urban.endmember_spectra.items():
        assert spec.shape == (198,) and 0 <= spec.min() and spec.max() <= 1, name
    # Vegetation red edge from the real library: NIR much brighter than red for trees.
    tree = urban.endmember_spectra["tree"]
    wl = urban.wavelengths
    assert tree[np.argmin(np.abs(wl - 850))] > 4 * tree[np.argmin(np.abs(wl - 670))]


def test_targets_are_subpixel_bags_with_the_papers_abundance():
    sc = simulate_scene("mixed", lines=96, seed=4, targets=10)
    assert len(sc.truth["targets"]) == 10
    assert 0 <= sc.target_abundance.min() and sc.target_abundance.max() <= 1
    area = BAG_SIZE_M[0] * BAG_SIZE_M[1]
    for t in sc.truth["targets"]:
        # A bag fully inside a ~1.5 m footprint: abundance = bag area / footprint area ≈ 0.086.
        assert t["abundance"] == pytest.approx(area / 1.5**2, rel=0.05)
        assert sc.target_abundance[t["row"], t["col"]] == pytest.approx(t["abundance"])
    # All the bag area is accounted for, in VNIR pixels.
    assert sc.target_abundance.sum() * 1.5**2 == pytest.approx(10 * area, rel=0.05)
    # The plastic's 1,730 nm absorption is in the endmember, not in the soil.
    bag = sc.endmember_spectra["plastic_bag"]
    wl = sc.wavelengths
    assert bag[np.argmin(np.abs(wl - 1730))] < 0.9 * bag[np.argmin(np.abs(wl - 1650))]


def test_clouds_are_masked_and_bright():
    sc = simulate_scene("glade", lines=64, seed=3, clouds=3, targets=0)
    assert sc.cloud_mask.any() and not sc.cloud_mask.all()
    b = band(sc, 550)
    assert np.median(b[sc.cloud_mask]) > np.percentile(b[~sc.cloud_mask], 95)


def test_same_seed_same_scene_other_seed_other_scene():
    a = simulate_scene("dunes", lines=32, seed=7)
    b = simulate_scene("dunes", lines=32, seed=7)
    c = simulate_scene("dunes", lines=32, seed=8)
    assert np.array_equal(a.vnir, b.vnir) and np.array_equal(a.swir, b.swir)
    assert np.array_equal(a.dsm, b.dsm) and a.truth == b.truth
    assert not np.array_equal(a.vnir, c.vnir)
    assert 20 < float(np.ptp(simulate_scene("dunes", lines=160, seed=7, noise_free=True).dsm)) < 32


# ------------------------------------------------------------------ sub-material texture
def test_brightness_field_has_the_requested_statistics():
    from geoboresight.simulate.surface import brightness_field

    f = brightness_field(np.random.default_rng(1), (400, 400), [(8.0, 0.06), (0.7, 0.05)])
    assert f.mean() == pytest.approx(1.0, abs=0.01)
    assert f.std() == pytest.approx(np.hypot(0.06, 0.05), rel=0.1)
    # Spatially correlated: neighbours 3 m apart still share the 8 m component.
    d = f - f.mean()
    lag3 = np.mean(d[:, :-3] * d[:, 3:]) / d.var()
    assert 0.3 < lag3 < 0.8


def test_texture_is_a_spectrally_flat_reflectance_factor():
    """Pure soil on flat ground with a known factor field: every band's signal follows it."""
    from dataclasses import replace

    from geoboresight.simulate.surface import brightness_field

    ext = (-400, 400, -200, 800)
    nx, ny = ext[1] - ext[0] + 1, ext[3] - ext[2] + 1
    plain = Surface(ext[0], ext[2], 1.0, np.zeros((ny, nx)), {"soil": np.ones((ny, nx))})
    factor = brightness_field(np.random.default_rng(3), (ny, nx), [(6.0, 0.08)])
    kw = dict(lines=48, seed=1, targets=0, noise_free=True, sun_zenith=30.0)
    a = simulate_scene("urban", surface=replace(plain, brightness={"soil": factor}), **kw)
    b = simulate_scene("urban", surface=plain, **kw)
    assert np.array_equal(a.abundances, b.abundances) and np.array_equal(a.dsm, b.dsm)
    core = (slice(4, -4), slice(4, -4))
    devs = []
    for nm in (550.0, 920.0, 1250.0, 2200.0):
        ta, tb = band(a, nm)[core], band(b, nm)[core]
        assert np.ptp(tb) < 1e-3 * tb.mean()  # uniform without texture
        devs.append((ta - tb).ravel())
    # Spectrally flat: the same pattern in every band of an instrument (VNIR and SWIR see
    # the ground through their own footprints and PSFs).
    assert np.corrcoef(devs[0], devs[1])[0, 1] > 0.999
    assert np.corrcoef(devs[2], devs[3])[0, 1] > 0.999
    # It is the factor field: sampled at the VNIR footprint centres (from the ray geometry).
    t = a.truth
    rows, cols = np.indices(a.dsm.shape)
    from geoboresight.simulate.geometry import COLS

    x = (cols - (COLS - 1) / 2) * t["gsd_m"]
    y = rows * t["line_spacing_m"]
    i = (y - ext[2]) / 1.0
    j = (x - ext[0]) / 1.0
    from scipy import ndimage

    smooth = ndimage.gaussian_filter(factor.astype(float), 1.0)
    at = ndimage.map_coordinates(smooth, [i.ravel(), j.ravel()], order=1).reshape(a.dsm.shape)
    r = np.corrcoef(at[core].ravel(), devs[1])[0, 1]
    assert r > 0.9
    # Amplitude: a uniform factor 1.1 gives the surface signal's 10 % (dark offset and path
    # radiance cancel in the differences), so (a − b) / signal is the factor − 1 per pixel.
    c = simulate_scene(
        "urban", surface=replace(plain, brightness={"soil": np.full((ny, nx), 1.1)}), **kw
    )
    signal = (band(c, 920.0) - band(b, 920.0))[core] / 0.1
    rel = (band(a, 920.0) - band(b, 920.0))[core] / signal
    assert np.std(rel) == pytest.approx(np.std(at[core]), rel=0.25)
    assert np.mean(rel) == pytest.approx(np.mean(at[core]) - 1.0, abs=0.01)


def test_presets_have_texture_in_open_ground_and_same_layout():
    kw = dict(lines=64, seed=0, geometry="large-squint", noise_free=True)
    a = simulate_scene("mixed", **kw)
    b = simulate_scene("mixed", texture=False, **kw)
    assert np.array_equal(a.dsm, b.dsm) and np.array_equal(a.abundances, b.abundances)
    assert a.truth == b.truth
    names = a.abundance_names
    ground = ("soil", "dark_soil", "grass", "dry_vegetation")
    open_ = sum(a.abundances[names.index(n)] for n in ground)
    m = (open_ > 0.99) & (a.shadow_fraction < 0.01)
    assert m.sum() > 500
    dark = 190.0  # VNIR dark offset (truth.json)
    ra = band(a, 920.0) - dark
    rb = band(b, 920.0) - dark
    # Within-material variation: the pixel-scale relative deviation from the untextured signal.
    dev = (ra[m] - rb[m]) / rb[m]
    assert 0.02 < np.std(dev) < 0.12


# ------------------------------------------------------------------ streamed stages
def test_radiance_and_dn_by_blocks_equal_one_whole_array_call():
    """Stages 5–6 stream over blocks of lines: any block size gives the whole-array result."""
    from geoboresight.simulate.atmosphere import illumination
    from geoboresight.simulate.geometry import COLS
    from geoboresight.simulate.scene import Footprints, at_sensor_radiance, instrument_cube
    from geoboresight.simulate.sensor import SWIR
    from geoboresight.simulate.spectra import aisa_dual_bands

    rng = np.random.default_rng(0)
    lines, k = 37, 3
    _, _, wl, fw = aisa_dual_bands()
    ill = illumination(wl, fw, 40.0, 1500.0)
    fp = Footprints.zeros(k, lines)
    for name in ("direct", "sky", "cloud_direct", "cloud_sky"):
        getattr(fp, name)[...] = rng.uniform(0, 0.5, getattr(fp, name).shape)
    rho = rng.uniform(0.05, 0.6, (k, len(wl)))
    rho_cloud = np.full(len(wl), 0.8)
    whole = SWIR.to_dn(
        at_sensor_radiance(fp.direct, fp.sky, fp.cloud_direct, fp.cloud_sky, rho, rho_cloud, ill),
        wl,
        None,
    )
    assert whole.shape == (len(wl), lines, COLS)
    for block_lines in (1, 5, 16, 256):
        cube = instrument_cube(fp, SWIR, rho, rho_cloud, ill, wl, None, block_lines=block_lines)
        np.testing.assert_allclose(cube, whole, rtol=1e-6, err_msg=f"block_lines={block_lines}")
    # With noise: the same seed and block size give the same DN (drawn in line order).
    a = instrument_cube(fp, SWIR, rho, rho_cloud, ill, wl, np.random.default_rng([1, 2]))
    b = instrument_cube(fp, SWIR, rho, rho_cloud, ill, wl, np.random.default_rng([1, 2]))
    assert a.dtype == np.uint16 and np.array_equal(a, b)


def test_ray_tracing_by_blocks_agrees_with_one_block():
    """Stages 2–4 stream over blocks of lines. Each block has its own fine grid,
    whose origin depends on the block, so pixels at sub-cell edges (walls, crowns, shadow
    edges) differ: the block size must not change the scene's content (means, fractions)."""
    from geoboresight.simulate.scene import (
        _sun,
        flight_geometry,
        preset_surface,
        scene_extent,
        trace_footprints,
    )

    geo, sun, lines = flight_geometry("large-squint"), _sun("mixed", None, None), 48
    ext, core = scene_extent(geo, lines, sun)
    surface = preset_surface("mixed", np.random.default_rng(3), ext, core, seed=3)
    names = list(surface.materials)
    ref_fp, ref = trace_footprints(geo, surface, names, lines, sun, None, 2, block_lines=lines)
    for block_lines in (7, 16, 40):
        fp, truth = trace_footprints(
            geo, surface, names, lines, sun, None, 2, block_lines=block_lines
        )
        assert np.allclose(truth.abundances.sum(0), 1.0, atol=1e-4)
        assert truth.shadow.mean() == pytest.approx(ref.shadow.mean(), abs=0.005)
        assert np.mean(np.abs(truth.shadow - ref.shadow)) < 0.03
        assert truth.z.mean() == pytest.approx(ref.z.mean(), abs=0.02)
        assert np.mean(np.abs(truth.abundances - ref.abundances)) < 0.001
        for inst in ("vnir", "swir"):
            # The ray geometry is the same: ground points within a fraction of a pixel.
            assert np.median(np.abs(fp[inst].x - ref_fp[inst].x)) < 0.001
            assert np.median(np.abs(fp[inst].y - ref_fp[inst].y)) < 0.001
            direct, ref_direct = fp[inst].direct.sum(0), ref_fp[inst].direct.sum(0)
            assert direct.mean() == pytest.approx(ref_direct.mean(), rel=0.005)


def test_sunlit_twin_lights_cast_shadow_and_changes_nothing_else():
    # cast_shadows=False: the reference a de-shadowing is checked against (each shadowed
    # pixel's own sunlit signal). Same layout; only pixels near a cast shadow change.
    from scipy import ndimage

    kw = dict(lines=64, seed=3, targets=0, noise_free=True, sun_zenith=45.0)
    real = simulate_scene("urban", **kw)
    twin = simulate_scene("urban", cast_shadows=False, **kw)
    assert np.array_equal(real.abundances, twin.abundances)
    assert np.array_equal(real.dsm, twin.dsm)
    f, g = real.shadow_fraction, twin.shadow_fraction
    assert (g <= f + 1e-6).all()
    assert f.mean() > 0.05 and g.mean() < f.mean() / 3  # what is left is self-shade
    # The SWIR sees the ground through the residual boresight offset and the roofs' parallax
    # (truth is on the VNIR grid): a wider margin there, and its first and last lines see
    # ground beyond the VNIR's.
    for cube, margin in (("vnir", 3), ("swir", 8)):
        far = ~ndimage.binary_dilation(f > 0, iterations=margin)
        far[:margin] = far[-margin:] = False
        assert far.sum() > 1000
        a, b = getattr(real, cube), getattr(twin, cube)
        # (float32 sums over the materials: equal to their rounding)
        np.testing.assert_allclose(a[:, far], b[:, far], rtol=1e-5)
    full = ndimage.binary_erosion(f >= 0.999) & (g < 0.02)
    assert full.sum() > 50
    for nm in (450.0, 650.0, 850.0, 1650.0, 2200.0):
        assert (band(twin, nm)[full] > band(real, nm)[full]).mean() > 0.95


def test_horizon_sky_is_one_on_flat_ground_and_the_trench_value_in_a_trench():
    from geoboresight.simulate.shadow import horizon_sky

    assert np.allclose(horizon_sky(np.zeros((40, 40)), 1.0, 20.0), 1.0)
    # A long trench 2a wide between walls d high: at its middle, the sky of a horizontal
    # surface is a/√(a² + d²) (the 2-D view factor), within the 16 azimuths' quadrature.
    z = np.zeros((200, 400))
    z[:, :180] = z[:, 220:] = 10.0
    v = horizon_sky(z, 0.5, 50.0)
    assert v[100, 200] == pytest.approx(10.0 / np.hypot(10.0, 10.0), rel=0.03)


def test_sky_obstruction_darkens_street_shadow_more_than_open_ground():
    kw = dict(lines=64, seed=3, targets=0, noise_free=True, sun_zenith=45.0)
    a = simulate_scene("urban", **kw)
    b = simulate_scene("urban", sky_obstruction=True, **kw)
    f = a.shadow_fraction
    full, lit = f >= 0.999, f == 0
    nm = 450.0  # where shadow is lit mostly by the sky
    from geoboresight.simulate.sensor import VNIR

    dark = VNIR.dark_dn
    shade = (band(b, nm)[full] - dark).mean() / (band(a, nm)[full] - dark).mean()
    sun = (band(b, nm)[lit] - dark).mean() / (band(a, nm)[lit] - dark).mean()
    assert shade < 0.9 and sun > 0.9 and shade < sun - 0.05
