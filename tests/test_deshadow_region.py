"""Each neighbourhood's own illumination ratio (geoboresight.shadow.region): the kernels
against their definitions, and de-shadowing against each pixel's own sunlit signal (the scene
simulated without cast shadows) on both scene models, where the shadows of one half of the
scene see less sky than the other's."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
import rasterio
from scipy import ndimage

from geoboresight import LightModel, deshadow_file
from geoboresight.io.scene import write_scene
from geoboresight.shadow import deshadow as ds
from geoboresight.shadow import deshadow_steps as dst
from geoboresight.shadow import region
from geoboresight.simulate import simulate_scene
from validation.scene_model2 import simulate2, write_scene2
from validation.shadow import SIM_DARK, write_dark_reference

K = np.array([2.0, 3.0, 5.0, 9.0, 17.0, 1.2])  # the scene's ratio; the last band k − 1 < 0.5


def test_a_pair_of_one_surface_gives_its_scale_of_k_minus_1():
    s = np.array([0.6, 1.0, 1.7])
    r = 1.0 + s[:, None] * (K - 1.0)
    got, rms = region.pair_scales(r, K)
    np.testing.assert_allclose(got, s, rtol=1e-12)
    np.testing.assert_allclose(rms, 0.0, atol=1e-12)
    # Another material across the edge (its spectrum's shape) departs from the model.
    shape = np.array([1.0, 1.3, 0.8, 1.5, 0.6, 1.0])
    assert region.pair_scales(r * shape, K)[1].min() > region.SAME_SURFACE_RMS


def test_open_ratios_are_those_the_scene_ratio_averages():
    rng = np.random.default_rng(0)
    a = rng.uniform(5, 20, (30, 6))
    va, vb, d = rng.uniform(0.4, 1, 30), rng.uniform(0.6, 1, 30), rng.uniform(0.7, 1.2, 30)
    b = a * ((K - 1.0) * d[:, None] / va[:, None] + vb[:, None] / va[:, None])
    got = region.open_ratios(a, b, sky_view=(va, vb), direct=d)
    np.testing.assert_allclose(got, np.broadcast_to(K, got.shape), rtol=1e-10)
    k, n, _ = ds.illumination_ratio(a, b, sky_view=(va, vb), direct=d, keep=1.0)
    np.testing.assert_allclose(k, K, rtol=1e-10)


def test_each_tile_takes_the_median_of_its_neighbourhood_and_the_scene_elsewhere():
    rng = np.random.default_rng(1)
    # Pairs in two places: 40 with scale 1.5 around (20, 20), 5 around (20, 300).
    rows = np.r_[rng.integers(10, 30, 40), rng.integers(10, 30, 5)]
    cols = np.r_[rng.integers(10, 30, 40), rng.integers(290, 310, 5)]
    s = np.r_[np.full(40, 1.5), np.full(5, 0.7)]
    grid, count = region.region_scale(rows, cols, s, (64, 320), tile=32, reach=1, min_pairs=12)
    assert grid.shape == (2, 10)
    assert grid[0, 0] == pytest.approx(1.5) and grid[1, 1] == pytest.approx(1.5)
    assert np.isnan(grid[0, 9]) and count[0, 9] == 5  # too few: the scene's ratio
    assert np.isnan(grid[0, 5]) and count[0, 5] == 0
    # Kept within the trusted range; the pairs marked as other surfaces do not count.
    assert region.region_scale(rows, cols, s * 10, (64, 320))[0][0, 0] == region.SCALE_RANGE[1]
    ok = np.r_[np.zeros(40, bool), np.ones(5, bool)]
    assert np.isnan(region.region_scale(rows, cols, s, (64, 320), ok, tile=32)[0]).all()
    px = region.pixel_scale(grid, 0, (64, 320), tile=32)
    assert px[16, 16] == pytest.approx(1.5) and px[16, 300] == pytest.approx(1.0)
    # A block of the line gets the same scales as the whole line.
    np.testing.assert_allclose(region.pixel_scale(grid, 20, (30, 320), tile=32), px[20:50])


def test_deshadow_with_a_scale_is_deshadow_with_the_scaled_ratio():
    rng = np.random.default_rng(2)
    x = rng.uniform(1, 50, (6, 8, 9))
    f = rng.uniform(0, 1, (8, 9))
    scale = np.full((8, 9), 1.4)
    got = ds.deshadow(x, f, ratio=K, scale=scale)
    np.testing.assert_allclose(got, ds.deshadow(x, f, ratio=1 + 1.4 * (K - 1)), rtol=1e-6)


def test_narrow_shadows_measure_the_ratio_on_their_edge_pixels():
    # Shadows two pixels wide: no pixel lies inside one, so no inset pair exists.
    f = np.zeros((40, 60))
    f[5:35, 10:12] = f[5:35, 30:32] = f[5:35, 50:52] = 1.0
    k_true = np.array([3.0, 8.0])
    rho = np.full((2, 40, 60), 40.0)
    signal = rho * np.where(f >= 0.9, 1.0 / k_true[:, None, None], 1.0)
    kw = dict(own=np.ones(f.shape, bool), picked=np.ones(f.shape, bool), n_vnir=1)
    pairs = dst.edge_pairs(signal, f, None, None, offset=(0.0, 0.0), **kw)
    assert pairs.inset.sum() == 0 and pairs.shaded.shape[0] >= ds.MIN_PAIRS
    with pytest.raises(ds.InputError):  # what the inset pairs alone give: too few
        ds.illumination_ratio(pairs.shaded[pairs.inset], pairs.sunlit[pairs.inset])
    fit = dst.fit_illumination(pairs, np.array([500.0, 1600.0]), shape=f.shape)
    assert fit.edge_pairs
    np.testing.assert_allclose(fit.ratio, k_true, rtol=1e-5)
    # With a pixel inside the shadows, the edge pixels are not used.
    f[5:35, 10:16] = 1.0
    signal = rho * np.where(f >= 0.9, 1.0 / k_true[:, None, None], 1.0)
    wide = dst.edge_pairs(signal, f, None, None, offset=(0.0, 0.0), **kw)
    assert not dst.fit_illumination(wide, np.array([500.0, 1600.0])).edge_pairs
    # They are counted, not kept: this block's inset pairs alone rule them out of the fit.
    assert wide.inset.all() and wide.inset.sum() >= ds.MIN_PAIRS and wide.skipped > 0
    # Merged with the narrow shadows' block (either first), whose edge pairs the merge
    # drops: the fit is the wide block's alone, every pair counted.
    wl = np.array([500.0, 1600.0])
    for merged in (dst.merge_edge_pairs(pairs, wide), dst.merge_edge_pairs(wide, pairs)):
        assert merged.inset.all() and merged.shaded.shape[0] == wide.shaded.shape[0]
        assert merged.count == pairs.count + wide.count
        one, both = dst.fit_illumination(wide, wl), dst.fit_illumination(merged, wl)
        np.testing.assert_array_equal(both.ratio, one.ratio)
        assert both.pairs_used == one.pairs_used and not both.edge_pairs


def test_a_scene_of_narrow_shadows_is_deshadowed_with_a_warning(tmp_path):
    # The simulator's mixed preset with the sun 20° from the zenith: its cast shadows are
    # one or two pixels wide, too few pixels lie inside them.
    sc = simulate_scene("mixed", lines=128, seed=41, sun_zenith=20.0, sun_azimuth=248.0, aot550=0.3)
    folder = str(tmp_path / "scene")
    write_scene(sc, folder)
    assert ds.pair_indices(sc.shadow_fraction)[0].size < ds.MIN_PAIRS
    r = deshadow_file(
        f"{folder}/vnir.hdr",
        f"{folder}/swir.hdr",
        shadow=f"{folder}/truth_shadow_fraction.tif",
        output=str(tmp_path / "d.tif"),
    )
    assert r["pairs_used"] >= ds.MIN_PAIRS and r["shadowed_pixels"] > 0
    assert any("too narrow" in w for w in r["warnings"])


#: The share of the sky the shadows of the scene's left half see, against the right half's.
SKY = 0.6


def _scene_with_less_sky(model, folder):
    """A scene whose left half sees ``SKY`` × the sky of the right half (a street canyon's
    against open ground), written to ``folder``; returns (truth fraction, each pixel's own
    sunlit signal above the dark level)."""
    if model == 1:
        kw = dict(lines=128, seed=2, sun_zenith=50.0)
        scenes = [simulate_scene("mixed", noise_free=nf, **kw) for nf in (False, True)]
        scenes.append(simulate_scene("mixed", noise_free=True, cast_shadows=False, **kw))
        darks = [
            (np.full(s.vnir.shape[0], SIM_DARK[0]), np.full(s.swir.shape[0], SIM_DARK[1]))
            for s in scenes
        ]
        offset = [scenes[0].truth["offset_px"][k] for k in ("along", "across")]
    else:
        kw = dict(rows=128, cols=256, seed=3, sun_zenith=50.0, relief_m=0.0)
        scenes = [simulate2(noise=n, **kw) for n in (True, False)]
        scenes.append(simulate2(noise=False, cast_shadows=False, **kw))
        # The noise-free runs draw the SWIR's dark pattern anew: each its own levels.
        darks = [(s.truth["vnir_dark_dn"], s.truth["swir_dark_dn"]) for s in scenes]
        offset = scenes[0].truth["offset_px"]
    noisy, clean, twin = scenes
    f = noisy.shadow_fraction
    left = np.arange(f.shape[1]) < f.shape[1] // 2
    out, own = [], []
    for i, name in enumerate(("vnir", "swir")):
        n, c, t = (
            getattr(s, name).astype(float) - np.asarray(d[i], float)[:, None, None]
            for s, d in zip(scenes, darks, strict=True)
        )
        # The fraction on this instrument's grid (a feature at VNIR row r, column c is at
        # SWIR row r + along, column c + across: truth.json's convention).
        fi = f if i == 0 else ndimage.shift(f, offset, order=1, mode="nearest")
        # The sky's light on each pixel: C = (1 − f)·P + D and T = P + D in shadow; in the
        # sun (and in little shadow) T/k, k the scene's sunlit-to-shadow ratio of the band.
        with np.errstate(invalid="ignore", divide="ignore"):
            k = np.median(t[:, fi >= 0.999] / c[:, fi >= 0.999], axis=1)[:, None, None]
            sky = np.where(fi >= 0.5, (c - (1.0 - fi) * t) / fi, t / k)
        cut = (1.0 - SKY) * np.clip(sky, 0.0, None) * left
        d0 = np.asarray(darks[0][i], float)[:, None, None]
        out.append(np.clip(np.rint(n - cut + d0), 0, 4095).astype(np.uint16))
        own.append(t - cut)
    if model == 1:
        write_scene(dataclasses.replace(noisy, vnir=out[0], swir=out[1]), folder)
    else:
        write_scene2(dataclasses.replace(noisy, vnir=out[0], swir=out[1]), folder)
    write_dark_reference(folder, darks[0])
    return f, np.concatenate(own)


def _brightness_errors(folder, tmp_path, f, own, **kw):
    """De-shadow with the truth fraction; the brightness error of the mean de-shadowed
    spectrum of the left half's fully shadowed pixels against their own sunlit signal, over
    the bands de-shadowed (and whose sunlit signal is ≥ 2 % of the brightest band's)."""
    out, rep = str(tmp_path / f"d{len(kw)}.tif"), str(tmp_path / f"d{len(kw)}.json")
    r = deshadow_file(
        f"{folder}/vnir.hdr", f"{folder}/swir.hdr", shadow=f"{folder}/truth_shadow_fraction.tif",
        output=out, report=rep, **kw,
    )  # fmt: skip
    bands = json.loads(open(rep).read())["bands"]
    dark = np.array([b["dark_level_dn"] for b in bands])[:, None, None]
    fixed = np.array([b["corrected"] for b in bands])
    with rasterio.open(out) as src:
        x = src.read().astype(float)
    has = (x != -9999.0).all(axis=0)
    x = x - dark
    # Fully shadowed, a pixel inside the shadow, and away from the halves' border by more
    # than a neighbourhood.
    full = ndimage.binary_erosion(f >= 0.999) & has
    full[:, f.shape[1] // 2 - 2 * region.TILE :] = False
    a, b = x[:, full].mean(axis=1), own[:, full].mean(axis=1)
    use = fixed & (b >= 0.02 * b.max())
    return float(a[use].mean() / b[use].mean() - 1.0), r, int(full.sum())


@pytest.mark.parametrize(
    "model",
    [
        1,
        pytest.param(
            2,
            marks=pytest.mark.xfail(
                strict=True,
                reason="on model 2 the pairs of one spectral shape across the edges of the "
                "darker half's shadows measure too low a scale (0.5 for 1.67): the option "
                "does worse there, as on model 2's hold-out scenes",
            ),
        ),
    ],
)
def test_each_neighbourhood_s_ratio_beats_the_scene_s_where_shadows_see_less_sky(model, tmp_path):
    folder = str(tmp_path / "scene")
    f, own = _scene_with_less_sky(model, folder)
    scene, _, n = _brightness_errors(folder, tmp_path, f, own)
    local, r, _ = _brightness_errors(folder, tmp_path, f, own, light=LightModel(regions=True))
    assert n >= 100 and r["regions"] > 0
    # One ratio for the scene under-corrects the half that sees less sky (by 31 % on the
    # simulator); its neighbourhoods' own ratios take most of that away (8 %: their scale is
    # the median of a few dozen noisy pairs).
    assert scene < -0.2
    assert abs(local) < 0.5 * abs(scene)


def test_each_neighbourhood_s_ratio_is_the_same_read_in_strips(tmp_path):
    sc = simulate_scene("urban", lines=96, seed=2, sun_zenith=45.0)
    folder = str(tmp_path / "scene")
    write_scene(sc, folder)
    cubes, results = [], []
    for rows in (4096, 24):
        out = str(tmp_path / f"d{rows}.tif")
        results.append(
            deshadow_file(
                f"{folder}/vnir.hdr",
                f"{folder}/swir.hdr",
                shadow=f"{folder}/truth_shadow_fraction.tif",
                output=out,
                light=LightModel(regions=True),
                block_rows=rows,
            )
        )
        with rasterio.open(out) as src:
            cubes.append(src.read())
    assert results[0]["regions"] == results[1]["regions"] > 0
    np.testing.assert_allclose(cubes[1], cubes[0], rtol=1e-5)
