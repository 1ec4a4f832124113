"""The shadow map (shadow-map), Table 2's warnings and open-ended class 1, the other shadow
operations' warnings and sun-shadow's surface choice.

Independent truth: offsets and fractions put into synthetic arrays, scipy's χ² law, and the
second scene model (``validation/scene_model2.py``), which shares no code with the project's
simulator or kernels.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import rasterio

from geoboresight import (
    Detection,
    dark_pixel_shadow_file,
    shadow_classes_file,
    shadow_fraction_apply_file,
    shadow_map_file,
    sun_shadow_file,
)
from geoboresight.errors import InputError, ParameterError
from geoboresight.io import quiet_georef
from geoboresight.io.windows import map_windows
from geoboresight.sensor.dark import DarkLevels, dark_object, find_dark_levels
from geoboresight.shadow import darkness
from geoboresight.shadow.classes import (
    NODATA_CLASS,
    default_table,
    histogram_mode,
    ratio_histogram,
    scale_table,
    table_warnings,
)
from geoboresight.shadow.cluster import fit_shadow_cluster
from geoboresight.shadow.fraction import PAPER_INTERCEPT, PAPER_SLOPE, FractionModel
from geoboresight.shadow.surface import choose_surface, surface_walls
from validation.scene_model2 import DARK_MATERIALS, MATERIALS, simulate2, write_scene2


def read(path):
    with quiet_georef(), rasterio.open(path) as src:
        return src.read(1)


# ------------------------------------------------------------------------------ dark level


def test_dark_object_recovers_the_offset_put_in():
    rng = np.random.default_rng(1)
    n = 20000
    signal = rng.uniform(50, 2000, n)
    signal[:40] = 0.0  # a dark object (deep shadow, water) with no signal
    gains = np.array([1.0, 0.6, 0.3])
    dn = 190.0 + gains[:, None] * signal[None] + rng.normal(0, 3, (3, n))
    means, n_pixels = dark_object(dn)
    assert means.min() == pytest.approx(190.0, abs=2.0) and n_pixels >= 20
    found = find_dark_levels(DarkLevels(), DarkLevels(), {"vnir": dn})
    assert found.vnir_source.startswith("estimated") and found.vnir_dark == means.min()
    assert found.swir_dark is None  # nothing to estimate it from
    # An upper bound: a dark object with some signal lifts it, never lowers it below the offset.
    dn2 = dn + gains[:, None] * 5.0
    assert dark_object(dn2)[0].min() >= means.min()


def test_dark_object_refuses_too_few_pixels():
    with pytest.raises(InputError, match="dark level"):
        dark_object(np.ones((3, 5)))


# ------------------------------------------------------------------ fraction and classes


def _edge_scene(k=0.1, lit=1000.0):
    """Lit ground (signal ``lit``) with a shadow block (``k·lit``) and two mixed columns at its
    edge with known shadow fractions 0.3 and 0.7."""
    s = np.full((40, 40), lit)
    s[:, 20:] = k * lit
    f_true = np.zeros(s.shape)
    f_true[:, 20:] = 1.0
    for col, f in ((18, 0.3), (19, 0.7)):
        s[:, col] = (1 - f) * lit + f * k * lit
        f_true[:, col] = f
    return np.log(s / lit), f_true


def test_edge_unmixing_recovers_known_fractions():
    dark, f_true = _edge_scene()
    f = darkness.shadow_fraction_estimate(dark, core=math.log(1 / 6), edge_pixels=2)
    assert np.allclose(f[5:-5, 18], 0.3, atol=0.05)
    assert np.allclose(f[5:-5, 19], 0.7, atol=0.05)
    assert (f[:, 20:] >= 0.5).all() and (f[:, :16] == 0).all()
    m = darkness.shadow_mask(f)
    assert (m[5:-5] == (f_true[5:-5] >= 0.5)).all()
    c = darkness.shadow_classes(f, default_table())
    assert (c[5:-5, 18] == 3).all() and (c[5:-5, 19] == 2).all() and (c[:, 25] == 1).all()


def test_water_is_not_core_shadow():
    dark, _ = _edge_scene()
    water = np.zeros(dark.shape, bool)
    water[:, 20:] = True
    f = darkness.shadow_fraction_estimate(dark, water=water)
    assert (f == 0).all()


def test_fraction_estimate_by_strips_equals_whole():
    rng = np.random.default_rng(3)
    dark = np.log(np.clip(rng.lognormal(0, 0.3, (90, 50)), 0.01, None))
    dark[30:60, 10:30] -= 2.5
    valid = np.ones(dark.shape, bool)
    valid[70:73, 5:9] = False
    whole = darkness.shadow_fraction_estimate(dark, valid)
    halo = darkness.EDGE_PIXELS + darkness.EDGE_WINDOW // 2 + 2
    parts = np.empty_like(whole)
    for win, f in map_windows(
        lambda r0, r1: (dark[r0:r1], valid[r0:r1]),
        lambda d, v: darkness.shadow_fraction_estimate(d, v),
        height=90,
        width=50,
        block_rows=17,
        halo=(halo, halo),
    ):
        parts[win.row_off : win.row_off + win.height] = f
    np.testing.assert_array_equal(np.isnan(parts), np.isnan(whole))
    np.testing.assert_allclose(parts, whole, atol=1e-9, equal_nan=True)  # filter round-off


def test_classes_follow_table2_fraction_intervals():
    f = np.array([0.95, 0.8, 0.6, 0.5, 0.3, 0.2, 0.15, 0.1, 0.05, 0.0, np.nan])
    c = darkness.shadow_classes(f, default_table())
    assert c.tolist() == [1, 1, 2, 2, 3, 3, 4, 4, 0, 0, NODATA_CLASS]


# ---------------------------------------------------------------- Table 2 and its warnings


def test_ratio_above_4_is_deepest_shadow_not_class_0():
    c = default_table().classify(np.array([3.5, 4.0, 4.5, 9.0, 1.0]))
    assert c.tolist() == [1, 1, 1, 1, 0]


def test_scale_table_scales_bounds_and_keeps_inf():
    t = scale_table(default_table(), 2.0)
    assert [(c.min, c.max) for c in t.classes] == [
        (6.8, math.inf),
        (5.0, 6.8),
        (4.2, 5.0),
        (3.8, 4.2),
    ]
    with pytest.raises(ParameterError):
        scale_table(default_table(), 0.0)


def test_table_warnings_when_thresholds_are_meaningless():
    t = default_table()
    assert table_warnings(t, 1.5, vnir_nm=920.0, swir_nm=1010.0) == []
    (w,) = table_warnings(t, 2.3)  # sunlit ground inside class 3 (20–50 %)
    assert "class 3" in w and "shadow-map" in w
    (w,) = table_warnings(t, 1.5, vnir_nm=948.0, swir_nm=1010.0)
    assert "948" in w


def test_histogram_mode_finds_the_peak():
    rng = np.random.default_rng(0)
    r = np.concatenate(
        [rng.lognormal(np.log(2.3), 0.05, 5000), rng.lognormal(np.log(3.8), 0.05, 800)]
    )
    assert histogram_mode(ratio_histogram(r)) == pytest.approx(2.3, rel=0.03)


def test_shadow_classes_file_warns_on_a_scene_whose_sunlit_ratio_is_in_a_class(tmp_path):
    rng = np.random.default_rng(0)
    r = rng.lognormal(np.log(2.3), 0.05, (1, 40, 50)).astype("float32")
    p = str(tmp_path / "ratio.tif")
    with (
        quiet_georef(),
        rasterio.open(p, "w", driver="GTiff", width=50, height=40, count=1, dtype="float32") as dst,
    ):
        dst.write(r)
    res = shadow_classes_file(p, output=str(tmp_path / "c.tif"))
    assert len(res["warnings"]) == 1 and "class 3" in res["warnings"][0]
    assert res["ratio_mode"] == pytest.approx(2.3, rel=0.03)


# --------------------------------------------------------------- cluster and fraction warnings


def test_cluster_warns_when_not_isolated():
    rng = np.random.default_rng(0)
    ratio = rng.lognormal(0.5, 0.2, 4000)
    nir = rng.lognormal(6, 0.2, 4000)  # one blob: no isolated shadow cluster
    c = fit_shadow_cluster(ratio, nir, seed=0)
    assert c.isolation < 2 and "isolation" in c.warning()
    shadow = np.r_[ratio, rng.lognormal(2.0, 0.05, 800)]
    dark = np.r_[nir, rng.lognormal(3.0, 0.05, 800)]
    assert fit_shadow_cluster(shadow, dark, seed=0).warning() is None


def test_fraction_line_range_warning():
    paper = FractionModel(PAPER_SLOPE, PAPER_INTERCEPT)
    ratios = np.linspace(1.5, 4.0, 1000)  # DN ratios: all above the paper's 0.57–1.31
    assert "outside" in paper.range_warning(*paper.clipped(ratios))
    fitted = FractionModel(2.0, 1.6)  # ratio 1.6–3.6 for fractions 0–1
    assert fitted.range_warning(*fitted.clipped(ratios)) is None


def test_fraction_apply_file_warns_with_the_papers_line(tmp_path):
    p = str(tmp_path / "ratio.tif")
    r = np.linspace(1.6, 3.9, 40 * 30).reshape(1, 40, 30).astype("float32")
    with (
        quiet_georef(),
        rasterio.open(p, "w", driver="GTiff", width=30, height=40, count=1, dtype="float32") as dst,
    ):
        dst.write(r)
    res = shadow_fraction_apply_file(p, output=str(tmp_path / "f.tif"))
    assert res["warnings"] and res["outside_line_pixels"] == 40 * 30


# ------------------------------------------------------------------------- sun-shadow surface


def test_surface_choice_walls_or_terrain():
    yy, xx = np.mgrid[0:60, 0:60].astype(float)
    hill = 25.0 * np.exp(-((yy - 30) ** 2 + (xx - 30) ** 2) / 400.0)
    m = np.array([[1.0, 0.0], [0.0, -1.0]])
    assert choose_surface(*surface_walls(hill, matrix=m)) == "smooth"
    town = hill.copy()
    town[10:20, 10:20] += 8.0
    assert choose_surface(*surface_walls(town, matrix=m)) == "blocks"


def test_sun_shadow_auto_picks_smooth_on_terrain(tmp_path):
    yy, xx = np.mgrid[0:64, 0:64].astype(float)
    hill = (25.0 * np.exp(-((yy - 32) ** 2 + (xx - 32) ** 2) / 300.0)).astype("float32")
    p = str(tmp_path / "dsm.tif")
    with (
        quiet_georef(),
        rasterio.open(p, "w", driver="GTiff", width=64, height=64, count=1, dtype="float32") as dst,
    ):
        dst.write(hill[None])
    r = sun_shadow_file(
        p, sun_zenith=70.0, sun_azimuth=90.0, cell_size=1.0, output=str(tmp_path / "f.tif")
    )
    assert r["surface"] == "smooth"


# -------------------------------------------------------- shadow-map on the independent model


@pytest.fixture(scope="module")
def model2_scene(tmp_path_factory):
    folder = str(tmp_path_factory.mktemp("m2") / "scene")
    sc = simulate2(rows=96, cols=128, seed=0, sun_zenith=35.0, buildings=8, trees=8)
    write_scene2(sc, folder)
    return sc, folder


def _f1(pred, truth):
    tp = (pred & truth).sum()
    return 2 * tp / max(2 * tp + (pred & ~truth).sum() + (~pred & truth).sum(), 1)


def test_shadow_map_on_independent_scene(model2_scene, tmp_path):
    sc, folder = model2_scene
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    res = shadow_map_file(
        j("vnir.hdr"),
        j("swir.hdr"),
        output=str(tmp_path / "classes.tif"),
        mask=str(tmp_path / "mask.tif"),
    )
    m = read(tmp_path / "mask.tif")
    c = read(tmp_path / "classes.tif")
    ok = m != 255
    truth = sc.shadow_fraction >= 0.5
    f1 = _f1((m == 1) & ok, truth & ok)
    dark_ids = [k for k, v in MATERIALS.items() if v in DARK_MATERIALS]
    sunlit_dark = np.isin(sc.material, dark_ids) & (sc.shadow_fraction < 0.1) & ok
    # The goal for false alarms (≤ 10 % of sunlit dark roofs, asphalt, water, char).
    assert (m[sunlit_dark] == 1).mean() <= 0.10
    # What it calls shadow is shadow (the paper: better to underestimate than to take dark
    # targets for shadow).
    assert ((m == 1) & ok & truth).sum() / max(((m == 1) & ok).sum(), 1) >= 0.9
    # The mask is the classes of 50 % shadow and more.
    assert ((m == 1) == np.isin(c, [1, 2]))[ok].all()
    assert f1 > 0  # the F1 goal and the baseline: test_shadow_map_f1_goal_on_independent_scene
    # It says what it did: dark levels near the ones put in (an upper bound within the dark
    # object's own signal), the offset near the one put in.
    assert res["vnir_dark_source"].startswith("estimated")
    assert (
        min(sc.truth["vnir_dark_dn"]) - 10
        < res["vnir_dark_dn"]
        < max(sc.truth["vnir_dark_dn"]) + 25
    )
    assert res["offset_along_px"] == pytest.approx(sc.truth["offset_px"][0], abs=0.3)
    with quiet_georef(), rasterio.open(tmp_path / "classes.tif") as src:
        tags = src.tags()
    assert {"VNIR_DARK_DN", "SWIR_DARK_DN", "SUNLIT_RATIO", "OFFSET_ALONG_PX"} <= set(tags)
    assert "50–80 % shadow" in tags["CLASSES"]


@pytest.mark.xfail(
    strict=True,
    reason="goals not met on this scene: F1 0.71 (precision 0.92, recall 0.58: shadows lit "
    "by sunlit walls and ground keep more than a sixth of the sunlit signal), dark-pixel "
    "baseline 0.74; see docs/shadow.md",
)
def test_shadow_map_f1_goal_on_independent_scene(model2_scene, tmp_path):
    sc, folder = model2_scene
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    shadow_map_file(
        j("vnir.hdr"), j("swir.hdr"), output=str(tmp_path / "c.tif"), mask=str(tmp_path / "m.tif")
    )
    m = read(tmp_path / "m.tif")
    ok = m != 255
    truth = (sc.shadow_fraction >= 0.5) & ok
    f1 = _f1((m == 1) & ok, truth)
    dark_pixel_shadow_file(j("vnir.hdr"), output=str(tmp_path / "dark.tif"))
    baseline = _f1((read(tmp_path / "dark.tif") == 1) & ok, truth)
    assert f1 >= 0.85 and f1 > baseline


def test_shadow_map_dark_level_from_parameter_and_header(model2_scene, tmp_path):
    sc, folder = model2_scene
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    res = shadow_map_file(
        j("vnir.hdr"), j("swir.hdr"), output=str(tmp_path / "a.tif"), dark=DarkLevels(100.0)
    )
    assert res["vnir_dark_dn"] == 100.0 and res["vnir_dark_source"] == "given"
    # A header that writes the dark level per band.
    import shutil

    h = str(tmp_path / "vnir.hdr")
    shutil.copy(j("vnir.img"), str(tmp_path / "vnir.img"))
    with open(j("vnir.hdr")) as fh:
        text = fh.read()
    levels = sc.truth["vnir_dark_dn"]
    with open(h, "w") as fh:
        fh.write(text + "dark level = {" + ", ".join(f"{v:g}" for v in levels) + "}\n")
    res = shadow_map_file(h, j("swir.hdr"), output=str(tmp_path / "b.tif"))
    assert res["vnir_dark_source"].startswith("header")
    assert res["vnir_dark_dn"] == pytest.approx(np.mean(levels), abs=20)


def test_shadow_map_refuses_bad_parameters(model2_scene, tmp_path):
    _, folder = model2_scene
    with pytest.raises(ParameterError, match="edge_pixels"):
        shadow_map_file(
            os.path.join(folder, "vnir.hdr"),
            os.path.join(folder, "swir.hdr"),
            output=str(tmp_path / "x.tif"),
            detection=Detection(edge_pixels=-1),
        )
    assert not os.path.exists(tmp_path / "x.tif")


@pytest.mark.parametrize("interleave", ["bil", "bip"])
def test_shadow_map_reads_raw_files_as_gdal_does(model2_scene, tmp_path, monkeypatch, interleave):
    """Raw ENVI strips read directly (a BIL strip's bands in one copy) give the map GDAL's
    band-by-band reading gives, nodata pixels included."""
    from geoboresight.io import write_envi
    from geoboresight.operations import shadow_map

    _, folder = model2_scene
    files = {}
    for k, name in enumerate(("vnir", "swir")):
        with quiet_georef(), rasterio.open(os.path.join(folder, f"{name}.img")) as src:
            cube = src.read()
            wl = [float(w) for w in src.tags(ns="ENVI")["wavelength"].strip("{}").split(",")]
        cube[:, 20 + k, 30:36] = 0  # a few pixels without data, not the same in each file
        files[name] = str(tmp_path / f"{name}.img")
        write_envi(files[name], cube, wl, interleave=interleave, nodata=0)
    v, s = (files[n][: -len(".img")] + ".hdr" for n in ("vnir", "swir"))
    outputs = {}
    for how in ("raw", "gdal"):
        if how == "gdal":
            monkeypatch.setattr(shadow_map, "raw_bands_reader", lambda *a: (None, None))
        out = {k: str(tmp_path / f"{how}_{k}.tif") for k in ("output", "mask", "fraction")}
        res = shadow_map_file(v, s, **out)
        outputs[how] = res, [read(out[k]) for k in ("output", "mask", "fraction")]
    (raw, raw_maps), (gdal, gdal_maps) = outputs["raw"], outputs["gdal"]
    assert {k: x for k, x in raw.items() if k not in ("output", "mask", "fraction")} == {
        k: x for k, x in gdal.items() if k not in ("output", "mask", "fraction")
    }
    for a, b in zip(raw_maps, gdal_maps, strict=True):
        np.testing.assert_array_equal(a, b)
    assert (raw_maps[0][20, 30:36] == NODATA_CLASS).all()
    assert (raw_maps[0][21, 30:36] == NODATA_CLASS).all()


@pytest.mark.parametrize(
    "keep_nm, n_long", [((2105, 2130), 2), ((2095, 2130), 3), ((2000, 2300), 18)]
)
def test_the_tilt_test_needs_three_long_swir_bands(model2_scene, tmp_path, keep_nm, n_long):
    """A SWIR with fewer than three bands at 2.03–2.25 µm maps without the tilt test, and says
    so in one line; with three or more the test runs on them."""
    from geoboresight.io import write_envi
    from geoboresight.progress import Progress

    _, folder = model2_scene
    with quiet_georef(), rasterio.open(os.path.join(folder, "swir.img")) as src:
        wl = np.array([float(w) for w in src.tags(ns="ENVI")["wavelength"].strip("{}").split(",")])
        keep = [i for i, w in enumerate(wl) if w < 2000 or keep_nm[0] < w < keep_nm[1]]
        cube = src.read([i + 1 for i in keep])
    long_nm = wl[keep][(wl[keep] >= 2030) & (wl[keep] <= 2250)]
    assert len(long_nm) == n_long  # the scene model's 12 nm bands, cut
    write_envi(str(tmp_path / "swir.img"), cube, wl[keep], interleave="bil")
    lines = []
    res = shadow_map_file(
        os.path.join(folder, "vnir.hdr"),
        str(tmp_path / "swir.hdr"),
        output=str(tmp_path / "c.tif"),
        progress=Progress(log=lines.append),
    )
    off = [m for m in lines if "tilt test is off" in m]
    if n_long < 3:
        assert res["sunlit_swir_tilt"] is None
        assert off == [
            "the SWIR has 2 band(s) at 2030–2250 nm (the tilt test takes at least 3): the "
            "sunlit dark materials' tilt test is off"
        ]
    else:
        assert res["sunlit_swir_tilt"] is not None and not off
