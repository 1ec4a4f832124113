"""The simulator's files: what a GIS user and the other applications read from a scene folder.

Checked with independent readers (rasterio/GDAL, the library's dual-sensor opener, json, csv):
wavelengths and FWHM in the ENVI headers, raw geometry kept raw, truth rasters on the VNIR grid,
the merged cube, byte-for-byte determinism of a written scene, and the ``simulate`` spec.
"""

from __future__ import annotations

import csv
import filecmp
import json
import os

import numpy as np
import pytest
import rasterio

import geoboresight as gb
from geoboresight import simulate_file
from geoboresight.algorithms.simulate import SIMULATE
from geoboresight.errors import OutputError, ParameterError
from geoboresight.io import open_dual, quiet_georef
from geoboresight.io.scene import NAVIGATION_FILES, SCENE_FILES, write_scene
from geoboresight.simulate import simulate_scene


@pytest.fixture(scope="module")
def small():
    return simulate_scene("mixed", lines=40, seed=11, targets=4, clouds=1, supersample=2)


@pytest.fixture(scope="module")
def folder(small, tmp_path_factory):
    out = tmp_path_factory.mktemp("scene") / "mixed"
    write_scene(small, out, merged=True)
    return out


def test_folder_holds_every_file(folder):
    names = set(os.listdir(folder))
    assert set(SCENE_FILES) <= names
    assert {"merged.img", "merged.hdr"} <= names
    assert not [n for n in names if ".tmp" in n]


def test_envi_cubes_carry_wavelengths_and_stay_raw(folder, small):
    dual = open_dual(str(folder / "vnir.hdr"), str(folder / "swir.hdr"))
    assert dual.crs is None and dual.transform is None
    assert np.allclose(dual.vnir.wavelengths, small.vnir_wavelengths, atol=1e-3)
    assert np.allclose(dual.swir.wavelengths, small.swir_wavelengths, atol=1e-3)
    assert np.allclose(dual.vnir.fwhm, small.vnir_fwhm, atol=1e-3)
    assert len(dual.vnir.bands) + len(dual.swir.bands) == 198
    bands = dual.ratio_bands(gb.BandChoice(vnir_nm=920.0, swir_nm=1010.0, tolerance_nm=10.0))
    assert (
        abs(dual.swir.wavelength_of(bands.swir_band) - 1010) < 2
        and abs(dual.vnir.wavelength_of(bands.vnir_band) - 920) < 3
    )
    with quiet_georef(), rasterio.open(folder / "vnir.img") as src:
        assert (
            src.dtypes[0] == "uint16" and src.count == 96 and (src.height, src.width) == (40, 286)
        )
        assert np.array_equal(src.read(), small.vnir)
    with open(folder / "vnir.hdr", encoding="utf-8") as f:
        header = f.read()
    assert "interleave = bil" in header and "wavelength units = Nanometers" in header
    assert ".tmp" not in header  # no temporary path leaks into the header


def test_merged_cube_is_split_at_the_seam(folder, small):
    dual = open_dual(str(folder / "merged.hdr"))
    assert len(dual.vnir.bands) == 96 and len(dual.swir.bands) == 102
    with quiet_georef(), rasterio.open(folder / "merged.img") as src:
        assert np.array_equal(src.read(97), small.swir[0])


def test_truth_rasters_on_vnir_grid(folder, small):
    expected = {
        "truth_dsm.tif": small.dsm,
        "truth_shadow_fraction.tif": small.shadow_fraction,
        "truth_target_abundance.tif": small.target_abundance,
        "truth_cloud_mask.tif": small.cloud_mask.astype("uint8"),
        "truth_material.tif": small.material,
    }
    for name, arr in expected.items():
        with quiet_georef(), rasterio.open(folder / name) as src:
            assert (src.height, src.width) == (40, 286), name
            assert src.crs is None, name
            assert np.allclose(src.read(1), arr), name
    with rasterio.open(folder / "truth_material.tif") as src:
        tags = src.tags(1)
        for k, v in small.material_names.items():
            assert tags[f"CLASS_{k}"] == v
        assert src.colormap(1)[1][:3] == (60, 60, 60)


def test_truth_json_and_endmembers(folder, small):
    truth = json.loads((folder / "truth.json").read_text())
    for key in (
        "preset", "seed", "lines", "cols", "gsd_m", "ifov_mrad", "flying_height_m",
        "nominal_altitude_m", "squint_deg", "boresight_deg", "offset_px",
        "disparity_px_per_m", "height_precision_m_per_px", "sun", "materials", "targets", "noise",
    ):  # fmt: skip
        assert key in truth, key
    assert truth == json.loads(json.dumps(small.truth))
    assert len(truth["targets"]) == 4
    for t in truth["targets"]:
        assert small.target_abundance[t["row"], t["col"]] == pytest.approx(t["abundance"], abs=1e-6)
    with open(folder / "endmembers.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 198
    assert float(rows[0]["wavelength_nm"]) == pytest.approx(400.0)
    assert set(small.abundance_names) <= set(rows[0])
    bag = np.array([float(r["plastic_bag"]) for r in rows])
    assert np.allclose(bag, small.endmember_spectra["plastic_bag"], atol=1e-6)


def test_same_seed_writes_identical_bytes(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    write_scene(simulate_scene("urban", lines=24, seed=5, supersample=2), a)
    write_scene(simulate_scene("urban", lines=24, seed=5, supersample=2), b)
    names = sorted(os.listdir(a))
    assert names == sorted(os.listdir(b))
    match, mismatch, errors = filecmp.cmpfiles(a, b, names, shallow=False)
    assert mismatch == [] and errors == [] and len(match) == len(names)


def test_existing_folder_is_refused_and_nothing_is_left(tmp_path, small):
    out = tmp_path / "scene"
    out.mkdir()
    with pytest.raises(OutputError, match="already exists"):
        write_scene(small, out)
    with pytest.raises(OutputError, match="does not exist"):
        write_scene(small, tmp_path / "missing" / "scene")
    assert os.listdir(tmp_path) == ["scene"]


def test_spec_runs_and_reports_the_offset(tmp_path):
    alg = SIMULATE
    assert alg.group == "Simulation"
    names = {p.name for p in alg.params}
    assert {"preset", "lines", "seed", "output", "squint_deg", "flying_height", "nominal_altitude",
            "sun_zenith", "sun_azimuth", "targets", "clouds", "merged", "geometry"} <= names  # fmt: skip
    out = tmp_path / "cli"
    res = alg(preset="dunes", lines=16, seed=1, output=str(out), supersample=1, squint_deg=1.0)
    truth = json.loads((out / "truth.json").read_text())
    assert res["offset_along_px"] == pytest.approx(truth["offset_px"]["along"])
    assert truth["squint_deg"] == pytest.approx(1.0)
    with pytest.raises(OutputError):
        alg(preset="dunes", lines=16, seed=1, output=str(out))
    with pytest.raises(ParameterError, match="lines"):
        alg(preset="dunes", lines=2, output=str(tmp_path / "x"))
    with pytest.raises(ParameterError, match="boresight_swir_deg"):
        alg(preset="dunes", lines=16, output=str(tmp_path / "x"), boresight_swir_deg="0,1")
    assert not (tmp_path / "x").exists()


def test_boresight_angles_from_the_spec(tmp_path):
    out = tmp_path / "angles"
    SIMULATE(
        preset="urban", lines=12, seed=1, output=str(out), supersample=1,
        boresight_vnir_deg="0.1,0.2,0", boresight_swir="0.1,1.2,0",  # the former SWIR name
    )  # fmt: skip
    truth = json.loads((out / "truth.json").read_text())
    assert truth["boresight_deg"] == {"vnir": [0.1, 0.2, 0.0], "swir": [0.1, 1.2, 0.0]}
    assert truth["squint_deg"] == pytest.approx(1.0, abs=0.01)
    # tan(1.2°) - tan(0.2°) over 1.5 m lines: the parallax per metre.
    tan = np.tan(np.radians(1.2)) - np.tan(np.radians(0.2))
    assert truth["disparity_px_per_m"]["along"] == pytest.approx(tan / 1.5, rel=1e-6)


def test_bad_parameters_name_the_parameter():
    with pytest.raises(ParameterError, match="preset"):
        simulate_scene("moon", lines=16)
    with pytest.raises(ParameterError, match="geometry"):
        simulate_scene("urban", lines=16, geometry="wide")
    with pytest.raises(ParameterError, match="sun_zenith"):
        simulate_scene("urban", lines=16, sun_zenith=95)


def test_operation_is_the_spec_run(tmp_path):
    """A script calling the file-level function gets the spec's files, and the same refusals."""
    assert SIMULATE.operation is simulate_file
    a, b = tmp_path / "a", tmp_path / "b"
    res = simulate_file(
        output=str(a), preset="dunes", lines=12, seed=2, sensor=gb.SensorOptions(supersample=1)
    )
    SIMULATE(output=str(b), preset="dunes", lines=12, seed=2, supersample=1)
    names = sorted(os.listdir(a))
    assert names == sorted(os.listdir(b)) and set(SCENE_FILES) <= set(names)
    match, mismatch, errors = filecmp.cmpfiles(a, b, names, shallow=False)
    assert mismatch == [] and errors == []
    assert res["output"] == str(a)
    with pytest.raises(OutputError, match="already exists"):
        simulate_file(output=str(a), preset="dunes", lines=12)
    res = simulate_file(output=str(a), preset="dunes", lines=12, seed=3, overwrite=True)
    assert json.loads((a / "truth.json").read_text())["seed"] == 3
    with pytest.raises(ParameterError, match="boresight_vnir_deg"):
        simulate_file(
            output=str(tmp_path / "c"),
            lines=12,
            flight=gb.SimulatedFlight(boresight_vnir_deg="0,20,0"),
        )
    assert not (tmp_path / "c").exists()


SAMPLE = os.path.join(os.path.dirname(__file__), os.pardir, "sample_data", "scene")


@pytest.mark.skipif(
    not os.path.exists(os.path.join(SAMPLE, "truth.json")), reason="no sample scene"
)
@pytest.mark.skipif(
    int(np.__version__.split(".")[0]) < 2,
    reason="the sample was made with NumPy 2 (sample_data/README.md)",
)
def test_sample_scene_regenerates_from_its_recipe(tmp_path):
    """sample_data/README.md's recipe gives the committed files: the ENVI cubes and headers,
    truth.json and endmembers.csv byte for byte, the truth rasters' values and tags, the IGM's
    values and the orthophoto's (JPEG: within a DN of the committed one)."""
    out = tmp_path / "scene"
    simulate_file(
        output=str(out),
        preset="mixed",
        lines=192,
        seed=4,
        flight=gb.SimulatedFlight(geometry="large-squint"),
        clouds=1,
        navigation=True,
    )
    exact = ["vnir.img", "vnir.hdr", "swir.img", "swir.hdr", "truth.json", "endmembers.csv"]
    match, mismatch, errors = filecmp.cmpfiles(SAMPLE, out, exact, shallow=False)
    assert mismatch == [] and errors == [], (mismatch, errors)
    for name in SCENE_FILES:
        if not name.endswith(".tif"):
            continue
        with (
            quiet_georef(),
            rasterio.open(out / name) as a,
            rasterio.open(os.path.join(SAMPLE, name)) as b,
        ):
            assert np.array_equal(a.read(), b.read()), name
            assert a.tags() == b.tags() and a.tags(1) == b.tags(1), name
            assert a.descriptions == b.descriptions and a.nodata == b.nodata, name
    for name in NAVIGATION_FILES:
        with rasterio.open(out / name) as a, rasterio.open(os.path.join(SAMPLE, name)) as b:
            assert a.crs == b.crs and a.transform == b.transform and a.nodata == b.nodata, name
            assert np.array_equal(a.dataset_mask(), b.dataset_mask()), name
            diff = np.abs(a.read().astype("float64") - b.read())
            assert diff.max() == 0 if name == "igm.tif" else diff.mean() < 1.0, name
