"""Adding an operation as docs/DEVELOPING.md says: a toy operation in a module of its own
(outside this package, registered through the ``geoboresight.algorithms`` entry point) appears
in every face: the command line (``list`` and its ``--help``), ``rio boresight``, the engine's
description (what the QGIS provider is generated from) and batch, whose Dask workers find it
the same way; and a Python call is checked against its spec."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rasterio

#: The toy: a file-level operation (read, a kernel step, write) and its spec, in one module.
TOY = '''
import numpy as np

from geoboresight import io
from geoboresight.algorithms.spec import Algorithm, Number, RasterIn, RasterOut, Result


def scaled(data, valid=None, *, factor):
    """The kernel: ``data`` times ``factor`` where valid."""
    return np.where(valid, data * factor, io.FLOAT_NODATA) if valid is not None else data * factor


def toy_scale_file(input, *, output, factor=2.0, progress=None):
    """Write band 1 of ``input`` times ``factor``."""
    with io.open_raster(input, "input") as src:
        data, valid = io.read_masked(src, 1)
        io.write_raster(output, scaled(data, valid, factor=factor), like=src)
    return {"output": output, "valid_pixels": int(valid.sum())}


# The spec wraps the function: TOY_SCALE.operation is toy_scale_file checked against it.
TOY_SCALE = Algorithm(
    name="toy-scale",
    display_name="Toy scale",
    group="Boresight ratio and statistics",
    short_help="Multiply a raster by a factor (a toy).",
    help="Multiplies band 1 of a raster by a factor.",
    params=(
        RasterIn(name="input", description="Raster to scale"),
        Number(name="factor", description="Factor", default=2.0, minimum=0.0, maximum=10.0),
        RasterOut(name="output", description="Scaled raster"),
    ),
    results=(Result("valid_pixels", "number", "Pixels scaled"),),
    example={"input": "ratio.tif", "output": "scaled.tif"},
    run=toy_scale_file,
)

ALGORITHMS = (TOY_SCALE,)
'''


@pytest.fixture(scope="module")
def added(tmp_path_factory) -> dict:
    """A folder holding the toy module and the metadata that registers it, as ``pip install``
    of a package declaring ``[project.entry-points."geoboresight.algorithms"]`` writes it;
    the environment that puts it on the path (for subprocesses and Dask's workers)."""
    root = tmp_path_factory.mktemp("added")
    (root / "toy_boresight.py").write_text(TOY, encoding="utf-8")
    meta = root / "toy_boresight-0.1.dist-info"
    meta.mkdir()
    (meta / "METADATA").write_text(
        "Metadata-Version: 2.1\nName: toy-boresight\nVersion: 0.1\n", encoding="utf-8"
    )
    (meta / "entry_points.txt").write_text(
        "[geoboresight.algorithms]\ntoy = toy_boresight\n", encoding="utf-8"
    )
    data = np.arange(12 * 10, dtype="float32").reshape(12, 10)
    with rasterio.open(
        root / "in.tif", "w", driver="GTiff", width=10, height=12, count=1, dtype="float32"
    ) as dst:
        dst.write(data, 1)
    path = os.pathsep.join(filter(None, [str(root), os.environ.get("PYTHONPATH")]))
    return {"root": root, "env": {**os.environ, "PYTHONPATH": path}, "data": data}


def _run(added, *words) -> subprocess.CompletedProcess:
    exe = Path(sys.executable).parent
    program = [str(exe / words[0])] if (exe / words[0]).exists() else [words[0]]
    return subprocess.run(
        [*program, *words[1:]],
        capture_output=True,
        text=True,
        env=added["env"],
        cwd=added["root"],
        timeout=600,
    )


def test_the_added_operation_is_a_command_with_its_help(added):
    listed = _run(added, "geoboresight", "list")
    assert listed.returncode == 0, listed.stderr
    assert "toy-scale" in listed.stdout and "Multiply a raster by a factor" in listed.stdout
    helped = _run(added, "geoboresight", "toy-scale", "--help")
    assert helped.returncode == 0, helped.stderr
    assert "--factor FLOAT     Factor [0–10]" in helped.stdout
    # Refused as every built-in operation refuses: one line naming the option.
    bad = _run(
        added, "geoboresight", "toy-scale", "--input", "in.tif", "--factor", "11", "-o", "x.tif"
    )
    assert bad.returncode == 1 and "--factor" in bad.stderr and "Traceback" not in bad.stderr
    assert not (added["root"] / "x.tif").exists()
    # Without the entry point it is unknown (the test's own environment).
    plain = subprocess.run(
        [str(Path(sys.executable).parent / "geoboresight"), "list"], capture_output=True, text=True
    )
    assert "toy-scale" not in plain.stdout


def test_the_added_operation_is_a_rio_command(added):
    listed = _run(added, "rio", "boresight", "list")
    assert listed.returncode == 0, listed.stderr
    assert "toy-scale" in listed.stdout
    done = _run(added, "rio", "boresight", "toy-scale", "--input", "in.tif", "-o", "rio.tif")
    assert done.returncode == 0, done.stderr
    with rasterio.open(added["root"] / "rio.tif") as src:
        np.testing.assert_array_equal(src.read(1), added["data"] * 2)


def test_the_engine_describes_the_added_operation(added):
    described = _run(added, "geoboresight", "engine", "describe")
    assert described.returncode == 0, described.stderr
    (toy,) = [a for a in json.loads(described.stdout)["algorithms"] if a["name"] == "toy-scale"]
    params = {p["name"]: p for p in toy["params"]}
    assert params["factor"]["kind"] == "number" and params["factor"]["maximum"] == 10.0
    assert params["input"]["kind"] == "raster" and params["output"]["is_output"]
    assert "valid_pixels" in {r["name"] for r in toy["results"]}
    (params_file := added["root"] / "params.json").write_text(
        json.dumps({"input": "in.tif", "factor": 3, "output": "engine.tif"})
    )
    ran = _run(
        added, "geoboresight", "engine", "run", "toy-scale", "--params-json", str(params_file)
    )
    assert ran.returncode == 0, ran.stdout + ran.stderr
    assert json.loads(ran.stdout.splitlines()[-1])["result"]["valid_pixels"] == 120


def test_batch_runs_the_added_operation_on_its_workers(added):
    jobs = added["root"] / "jobs.json"
    jobs.write_text(
        json.dumps(
            [
                {"input": "in.tif", "factor": 0.5, "output": "batch_a.tif"},
                {"input": "in.tif", "factor": 4, "output": "batch_b.tif"},
            ]
        )
    )
    done = _run(added, "geoboresight", "batch", "toy-scale", str(jobs), "--workers", "1")
    assert done.returncode == 0, done.stdout + done.stderr
    for name, factor in (("batch_a.tif", 0.5), ("batch_b.tif", 4)):
        with rasterio.open(added["root"] / name) as src:
            np.testing.assert_array_equal(src.read(1), added["data"] * factor)


def test_a_python_call_of_the_added_operation_is_checked_by_its_spec(added):
    code = (
        "from toy_boresight import TOY_SCALE\n"
        "try:\n"
        "    TOY_SCALE.operation('in.tif', output='py.tif', factor='much')\n"
        "except Exception as exc:\n"
        "    print(type(exc).__name__, exc)\n"
    )
    out = _run(added, sys.executable, "-c", code)
    assert out.stdout.strip() == "ParameterError parameter 'factor': expected a number, got 'much'"


def test_an_added_module_that_fails_to_import_leaves_the_others_running(tmp_path):
    (tmp_path / "broken_boresight.py").write_text("raise ImportError('no such library')\n")
    meta = tmp_path / "broken_boresight-0.1.dist-info"
    meta.mkdir()
    (meta / "METADATA").write_text("Metadata-Version: 2.1\nName: broken-boresight\nVersion: 0.1\n")
    (meta / "entry_points.txt").write_text("[geoboresight.algorithms]\nbroken = broken_boresight\n")
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}
    listed = subprocess.run(
        [str(Path(sys.executable).parent / "geoboresight"), "list"],
        capture_output=True,
        text=True,
        env=env,
    )
    assert listed.returncode == 0 and "ratio" in listed.stdout
    assert "operations of broken_boresight (broken) not loaded: no such library" in listed.stderr
