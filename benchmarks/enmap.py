"""Benchmark: RX and SVDD on a full-size EnMAP L1B scene, co-registered and not, in RX-limits.

    .venv/bin/python benchmarks/enmap.py [--rows 1000] [--cols 1000] [--workdir /tmp] [--keep]

1. **The scene.** An EnMAP L1B product laid out as delivered (``tests/products_space.py``'s
   ``write_enmap_l1b``, after GFZ EnPT's reader and EnMAP-Box's importer: ``METADATA.XML``,
   int16 ``SPECTRAL_IMAGE_VNIR``/``_SWIR`` GeoTIFFs, band-interleaved, the quality pixel masks)
   with a real product's 91 VNIR bands (418–993 nm) and 133 SWIR bands (904–2,429 nm), 1,000
   × 1,000 pixels: 0.45 GB of DN, read through GDAL (a VRT scales DN to radiance and masks
   the defective pixels). Its files are read once before any timing.
2. **The operations**, each its own process through the command line (start-up included),
   sharing one cache folder: ``boresight-offset`` first (as a user's first look at the
   scene), then ``rx`` and ``svdd`` with ``--no-coregister`` and with their default (the SWIR
   bands co-registered onto the VNIR grid by the measured offset). Wall time and peak RSS
   come from ``os.wait4``.
3. **The unit: RX's streamed limit** on this scene, before and after the operations (their
   mean): ``benchmarks/flightline.py``'s process that only reads the cube strip by strip and
   runs the covariance ``syrk`` and the whitening GEMMs twice.

Prints a Markdown table; record it in ``benchmarks/RESULTS.md`` with the commit.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

from flightline import EXE, RX_LIMIT, leave, load, run, settle, table, work_folder

from geoboresight.io.cache import CACHE_ENV

HERE = os.path.dirname(os.path.abspath(__file__))
#: The scene, with a real EnMAP L1B product's bands: 91 VNIR, 133 SWIR, over the same ranges.
WRITE = """
import sys
import numpy as np
sys.path.insert(0, sys.argv[1])
from tests.products_space import write_enmap_l1b
write_enmap_l1b(sys.argv[2], rows=int(sys.argv[3]), cols=int(sys.argv[4]),
                vnir_wl=np.linspace(418.0, 993.0, 91), swir_wl=np.linspace(904.0, 2429.0, 133))
"""


def make_scene(folder: str, rows: int, cols: int) -> str:
    """The product, written by a process of its own: this one must stay small, because a
    child started with ``fork``/``vfork`` carries its parent's peak RSS into its own."""
    root = os.path.dirname(HERE)
    subprocess.run([sys.executable, "-c", WRITE, root, folder, str(rows), str(cols)], check=True)
    settle([os.path.join(folder, name) for name in os.listdir(folder)])
    return folder


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=1000)
    ap.add_argument("--cols", type=int, default=1000)
    ap.add_argument("--workdir")
    ap.add_argument("--keep", action="store_true")
    args = ap.parse_args(argv)
    if min(args.rows, args.cols) < 64:
        ap.error("--rows and --cols: at least 64 pixels (the offset is measured on blocks)")
    work, log = work_folder(ap, args.workdir, "gb-enmap-")
    try:
        scene = make_scene(os.path.join(work, "L1B"), args.rows, args.cols)
        out = os.path.join(work, "out")
        os.makedirs(out)
        os.environ[CACHE_ENV] = os.path.join(work, "cache")
        limit = [sys.executable, "-c", RX_LIMIT, scene, ""]
        ops = {
            "boresight-offset": ["boresight-offset", "--vnir", scene],
            "rx --no-coregister": ["rx", "--vnir", scene, "--no-coregister"],
            "rx (co-registered, the default)": ["rx", "--vnir", scene],
            "svdd --no-coregister": ["svdd", "--vnir", scene, "--no-coregister"],
            "svdd (co-registered, the default)": ["svdd", "--vnir", scene],
        }
        limits = [run(limit, log)]
        print(f"  RX limit            {limits[-1]['seconds']:7.1f} s", flush=True)
        res = {}
        for i, (name, cmd) in enumerate(ops.items()):
            target = os.path.join(out, f"{i}.json" if name == "boresight-offset" else f"{i}.tif")
            res[name] = run([EXE, *cmd, "--output", target], log)
            r = res[name]
            flag = "" if r["status"] == 0 else f"  FAILED ({r['status']}): see {log}"
            print(f"  {name:34s} {r['seconds']:6.1f} s  {r['peak_gb']:.3f} GB{flag}", flush=True)
        limits.append(run(limit, log))
        print(f"  RX limit            {limits[-1]['seconds']:7.1f} s", flush=True)
        if any(r["status"] for r in [*limits, *res.values()]):
            print(f"an operation failed: see {log}", file=sys.stderr)
            return 1
        unit = sum(r["seconds"] for r in limits) / len(limits)
        seconds = ", ".join(f"{r['seconds']:.1f}" for r in limits)
        print(
            f"\nEnMAP L1B {args.rows} × {args.cols} px, 91 + 133 bands; load average now "
            f"{load()}; RX limit {seconds} s (unit: "
            f"their mean, {unit:.1f} s)\n"
        )
        rows = [
            (name, f"{r['seconds']:.1f}", f"{r['seconds'] / unit:.2f}", f"{r['peak_gb']:.2f}")
            for name, r in res.items()
        ]
        print(table(rows, ("operation", "wall (s)", "RX-limits", "peak RSS (GB)")))
        for op in ("rx", "svdd"):
            a = res[f"{op} (co-registered, the default)"]["seconds"]
            b = res[f"{op} --no-coregister"]["seconds"]
            print(f"\n{op}: co-registered / not = {a / b:.2f}")
    finally:
        leave(work, args.keep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
