"""The sky-light test of dark pixels (shadow.context): a pixel dark in the near infrared and
SWIR whose blue is as bright as the scene's sunlit blue is a sunlit dark material, not shadow.

Independent truth: blue levels put into synthetic arrays, and the shadow fraction and
materials of both scene models (the project's simulator and ``validation/scene_model2.py``,
which shares no code with it), each scored against its own truth with the test on and
effectively off (a limit of e³ times the sunlit blue, which no dark pixel reaches).
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
from geoboresight.shadow.context import sunlit_blue_level, sunlit_dark
from validation.shadow import make_scene

CORE = math.log(1 / 6)


def read(path):
    with quiet_georef(), rasterio.open(path) as src:
        return src.read(1), src.tags()


def _dark_patches(blue_in_shadow, blue_in_material, lit_blue=100.0):
    """Lit ground (blue ``lit_blue``) with two dark patches (NIR/SWIR darkness ln 1/10): one
    whose blue is ``blue_in_shadow``, one whose blue is ``blue_in_material``."""
    blue = np.full((30, 40), lit_blue)
    dark = np.zeros((30, 40))
    dark[5:15, 5:15] = dark[5:15, 25:35] = math.log(0.1)
    blue[5:15, 5:15] = blue_in_shadow
    blue[5:15, 25:35] = blue_in_material
    return blue, dark


def test_dark_pixels_keeping_the_sunlit_blue_are_declined():
    blue, dark = _dark_patches(30.0, 110.0)  # skylight: a third of the blue; a flat dark roof
    level = sunlit_blue_level(blue, dark > CORE)
    assert level == pytest.approx(math.log(100.0))
    out = sunlit_dark(blue, dark, core=CORE, blue_level=level)
    assert not out[5:15, 5:15].any()  # the shadow stays a candidate
    assert out[5:15, 25:35].all()  # the dark material in the sun is declined
    assert not out[dark > CORE].any()  # only dark pixels are ever declined
    # The limit is the knob: at ln 1/2 the shadow's blue (0.3 of sunlit) is still dim enough;
    # at ln 1/4 it is taken for a material too.
    assert not sunlit_dark(blue, dark, core=CORE, blue_level=level, limit=math.log(1 / 2))[
        5:15, 5:15
    ].any()
    assert sunlit_dark(blue, dark, core=CORE, blue_level=level, limit=math.log(1 / 4))[
        5:15, 5:15
    ].all()


def test_noise_in_the_blue_is_averaged_over_the_dark_neighbours():
    rng = np.random.default_rng(3)
    blue, dark = _dark_patches(30.0, 110.0)
    noisy = blue + rng.normal(0, 25, blue.shape)  # a dim, noisy blue band
    out = sunlit_dark(noisy, dark, core=CORE, blue_level=math.log(100.0))
    # Pixel by pixel a 25 DN noise crosses the limit in ~0.3 % of the shadow's pixels at
    # one sigma ×3; averaged over 3 × 3 dark neighbours (σ/3) none do.
    assert out[5:15, 5:15].mean() == 0
    assert out[6:14, 26:34].mean() >= 0.9


def test_no_sunlit_blue_no_test_and_bad_limits_refused():
    blue, dark = _dark_patches(30.0, 110.0)
    assert not sunlit_dark(blue, dark, core=CORE, blue_level=math.nan).any()
    assert math.isnan(sunlit_blue_level(blue, np.zeros(blue.shape, bool)))
    for bad in (math.nan, math.inf, "high"):
        with pytest.raises(ParameterError, match="sky_blue"):
            sunlit_dark(blue, dark, core=CORE, blue_level=0.0, limit=bad)


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
    assert tags["SKY_BLUE"] == "0.0"
    if model == 2:
        # Model 2's parking lots, dark roofs (and char, which is dark in the blue too: it
        # stays) are 30 % flagged without the test.
        assert fa_off >= 0.25 and fa <= 0.5 * fa_off
        assert r >= 0.85 * r_off  # shadows on bright soil keep the scene's sunlit blue
        assert f1 > f1_off + 0.1
    else:
        # The simulator's dark materials already stay above the core darkness: the test
        # must not cost its shadows.
        assert r >= 0.98 * r_off and f1 >= f1_off - 0.01


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
