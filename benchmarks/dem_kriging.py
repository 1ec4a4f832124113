"""Benchmark: the relative DEM of a 286 × 2,000 scene in bounded memory, beside PyKrige's default.

    .venv/bin/python benchmarks/dem_kriging.py [--update benchmarks/RESULTS.md]

Every case runs in a fresh subprocess. Peak memory is that process's peak resident set size
(``ru_maxrss`` from ``os.wait4``, so it is known even for a killed process). A watchdog polls
``/proc/<pid>/status`` (``VmRSS``) every 0.1 s and kills the child when it exceeds 12 GB, so
PyKrige's default cannot exhaust the machine (2 cores and 24 GB shared with other jobs); before
each PyKrige case the script waits until 13 GB are available (``MemAvailable``), or reports
the case as not run.

Cases (the same 286 × 2,000 grid, 572,000 pixels; the same random control points per N):

- ``pykrige N``: ``OrdinaryKriging(x, y, z, variogram_model="spherical").execute("grid", ...)``
  with PyKrige's defaults (vectorised backend: an (N grid points × N control points) system);
- ``pykrige-local N``: the same with PyKrige's own moving window
  (``execute("grid", ..., backend="C", n_closest_points=32)``), the closest peer to ours: its
  constructor still fits the variogram on all N × N point pairs;
- ``ours N``: geoboresight's kriging (:func:`geoboresight.dem.kriging.krige_grid`: variogram
  fitted by PyKrige on ≤ 2,000 points, then blocks of targets sharing one neighbourhood (each
  target keeps its 32 nearest points), one batched LU per block, on nodes every range/40 px
  interpolated bilinearly; PyKrige's kriging system, compared with PyKrige in tests/test_dem.py);
- ``chain``: geoboresight's whole relative-DEM chain (offset, disparity, heights, ≥ 20,000
  control points, variogram fit, local kriging of every pixel, cross-validation) on a
  synthetic textured pair of 286 × 2,000 pixels.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import sys
import threading
import time

ROWS, COLS = 2000, 286
RSS_LIMIT = 12 * 1024**3
NEED_AVAILABLE = 13 * 1024**3
HEADING = "## Relative DEM"


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

    out: dict = {"case": name, "points": n}
    if name == "chain":
        sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests"))
        from dem_synth import bump, pair

        from geoboresight.dem.height import HeightFactor
        from geoboresight.dem.relative import relative_dem

        h = bump(ROWS, COLS)
        v, s, _, _ = pair(ROWS, COLS, dsm=h, noise=5.0)
        t0 = time.perf_counter()
        r = relative_dem(v, s, factor=HeightFactor(1 / 30), point_spacing=5)
        ok = np.isfinite(r.dem)
        e = r.dem[ok] - h[ok]
        out.update(
            points=int(r.points[0].size), rmse_m=float(np.sqrt(np.mean((e - e.mean()) ** 2)))
        )
    elif name == "ours":
        from geoboresight.dem.kriging import fit_variogram, krige_grid

        x, y, z = _points(n)
        t0 = time.perf_counter()
        vg = fit_variogram(x, y, z)
        dem, _ = krige_grid(x, y, z, (ROWS, COLS), vg, n_closest_points=32)
        out["mean"] = float(np.nanmean(dem))
    elif name == "pykrige":
        from pykrige.ok import OrdinaryKriging

        x, y, z = _points(n)
        t0 = time.perf_counter()
        ok = OrdinaryKriging(x, y, z, variogram_model="spherical")
        dem, _ = ok.execute("grid", np.arange(COLS, dtype=float), np.arange(ROWS, dtype=float))
        out["mean"] = float(np.mean(dem))
    elif name == "pykrige-local":
        from pykrige.ok import OrdinaryKriging

        x, y, z = _points(n)
        t0 = time.perf_counter()
        ok = OrdinaryKriging(x, y, z, variogram_model="spherical")
        dem, _ = ok.execute(
            "grid",
            np.arange(COLS, dtype=float),
            np.arange(ROWS, dtype=float),
            backend="C",
            n_closest_points=32,
        )
        out["mean"] = float(np.mean(dem))
    else:
        raise SystemExit(f"unknown case {name}")
    out["seconds"] = time.perf_counter() - t0
    return out


def _status_kb(pid: int, key: str) -> int | None:
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as f:
            m = re.search(rf"^{key}:\s+(\d+) kB", f.read(), re.M)
        return int(m.group(1)) if m else None
    except OSError:
        return None


def _available() -> int:
    with open("/proc/meminfo", encoding="ascii") as f:
        return int(re.search(r"^MemAvailable:\s+(\d+) kB", f.read(), re.M).group(1)) * 1024


def run_subprocess(name: str, n: int, timeout: float = 1800.0) -> dict:
    """Run a case in a fresh interpreter under the RSS watchdog; its figures or its failure."""
    row = {"case": name, "points": n}
    if name.startswith("pykrige"):
        deadline = time.time() + 120
        while _available() < NEED_AVAILABLE and time.time() < deadline:
            time.sleep(5)
        if _available() < NEED_AVAILABLE:
            row["error"] = f"not run: only {_available() / 1024**3:.1f} GB available"
            return row
    cmd = [sys.executable, os.path.abspath(__file__), "--case", name, str(n)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed = {}

    def watchdog():
        while proc.poll() is None:
            rss = _status_kb(proc.pid, "VmRSS")
            if rss is not None and rss * 1024 > RSS_LIMIT:
                killed["rss"] = rss * 1024
                os.kill(proc.pid, signal.SIGKILL)
                return
            if time.perf_counter() - t0 > timeout:
                killed["timeout"] = True
                os.kill(proc.pid, signal.SIGKILL)
                return
            time.sleep(0.1)

    guard = threading.Thread(target=watchdog, daemon=True)
    guard.start()
    # Drain the pipes in threads, then reap the child with wait4 to read its own peak RSS.
    chunks = {"out": "", "err": ""}

    def drain(stream, key):
        chunks[key] = stream.read()

    readers = [
        threading.Thread(target=drain, args=(proc.stdout, "out")),
        threading.Thread(target=drain, args=(proc.stderr, "err")),
    ]
    for t in readers:
        t.start()
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    for t in readers:
        t.join()
    guard.join(timeout=1)
    wall = time.perf_counter() - t0
    row["peak_mb"] = usage.ru_maxrss / 1024  # kB on Linux
    if "rss" in killed:
        row["error"] = (
            f"killed by the watchdog above {RSS_LIMIT / 1024**3:.0f} GB "
            f"(resident {killed['rss'] / 1024**3:.1f} GB after {wall:.0f} s)"
        )
        return row
    if "timeout" in killed:
        row["error"] = f"killed after {timeout:.0f} s"
        return row
    if proc.returncode != 0:
        tail = (chunks["err"].strip().splitlines() or ["failed"])[-1]
        row["error"] = f"failed: {tail[:140]}"
        return row
    row.update(json.loads(chunks["out"].strip().splitlines()[-1]))
    return row


def table(rows: list[dict]) -> str:
    ours = {r["points"]: r for r in rows if r["case"] == "ours" and "error" not in r}
    label = {
        "chain": "geoboresight relative-DEM chain (matching + kriging + cross-validation)",
        "ours": "geoboresight kriging (variogram fit + blocks of targets sharing one local neighbourhood, one LU per block, nodes every range/40 px)",
        "pykrige": "PyKrige default: `OrdinaryKriging(...).execute('grid')` (vectorised)",
        "pykrige-local": "PyKrige moving window: `execute('grid', backend='C', n_closest_points=32)`",
    }
    lines = [
        "| control points | case | time (s) | peak RSS (MB) | time ratio PyKrige / ours | "
        "memory ratio PyKrige / ours |",
        "|---|---|---|---|---|---|",
    ]
    rank = {"pykrige": 0, "pykrige-local": 1, "ours": 2, "chain": 3}
    order = sorted(rows, key=lambda r: (r["case"] == "chain", r["points"], rank[r["case"]]))
    for r in order:
        name = label[r["case"]]
        if r["case"] == "chain" and "rmse_m" in r:
            name += f", DEM RMSE {r['rmse_m']:.2f} m"
        peak = f"{r['peak_mb']:,.0f}" if "peak_mb" in r else "—"
        if "error" in r:
            lines.append(f"| {r['points']:,} | {name} | {r['error']} | ≥ {peak} | — | — |")
            continue
        ref = ours.get(r["points"]) if r["case"].startswith("pykrige") else None
        rt = f"{r['seconds'] / ref['seconds']:.1f}×" if ref else ""
        rm = f"{r['peak_mb'] / ref['peak_mb']:.1f}×" if ref else ""
        lines.append(f"| {r['points']:,} | {name} | {r['seconds']:.1f} | {peak} | {rt} | {rm} |")
    return "\n".join(lines)


def replace_section(path: str, text: str) -> None:
    """Replace the '## Relative DEM' section of ``path`` (up to the next '## ') by ``text``."""
    with open(path, encoding="utf-8") as f:
        content = f.read()
    start = content.find(HEADING + "\n")
    if start < 0:
        content = content.rstrip("\n") + "\n\n" + text
    else:
        nxt = content.find("\n## ", start + len(HEADING))
        tail = content[nxt + 1 :] if nxt >= 0 else ""
        content = content[:start] + text + ("\n" + tail if tail else "")
    with open(path, "w", encoding="utf-8") as f:
        f.write(content)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", nargs=2, metavar=("NAME", "N"))
    ap.add_argument("--update", help="replace the '## Relative DEM' section of this Markdown file")
    ap.add_argument("--pykrige-sizes", default="500,1000,2000,5000")
    ap.add_argument("--local-sizes", default="5000,22000")
    ap.add_argument("--ours-sizes", default="500,1000,2000,5000,22000")
    args = ap.parse_args(argv)
    if args.case:
        print(json.dumps(case(args.case[0], int(args.case[1]))))
        return 0
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    avail = _available() / 1024**3
    rows = []
    for n in (int(s) for s in args.ours_sizes.split(",")):
        rows.append(run_subprocess("ours", n))
        print(rows[-1], flush=True)
    rows.append(run_subprocess("chain", 0))
    print(rows[-1], flush=True)
    for n in (int(s) for s in args.pykrige_sizes.split(",")):
        rows.append(run_subprocess("pykrige", n))
        print(rows[-1], flush=True)
    for n in (int(s) for s in args.local_sizes.split(",") if s):
        rows.append(run_subprocess("pykrige-local", n))
        print(rows[-1], flush=True)
    import numpy
    import pykrige

    text = "\n".join(
        [
            HEADING,
            "",
            f"Ordinary kriging of every pixel of a {COLS} × {ROWS:,} grid ({COLS * ROWS:,} pixels), "
            "each case in a fresh subprocess; peak RSS = the child's `ru_maxrss` (from `os.wait4`, "
            "includes ~100–150 MB of interpreter and libraries); a watchdog polling "
            f"`/proc/<pid>/status` kills a child whose resident memory exceeds "
            f"{RSS_LIMIT / 1024**3:.0f} GB (its peak is then a lower bound). "
            f"One run, {started}, PyKrige {pykrige.__version__}, NumPy {numpy.__version__}, "
            f"{os.cpu_count()} cores shared with other engineers' jobs ({avail:.0f} GB available "
            "at the start), so times are indicative. Command: "
            "`python benchmarks/dem_kriging.py --update benchmarks/RESULTS.md`.",
            "",
            table(rows),
            "",
        ]
    )
    print(text)
    if args.update:
        replace_section(args.update, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
