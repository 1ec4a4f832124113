"""Benchmark: radiance from raw DN, written and on the fly, on an AisaFENIX-like flight line.

A raw capture (uint16 BIL, 64 bands: 32 VNIR with tint1, 32 SWIR with tint2; 256 samples;
its Specim header, dark frames after the image, a frame counter) and its calibration (.cal)
are written for each line length. Each case runs in a fresh process (wall time, peak RSS):

* ``radiance``: the whole cube through the calibration into a float32 ENVI BIL cube, and
  into a GeoTIFF (compressed, with overviews);
* ``cube read``: every band of the same line read in strips, as the cube operations read it
  (``io.open_cube`` of the capture's image): the floor of any operation over the whole cube;
* ``ratio`` in DN and ``ratio`` with ``--vnir-calibration`` (radiance on the fly).

Reported: radiance (ENVI BIL, GeoTIFF) / cube read, on-the-fly ratio / DN ratio (the same run), and the peaks at
each length (memory must stay flat as the line grows).

    python benchmarks/radiance.py [--lines 5000,20000] [--work DIR] [--keep]
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _measure import measure  # noqa: E402

BANDS, SAMPLES, DARK = 64, 256, 100
WL = np.r_[np.linspace(880.0, 970.0, 32), np.linspace(980.0, 1290.0, 32)]


def write_capture(folder: str, lines: int, seed: int = 0) -> tuple[str, str]:
    """A raw capture of ``lines`` image lines and its calibration; (header, calibration)."""
    os.makedirs(folder, exist_ok=True)
    rng = np.random.default_rng(seed)
    gain = rng.uniform(0.5, 1.5, (BANDS, SAMPLES)).astype("<f4")
    dark = np.where(np.arange(BANDS)[:, None] < 32, 150, 1500) + rng.integers(
        0, 40, (BANDS, SAMPLES)
    )
    data = os.path.join(folder, "capture.raw")
    total = lines + DARK
    out = np.memmap(data, "<u2", "w+", shape=(total, BANDS, SAMPLES))
    for r0 in range(0, total, 1000):
        r1 = min(total, r0 + 1000)
        rows = np.arange(r0, r1)
        light = (rows < lines)[:, None, None]
        # Image lines: dark + signal; dark lines (after the image): dark + read noise.
        signal = np.where(light, rng.integers(0, 1500, (r1 - r0, BANDS, SAMPLES)), 0)
        block = dark[None] + signal + rng.integers(-3, 4, (r1 - r0, BANDS, SAMPLES))
        block[:, 0, 0] = (1000 + rows + np.where(rows >= lines, 36, 0)) % 65536
        block[:, 0, 1] = 0
        out[r0:r1] = block
    out.flush()
    del out
    wl = "{" + ", ".join(f"{w:.3f}" for w in WL) + "}"
    with open(os.path.join(folder, "capture.hdr"), "w") as f:
        f.write(
            f"ENVI\nsamples = {SAMPLES}\nlines = {total}\nbands = {BANDS}\nheader offset = 0\n"
            "data type = 12\ninterleave = bil\nbyte order = 0\nsensorid = 350005\n"
            f"autodarkstartline = {lines}\ntint1 = 28.0\ntint2 = 8.0\nvimg1 = {{1, 32}}\n"
            f"vimg2 = {{33, 64}}\nbinning = {{1, 1}}\nfps = 30\nwavelength = {wl}\n"
        )
    gain.tofile(os.path.join(folder, "cal.cal"))
    with open(os.path.join(folder, "cal.hdr"), "w") as f:
        f.write(
            f"ENVI\nsamples = {SAMPLES}\nlines = 1\nbands = {BANDS}\nheader offset = 0\n"
            f"data type = 4\ninterleave = bil\nbyte order = 0\nsensorid = 350005\n"
            f"binning = {{1, 1}}\nwavelength = {wl}\n"
        )
    return os.path.join(folder, "capture.hdr"), os.path.join(folder, "cal.cal")


CASES = {
    "radiance (ENVI BIL)": "gb.radiance_file(HDR, CAL, output=OUT + '/rad.img', overwrite=True)",
    "radiance (GeoTIFF)": "gb.radiance_file(HDR, CAL, output=OUT + '/rad.tif', overwrite=True)",
    "cube read": (
        "from geoboresight.io import open_dual, open_cube\n"
        "d = open_dual(HDR)\n"
        "cube = open_cube([d.vnir.reads])\n"
        "read = cube.reader(dtype='float32')\n"
        "for r0 in range(0, cube.height, 256):\n"
        "    read(r0, min(cube.height, r0 + 256))"
    ),
    "ratio (DN)": "gb.ratio_file(HDR, output=OUT + '/r_dn.tif', overwrite=True)",
    "ratio (radiance on the fly)": (
        "gb.ratio_file(HDR, output=OUT + '/r_rad.tif', overwrite=True,"
        " layout=gb.DualLayout(vnir_calibration=CAL))"
    ),
}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", default="5000,20000")
    ap.add_argument("--work", default=None)
    ap.add_argument("--keep", action="store_true")
    args = ap.parse_args(argv)
    work = args.work or tempfile.mkdtemp(prefix="gb-radiance-bench-")
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    print(f"load average at start: {os.getloadavg()[0]:.2f}")
    rows = []
    try:
        for n in [int(v) for v in args.lines.split(",")]:
            folder = os.path.join(work, f"line{n}")
            hdr, cal = write_capture(folder, n)
            res = {}
            for name, body in CASES.items():
                code = (
                    f"import sys; sys.path.insert(0, {repo!r})\nimport geoboresight as gb\n"
                    f"HDR, CAL, OUT = {hdr!r}, {cal!r}, {folder!r}\n{body}"
                )
                res[name] = measure(code)
                print(n, name, res[name], flush=True)
            rows.append((n, res))
    finally:
        print(f"load average at end: {os.getloadavg()[0]:.2f}")
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    print("\n| lines | case | seconds | peak MiB |\n|---|---|---|---|")
    for n, res in rows:
        for name, r in res.items():
            print(
                f"| {n} | {name} | {r.get('seconds', float('nan')):.2f} | {r.get('peak_mib', float('nan')):.0f} |"
            )
    print(
        "\n| lines | radiance .img / cube read | radiance .tif / cube read "
        "| on-the-fly ratio / DN ratio |\n|---|---|---|---|"
    )
    for n, res in rows:
        read = res["cube read"]["seconds"]
        a = res["radiance (ENVI BIL)"]["seconds"] / read
        t = res["radiance (GeoTIFF)"]["seconds"] / read
        b = res["ratio (radiance on the fly)"]["seconds"] / res["ratio (DN)"]["seconds"]
        print(f"| {n} | {a:.2f} | {t:.2f} | {b:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
