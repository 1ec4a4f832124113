"""Benchmark: the relative DEM of a 286 × 2,000 scene in bounded memory, beside PyKrige's default.

    /work/.venv-dev/bin/python benchmarks/dem_kriging.py [--append benchmarks/RESULTS.md]

Each case runs in its own subprocess (peak memory = that process's ru_maxrss; a failure or an
out-of-memory kill does not stop the script). PyKrige's default vectorised ordinary kriging
builds an (N grid points × N control points) distance matrix: it is measured at sizes that fit
(500 / 1,000 / 2,000 points), under an address-space limit of 12 GB so that it fails cleanly
instead of exhausting the machine.

Cases (same 286 × 2,000 grid, 572,000 pixels):
- ``chain``: geoboresight's whole relative-DEM chain (offset, disparity, heights, ≥ 20,000 control
  points, variogram fit, local kriging of every pixel, cross-validation) on a synthetic pair;
- ``ours N``: geoboresight's blockwise local kriging (32 neighbours, C backend) of N points;
- ``pykrige N``: ``OrdinaryKriging(...).execute("grid", ...)`` with its defaults (vectorised).
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

ROWS, COLS = 2000, 286
LIMIT_BYTES = 12 * 1024**3


def _points(n, seed=0):
    import numpy as np

    rng = np.random.default_rng(seed)
    x = rng.uniform(0, COLS - 1, n)
    y = rng.uniform(0, ROWS - 1, n)
    z = 15 * np.sin(y / 150) + 8 * np.cos(x / 40) + rng.normal(0, 0.5, n)
    return x, y, z


def case(name: str, n: int) -> dict:
    """Run one case in this process; return its figures."""
    import numpy as np

    t0 = time.perf_counter()
    out: dict = {"case": name, "points": n}
    if name == "chain":
        sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "tests"))
        from dem_synth import bump, pair

        from geoboresight.dem.height import HeightFactor
        from geoboresight.dem.relative import relative_dem

        h = bump(ROWS, COLS)
        v, s, _, _ = pair(ROWS, COLS, dsm=h, noise=5.0)
        t0 = time.perf_counter()
        r = relative_dem(v, s, HeightFactor(1 / 30), point_spacing=5)
        ok = np.isfinite(r.dem)
        e = r.dem[ok] - h[ok]
        out.update(
            points=int(r.points[0].size), rmse_m=float(np.sqrt(np.mean((e - e.mean()) ** 2)))
        )
    elif name == "ours":
        from geoboresight.dem.kriging import fit_variogram, krige_grid

        x, y, z = _points(n)
        vg = fit_variogram(x, y, z)
        dem, _ = krige_grid(x, y, z, (ROWS, COLS), vg, n_closest_points=32, backend="C")
        out["mean"] = float(np.nanmean(dem))
    elif name == "pykrige":
        from pykrige.ok import OrdinaryKriging

        x, y, z = _points(n)
        ok = OrdinaryKriging(x, y, z, variogram_model="spherical")
        dem, _ = ok.execute("grid", np.arange(COLS, dtype=float), np.arange(ROWS, dtype=float))
        out["mean"] = float(np.mean(dem))
    out["seconds"] = time.perf_counter() - t0
    out["peak_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return out


def run_subprocess(name: str, n: int) -> dict:
    cmd = [sys.executable, __file__, "--case", name, str(n)]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        tail = (proc.stderr.strip().splitlines() or ["killed"])[-1]
        return {"case": name, "points": n, "error": tail[:120], "returncode": proc.returncode}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--case", nargs=2, metavar=("NAME", "N"))
    ap.add_argument("--append", help="append the table to this Markdown file")
    ap.add_argument("--sizes", default="500,1000,2000")
    args = ap.parse_args(argv)
    if args.case:
        if args.case[0] == "pykrige":
            resource.setrlimit(resource.RLIMIT_AS, (LIMIT_BYTES, LIMIT_BYTES))
        print(json.dumps(case(args.case[0], int(args.case[1]))))
        return 0
    sizes = [int(s) for s in args.sizes.split(",")]
    rows = [run_subprocess("chain", 0)]
    for n in sizes + [22000]:
        rows.append(run_subprocess("ours", n))
    for n in sizes:
        rows.append(run_subprocess("pykrige", n))
    ours = {r["points"]: r for r in rows if r["case"] == "ours"}
    lines = [
        "## Relative DEM",
        "",
        f"Kriging every pixel of a {COLS} × {ROWS} scene ({COLS * ROWS:,} pixels); each case in its "
        f"own process, peak = ru_maxrss (includes ~150 MB of interpreter and libraries). "
        f"PyKrige default = `OrdinaryKriging(..., 'spherical').execute('grid', ...)` "
        f"(vectorised backend), run under a {LIMIT_BYTES / 1024**3:.0f} GB address-space limit. "
        f"Machine: {os.cpu_count()} cores shared with other jobs. "
        "Command: `python benchmarks/dem_kriging.py --append benchmarks/RESULTS.md`.",
        "",
        "| case | control points | time (s) | peak memory (MB) | time ratio vs ours | memory ratio vs ours |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        label = {
            "chain": "geoboresight relative-DEM chain (matching + kriging + cross-validation)",
            "ours": "geoboresight local kriging (32 neighbours, blockwise, C backend)",
            "pykrige": "PyKrige default vectorised ordinary kriging",
        }[r["case"]]
        if "error" in r:
            lines.append(f"| {label} | {r['points']:,} | failed: {r['error']} | — | — | — |")
            continue
        ref = ours.get(r["points"]) if r["case"] == "pykrige" else None
        ratio_t = f"{r['seconds'] / ref['seconds']:.1f}×" if ref and "seconds" in ref else ""
        ratio_m = f"{r['peak_mb'] / ref['peak_mb']:.1f}×" if ref and "peak_mb" in ref else ""
        extra = f" (DEM RMSE {r['rmse_m']:.2f} m)" if "rmse_m" in r else ""
        lines.append(
            f"| {label}{extra} | {r['points']:,} | {r['seconds']:.1f} | {r['peak_mb']:.0f} | {ratio_t} | {ratio_m} |"
        )
    text = "\n".join(lines) + "\n"
    print(text)
    if args.append:
        with open(args.append, "a", encoding="utf-8") as f:
            f.write("\n" + text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
