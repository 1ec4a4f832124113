"""``shadow-map --dsm`` with a DSM from another source: shifted by half a pixel, smoothed and
with 0.3 m of height noise, as a DSM of another date or resolution registered within a pixel.

Independent truth: the noise drawn here (its sample standard deviation), and the two scene
models (the simulator and ``validation/scene_model2.py``, which shares no code with the
kernels), each with its own shadow fraction and its exact DSM.
"""

from __future__ import annotations

import os

import numpy as np
import pytest
import rasterio
from scipy import ndimage

from geoboresight import SurfaceModel, shadow_map_file
from geoboresight.shadow import darkness
from geoboresight.shadow.surface import edge_tolerance, height_noise, second_differences
from validation.shadow import make_scene, write_tif


def _town():
    z = np.zeros((120, 140))
    z[20:45, 15:50] = 9.0
    z[70:100, 60:90] = 4.5
    z[30:60, 100:130] = 14.0
    return z


def _hill():
    y, x = np.mgrid[0:120, 0:140]
    return 20.0 * np.exp(-((x - 70.0) ** 2 + (y - 60.0) ** 2) / (2 * 30.0**2))


@pytest.mark.parametrize("surface", [_town, _hill])
@pytest.mark.parametrize("sigma", [0.05, 0.3, 1.0])
@pytest.mark.parametrize("smooth", [0.0, 0.7])
def test_height_noise_is_the_noise_drawn(surface, sigma, smooth):
    rng = np.random.default_rng(7)
    z = surface()
    if smooth:
        z = ndimage.gaussian_filter(z, smooth)
    noise = rng.normal(0.0, sigma, z.shape)
    # Strips' counts add up to the whole's.
    counts = second_differences((z + noise)[:50]) + second_differences((z + noise)[50:])
    assert np.array_equal(counts, second_differences(z + noise))
    # The median's sampling error on ~16,000 differences is about 1 %; the walls and the
    # hill's curvature bias it up by a few per cent at most; the bins are 5 mm wide.
    assert height_noise(counts) == pytest.approx(noise.std(), rel=0.08, abs=0.005)


def test_an_exact_dsm_has_no_noise_and_keeps_the_registration_tolerance():
    for z in (_town(), _hill()):
        assert height_noise(second_differences(z)) == 0.0
    assert edge_tolerance(0.0, darkness.DSM_TOLERANCE) == darkness.DSM_TOLERANCE
    assert edge_tolerance(0.3, darkness.DSM_TOLERANCE) == darkness.DSM_TOLERANCE + 1


def _read(path):
    with rasterio.open(path) as src:
        return src.read(1), src.tags()


SCENES = [
    (1, dict(preset="urban", seed=0, zenith=40.0, azimuth=200.0)),
    (2, dict(seed=1, sun_zenith=40.0, sun_azimuth=150.0)),
]


@pytest.mark.parametrize("model, opts", SCENES, ids=["simulator", "model2"])
def test_a_dsm_from_another_source_scores_near_the_exact_one(model, opts, tmp_path):
    folder = str(tmp_path / "scene")
    material, _, dark_ids, zen, az, gsd = make_scene(model, opts, 128, folder)
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    rng = np.random.default_rng(5)
    z, _ = _read(j("truth_dsm.tif"))
    z = ndimage.gaussian_filter(ndimage.shift(z.astype(float), (0.5, -0.4), order=1), 0.7)
    write_tif(j("dsm_other.tif"), z + rng.normal(0.0, 0.3, z.shape))
    f, _ = _read(j("truth_shadow_fraction.tif"))
    truth = np.asarray(f, float) >= 0.5
    scores = {}
    for name in ("truth_dsm", "dsm_other"):
        shadow_map_file(
            j("vnir.hdr"),
            j("swir.hdr"),
            output=j(f"{name}_classes.tif"),
            mask=j(f"{name}_mask.tif"),
            surface=SurfaceModel(j(f"{name}.tif"), zen, az, gsd),
        )
        m, _ = _read(j(f"{name}_mask.tif"))
        _, tags = _read(j(f"{name}_classes.tif"))
        ok = (m != 255) & np.isfinite(f)
        shadow = (m == 1) & ok
        tp = (shadow & truth).sum()
        f1 = 2 * tp / (2 * tp + (shadow & ~truth).sum() + (~shadow & truth & ok).sum())
        dark = np.isin(material, dark_ids) & (np.asarray(f, float) < 0.1) & ok
        scores[name] = (f1, shadow[dark].mean() if dark.any() else 0.0, tags)
    exact, other = scores["truth_dsm"], scores["dsm_other"]
    # The noise is measured and widens the band in which the image decides; the exact DSM
    # keeps the registration's.
    assert float(exact[2]["DSM_HEIGHT_NOISE_M"]) < 0.01
    assert int(exact[2]["DSM_EDGE_TOLERANCE_PX"]) == darkness.DSM_TOLERANCE
    # Crowns' texture and the scene's many walls add to the median: within a third.
    assert float(other[2]["DSM_HEIGHT_NOISE_M"]) == pytest.approx(0.3, rel=0.34)
    assert int(other[2]["DSM_EDGE_TOLERANCE_PX"]) == darkness.DSM_TOLERANCE + 1
    # Half a pixel off and smoothed, the cast edges still fall within the widened band: the
    # F1 (every pixel, mixed edges included) is the goal's 0.97 of the exact DSM's (these
    # scenes give 0.974 and 0.986; with the registration's one-pixel band alone, 0.958 and
    # 0.965).
    assert other[0] >= 0.97 * exact[0]
    assert other[1] <= 0.05  # sunlit dark materials stay sunlit


@pytest.mark.parametrize("azimuth", [0.0, 180.0])
def test_a_rough_dsm_in_strips_equals_the_whole_image(azimuth, tmp_path):
    """The wider zone of a DSM from another source, and the sweep of a shadow's far end
    down-sun, read beyond a strip: strips of 16 lines (model 2, sun 60° from the north, then
    the south, a DSM half a pixel off, smoothed and noisy) give the whole image's fraction."""
    from validation.scene_model2 import simulate2, write_scene2

    folder = str(tmp_path / "scene")
    sc = simulate2(rows=72, cols=96, seed=0, sun_zenith=60.0, sun_azimuth=azimuth)
    write_scene2(sc, folder)
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    z, _ = _read(j("truth_dsm.tif"))
    z = ndimage.gaussian_filter(ndimage.shift(z.astype(float), (0.5, -0.4), order=1), 0.7)
    write_tif(j("dsm_other.tif"), z + np.random.default_rng(3).normal(0.0, 0.3, z.shape))
    surface = SurfaceModel(j("dsm_other.tif"), 60.0, azimuth, sc.truth["gsd_m"])
    fractions = []
    for rows in (16, 1000):
        shadow_map_file(
            j("vnir.hdr"),
            j("swir.hdr"),
            output=str(tmp_path / f"c{rows}.tif"),
            fraction=str(tmp_path / f"f{rows}.tif"),
            surface=surface,
            block_rows=rows,
        )
        fractions.append(_read(str(tmp_path / f"f{rows}.tif"))[0])
    tags = _read(str(tmp_path / "c1000.tif"))[1]
    assert int(tags["DSM_EDGE_TOLERANCE_PX"]) == darkness.DSM_TOLERANCE + 1  # the wider zone
    assert np.array_equal(np.isnan(fractions[0]), np.isnan(fractions[1]))
    np.testing.assert_allclose(fractions[0], fractions[1], rtol=1e-5, atol=1e-5)
    # Against the scene's own truth (measured F1 0.89 from the north, 0.93 from the south;
    # 0.94 and 0.96 with the exact DSM).
    truth = sc.shadow_fraction >= 0.5
    pred = fractions[1] >= 0.5
    tp = (pred & truth).sum()
    assert 2 * tp / (2 * tp + (pred & ~truth).sum() + (~pred & truth).sum()) > 0.8
