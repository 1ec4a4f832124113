"""De-shadowing and the additive signal: per-band dark levels from the header, and the
estimate of a signal the sun does not scale (path radiance, a dark level that differs from
band to band) from the intercept of the pairs' line.

Independent truth: pairs written from x = ρ·E·g + c with a known c (a path radiance falling
as λ^−4 plus a white per-band dark remainder), and the second scene model
(``validation/scene_model2.py``) with its per-band dark levels written into the header.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import rasterio
from synth import write_gtiff  # noqa: E402

from geoboresight import LightModel, deshadow_file
from geoboresight.shadow import deshadow as ds
from validation.scene_model2 import simulate2, write_scene2

WL = np.linspace(420.0, 2400.0, 40)


def _spectra():
    """Five smooth reflectance spectra of different brightness (no red edge)."""
    x = (WL - 420.0) / 1980.0
    return [
        lvl * (1.0 + s * x)
        for lvl, s in ((0.05, 0.5), (0.1, 1.0), (0.2, 0.3), (0.3, -0.2), (0.4, 0.4))
    ]


def _pairs(n=1500, seed=0, sky=False, mixed=0.2):
    """(shaded, sunlit, c, k, sky views) of pairs: one surface on both sides, ``mixed`` of
    them two surfaces."""
    rng = np.random.default_rng(seed)
    e_sky = 1000.0 * (WL / 500.0) ** -2 + 30.0  # k from 3.5 in the blue to ~25
    e_dir = 4000.0 * (WL / 500.0) ** -0.5
    k = (e_dir + e_sky) / e_sky
    # Path radiance λ^−4 (≈ 60 DN in the blue), a white dark remainder of 10 DN.
    c = 60.0 * (WL / 420.0) ** -4 + 10.0 * rng.standard_normal(WL.size)
    rho = _spectra()
    ma = rng.integers(0, len(rho), n)
    mb = np.where(rng.random(n) < mixed, rng.integers(0, len(rho), n), ma)
    ra = np.array([rho[i] for i in ma]) * (1 + 0.02 * rng.standard_normal((n, 1)))
    rb = np.array([rho[i] for i in mb]) * (1 + 0.02 * rng.standard_normal((n, 1)))
    va = rng.uniform(0.5, 1.0, n) if sky else np.ones(n)
    vb = rng.uniform(0.9, 1.0, n) if sky else np.ones(n)
    a = ra * va[:, None] * e_sky + c + rng.standard_normal((n, WL.size))
    b = rb * (e_dir + vb[:, None] * e_sky) + c + rng.standard_normal((n, WL.size))
    return a, b, c, k, (va, vb)


@pytest.mark.parametrize("sky", [False, True])
def test_additive_signal_recovers_path_radiance_and_per_band_dark(sky):
    a, b, c, k, v = _pairs(sky=sky)
    sv = v if sky else None
    keep = ds.KEEP_WITH_SURFACE if sky else ds.KEEP
    k0, _, _ = ds.illumination_ratio(a, b, sky_view=sv, keep=keep)
    # The signal the sun does not scale biases the ratio of the blue, where it is largest.
    assert abs(k0[0] / k[0] - 1) > 0.05
    est, err = ds.additive_signal(a, b, k0, sky_view=sv)
    assert np.isfinite(err).all()
    # Within 3 standard errors, and the errors small against the signal's spread (10 DN).
    assert (np.abs(est - c) <= 3 * err + 0.5).all(), np.c_[est, c, err]
    assert np.median(err) < 2.0
    # The white part too: the estimate follows the per-band remainder, not a smooth curve.
    white = c - 60.0 * (WL / 420.0) ** -4
    assert np.corrcoef(est - 60.0 * (WL / 420.0) ** -4, white)[0, 1] > 0.9
    k1, _, _ = ds.illumination_ratio(a - est, b - est, sky_view=sv, keep=keep)
    assert np.allclose(k1, k, rtol=0.03), np.c_[k1, k]


def test_one_material_does_not_measure_the_additive_signal():
    """Pairs of one surface fix a point of the line, not the line: the error says so."""
    a, b, c, k, _ = _pairs()
    rng = np.random.default_rng(5)
    rho = _spectra()[2] * (1 + 0.02 * rng.standard_normal((400, 1)))
    e_sky = 1000.0 * (WL / 500.0) ** -2 + 30.0
    e_dir = 4000.0 * (WL / 500.0) ** -0.5
    a1 = rho * e_sky + c + rng.standard_normal((400, WL.size))
    b1 = rho * (e_dir + e_sky) + c + rng.standard_normal((400, WL.size))
    _, err1 = ds.additive_signal(a1, b1, k)
    _, err5 = ds.additive_signal(a, b, k)
    # Only the texture (2 %) spans the line: errors an order above those of five materials.
    assert np.median(err1) > 5 * np.median(err5)


def test_a_line_above_the_dimmest_shadow_is_not_measured():
    """c above every pair's shadowed signal contradicts x = ρ·E·g + c (ρ > 0)."""
    a, b, c, k, _ = _pairs(mixed=0.0)
    est, err = ds.additive_signal(a, b, k)
    assert np.isfinite(err).all()
    # Pairs that say the shadowed surface is darker than c: the sunlit side from a line whose
    # intercept puts c far above them.
    fake = 3.0 * a.max(axis=0)
    b2 = k * (a - fake) + fake
    est2, err2 = ds.additive_signal(a, b2, k)
    assert not np.isfinite(err2).any()
    assert (est2 == 0).all()


def _vegetation_and_soil(n=600, seed=2):
    rng = np.random.default_rng(seed)
    soil = 0.1 + 0.15 * (WL - 420.0) / 1980.0
    veg = np.where(WL < 700.0, 0.05, 0.45) * np.where(WL > 1400.0, 0.5, 1.0)
    e_sky = 1000.0 * (WL / 500.0) ** -2 + 30.0  # k from 3.5 in the blue to ~25
    e_dir = 4000.0 * (WL / 500.0) ** -0.5
    ma = rng.integers(0, 2, n)
    mb = np.where(rng.random(n) < 0.4, 1 - ma, ma)
    rho = np.array([soil, veg])
    ra = rho[ma] * (1 + 0.02 * rng.standard_normal((n, 1)))
    rb = rho[mb] * (1 + 0.02 * rng.standard_normal((n, 1)))
    a = ra * e_sky + 2.0 * rng.standard_normal((n, WL.size)) + 20
    b = rb * (e_dir + e_sky) + 2.0 * rng.standard_normal((n, WL.size)) + 20
    return a, b, ma == mb


def test_same_surface_drops_pairs_across_a_material_boundary():
    a, b, same = _vegetation_and_soil()
    one = ds.same_surface(a, b, WL)
    assert same[one].mean() > 0.95  # what is kept is one surface
    assert one[same].mean() > 0.8  # and most of the one-surface pairs are kept
    # No bands between 420 and 900 nm: no split.
    assert ds.same_surface(a[:, WL > 1000], b[:, WL > 1000], WL[WL > 1000]).all()


# ------------------------------------------------------------------ per-band dark levels


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("m2dark") / "scene")
    sc = simulate2(rows=64, cols=80, seed=0, sun_zenith=35.0, buildings=8, trees=6)
    write_scene2(sc, folder)
    return sc, folder


def _with_dark(folder, name, levels):
    with open(os.path.join(folder, name), "a", encoding="utf-8") as fh:
        fh.write("dark level = {" + ", ".join(f"{v:.2f}" for v in levels) + "}\n")


def _deshadow_truth_fraction(sc, folder, tmp_path, **kwargs):
    """deshadow_file on the scene with its truth fraction: (fraction, output, report's bands)."""
    frac = str(tmp_path / "f.tif")
    f = np.nan_to_num(sc.shadow_fraction.astype("float32"), nan=0.0)
    write_gtiff(frac, f[None])
    out, rep = str(tmp_path / "d.tif"), str(tmp_path / "d.json")
    deshadow_file(
        os.path.join(folder, "vnir.hdr"),
        os.path.join(folder, "swir.hdr"),
        shadow=frac,
        output=out,
        report=rep,
        **kwargs,
    )
    with open(rep) as fh:
        return f, out, json.load(fh)["bands"]


def test_deshadow_subtracts_the_headers_per_band_dark_levels(scene, tmp_path):
    sc, folder = scene
    dark_v, dark_s = sc.truth["vnir_dark_dn"], sc.truth["swir_dark_dn"]
    _with_dark(folder, "vnir.hdr", dark_v)
    _with_dark(folder, "swir.hdr", dark_s)
    f, out, bands = _deshadow_truth_fraction(sc, folder, tmp_path)
    levels = np.array([b["dark_level_dn"] for b in bands])
    k = np.array([b["illumination_ratio"] for b in bands])
    # The header's level of every band, not one per instrument.
    assert np.allclose(levels, np.r_[dark_v, dark_s], atol=0.01)
    nv = len(dark_v)
    with rasterio.open(out) as src:
        cube = src.read()
    full = f >= 0.999
    x = sc.vnir[:, full].astype(np.float64)
    d = np.asarray(dark_v)[:, None]
    # Full shadow: (DN − d_b)·k_b + d_b, band by band.
    assert np.allclose(cube[:nv, full], (x - d) * k[:nv, None] + d, rtol=1e-4, atol=0.05)
    lit = f == 0
    assert np.allclose(cube[:nv, lit], sc.vnir[:, lit], atol=0.01)


def test_deshadow_file_with_the_additive_signal_scales_only_the_signal_above_it(scene, tmp_path):
    sc, folder = scene
    f, out, bands = _deshadow_truth_fraction(sc, folder, tmp_path, light=LightModel(additive=True))
    d = np.array([b["dark_level_dn"] for b in bands])
    c = np.array([b["additive_signal_dn"] for b in bands])
    k = np.array([b["illumination_ratio"] for b in bands])
    nv = sc.vnir.shape[0]
    # Model 2's path radiance is 3 % of the sky's light: the blue's additive signal is
    # positive and measured.
    assert (c[:10] > 0).all()
    assert all(b["additive_signal_error_dn"] is not None for b in bands[:10])
    with rasterio.open(out) as src:
        cube = src.read()
    full = f >= 0.999
    base = (d + c)[:nv, None]
    x = sc.vnir[:, full].astype(np.float64)
    assert np.allclose(cube[:nv, full], (x - base) * k[:nv, None] + base, rtol=1e-4, atol=0.05)
    lit = f == 0
    assert np.allclose(cube[:nv, lit], sc.vnir[:, lit], atol=0.01)


# ------------------------------------------------- the slope's direct light, the dark object


def _sloped_pairs(n=1500, seed=3):
    """Pairs whose sunlit sides lie on slopes: direct light × cos i/cos Z (0.6–1.3), the
    brighter materials on the sunnier slopes (relief and land cover go together)."""
    rng = np.random.default_rng(seed)
    e_sky = 1000.0 * (WL / 500.0) ** -2 + 30.0
    e_dir = 4000.0 * (WL / 500.0) ** -0.5
    c = 60.0 * (WL / 420.0) ** -4 + 10.0 * rng.standard_normal(WL.size)
    rho = np.array(_spectra())
    m = rng.integers(0, len(rho), n)
    cos_i = np.clip(0.6 + 0.15 * m + 0.1 * rng.standard_normal(n), 0.3, 1.5)
    r = rho[m] * (1 + 0.02 * rng.standard_normal((n, 1)))
    a = r * e_sky + c + rng.standard_normal((n, WL.size))
    b = r * (cos_i[:, None] * e_dir + e_sky) + c + rng.standard_normal((n, WL.size))
    return a, b, c, (e_dir + e_sky) / e_sky, cos_i


def test_the_slopes_direct_light_takes_the_bias_out_of_the_line():
    a, b, c, k, cos_i = _sloped_pairs()
    k0, _, _ = ds.illumination_ratio(a, b, keep=ds.KEEP_WITH_SURFACE)
    flat, err_flat = ds.additive_signal(a, b, k0)
    # Without the slope the line's intercept follows the slopes: off by many standard errors.
    fin = np.isfinite(err_flat)
    assert np.median(np.abs(flat - c)[fin] / err_flat[fin]) > 5
    k1, _, _ = ds.illumination_ratio(a, b, direct=cos_i, keep=ds.KEEP_WITH_SURFACE)
    est, err = ds.additive_signal(a, b, k1, direct=cos_i)
    assert np.isfinite(err).all()
    assert (np.abs(est - c) <= 3 * err + 0.5).all(), np.c_[est, c, err]
    # And the ratio of level ground above it.
    k2, _, _ = ds.illumination_ratio(a - est, b - est, direct=cos_i, keep=ds.KEEP_WITH_SURFACE)
    assert np.allclose(k2, k, rtol=0.03)


def test_plane_incidence_is_the_slopes_cos_i_and_quieter_than_hillshade():
    from geoboresight.shadow import incidence

    yy, xx = np.mgrid[0:60, 0:60].astype(float)
    z = 0.25 * xx - 0.15 * yy  # a plane rising to the east and to the north (row 0)
    zen, az = 40.0, 120.0
    n = np.array([-0.25, -0.15, 1.0])  # normal (east, north, up): −∂z/∂east, −∂z/∂north, 1
    n /= np.linalg.norm(n)
    s = np.array(
        [
            np.sin(np.radians(zen)) * np.sin(np.radians(az)),
            np.sin(np.radians(zen)) * np.cos(np.radians(az)),
            np.cos(np.radians(zen)),
        ]
    )
    truth = float(n @ s) / np.cos(np.radians(zen))
    p = incidence.plane_incidence(z, sun_zenith=zen, sun_azimuth=az, cell_size=1.0)
    assert np.allclose(p[5:-5, 5:-5], truth, atol=1e-9)
    noisy = z + np.random.default_rng(0).normal(0.0, 0.3, z.shape)
    p = incidence.plane_incidence(noisy, sun_zenith=zen, sun_azimuth=az, cell_size=1.0)
    h = incidence.hillshade(noisy, sun_zenith=zen, sun_azimuth=az, cell_size=1.0)
    h = h.astype(float) / np.cos(np.radians(zen))
    inner = (slice(5, -5), slice(5, -5))
    assert np.std(p[inner] - truth) < 0.5 * np.std(h[inner] - truth)
    assert np.std(p[inner] - truth) < 0.06


def test_the_dark_object_bounds_the_additive_signal_and_measures_it_where_the_line_cannot():
    """A line good in the blue and poor beyond 1,400 nm (a standard error of 40 DN, scattered
    by it), a dark object high by its own shadowed signal (3 % reflectance under the shadow's
    light): the combination follows the line where it is precise, the dark object where it
    is not, never above the dark object."""
    rng = np.random.default_rng(7)
    e_sky = 1000.0 * (WL / 500.0) ** -2 + 30.0
    c = 60.0 * (WL / 420.0) ** -4 + 10.0 * rng.standard_normal(WL.size)
    shadow_typ = c + 0.15 * e_sky  # the median shadowed pixel: 15 % reflectance
    dark = c + 0.03 * e_sky * (1 + 0.1 * rng.standard_normal(WL.size))  # 3 % (±10 %)
    err = np.where(WL < 1400.0, 1.0, 40.0)
    line = c + err * rng.standard_normal(WL.size)
    est, se = ds.combine_additive(line, err, dark, shadow_typ)
    assert (est <= dark + 1e-9).all()
    assert (se <= err + 1e-9).all()
    poor = WL >= 1400.0
    # Where the line is poor the dark object's estimate decides: within its own scatter.
    assert np.abs(est - c)[poor].max() < 0.25 * np.abs(line - c)[poor].max()
    assert np.sqrt(np.mean((est - c)[poor] ** 2)) < 5.0
    # Where the line is good it stays.
    assert np.abs(est - line)[~poor].max() < 2.0
    # A line far above the dark object is brought down to it.
    est2, _ = ds.combine_additive(c + 100.0, err, dark, shadow_typ)
    assert (est2 <= dark + 1e-9).all()


def test_dark_object_is_the_darkest_pixels_mean():
    x = np.array([[5.0, 1.0, 3.0, np.nan, 2.0], [50.0, 10.0, 30.0, 0.0, 20.0]])
    assert np.allclose(ds.dark_object(x, 2), [1.5, 15.0])
    assert np.isnan(ds.dark_object(x, 5)).all()


def _model2_additive_truth(sc, levels):
    """Model 2's signal the sun does not scale, per band, above the levels subtracted: path
    radiance (3 % of the sky's light, through the model's band responses and gains) plus the
    per-band dark level less the one level per instrument."""
    from validation.scene_model2 import FINE, band_matrix, spctral2

    _, diffuse = spctral2(FINE, sc.truth["sun"]["zenith_deg"], aot500=sc.truth["aot500"])
    path = 0.03 * diffuse / np.pi
    vn, sn = np.arange(400.0, 1001.0, 6.0), np.arange(960.0, 2501.0, 12.0)
    r_v = np.interp(vn, [400, 500, 650, 800, 900, 1000], [0.3, 0.8, 1.0, 0.75, 0.4, 0.12])
    r_s = np.interp(sn, [960, 1000, 1050, 1150, 2200, 2500], [0.05, 0.1, 0.4, 1.0, 1.0, 0.5])
    p = np.r_[
        30000.0 * r_v * (band_matrix(vn, np.full(vn.size, 6.0)) @ path),
        90000.0 * r_s * (band_matrix(sn, np.full(sn.size, 12.0)) @ path),
    ]
    return p + np.r_[sc.truth["vnir_dark_dn"], sc.truth["swir_dark_dn"]] - levels, vn.size


def test_additive_signal_on_relief_against_model_2s_truth(tmp_path):
    """Model 2 with 25 m of relief (as development seed 3) and its DSM: the additive signal
    (path radiance + the per-band dark remainder) band by band against the model's truth. In
    the SWIR the line alone is off by its slopes' light and the texture (r.m.s. 174 DN
    against a true 114 DN on average); with the dark object the combination is within 34 DN,
    and nowhere above the dark object."""
    sc = simulate2(
        rows=96, cols=120, seed=3, sun_zenith=45.0, relief_m=25.0, vnir_dark=300.0, swir_dark=1500.0
    )
    folder = str(tmp_path / "scene")
    write_scene2(sc, folder)
    f = np.nan_to_num(sc.shadow_fraction.astype("float32"), nan=0.0)
    for name, arr in (("f.tif", f), ("z.tif", sc.dsm.astype("float32"))):
        write_gtiff(str(tmp_path / name), arr[None])
    from geoboresight import SurfaceModel

    rep = str(tmp_path / "r.json")
    deshadow_file(
        os.path.join(folder, "vnir.hdr"),
        os.path.join(folder, "swir.hdr"),
        shadow=str(tmp_path / "f.tif"),
        output=str(tmp_path / "o.tif"),
        report=rep,
        surface=SurfaceModel(str(tmp_path / "z.tif"), 45.0, 150.0, 1.0),
        light=LightModel(additive=True),
    )
    with open(rep) as fh:
        bands = json.load(fh)["bands"]
    levels = np.array([b["dark_level_dn"] for b in bands])
    c = np.array([b["additive_signal_dn"] for b in bands])
    line = np.array(
        [
            np.nan if b["additive_signal_line_dn"] is None else b["additive_signal_line_dn"]
            for b in bands
        ]
    )
    dark = np.array([b["dark_object_dn"] for b in bands])
    truth, nv = _model2_additive_truth(sc, levels)
    assert (c <= dark + 1e-6).all()
    rms = lambda e: float(np.sqrt(np.nanmean(e**2)))  # noqa: E731
    assert abs(np.mean((c - truth)[:nv])) < 15.0
    assert rms((c - truth)[:nv]) < 20.0
    assert rms((c - truth)[nv:]) < 50.0
    assert rms((c - truth)[nv:]) < 0.5 * rms((line - truth)[nv:])
