"""``qgis_process`` from the command line, as a user or a batch script runs it: the plugin
installed from the zip ``make plugin-zip`` builds, in a throw-away QGIS profile."""

from __future__ import annotations

import json
import os
import shutil
import site
import subprocess
import zipfile

import numpy as np
import pytest
import rasterio
from qgis_harness import PLUGIN_DIR, REPO

import geoboresight
from geoboresight.algorithms import registry
from geoboresight.io import quiet_georef

pytestmark = pytest.mark.qgis

QGIS_PROCESS = "/usr/bin/qgis_process.bin"  # /usr/bin/qgis_process is a broken wrapper on Debian
PLUGIN = "geoboresight_qgis"


@pytest.fixture(scope="module")
def qgis_env(tmp_path_factory):
    if not os.path.exists(QGIS_PROCESS):
        pytest.skip(f"{QGIS_PROCESS} not found (Debian package qgis)")
    root = tmp_path_factory.mktemp("qgis_process")
    plugins = root / "plugins"
    plugins.mkdir()
    zip_path = root / "geoboresight-plugin.zip"
    if shutil.which("make"):
        subprocess.run(
            ["make", "-s", "-C", str(REPO), "plugin-zip", f"PLUGIN_ZIP={zip_path}"],
            check=True,
            capture_output=True,
            timeout=60,
        )
        with zipfile.ZipFile(zip_path) as z:
            assert all(n.startswith(f"{PLUGIN}/") for n in z.namelist())
            assert f"{PLUGIN}/metadata.txt" in z.namelist()
            z.extractall(plugins)
    else:  # no make: install the folder the zip would contain
        shutil.copytree(PLUGIN_DIR, plugins / PLUGIN, ignore=shutil.ignore_patterns("__pycache__"))

    # qgis_process ignores venvs: the library comes through PYTHONPATH. An editable install
    # lives in the source tree (its .pth hook is not read from PYTHONPATH), so add that too.
    paths = [p for p in site.getsitepackages() if "site-packages" in p]
    lib_root = os.path.dirname(os.path.dirname(os.path.abspath(geoboresight.__file__)))
    if not any(lib_root.startswith(p) for p in paths):
        paths.append(lib_root)
    env = dict(
        os.environ,
        QT_QPA_PLATFORM="offscreen",
        XDG_RUNTIME_DIR=str(root),
        QGIS_CUSTOM_CONFIG_PATH=str(root / "profile"),  # not the user's ~/.local profile
        QGIS_PLUGINPATH=str(plugins),
        PYTHONPATH=os.pathsep.join(paths),
    )
    enable = _qgis_process(env, "plugins", "enable", PLUGIN)
    assert enable.returncode in (0, 1), enable.stderr  # 1: already enabled
    ini = root / "profile" / "profiles" / "default" / "QGIS" / "QGIS3.ini"
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
    assert set(algs) == {f"geoboresight:{n}" for n in registry()}


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
    lib = registry()["ratio"](vnir=vnir, swir=swir, output=str(ref))
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


# Inside qgis_process, Debian's GDAL is loaded before the wheels' own GDALs (as in the desktop
# application): a colour table written through rasterio and vector layers are the places where
# two GDALs in one process could disagree. Vectors are written without OGR (io.vector) since
# the pyogrio wheel's GDAL next to Debian's aborted qgis_process ("double free or corruption").
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
    registry()[name](**l_values)
    for p in spec.outputs:
        assert_same_file(q_values[p.name], l_values[p.name], str(q_dir), str(l_dir))
