"""Small inputs for every operation, and the tools of a hostile user's tests: run the CLI, snapshot
a folder byte by byte, mount a full or read-only file system.

Independent of the simulator: random cubes (``synth``) on a raw grid and on a UTM grid, with
variants in another CRS, on a shifted grid and one line short.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from click.testing import CliRunner
from rasterio.transform import from_origin
from synth import SWIR_WL, VNIR_WL, cube, write_envi, write_gtiff

from geoboresight.cli import main

UTM36 = "EPSG:32636"
UTM37 = "EPSG:32637"
GRID = from_origin(700000.0, 3500000.0, 2.0, 2.0)
SHIFTED = from_origin(700100.0, 3500000.0, 2.0, 2.0)
ROWS, COLS = 40, 30


def _float(seed: int, lo: float = 0.0, hi: float = 1.0, rows: int = ROWS) -> np.ndarray:
    return np.random.default_rng(seed).uniform(lo, hi, (1, rows, COLS)).astype("float32")


def make_inputs(d: Path) -> Path:
    """Write every input the catalogue's operations need into ``d``; ``d``."""
    d.mkdir(parents=True, exist_ok=True)
    vn, sw = cube(len(VNIR_WL), ROWS, COLS, seed=1), cube(len(SWIR_WL), ROWS, COLS, seed=2)
    write_envi(d / "v.img", vn, VNIR_WL)
    write_envi(d / "s.img", sw, SWIR_WL)
    write_envi(d / "s_small.img", sw[:, : ROWS - 1], SWIR_WL)
    write_envi(d / "vg.img", vn, VNIR_WL, crs=UTM36, transform=GRID)
    write_envi(d / "sg.img", sw, SWIR_WL, crs=UTM36, transform=GRID)
    write_envi(d / "sg37.img", sw, SWIR_WL, crs=UTM37, transform=GRID)
    write_envi(d / "sg_shift.img", sw, SWIR_WL, crs=UTM36, transform=SHIFTED)
    write_envi(d / "vg37.img", vn, VNIR_WL, crs=UTM37, transform=GRID)
    ratio = (sw[1:2].astype("float32") + 1.0) / (vn[10:11].astype("float32") + 1.0)
    write_gtiff(d / "ratio.tif", ratio)
    write_gtiff(d / "ratio_g.tif", ratio, crs=UTM36, transform=GRID)
    write_gtiff(d / "ratio_small.tif", ratio[:, : ROWS - 1])
    for name, crs, tr, rows in (
        ("", None, None, ROWS),
        ("_g", UTM36, GRID, ROWS),
        ("37", UTM37, GRID, ROWS),
        ("_shift", UTM36, SHIFTED, ROWS),
        ("_small", None, None, ROWS - 1),
    ):
        write_gtiff(d / f"truth{name}.tif", _float(3, rows=rows), crs=crs, transform=tr)
        target = (_float(4, rows=rows) > 0.9).astype("uint8")
        write_gtiff(d / f"target{name}.tif", target, crs=crs, transform=tr)
        write_gtiff(d / f"dem{name}.tif", _float(5, 0, 30, rows), crs=crs, transform=tr)
        write_gtiff(d / f"score{name}.tif", _float(6, 0, 10, rows), crs=crs, transform=tr)
        write_gtiff(
            d / f"mask{name}.tif",
            (_float(7, rows=rows) > 0.8).astype("uint8"),
            crs=crs,
            transform=tr,
        )
    classes = np.random.default_rng(8).integers(0, 5, (1, ROWS, COLS)).astype("uint8")
    write_gtiff(d / "classes.tif", classes)
    wl = np.arange(400.0, 2460.0, 10.0)
    rng = np.random.default_rng(9)
    rows = [
        f"{w:.1f},8.0,{a:.4f},{b:.4f}"
        for w, a, b in zip(
            wl, rng.uniform(0.05, 0.5, wl.size), rng.uniform(0.05, 0.5, wl.size), strict=True
        )
    ]
    (d / "em.csv").write_text("wavelength_nm,fwhm_nm,grass,soil\n" + "\n".join(rows) + "\n")
    # Georeferencing: ground control points and an input geometry map (x, y of each pixel).
    cols, lines = np.meshgrid(np.arange(COLS) + 0.5, np.arange(ROWS) + 0.5)
    x, y = 700000.0 + 2.0 * cols, 3500000.0 - 2.0 * lines
    write_gtiff(d / "igm.tif", np.stack([x, y]).astype("float64"))
    gcp = [(0.5, 0.5), (COLS - 0.5, 0.5), (COLS - 0.5, ROWS - 0.5), (0.5, ROWS - 0.5), (15, 20)]
    (d / "gcps.csv").write_text(
        f"# CRS: {UTM36}\npixel,line,x,y\n"
        + "".join(f"{p},{q},{700000 + 2 * p},{3500000 - 2 * q}\n" for p, q in gcp)
    )
    return d


def snapshot(*folders: Path) -> dict[str, str]:
    """Every file under ``folders`` (hidden ones too) with the SHA-256 of its bytes."""
    out = {}
    for folder in folders:
        for root, dirs, files in os.walk(folder):
            for name in dirs + files:
                p = Path(root) / name
                key = str(p)
                out[key] = (
                    "dir"
                    if p.is_dir() and not p.is_symlink()
                    else (
                        "link:" + os.readlink(p)
                        if p.is_symlink()
                        else hashlib.sha256(p.read_bytes()).hexdigest()
                    )
                )
    return out


def cli(argv: list[str]):
    """Run the CLI in-process (quiet); the click result."""
    return CliRunner().invoke(main, [*argv, "-q"], catch_exceptions=True)


def error_line(result) -> str:
    """The error message of a failed run, asserted to be one line without a traceback (a
    command-line usage error, exit status 2, too: it says where the help is)."""
    err = result.stderr.strip()
    assert "Traceback" not in result.output, result.output
    assert result.exception is None or isinstance(result.exception, SystemExit), repr(
        result.exception
    )
    if result.exit_code == 2:
        assert "--help')" in err, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("Error: "), err
    return err


def run_subprocess(args: list[str], **kw) -> subprocess.CompletedProcess:
    """``python -m geoboresight.cli ARGS`` in a subprocess (for signals and resource limits)."""
    return subprocess.run(
        [sys.executable, "-m", "geoboresight.cli", *args],
        capture_output=True,
        text=True,
        timeout=300,
        **kw,
    )


@contextlib.contextmanager
def mounted(folder: Path, options: str):
    """A tmpfs mounted at ``folder`` with ``options`` (e.g. ``size=64k`` or ``ro``), or None
    when this machine does not let us mount (not root, no CAP_SYS_ADMIN)."""
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        yield None
        return
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True
    )
    if done.returncode != 0:
        yield None
        return
    try:
        yield folder
    finally:
        subprocess.run(["umount", "-l", str(folder)], capture_output=True)


@contextlib.contextmanager
def read_only_folder(folder: Path):
    """A folder this process cannot write into: a read-only tmpfs as root, else mode 0555;
    None when neither is possible."""
    if os.geteuid() == 0:
        with mounted(folder, "ro,size=16k") as m:
            yield m
        return
    folder.mkdir(parents=True, exist_ok=True)
    folder.chmod(0o555)
    try:
        yield folder
    finally:
        folder.chmod(0o755)
