"""A new user's first run of the real QGIS desktop under Xvfb: a fresh profile (temporary
HOME and --profiles-path), QGIS's own Python with no geoboresight and no PYTHONPATH.

In one QGIS process (desktop_script.py): install the zip as *Install from ZIP* does; the tools
are listed at once (the operation list shipped in the zip) and running one without an engine
says how to set it up; the newcomer's path: "Set up the geoboresight engine" with no field
filled (the zip's wheel, its dependencies from the package index, or from the wheelhouse in
$GEOBORESIGHT_WHEELHOUSE when set, e.g. CI's `make wheelhouse`), then *Plugins ▸ geoboresight
▸ Open the sample scene*: the sample scene's products on its orthophoto, their layer names,
a map canvas that is not blank; then, with the project's engine, every operation through ``processing.run``, compared
here with the library's own outputs; the ratio dialog opens with its help, runs, and adds its
layer styled; a screenshot that is not blank; and after all that, none of geoboresight,
rasterio, shapely, pyproj, scikit-learn or matplotlib in QGIS's ``sys.modules`` and only the
system's libgdal in ``/proc/self/maps``.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess

import pytest
from qgis_cases import to_qgis, values_for
from qgis_compare import assert_same_file, same_value
from qgis_harness import FORBIDDEN_MODULES, library_run, require_engine

from geoboresight.algorithms import registry

pytestmark = pytest.mark.qgis

HERE = os.path.dirname(os.path.abspath(__file__))


@pytest.fixture(scope="module")
def desktop(tmp_path_factory, inputs, plugin_zip):
    """Run the whole desktop script once; the report and the folders of both runs."""
    for tool in ("qgis", "xvfb-run"):
        if not shutil.which(tool):
            pytest.skip(f"{tool} not found (apt packages qgis, xvfb)")
    root = tmp_path_factory.mktemp("desktop")
    zip_path = plugin_zip
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
        "tour_shot": str(root / "tour.png"),
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
        timeout=2400,
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


def test_the_newcomers_path_setup_then_the_sample_scene_on_its_map(desktop):
    """No field filled in the setup tool, then the tour; figures in docs/qgis.md."""
    report, *_ = desktop
    setup = report["setup"]
    assert setup["ok"], (setup.get("error"), setup["log"][-20:])
    log = "\n".join(setup["log"])
    assert "installing the geoboresight wheel that came with the plugin" in log or (
        os.environ.get("GEOBORESIGHT_WHEELHOUSE") and "installing offline from the wheels" in log
    ), log[-3000:]
    assert "Successfully installed" in log
    assert re.search(r"engine: \d+ MB on disk", log), log[-2000:]
    assert float(setup["result"]["SIZE_MB"]) > 50
    texts = setup["progress_texts"]  # pip's stages, n of m where known
    assert any(t.startswith("pip: collecting package") for t in texts), texts[:20]
    assert any(re.match(r"pip: installing \d+ packages", t) for t in texts), texts
    assert any(re.match(r"pip: installed \d+ of \d+ packages", t) for t in texts), texts
    assert setup["toolbox_expanded"], "the setup collapsed the Processing Toolbox"
    print(f"setup: {setup['seconds']:.0f} s, {setup['result']['SIZE_MB']} MB")
    assert "Open the sample scene" in " ".join(report["menu"])
    tour = report["tour"]
    assert tour["error"] in (None, ""), tour["error"]
    names = [lay["name"] for lay in tour["layers"]]
    assert sorted(names) == [
        "boresight ratio",
        "orthophoto",
        "relative DEM",
        "shadow classes",
    ], names
    # The products lie on the orthophoto: each one's extent inside the orthophoto's.
    ortho = next(lay for lay in tour["layers"] if lay["name"] == "orthophoto")["extent"]
    for lay in tour["layers"]:
        x0, y0, x1, y1 = lay["extent"]
        assert x0 >= ortho[0] - 3 and y0 >= ortho[1] - 3, (lay["name"], lay["extent"], ortho)
        assert x1 <= ortho[2] + 3 and y1 <= ortho[3] + 3, (lay["name"], lay["extent"], ortho)
    crs = {lay["crs"] for lay in tour["layers"]}
    assert len(crs) == 1 and crs.pop().startswith("EPSG:326"), tour["layers"]
    assert tour["project_crs"] == tour["layers"][0]["crs"]
    shadow = next(lay for lay in tour["layers"] if lay["name"] == "shadow classes")
    background = [c for c in shadow["classes"] if c[0] == 0]
    assert background and background[0][2] == 0, shadow["classes"]  # "no shadow" transparent
    labels = [c[1] for c in shadow["classes"]]
    assert all("(" not in label for label in labels), labels  # one name per class
    ratio = next(lay for lay in tour["layers"] if lay["name"] == "boresight ratio")
    assert ratio["renderer"] == "singlebandpseudocolor"
    assert tour["canvas_colours"] > 20, tour  # the overlay is drawn: not a blank canvas
    print(f"tour: {tour['seconds']:.0f} s")


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
    """The class raster's named categories, from the PAM sidecar the library writes (read
    here with the standard library: independent of the plugin and of GDAL)."""
    import xml.etree.ElementTree as ET

    sidecar = path + ".aux.xml"
    if not os.path.exists(sidecar):
        return []
    root = ET.parse(sidecar).getroot()
    names = [
        c.text or "" for c in root.findall(".//PAMRasterBand[@band='1']/CategoryNames/Category")
    ]
    return [n for n in names if n.strip()]
