"""The surface-model prior of shadow-map (``--dsm``) and de-shadowing (``deshadow``).

Independent truth: cast shadows and illumination ratios put into synthetic arrays (the
sunlit/shadow signal written from L = (E_dir·(1 − f) + E_diff)·ρ), and the second scene model
(``validation/scene_model2.py``), which shares no code with the kernels.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from geoboresight import SurfaceModel, deshadow_file, shadow_map_file
from geoboresight.errors import InputError, ParameterError
from geoboresight.shadow import darkness
from geoboresight.shadow import deshadow as ds
from geoboresight.shadow import illumination as ill
from geoboresight.shadow.prior import dsm_shadow_fraction, prior_agreement, prior_registration
from validation.scene_model2 import simulate2, write_scene2

SUN = dict(sun_zenith=40.0, sun_azimuth=180.0)  # from the south: shadows fall north (up)


def _town():
    """A 6 m building (cast shadow north of it) and a black roof at 3 m elsewhere whose own
    shadow is small; (dsm, darkness, truth shadow, black roof)."""
    z = np.zeros((60, 60))
    z[30:40, 10:22] = 6.0  # building
    z[30:40, 40:52] = 3.0  # black-roofed building
    prior = ill.shadow_fraction(z, **SUN, cell_size=1.0)
    d = np.full(z.shape, -0.1)  # sunlit ground near the sunlit mode
    shade = prior >= 0.5
    d[shade] = math.log(1 / 10)  # skylight only
    roof = np.zeros(z.shape, bool)
    roof[30:40, 40:52] = True
    d[roof] = math.log(1 / 8)  # black roof in the sun: as dark as shadow
    return z, prior, d, shade, roof


def test_the_dsm_prior_flags_cast_shadow_and_not_a_black_roof():
    z, prior, d, shade, roof = _town()
    assert shade.sum() > 50  # 6 m · tan 40° ≈ 5 px of shadow north of the building
    f = dsm_shadow_fraction(d, prior)
    # A black roof outside any cast shadow is not shadow; only its row next to its own
    # shadow (within the registration tolerance) may be taken.
    from scipy import ndimage

    far = roof & ~ndimage.binary_dilation(shade, iterations=darkness.DSM_TOLERANCE)
    assert far.sum() >= 0.85 * roof.sum()
    assert (f[far] == 0).all()
    assert (f[shade] >= 0.5).all()  # the cast shadow is
    # Without the prior the roof is shadow: the reason for the surface model.
    f0 = darkness.shadow_fraction_estimate(d, core=darkness.CORE_DARKNESS)
    assert (f0[roof] >= 0.5).mean() > 0.9


def test_the_prior_is_refined_within_a_pixel_and_lit_predictions_dropped():
    z, prior, d, shade, roof = _town()
    # The image's shadow a pixel longer than the model's (registration): the rim pixel is
    # taken, a pixel two away is not.
    rows = np.nonzero(shade.any(axis=1))[0]
    top = rows.min()
    d2 = d.copy()
    d2[top - 1, 12:20] = math.log(1 / 10)
    d2[top - 3, 12:20] = math.log(1 / 10)
    f = dsm_shadow_fraction(d2, prior)
    assert (f[top - 1, 12:20] >= 0.5).all()
    assert (f[top - 3, 12:20] == 0).all()
    # Predicted shadow that is bright (the model is of another date) is not shadow.
    d3 = d.copy()
    d3[shade] = -0.2
    assert (dsm_shadow_fraction(d3, prior)[shade] < 0.5).all()


@pytest.mark.parametrize("longer", [False, True])
def test_a_dark_road_running_past_the_rim_is_not_rim_shadow(longer):
    """A road (reflectance a quarter of the sunlit mode's: as dark as the rim rule takes)
    runs north through the building's cast shadow and on, sunlit, beyond it. Signals are
    written from L = (E_dir·(1 − f) + E_diff)·ρ with skylight a tenth of the sun's light.
    The road's pixel just beyond the predicted shadow is lit (truth f = 0): its darkness is
    its material's, as the lit road beyond the rim shows, so it is not shadow. With
    ``longer`` the image's shadow is a pixel longer than the model's (registration): then
    that pixel is shaded, on the road and on the grass beside it, and is found."""
    z, prior, _, shade, _ = _town()
    frac = shade.astype(float)
    top = np.nonzero(shade.any(axis=1))[0].min()
    if longer:
        frac[top - 1, 10:22] = 1.0
    rho = np.full(z.shape, 0.9)
    road = np.zeros(z.shape, bool)
    road[:30, 14:18] = True  # up to the building, through its shadow and beyond
    rho[road] = 0.25
    d = np.log(rho * (1 - frac + 0.1 * frac))
    assert (d[top - 1, 14:18] <= darkness.RIM_DARKNESS).all()  # dark enough for the rim rule
    f = dsm_shadow_fraction(d, prior, heights=z, clearance=1.0)
    mask = f >= 0.5
    truth = frac >= 0.5
    assert (mask[top - 1, 14:18] == truth[top - 1, 14:18]).all()  # the road beside the shadow
    assert (mask[top - 1, 10:22] == truth[top - 1, 10:22]).all()  # road and grass
    assert (mask[shade]).all()  # the predicted shadow, road and grass
    assert not mask[road & ~truth].any()  # no sunlit road pixel anywhere


def test_the_top_of_a_caster_beside_its_shadow_is_not_rim_shadow():
    z, prior, d, shade, roof = _town()
    from scipy import ndimage

    # The black roof's row next to its own shadow: dark enough for the rim rule, but it is
    # the caster's top (3 m above the shadow's ground), lit by the sun.
    beside = roof & ndimage.binary_dilation(shade, iterations=darkness.DSM_TOLERANCE)
    assert beside.sum() >= 10
    without = dsm_shadow_fraction(d, prior)
    # Without the heights the roof beyond that row, lit and as dark, already says the row is
    # not shaded (its fraction against it as the sunlit end); the heights also say so.
    assert (without[beside] >= 0.5).mean() <= 0.5
    f = dsm_shadow_fraction(d, prior, heights=z, clearance=1.0)
    # Not rim shadow any more; it is still unmixed against its neighbourhood, where its own
    # dark roof is the sunlit reference (fraction ~0), except within the unmixing window
    # (half of EDGE_WINDOW + 1 = 3 px) of the roof's ends, where the bright ground is.
    assert (f[roof & ~beside] == 0).all()
    inner = (
        beside & (np.cumsum(beside, axis=1) > 3) & (np.cumsum(beside[:, ::-1], axis=1)[:, ::-1] > 3)
    )
    assert inner.sum() >= 4
    assert (f[inner] < 0.5).all()
    assert (f[beside] >= 0.5).mean() <= 0.5
    assert (f[shade] >= 0.5).all()
    # A dark pixel at ground level beside the shadow (registration) is still taken.
    top = np.nonzero(shade.any(axis=1))[0].min()
    d2 = d.copy()
    d2[top - 1, 12:20] = math.log(1 / 10)
    f2 = dsm_shadow_fraction(d2, prior, heights=z, clearance=1.0)
    assert (f2[top - 1, 12:20] >= 0.5).all()
    with pytest.raises(InputError, match="parameter 'heights'"):
        dsm_shadow_fraction(d, prior, heights=z[:-1], clearance=1.0)


def test_shadow_cast_from_beyond_the_surface_model_is_left_to_the_spectra():
    """The sun is south: a caster just south of the grid (not in the surface model) shades
    its southern edge; there the spectral estimate holds, elsewhere the prior rules."""
    z, prior, d, shade, roof = _town()
    d2 = d.copy()
    d2[57:, 5:25] = math.log(1 / 10)  # shadow of something beyond the southern edge
    unseen = ill.unseen_casters(z, **SUN, top=float(z.max()), cell_size=1.0, clearance=1.0)
    assert unseen[57:, 5:25].all()
    assert not unseen[:50].any()  # 5 m of rise clear the grid's top within a few cells
    # A black patch in the same band that does not reach the edge: a lit row lies between
    # it and the sun, so no caster beyond the edge shades it.
    d2[56:58, 35:50] = math.log(1 / 8)
    assert unseen[56:58, 35:50].all()
    m = ill.grid_matrix(None, 1.0)
    drow, dcol, rise = ill.sun_step(SUN["sun_zenith"], SUN["sun_azimuth"], m, 1.0)
    ray = (drow, dcol, ill.march_steps(float(z.max()), rise, z.shape, drow, dcol))
    assert (round(drow), round(dcol)) == (1, 0)  # towards the sun: south, down the rows
    f_no = dsm_shadow_fraction(d2, prior, heights=z, clearance=1.0)
    f = dsm_shadow_fraction(d2, prior, heights=z, clearance=1.0, unseen=unseen, ray=ray)
    assert (f_no[57:, 5:25] == 0).all()
    assert (f[58:, 7:23] >= 0.5).all()
    assert (f[56:58, 35:50] == 0).all()
    # Without the way to the edge checked, the patch is taken.
    f_any = dsm_shadow_fraction(d2, prior, heights=z, clearance=1.0, unseen=unseen)
    assert (f_any[56:58, 37:48] >= 0.5).all()
    assert np.array_equal(f[:50], f_no[:50])  # the black roof stays out
    with pytest.raises(InputError, match="parameter 'unseen'"):
        dsm_shadow_fraction(d, prior, unseen=unseen[:-1])


def _shortened(zenith):
    """A 5.2 m building on level ground, sun from the south at ``zenith``; (heights, prior of
    clearance 1, darkness written from the exact cast shadow (clearance 0), exact shadow
    fraction, ray and reach as the operation derives them)."""
    z = np.zeros((60, 40))
    z[40:48, 10:30] = 5.2
    sun = dict(sun_zenith=zenith, sun_azimuth=180.0)
    exact = ill.shadow_fraction(z, **sun, cell_size=1.0)
    prior = ill.shadow_fraction(z, **sun, cell_size=1.0, clearance=1.0)
    rho, sky = 0.5, 0.1  # ground at half the sunlit mode, skylight a tenth of the sun's
    d = np.log(rho * (1 - exact + sky * exact))
    m = ill.grid_matrix(None, 1.0)
    drow, dcol, rise = ill.sun_step(zenith, 180.0, m, 1.0)
    ray = (drow, dcol, ill.march_steps(5.2, rise, z.shape, drow, dcol))
    return z, prior, d, exact, ray, 1.0 / rise


@pytest.mark.parametrize("zenith", [60.0, 63.4])
def test_the_far_end_a_clearance_shortens_is_found_and_only_along_the_ray(zenith):
    """The clearance (1 m) shortens a shadow by clearance·tan(zenith) at its far end (1.7 and
    2.0 px here): two rows of pixels, one more than the one-pixel tolerance. With ``reach`` (the clearance over the
    sun's rise per cell) the exact shadow is recovered; a black patch down-sun of the shadow
    but cut from it by a lit row is not shadow."""
    z, prior, d, exact, ray, reach = _shortened(zenith)
    truth = exact >= 0.5
    assert reach == pytest.approx(math.tan(math.radians(zenith)))
    lost = truth & ~(prior >= 0.5)
    assert lost.sum() >= 2 * 20  # two rows of the far end (the building is 20 px wide)
    without = dsm_shadow_fraction(d, prior, heights=z, clearance=1.0, ray=ray)
    assert ((without >= 0.5) != truth).sum() >= 15  # the failure: a row beyond the tolerance
    f = dsm_shadow_fraction(d, prior, heights=z, clearance=1.0, ray=ray, reach=reach)
    assert ((f >= 0.5) == truth).all()
    # A shadow really as short as predicted (the two rows lit ground) with black material (an
    # eighth of the sunlit mode) on the farther row, within the reach; and beside the shadow,
    # off its ray: neither is shadow, since the lit row cuts the first from the shadow.
    far = int(np.nonzero(truth.any(axis=1))[0].min())  # the exact shadow's far (northern) row
    assert not (prior[far : far + 2] >= 0.5).any()
    lit_ground = 0.5  # brighter than the rim's third of the sunlit mode
    assert lit_ground > math.exp(darkness.RIM_DARKNESS)
    d2 = d.copy()
    d2[far + 1, :] = math.log(lit_ground)
    d2[far, 12:28] = math.log(1 / 8)
    d2[far + 2 : far + 5, 32:35] = math.log(1 / 8)  # east of the shadow, two columns off it
    f2 = dsm_shadow_fraction(d2, prior, heights=z, clearance=1.0, ray=ray, reach=reach)
    assert (f2[far, 12:28] == 0).all()
    assert (f2[far + 2 : far + 5, 32:35] == 0).all()
    assert ((f2 >= 0.5) == (prior >= 0.5)).all()
    # Without the ray, no sweep: the reach needs the sun's direction.
    assert np.array_equal(
        dsm_shadow_fraction(d, prior, heights=z, clearance=1.0, reach=reach),
        dsm_shadow_fraction(d, prior, heights=z, clearance=1.0),
    )


@pytest.mark.parametrize("truth", [0.3, 0.8])
def test_a_predicted_edge_pixel_keeps_its_unmixed_fraction(truth):
    """A dark soil (sunlit signal 0.4 of the mode, skylight a tenth of the sun's light): the
    model shades the edge row of a shadow that covers ``truth`` of it. Signal is linear in
    the shaded share, so the row is shadow (≥ 0.5) exactly when ``truth`` ≥ 0.5, although at
    0.3 it is darker than half the sunlit mode (the old rule forced it to 0.5)."""
    rho, sky = 0.4, 0.1
    frac = np.zeros((40, 40))
    frac[20:30, 10:30] = 1.0
    frac[20, 10:30] = truth
    d = np.log(rho * (1 - frac + sky * frac))
    prior = np.where(frac > 0, 0.75, 0.0)  # the model: shaded, with a sub-pixel edge
    prior[21:30] = 1.0
    f = dsm_shadow_fraction(d, prior)
    assert (d[20, 10:30] < darkness.LIT_DARKNESS).all()  # not spectrally lit
    assert ((f[20, 12:28] >= 0.5) == (truth >= 0.5)).all()
    assert (f[22:30, 10:30] >= 0.5).all()


def test_clearance_removes_the_shadows_of_height_noise():
    rng = np.random.default_rng(0)
    z = rng.normal(0, 0.3, (80, 80))  # flat ground, 0.3 m of noise
    noisy = ill.shadow_fraction(z, **SUN, cell_size=1.0) >= 0.5
    clear = ill.shadow_fraction(z, **SUN, cell_size=1.0, clearance=1.0) >= 0.5
    assert noisy.mean() > 0.01
    assert clear.mean() < 0.001


def test_prior_agreement_finds_the_shift():
    z, prior, d, shade, roof = _town()
    d2 = np.full(d.shape, -0.1)
    d2[np.roll(shade, (2, -1), axis=(0, 1))] = math.log(1 / 10)
    a = prior_agreement(d2, prior)
    assert (a["dsm_shift_rows"], a["dsm_shift_columns"]) == (2, -1)
    assert a["dsm_iou_at_shift"] > 0.95 > a["dsm_iou"]


def test_a_cell_the_model_shades_in_part_is_shadow_when_as_dark_as_core_shadow():
    """Away from any cell the model shades half or more: a cell with a shaded sub-cell
    (prior 0.25: a crown beside a taller one) as dark as core shadow is shadow; the same
    darkness where the model shades nothing (a black roof) is not; a cell shaded in part but
    only as dark as the rim is not either."""
    d = np.full((40, 40), -0.1)
    prior = np.zeros(d.shape)
    prior[10, 10] = prior[10, 30] = 0.25  # shaded in part, far from any full shadow
    d[10, 10] = math.log(1 / 10)  # as dark as core shadow (ln 1/6 or below)
    d[10, 30] = math.log(1 / 4)  # rim-dark only
    d[30, 10] = math.log(1 / 10)  # black roof: the model shades nothing there
    f = dsm_shadow_fraction(d, prior)
    assert f[10, 10] >= 0.5
    assert f[10, 30] == 0.0
    assert f[30, 10] == 0.0


def test_a_cast_moved_by_whole_cells_is_the_cast_of_the_moved_surface():
    z, *_ = _town()
    moved = np.zeros_like(z)
    moved[2:, :-1] = z[:-2, 1:]  # the town 2 rows down, 1 column left (flat ground beyond)
    want = ill.shadow_fraction(moved, **SUN, cell_size=1.0)
    got = ill.shadow_fraction(z, **SUN, cell_size=1.0, shift=(2, -1))
    inner = np.s_[3:-3, 3:-3]  # away from the grid's edge (nothing shaded beyond it)
    assert np.array_equal(got[inner], want[inner])
    # A quarter cell: one sub-cell of four, so fractions move by multiples of 1/4.
    q = ill.shadow_fraction(z, **SUN, cell_size=1.0, shift=(0.25, 0.0))
    assert np.allclose(q.sum(), want.sum(), rtol=0.02)
    assert set(np.unique(q * 16).round(6)) <= set(range(17))


@pytest.mark.parametrize("sub", [(1, 0), (0, -1), (-1, 1), (0, 0)])
def test_prior_registration_finds_a_half_pixel_shift(sub):
    """The image's shadow is cast from the surface moved by half a cell (one cell of a
    surface twice as fine, on which the truth is computed independently: cast, then averaged
    2 × 2); the DSM given is the unmoved one. Noise and a black roof (dark, unshaded) are in
    the evidence."""
    rng = np.random.default_rng(5)
    z = np.zeros((80, 80))
    for r0, c0, h in ((12, 10, 6.0), (40, 30, 8.0), (20, 52, 5.0), (55, 60, 7.0)):
        z[r0 : r0 + 10, c0 : c0 + 9] = h
    fine = np.kron(z, np.ones((2, 2)))
    moved = np.roll(fine, sub, axis=(0, 1))
    cast = ill.cast_shadow(moved, **SUN, cell_size=0.5)
    truth = cast.reshape(80, 2, 80, 2).mean(axis=(1, 3))
    evidence = 1.5 * truth + rng.normal(0, 0.15, truth.shape)
    evidence[60:70, 10:20] += 1.5  # a black roof in the sun
    sub_cells = ill.sub_cell_shadow(z, **SUN, cell_size=1.0)
    r = prior_registration(evidence, sub_cells, ill.SUPERSAMPLE)
    assert (r["dsm_registration_rows"], r["dsm_registration_columns"]) == (
        sub[0] / 2,
        sub[1] / 2,
    )
    if sub != (0, 0):
        assert r["dsm_registration_r"] > r["dsm_registration_r0"]
    # Within its bound: a shift of 1.5 cells is reported at the 1-cell limit, not beyond.
    far = np.roll(fine, (3, 0), axis=(0, 1))
    ev = ill.cast_shadow(far, **SUN, cell_size=0.5).reshape(80, 2, 80, 2).mean(axis=(1, 3))
    r = prior_registration(ev, sub_cells, ill.SUPERSAMPLE, max_shift=1)
    assert r["dsm_registration_rows"] == 1.0


def _lit_scene(k, rows=60, cols=70, seed=1):
    """Cube (bands, rows, cols) of two materials under a cast shadow with fraction f, from
    L = (E_dir·(1 − f) + E_diff)·ρ with E_diff = 1, E_dir = k − 1."""
    rng = np.random.default_rng(seed)
    nb = k.size
    z = np.zeros((rows, cols))
    z[35:45, 10:30] = 8.0
    z[35:45, 45:60] = 5.0
    f = ill.shadow_fraction(z, **SUN, cell_size=1.0, supersample=4).astype(float)
    rho = np.empty((nb, rows, cols))
    a = np.linspace(0.1, 0.4, nb)
    b = np.linspace(0.3, 0.15, nb)
    grass = np.zeros((rows, cols), bool)
    grass[:, cols // 2 :] = True
    rho[:, ~grass] = a[:, None]
    rho[:, grass] = b[:, None]
    rho *= 1 + 0.03 * rng.standard_normal((1, rows, cols))
    roofs = z > 0
    rho[:, roofs] = np.linspace(0.05, 0.07, nb)[:, None]  # dark roofs: other material
    e_dir, e_diff = k - 1.0, 1.0
    light = e_dir[:, None, None] * (1 - f)[None] + e_diff
    return rho * light, rho * k[:, None, None], f


def test_deshadow_recovers_the_sunlit_spectrum():
    k = np.linspace(3.0, 20.0, 12)  # blue to SWIR
    cube, sunlit, f = _lit_scene(k)
    a, b = ds.shadow_pairs(cube, f)
    est, n, spread = ds.illumination_ratio(a, b)
    # Texture of 3 % on both sides of a pair: the median ratio is within a few per cent.
    assert np.allclose(est, k, rtol=0.05), (est, k)
    out = ds.deshadow(cube, f, ratio=est)
    full = f >= 0.999
    ratio = out[:, full].mean(axis=1) / sunlit[:, full].mean(axis=1)
    assert np.allclose(ratio, 1.0, atol=0.05)
    # Partial shadow: the exact formula (the linear one would over-correct).
    part = (f > 0.2) & (f < 0.8)
    assert part.sum() > 5
    exact = ds.deshadow(cube, f, ratio=k)
    assert np.allclose(exact[:, part], sunlit[:, part], rtol=1e-5)
    assert (ds.deshadow(cube, np.zeros_like(f), ratio=k) == cube.astype(np.float32)).all()


def test_too_few_pairs_is_one_clear_error():
    with pytest.raises(InputError, match="pairs of shadowed and sunlit"):
        ds.illumination_ratio(np.ones((3, 4)), np.ones((3, 4)))


# ------------------------------------------------------------------------- the operations


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("m2dsm") / "scene")
    sc = simulate2(rows=72, cols=96, seed=0, sun_zenith=35.0, buildings=8, trees=6)
    write_scene2(sc, folder)
    return sc, folder


def _j(folder, name):
    return os.path.join(folder, name)


def _read(path):
    with rasterio.open(path) as src:
        return src.read()


def _assert_strips_equal_whole(strips, whole):
    """Strips equal the whole image: the same nodata and values within float32 rounding.

    The moving-window means (``ndimage.uniform_filter``) keep a running sum, so a strip's
    float64 values round by where the strip starts (about 1e-13); cast to float32 that can
    move a value by a few units in the last place; the edge unmixing's division by the
    sunlit-to-shadow contrast can enlarge that tenfold. 1e-5 is still far below anything a
    class boundary or a mask reads (the class rasters are compared exactly).
    """
    assert np.array_equal(np.isnan(strips), np.isnan(whole))
    np.testing.assert_allclose(strips, whole, rtol=1e-5, atol=1e-5)


def _surface(sc, folder):
    t = sc.truth
    return SurfaceModel(
        _j(folder, "truth_dsm.tif"), t["sun"]["zenith_deg"], t["sun"]["azimuth_deg"], t["gsd_m"]
    )


def _f1(fraction, truth_fraction):
    """F1 of the shadow mask (fraction ≥ 0.5) against the truth's."""
    pred, truth = fraction >= 0.5, truth_fraction >= 0.5
    tp = (pred & truth).sum()
    return 2 * tp / (2 * tp + (pred & ~truth).sum() + (~pred & truth).sum())


def _in_strips_and_whole(folder, surface, tmp_path):
    """shadow-map --dsm in strips of 16 lines and whole: (the whole run's result, [(classes,
    fraction) of each])."""
    outs = []
    for rows in (16, 1000):
        r = shadow_map_file(
            _j(folder, "vnir.hdr"),
            _j(folder, "swir.hdr"),
            output=str(tmp_path / f"c{rows}.tif"),
            fraction=str(tmp_path / f"f{rows}.tif"),
            surface=surface,
            block_rows=rows,
        )
        outs.append((_read(tmp_path / f"c{rows}.tif"), _read(tmp_path / f"f{rows}.tif")))
    return r, outs


def test_shadow_map_with_a_dsm_in_strips_equals_the_whole_image(scene, tmp_path):
    sc, folder = scene
    r, outs = _in_strips_and_whole(folder, _surface(sc, folder), tmp_path)
    assert (outs[0][0] == outs[1][0]).all()
    _assert_strips_equal_whole(outs[0][1], outs[1][1])
    # The true DSM: registered (best shift 0) and little predicted shadow spectrally lit.
    assert (r["dsm_shift_rows"], r["dsm_shift_columns"]) == (0, 0)
    assert r["dsm_predicted_shadow_lit_share"] < 0.1
    # Strips of 16 lines cut the band a caster beyond the edge could shade: still equal.
    assert 0 < r["dsm_unseen_share"] < 0.5
    assert _f1(outs[1][1][0], sc.shadow_fraction) > 0.8


def test_a_dsm_off_by_a_fraction_of_a_pixel_is_registered_in_strips_as_whole(tmp_path):
    """Model 2 (sun 35° from the south-south-east) with its DSM moved 0.4 px down and 0.6 px
    left (bilinear, as a resampled DSM is) and given 0.3 m of height noise: shadow-map moves
    its predicted shadow back up (rows), the same in strips as whole, within a pixel, and its
    mask matches the scene's truth better than with the prediction where the DSM puts it."""
    from dataclasses import replace

    from scipy import ndimage

    folder = str(tmp_path / "scene")
    sc = simulate2(rows=96, cols=96, seed=0, sun_zenith=35.0, buildings=8, trees=6)
    write_scene2(sc, folder)
    with rasterio.open(_j(folder, "truth_dsm.tif")) as src:
        z, profile = src.read(1), src.profile
    moved = ndimage.shift(z, (0.4, -0.6), order=1, mode="nearest")
    moved = moved + np.random.default_rng(0).normal(0, 0.3, z.shape)
    off = str(tmp_path / "dsm_off.tif")
    with rasterio.open(off, "w", **profile) as dst:
        dst.write(moved.astype("float32"), 1)
    t = sc.truth
    surface = SurfaceModel(off, t["sun"]["zenith_deg"], t["sun"]["azimuth_deg"], t["gsd_m"])
    r, outs = _in_strips_and_whole(folder, surface, tmp_path)
    _assert_strips_equal_whole(outs[0][1], outs[1][1])
    assert -1.0 <= r["dsm_registration_rows"] < 0
    assert abs(r["dsm_registration_columns"]) <= 1.0
    assert r["dsm_registration_t"] > darkness.REGISTRATION_T
    fixed = shadow_map_file(
        _j(folder, "vnir.hdr"),
        _j(folder, "swir.hdr"),
        output=str(tmp_path / "fixed.tif"),
        fraction=str(tmp_path / "fixed_f.tif"),
        surface=replace(surface, register=False),
    )
    assert (fixed["dsm_registration_rows"], fixed["dsm_registration_columns"]) == (0.0, 0.0)
    registered, unmoved = _read(tmp_path / "f1000.tif")[0], _read(tmp_path / "fixed_f.tif")[0]
    assert _f1(registered, sc.shadow_fraction) > _f1(unmoved, sc.shadow_fraction)


@pytest.mark.parametrize("azimuth", [0.0, 180.0])
def test_strips_equal_the_whole_image_with_the_far_end_swept(azimuth, tmp_path):
    """A high sun (60°: the clearance takes 1.7 px off each shadow's far end, swept back)
    from the north, then the south: strips of 16 lines look far enough towards the sun."""
    folder = str(tmp_path / "scene")
    sc = simulate2(rows=72, cols=96, seed=0, sun_zenith=60.0, sun_azimuth=azimuth)
    write_scene2(sc, folder)
    surface = SurfaceModel(_j(folder, "truth_dsm.tif"), 60.0, azimuth, sc.truth["gsd_m"])
    _, outs = _in_strips_and_whole(folder, surface, tmp_path)
    _assert_strips_equal_whole(outs[0][1], outs[1][1])


def test_deshadow_file_strips_equal_whole_and_report(scene, tmp_path):
    sc, folder = scene
    frac = tmp_path / "truth_f.tif"
    with rasterio.open(_j(folder, "truth_shadow_fraction.tif")) as src:
        prof = src.profile
        data = src.read(1)
    with rasterio.open(frac, "w", **prof) as dst:
        dst.write(data, 1)
    outs = []
    for rows in (16, 1000):
        r = deshadow_file(
            _j(folder, "vnir.hdr"),
            _j(folder, "swir.hdr"),
            shadow=str(frac),
            output=str(tmp_path / f"d{rows}.tif"),
            report=str(tmp_path / f"d{rows}.json"),
            block_rows=rows,
        )
        outs.append(_read(tmp_path / f"d{rows}.tif"))
    _assert_strips_equal_whole(outs[0], outs[1])
    rep = json.loads((tmp_path / "d16.json").read_text())
    nb = sc.vnir.shape[0] + sc.swir.shape[0]
    assert len(rep["bands"]) == nb == outs[0].shape[0]
    with rasterio.open(tmp_path / "d16.tif") as src:
        assert src.descriptions[0].startswith("VNIR 400.0")
        assert float(src.tags(1)["wavelength"]) == pytest.approx(400.0)
    # Out of shadow the values are the input's.
    lit = data == 0
    assert np.allclose(outs[0][0][lit], sc.vnir[0][lit], atol=0.01)
    assert r["pairs_used"] >= ds.MIN_PAIRS


def test_poor_agreement_points_to_the_surface_model_only_without_one(scene, tmp_path, monkeypatch):
    """The warning on pairs that agree poorly says what a surface model would leave out
    (pairs across a height step) when none is given, and not when it is."""
    from geoboresight.operations import deshadow as op

    sc, folder = scene
    monkeypatch.setattr(op, "POOR_SPREAD", -1.0)  # every fit "agrees poorly"
    t = sc.truth
    found = {}
    for name, surface in (
        ("none", SurfaceModel()),
        (
            "dsm",
            SurfaceModel(
                _j(folder, "truth_dsm.tif"),
                t["sun"]["zenith_deg"],
                t["sun"]["azimuth_deg"],
                t["gsd_m"],
            ),
        ),
    ):
        r = deshadow_file(
            _j(folder, "vnir.hdr"),
            _j(folder, "swir.hdr"),
            shadow=_j(folder, "truth_shadow_fraction.tif"),
            output=str(tmp_path / f"d_{name}.tif"),
            surface=surface,
        )
        found[name] = [w for w in r["warnings"] if "agree poorly" in w]
    assert len(found["none"]) == len(found["dsm"]) == 1
    assert "surface model" in found["none"][0] and "height step" in found["none"][0]
    assert "surface model" not in found["dsm"][0]


def test_bad_surface_inputs_give_one_clear_line(scene, tmp_path):
    sc, folder = scene
    small = tmp_path / "small.tif"
    with rasterio.open(
        small, "w", driver="GTiff", width=10, height=8, count=1, dtype="float32"
    ) as dst:
        dst.write(np.zeros((8, 10), "float32"), 1)
    v, s = _j(folder, "vnir.hdr"), _j(folder, "swir.hdr")
    out = str(tmp_path / "x.tif")
    with pytest.raises(InputError, match="8 × 10 cells but the image 72 × 96") as e:
        shadow_map_file(v, s, output=out, surface=SurfaceModel(str(small), 30.0, 150.0, 1.0))
    assert "\n" not in str(e.value)
    for zen, match in ((95.0, "sun_zenith"), (90.0, "horizon")):
        with pytest.raises(ParameterError, match=match) as e:
            shadow_map_file(
                v,
                s,
                output=out,
                surface=_surface(sc, folder).__class__(
                    _j(folder, "truth_dsm.tif"), zen, 150.0, 1.0
                ),
            )
        assert "\n" not in str(e.value)
    with pytest.raises(ParameterError, match="sun_zenith"):
        shadow_map_file(v, s, output=out, surface=SurfaceModel(_j(folder, "truth_dsm.tif")))
    with pytest.raises(InputError, match="shadow fraction .* 8 × 10 pixels"):
        deshadow_file(v, s, shadow=str(small), output=out)
    assert not os.path.exists(out)


def test_the_dsm_is_an_input_of_shadow_map(scene, tmp_path):
    # A file inside a parameter group is still checked as an input: not overwritten.
    sc, folder = scene
    from geoboresight.errors import OutputError

    dsm = _j(folder, "truth_dsm.tif")
    with pytest.raises(OutputError):
        shadow_map_file(
            _j(folder, "vnir.hdr"),
            _j(folder, "swir.hdr"),
            output=dsm,
            surface=_surface(sc, folder),
            overwrite=True,
        )
    assert os.path.exists(dsm)


def test_cli_runs_shadow_map_with_a_dsm_then_deshadow(scene, tmp_path):
    from geoboresight.cli import main

    sc, folder = scene
    t = sc.truth
    frac = str(tmp_path / "f.tif")
    r = CliRunner().invoke(
        main,
        [
            "shadow-map",
            "--vnir", _j(folder, "vnir.hdr"),
            "--swir", _j(folder, "swir.hdr"),
            "--dsm", _j(folder, "truth_dsm.tif"),
            "--sun-zenith", str(t["sun"]["zenith_deg"]),
            "--sun-azimuth", str(t["sun"]["azimuth_deg"]),
            "--cell-size", "1",
            "--fraction", frac,
            "-o", str(tmp_path / "c.tif"),
        ],
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(
        main,
        [
            "deshadow",
            "--vnir", _j(folder, "vnir.hdr"),
            "--swir", _j(folder, "swir.hdr"),
            "--shadow", frac,
            "-o", str(tmp_path / "d.tif"),
        ],
    )  # fmt: skip
    assert r.exit_code == 0, r.output
    with rasterio.open(tmp_path / "d.tif") as src:
        assert src.count == sc.vnir.shape[0] + sc.swir.shape[0]
    # The spec from Python, as QGIS and batch reach it.
    from geoboresight.algorithms import registry

    res = registry()["deshadow"](
        vnir=_j(folder, "vnir.hdr"),
        swir=_j(folder, "swir.hdr"),
        shadow=frac,
        output=str(tmp_path / "d2.tif"),
    )
    assert res["ratio_max"] > 3 and res["ratio_min"] >= 1


def test_deshadow_file_with_a_dsm_strips_equal_whole(scene, tmp_path):
    # The sky-view factor is computed on each strip's DSM read beyond it by the horizon
    # search's reach, the pairs with their heights: strips give the whole image's result.
    sc, folder = scene
    frac = tmp_path / "truth_f.tif"
    with rasterio.open(_j(folder, "truth_shadow_fraction.tif")) as src:
        prof = src.profile
        data = src.read(1)
    with rasterio.open(frac, "w", **prof) as dst:
        dst.write(data, 1)
    outs, results = [], []
    for rows in (16, 1000):
        results.append(
            deshadow_file(
                _j(folder, "vnir.hdr"),
                _j(folder, "swir.hdr"),
                shadow=str(frac),
                output=str(tmp_path / f"d{rows}.tif"),
                surface=_surface(sc, folder),
                block_rows=rows,
            )
        )
        outs.append(_read(tmp_path / f"d{rows}.tif"))
    _assert_strips_equal_whole(outs[0], outs[1])
    assert results[0]["pairs_used"] == results[1]["pairs_used"] >= ds.MIN_PAIRS
    # Out of shadow the values are the input's.
    lit = data == 0
    assert np.allclose(outs[0][0][lit], sc.vnir[0][lit], atol=0.01)


def test_deshadow_bad_surface_inputs_give_one_clear_line(scene, tmp_path):
    sc, folder = scene
    small = tmp_path / "small.tif"
    with rasterio.open(
        small, "w", driver="GTiff", width=10, height=8, count=1, dtype="float32"
    ) as dst:
        dst.write(np.zeros((8, 10), "float32"), 1)
    v, s = _j(folder, "vnir.hdr"), _j(folder, "swir.hdr")
    shadow = _j(folder, "truth_shadow_fraction.tif")
    out = str(tmp_path / "x.tif")
    with pytest.raises(InputError, match="surface model .*8 × 10 cells") as e:
        deshadow_file(
            v, s, shadow=shadow, output=out, surface=SurfaceModel(str(small), 30.0, 150.0, 1.0)
        )
    assert "\n" not in str(e.value)
    with pytest.raises(ParameterError, match="sun_zenith") as e:
        deshadow_file(
            v, s, shadow=shadow, output=out, surface=SurfaceModel(_j(folder, "truth_dsm.tif"))
        )
    assert "\n" not in str(e.value)
    assert not os.path.exists(out)
