"""Writing a spectral cube strip by strip (what ``deshadow`` does): geoboresight's GeoTIFF
writer (tiled, deflate, band-interleaved) against the same writer with GDAL's
default pixel interleaving (what rasterio gives a user who writes a multi-band GeoTIFF with
``rasterio.open(..., "w", tiled=True, compress="deflate")``), and the read of 3 bands a map
viewer draws. Each case in a fresh process (wall time and peak RSS); a case that passes the
time limit is reported as such.

    python benchmarks/cube_write.py [--bands 200] [--lines 1024] [--cols 512] [--limit 900]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _measure import measure  # noqa: E402

BODY = """
import numpy as np, rasterio, time
from rasterio.windows import Window
from geoboresight.io.grid import Grid
from geoboresight.io.raster import create_raster, writer_options
bands, lines, cols, path, co = {bands}, {lines}, {cols}, {path!r}, {co!r}
strip = (np.random.default_rng(0).random((bands, 16, cols)) * 1000).astype("float32")
with writer_options(co=co):
    with create_raster(path, Grid(cols, lines), count=bands) as dst:
        for r in range(0, lines, 16):
            dst.write(strip[:, : min(16, lines - r)], window=Window(0, r, cols, min(16, lines - r)))
extra["write_s"] = time.perf_counter() - t0
with rasterio.open(path) as src:
    t1 = time.perf_counter()
    src.read([min(bands, 30), min(bands, 20), min(bands, 10)])
    extra["read3_s"] = time.perf_counter() - t1
    extra["interleave"] = src.interleaving.name if src.interleaving else "?"
extra["mb"] = __import__("os").path.getsize(path) / 1e6
"""


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--bands", type=int, default=200)
    ap.add_argument("--lines", type=int, default=1024)
    ap.add_argument("--cols", type=int, default=512)
    ap.add_argument("--limit", type=float, default=900.0, help="seconds per case")
    a = ap.parse_args()
    cases = (
        ("geoboresight", []),
        ("GDAL default INTERLEAVE=PIXEL", ["INTERLEAVE=PIXEL"]),
    )
    rows = []
    with tempfile.TemporaryDirectory() as folder:
        for name, co in cases:
            path = os.path.join(folder, f"cube{len(rows)}.tif")
            body = BODY.format(bands=a.bands, lines=a.lines, cols=a.cols, path=path, co=co)
            try:
                r = measure(body, timeout=a.limit)
            except Exception:  # noqa: BLE001 - subprocess.TimeoutExpired
                r = {"error": f"not done in {a.limit:.0f} s"}
            rows.append((name, r))
    print(f"{a.bands} bands × {a.lines} lines × {a.cols} columns, float32, strips of 16 lines\n")
    print("| writer | write (s) | read 3 bands (s) | peak RSS (MiB) | file (MB) | write ratio |")
    print("|---|---|---|---|---|---|")
    ours = rows[0][1].get("write_s")
    for name, r in rows:
        if "error" in r:
            ratio = f"> {a.limit / ours:.0f}×" if ours else "—"
            print(f"| {name} | {r['error']} | — | — | — | {ratio} |")
            continue
        ratio = f"{r['write_s'] / ours:.1f}×" if ours else "—"
        print(
            f"| {name} (read back: {r['interleave']}) | {r['write_s']:.1f} | {r['read3_s']:.3f} | "
            f"{r['peak_mib']:.0f} | {r['mb']:.0f} | {ratio} |"
        )


if __name__ == "__main__":
    main()
