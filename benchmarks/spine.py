"""Boresight ratio and statistics on a long flight line: geoboresight (streamed) vs the peer a
rasterio user would write (read the whole bands, NumPy divide; SciPy/NumPy statistics in memory).

    python benchmarks/spine.py [--lines 200000]

Prints a table of wall time and peak memory (each run in a fresh process) and the ratios.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile

import numpy as np
from _measure import measure


def make_scene(folder: str, lines: int, cols: int = 286, block: int = 5000) -> tuple[str, str]:
    """Two 4-band int16 ENVI files (VNIR with 920 nm, SWIR with 1010 nm), written blockwise."""
    import rasterio
    from rasterio.windows import Window

    from geoboresight.io import quiet_georef

    paths = []
    for name, wl in (("vnir", [800, 880, 920, 960]), ("swir", [1010, 1200, 1600, 2200])):
        path = os.path.join(folder, f"{name}.img")
        prof = dict(
            driver="ENVI", width=cols, height=lines, count=4, dtype="int16", interleave="bil"
        )
        rng = np.random.default_rng(len(name))
        with quiet_georef(), rasterio.open(path, "w", **prof) as dst:
            dst.update_tags(
                ns="ENVI",
                wavelength="{" + ",".join(map(str, wl)) + "}",
                wavelength_units="Nanometers",
            )
            for r in range(0, lines, block):
                h = min(block, lines - r)
                dst.write(
                    rng.integers(1, 4000, (4, h, cols), dtype="int16"), window=Window(0, r, cols, h)
                )
        paths.append(path)
    return paths[0], paths[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--lines", type=int, default=200_000)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="gb-bench-")
    try:
        v, s = make_scene(tmp, args.lines)
        ours_ratio = measure(f"""
from geoboresight.algorithms import get
get("ratio")(vnir={v!r}, swir={s!r}, output={tmp!r} + "/ours.tif")
""")
        peer_ratio = measure(f"""
import numpy as np, rasterio, warnings
warnings.simplefilter("ignore")
with rasterio.open({s!r}) as a, rasterio.open({v!r}) as b:
    num = a.read(1).astype("float32"); den = b.read(3).astype("float32"); prof = b.profile
with np.errstate(divide="ignore", invalid="ignore"):
    r = np.where(den > 0, num / den, -9999).astype("float32")
prof.update(driver="GTiff", count=1, dtype="float32", nodata=-9999, tiled=True, blockxsize=256, blockysize=256, compress="deflate", interleave="band")
with rasterio.open({tmp!r} + "/peer.tif", "w", **prof) as d:
    d.write(r, 1)
""")
        ours_stats = measure(f"""
from geoboresight.algorithms import get
get("stats")(input={tmp!r} + "/ours.tif", output={tmp!r} + "/ours.json")
""")
        peer_stats = measure(f"""
import numpy as np, rasterio, scipy.stats as st
with rasterio.open({tmp!r} + "/peer.tif") as a:
    x = a.read(1, masked=True).compressed().astype("float64")
out = dict(n=x.size, mean=x.mean(), std=x.std(ddof=1), skew=st.skew(x, bias=False),
           kurt=st.kurtosis(x, bias=False), pct=np.percentile(x, [1, 5, 25, 50, 75, 95, 99]),
           hist=np.histogram(x, 50), out=(np.abs(x - x.mean()) > 3 * x.std(ddof=1)).sum())
""")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    rows = [
        ("ratio", ours_ratio, peer_ratio, "rasterio full read + NumPy"),
        ("stats", ours_stats, peer_stats, "NumPy/SciPy in memory"),
    ]
    print(
        f"flight line: 286 x {args.lines} pixels ({286 * args.lines * 4 / 2**20:.0f} MiB as float32)"
    )
    print(
        "| operation | geoboresight s | peer s | time ratio | geoboresight peak MiB | peer peak MiB | memory ratio | peer |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, o, p, peer in rows:
        if "error" in o or "error" in p:
            print(f"| {name} | {o} | {p} | | | | | {peer} |")
            continue
        print(
            f"| {name} | {o['seconds']:.2f} | {p['seconds']:.2f} | {o['seconds'] / p['seconds']:.2f}x "
            f"| {o['peak_mib']:.0f} | {p['peak_mib']:.0f} | {o['peak_mib'] / p['peak_mib']:.2f}x | {peer} |"
        )


if __name__ == "__main__":
    main()
