"""Benchmark: one operation's own time on a flight line, without starting Python, with code
trees alternated.

    .venv/bin/python benchmarks/operation_alone.py [--alternate TREE,TREE] [--op shadow-map]
        [--lines 3000] [--geotiff [--vnir-bands 300]] [--rounds 3] [--runs 3] [--workdir /tmp]

The line is ``benchmarks/flightline.py``'s (a simulated scene tiled along-track, ENVI BIL;
with ``--geotiff`` rewritten as tiled, band-interleaved GeoTIFFs read through GDAL; with
``--vnir-bands N`` too, the VNIR resampled linearly onto N bands over the same range, as a
sensor of finer bands would deliver it). Each
round runs, for each code tree in turn (``PYTHONPATH``: a checkout, or ``git archive COMMIT``
unpacked), one process that imports the library, runs the operation once not kept (the
boresight offset is measured then into the shared cache folder, the files come into the page
cache), then ``--runs`` times timed in the process: wall and CPU time of the operation
alone, which the process's start (0.7–1 s of a command) does not dilute. Prints a Markdown
table with each tree's runs and their sum over the first tree's.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

from flightline import EXE, as_geotiff, commands, load, make_line, simulate, table

from geoboresight.io.cache import CACHE_ENV

#: Runs the command-line operation's arguments in one process: once not kept, then timed.
_TIMED = """
import json, sys, time
from click.testing import CliRunner
from geoboresight.cli import main
args, runs = json.loads(sys.argv[1]), int(sys.argv[2])
def once():
    result = CliRunner().invoke(main, args + ["--overwrite"], catch_exceptions=False)
    assert result.exit_code == 0, result.output
once()
for _ in range(runs):
    t0, c0 = time.perf_counter(), time.process_time()
    once()
    print(time.perf_counter() - t0, time.process_time() - c0, flush=True)
"""

#: The VNIR GeoTIFF (argv 1) resampled linearly onto argv 2 bands, written in its place.
_RESAMPLE = """
import os, sys, numpy as np, rasterio
path, n = sys.argv[1], int(sys.argv[2])
with rasterio.open(path) as src:
    wl = np.array([float(src.tags(b)["wavelength"]) for b in range(1, src.count + 1)])
    new = np.linspace(wl[0], wl[-1], n)
    i = np.clip(np.searchsorted(wl, new) - 1, 0, len(wl) - 2)
    f = ((new - wl[i]) / (wl[i + 1] - wl[i]))[:, None, None]
    with rasterio.open(path + ".tmp.tif", "w", **{**src.profile, "count": n}) as dst:
        for b in range(n):
            dst.update_tags(b + 1, wavelength=f"{new[b]:.3f}", wavelength_units="Nanometers")
        for r in range(0, src.height, 500):
            w = ((r, min(src.height, r + 500)), (0, src.width))
            cube = src.read(window=w).astype("float32")
            dst.write((cube[i] * (1 - f) + cube[i + 1] * f).round().astype(src.dtypes[0]), window=w)
os.replace(path + ".tmp.tif", path)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--alternate",
        default=os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
        help="code trees (comma-separated; default this checkout alone)",
    )
    ap.add_argument("--op", default="shadow-map", help="shadow-map, deshadow or ratio")
    ap.add_argument("--lines", type=int, default=3000)
    ap.add_argument("--tile", type=int, default=500, help="lines of the simulated scene")
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--geotiff", action="store_true", help="the line as GeoTIFFs")
    ap.add_argument("--vnir-bands", type=int, help="with --geotiff: the VNIR on this many bands")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--runs", type=int, default=3, help="timed runs per process")
    ap.add_argument("--workdir", default=tempfile.gettempdir())
    args = ap.parse_args(argv)
    if args.op not in ("shadow-map", "deshadow", "ratio"):
        ap.error(f"--op: shadow-map, deshadow or ratio, got {args.op!r}")
    trees = [os.path.abspath(t) for t in args.alternate.split(",") if t]
    work = tempfile.mkdtemp(prefix="gb-alone-", dir=args.workdir)
    start = load()
    print(f"work folder {work}; load average {start}", flush=True)
    try:
        line = make_line(
            simulate(work, args.tile, args.seed), os.path.join(work, "line"), args.lines
        )
        if args.geotiff:
            as_geotiff(line)
            if args.vnir_bands:
                subprocess.run(
                    [sys.executable, "-c", _RESAMPLE, os.path.join(line, "vnir.tif")]
                    + [str(args.vnir_bands)],
                    check=True,
                )
        out = os.path.join(work, "out")
        os.makedirs(out, exist_ok=True)
        cmds = commands(line, out)
        os.environ[CACHE_ENV] = os.path.join(work, "cache")
        needs = {"deshadow": ["shadow-map"], "ratio": []}.get(args.op, [])
        for op in needs:  # its inputs, once
            subprocess.run([EXE, *cmds[op], "--overwrite"], check=True, capture_output=True)
        times = {t: [] for t in trees}
        for k in range(args.rounds):
            for t in trees:
                env = {**os.environ, "PYTHONPATH": t}
                got = subprocess.run(
                    [sys.executable, "-c", _TIMED, json.dumps(cmds[args.op]), str(args.runs)],
                    env=env,
                    cwd=t,  # `python -c` puts the working folder first on sys.path
                    check=True,
                    capture_output=True,
                    text=True,
                ).stdout.split()
                pairs = [(float(w), float(c)) for w, c in zip(got[::2], got[1::2], strict=True)]
                times[t] += pairs
                print(f"round {k + 1}: {t}: " + " ".join(f"{w:.2f}" for w, _ in pairs), flush=True)
        first = times[trees[0]]
        rows = [
            (
                f"{args.op}: {t}",
                " / ".join(f"{w:.2f}" for w, _ in ts),
                " / ".join(f"{c:.2f}" for _, c in ts),
                f"{sum(w for w, _ in ts) / sum(w for w, _ in first):.3f}",
                f"{sum(c for _, c in ts) / sum(c for _, c in first):.3f}",
            )
            for t, ts in times.items()
        ]
        kind = "GeoTIFF" if args.geotiff else "ENVI BIL"
        kind += f", VNIR on {args.vnir_bands} bands" if args.geotiff and args.vnir_bands else ""
        print(f"\n{args.lines} lines ({kind}), load average {start} -> {load()}\n")
        header = (
            "operation: code",
            "wall (s)",
            "CPU (s)",
            "wall sum / first's",
            "CPU sum / first's",
        )
        print(table(rows, header))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
