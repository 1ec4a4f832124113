"""The sky-light test of dark pixels (shadow.context): a pixel dark in the near infrared and
SWIR whose blue keeps most of the scene's sunlit blue, with the flat blue/NIR balance of a dark
material, or whose long SWIR (2.0–2.3 µm) is not darker than its SWIR against the sunlit
ground (the sky's tilt, which a shadow has and a sunlit dark material has not), is a sunlit
dark material, not shadow.

Independent truth: blue and SWIR levels put into synthetic arrays, and the shadow fraction
and materials of both scene models (the project's simulator and
``validation/scene_model2.py``, which shares no code with it), each scored against its own
truth with the test on and effectively off (a limit of e³ times the sunlit blue, which no
dark pixel reaches), and with the long SWIR and without it (the same scene's SWIR cut at
1.9 µm).
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner

from geoboresight import Detection, shadow_map_file
from geoboresight.cli import main
from geoboresight.errors import ParameterError
from geoboresight.io import quiet_georef
from geoboresight.io.raster import write_envi
from geoboresight.shadow.context import (
    BLUE_NIR_RISE,
    SWIR_TILT,
    TILT_BLUE_MARGIN,
    sunlit_blue_levels,
    sunlit_dark,
    sunlit_tilt_level,
    swir_tilt,
)
from validation.shadow import make_scene

CORE = math.log(1 / 6)


def read(path):
    with quiet_georef(), rasterio.open(path) as src:
        return src.read(1), src.tags()


def _dark_patches(blue_in_shadow, blue_in_material, lit_blue=100.0):
    """Lit ground (blue ``lit_blue``, NIR 4 × that: soil and grass) with two dark patches
    (NIR/SWIR darkness ln 1/10): a shadow on flat ground (blue = NIR, as a dark material's)
    whose blue is ``blue_in_shadow``, and a flat dark material whose blue is
    ``blue_in_material``."""
    blue = np.full((30, 40), lit_blue)
    nir = 4 * blue
    dark = np.zeros((30, 40))
    dark[5:15, 5:15] = dark[5:15, 25:35] = math.log(0.1)
    blue[5:15, 5:15] = nir[5:15, 5:15] = blue_in_shadow
    blue[5:15, 25:35] = nir[5:15, 25:35] = blue_in_material
    return blue, nir, dark


def test_dark_pixels_keeping_the_sunlit_blue_are_declined():
    blue, nir, dark = _dark_patches(30.0, 110.0)  # skylight: a third of the blue; a dark roof
    levels = sunlit_blue_levels(blue, nir, dark > CORE)
    assert levels == pytest.approx((math.log(100.0), math.log(1 / 4)))
    out = sunlit_dark(blue, nir, dark, core=CORE, levels=levels)
    assert not out[5:15, 5:15].any()  # the shadow stays a candidate: its blue is dim
    assert out[5:15, 25:35].all()  # the dark material in the sun is declined
    assert not out[dark > CORE].any()  # only dark pixels are ever declined
    # The limit is the knob: at ln 1/2 the shadow's blue (0.3 of sunlit) is still dim enough;
    # at ln 1/4 it is taken for a material too.
    assert not sunlit_dark(blue, nir, dark, core=CORE, levels=levels, limit=math.log(1 / 2))[
        5:15, 5:15
    ].any()
    assert sunlit_dark(blue, nir, dark, core=CORE, levels=levels, limit=math.log(1 / 4))[
        5:15, 5:15
    ].all()


def test_a_bright_blue_shadow_that_keeps_its_grounds_balance_stays_shadow():
    # A shadow under a bright (hazy, low-sun) sky on the scene's own kind of ground: its blue
    # is at the sunlit level, its blue/NIR the ground's raised by the sky (× 2), below the
    # rise of a flat material (e^0.9 ≈ 2.5 ×).
    blue, nir, dark = _dark_patches(30.0, 110.0)
    blue[5:15, 5:15] = 100.0
    nir[5:15, 5:15] = 4 * 100.0 / 2
    assert math.log(2) < BLUE_NIR_RISE < math.log(4)
    levels = sunlit_blue_levels(blue, nir, dark > CORE)
    out = sunlit_dark(blue, nir, dark, core=CORE, levels=levels)
    assert not out[5:15, 5:15].any() and out[5:15, 25:35].all()


def test_noise_in_the_blue_is_averaged_over_the_dark_neighbours():
    rng = np.random.default_rng(3)
    blue, nir, dark = _dark_patches(30.0, 110.0)
    noisy = blue + rng.normal(0, 25, blue.shape)  # a dim, noisy blue band
    out = sunlit_dark(noisy, nir, dark, core=CORE, levels=(math.log(100.0), math.log(1 / 4)))
    # Pixel by pixel 25 DN of noise takes a shadow's blue (30 DN) above the limit (0.74 × 100)
    # in 4 % of its pixels; averaged over 3 × 3 dark neighbours (σ / 3) in none.
    assert ((noisy[5:15, 5:15] - 100 * math.exp(-0.3)) >= 0).mean() > 0.01
    assert out[5:15, 5:15].mean() == 0
    assert out[6:14, 26:34].mean() >= 0.9


def test_no_sunlit_blue_no_test_and_bad_limits_refused():
    blue, nir, dark = _dark_patches(30.0, 110.0)
    assert not sunlit_dark(blue, nir, dark, core=CORE, levels=(math.nan, 0.0)).any()
    assert np.isnan(sunlit_blue_levels(blue, nir, np.zeros(blue.shape, bool))).all()
    for bad in (math.nan, math.inf, "high"):
        with pytest.raises(ParameterError, match="sky_blue"):
            sunlit_dark(blue, nir, dark, core=CORE, levels=(0.0, 0.0), limit=bad)


def _tilted_patches():
    """Lit ground (blue 100, NIR 400, SWIR 300, long SWIR 150: vegetation and soil, darker at
    2.2 than at 1.65 µm) with three patches dark in NIR and SWIR (a tenth of the ground's),
    each with a blue of 0.65 × the sunlit blue (below test 1's limit, above test 3's): a
    shadow (the sky's share a third lower at 2.2 than at 1.65 µm: long SWIR 0.6 × the
    ground's tilt), a flat dark roof (long SWIR = its SWIR × the irradiance's ratio, the
    ground's reflectance ratio being 0.6) and, at blue 0.3 × sunlit, char (flat too)."""
    shape = (30, 60)
    blue, nir = np.full(shape, 100.0), np.full(shape, 400.0)
    swir, long = np.full(shape, 300.0), np.full(shape, 150.0)
    dark = np.zeros(shape)
    for c0, b, tilt in ((5, 65.0, 0.6), (25, 65.0, 1 / 0.6), (45, 30.0, 1 / 0.6)):
        sl = (slice(5, 15), slice(c0, c0 + 10))
        dark[sl] = math.log(0.1)
        blue[sl], nir[sl], swir[sl] = b, b, 30.0
        long[sl] = 15.0 * tilt
    return blue, nir, swir, long, dark


def test_the_long_swirs_tilt_declines_a_dark_roof_and_keeps_the_shadow():
    blue, nir, swir, long, dark = _tilted_patches()
    lit = dark > CORE
    tilt = sunlit_tilt_level(swir, long, lit)
    assert tilt == pytest.approx(math.log(0.5))
    t = swir_tilt(swir, long, ~lit, tilt)
    assert t[7:13, 7:13] == pytest.approx(math.log(0.6))  # the sky's tilt: −0.51
    assert t[7:13, 27:33] == pytest.approx(-math.log(0.6))  # a flat material's: +0.51
    assert math.log(0.6) < SWIR_TILT < 0
    levels = (*sunlit_blue_levels(blue, nir, lit), tilt)
    without = sunlit_dark(blue, nir, dark, core=CORE, levels=levels[:2])
    out = sunlit_dark(blue, nir, dark, core=CORE, levels=levels, swir=swir, long_swir=long)
    # Without the long SWIR the blue (0.65 × sunlit, below e^−0.3) declines neither patch.
    assert not without.any()
    assert not out[5:15, 5:15].any()  # the shadow stays a candidate
    assert out[5:15, 25:35].all()  # the sunlit dark roof is declined
    # Char (blue 0.3 × sunlit) is below test 3's blue limit: only geometry tells it apart.
    assert math.log(0.3) < -0.3 - TILT_BLUE_MARGIN < math.log(0.65)
    assert not out[5:15, 45:55].any()
    # A NaN tilt level (no long-SWIR bands lit) turns the tilt test off.
    nan_levels = (*levels[:2], math.nan)
    assert not sunlit_dark(
        blue, nir, dark, core=CORE, levels=nan_levels, swir=swir, long_swir=long
    ).any()


# --------------------------------------------------------------- both scene models' truth

M2 = dict(seed=2, sun_zenith=25.0, vnir_dark=60.0, swir_dark=400.0, vnir_gain=0.5, swir_gain=0.5)
SIM = dict(preset="mixed", zenith=60.0)


@pytest.fixture(scope="module", params=[(2, M2), (1, SIM)], ids=["model2", "simulator"])
def scene(request, tmp_path_factory):
    model, opts = request.param
    folder = str(tmp_path_factory.mktemp(f"m{model}") / "scene")
    material, names, dark_ids, *_ = make_scene(model, opts, 128, folder)
    with quiet_georef(), rasterio.open(os.path.join(folder, "truth_shadow_fraction.tif")) as s:
        f = s.read(1).astype(float)
    return model, folder, np.isin(material, dark_ids) & (f < 0.1), f >= 0.5


def _score(folder, out, sunlit_dark_px, truth, **kw):
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    res = shadow_map_file(j("vnir.hdr"), j("swir.hdr"), output=out, mask=out + ".mask.tif", **kw)
    m, tags = read(out + ".mask.tif")
    ok = m != 255
    shadow = (m == 1) & ok
    recall = (shadow & truth).sum() / (truth & ok).sum()
    flagged = shadow[sunlit_dark_px & ok].mean()
    tp = (shadow & truth).sum()
    f1 = 2 * tp / (2 * tp + (shadow & ~truth).sum() + (~shadow & truth & ok).sum())
    return res, tags, recall, flagged, f1


def test_dark_materials_stay_sunlit_and_shadow_recall_holds(scene, tmp_path):
    model, folder, sunlit_dark_px, truth = scene
    res_off, _, r_off, fa_off, f1_off = _score(
        folder, str(tmp_path / "off.tif"), sunlit_dark_px, truth, detection=Detection(sky_blue=3)
    )
    res, tags, r, fa, f1 = _score(folder, str(tmp_path / "on.tif"), sunlit_dark_px, truth)
    assert fa <= fa_off and fa <= 0.15
    # The product says how much of the dark it declined, and more is declined with the test.
    assert float(tags["DARK_DECLINED_SHARE"]) == pytest.approx(res["dark_declined_share"])
    assert res["dark_declined_share"] >= res_off["dark_declined_share"]
    assert tags["SKY_BLUE"] == "-0.3"
    if model == 2:
        # Model 2's parking lots, dark roofs (and char, which is dark in the blue too: it
        # stays) are 30 % flagged without the test.
        assert fa_off >= 0.25 and fa <= 0.5 * fa_off
        assert r >= 0.85 * r_off  # shadows on bright soil keep the scene's sunlit blue
        assert f1 > f1_off + 0.1
    else:
        # The simulator's dark materials already stay above the core darkness. The test's
        # cost is here: at 60° the bright sky keeps shadows on concrete near the sunlit
        # blue, and their flat balance is a dark material's; shadows on asphalt are as
        # flat in the SWIR as a sunlit material (recall 0.96 → 0.90).
        assert r >= 0.92 * r_off and f1 >= f1_off - 0.04


#: A model-2 scene whose dark roofs and parking keep 0.7–0.9 of the sunlit blue (so the blue
#: test alone leaves a fifth of them flagged) under a clear sky at 46°.
M2_ROOFS = dict(
    seed=81,
    sun_zenith=45.73,
    sun_azimuth=280.42,
    aot500=0.07,
    relief_m=9.11,
    vnir_dark=331.07,
    swir_dark=875.53,
    vnir_gain=0.78,
    swir_gain=0.93,
    adjacency=0.35,
    buildings=9,
    trees=15,
    offset_px=(0.33, -0.3),
)


def _short_swir(folder, out):
    """The scene's SWIR cut at 1.9 µm (a SWIR instrument without the 2.0–2.3 µm window)."""
    with quiet_georef(), rasterio.open(os.path.join(folder, "swir.img")) as src:
        wl = [float(w) for w in src.tags(ns="ENVI")["wavelength"].strip("{}").split(",")]
        keep = [i + 1 for i, w in enumerate(wl) if w < 1900]
        cube = src.read(keep)
    write_envi(out, cube, [wl[i - 1] for i in keep], interleave="bsq")
    return out[: -len(".img")] + ".hdr"


@pytest.mark.parametrize("model, opts", [(2, M2_ROOFS), (1, SIM)], ids=["model2", "simulator"])
def test_the_long_swir_leaves_dark_roofs_sunlit(model, opts, tmp_path):
    folder = str(tmp_path / "scene")
    material, names, dark_ids, *_ = make_scene(model, opts, 128, folder)
    with quiet_georef(), rasterio.open(os.path.join(folder, "truth_shadow_fraction.tif")) as s:
        f = s.read(1).astype(float)
    sunlit_dark_px, truth = np.isin(material, dark_ids) & (f < 0.1), f >= 0.5
    short = _short_swir(folder, str(tmp_path / "short.img"))
    v = os.path.join(folder, "vnir.hdr")
    runs = {}
    for name, swir in (("long", os.path.join(folder, "swir.hdr")), ("short", short)):
        out = str(tmp_path / f"{name}.tif")
        res = shadow_map_file(v, swir, output=out, mask=out + ".mask.tif")
        m = read(out + ".mask.tif")[0]
        ok = m != 255
        shadow = (m == 1) & ok
        tp = (shadow & truth).sum()
        f1 = 2 * tp / (2 * tp + (shadow & ~truth).sum() + (~shadow & truth & ok).sum())
        runs[name] = (shadow[sunlit_dark_px & ok].mean(), f1, res)
    (fa, f1, res), (fa_short, f1_short, res_short) = runs["long"], runs["short"]
    assert res["sunlit_swir_tilt"] is not None and res_short["sunlit_swir_tilt"] is None
    if model == 2:
        # The blue test alone leaves 18 % of the dark roofs and parking flagged; with the
        # long SWIR's tilt, 2 %, and F1 against the truth goes from 0.73 to 0.9.
        assert fa_short >= 0.12 and fa <= 0.05
        assert f1 >= f1_short + 0.1
    else:
        # The simulator's dark materials stay above the core darkness; at 60° its shadows on
        # asphalt are as flat in the SWIR as a sunlit material: the cost is there, small.
        assert fa <= fa_short + 0.01
        assert f1 >= f1_short - 0.02


def test_the_knob_from_the_command_line(scene, tmp_path):
    model, folder, sunlit_dark_px, truth = scene
    if model != 2:
        pytest.skip("one scene is enough for the command line")
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    runs = {}
    for limit in ("-0.5", "0.5"):
        out = str(tmp_path / f"c{limit}.tif")
        args = ["shadow-map", "--vnir", j("vnir.hdr"), "--swir", j("swir.hdr"), "-o", out]
        r = CliRunner().invoke(main, [*args, "--mask", out + ".m.tif", "--sky-blue", limit])
        assert r.exit_code == 0, r.output
        m, tags = read(out + ".m.tif")
        runs[limit] = ((m == 1) & sunlit_dark_px).mean(), float(tags["DARK_DECLINED_SHARE"])
    # A lower limit declines more of the dark and flags fewer dark materials.
    assert runs["-0.5"][1] > runs["0.5"][1]
    assert runs["-0.5"][0] < runs["0.5"][0]
    r = CliRunner().invoke(
        main,
        [
            "shadow-map",
            "--vnir",
            j("vnir.hdr"),
            "--swir",
            j("swir.hdr"),
            "-o",
            str(tmp_path / "x.tif"),
            "--sky-blue",
            "nan",
        ],
    )
    assert r.exit_code != 0 and "--sky-blue" in r.output and "Traceback" not in r.output
    assert not os.path.exists(tmp_path / "x.tif")


def test_strips_give_the_whole_images_map(scene, tmp_path):
    # The test reads its 3 × 3 neighbourhood across strip borders: the halo covers it.
    model, folder, *_ = scene
    if model != 2:
        pytest.skip("one scene is enough for the strips")
    j = lambda n: os.path.join(folder, n)  # noqa: E731
    fractions = []
    for rows in (256, 16):
        out = str(tmp_path / f"f{rows}.tif")
        shadow_map_file(
            j("vnir.hdr"), j("swir.hdr"), output=out + ".c.tif", fraction=out, block_rows=rows
        )
        fractions.append(read(out)[0])
    # Equal to float32 rounding (the neighbourhood means sum in another order near a border).
    np.testing.assert_allclose(fractions[0], fractions[1], rtol=0, atol=1e-6)
    assert ((fractions[0] >= 0.5) == (fractions[1] >= 0.5)).all()


def test_the_blocks_forward_the_test_and_the_surface_models_fallback_applies_it():
    # shadow_map_block takes the knob and the long SWIR; with a surface model whose caster
    # may stand beyond its edge (every pixel "unseen", no prior shadow) the spectral
    # estimate holds there, and so does its test: the shadow stays, the dark roof does not.
    from geoboresight.sensor.dark import DarkLevels
    from geoboresight.shadow import blocks, darkness
    from geoboresight.shadow.classes import default_table

    blue, nir, swir, long, dark = _tilted_patches()
    lit = dark > CORE
    cal = darkness.calibrate_shadow_map(
        blue.ravel(),
        nir.ravel(),
        swir.ravel(),
        np.ones(blue.size),
        lit.ravel() | ~lit.ravel(),
        dark=DarkLevels(0.0, 0.0),
        table=default_table(),
        long_swir=long.ravel(),
    )
    assert cal.tilt_level == pytest.approx(math.log(0.5))
    cubes = dict(blue=blue[None], nir=nir[None], swir=swir[None])
    kw = dict(calibration=cal, dark_levels=(0.0, 0.0, 0.0, 0.0), edge_pixels=0)
    _, m_off = blocks.shadow_map_block(**cubes, **kw)
    _, m_on = blocks.shadow_map_block(**cubes, **kw, sky_blue=-0.3, long_swir=long[None])
    roof, shade = (slice(7, 13), slice(27, 33)), (slice(7, 13), slice(7, 13))
    assert (m_off[roof] == 1).all() and (m_on[roof] == 0).all()
    assert (m_on[shade] == 1).all()
    no_prior = blocks.ModelOnBlock(prior=np.zeros(blue.shape), unseen=np.ones(blue.shape, bool))
    f_off, _ = blocks.shadow_fraction_block(**cubes, **kw, model=no_prior)
    f_on, _ = blocks.shadow_fraction_block(
        **cubes, **kw, model=no_prior, sky_blue=-0.3, long_swir=long[None]
    )
    assert (f_off[roof] >= 0.5).all() and (f_on[roof] < 0.5).all()
    assert (f_on[shade] >= 0.5).all()
