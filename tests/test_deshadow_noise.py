"""De-shadowing and the noise: a band whose signal in full shadow the noise does not resolve
is flagged and left as measured, not amplified.

Independent truth: Gaussian noise of a known σ drawn with NumPy; and each scene model run
twice, with and without its noise (the simulator's ``noise_free``, model 2's ``noise=False``:
same layout and spectra), so that each band's true noise in shadow is the spread of the
difference and its true signal the noise-free cube above its true dark level.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio
from scipy import ndimage

from geoboresight import deshadow_file
from geoboresight.errors import InputError, ParameterError
from geoboresight.io.scene import write_scene
from geoboresight.shadow import deshadow as ds
from geoboresight.shadow import deshadow_steps as dst
from geoboresight.simulate import simulate_scene
from validation.scene_model2 import simulate2, write_scene2
from validation.shadow import SIM_DARK, write_dark_reference


def test_the_noise_of_neighbouring_shadowed_pixels_is_the_drawn_sigma():
    """Flat shadowed patches with white noise σ = 4 and 12 DN in two bands: the robust spread
    of neighbours' differences gives σ to the MAD's sampling error (≈ 1.67 / √n: 3 % at
    n ≈ 3,000 pairs; 4 sampling errors allowed)."""
    rng = np.random.default_rng(5)
    sigma = np.array([4.0, 12.0])
    signal = np.array([40.0, 20.0])[:, None, None] + sigma[:, None, None] * rng.standard_normal(
        (2, 60, 60)
    )
    fraction = np.ones((60, 60))
    ok = np.ones((60, 60), bool)
    steps = dst.shadow_steps(signal, fraction, ok, ok)
    assert steps.shape == (2, 60 * 59, 2)
    level, noise = ds.shadow_noise(steps[0], steps[1])
    np.testing.assert_allclose(noise, sigma, rtol=4 * 1.67 / np.sqrt(60 * 59))
    np.testing.assert_allclose(level, [40.0, 20.0], atol=1.0)


def test_only_fully_shadowed_neighbours_are_sampled():
    f = np.zeros((4, 6))
    f[:, :3] = 1.0
    f[0, 1] = 0.5
    sig = np.arange(24, dtype=float).reshape(1, 4, 6)
    ok = np.ones((4, 6), bool)
    ok[3, 0] = False
    steps = dst.shadow_steps(sig, f, ok, ok)
    # Pairs (row, left column): (1, 0), (1, 1), (2, 0), (2, 1), (3, 1).
    assert steps.shape == (2, 5, 1)
    np.testing.assert_allclose(steps[1], 1.0)
    np.testing.assert_allclose(np.sort(steps[0, :, 0]), [6.5, 7.5, 12.5, 13.5, 19.5])


def test_resolved_bands_are_those_3_sigma_above_zero():
    got = ds.resolved_bands(
        np.array([30.0, 29.0, 5.0, np.nan, 10.0, 0.0]),
        np.array([10.0, 10.0, 10.0, 1.0, np.nan, 0.0]),
    )
    assert got.tolist() == [True, False, False, False, True, False]
    with pytest.raises(ParameterError, match="min_snr"):
        ds.resolved_bands(np.ones(2), np.ones(2), min_snr=0.0)
    with pytest.raises(InputError, match="levels of shape"):
        ds.shadow_noise(np.ones((5, 2)), np.ones((5, 3)))
    # Too few pairs: the noise is unknown and nothing is flagged.
    level, noise = ds.shadow_noise(np.ones((5, 2)), np.ones((5, 2)))
    assert np.isnan(noise).all() and ds.resolved_bands(level, noise).all()


def test_the_fit_leaves_an_unresolved_band_at_ratio_1():
    rng = np.random.default_rng(3)
    k = np.array([2.0, 3.0, 4.0])
    shaded = rng.uniform(20, 60, (400, 3))
    shaded[:, 2] = rng.uniform(1, 3, 400)  # a band 1–3 DN in shadow …
    steps = np.stack([np.tile([40.0, 40.0, 2.0], (200, 1)), rng.normal(0, 2.0, (200, 3))])
    steps[1, :, 2] = rng.normal(0, 8.0, 200)  # … against 8 DN of noise
    pairs = dst.EdgePairs(
        shaded.astype(np.float32),
        (shaded * k).astype(np.float32),
        np.ones((3, 400), np.float32),
        np.zeros((0, 2), np.float32),
        np.zeros((0, 1), np.float32),
        np.zeros((400, 0), np.float32),
        np.zeros((400, 0), np.float32),
        steps[:, :, :2].astype(np.float32),
        steps[:, :, 2:].astype(np.float32),
    )
    fit = dst.fit_illumination(pairs, np.array([450.0, 850.0, 1650.0]))
    np.testing.assert_allclose(fit.ratio, [2.0, 3.0, 1.0], rtol=1e-5)
    assert fit.resolved.tolist() == [True, True, False] and fit.unresolved == 1
    merged = dst.merge_edge_pairs(dst.EdgePairs.empty(3, 2, False), pairs)
    assert merged.steps_vnir.shape == (2, 200, 2) and merged.steps_swir.shape == (2, 200, 1)


def _scene(model, tmp_path):
    """(folder, noise-free VNIR and SWIR signal above the true dark level, the noisy cube's
    difference from the noise-free one, truth fraction) of a small scene of ``model``."""
    folder = str(tmp_path / "scene")
    if model == 1:
        kw = dict(lines=72, seed=2, sun_zenith=45.0)
        noisy = simulate_scene("urban", **kw)
        clean = simulate_scene("urban", noise_free=True, **kw)
        write_scene(noisy, folder)
        dark = dark_clean = list(SIM_DARK)  # one level per instrument
    else:
        kw = dict(rows=72, cols=96, seed=3, sun_zenith=45.0)
        noisy = simulate2(**kw)
        clean = simulate2(noise=False, **kw)
        write_scene2(noisy, folder)
        dark = [noisy.truth["vnir_dark_dn"], noisy.truth["swir_dark_dn"]]
        # A sensor product's dark reference: each band's level in the header.
        write_dark_reference(folder, dark)
        # The noise-free run draws the SWIR's dark pattern anew: its own levels.
        dark_clean = [clean.truth["vnir_dark_dn"], clean.truth["swir_dark_dn"]]
    out = []
    for a, b, d, dc in zip(
        (noisy.vnir, noisy.swir), (clean.vnir, clean.swir), dark, dark_clean, strict=True
    ):
        d = np.broadcast_to(np.asarray(d, float), (a.shape[0],))[:, None, None]
        dc = np.broadcast_to(np.asarray(dc, float), (a.shape[0],))[:, None, None]
        out.append((b.astype(float) - dc, (a.astype(float) - d) - (b.astype(float) - dc)))
    signal = np.concatenate([o[0] for o in out])
    diff = np.concatenate([o[1] for o in out])
    return folder, signal, diff, noisy.shadow_fraction


@pytest.mark.parametrize("model", [1, 2])
def test_the_flagged_bands_are_those_the_true_noise_does_not_resolve(model, tmp_path):
    folder, signal, diff, f = _scene(model, tmp_path)
    # Deep inside full shadow (2 px from its edge, more than the SWIR's offset): each band's
    # true signal and noise there.
    deep = ndimage.binary_erosion(f >= 0.999, iterations=2)
    true_signal = np.median(signal[:, deep], axis=1)
    true_noise = diff[:, deep].std(axis=1)
    snr = true_signal / true_noise
    assert (snr < 2).sum() >= 10 and (snr > 6).sum() >= 50  # both kinds of band are there
    frac = str(tmp_path / "f.tif")
    with rasterio.open(f"{folder}/truth_shadow_fraction.tif") as src:
        prof, fr = src.profile, src.read(1)
    with rasterio.open(frac, "w", **prof) as dst_:
        dst_.write(fr, 1)
    out, mask, rep = (str(tmp_path / n) for n in ("d.tif", "m.tif", "d.json"))
    r = deshadow_file(
        f"{folder}/vnir.hdr",
        f"{folder}/swir.hdr",
        shadow=frac,
        output=out,
        report=rep,
        unresolved=mask,
    )
    bands = json.loads(open(rep).read())["bands"]
    resolved = np.array([b["resolved_in_shadow"] for b in bands])
    noise = np.array([b["shadow_noise_dn"] for b in bands], float)
    # The noise measured on neighbours: never below the truth beyond the sampling error;
    # above it by the scene's texture within a shadow (which only flags a band sooner).
    ratio = noise / true_noise
    assert np.nanmin(ratio) > 0.8 and np.nanmedian(ratio) < 2.0
    assert r["bands_unresolved"] == int((~resolved).sum()) > 0
    assert (~resolved[snr < 2]).mean() >= 0.95
    assert resolved[snr > 6].all()
    # Unresolved bands are left as measured; resolved ones are brightened in shadow.
    with rasterio.open(out) as src:
        cube = src.read()
        tags = [src.tags(i + 1) for i in range(src.count)]
    x = np.concatenate([_read_cube(f"{folder}/vnir.hdr"), _read_cube(f"{folder}/swir.hdr")])
    shaded = fr > 0
    has = (cube != -9999.0).all(axis=0)  # the SWIR's edge beyond the offset has no data
    kept = shaded & has
    np.testing.assert_allclose(cube[~resolved][:, kept], x[~resolved][:, kept], atol=1e-3)
    assert (
        cube[resolved][:, deep & has].mean() > x[resolved][:, deep & has].mean()
    ) and resolved.any()
    assert [t["resolved_in_shadow"] == "yes" for t in tags] == resolved.tolist()
    with rasterio.open(mask) as src:
        m = src.read(1)
    assert set(np.unique(m[shaded])) == {1} and set(np.unique(m[~shaded & (m != 255)])) == {0}


def _read_cube(path):
    with rasterio.open(path.replace(".hdr", ".img")) as src:
        return src.read().astype(float)


def test_the_pairs_that_agree_are_chosen_on_the_resolved_bands():
    """240 pairs of one surface (k = 2, 3, 4, each pair within ±3 %) and 160 of another
    (k = 1.5), and a band lost in noise in shadow (log-normal ±1 across the pairs): the
    consensus keeps the first surface's central pairs and gives its ratios to their spread
    over √(pairs kept) (≈ 0.5 %; 1.5 % allowed); the noisy band keeps ratio 1."""
    rng = np.random.default_rng(8)
    n = 400
    first = np.arange(n)[:, None] < 240
    k = np.where(first, np.array([2.0, 3.0, 4.0]) * np.exp(rng.normal(0, 0.03, (n, 1))), 1.5)
    shaded = rng.uniform(20, 60, (n, 4))
    shaded[:, 3] = rng.uniform(1, 3, n)
    sunlit = np.column_stack([shaded[:, :3] * k, shaded[:, 3] * np.exp(rng.normal(0, 1, n))])
    steps = np.stack([np.tile([40.0, 40.0, 40.0, 2.0], (200, 1)), rng.normal(0, 2.0, (200, 4))])
    steps[1, :, 3] = rng.normal(0, 8.0, 200)
    pairs = dst.EdgePairs(
        shaded.astype(np.float32),
        sunlit.astype(np.float32),
        np.ones((3, n), np.float32),
        np.zeros((0, 2), np.float32),
        np.zeros((0, 2), np.float32),
        np.zeros((n, 0), np.float32),
        np.zeros((n, 0), np.float32),
        steps[:, :, :2].astype(np.float32),
        steps[:, :, 2:].astype(np.float32),
    )
    fit = dst.fit_illumination(pairs, np.array([450.0, 650.0, 850.0, 1650.0]))
    np.testing.assert_allclose(fit.ratio, [2.0, 3.0, 4.0, 1.0], rtol=0.015)
    assert fit.resolved.tolist() == [True, True, True, False]
