"""Fault injection: a run killed (SIGKILL) or interrupted (SIGINT) mid-write, and full disks.

What must hold: the previous output is byte-identical after any fault, an interrupted run
leaves nothing behind, a killed run's temporary file is swept by the next run into that
folder, and a full disk fails the run (exit status 1, one line naming the output) instead of
renaming a corrupt file over the good one.
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hostile import cli, error_line, make_inputs, mounted, snapshot
from synth import write_gtiff

from geoboresight import io
from geoboresight.errors import OutputError

# The CLI, with a progress bar that stops (prints MID and sleeps) once the output's temporary
# file exists: the process is then certainly in the middle of writing.
HOLD = r"""
import glob, os, sys, time
import geoboresight.cli as cli
folder, stem = sys.argv[1], sys.argv[2]
import signal
# A test suite started as a background shell job (`make test &`) runs with SIGINT ignored,
# and its children inherit that: restore Python's own handler, as an interactive run has.
signal.signal(signal.SIGINT, signal.default_int_handler)
held = []
def hold(self, fraction, message):
    # Hold once, mid-write (a temporary output exists), for the test's signal; later calls
    # (e.g. the progress of the clean-up after the signal) go on.
    if not held and glob.glob(os.path.join(folder, "." + stem + ".*.tmp*")):
        held.append(1)
        print("MID", flush=True)
        time.sleep(120)
cli._Bar.__call__ = hold
sys.argv = ["geoboresight", *sys.argv[3:]]
cli.main()
"""


@pytest.fixture
def scene(tmp_path) -> tuple[Path, Path]:
    inputs = make_inputs(tmp_path / "inputs")
    out = tmp_path / "out"
    out.mkdir()
    return inputs, out


def _ratio_args(inputs: Path, output: Path) -> list[str]:
    return [
        "ratio",
        "--vnir",
        str(inputs / "v.img"),
        "--swir",
        str(inputs / "s.img"),
        "-o",
        str(output),
    ]


def _start_held(out: Path, stem: str, args: list[str]) -> subprocess.Popen:
    proc = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(out), stem, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    line = proc.stdout.readline()
    assert line.strip() == "MID", (line, proc.stderr.read() if proc.poll() is not None else "")
    return proc


def _litter(folder: Path) -> list[str]:
    return sorted(n for n in os.listdir(folder) if ".tmp" in n)


def test_sigkill_mid_write_keeps_the_previous_output_and_the_next_run_sweeps(scene):
    inputs, out = scene
    previous = out / "r.tif"
    assert cli(_ratio_args(inputs, previous)).exit_code == 0
    before = previous.read_bytes()
    inputs_before = snapshot(inputs)
    proc = _start_held(out, "r", [*_ratio_args(inputs, previous), "--overwrite"])
    litter = _litter(out)
    assert litter, "the run was not mid-write"
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    assert previous.read_bytes() == before
    assert _litter(out) == litter  # nothing cleaned up a killed process: litter remains
    # The next run into that folder sweeps it (its writer is gone).
    assert cli(_ratio_args(inputs, out / "r2.tif")).exit_code == 0
    assert _litter(out) == []
    assert previous.read_bytes() == before
    assert sorted(os.listdir(out)) == ["r.tif", "r2.tif"]
    assert snapshot(inputs) == inputs_before


def test_sigint_mid_write_leaves_nothing(scene):
    inputs, out = scene
    (out / "keep.txt").write_text("the user's file")
    before = snapshot(out)
    proc = _start_held(out, "new", _ratio_args(inputs, out / "new.tif"))
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert err.strip().splitlines()[-1] == "Error: cancelled; no output was left behind"
    assert "Traceback" not in err
    assert snapshot(out) == before


def test_sigint_mid_write_with_overwrite_keeps_the_previous_output(scene):
    inputs, out = scene
    previous = out / "r.tif"
    assert cli(_ratio_args(inputs, previous)).exit_code == 0
    before = snapshot(out)
    proc = _start_held(out, "r", [*_ratio_args(inputs, previous), "--overwrite"])
    proc.send_signal(signal.SIGINT)
    proc.communicate(timeout=60)
    assert proc.returncode == 1
    assert snapshot(out) == before


def _fill(folder: Path) -> None:
    """Fill the file system of ``folder`` to the last byte."""
    fd = os.open(folder / "filler", os.O_WRONLY | os.O_CREAT)
    try:
        for chunk in (65536, 4096, 1):
            try:
                while True:
                    os.write(fd, b"\0" * chunk)
            except OSError:
                pass
    finally:
        os.close(fd)


#: One operation per kind of writer: GeoTIFF, JSON, PNG, GeoPackage.
FULL_DISK_RUNS = {
    "ratio-tif": lambda i, o: _ratio_args(i, o / "out.tif"),
    "stats-json": lambda i, o: ["stats", "-i", str(i / "ratio.tif"), "-o", str(o / "out.json")],
    "roc-png": lambda i, o: [
        "roc",
        "--scores",
        str(i / "score.tif"),
        "--truth",
        str(i / "target.tif"),
        "-o",
        str(o / "out.png"),
    ],
    "shadow-polygons-gpkg": lambda i, o: [
        "shadow-polygons",
        "--classes-raster",
        str(i / "classes.tif"),
        "-o",
        str(o / "out.gpkg"),
    ],
}


@pytest.mark.parametrize("kind", sorted(FULL_DISK_RUNS))
def test_full_disk_fails_the_run_and_keeps_the_previous_output(tmp_path, kind):
    inputs = make_inputs(tmp_path / "inputs")
    with mounted(tmp_path / "full", "size=1m") as full:
        if full is None:
            pytest.skip("cannot mount a tmpfs here; test_file_size_limit covers a full disk")
        args = FULL_DISK_RUNS[kind](inputs, full)
        first = cli(args)
        assert first.exit_code == 0, first.output
        _fill(full)
        before = snapshot(full, inputs)
        result = cli([*args, "--overwrite"])
        assert result.exit_code == 1
        line = error_line(result)
        assert "out." in line and "full" in line, line
        assert ".tmp" not in line  # the user's path, never the temporary name
        assert snapshot(full, inputs) == before  # previous output kept, nothing left behind


def test_gdal_error_at_close_fails_the_write(tmp_path):
    """GDAL reports a full disk met while flushing at close only on stderr, and the close
    returns normally: the writer must notice (the file is checked before the rename)."""
    with mounted(tmp_path / "full", "size=256k") as full:
        if full is None:
            pytest.skip("cannot mount a tmpfs here")
        (full / "x.tif").write_bytes(b"previous")
        data = np.random.default_rng(0).random((600, 600)).astype("float32")
        with pytest.raises(OutputError, match="full") as info:
            io.write_raster(str(full / "x.tif"), data, like=io.Grid(600, 600))
        assert str(full / "x.tif") in str(info.value)
        assert (full / "x.tif").read_bytes() == b"previous"
        assert os.listdir(full) == ["x.tif"]


def _limit_file_size(limit: int):
    def apply():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # write() then fails with EFBIG
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    return apply


def test_file_size_limit_fails_the_run_and_keeps_the_previous_output(tmp_path):
    """A full disk without mounting one: RLIMIT_FSIZE makes every write past 64 kB fail
    (EFBIG), as ENOSPC would."""
    big = np.random.default_rng(1).uniform(1.0, 4.0, (1, 400, 400)).astype("float32")
    ratio = write_gtiff(tmp_path / "ratio.tif", big)
    out = tmp_path / "out"
    out.mkdir()
    args = ["boresight-indicator", "--ratio", ratio, "-o", str(out / "ind.tif"), "-q"]
    first = subprocess.run([sys.executable, "-m", "geoboresight.cli", *args], capture_output=True)
    assert first.returncode == 0, first.stderr
    before = snapshot(out)
    done = subprocess.run(
        [sys.executable, "-m", "geoboresight.cli", *args, "--overwrite"],
        capture_output=True,
        text=True,
        preexec_fn=_limit_file_size(64 * 1024),
        timeout=300,
    )
    assert done.returncode == 1, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("Error: output") and "ind.tif" in last, done.stderr
    assert "Traceback" not in done.stderr
    assert snapshot(out) == before
