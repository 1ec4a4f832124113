"""``qgis_process`` from the command line, as a user or a batch script runs it: the plugin
installed from the zip ``make plugin-zip`` builds, in a throw-away QGIS profile, with QGIS's
own Python (no PYTHONPATH): every run goes through the engine."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import zipfile

import numpy as np
import pytest
import rasterio
from qgis_harness import QGIS_PROCESS, REPO, library_run, require_engine

from geoboresight.algorithms import registry
from geoboresight.io import quiet_georef

pytestmark = pytest.mark.qgis

PLUGIN = "geoboresight_qgis"


@pytest.fixture(scope="module")
def qgis_env(tmp_path_factory, plugin_zip):
    """A fresh profile (a temporary HOME), the plugin from the zip, QGIS's own Python with no
    PYTHONPATH: the library is reached only through the engine."""
    if not os.path.exists(QGIS_PROCESS):
        pytest.skip(f"{QGIS_PROCESS} not found (Debian package qgis)")
    root = tmp_path_factory.mktemp("qgis_process")
    plugins = root / "plugins"
    plugins.mkdir()
    with zipfile.ZipFile(plugin_zip) as z:
        assert all(n.startswith(f"{PLUGIN}/") for n in z.namelist())
        assert f"{PLUGIN}/metadata.txt" in z.namelist()
        z.extractall(plugins)
    home = root / "home"
    home.mkdir()
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}
    env.update(
        HOME=str(home),  # a fresh ~/.local/share/QGIS/QGIS3/profiles/default
        QT_QPA_PLATFORM="offscreen",
        XDG_RUNTIME_DIR=str(root),
        QGIS_PLUGINPATH=str(plugins),
        GEOBORESIGHT_ENGINE=require_engine(),
    )
    enable = _qgis_process(env, "plugins", "enable", PLUGIN)
    assert enable.returncode in (0, 1), enable.stderr  # 1: already enabled
    ini = home / ".local/share/QGIS/QGIS3/profiles/default/QGIS/QGIS3.ini"
    assert f"{PLUGIN}=true" in ini.read_text()
    return env


def _qgis_process(env, *args, timeout=180):
    return subprocess.run(
        [QGIS_PROCESS, *args], env=env, capture_output=True, text=True, timeout=timeout
    )


def _scene(inputs, tmp_path):
    """The bundled sample scene when it is there (copied: QGIS's GDAL rewrites the ENVI files'
    .aux.xml when it opens them), else the tests' small scene."""
    for folder in (REPO / "sample_data" / "scene", REPO / "sample_data"):
        if (folder / "vnir.img").exists() and (folder / "swir.img").exists():
            for name in ("vnir.img", "vnir.hdr", "swir.img", "swir.hdr"):
                shutil.copy(folder / name, tmp_path / name)
            return str(tmp_path / "vnir.img"), str(tmp_path / "swir.img")
    return inputs.scene["vnir"], inputs.scene["swir"]


def test_qgis_process_lists_every_spec(qgis_env):
    listed = _qgis_process(qgis_env, "--json", "list")
    assert listed.returncode == 0, listed.stderr
    providers = json.loads(listed.stdout)["providers"]
    algs = providers["geoboresight"]["algorithms"]
    assert set(algs) == {f"geoboresight:{n}" for n in registry()} | {"geoboresight:setup-engine"}


def test_qgis_process_runs_the_ratio(qgis_env, inputs, tmp_path):
    vnir, swir = _scene(inputs, tmp_path)
    out = tmp_path / "ratio.tif"
    run = _qgis_process(
        qgis_env,
        "--json",
        "run",
        "geoboresight:ratio",
        "--",
        f"vnir={vnir}",
        f"swir={swir}",
        f"output={out}",
    )
    assert run.returncode == 0, run.stderr
    assert out.exists()  # qgis_process exits 0 even when a mandatory parameter is missing
    report = json.loads(run.stdout)
    assert report["results"]["output"] == str(out)
    ref = tmp_path / "ref.tif"
    lib = library_run("ratio", {"vnir": vnir, "swir": swir, "output": str(ref)})
    assert report["results"]["swir_band"] == lib["swir_band"]
    assert report["results"]["valid_pixels"] == lib["valid_pixels"]
    with quiet_georef(), rasterio.open(out) as a, rasterio.open(ref) as b:
        np.testing.assert_array_equal(a.read(), b.read())
        assert (a.crs, a.transform) == (b.crs, b.transform)
    assert (tmp_path / "ratio.qml").exists()  # the ramp style QGIS will open it with
    assert any("boresight ratio" in m for m in report["log"]["info"])


def test_qgis_process_reports_a_bad_band(qgis_env, inputs, tmp_path):
    out = tmp_path / "stats.json"
    run = _qgis_process(
        qgis_env,
        "run",
        "geoboresight:stats",
        "--",
        f"input={inputs.ratio}",
        "band=3",
        f"output={out}",
    )
    assert run.returncode == 1
    assert "band 3 does not exist" in run.stdout + run.stderr
    assert not out.exists()


# Outputs where two GDALs in one process used to be the risk (a colour table, vector layers):
# now written by the engine alone, compared with the library's.
MIXED_GDAL = (
    "shadow-classes",
    "anomaly-polygons",
    "shadow-polygons",
)


@pytest.mark.parametrize("name", MIXED_GDAL)
def test_qgis_process_matches_the_library(name, qgis_env, inputs, tmp_path):
    from qgis_cases import to_qgis, values_for
    from qgis_compare import assert_same_file

    spec = registry().get(name)
    if spec is None:
        pytest.skip(f"{name} is not in this version's registry")
    q_dir, l_dir = tmp_path / "q", tmp_path / "l"
    q_dir.mkdir()
    l_dir.mkdir()
    q_values = values_for(spec, inputs, str(q_dir))
    args = [f"{k}={v}" for k, v in to_qgis(spec, q_values).items() if v is not None]
    run = _qgis_process(qgis_env, "--json", "run", f"geoboresight:{name}", "--", *args)
    assert run.returncode == 0, run.stderr[-3000:]
    l_values = values_for(spec, inputs, str(l_dir))
    library_run(name, l_values)
    for p in spec.outputs:
        assert_same_file(q_values[p.name], l_values[p.name], str(q_dir), str(l_dir))
