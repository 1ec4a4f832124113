"""The engine's machine mode (``geoboresight engine ...``), as the QGIS plugin speaks it: the
operation list matches the specs, a run is JSON lines ending in a result or a one-line error,
SIGTERM cancels and leaves nothing, and the declared results match what operations return."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys

import numpy as np
import pytest
import rasterio

from geoboresight import __version__
from geoboresight.algorithms import registry
from geoboresight.engine import COMMON_RESULTS, PROTOCOL
from geoboresight.io import quiet_georef, write_envi

ENGINE = [sys.executable, "-m", "geoboresight.cli", "engine"]


def _engine(*args, **kw):
    return subprocess.run([*ENGINE, *args], capture_output=True, text=True, timeout=300, **kw)


def _lines(stdout: str) -> list[dict]:
    return [json.loads(line) for line in stdout.splitlines() if line.strip()]


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    folder = tmp_path_factory.mktemp("engine")
    rng = np.random.default_rng(5)
    shape = (64, 24)
    vnir = rng.integers(200, 4000, (6, *shape)).astype("uint16")
    swir = rng.integers(200, 4000, (6, *shape)).astype("uint16")
    return (
        write_envi(str(folder / "vnir.img"), vnir, np.linspace(870.0, 970.0, 6)),
        write_envi(str(folder / "swir.img"), swir, 980.0 + 30.0 * np.arange(6)),
    )


def test_version_is_json_and_light():
    done = _engine("version")
    assert done.returncode == 0, done.stderr
    info = json.loads(done.stdout)
    assert info["version"] == __version__ and info["protocol"] == PROTOCOL
    assert info["engine"] == "geoboresight"


def test_describe_lists_every_spec_with_its_parameters():
    done = _engine("describe")
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    assert doc["version"] == __version__ and doc["protocol"] == PROTOCOL
    algs = {a["name"]: a for a in doc["algorithms"]}
    assert list(algs) == list(registry())  # same order: by group, then name
    for name, spec in registry().items():
        a = algs[name]
        assert (a["display_name"], a["group"], a["help"]) == (
            spec.display_name,
            spec.group,
            spec.help,
        )
        assert [p["name"] for p in a["params"]] == [p.name for p in spec.params]
        for p, q in zip(spec.params, a["params"], strict=True):
            assert q["kind"] == p.kind and q["required"] == p.required
            assert q["advanced"] == p.advanced and q["is_output"] == p.is_output
            for attr in ("minimum", "maximum", "unit", "integer", "raster", "extension"):
                if hasattr(p, attr):
                    assert q[attr] == getattr(p, attr), (name, p.name, attr)
            if hasattr(p, "choices"):
                assert q["choices"] == list(p.choices)
        assert {g["id"] for g in doc["groups"]} >= {a["group_id"]}
        declared = [r["name"] for r in a["results"]]
        assert declared == [r.name for r in registry()[name].results] + [
            r[0] for r in COMMON_RESULTS
        ]


def test_declared_results_have_types_and_are_not_files():
    for name, alg in registry().items():
        outputs = {p.name for p in alg.outputs}
        for key, kind, description in alg.results:
            assert kind in ("number", "string", "boolean") and description
            assert key not in outputs, (name, key)  # files are declared by their parameter


def test_run_speaks_json_lines_and_matches_the_library(pair, tmp_path):
    vnir, swir = pair
    params = tmp_path / "p.json"
    out = tmp_path / "ratio.tif"
    params.write_text(
        json.dumps({"vnir": vnir, "swir": swir, "block_rows": 16, "output": str(out)})
    )
    done = _engine("run", "ratio", "--params-json", str(params))
    assert done.returncode == 0, done.stderr
    lines = _lines(done.stdout)  # every stdout line is one JSON object
    assert lines[0]["engine"]["version"] == __version__ and lines[0]["engine"]["pid"] > 0
    progress = [m["progress"] for m in lines if "progress" in m]
    assert (
        progress == sorted(progress) and progress[-1] == pytest.approx(1.0) and len(progress) == 4
    )
    assert any("boresight ratio" in m.get("info", "") for m in lines)
    result = lines[-1]["result"]
    ref = tmp_path / "ref.tif"
    lib = registry()["ratio"](vnir=vnir, swir=swir, output=str(ref))
    assert result == {**lib, "output": str(out)}
    with quiet_georef(), rasterio.open(out) as a, rasterio.open(ref) as b:
        np.testing.assert_array_equal(a.read(), b.read())


def test_user_error_is_one_line_and_exit_1(pair, tmp_path):
    vnir, swir = pair
    out = tmp_path / "r.tif"
    done = _engine(
        "run",
        "ratio",
        "--params-json",
        "-",
        input=json.dumps({"vnir": vnir, "swir": swir, "swir_nm": 5000, "output": str(out)}),
    )
    assert done.returncode == 1
    last = _lines(done.stdout)[-1]
    # Named as the QGIS dialog labels the field, not swir_nm.
    assert set(last) == {"error"} and "'SWIR wavelength (nm)'" in last["error"]
    assert "\n" not in last["error"]
    assert not out.exists()
    bad = _engine("run", "no-such-operation", "--params-json", "-", input="{}")
    assert bad.returncode == 1 and "unknown operation" in _lines(bad.stdout)[-1]["error"]
    junk = _engine("run", "ratio", "--params-json", "-", input="[1, 2")
    assert junk.returncode == 1 and "not valid JSON" in _lines(junk.stdout)[-1]["error"]


def test_sigterm_cancels_and_leaves_nothing(tmp_path):
    """What QGIS's cancel sends: the operation stops, removes its output, says so, exit 3."""
    rng = np.random.default_rng(2)
    shape = (4000, 64)
    vnir = write_envi(
        str(tmp_path / "v.img"),
        rng.integers(1, 4000, (6, *shape)).astype("uint16"),
        np.linspace(870.0, 970.0, 6),
    )
    swir = write_envi(
        str(tmp_path / "s.img"),
        rng.integers(1, 4000, (6, *shape)).astype("uint16"),
        980.0 + 30.0 * np.arange(6),
    )
    out = tmp_path / "out" / "ratio.tif"
    out.parent.mkdir()
    params = tmp_path / "p.json"
    params.write_text(json.dumps({"vnir": vnir, "swir": swir, "block_rows": 1, "output": str(out)}))
    proc = subprocess.Popen(
        [*ENGINE, "run", "ratio", "--params-json", str(params)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    seen = []
    for line in proc.stdout:  # wait until the block loop runs
        seen.append(json.loads(line))
        if "progress" in seen[-1] and seen[-1]["progress"] > 0.01:
            break
    proc.send_signal(signal.SIGTERM)
    rest, _ = proc.communicate(timeout=60)
    assert proc.returncode == 3
    last = _lines(rest)[-1]
    assert last == {"error": "cancelled by the user: no output was written"}
    assert os.listdir(out.parent) == []  # neither the output nor the writer's temporary file


def test_engine_imports_stay_lazy():
    """`engine version` (what the plugin calls at QGIS start) loads no NumPy or GDAL."""
    code = "import sys; from geoboresight.cli import main; sys.argv=['g','engine','version']\n"
    code += "try:\n    main()\nexcept SystemExit:\n    pass\n"
    code += "print(sorted(m for m in ('numpy','rasterio','scipy','sklearn','matplotlib') if m in sys.modules))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip().splitlines()[-1] == "[]", done.stdout + done.stderr


def test_sigterm_after_the_run_finished_reports_the_result(pair, tmp_path):
    """A cancel that reaches the engine once the operation has returned (its outputs in place)
    is too late: the engine reports the result and exits 0, and the plugin says the cancel
    came late instead of claiming that nothing was written."""
    vnir, swir = pair
    out = tmp_path / "r.tif"
    params = tmp_path / "p.json"
    params.write_text(json.dumps({"vnir": vnir, "swir": swir, "output": str(out)}))
    code = (
        "import os, signal, sys\n"
        "from geoboresight import engine\n"
        "plain = engine._plain\n"
        "def late(result):  # the SIGTERM arrives as the result is about to be reported\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    return plain(result)\n"
        "engine._plain = late\n"
        "sys.exit(engine.run('ratio', sys.argv[1]))\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code, str(params)], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stdout + done.stderr
    last = _lines(done.stdout)[-1]
    assert last["result"]["output"] == str(out) and out.exists()


@pytest.fixture(scope="module")
def face_inputs(tmp_path_factory):
    from hostile import make_face_inputs

    return make_face_inputs(tmp_path_factory.mktemp("engine-faces") / "in")


def _face_case_ids():
    from hostile import FACE_CASES

    return [pytest.param(c, id=c.id) for c in FACE_CASES]


@pytest.mark.parametrize("case", _face_case_ids())
def test_the_hostile_cases_in_the_engine(case, face_inputs, tmp_path):
    """hostile.FACE_CASES as QGIS meets them: a result with the warning of an accepted
    repeat, or one error line naming the file and the field by its QGIS label (never the
    command line's --vnir-dark); no raw library warning on stderr; never exit 2 (a bug)."""
    from hostile import face_values

    values = face_values(case, face_inputs, tmp_path)
    done = _engine("run", case.op, "--params-json", "-", input=json.dumps(values))
    assert done.returncode == case.code, (done.stdout, done.stderr)
    assert "Warning:" not in done.stderr, done.stderr
    last = _lines(done.stdout)[-1]
    if case.code == 0:
        assert any(case.warning in w for w in last["result"]["warnings"]), last
        return
    for expect in case.expect:
        assert expect in last["error"], (expect, last)
    if case.param:
        from geoboresight.engine import field_label

        label = field_label(registry()[case.op].param(case.param))
        assert f"'{label}'" in last["error"] and "--" not in last["error"], last


def test_a_specim_capture_in_the_engine_is_its_image_lines(tmp_path):
    """stats on a Specim capture with dark frames, as QGIS runs it: N = the image's pixels."""
    from hostile import COLS, ROWS, make_products

    p = make_products(tmp_path / "p")["specim"]
    values = {"input": p.path, "band": 2, "output": str(tmp_path / "s.json")}
    done = _engine("run", "stats", "--params-json", "-", input=json.dumps(values))
    assert done.returncode == 0, done.stderr
    assert _lines(done.stdout)[-1]["result"]["n"] == ROWS * COLS
