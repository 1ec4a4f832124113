"""Benchmark: sun-shadow ground truth vs the tools a user would otherwise pick.

Cast shadows of a 500 × 500 DSM (default; 2000 × 2000 took r.sunmask > 9 min) (1 m cells, buildings on a hill, 30 m relief) at zenith 60°:
our ray march (`cast_shadow`, whole-array shifts) vs GRASS `r.sunmask` (same algorithm, C, per
cell), and the hillshade vs `gdaldem hillshade`. Each case runs in its own process (wall time
and peak RSS); GRASS's time includes its start-up and import, gdaldem's its file I/O,
ours the GeoTIFF read. One run, side by side.

    python benchmarks/shadow.py [--size 2000] [--append benchmarks/RESULTS.md]
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile

import numpy as np
import rasterio
from rasterio.transform import from_origin

sys.path.insert(0, os.path.dirname(__file__))
from _measure import measure  # noqa: E402


def make_dsm(path, n):
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:n, 0:n]
    z = 20 * np.exp(-((yy - n / 2) ** 2 + (xx - n / 3) ** 2) / (2 * (n / 5) ** 2)) + 1.0
    for _ in range(n // 10):
        r, c = rng.integers(0, n - 30, 2)
        h, w = rng.integers(8, 30, 2)
        z[r : r + h, c : c + w] += rng.uniform(4, 10)
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=n,
        height=n,
        count=1,
        dtype="float32",
        crs="EPSG:32636",
        transform=from_origin(500000, 3500000, 1, 1),
    ) as d:
        d.write(z.astype("float32"), 1)


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=500)
    ap.add_argument("--append")
    a = ap.parse_args(argv)
    tmp = tempfile.mkdtemp(prefix="bench_shadow_")
    try:
        dsm = os.path.join(tmp, "dsm.tif")
        make_dsm(dsm, a.size)
        ours_cast = measure(f"""
import rasterio
from geoboresight.shadow.illumination import cast_shadow
with rasterio.open({dsm!r}) as s: z = s.read(1); tr = s.transform
m = cast_shadow(z, sun_zenith=60.0, sun_azimuth=205.8, transform=tr)
""")
        script = os.path.join(tmp, "s.sh")
        with open(script, "w") as f:
            f.write(
                f"set -e\nr.in.gdal input={dsm} output=dsm --quiet\ng.region raster=dsm\n"
                "r.sunmask -z elevation=dsm output=sh altitude=30 azimuth=205.8 --quiet\n"
            )
        grass = (
            measure(f"""
import subprocess
subprocess.run(["grass", "--tmp-location", {dsm!r}, "--exec", "bash", {script!r}], check=True,
               capture_output=True)
""")
            if shutil.which("grass")
            else {"error": "grass not installed"}
        )
        ours_hs = measure(f"""
import rasterio
from geoboresight.shadow.incidence import hillshade
with rasterio.open({dsm!r}) as s: z = s.read(1); tr = s.transform
h = hillshade(z, sun_zenith=60.0, sun_azimuth=205.8, transform=tr)
""")
        out = os.path.join(tmp, "hs.tif")
        gdal = (
            measure(f"""
import subprocess
subprocess.run(["gdaldem", "hillshade", "-q", "-az", "205.8", "-alt", "30", {dsm!r}, {out!r}],
               check=True)
""")
            if shutil.which("gdaldem")
            else {"error": "gdaldem not installed"}
        )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    def row(name, r, ref, external=False):
        if external and "error" not in r:
            # ru_maxrss of the wrapper does not include the external tool's own process.
            return (
                f"| {name} | {r['seconds']:.2f} | n/a (external process) | "
                f"{r['seconds'] / ref['seconds']:.2f} | — |"
            )
        if "error" in r:
            return f"| {name} | failed: {r['error']} | — | — | — |"
        ratio = lambda k: f"{r[k] / ref[k]:.2f}" if "error" not in ref else "—"  # noqa: E731
        return f"| {name} | {r['seconds']:.2f} | {r['peak_mib']:.0f} | {ratio('seconds')} | {ratio('peak_mib')} |"

    lines = [
        "",
        "## Shadow (sun-shadow ground truth)",
        "",
        f"{a.size} × {a.size} DSM, 1 m cells, zenith 60°, azimuth 205.8°; each case in its own "
        "process (peak = ru_maxrss, includes the interpreter/libraries). Command: "
        "`python benchmarks/shadow.py --append benchmarks/RESULTS.md`.",
        "",
        "| case | time (s) | peak memory (MB) | time ratio vs ours | memory ratio vs ours |",
        "|---|---|---|---|---|",
        row("geoboresight cast_shadow (ray march, whole-array shifts)", ours_cast, ours_cast),
        row("GRASS r.sunmask (incl. GRASS start-up + r.in.gdal)", grass, ours_cast, True),
        row("geoboresight hillshade (Horn)", ours_hs, ours_hs),
        row("gdaldem hillshade (incl. writing the GeoTIFF)", gdal, ours_hs, True),
        "",
    ]
    text = "\n".join(lines)
    print(text)
    if a.append:
        with open(a.append, "a") as f:
            f.write(text + "\n")


if __name__ == "__main__":
    main()
