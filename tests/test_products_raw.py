"""Raw-DN sensor products: Specim raw ENVI (dark frames, frame counter, DARKREF) and HySpex
``.hyspex`` (binary header, background matrix), through every layer: recognition, the image
GDAL reads (image lines only), the dark reference, the boresight ratio, statistics, the CLI,
shadow-map's dark levels and the damaged-file messages.

Independent truth: the simulator's scene (known DN with each detector's dark offset) written
to the published layouts by ``tests/products.py``, and NumPy on those arrays.
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
import rasterio
from click.testing import CliRunner
from products import dark_frames, write_hyspex, write_specim_raw

import geoboresight as gb
from geoboresight.cli import main
from geoboresight.errors import InputError
from geoboresight.io import open_dual, quiet_georef
from geoboresight.io.dual import SWIR_NM, VNIR_NM
from geoboresight.io.products import recognise
from geoboresight.io.products import specim as specim_reader
from geoboresight.io.windows import read_masked
from geoboresight.simulate.scene import simulate_scene

LINES = 48
DARK_LINES = 20
VNIR_DARK = 190.0  # the simulator's VNIR and SWIR dark offsets (simulate/sensor.py)
SWIR_DARK = 800.0


@pytest.fixture(scope="module")
def scene():
    return simulate_scene("urban", lines=LINES, seed=3)


def _pattern(bands, samples, level):
    """A dark level with a fixed column pattern, as a real detector has."""
    cols = np.arange(samples)
    return level + 4.0 * np.sin(cols / 7.0)[None, :] + np.zeros((bands, 1))


def _read_all(source):
    with quiet_georef(), rasterio.open(source) as src:
        return src.read()


def _nearest(wl, nm):
    return int(np.argmin(np.abs(np.asarray(wl) - nm)))


def _ratio_numpy(swir_band, vnir_band):
    s = swir_band.astype(np.float32)
    v = vnir_band.astype(np.float32)
    ok = v > 0
    return np.where(ok, s / np.where(ok, v, 1), -9999.0).astype(np.float32)


def _written_ratio(path):
    with quiet_georef(), rasterio.open(path) as src:
        return src.read(1), src.height, src.width


@pytest.fixture(scope="module")
def specim_pair(scene, tmp_path_factory):
    """An Eagle capture whose autodarkstartline points at the last light line (corrected by
    the frame counter) and a Hawk capture pointing at the first dark line."""
    folder = tmp_path_factory.mktemp("specim")
    b_v, _, s = scene.vnir.shape
    eagle = write_specim_raw(
        folder,
        "eagle",
        scene.vnir,
        scene.vnir_wavelengths,
        fwhm=scene.vnir_fwhm,
        dark=_pattern(b_v, s, VNIR_DARK),
        dark_lines=DARK_LINES,
        autodark_shift=-1,
        seed=1,
    )
    hawk = write_specim_raw(
        folder,
        "hawk",
        scene.swir,
        scene.swir_wavelengths,
        fwhm=scene.swir_fwhm,
        dark=_pattern(scene.swir.shape[0], s, SWIR_DARK),
        dark_lines=DARK_LINES,
        seed=2,
    )
    return eagle, hawk


# ------------------------------------------------------------------ Specim: recognition


def test_specim_capture_is_recognised_with_its_image_lines_and_dark_frames(scene, specim_pair):
    (hdr_v, data_v, cube_v), (hdr_s, data_s, cube_s) = specim_pair
    for path in (hdr_v, data_v):  # the header or the data file
        product = recognise(path)
        assert product is not None and product.kind == "Specim raw ENVI"
        (image,) = product.images
        assert image.name == "VNIR" and image.units == "DN"
        np.testing.assert_allclose(image.wavelengths, scene.vnir_wavelengths, atol=1e-4)
        np.testing.assert_allclose(image.fwhm, scene.vnir_fwhm, atol=1e-4)
        pixels = _read_all(image.source)
        assert pixels.shape == (scene.vnir.shape[0], LINES, scene.vnir.shape[2])
        # The image lines as written (band 1 holds the frame counter in samples 0-1).
        np.testing.assert_array_equal(pixels, cube_v[:LINES].transpose(1, 0, 2))
        np.testing.assert_array_equal(pixels[1:], scene.vnir[1:])
        # autodarkstartline = 47 pointed at the last light line: the counter moved it to 48.
        assert any("last light line" in n for n in product.notes)
        # The dark reference: the mean of the dark lines, exactly (NaN where not image).
        want = cube_v[LINES:].mean(axis=0)
        assert image.dark_source == "frames" and image.dark.shape == want.shape
        assert np.isnan(image.dark[0, :2]).all()
        got = image.dark.copy()
        got[0, :2] = want[0, :2]
        np.testing.assert_array_equal(got, want)
    hawk = recognise(hdr_s).images[0]
    assert hawk.name == "SWIR" and hawk.dark_source == "frames"
    assert _read_all(hawk.source).shape[1] == LINES
    np.testing.assert_array_equal(hawk.dark[1:], cube_s[LINES:, 1:].mean(axis=0))


def test_specim_frame_counter_is_masked_in_band_1_only(specim_pair):
    (hdr_v, _, _), _ = specim_pair
    source = recognise(hdr_v).images[0].source
    with quiet_georef(), rasterio.open(source) as src:
        _, ok = read_masked(src, 1)
        assert not ok[:, :2].any() and ok[:, 2:].all()
        _, ok = read_masked(src, 2)
        assert ok.all()


def test_specim_header_without_dark_frames(scene, tmp_path):
    """sensorid/fps/tint alone: a product only when it carries something a plain read misses."""
    img = scene.vnir[:, :12]
    plain, _, _ = write_specim_raw(tmp_path, "plain", img, scene.vnir_wavelengths, counter=False)
    assert recognise(plain) is None  # GDAL reads it as before
    counted, _, _ = write_specim_raw(tmp_path, "counted", img, scene.vnir_wavelengths)
    product = recognise(counted)
    assert product is not None and product.images[0].dark is None
    assert _read_all(product.images[0].source).shape[1] == 12
    # A DARKREF_<name> capture beside it (hylite's Fenix convention) is the dark reference.
    lab, _, _ = write_specim_raw(tmp_path, "lab", img, scene.vnir_wavelengths, counter=False)
    ref = dark_frames((9,) + img.shape[::2], VNIR_DARK, seed=4)
    write_specim_raw(tmp_path, "DARKREF_lab", ref.transpose(1, 0, 2), scene.vnir_wavelengths)
    image = recognise(lab).images[0]
    assert image.dark_source == "DARKREF file"
    want = ref.mean(axis=0)
    np.testing.assert_array_equal(image.dark[1:], want[1:])
    np.testing.assert_array_equal(image.dark[0, 2:], want[0, 2:])
    assert np.isnan(image.dark[0, :2]).all()  # the DARKREF's own frame counter


def test_specim_counter_check_leaves_a_correct_autodarkstartline(scene, tmp_path):
    hdr, _, cube = write_specim_raw(
        tmp_path, "ok", scene.vnir[:, :10], scene.vnir_wavelengths, dark=190.0, dark_lines=5
    )
    product = recognise(hdr)
    assert not any("last light line" in n for n in product.notes)
    assert _read_all(product.images[0].source).shape[1] == 10
    # No counter at all: autodarkstartline is taken as written.
    hdr, _, _ = write_specim_raw(
        tmp_path,
        "nocount",
        scene.vnir[:, :10],
        scene.vnir_wavelengths,
        dark=190.0,
        dark_lines=5,
        autodark_shift=-1,
        counter=False,
    )
    assert _read_all(recognise(hdr).images[0].source).shape[1] == 9
    assert specim_reader.image_name([400, 1200]) == "cube"


# ------------------------------------------------------------------ Specim: operations


def test_ratio_of_a_specim_eagle_hawk_pair_equals_numpy(scene, specim_pair, tmp_path):
    (hdr_v, _, _), (hdr_s, _, _) = specim_pair
    out = str(tmp_path / "ratio.tif")
    result = gb.ratio_file(hdr_v, hdr_s, output=out)
    vb, sb = _nearest(scene.vnir_wavelengths, VNIR_NM), _nearest(scene.swir_wavelengths, SWIR_NM)
    assert (result["vnir_band"], result["swir_band"]) == (vb + 1, sb + 1)
    got, height, width = _written_ratio(out)
    assert (height, width) == (LINES, scene.vnir.shape[2])  # image lines only
    np.testing.assert_array_equal(got, _ratio_numpy(scene.swir[sb], scene.vnir[vb]))
    stats = gb.stats_file(out, output=str(tmp_path / "stats.json"))
    assert stats["n"] == result["valid_pixels"] == int((scene.vnir[vb] > 0).sum())
    assert stats["n"] <= LINES * scene.vnir.shape[2]


def test_ratio_of_an_aisa_dual_merged_cube_with_dark_frames(scene, tmp_path):
    merged = np.concatenate([scene.vnir, scene.swir])
    wl = scene.wavelengths
    dark = np.concatenate(
        [
            _pattern(scene.vnir.shape[0], merged.shape[2], VNIR_DARK),
            _pattern(scene.swir.shape[0], merged.shape[2], SWIR_DARK),
        ]
    )
    hdr, _, cube = write_specim_raw(
        tmp_path, "dual", merged, wl, dark=dark, dark_lines=DARK_LINES, extension=".img"
    )
    product = recognise(hdr)
    assert product.images[0].name == "cube"
    dual = open_dual(hdr)
    assert dual.merged and dual.height == LINES
    assert dual.vnir.dark.shape == (len(dual.vnir.bands), merged.shape[2])
    np.testing.assert_array_equal(
        dual.swir.dark, cube[LINES:].mean(axis=0)[np.asarray(dual.swir.bands) - 1]
    )
    out = str(tmp_path / "ratio.tif")
    result = gb.ratio_file(hdr, output=out)
    vb, sb = _nearest(wl[wl < 975], VNIR_NM), _nearest(wl, SWIR_NM)
    assert (result["vnir_band"], result["swir_band"]) == (vb + 1, sb + 1)
    got, height, _ = _written_ratio(out)
    assert height == LINES
    np.testing.assert_array_equal(got, _ratio_numpy(merged[sb], merged[vb]))
    stats = gb.stats_file(out, output=str(tmp_path / "stats.json"))
    assert stats["n"] == int((merged[vb] > 0).sum())


def test_shadow_map_takes_the_dark_frames(specim_pair, tmp_path):
    (hdr_v, _, cube_v), (hdr_s, _, cube_s) = specim_pair
    out = str(tmp_path / "shadow.tif")
    result = gb.shadow_map_file(hdr_v, hdr_s, output=out)
    assert result["vnir_dark_source"] == "frames" and result["swir_dark_source"] == "frames"
    # One level per band (the mean over its columns); their mean is close to the offsets.
    assert result["vnir_dark_dn"] == pytest.approx(VNIR_DARK, abs=1.0)
    assert result["swir_dark_dn"] == pytest.approx(SWIR_DARK, abs=1.0)
    with quiet_georef(), rasterio.open(out) as src:
        tags = {k.lower(): v for k, v in src.tags().items()}
        assert src.height == LINES
    assert tags["vnir_dark_source"] == "frames"


# ------------------------------------------------------------------ HySpex


@pytest.fixture(scope="module")
def hyspex_pair(scene, tmp_path_factory):
    folder = tmp_path_factory.mktemp("hyspex")
    s = scene.vnir.shape[2]
    bg_v = _pattern(scene.vnir.shape[0], s, VNIR_DARK)
    bg_s = _pattern(scene.swir.shape[0], s, SWIR_DARK)
    v = write_hyspex(folder, "VNIR_1800", scene.vnir, scene.vnir_wavelengths, bg_v)
    w = write_hyspex(folder, "SWIR_384", scene.swir, scene.swir_wavelengths, bg_s)
    return v, w, bg_v, bg_s


def test_hyspex_is_recognised_with_its_background_matrix(scene, hyspex_pair):
    v, w, bg_v, bg_s = hyspex_pair
    product = recognise(v)
    assert product.kind == "HySpex"
    (image,) = product.images
    assert image.name == "VNIR" and image.units == "DN"
    np.testing.assert_array_equal(image.wavelengths, scene.vnir_wavelengths)
    np.testing.assert_array_equal(_read_all(image.source), scene.vnir)
    assert image.dark_source == "background matrix"
    np.testing.assert_array_equal(image.dark, bg_v)
    swir = recognise(w).images[0]
    assert swir.name == "SWIR" and len(swir.wavelengths) == scene.swir.shape[0]
    np.testing.assert_array_equal(swir.dark, bg_s)


def test_ratio_of_a_hyspex_pair_equals_numpy(scene, hyspex_pair, tmp_path):
    v, w, _, _ = hyspex_pair
    out = str(tmp_path / "ratio.tif")
    result = gb.ratio_file(v, w, output=out)
    vb, sb = _nearest(scene.vnir_wavelengths, VNIR_NM), _nearest(scene.swir_wavelengths, SWIR_NM)
    assert (result["vnir_band"], result["swir_band"]) == (vb + 1, sb + 1)
    got, height, width = _written_ratio(out)
    assert (height, width) == scene.vnir.shape[1:]
    np.testing.assert_array_equal(got, _ratio_numpy(scene.swir[sb], scene.vnir[vb]))
    stats = gb.stats_file(out, output=str(tmp_path / "stats.json"))
    assert stats["n"] == int((scene.vnir[vb] > 0).sum())


def test_hyspex_pair_of_different_sizes_is_refused(scene, tmp_path):
    """VNIR-1800 and SWIR-384 see the same swath with different pixel counts."""
    v = write_hyspex(
        tmp_path, "v", scene.vnir, scene.vnir_wavelengths, np.zeros(scene.vnir[:, 0].shape)
    )
    narrow = scene.swir[:, :, :64]
    w = write_hyspex(tmp_path, "w", narrow, scene.swir_wavelengths, np.zeros(narrow[:, 0].shape))
    with pytest.raises(InputError, match="same pixel grid") as err:
        gb.ratio_file(v, w, output=str(tmp_path / "r.tif"))
    message = str(err.value)
    assert "286 × 48" in message and "64 × 48" in message and "resample" in message


# ------------------------------------------------------------------ CLI and damaged files


def test_cli_ratio_on_specim_and_hyspex_pairs(specim_pair, hyspex_pair, tmp_path):
    (hdr_v, _, _), (hdr_s, _, _) = specim_pair
    v, w, _, _ = hyspex_pair
    for i, (a, b) in enumerate(((hdr_v, hdr_s), (v, w))):
        out = str(tmp_path / f"r{i}.tif")
        r = CliRunner().invoke(main, ["ratio", "--vnir", a, "--swir", b, "-o", out, "--json"])
        assert r.exit_code == 0, r.output
        assert _written_ratio(out)[1] == LINES


def _damaged(scene, folder):
    """(file, words its message must hold) for each damaged product."""
    img, wl = scene.vnir[:, :6, :40], scene.vnir_wavelengths
    bg = np.full(img[:, 0].shape, VNIR_DARK)
    full = os.path.getsize(write_hyspex(folder, "whole", img, wl, bg))
    yield write_hyspex(folder, "short_header", img, wl, bg, truncate_to=1000), "header is truncated"
    yield write_hyspex(folder, "past_end", img, wl, bg, hdr_size=10**9), "past the end"
    yield (
        write_hyspex(folder, "short_data", img, wl, bg, truncate_to=full - 7),
        "data are truncated",
    )
    hdr, _, _ = write_specim_raw(
        folder, "late", img, wl, dark=190, dark_lines=3, autodarkstartline=40
    )
    yield hdr, "autodarkstartline = 40"


def test_damaged_products_give_one_line_naming_the_file(scene, tmp_path):
    for path, words in _damaged(scene, tmp_path):
        with pytest.raises(InputError, match=words) as err:
            recognise(path)
        assert path in str(err.value)
        out = str(tmp_path / "r.tif")
        r = CliRunner().invoke(main, ["ratio", "--vnir", path, "--swir", path, "-o", out])
        assert r.exit_code == 1, r.output
        assert "Traceback" not in r.output and path in r.output and words in r.output
        assert len(r.output.strip().splitlines()) == 1, r.output


def test_stats_json_counts_image_pixels_only(specim_pair, tmp_path):
    (hdr_v, _, _), (hdr_s, _, _) = specim_pair
    out = str(tmp_path / "r.tif")
    gb.ratio_file(hdr_v, hdr_s, output=out)
    gb.stats_file(out, output=str(tmp_path / "s.json"))
    stats = json.loads((tmp_path / "s.json").read_text())
    assert 0 < stats["n"] <= LINES * 286


def test_deshadow_takes_the_dark_frames_band_by_band(scene, tmp_path):
    """A Specim capture whose dark frames differ from band to band: deshadow subtracts each
    band's own level (the mean over its columns), not one level per instrument."""
    b_v, _, s = scene.vnir.shape
    b_s = scene.swir.shape[0]
    step_v = 6.0 * (np.arange(b_v) % 9)[:, None]
    step_s = 9.0 * (np.arange(b_s) % 7)[:, None]
    folder = tmp_path / "specim"
    hdr_v, _, _ = write_specim_raw(
        folder,
        "eagle",
        scene.vnir + step_v[:, :, None].astype(scene.vnir.dtype),  # the image's dark too
        scene.vnir_wavelengths,
        fwhm=scene.vnir_fwhm,
        dark=_pattern(b_v, s, VNIR_DARK) + step_v,
        dark_lines=DARK_LINES,
        seed=1,
    )
    hdr_s, _, _ = write_specim_raw(
        folder,
        "hawk",
        scene.swir + step_s[:, :, None].astype(scene.swir.dtype),
        scene.swir_wavelengths,
        fwhm=scene.swir_fwhm,
        dark=_pattern(b_s, s, SWIR_DARK) + step_s,
        dark_lines=DARK_LINES,
        seed=2,
    )
    frac = str(tmp_path / "f.tif")
    f = np.nan_to_num(np.asarray(scene.shadow_fraction, "float32"), nan=0.0)
    with rasterio.open(
        frac, "w", driver="GTiff", width=f.shape[1], height=f.shape[0], count=1, dtype="float32"
    ) as dst:
        dst.write(f, 1)
    rep = str(tmp_path / "d.json")
    gb.deshadow_file(hdr_v, hdr_s, shadow=frac, output=str(tmp_path / "d.tif"), report=rep)
    with open(rep) as fh:
        levels = np.array([b["dark_level_dn"] for b in json.load(fh)["bands"]])
    expected = np.r_[VNIR_DARK + step_v[:, 0], SWIR_DARK + step_s[:, 0]]
    # The column pattern averages to within a DN of the level; the steps are band by band.
    assert levels == pytest.approx(expected, abs=1.0)
    assert np.ptp(levels[:b_v]) >= 40
