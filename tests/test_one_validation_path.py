"""One validation path: the command line, the engine's JSON-lines protocol and batch jobs
accept and refuse exactly the same values, and a refusal names the same parameter.

Every value is driven through every face that can carry it: text (what a user types) through
the CLI, the engine, a batch CSV and a batch JSON file; JSON-typed values (``true``, a list, a
number where a path belongs, ``NaN``) through the engine and a batch JSON file, which pass
JSON values as they come. A refusal is exit 1 or 2 (never 70, never a traceback) with one line
naming the parameter; the good values give the same result through every face.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import pytest
from click.testing import CliRunner
from hostile import UTM36, make_inputs

from geoboresight.batch import read_labelled_jobs, run_batch
from geoboresight.cli import main

_TEXT_ONLY = object()  # a value with no JSON-typed form (the text form is used)


@dataclass
class Bad:
    id: str
    op: str
    param: str
    text: str | None  # what a user types (CLI, batch CSV); None: no text form
    json: object = _TEXT_ONLY  # the JSON-typed value (engine, batch JSON)
    cli: list[str] | None = None  # the command-line words, when not --param TEXT


#: Valid arguments of each operation used (paths relative to the inputs folder).
BASE = {
    "stats": {"input": "ratio.tif"},
    "geolocate": {"input": "ratio.tif", "igm": "igm.tif", "igm_crs": UTM36},
    "coregister": {"vnir": "v.img", "swir": "s.img"},
}
_PATHS = {"input", "igm", "vnir", "swir"}

BAD = [
    Bad("bool-for-number", "stats", "bins", "true", True),
    Bad("bool-for-number-float", "geolocate", "resolution", "true", True),
    Bad("negative-enum-index", "geolocate", "resampling", "-1", -1),
    Bad("enum-index-beyond", "geolocate", "resampling", "9", 9),
    Bad("unknown-choice", "geolocate", "resampling", "cubicc"),
    Bad("list-for-path", "stats", "input", None, ["ratio.tif", "ratio.tif"]),
    Bad("number-for-path", "stats", "input", None, 12345),
    Bad("dict-for-number", "stats", "bins", None, {"value": 5}),
    Bad("unknown-parameter", "stats", "binz", "5", 5),
    Bad("nan", "geolocate", "resolution", "nan", math.nan),
    Bad("inf", "geolocate", "resolution", "inf", math.inf),
    Bad("below-minimum", "stats", "bins", "1", 1),
    Bad("above-maximum", "stats", "bins", "20000", 20000),
    Bad("fraction-for-whole-number", "stats", "bins", "2.5", 2.5),
    Bad("negative", "geolocate", "resolution", "-2", -2),
    Bad("garbled-number", "stats", "bins", "2O"),
    Bad("string-for-flag", "coregister", "follow_drift", "maybe", cli=["--follow-drift=maybe"]),
    Bad("number-for-flag", "coregister", "follow_drift", "2", 2, cli=["--follow-drift=2"]),
    Bad("list-for-flag", "coregister", "follow_drift", None, [True]),
    Bad("list-for-text", "geolocate", "igm_crs", None, [UTM36]),
]


@pytest.fixture(scope="module")
def d(tmp_path_factory) -> Path:
    return make_inputs(tmp_path_factory.mktemp("one_path") / "in")


def _values(op: str, d: Path, **extra) -> dict:
    out = {k: str(d / v) if k in _PATHS else v for k, v in BASE[op].items()}
    return {**out, **extra}


def _names(param: str) -> tuple[str, ...]:
    """How each face names a parameter: Python 'name', the CLI --name, the engine (what QGIS
    shows) the field's label."""
    from geoboresight.algorithms import registry
    from geoboresight.engine import field_label

    labels = {field_label(p) for a in registry().values() for p in a.params if p.name == param}
    return (f"'{param}'", "--" + param.replace("_", "-"), f" {param}", *labels)


def _refused(face: str, message: str, param: str) -> None:
    assert message, f"{face}: refused without a message"
    assert "\n" not in message.strip(), (face, message)
    assert "Traceback" not in message and "bug in geoboresight" not in message, (face, message)
    assert "internal error" not in message, (face, message)
    assert any(n in message for n in _names(param)), (face, param, message)


def _cli(op: str, d: Path, out: Path, words: list[str]):
    argv = [op]
    for k, v in _values(op, d).items():
        argv += ["--" + k.replace("_", "-"), v]
    argv += ["--output", str(out), *words, "-q"]
    return CliRunner().invoke(main, argv, catch_exceptions=True)


def _engine(op: str, values: dict, tmp: Path):
    params = tmp / "params.json"
    params.write_text(json.dumps(values))  # NaN and Infinity as JSON's common extension
    result = CliRunner().invoke(main, ["engine", "run", op, "--params-json", str(params)])
    lines = [json.loads(x) for x in result.stdout.splitlines() if x.strip()]
    return result.exit_code, lines


def _batch_json(op: str, values: dict, tmp: Path):
    jobs = tmp / "jobs.json"
    jobs.write_text(json.dumps([values]))
    rows, labels = read_labelled_jobs(str(jobs))
    return run_batch(op, rows, labels=labels, n_workers=1)


def _batch_csv(op: str, values: dict, tmp: Path):
    jobs = tmp / "jobs.csv"
    header = list(values)
    jobs.write_text(
        ",".join(header) + "\n" + ",".join(f'"{values[k]}"' for k in header) + "\n",
        encoding="utf-8",
    )
    rows, labels = read_labelled_jobs(str(jobs))
    return run_batch(op, rows, labels=labels, n_workers=1)


@pytest.mark.parametrize("bad", BAD, ids=[b.id for b in BAD])
def test_every_face_refuses_the_same_bad_value_naming_the_parameter(bad: Bad, d, tmp_path):
    out = tmp_path / "out.json" if bad.op == "stats" else tmp_path / "out.tif"
    faces = 0
    if bad.text is not None:
        # The command line: a usage error (2) or a refusal (1), never a bug (70).
        words = bad.cli or ["--" + bad.param.replace("_", "-"), bad.text]
        done = _cli(bad.op, d, out, words)
        assert done.exit_code in (1, 2), (done.exit_code, done.output)
        _refused("cli", done.stderr.strip().splitlines()[-1], bad.param)
        # The same text through the engine and a batch CSV row.
        code, lines = _engine(
            bad.op, _values(bad.op, d, output=str(out), **{bad.param: bad.text}), tmp_path
        )
        assert code == 1, lines
        _refused("engine (text)", lines[-1]["error"], bad.param)
        (job,) = _batch_csv(
            bad.op, _values(bad.op, d, output=str(out), **{bad.param: bad.text}), tmp_path
        )
        assert not job.ok and job.label == "line 2", job
        _refused("batch CSV", job.error, bad.param)
        faces += 3
    if bad.json is not _TEXT_ONLY:
        values = _values(bad.op, d, output=str(out), **{bad.param: bad.json})
        if bad.param in _PATHS and isinstance(bad.json, list):
            values[bad.param] = [str(d / p) for p in bad.json]
        code, lines = _engine(bad.op, values, tmp_path)
        assert code == 1, lines
        _refused("engine (JSON)", lines[-1]["error"], bad.param)
        (job,) = _batch_json(bad.op, values, tmp_path)
        assert not job.ok and job.label == "job 1", job
        _refused("batch JSON", job.error, bad.param)
        faces += 2
    assert faces >= 2
    assert not out.exists(), "a refused run left an output"


#: Good values in the forms each face passes them: all accepted, the same result.
GOOD = [
    ("text", {"bins": "20", "band": "1", "percentiles": "5,50,95"}),
    ("json", {"bins": 20, "band": 1, "percentiles": "5,50,95"}),
    ("json-float-whole", {"bins": 20.0, "band": 1.0, "percentiles": "5,50,95"}),
]


def _stats(path: Path) -> dict:
    doc = json.loads(path.read_text())
    doc.pop("output", None)
    return doc


def test_good_values_give_the_same_result_through_every_face(d, tmp_path):
    results = {}
    done = _cli(
        "stats",
        d,
        tmp_path / "cli.json",
        ["--bins", "20", "--band", "1", "--percentiles", "5,50,95"],
    )
    assert done.exit_code == 0, done.output
    results["cli"] = _stats(tmp_path / "cli.json")
    for form, extra in GOOD:
        out = tmp_path / f"engine-{form}.json"
        code, lines = _engine("stats", _values("stats", d, output=str(out), **extra), tmp_path)
        assert code == 0 and "result" in lines[-1], lines
        results[f"engine {form}"] = _stats(out)
    jobs = [
        _values("stats", d, output=str(tmp_path / f"batch-{form}.json"), **extra)
        for form, extra in GOOD
    ]
    (tmp_path / "jobs.json").write_text(json.dumps(jobs))
    rows, labels = read_labelled_jobs(str(tmp_path / "jobs.json"))
    for job in run_batch("stats", rows, labels=labels, n_workers=1):
        assert job.ok, job.error
    for form, _ in GOOD:
        results[f"batch {form}"] = _stats(tmp_path / f"batch-{form}.json")
    first = results["cli"]
    for face, doc in results.items():
        assert doc == first, face


def _bad_python_values(alg) -> dict:
    """One value of the wrong kind for each of ``alg``'s arguments, as a script might pass it:
    a number for a path, text for a number, an unknown choice, a bare number for a parameter
    group's value."""
    from geoboresight.algorithms import spec

    by_kind = {
        spec.Number: "many",
        spec.Band: "first",
        spec.Enum: "no-such-choice",
        spec.Flag: "maybe",
        spec.Text: [1],
        spec.RasterIn: 12345,
        spec.MultiRaster: 12345,
        spec.FileIn: 12345,
        spec._Out: 12345,
    }
    grouped = {p.name for g in alg.groups for p in g.params}
    bad = {g.name: 42 for g in alg.groups}
    for p in alg.params:
        if p.name not in grouped:
            bad[p.name] = next(v for kind, v in by_kind.items() if isinstance(p, kind))
    return bad


def _example_arguments(alg) -> dict:
    """``alg``'s example as Python arguments: its members gathered into their group's value."""
    return alg.bind({k: alg.param(k).coerce(v) for k, v in alg.example.items()})


def _refusal(call) -> tuple[str, str]:
    from geoboresight.errors import GeoboresightError

    try:
        call()
    except GeoboresightError as exc:
        return type(exc).__name__, str(exc)
    raise AssertionError("accepted")


def test_an_operation_from_geoboresight_checks_its_arguments_as_every_face(tmp_path, monkeypatch):
    """Every operation, called from ``geoboresight`` (the function its spec wraps), refuses
    each bad argument with the same one-line error naming it as every face does."""
    import geoboresight as gb
    from geoboresight.algorithms import registry

    monkeypatch.chdir(tmp_path)  # the examples' file names: nothing is read or written
    checked = 0
    for alg in registry().values():
        name = alg.run.__name__
        assert getattr(gb, name) is alg.operation
        base = _example_arguments(alg)
        for param, value in _bad_python_values(alg).items():
            args = {**base, param: value}
            kind, message = _refusal(lambda name=name, args=args: getattr(gb, name)(**args))
            assert kind in ("ParameterError", "InputError"), (alg.name, param, kind, message)
            assert "\n" not in message and f"'{param}'" in message, (alg.name, param, message)
            checked += 1
    assert checked > 200


def test_an_operation_from_geoboresight_is_its_spec_wrapping_the_function():
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from geoboresight.operations.ratio import ratio_file\n"
        "assert 'geoboresight.algorithms.ratio' not in sys.modules\n"
        "import geoboresight as gb\n"
        "assert gb.ratio_file.__wrapped__ is ratio_file\n"
        "try:\n"
        "    gb.ratio_file('v.hdr', 's.hdr', output='r.tif', bands=42)\n"
        "except Exception as exc:\n"
        "    print(type(exc).__name__, exc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "ParameterError parameter 'bands': expected a BandChoice, got 42"
