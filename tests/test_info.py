"""``geoboresight info``: what a flight line is, on every sensor product the readers know
(EnMAP L1B folder/zip/XML, PRISMA L1, Specim raw pair, HySpex) and on plain ENVI files; the
command line (positional paths, text, --json, -o), the engine's JSON lines, and the ratio's log
line naming the product.

Independent truth: what the fixture writers put in the files (tests/products*.py) and the
bands the ratio itself uses (its own result).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner
from products import write_hyspex, write_specim_raw
from products_space import write_enmap_l1b, write_prisma_l1

import geoboresight as gb
from geoboresight.cli import main
from geoboresight.io import write_envi
from geoboresight.io.describe import describe_product
from geoboresight.simulate.scene import simulate_scene

ENGINE = [sys.executable, "-m", "geoboresight.cli", "engine"]


@pytest.fixture(scope="module")
def scene():
    return simulate_scene("urban", lines=40, seed=4)


@pytest.fixture(scope="module")
def enmap(tmp_path_factory):
    return write_enmap_l1b(tmp_path_factory.mktemp("enmap"))


@pytest.fixture(scope="module")
def enmap_zip(tmp_path_factory):
    return write_enmap_l1b(tmp_path_factory.mktemp("enmapz"), zip=True)


@pytest.fixture(scope="module")
def prisma(tmp_path_factory):
    return write_prisma_l1(tmp_path_factory.mktemp("prisma") / "PRS_L1_STD.he5")


@pytest.fixture(scope="module")
def specim(scene, tmp_path_factory):
    folder = tmp_path_factory.mktemp("specim")
    s = scene.vnir.shape[2]
    eagle = write_specim_raw(
        folder,
        "eagle",
        scene.vnir,
        scene.vnir_wavelengths,
        dark=np.full((scene.vnir.shape[0], s), 190.0),
        dark_lines=10,
    )
    hawk = write_specim_raw(
        folder,
        "hawk",
        scene.swir,
        scene.swir_wavelengths,
        dark=np.full((scene.swir.shape[0], s), 800.0),
        dark_lines=10,
    )
    return eagle[0], hawk[0]


def _ratio_bands(tmp_path, vnir, swir=None):
    return gb.ratio_file(vnir, swir, output=str(tmp_path / "r.tif"))


def _check_against_ratio(d, ratio):
    for key in ("vnir_band", "vnir_wavelength_nm", "swir_band", "swir_wavelength_nm"):
        assert d[key] == ratio[key], key
    assert "ratio_error" not in d


def test_enmap_folder_zip_and_xml_are_described_alike(enmap, enmap_zip, tmp_path):
    xml = next(p for p in (tmp_path.parent / enmap.path).iterdir() if p.name.endswith("XML"))
    ratio = _ratio_bands(tmp_path, enmap.path)
    rows, cols = enmap.vnir_radiance.shape[1:]
    for path in (enmap.path, enmap_zip.path, str(xml)):
        d = describe_product(path)
        assert d["product"] == "EnMAP L1B" and d["arrangement"] == "product"
        assert (d["lines"], d["samples"]) == (rows, cols)
        assert (d["vnir_bands"], d["swir_bands"]) == (enmap.vnir_wl.size, enmap.swir_wl.size)
        _check_against_ratio(d, ratio)
        (f,) = d["files"]
        vnir, swir = f["images"]
        assert vnir["dtype"] == "float32" and vnir["stored_dtype"] == "int16"
        assert vnir["units"].startswith("radiance")
        assert vnir["wavelength_min_nm"] == pytest.approx(enmap.vnir_wl.min(), abs=1e-3)
        assert swir["wavelength_max_nm"] == pytest.approx(enmap.swir_wl.max(), abs=1e-3)
        assert f["geolocation"] is None and any("RPC" in n for n in f["notes"])
        assert d["dark_source"] == ""


def test_prisma_reports_its_geolocation_unused_slots_and_bil(prisma, tmp_path):
    d = describe_product(prisma.path)
    ratio = _ratio_bands(tmp_path, prisma.path)
    _check_against_ratio(d, ratio)
    (f,) = d["files"]
    assert f["product"] == "PRISMA L1"
    vnir, swir = f["images"]
    # The fixture's unused slots (centre 0) are the bad bands, and not in the range.
    used_v, used_s = prisma.vnir_wl[prisma.vnir_wl > 0], prisma.swir_wl[prisma.swir_wl > 0]
    assert vnir["bands"] == prisma.vnir_wl.size and swir["bands"] == prisma.swir_wl.size
    assert vnir["bands"] - len(vnir["bad_bands"]) == d["vnir_bands"] == used_v.size
    assert swir["bands"] - len(swir["bad_bands"]) == d["swir_bands"] == used_s.size
    assert vnir["wavelength_min_nm"] == pytest.approx(used_v.min(), abs=1e-3)
    assert vnir["interleave"] == "BIL" and vnir["stored_dtype"] == "uint16"
    geo = f["geolocation"]
    assert geo["crs"] == "EPSG:4326" and (geo["lines"], geo["samples"]) == (
        d["lines"],
        d["samples"],
    )


def test_specim_pair_reports_dark_frames_and_the_ratio_bands(specim, scene, tmp_path):
    v, s = specim
    d = describe_product(v, s)
    assert d["product"] == "Specim raw ENVI" and d["arrangement"] == "two files"
    assert (d["lines"], d["samples"]) == scene.vnir.shape[1:]
    assert (d["vnir_bands"], d["swir_bands"]) == (scene.vnir.shape[0], scene.swir.shape[0])
    _check_against_ratio(d, _ratio_bands(tmp_path, v, s))
    assert d["dark_source"] == "frames"
    means = [f["images"][0]["dark"]["mean"] for f in d["files"]]
    assert means == pytest.approx([190.0, 800.0], abs=0.5)
    assert all(f["images"][0]["interleave"] == "BIL" for f in d["files"])


def test_hyspex_alone_describes_itself_and_says_why_no_ratio(scene, tmp_path):
    bg = np.full(scene.vnir[:, 0].shape, 190.0)
    path = write_hyspex(tmp_path, "VNIR_1800", scene.vnir, scene.vnir_wavelengths, bg)
    d = describe_product(path)
    assert d["product"] == "HySpex" and d["vnir_band"] is None
    assert "SWIR" in d["ratio_error"]
    im = d["files"][0]["images"][0]
    assert im["dark_source"] == "background matrix" and im["dark"]["mean"] == pytest.approx(190.0)


def test_plain_envi_files_are_gdal_rasters_with_their_bad_bands(tmp_path):
    rng = np.random.default_rng(1)
    cube = rng.integers(100, 2000, (6, 20, 12)).astype("uint16")
    v = write_envi(str(tmp_path / "v.img"), cube, np.linspace(870.0, 970.0, 6))
    s = write_envi(str(tmp_path / "s.img"), cube, 980.0 + 30.0 * np.arange(6))
    hdr = tmp_path / "s.hdr"
    hdr.write_text(hdr.read_text() + "bbl = {1, 1, 0, 1, 1, 0}\n")
    d = describe_product(v, s)
    assert d["product"] == "GDAL raster" and (d["lines"], d["samples"]) == (20, 12)
    assert d["files"][1]["images"][0]["bad_bands"] == [3, 6]
    assert d["swir_bands"] == 4 and d["files"][0]["geolocation"] is None


def test_cli_positional_text_json_and_output(enmap, tmp_path):
    runner = CliRunner()
    text = runner.invoke(main, ["info", "-q", enmap.path])
    assert text.exit_code == 0, text.output
    assert (
        text.output.startswith("Product: EnMAP L1B") and "Boresight ratio: SWIR band" in text.output
    )
    out = tmp_path / "info.json"
    js = runner.invoke(main, ["info", "-q", "--json", "--vnir", enmap.path, "-o", str(out)])
    assert js.exit_code == 0, js.output
    result = json.loads(js.output)
    written = json.loads(out.read_text())
    assert result["output"] == str(out) and result["product"] == written["product"]
    assert written["files"] == result["files"] and "summary" not in written
    twice = runner.invoke(main, ["info", enmap.path, "--vnir", enmap.path])
    assert twice.exit_code != 0 and "given twice" in twice.output


def test_ratio_log_names_the_product(enmap, tmp_path):
    messages = []
    gb.ratio_file(
        enmap.path,
        output=str(tmp_path / "r.tif"),
        progress=gb.Progress(log=messages.append),
    )
    assert any("EnMAP L1B product" in m for m in messages), messages


def _engine_run(tmp_path, name, params):
    path = tmp_path / f"{name}.json"
    path.write_text(json.dumps(params))
    done = subprocess.run(
        [*ENGINE, "run", name, "--params-json", str(path)],
        capture_output=True,
        text=True,
        timeout=300,
    )
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.strip()]
    return done, lines


def test_engine_runs_ratio_and_info_on_a_specim_pair_and_a_prisma_file(specim, prisma, tmp_path):
    v, s = specim
    for tag, params in (("specim", {"vnir": v, "swir": s}), ("prisma", {"vnir": prisma.path})):
        out = tmp_path / f"{tag}.tif"
        done, lines = _engine_run(tmp_path, "ratio", {**params, "output": str(out)})
        assert done.returncode == 0, done.stderr
        result = lines[-1]["result"]
        lib = gb.ratio_file(**params, output=str(tmp_path / f"{tag}_lib.tif"))
        assert result == {**lib, "output": str(out)}
        kind = "Specim raw ENVI" if tag == "specim" else "PRISMA L1"
        assert any(f"{kind} product" in m.get("info", "") for m in lines)
        done, lines = _engine_run(tmp_path, "info", params)
        assert done.returncode == 0, done.stderr
        info = lines[-1]["result"]
        assert info["product"] == kind and info["swir_band"] == lib["swir_band"]
        assert info["summary"].startswith(f"Product: {kind}")
