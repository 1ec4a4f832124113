"""The plugin repository and the dialogs, in the real QGIS desktop under Xvfb (a fresh
profile, QGIS's own Python, no PYTHONPATH; repository_script.py runs inside QGIS).

``make plugin-repo`` writes plugins.xml beside the zip; QGIS's plugin manager, given its file://
URL as a user adds a repository, fetches it, lists the plugin with its version, installs it and
the provider's tools appear. Then every algorithm's dialog, at 1,000 × 700 pixels with its
advanced parameters expanded, shows its parameters without scrolling sideways, every browse
button inside the visible area: the fields' labels are a few words (the sentence is in the help
pane), as QGIS names its own parameters.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import xml.etree.ElementTree as ET

import pytest
from qgis_harness import PLUGIN_NAME, REPO, require_engine

from geoboresight import __version__
from geoboresight.algorithms import registry

pytestmark = pytest.mark.qgis

HERE = os.path.dirname(os.path.abspath(__file__))


@pytest.fixture(scope="module")
def qgis_run(tmp_path_factory, plugin_zip):
    for tool in ("qgis", "xvfb-run"):
        if not shutil.which(tool):
            pytest.skip(f"{tool} not found (apt packages qgis, xvfb)")
    root = tmp_path_factory.mktemp("repository")
    repo = root / "repo"
    subprocess.run(
        [
            "make",
            "-s",
            "-C",
            str(REPO),
            "-o",  # the zip is the session's, built by `make plugin-zip` (tests/qgis/conftest.py)
            "plugin-zip",
            "plugin-repo",
            f"PLUGIN_ZIP={plugin_zip}",
            f"PLUGIN_REPO={repo}",
        ],
        check=True,
        capture_output=True,
        timeout=600,
    )
    (root / "shots").mkdir()
    job = {
        "repository_url": (repo / "plugins.xml").as_uri(),
        "plugin_id": PLUGIN_NAME,
        "engine": require_engine(),
        "report": str(root / "report.json"),
        "shots": str(root / "shots"),
    }
    (root / "job.json").write_text(json.dumps(job))
    home = root / "home"
    home.mkdir()
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "VIRTUAL_ENV", "QT_QPA_PLATFORM", "GEOBORESIGHT_ENGINE")
    }
    env.update(HOME=str(home), GB_REPO_JOB=str(root / "job.json"), XDG_RUNTIME_DIR=str(root))
    run = subprocess.run(
        [
            "xvfb-run",
            "-a",
            "-s",
            "-screen 0 1600x1000x24",
            "qgis",
            "--profiles-path",
            str(root / "profiles"),
            "--nologo",
            "--noversioncheck",
            "--code",
            os.path.join(HERE, "repository_script.py"),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    report_path = root / "report.json"
    assert report_path.exists(), (run.returncode, run.stderr[-3000:])
    report = json.loads(report_path.read_text())
    assert "crash" not in report, report["crash"]
    return report, repo


def test_plugins_xml_is_the_plugin_managers_format(qgis_run):
    _, repo = qgis_run
    root = ET.parse(repo / "plugins.xml").getroot()
    (node,) = root.findall("pyqgis_plugin")
    assert node.get("version") == __version__
    assert node.findtext("file_name") == f"{PLUGIN_NAME}.{__version__}.zip"
    assert (repo / node.findtext("file_name")).is_file()
    assert node.findtext("qgis_minimum_version") == "3.22"
    assert node.findtext("download_url").endswith(node.findtext("file_name"))


def test_qgis_installs_the_plugin_from_the_repository(qgis_run):
    report, _ = qgis_run
    assert report["repository"]["state"] == 2, report["repository"]  # Repositories.STATE_LOADED
    assert not report.get("message_boxes"), report["message_boxes"]
    available = report["available"]
    assert available and available["version_available"] == __version__, available
    assert available["zip_repository"] == "geoboresight"
    assert report["installed"] == __version__, report
    assert report["loaded"], report
    assert os.path.isfile(os.path.join(report["installed_path"], "metadata.txt"))
    assert report["tools"] == sorted([*registry(), "setup-engine"])


@pytest.mark.parametrize("name", list(registry()))
def test_the_dialog_fits_its_window(qgis_run, name):
    report, _ = qgis_run
    d = report["dialogs"][name]
    assert "error" not in d, d
    assert d["collapsed"] == [], d  # advanced parameters shown too
    where = f"{name}: {d['shot']}"
    assert not d["horizontal_bar_visible"] and d["horizontal_range"] == 0, (where, d)
    assert d["content_width"] <= d["viewport_width"], (where, d)
    for b in d["browse_buttons"]:
        assert 0 < b["right"] <= d["viewport_width"], (where, b)
    if registry()[name].inputs[0].kind in ("raster", "multiraster", "file"):
        assert d["browse_buttons"], (where, "no browse button found")
