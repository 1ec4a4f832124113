"""The shadow map's and the de-shadowing's kernel steps on small arrays: the surface prior
(shadow.prior) against the geometry of a block casting on level ground, the de-shadowing's
steps (shadow.deshadow_steps) against the correction's closed form, and the provenance
generated from the kernels' constants."""

from __future__ import annotations

import math

import numpy as np
import pytest

from geoboresight.sensor.dark import DarkLevels
from geoboresight.shadow import blocks, darkness
from geoboresight.shadow import deshadow_steps as dst
from geoboresight.shadow import illumination as ill
from geoboresight.shadow import prior as sp
from geoboresight.shadow.classes import default_table

CELL = 1.0
BLOCK_M = 10.0  # a flat-topped block 10 m high on level ground


def _prior(azimuth=180.0, zenith=45.0, clearance=0.0, top=BLOCK_M, relief=BLOCK_M, shape=(40, 30)):
    return sp.surface_prior(
        relief,
        top,
        sun_zenith=zenith,
        sun_azimuth=azimuth,
        transform=ill.grid_matrix(None, CELL),
        surface="blocks",
        clearance=clearance,
        shape=shape,
    )


def _block(shape=(40, 30)):
    z = np.zeros(shape)
    z[25:30, 10:20] = BLOCK_M
    return z


@pytest.mark.parametrize(
    ("zenith", "clearance", "cell"), [(45.0, 0.0, 1.0), (60.0, 1.0, 2.0), (30.0, 0.5, 0.5)]
)
def test_the_reach_is_the_clearance_times_tan_zenith_in_cells(zenith, clearance, cell):
    p = sp.surface_prior(
        5.0,
        5.0,
        sun_zenith=zenith,
        sun_azimuth=123.0,
        transform=ill.grid_matrix(None, cell),
        surface="smooth",
        clearance=clearance,
        shape=(20, 20),
    )
    assert p.reach == pytest.approx(clearance * math.tan(math.radians(zenith)) / cell)
    # One cell a step towards the sun: azimuth 123° is east of south (rows grow southward).
    az = math.radians(123.0)
    assert p.ray[:2] == pytest.approx((-math.cos(az), math.sin(az)))
    assert p.ray[2] >= 1 and p.shift == (0.0, 0.0)


def test_the_prior_is_the_blocks_shadow_on_level_ground():
    """Sun in the south at 45°: a 10 m block shades the 10 cells north of it, not its top
    and nothing south of it; a 2 m clearance takes 2 m · tan 45° = 2 cells off the far end."""
    z, ok = _block(), np.ones((40, 30), bool)
    f = sp.prior_fraction(z, ok, surface_prior=_prior())
    assert f.dtype == np.float32
    assert (f[15:25, 11:19] == 1).all()  # the shadow's 10 lines
    assert (f[:14] == 0).all() and (f[25:] == 0).all()
    short = sp.prior_fraction(z, ok, surface_prior=_prior(clearance=2.0))
    assert (short[18:25, 11:19] == 1).all() and (short[:16] == 0).all()
    assert _prior(clearance=2.0).reach == pytest.approx(2.0)


def test_the_prior_from_sub_cells_and_moved_by_the_registration():
    z, ok = _block(), np.ones((40, 30), bool)
    ok[0, 0] = False
    p = _prior()
    cast = sp.sub_cell_cast(z, ok, surface_prior=p)
    assert cast.shape == (40 * ill.SUPERSAMPLE, 30 * ill.SUPERSAMPLE)
    direct = sp.prior_fraction(z, ok, surface_prior=p)
    np.testing.assert_array_equal(sp.prior_fraction(z, ok, surface_prior=p, sub_cells=cast), direct)
    assert np.isnan(direct[0, 0])
    # Moved a whole line south: the same shadow one line further down (nothing comes in).
    moved = sp.prior_fraction(z, None, surface_prior=_replace(p, shift=(1.0, 0.0)), sub_cells=cast)
    still = sp.prior_fraction(z, None, surface_prior=p, sub_cells=cast)
    np.testing.assert_array_equal(moved[1:], still[:-1])
    assert (moved[0] == 0).all()


def _replace(p, **kw):
    import dataclasses

    return dataclasses.replace(p, **kw)


def test_the_heights_move_with_the_cast_shadow():
    rows, cols = np.mgrid[0:12, 0:9].astype(np.float64)
    z = 2.0 * rows + 0.5 * cols
    ok = np.ones(z.shape, bool)
    ok[5, 4] = False
    still = sp.registered_heights(z, ok, surface_prior=_prior())
    assert np.isnan(still[5, 4]) and np.array_equal(still[ok], z[ok])
    moved = sp.registered_heights(z, None, surface_prior=_replace(_prior(), shift=(1.0, 0.0)))
    # A whole line down: each cell holds the height of the cell above it; the first line none.
    np.testing.assert_allclose(moved[1:], z[:-1])
    assert np.isnan(moved[0]).all()


def test_unseen_pixels_are_those_a_caster_beyond_the_edge_could_shade():
    """Sun in the north at 45°, level ground, the model's top 10 m: a caster that high just
    beyond the north edge shades the ground within 10 m · tan 45° = 10 cells of it."""
    p = _prior(azimuth=0.0, relief=0.0, top=10.0)
    u = sp.unseen_pixels(np.zeros((40, 30)), None, surface_prior=p)
    assert u[:10].all() and not u[11:].any()
    # A strip of the grid gives its own lines of the whole answer.
    np.testing.assert_array_equal(
        sp.unseen_pixels(np.zeros((8, 30)), None, surface_prior=p, row0=6), u[6:14]
    )


@pytest.mark.parametrize(("azimuth", "up"), [(0.0, True), (180.0, False)])
def test_the_halo_adds_the_sweep_towards_the_sun(azimuth, up):
    p = _prior(azimuth=azimuth, clearance=2.5)  # reach 2.5 cells: 3 lines, and one more
    sweep = 4
    got = sp.prior_halo(p, 5, (2, 7))
    assert got == ((5 + 2 + sweep, 5 + 7) if up else (5 + 2, 5 + 7 + sweep))


def _calibrated_block(rows=40, cols=30):
    """A block of blue, NIR and SWIR DN (dark level 100) with the block's shadow darkening
    the image, and the scene's calibration from it."""
    lit = np.ones((rows, cols))
    lit[15:25, 10:20] = 0.06
    dark = 100.0
    blue = dark + 300 * (0.3 + 0.7 * lit)[None].repeat(2, 0)
    nir = dark + 1000 * lit[None].repeat(2, 0)
    swir = dark + 800 * lit[None].repeat(2, 0)
    sig = [darkness.signal(x, dark).ravel() for x in (blue, nir, swir)]
    cal = darkness.calibrate_shadow_map(
        *sig,
        np.ones_like(sig[0]),
        np.ones(rows * cols, bool),
        dark=DarkLevels(dark, dark),
        table=default_table(),
    )
    block = dict(calibration=cal, dark_levels=(dark, dark, dark), edge_pixels=2)
    return blue, nir, swir, block


def test_the_block_with_the_model_finds_its_shadow_and_falls_back_where_it_has_no_height():
    blue, nir, swir, block = _calibrated_block()
    z, z_ok = _block(), np.ones((40, 30), bool)
    z_ok[:, :5] = False  # beyond the model's extent
    b = blocks.prior_map_block(
        blue, nir, swir, z, heights_valid=z_ok, surface_prior=_prior(), **block
    )
    assert (b.fraction[16:24, 11:19] >= 0.5).all()  # predicted and dark
    assert (b.fraction[:10, 5:] == 0).all()  # lit and not predicted
    assert b.holes[:, :5].all() and not b.holes[:, 5:].any()
    spectral, _ = blocks.shadow_fraction_block(blue, nir, swir, None, **block)
    np.testing.assert_array_equal(b.fraction[:, :5], spectral[:, :5])
    assert b.deep.any() and not b.lit.any()  # the predicted shadow is dark


def test_registration_off_keeps_the_cast_and_measures_the_agreement():
    blue, nir, swir, block = _calibrated_block()
    z, z_ok = _block(), np.ones((40, 30), bool)
    p, agree = blocks.register_prior(
        blue, nir, swir, z, heights_valid=z_ok, surface_prior=_prior(), register=False, **block
    )
    assert p.shift == (0.0, 0.0)
    assert agree["dsm_registration_r"] is None and agree["dsm_registration_rows"] == 0.0
    assert (agree["dsm_shift_rows"], agree["dsm_shift_columns"]) == (0, 0)
    assert agree["dsm_iou"] == agree["dsm_iou_at_shift"] > 0.9


def test_the_method_is_written_from_the_kernel_constants(monkeypatch):
    assert darkness.log_fraction_text(math.log(1 / 2)) == "ln 1/2"
    assert darkness.log_fraction_text(darkness.RIM_DARKNESS) == "ln 1/3"
    assert darkness.log_fraction_text(-0.8) == "-0.800"
    p = _prior(clearance=1.5)
    text = sp.prior_method(p, registered=False, edge_pixels=2)
    assert "lit above ln 1/2" in text and "at or below ln 1/3" in text and "1.5 m" in text
    assert f"within {darkness.DSM_TOLERANCE} px" in text and "moved by" not in text
    monkeypatch.setattr(darkness, "LIT_DARKNESS", math.log(1 / 4))
    assert "lit above ln 1/4" in sp.prior_method(p, registered=True, edge_pixels=2)


# ------------------------------------------------------------------------------ de-shadowing


def test_the_pair_share_is_picked_by_position_whatever_the_strips():
    share = dst.pair_share((1000, 1000))  # 250,000 of 1,000,000 pixels
    assert share == 250
    picked = dst.picked_pixels(0, (500, 400), share)
    assert picked.mean() == pytest.approx(0.25, abs=0.01)
    np.testing.assert_array_equal(dst.picked_pixels(123, (40, 400), share), picked[123:163])
    assert dst.pair_share((10, 10)) == dst.PAIR_BUCKETS and dst.pair_share((10**5, 10**5)) == 1


def test_the_darkest_pixels_by_their_band_mean():
    rng = np.random.default_rng(0)
    sig = rng.uniform(0, 100, (3, 6, 7))
    ok = np.ones((6, 7), bool)
    ok[0, 0] = False
    sig[:, 1, 1] = np.nan
    got = dst.darkest_pixels(sig, ok, n=5)
    use = ok & np.isfinite(sig).all(axis=0)
    px = sig[:, use].T
    truth = px[np.argsort(px.mean(axis=1))[:5]]
    np.testing.assert_allclose(np.sort(got.mean(axis=1)), np.sort(truth.mean(axis=1)), rtol=1e-6)
    merged = dst.keep_darkest(np.concatenate([got, truth.astype(np.float32)]), 5)
    assert merged.shape == (5, 3) and merged.mean(axis=1).max() <= truth.mean(axis=1).max() + 1e-4


def test_edge_pairs_pair_the_shaded_side_with_the_sunlit_one():
    """A shadow edge between signal 10 (shaded) and 30 (sunlit) in every band."""
    rows, cols = 12, 16
    f = np.zeros((rows, cols))
    f[:, :8] = 1.0
    sig = np.where(f > 0.5, 10.0, 30.0)[None].repeat(3, 0)
    own = np.ones((rows, cols), bool)
    e = dst.edge_pairs(sig, f, None, None, own=own, picked=own, n_vnir=2, offset=(0.0, 0.0))
    assert e.shaded.shape[0] > 0 and e.shaded.shape == e.sunlit.shape == (e.views.shape[1], 3)
    np.testing.assert_allclose(e.shaded, 10.0)
    np.testing.assert_allclose(e.sunlit, 30.0)
    assert (e.views == 1).all()  # no surface model: open sky, flat
    assert e.dark_vnir.shape[1] == 2 and e.dark_swir.shape[1] == 1
    both = dst.merge_edge_pairs(dst.EdgePairs.empty(3, 2, False), e)
    np.testing.assert_array_equal(both.shaded, e.shaded)


def test_the_illumination_fit_recovers_the_ratio_of_each_band():
    rng = np.random.default_rng(3)
    k = np.array([2.0, 3.0, 4.0, 0.8])  # the last band darkens in the sun: left unchanged
    shaded = rng.uniform(20, 60, (400, 4)).astype(np.float32)
    pairs = dst.EdgePairs(
        shaded,
        (shaded * k).astype(np.float32),
        np.ones((3, 400), np.float32),
        np.zeros((0, 2), np.float32),
        np.zeros((0, 2), np.float32),
        np.zeros((400, 0), np.float32),
        np.zeros((400, 0), np.float32),
    )
    fit = dst.fit_illumination(pairs, np.array([450.0, 650.0, 850.0, 1650.0]))
    np.testing.assert_allclose(fit.ratio, [2.0, 3.0, 4.0, 1.0], rtol=1e-5)
    assert fit.unchanged == 1 and fit.spread < 1e-5 and (fit.additive == 0).all()


def test_the_block_is_scaled_by_the_closed_form():
    """L_sun = L / (1 − f·(1 − 1/k)) above the base, on each instrument's grid (no offset)."""
    k = np.array([2.0, 3.0, 5.0])
    f = np.array([[0.0, 0.5, 1.0, np.nan]])
    cube = np.full((3, 1, 4), 150.0)
    base = np.full((3, 1, 1), 100.0)
    fit = dst.IlluminationFit(
        k, 10, 0.0, np.zeros(3), np.full(3, np.inf), np.zeros(3), np.zeros(3),
        np.full(3, np.nan), np.zeros(3), np.zeros(3),
    )  # fmt: skip
    out, shaded = dst.deshadow_block(cube, f, None, base=base, fit=fit, n_vnir=2, offset=(0.0, 0.0))
    for b in range(3):
        for c in range(3):
            want = 100.0 + 50.0 / (1.0 - f[0, c] * (1.0 - 1.0 / k[b]))
            assert out[b, 0, c] == pytest.approx(want, rel=1e-5)
    assert shaded.tolist() == [[False, True, True, False]]
