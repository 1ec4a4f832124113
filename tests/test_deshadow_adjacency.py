"""De-shadowing with the light of the sunlit surroundings (ATCOR-4's terrain-reflected term,
``(1 − V)·ρ̄·E_global``; ``deshadow --adjacency``).

Independent truth: pairs written from a shadow lit by ``V·E_sky + (1 − V)·A·ρ̄·E_global``
(A and each pair's surroundings ρ̄ known), and the second scene model
(``validation/scene_model2.py``) with and without its adjacency light.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import rasterio
from synth import write_gtiff  # noqa: E402

from geoboresight import LightModel, deshadow_file
from geoboresight.errors import ParameterError
from geoboresight.shadow import deshadow as ds
from validation.scene_model2 import simulate2, write_scene2

WL = np.linspace(420.0, 2400.0, 40)


def _adjacency_pairs(share, n=2000, seed=0):
    """Pairs of one surface whose shadowed side gets V_a·E_sky + (1 − V_a)·share·ρ̄_a·E_glob
    and sunlit side E_dir + V_b·E_sky + (1 − V_b)·share·ρ̄_b·E_glob, ρ̄ the surroundings'
    reflectance (grey, 0.03–0.45, each pair its own). Returns (shaded, sunlit, surroundings'
    sunlit signals, k, sky views, the shadowed sides' true sunlit signals)."""
    rng = np.random.default_rng(seed)
    e_sky = 1000.0 * (WL / 500.0) ** -2 + 30.0
    e_dir = 4000.0 * (WL / 500.0) ** -0.5
    e_glob = e_dir + e_sky
    k = e_glob / e_sky
    x = (WL - 420.0) / 1980.0
    levels = rng.uniform(0.05, 0.4, n)[:, None] * (1.0 + rng.uniform(-0.5, 1.0, n)[:, None] * x)
    rho_a = levels * (1 + 0.02 * rng.standard_normal((n, 1)))
    rho_b = levels * (1 + 0.02 * rng.standard_normal((n, 1)))
    va = rng.uniform(0.5, 0.95, n)[:, None]
    vb = rng.uniform(0.9, 1.0, n)[:, None]
    sur_a = rng.uniform(0.03, 0.45, n)[:, None] * np.ones(WL.size)
    sur_b = sur_a * rng.uniform(0.9, 1.1, (n, 1))
    light_a = va * e_sky + (1 - va) * share * sur_a * e_glob
    light_b = e_dir + vb * e_sky + (1 - vb) * share * sur_b * e_glob
    a = rho_a * light_a
    b = rho_b * light_b
    truth = rho_a * (e_dir + light_a)
    s_a = sur_a * e_glob * (1 + 0.02 * rng.standard_normal((n, WL.size)))
    s_b = sur_b * e_glob * (1 + 0.02 * rng.standard_normal((n, WL.size)))
    return a, b, (s_a, s_b), k, (va[:, 0], vb[:, 0]), truth


def _corrected(a, k, va, term):
    """The shadowed sides de-shadowed (f = 1) with the open-ground ratio and the term."""
    v = va[:, None] + term
    return a * (k - 1.0 + v) / v


def test_the_surroundings_light_is_measured_and_each_shadow_gets_its_own_ratio():
    a, b, sur, k, sky, truth = _adjacency_pairs(0.8)
    k_adj, scale, eta = ds.adjacency_ratio(a, b, sur, sky_view=sky)
    term = scale * (1.0 - sky[0])[:, None] * sur[0]
    err_adj = np.abs(_corrected(a, k_adj, sky[0], term) / truth - 1)
    k_sky, _, _ = ds.illumination_ratio(a, b, sky_view=sky, keep=1.0)
    err_sky = np.abs(_corrected(a, k_sky, sky[0], 0.0) / truth - 1)
    assert np.median(np.abs(k_adj / k - 1)) < 0.03
    assert np.median(err_adj) < 0.02
    # Without the term the shadows among bright surroundings come out too bright and those
    # among dark ones too dark: the error is several times larger.
    assert np.median(err_sky) > 3 * np.median(err_adj)
    assert (eta > 0.05).mean() > 0.9


def test_no_surroundings_light_measures_none():
    a, b, sur, k, sky, truth = _adjacency_pairs(0.0, seed=1)
    k_adj, scale, eta = ds.adjacency_ratio(a, b, sur, sky_view=sky)
    assert np.median(eta) < 0.05
    assert np.median(np.abs(k_adj / k - 1)) < 0.03
    term = scale * (1.0 - sky[0])[:, None] * sur[0]
    assert np.median(np.abs(_corrected(a, k_adj, sky[0], term) / truth - 1)) < 0.02


def test_surround_signal_is_the_mean_of_the_sunlit_pixels_in_the_window():
    rng = np.random.default_rng(4)
    x = rng.uniform(10, 100, (3, 40, 50))
    lit = rng.random((40, 50)) < 0.5
    lit[10:30, 10:30] = False
    s = ds.surround_signal(x, lit, 5)
    r, c = 7, 21
    win = (slice(r - 2, r + 3), slice(c - 2, c + 3))
    np.testing.assert_allclose(s[:, r, c], x[:, win[0], win[1]][:, lit[win]].mean(axis=1))
    assert np.isnan(s[:, 20, 20]).all()  # no sunlit pixel within 2 px
    # A strip read with half the window of halo gives the whole image's values.
    strip = ds.surround_signal(x[:, 13:27], lit[13:27], 5)
    np.testing.assert_allclose(strip[:, 2:-2], s[:, 15:25], equal_nan=True)


def test_the_term_enters_the_factor_with_the_sky_view():
    x = np.full((2, 1, 3), 10.0)
    f = np.array([[0.0, 1.0, 1.0]])
    v = np.full((1, 3), 0.6)
    k = np.array([4.0, 11.0])
    term = np.zeros((2, 1, 3))
    term[:, 0, 2] = 0.2
    out = ds.deshadow(x, f, ratio=k, sky_view=v, adjacency=term)
    np.testing.assert_allclose(out[:, 0, 0], 10.0)  # out of shadow: unchanged
    np.testing.assert_allclose(out[:, 0, 1], 10.0 * (k - 1 + 0.6) / 0.6, rtol=1e-6)
    np.testing.assert_allclose(out[:, 0, 2], 10.0 * (k - 1 + 0.8) / 0.8, rtol=1e-6)


def _model2(tmp_path, name, adjacency):
    sc = simulate2(rows=96, cols=120, seed=0, sun_zenith=35.0, adjacency=adjacency)
    folder = str(tmp_path / name)
    write_scene2(sc, folder)
    write_gtiff(
        os.path.join(folder, "f.tif"),
        np.nan_to_num(sc.shadow_fraction, nan=0.0).astype("float32")[None],
    )
    write_gtiff(os.path.join(folder, "z.tif"), sc.dsm.astype("float32")[None])
    return folder


def _run(folder, out, **kw):
    from geoboresight import SurfaceModel

    rep = out + ".json"
    deshadow_file(
        os.path.join(folder, "vnir.hdr"),
        os.path.join(folder, "swir.hdr"),
        shadow=os.path.join(folder, "f.tif"),
        output=out,
        report=rep,
        surface=SurfaceModel(os.path.join(folder, "z.tif"), 35.0, 150.0, 1.0),
        **kw,
    )
    with open(rep) as fh:
        return np.array([b["adjacency_share"] for b in json.load(fh)["bands"]])


def test_deshadow_file_measures_model_2s_adjacency_light(tmp_path):
    """Model 2 lights shadow by adjacency·env·E_global·(1 − V): the share measured with its
    adjacency light at 0.8 is larger than with none, where it is small; strips give the
    whole image's cube (the window's halo)."""
    strong = _model2(tmp_path, "strong", 0.8)
    none = _model2(tmp_path, "none", 0.0)
    eta_strong = _run(strong, str(tmp_path / "s.tif"), light=LightModel(adjacency=True))
    eta_none = _run(none, str(tmp_path / "n.tif"), light=LightModel(adjacency=True))
    vnir = slice(0, 101)  # model 2's VNIR bands, where shadow has signal
    assert np.median(eta_strong[vnir]) > np.median(eta_none[vnir]) + 0.05
    assert np.median(eta_none[vnir]) < 0.1
    _run(strong, str(tmp_path / "s16.tif"), light=LightModel(adjacency=True), block_rows=16)
    with rasterio.open(str(tmp_path / "s.tif")) as a, rasterio.open(str(tmp_path / "s16.tif")) as b:
        np.testing.assert_allclose(a.read(), b.read(), rtol=1e-5, atol=1e-3)


def test_adjacency_needs_a_surface_model(tmp_path):
    folder = _model2(tmp_path, "s", 0.5)
    with pytest.raises(ParameterError, match="surface model"):
        deshadow_file(
            os.path.join(folder, "vnir.hdr"),
            os.path.join(folder, "swir.hdr"),
            shadow=os.path.join(folder, "f.tif"),
            output=str(tmp_path / "o.tif"),
            light=LightModel(adjacency=True),
        )
