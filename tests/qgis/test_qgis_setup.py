"""The "Set up the geoboresight engine" tool in real QGIS (QGIS's own Python, a fresh profile,
no PYTHONPATH): it makes a venv under the profile with a Python >= 3.11, installs the library's
wheel given to it (the one the plugin zip carries; its dependencies from the package index:
this test needs the network), checks the version, and the plugin then finds that engine by
itself and runs with it. Each failure it can report (old Python, no venv module, missing
wheel, no network) says what to do.
"""

from __future__ import annotations

import glob
import json
import os
import subprocess
import zipfile

import numpy as np
import pytest
import rasterio
from qgis_harness import FORBIDDEN_MODULES, PLUGIN_NAME, fake_engine, library_run

import geoboresight
from geoboresight.io import quiet_georef

pytestmark = pytest.mark.qgis
HERE = os.path.dirname(os.path.abspath(__file__))


@pytest.fixture(scope="module")
def setup_run(tmp_path_factory, inputs, plugin_zip):
    root = tmp_path_factory.mktemp("setup")
    zip_path = plugin_zip
    # The library's wheel the zip carries (what `make dist` builds), given as a user gives one.
    with zipfile.ZipFile(zip_path) as z:
        inside = [n for n in z.namelist() if n.startswith(f"{PLUGIN_NAME}/wheels/")]
        z.extractall(root / "zip", inside)
    wheels = glob.glob(
        str(root / "zip" / "*" / "wheels" / f"geoboresight-{geoboresight.__version__}-*.whl")
    )
    assert len(wheels) == 1, wheels
    old = fake_engine(
        root,
        "python3.9",
        'print(json.dumps({"version": [3, 9, 2], "venv": True, "executable": "x"}))\n',
    )
    no_venv = fake_engine(
        root,
        "python3.12",
        'print(json.dumps({"version": [3, 12, 1], "venv": False, "executable": "x"}))\n',
    )
    job = {
        "zip": str(zip_path),
        "plugins": str(root / "plugins"),
        "profile": str(root / "profile"),
        "wheel": wheels[0],
        "report": str(root / "report.json"),
        "forbidden": list(FORBIDDEN_MODULES) + ["sklearn"],
        "ratio": {
            "vnir": inputs.scene["vnir"],
            "swir": inputs.scene["swir"],
            "output": str(root / "ratio.tif"),
        },
        "failures": {
            "old_python": {"PYTHON": old},
            "no_venv": {"PYTHON": no_venv},
            "missing_wheel": {"PACKAGE": str(root / "nowhere.whl")},
            "no_network": {
                "PIP_OPTIONS": "--isolated --index-url http://127.0.0.1:9/simple --retries 1 --timeout 3"
            },
        },
    }
    (root / "job.json").write_text(json.dumps(job))
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "VIRTUAL_ENV", "GEOBORESIGHT_ENGINE")
    }
    env.update(
        HOME=str(root / "home"),
        GB_SETUP_JOB=str(root / "job.json"),
        QT_QPA_PLATFORM="offscreen",
        XDG_RUNTIME_DIR=str(root),
    )
    done = subprocess.run(
        ["/usr/bin/python3", os.path.join(HERE, "setup_script.py")],
        env=env,
        capture_output=True,
        text=True,
        timeout=1800,
    )
    report = json.loads((root / "report.json").read_text())
    assert "crash" not in report, report["crash"] + done.stderr[-2000:]
    return report, job


def test_setup_installs_the_wheel_and_the_plugin_finds_the_engine(setup_run):
    report, job = setup_run
    setup = report["setup"]
    assert setup["ok"], setup.get("error")
    venv = os.path.join(report["settings_dir"], "geoboresight", "engine")
    assert setup["result"]["ENGINE"] == os.path.join(venv, "bin", "geoboresight")
    assert setup["result"]["VERSION"] == geoboresight.__version__
    log = "\n".join(setup["log"])
    assert "Successfully installed" in log and "geoboresight" in log  # pip's own output shown
    assert "Python 3." in log
    # auto-detected: no environment variable, no option
    assert report["engine_after"] == setup["result"]["ENGINE"]
    assert report["engine_source"] == "the engine set up by the plugin"
    assert "ratio" in report["listed"] and "setup-engine" in report["listed"]


def test_the_set_up_engine_runs_like_the_library(setup_run, tmp_path):
    report, job = setup_run
    assert report["ratio"]["ok"], report["ratio"].get("error")
    ref = str(tmp_path / "ref.tif")
    lib = library_run("ratio", {**job["ratio"], "output": ref})
    assert report["ratio"]["result"]["valid_pixels"] == str(lib["valid_pixels"])
    with quiet_georef(), rasterio.open(job["ratio"]["output"]) as a, rasterio.open(ref) as b:
        np.testing.assert_array_equal(a.read(), b.read())
    assert report["modules"] == []  # QGIS's Python still never imported the library


def test_setup_failures_say_what_to_do(setup_run):
    report, _ = setup_run
    old = report["old_python"]
    assert not old["ok"] and "no Python 3.11 or later found" in old["error"], old
    assert "3.9.2" in old["error"] and "apt install python3 python3-venv" in old["error"]
    no_venv = report["no_venv"]
    assert not no_venv["ok"] and "python3-venv" in no_venv["error"], no_venv
    missing = report["missing_wheel"]
    assert not missing["ok"] and "nowhere.whl does not exist" in missing["error"], missing
    offline = report["no_network"]
    assert not offline["ok"] and "could not reach the package index" in offline["error"], offline
    assert "--find-links" in offline["error"]
    for case in ("old_python", "no_venv", "missing_wheel", "no_network"):
        assert "Traceback" not in report[case]["error"], report[case]["error"]
