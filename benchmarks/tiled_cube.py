"""Benchmark: ``rx`` on one cube stored as uncompressed ENVI BIL and as a tiled, compressed GeoTIFF.

    .venv/bin/python benchmarks/tiled_cube.py [--rows 2048] [--cols 600] [--bands 60] [--workdir /tmp] [--keep]

1. **The cube**: ``--bands`` int16 bands of ``--rows`` × ``--cols`` pixels (a smooth spectrum
   per 32-line block plus noise, so that DEFLATE has something to do), written twice by a
   process of its own: ENVI BIL (read straight from disk, no GDAL) and a GeoTIFF tiled
   256 × 256, pixel-interleaved, DEFLATE (read through GDAL, each tile decompressed).
   Both are synced and read once before timing.
2. **The operation**: ``rx --no-coregister`` on each, alternating, ``--repeat`` times, each
   its own process through the command line; wall time and peak RSS from ``os.wait4``.
3. **The ratio** tiled / ENVI of the medians: what a tiled, compressed cube costs over the
   fastest layout. ``rx`` reads 16-line strips, so without a block cache that holds a row
   of tiles every 256-line tile would be decoded 16 times per pass.

Prints a Markdown table; record it in ``benchmarks/RESULTS.md`` with the commit.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys

from flightline import EXE, leave, load, run, settle, table, work_folder

WRITE = """
import sys
import numpy as np
import rasterio
from rasterio.windows import Window
sys.path.insert(0, sys.argv[1])
from geoboresight.io import quiet_georef, write_envi
folder, rows, cols, k = sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
rng = np.random.default_rng(0)
spectra = rng.normal(2000, 300, (k, -(-rows // 32), 1, cols))
cube = (np.repeat(spectra, 32, axis=2).reshape(k, -1, cols)[:, :rows]
        + rng.normal(0, 50, (k, rows, cols))).astype(np.int16)
write_envi(folder + "/cube.img", cube, np.linspace(400, 2400, k))
profile = dict(driver="GTiff", width=cols, height=rows, count=k, dtype="int16", tiled=True,
               blockxsize=256, blockysize=256, compress="deflate", interleave="pixel")
with quiet_georef(), rasterio.open(folder + "/cube.tif", "w", **profile) as dst:
    dst.write(cube)
"""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=2048)
    ap.add_argument("--cols", type=int, default=600)
    ap.add_argument("--bands", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--workdir")
    ap.add_argument("--keep", action="store_true")
    args = ap.parse_args(argv)
    if min(args.rows, args.cols) < 64 or args.bands < 3 or args.repeat < 1:
        ap.error("--rows and --cols: at least 64; --bands: at least 3; --repeat: at least 1")
    work, log = work_folder(ap, args.workdir, "gb-tiled-")
    try:
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        size = [str(args.rows), str(args.cols), str(args.bands)]
        subprocess.run([sys.executable, "-c", WRITE, root, work, *size], check=True)
        files = {"ENVI BIL": "cube.hdr", "GeoTIFF, tiled 256 × 256, DEFLATE": "cube.tif"}
        settle([os.path.join(work, f) for f in ("cube.img", "cube.tif")])
        res: dict[str, list] = {name: [] for name in files}
        for i in range(args.repeat):
            for name, f in files.items():
                out = os.path.join(work, f"rx{i}-{f}.tif")
                cmd = [EXE, "rx", "--vnir", os.path.join(work, f), "--no-coregister"]
                r = run([*cmd, "--output", out], log)
                if r["status"]:
                    print(f"{name} failed: see {log}", file=sys.stderr)
                    return 1
                res[name].append(r)
                print(f"  {name:34s} {r['seconds']:6.1f} s  {r['peak_gb']:.3f} GB", flush=True)
        med = {n: statistics.median(r["seconds"] for r in rs) for n, rs in res.items()}
        envi = med["ENVI BIL"]
        print(
            f"\n{args.bands} × {args.rows} × {args.cols} int16, rx --no-coregister, "
            f"{args.repeat} alternating runs each; load average now {load()}\n"
        )
        rows = [
            (
                name,
                " / ".join(f"{r['seconds']:.2f}" for r in rs),
                f"{med[name] / envi:.2f}",
                f"{max(r['peak_gb'] for r in rs):.2f}",
            )
            for name, rs in res.items()
        ]
        print(table(rows, ("file", "wall (s)", "median / ENVI's", "peak RSS (GB)")))
    finally:
        leave(work, args.keep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
