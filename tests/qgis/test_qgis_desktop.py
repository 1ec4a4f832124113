"""A new user's first session, in the real QGIS desktop under Xvfb: a fresh profile (temporary
HOME and --profiles-path), QGIS's own Python with no geoboresight and no PYTHONPATH.

In one QGIS process (desktop_script.py): install the zip as *Install from ZIP* does; the tools
are listed at once (the operation list shipped in the zip) and running one without an engine
says how to set it up; with the engine, every operation through ``processing.run``, compared
here with the library's own outputs; the ratio dialog opens with its help, runs, and adds its
layer styled; a screenshot that is not blank; and after all that, none of geoboresight,
rasterio, shapely, pyproj, scikit-learn or matplotlib in QGIS's ``sys.modules`` and only the
system's libgdal in ``/proc/self/maps``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest
from qgis_cases import to_qgis, values_for
from qgis_compare import assert_same_file, same_value
from qgis_harness import FORBIDDEN_MODULES, REPO, library_run, require_engine

from geoboresight.algorithms import registry

pytestmark = pytest.mark.qgis

HERE = os.path.dirname(os.path.abspath(__file__))


@pytest.fixture(scope="module")
def desktop(tmp_path_factory, inputs):
    """Run the whole session once; the report and the folders of both runs."""
    for tool in ("qgis", "xvfb-run"):
        if not shutil.which(tool):
            pytest.skip(f"{tool} not found (apt packages qgis, xvfb)")
    root = tmp_path_factory.mktemp("desktop")
    zip_path = root / "geoboresight-plugin.zip"
    subprocess.run(
        ["make", "-s", "-C", str(REPO), "plugin-zip", f"PLUGIN_ZIP={zip_path}"],
        check=True,
        capture_output=True,
        timeout=600,
    )
    q_root, l_root = root / "qgis", root / "lib"
    cases, lib_values, no_case = {}, {}, {}
    for name, spec in registry().items():
        (q_root / name).mkdir(parents=True)
        (l_root / name).mkdir(parents=True)
        try:
            cases[name] = to_qgis(spec, values_for(spec, inputs, str(q_root / name)))
            lib_values[name] = values_for(spec, inputs, str(l_root / name))
        except LookupError as exc:  # that operation's test fails with the message
            no_case[name] = str(exc)
    scene = inputs.scene
    job = {
        "zip": str(zip_path),
        "engine": require_engine(),
        "cases": cases,
        "dialog_params": {
            "vnir": os.path.splitext(scene["vnir"])[0] + ".hdr",  # as a user picks it
            "swir": scene["swir"],
            "output": "TEMPORARY_OUTPUT",
        },
        "forbidden": list(FORBIDDEN_MODULES) + ["sklearn"],
        "report": str(root / "report.json"),
        "screenshot": str(root / "screen.png"),
        "dialog_shot": str(root / "dialog.png"),
        "canvas_shot": str(root / "canvas.png"),
    }
    (root / "job.json").write_text(json.dumps(job))
    home = root / "home"
    home.mkdir()
    env = {
        k: v
        for k, v in os.environ.items()
        if k not in ("PYTHONPATH", "VIRTUAL_ENV", "QT_QPA_PLATFORM", "GEOBORESIGHT_ENGINE")
    }
    env.update(HOME=str(home), GB_DESKTOP_JOB=str(root / "job.json"), XDG_RUNTIME_DIR=str(root))
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
            os.path.join(HERE, "desktop_script.py"),
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=1200,
    )
    report_path = root / "report.json"
    assert report_path.exists(), (run.returncode, run.stderr[-3000:])
    report = json.loads(report_path.read_text())
    assert "crash" not in report, report["crash"]
    report["no_case"] = no_case
    return report, job, lib_values, q_root, l_root


def test_install_from_zip_lists_the_tools_at_once(desktop):
    report, *_ = desktop
    assert report["before_install"] is None  # a fresh profile: no provider yet
    assert report["plugin_loaded"]
    expected = sorted([*registry(), "setup-engine"])
    assert report["listed_without_engine"] == expected  # from the zip's operations.json
    assert report["listed_with_engine"] == expected
    text = report["no_engine_error"]
    assert text and "not set up yet" in text and "Set up the geoboresight engine" in text


@pytest.mark.parametrize("name", list(registry()))
def test_every_operation_in_the_desktop_matches_the_library(desktop, name):
    report, job, lib_values, q_root, l_root = desktop
    assert name not in report["no_case"], report["no_case"].get(name)
    run = report["runs"][name]
    assert run["ok"], run.get("error")
    q_dir, l_dir = str(q_root / name), str(l_root / name)
    lib = library_run(name, lib_values[name])
    spec = registry()[name]
    for p in spec.outputs:
        if p.name in lib:
            assert_same_file(job["cases"][name][p.name], lib_values[name][p.name], q_dir, l_dir)
    for p in spec.outputs:  # outputs open styled: a ramp, or only the named classes
        info = run["rasters"].get(p.name)
        if info is None or info["bands"] != 1:
            continue
        if info["renderer"] == "paletted":
            classes = _category_names(lib_values[name][p.name])
            assert classes and info["classes"] == classes, (p.name, info["classes"], classes)
        else:
            assert info["renderer"] == "singlebandpseudocolor", (p.name, info)
    params = {p.name for p in spec.params}
    for key, value in lib.items():
        if key in {p.name for p in spec.outputs}:
            continue
        # Scalar results are declared outputs a model can chain; only results named after the
        # inputs (ROC's auc_<name>, pd_at_pfa_<name>) or like a parameter are not.
        if key not in params and not key.startswith(("auc_", "pd_at")):
            kind = run["declared"].get(key)
            if isinstance(value, bool):
                assert kind == "outputBoolean", (key, kind)
            elif isinstance(value, int | float):
                assert kind == "outputNumber", (key, kind)
            else:
                assert kind == "outputString", (key, kind)
        got = run["result"].get(key)
        if isinstance(got, str) and isinstance(value, list | dict):
            got = json.loads(got)  # lists and tables reach QGIS as JSON text
        if isinstance(value, str):
            value = value.replace(l_dir, q_dir)
        assert same_value(got, value), (key, got, value)
        assert any(key in m for m in run["infos"]), f"result {key} not shown in the log"


def _category_names(path):
    """The class raster's named categories, read with GDAL (independent of the plugin)."""
    from osgeo import gdal

    names = gdal.Open(path).GetRasterBand(1).GetCategoryNames() or []
    return [n for n in names if n.strip()]


def test_qgis_process_never_loads_the_library_or_its_wheels(desktop):
    report, *_ = desktop
    assert report["steps"][-1] == "done"
    loaded = [m for m in report["modules"] if m.split(".")[0] != "numpy"]
    assert loaded == [], loaded
    libs = report["gdal_libraries"]
    assert len(libs) == 1 and libs[0].startswith("/usr/lib/"), libs  # the system's GDAL alone


def test_ratio_dialog_help_run_and_styled_layer(desktop, inputs):
    report, job, *_ = desktop
    spec = registry()["ratio"]
    assert spec.short_help in report["dialog_help"], report["dialog_help"][:500]
    layers = report["dialog_layers"]
    assert len(layers) == 1, (layers, report.get("dialog_log"))
    layer = layers[0]
    assert layer["renderer"] == "singlebandpseudocolor"
    stem = os.path.splitext(os.path.basename(inputs.scene["vnir"]))[0]
    assert layer["name"] == f"{spec.display_name} ({stem})", layer  # output and input


@pytest.mark.parametrize("shot", ["screenshot", "dialog_shot", "canvas_shot"])
def test_screenshots_are_not_blank(desktop, shot):
    import matplotlib.image as mpimg

    report, job, *_ = desktop
    image = mpimg.imread(job[shot])[..., :3]
    assert image.shape[0] > 300 and image.shape[1] > 500, image.shape
    colours = np.unique((image.reshape(-1, 3) * 255).astype(np.uint8), axis=0)
    assert len(colours) > 50, len(colours)  # widgets, text and a rendered raster, not one fill
    assert float(image.std()) > 0.05


if __name__ == "__main__":  # pragma: no cover
    sys.exit(pytest.main([__file__, "-q"]))
