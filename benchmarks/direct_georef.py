"""Direct georeferencing of a long line: time and peak memory against the least work any
exact method does on the same pixels.

A simulated survey line (``geoboresight.simulate.flight``: SBET at 200 Hz, 50 lines/s,
60 m/s, heading north) of N lines × 1,000 pixels (30° field of view, ~900 m above the
ground) over a 1 m DEM with ±40 m relief and a 15 m scarp, written as files; then, each in a
fresh process (benchmarks/_measure.py):

* ``direct-georeference`` (the file-level operation: reads the SBET, line times, sensor model,
  the DEM block by block, writes the float64 IGM GeoTIFF), timed from the call (imports and
  loading the compiled kernel from its cache excluded; a first run fills the cache);
* the floor: one pyproj transform (ECEF to the map CRS) of every ground point plus one
  bilinear DEM lookup (SciPy ``map_coordinates``, order 1) per pixel, block by block over
  the same line, with the DEM in memory (its read is not timed).

    python benchmarks/direct_georef.py [--lines 5000 20000]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _measure import measure  # noqa: E402

PIXELS = 1000
RATE = 50.0


def write_scene(folder, lines):
    """The line's files in ``folder``: SBET, line times, sensor model, DEM, a raw image."""
    import rasterio
    from rasterio.transform import from_origin

    from geoboresight.io.navigation import write_line_times, write_sbet, write_sensor_model_csv
    from geoboresight.sensor.model import SensorModel
    from geoboresight.simulate.flight import Flight

    flight = Flight(track_deg=0.0)
    times = flight.line_times(lines, rate=RATE)
    nav = flight.navigation(times[0] - 1.0, times[-1] + 1.0)
    write_sbet(os.path.join(folder, "line.out"), nav, wander_deg=flight.wander(nav.time))
    write_line_times(os.path.join(folder, "times.txt"), times)
    write_sensor_model_csv(os.path.join(folder, "model.csv"), SensorModel.ideal(PIXELS, 30.0))
    e0, n0 = flight.origin
    length = lines / RATE * flight.speed
    left, top = e0 - 400.0, n0 + length + 200.0
    width, height = 800, int(length + 400.0)
    profile = dict(driver="GTiff", width=width, height=height, count=1, dtype="float32",
                   crs=flight.crs, transform=from_origin(left, top, 1.0, 1.0), tiled=True,
                   compress="deflate")  # fmt: skip
    with rasterio.open(os.path.join(folder, "dem.tif"), "w", **profile) as dst:
        for r0 in range(0, height, 1024):
            rows = np.arange(r0, min(height, r0 + 1024))
            y = (top - rows - 0.5)[:, None] - n0
            x = (left + np.arange(width) + 0.5)[None, :] - e0
            z = (340.0 + 40.0 * np.sin(x / 70.0) * np.cos(y / 90.0)
                 + 15.0 * np.tanh((x - 0.6 * np.mod(y, 400.0) + 50.0) / 5.0)
                 + 0.7 * np.sin(x / 3.1 + y / 4.3))  # fmt: skip
            dst.write(z.astype("float32")[None], window=((r0, r0 + len(rows)), (0, width)))
    with rasterio.open(os.path.join(folder, "line.bil"), "w", driver="ENVI", width=PIXELS,
                       height=lines, count=1, dtype="uint8") as dst:  # fmt: skip
        dst.write(np.zeros((1, lines, PIXELS), "uint8"))


OPERATION = """
# {{ext}}: the IGM as GeoTIFF (lossless ZSTD where GDAL has it, else deflate) or ENVI BIL
import time
import geoboresight as gb
from geoboresight.operations import direct_georef
from geoboresight.sensor import intersect
import numpy as np
# loading the compiled kernel from its cache is part of the import
intersect.march(np.zeros((1, 3, 3)), np.zeros((2, 2)))
t_call = time.perf_counter()
gb.direct_georeference_file(
    "{f}/line.bil", "{f}/line.out", output="{f}/igm{ext}",
    geometry=gb.SensorGeometry(sensor_model="{f}/model.csv", line_times="{f}/times.txt",
                               boresight=gb.Boresight(0.4, -0.3, 0.5),
                               lever_arm=gb.LeverArm(0.3, -0.1, 0.3)),
    terrain=gb.Terrain(dem="{f}/dem.tif"), overwrite=True)
extra["call_seconds"] = time.perf_counter() - t_call
"""

FLOOR = """
import numpy as np, rasterio, time
from pyproj import Transformer
from scipy import ndimage
t_start = time.perf_counter()
with rasterio.open("{f}/dem.tif") as src:
    z = src.read(1).astype("float64"); a, b, c, d, e, f = tuple(src.transform)[:6]; crs = src.crs
to_ecef = Transformer.from_crs(crs, "EPSG:4978", always_xy=True)
to_map = Transformer.from_crs("EPSG:4978", crs, always_xy=True)
spent = 0.0
with rasterio.open("{f}/igm.tif") as igm:
    for r0 in range(0, igm.height, 256):
        win = ((r0, min(igm.height, r0 + 256)), (0, igm.width))
        x, y, h = igm.read(window=win)
        X, Y, Z = to_ecef.transform(x.ravel(), y.ravel(), h.ravel())
        t0 = time.perf_counter()
        mx, my, mh = to_map.transform(X, Y, Z)
        zz = ndimage.map_coordinates(z, [(np.asarray(my) - f) / e - 0.5,
                                         (np.asarray(mx) - c) / a - 0.5], order=1)
        spent += time.perf_counter() - t0
extra["floor_seconds"] = spent
"""


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, nargs="+", default=[5000, 20000])
    args = ap.parse_args(argv)
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()  # fmt: skip
    print(f"commit {commit}, numba: {_has_numba()}")
    print(
        "| lines | pixels | IGM | direct-georeference (s) | peak RSS (MiB) "
        "| floor: pyproj + bilinear (s) | ratio |"
    )
    print("|---|---|---|---|---|---|---|")
    for lines in args.lines:
        with tempfile.TemporaryDirectory(prefix="gb-dg-") as folder:
            write_scene(folder, lines)
            # a first run compiles the Numba kernel into its cache (not timed)
            measure(OPERATION.format(f=folder, ext=".tif"))
            ops = {ext: measure(OPERATION.format(f=folder, ext=ext)) for ext in (".tif", ".bil")}
            floor = measure(FLOOR.format(f=folder))
            for ext, op in ops.items():
                if "error" in op or "error" in floor:
                    print(op, floor)
                    continue
                ratio = op["call_seconds"] / floor["floor_seconds"]
                print(f"| {lines:,} | {lines * PIXELS:,} | {ext} | {op['call_seconds']:.1f} "
                      f"| {op['peak_mib']:.0f} | {floor['floor_seconds']:.1f} | {ratio:.2f}× |",
                      flush=True)  # fmt: skip


def _has_numba():
    try:
        import numba

        return numba.__version__
    except ImportError:
        return "no"


if __name__ == "__main__":
    main()
