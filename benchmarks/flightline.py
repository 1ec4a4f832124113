"""Benchmark: every product of a whole flight line, wall time and peak memory per operation.

    .venv/bin/python benchmarks/flightline.py [--lines 20000] [--memory-lines 5000,20000,80000]
        [--memory-ops boresight-offset,relative-dem] [--workdir /tmp] [--no-rx-limit]

1. **The line.** A scene is simulated once (``geoboresight simulate --preset mixed --geometry
   large-squint``, ``--tile`` lines, default 500) and tiled along-track into a flight line of
   ``--lines`` lines (ENVI BIL uint16, 286 columns, VNIR 96 + SWIR 102 bands: 20,000 lines =
   2.27 GB). BIL stores a line after another, so tiling repeats the files' bytes. The files
   are flushed to disk (``os.sync``) and read once before any timing: a freshly written 2 GB
   file read while the kernel is still flushing it was measured 60× slower. With
   ``--geotiff`` the main line is rewritten as tiled (256), band-interleaved, deflated
   GeoTIFFs with the same band tags: every band is then read through GDAL, not the raw files.
2. **Nine operations and the report**, each as its own process through the command line, one
   after another as a user (or ``report``) would, sharing one cache folder (the boresight
   offset is measured by the first operation that needs it): ``ratio``, ``stats``, ``shadow-classes``,
   ``shadow-cluster``, ``boresight-offset``, ``relative-dem``, ``rx``, ``svdd``,
   ``boresight-indicator``; then, outside their sum, ``--also`` (default ``shadow-map`` and
   ``deshadow`` on its fraction), then ``report --products``. Wall time and peak RSS come from
   ``os.wait4`` (the child's ``ru_maxrss``; the children are started by ``posix_spawn``/
   ``vfork``, so they do not inherit this process's peak, which stays small anyway).
3. **Memory in line length**: the same (or the ``--memory-ops``) operations on lines of
   ``--memory-lines`` lines; peak at the longest ÷ peak at the shortest.
4. **The unit: RX's streamed limit**, in the same run, before and after the nine operations
   (their mean): a process that only reads the cube block by block (same strips, threads and
   bands as ``rx``) and runs the covariance ``syrk`` and the whitening GEMMs (the same
   triangular blocks), twice over the line. Every operation is printed in RX-limits; ``rx``
   and ``svdd`` are also run alone with the offset not yet measured (a cold cache). The same
   limit on co-registered strips (the SWIR bands shifted by the measured offset, as ``rx``
   reads them) is run once: ``rx`` against it is what ``rx`` adds beyond co-registration's
   own arithmetic. Rerun this
   script and record its tables in ``benchmarks/RESULTS.md`` with the commit whenever a change
   touches a default or a hot path.
5. **Before and after** (``--alternate TREE,TREE,...``): only the ``--also`` operations,
   each code tree in turn through ``PYTHONPATH`` (a checkout, or ``git archive COMMIT`` unpacked),
   a first round not kept (it fills the page cache and measures the offset into the shared
   cache folder), then ``--rounds`` rounds; wall time, CPU time (user + system) and peak RSS
   of each run, with the ratio to the first tree's run of the same round.
6. **Many lines on Dask** (``--batch-jobs N``, 0 skips): ``--batch-op`` on N jobs of a
   ``--batch-lines`` line (every job reads the same line, each writes its own output): one
   after another as processes, ``geoboresight batch --workers 1`` and ``--workers 2`` (a
   ``LocalCluster``), and ``geoboresight batch --scheduler`` against a ``dask scheduler`` and
   two ``dask worker --no-nanny`` processes (one thread each) started separately.

Lines are written in ``--workdir`` (checked for free space first) and deleted at the end
unless ``--keep``. Prints Markdown tables (paste them into benchmarks/RESULTS.md with the
load average printed at the start and the end).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

from geoboresight.io.cache import CACHE_ENV

HERE = os.path.dirname(os.path.abspath(__file__))
EXE = os.path.join(os.path.dirname(sys.executable), "geoboresight")
COLS, BYTES_PER_PIXEL_LINE = 286, 198 * 2
GEOMETRY = {"squint_deg": 3.0, "flying_height": 1500.0, "ifov_mrad": 1.0}  # large-squint
#: One BLAS/OpenMP thread per Dask worker process (what Dask's nannies set).
THREADS = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
NINE = (
    "ratio",
    "stats",
    "shadow-classes",
    "shadow-cluster",
    "boresight-offset",
    "relative-dem",
    "rx",
    "svdd",
    "boresight-indicator",
)


def load() -> str:
    """The 1, 5 and 15 minute load averages (the machine is shared)."""
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def free_gb(path: str) -> float:
    st = os.statvfs(path)
    return st.f_bavail * st.f_frsize / 1e9


def run(cmd: list[str], log: str) -> dict:
    """Run ``cmd``; its wall time (s), CPU time (s), peak RSS (GB) from ``os.wait4`` and
    exit status."""
    with open(log, "ab") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=err)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
    return {
        "seconds": wall,
        "cpu_seconds": usage.ru_utime + usage.ru_stime,
        "peak_gb": usage.ru_maxrss / 1024**2,  # KiB on Linux
        "status": proc.returncode,
        "command": " ".join(os.path.basename(c) if c == EXE else c for c in cmd),
    }


def simulate(work: str, tile: int, seed: int) -> str:
    scene = os.path.join(work, f"scene{tile}")
    if not os.path.exists(os.path.join(scene, "vnir.hdr")):
        subprocess.run(
            [EXE, "simulate", "--preset", "mixed", "--lines", str(tile), "--seed", str(seed)]
            + ["--geometry", "large-squint", "--clouds", "1", "--output", scene],
            check=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    return scene


def make_line(scene: str, out: str, lines: int) -> str:
    """Tile the simulated scene along-track into ``lines`` lines.

    Streamed through a 1 MiB buffer: this process must stay small, because a child started
    with ``fork``/``vfork`` carries its parent's peak RSS into its own ``ru_maxrss``."""
    os.makedirs(out, exist_ok=True)
    buf = bytearray(1 << 20)
    for name in ("vnir", "swir"):
        with open(os.path.join(scene, f"{name}.hdr"), encoding="utf-8") as f:
            hdr = f.read()
        n0 = int(re.search(r"lines\s*=\s*(\d+)", hdr).group(1))
        src_path = os.path.join(scene, f"{name}.img")
        per_line = os.path.getsize(src_path) // n0
        with open(src_path, "rb") as src, open(os.path.join(out, f"{name}.img"), "wb") as dst:
            left = lines
            while left:
                k = min(left, n0)
                src.seek(0)
                todo = k * per_line
                while todo:
                    got = src.readinto(memoryview(buf)[: min(len(buf), todo)])
                    dst.write(memoryview(buf)[:got])
                    todo -= got
                left -= k
        with open(os.path.join(out, f"{name}.hdr"), "w", encoding="utf-8") as f:
            f.write(re.sub(r"lines\s*=\s*\d+", f"lines   = {lines}", hdr))
    settle([os.path.join(out, f"{name}.img") for name in ("vnir", "swir")])
    return out


def as_geotiff(line: str) -> str:
    """The line's two images rewritten as tiled, band-interleaved, deflated GeoTIFFs (their
    band tags, the wavelengths among them, copied), the ENVI files removed: the operations
    then read every band through GDAL, as a line delivered in GeoTIFF is read."""
    code = """
import sys, rasterio, rasterio.shutil
for name in ("vnir", "swir"):
    rasterio.shutil.copy(f"{sys.argv[1]}/{name}.img", f"{sys.argv[1]}/{name}.tif", driver="GTiff",
                         tiled=True, blockxsize=256, blockysize=256, interleave="band",
                         compress="deflate", zlevel=3)
"""
    subprocess.run([sys.executable, "-c", code, line], check=True)
    for name in ("vnir", "swir"):
        for ext in ("img", "hdr"):
            os.remove(os.path.join(line, f"{name}.{ext}"))
    settle([os.path.join(line, f"{name}.tif") for name in ("vnir", "swir")])
    return line


def images(line: str) -> tuple[str, str]:
    """The line's VNIR and SWIR: ENVI headers, or GeoTIFFs after :func:`as_geotiff`."""
    ext = "tif" if os.path.exists(os.path.join(line, "vnir.tif")) else "hdr"
    return os.path.join(line, f"vnir.{ext}"), os.path.join(line, f"swir.{ext}")


def settle(paths) -> None:
    """Let freshly written files reach the disk, then read them once (the page cache then
    holds them, as for any file the user has just copied): no operation pays for the
    kernel's flushing."""
    os.sync()
    buf = bytearray(1 << 20)
    for path in paths:
        with open(path, "rb", buffering=0) as f:
            while f.readinto(buf):
                pass


def commands(line: str, out: str) -> dict[str, list[str]]:
    v, s = images(line)
    o = lambda name: os.path.join(out, name)  # noqa: E731
    geo = [f"--{k.replace('_', '-')}={val}" for k, val in GEOMETRY.items()]
    return {
        "ratio": ["ratio", "--vnir", v, "--swir", s, "--output", o("ratio.tif")],
        "stats": ["stats", "--input", o("ratio.tif"), "--output", o("stats.json")],
        "shadow-classes": [
            "shadow-classes",
            "--ratio",
            o("ratio.tif"),
            "--output",
            o("classes.tif"),
            "--mask",
            o("mask.tif"),
        ],
        "shadow-cluster": [
            "shadow-cluster",
            "--ratio",
            o("ratio.tif"),
            "--vnir",
            v,
            "--output",
            o("cluster.tif"),
        ],
        "boresight-offset": [
            "boresight-offset",
            "--vnir",
            v,
            "--swir",
            s,
            "--output",
            o("offset.json"),
            "--plot",
            o("offset.png"),
        ],
        "relative-dem": ["relative-dem", "--vnir", v, "--swir", s, *geo]
        + ["--output", o("dem.tif"), "--variance", o("dem_var.tif"), "--report", o("dem.json")],
        "rx": ["rx", "--vnir", v, "--swir", s, "--output", o("rx.tif")],
        "svdd": ["svdd", "--vnir", v, "--swir", s, "--output", o("svdd.tif")],
        "boresight-indicator": [
            "boresight-indicator",
            "--ratio",
            o("ratio.tif"),
            "--output",
            o("indicator.tif"),
        ],
        "shadow-map": ["shadow-map", "--vnir", v, "--swir", s, "--output", o("shadow.tif")]
        + ["--fraction", o("shadow_fraction.tif")],
        "deshadow": ["deshadow", "--vnir", v, "--swir", s, "--shadow", o("shadow_fraction.tif")]
        + ["--output", o("deshadowed.tif")],
        "report": ["report", "--vnir", v, "--swir", s, *geo]
        + ["--output", o("report.html"), "--products", o("products")],
    }


_LIMIT = """
import sys, threading, numpy as np
from geoboresight import io
from geoboresight.anomaly.rx import _triangular_blocks
from geoboresight.operations.anomaly import CUBE_BLOCK_ROWS, open_image
cube, bands, _, _ = open_image(sys.argv[1], sys.argv[2] or None)  # "": a product holding both
k = len(bands)
<READER>
strips = dict(height=cube.height, width=cube.width, block_rows=CUBE_BLOCK_ROWS,
              workers=io.windows.default_workers())
local = threading.local()
def buffers(n):
    if getattr(local, "n", 0) < n:
        local.x, local.z, local.n = np.empty((k, n)), np.empty((k, n)), n
    return local.x[:, :n], local.z[:, :n]
def cov(data, valid):  # read + the covariance GEMM (syrk) alone
    x, _ = buffers(data[0].size)
    np.copyto(x, data.reshape(k, -1), casting="unsafe")
    return x @ x.T
total = np.zeros((k, k))
for _, c in io.map_windows(read, cov, **strips):
    total += c
W = _triangular_blocks(np.tril(np.ones((k, k))), np.float64)
def white(data, valid):  # read + the whitening GEMMs alone
    x, z = buffers(data[0].size)
    np.copyto(x, data.reshape(k, -1), casting="unsafe")
    for wb, a, b in W:
        np.matmul(wb, x[:b], out=z[a:b])
for _ in io.map_windows(read, white, **strips):
    pass
"""
RX_LIMIT = _LIMIT.replace("<READER>", "read = cube.reader(bands, None)")
#: The same limit on co-registered strips: the SWIR bands of each strip shifted onto the VNIR
#: grid as ``rx`` shifts them, by the offset ``boresight-offset`` measured (argv 3 and 4).
#: ``rx`` in these units is what it adds beyond co-registration's own arithmetic.
RX_LIMIT_COREGISTERED = _LIMIT.replace(
    "<READER>",
    """from geoboresight.io.dual import DualLayout
from geoboresight.operations.anomaly import _Coregistered, _cube_index, _dual_of
dual = _dual_of(sys.argv[1], sys.argv[2], DualLayout())
is_swir = np.isin(bands, _cube_index(dual, dual.swir))
read = _Coregistered(cube, bands, is_swir, float(sys.argv[3]), float(sys.argv[4])).reader()""",
)


def batch_scaling(scene: str, work: str, jobs: int, lines: int, op: str, log: str) -> list:
    """Wall time of ``jobs`` runs of ``op``: sequential, local Dask clusters, a scheduler."""
    line = make_line(scene, os.path.join(work, f"batch{lines}"), lines)
    rows = []

    def jobs_file(tag: str) -> str:
        out = os.path.join(work, f"batch-{tag}")
        os.makedirs(out, exist_ok=True)
        v, s = os.path.join(line, "vnir.hdr"), os.path.join(line, "swir.hdr")
        extra = {k: v for k, v in GEOMETRY.items()} if op == "relative-dem" else {}
        path = os.path.join(out, "jobs.json")
        with open(path, "w", encoding="utf-8") as f:
            json.dump(
                [
                    {"vnir": v, "swir": s, "output": os.path.join(out, f"{i}.tif"), **extra}
                    for i in range(jobs)
                ],
                f,
            )
        return path

    t0 = time.perf_counter()
    for i in range(jobs):
        path = jobs_file("seq")
        with open(path, encoding="utf-8") as f:
            job = json.load(f)[i]
        args = [f"--{k.replace('_', '-')}={v}" for k, v in job.items()]
        run([EXE, op, *args, "--overwrite"], log)
    seq = time.perf_counter() - t0
    rows.append(("one after another (processes)", f"{seq:.1f}", "1.00×"))
    for n in (1, 2):
        r = run([EXE, "batch", op, jobs_file(f"w{n}"), "--workers", str(n), "--overwrite"], log)
        rows.append((f"`batch --workers {n}` (LocalCluster)", f"{r['seconds']:.1f}", r))
    port = 8786 + os.getpid() % 1000
    dask = os.path.join(os.path.dirname(sys.executable), "dask")
    procs = [
        subprocess.Popen(
            [dask, "scheduler", "--port", str(port), "--dashboard-address", ":0"],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        time.sleep(3)
        for _ in range(2):
            # Without a nanny, as batch's own workers (geoboresight.batch.worker_environ): a
            # nanny would set MALLOC_TRIM_THRESHOLD_, 2–3× slower for these operations.
            procs.append(
                subprocess.Popen(
                    [dask, "worker", f"tcp://127.0.0.1:{port}", "--no-nanny"]
                    + ["--nthreads", "1", "--no-dashboard"],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    env={**os.environ, **THREADS},
                )
            )
        time.sleep(5)
        r = run(
            [EXE, "batch", op, jobs_file("sched"), "--scheduler", f"tcp://127.0.0.1:{port}"]
            + ["--overwrite"],
            log,
        )
        rows.append(
            ("`batch --scheduler` (dask scheduler + 2 worker processes)", f"{r['seconds']:.1f}", r)
        )
    finally:
        for p in reversed(procs):
            p.terminate()
            p.wait()
    shutil.rmtree(line, ignore_errors=True)
    return [
        (
            label,
            sec,
            x
            if isinstance(x, str)
            else (f"{seq / float(sec):.2f}×" if x["status"] == 0 else f"FAILED ({x['status']})"),
        )
        for label, sec, x in rows
    ]


def dem_accuracy(dem_path: str, scene: str, lines: int) -> dict:
    """Pearson r and RMSE (mean difference removed) of a line's relative DEM against the true
    DSM of the simulated scene tiled as the line was, streamed tile by tile (run in a child
    process: this one must stay small)."""
    code = f"""
import json, numpy as np, rasterio
with rasterio.open({os.path.join(scene, "truth_dsm.tif")!r}) as t:
    truth = t.read(1).astype("float64")
n0 = truth.shape[0]
acc = np.zeros(6)  # n, Σx, Σy, Σx², Σy², Σxy
with rasterio.open({dem_path!r}) as d:
    for r0 in range(0, {lines}, n0):
        k = min(n0, {lines} - r0)
        x = d.read(1, window=((r0, r0 + k), (0, d.width))).astype("float64")
        ok = np.isfinite(x) & (x != d.nodata if d.nodata is not None else True)
        x, y = x[ok], truth[:k][ok]
        acc += [x.size, x.sum(), y.sum(), (x * x).sum(), (y * y).sum(), (x * y).sum()]
n, sx, sy, sxx, syy, sxy = acc
cxx, cyy, cxy = sxx - sx * sx / n, syy - sy * sy / n, sxy - sx * sy / n
r = cxy / np.sqrt(cxx * cyy)
rmse = np.sqrt(max(cxx + cyy - 2 * cxy, 0) / n)
print(json.dumps({{"r": float(r), "rmse_m": float(rmse), "pixels": int(n)}}))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def work_folder(ap, workdir: str | None, prefix: str) -> tuple[str, str]:
    """A fresh work folder under ``workdir`` (refused in one line when that is not a folder),
    announced with the load average, and its log of the operations' errors."""
    if workdir and not os.path.isdir(workdir):
        ap.error(f"--workdir {workdir} is not a folder")
    work = tempfile.mkdtemp(prefix=prefix, dir=workdir)
    print(f"work folder {work}; load average {load()}", flush=True)
    return work, os.path.join(work, "stderr.log")


def leave(work: str, keep: bool) -> None:
    """Delete the work folder, or say where it is kept."""
    if keep:
        print(f"kept {work}")
    else:
        shutil.rmtree(work, ignore_errors=True)


def table(rows: list[tuple], header: tuple) -> str:
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def run_ops(line: str, ops, out: str, log: str) -> dict:
    os.makedirs(out, exist_ok=True)
    cmds = commands(line, out)
    res = {}
    for op in ops:
        res[op] = run([EXE, *cmds[op], "--overwrite"], log)
        r = res[op]
        print(
            f"  {op:20s} {r['seconds']:7.1f} s  {r['peak_gb']:.3f} GB"
            + (f"  FAILED ({r['status']})" if r["status"] else ""),
            flush=True,
        )
    return res


def alternate(line: str, ops, trees, rounds: int, work: str, log: str) -> list[tuple]:
    """``ops`` on ``line`` with each code tree in turn (``PYTHONPATH``), a first round not
    kept, then ``rounds`` rounds: a table row per tree and operation."""
    runs = {(t, op): [] for t in trees for op in ops}
    for k in range(rounds + 1):
        for t in trees:
            os.environ["PYTHONPATH"] = os.path.abspath(t)
            print(f"round {k} ({'warm-up' if k == 0 else 'kept'}): {t}", flush=True)
            res = run_ops(line, ops, os.path.join(work, f"out-{trees.index(t)}"), log)
            failed = [op for op in ops if res[op]["status"]]
            if failed:
                raise SystemExit(f"{', '.join(failed)} failed with {t}: see {log} (--keep)")
            for op in ops if k else ():
                runs[t, op].append(res[op])
    rows = []
    for (t, op), rs in runs.items():
        first = runs[trees[0], op]
        rows.append(
            (
                f"{op}: {t}",
                " / ".join(f"{r['seconds']:.2f}" for r in rs),
                " / ".join(f"{r['cpu_seconds']:.2f}" for r in rs),
                " / ".join(f"{r['peak_gb']:.3f}" for r in rs),
                " / ".join(
                    f"{r['seconds'] / f['seconds']:.2f}" for r, f in zip(rs, first, strict=True)
                ),
            )
        )
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lines", type=int, default=20000)
    ap.add_argument("--memory-lines", default="5000,20000,80000")
    ap.add_argument(
        "--memory-ops",
        default=",".join(NINE),
        help="operations of the memory table (comma-separated; default the nine)",
    )
    ap.add_argument(
        "--also",
        default="shadow-map,deshadow",
        help="operations timed on the line after the nine, outside their sum (comma-separated;"
        " empty: none)",
    )
    ap.add_argument("--tile", type=int, default=500, help="lines of the simulated scene")
    ap.add_argument("--seed", type=int, default=4)
    ap.add_argument("--workdir", default=tempfile.gettempdir())
    ap.add_argument("--keep", action="store_true")
    ap.add_argument("--no-report", action="store_true")
    ap.add_argument("--no-rx-limit", action="store_true")
    ap.add_argument("--batch-jobs", type=int, default=4, help="Dask scaling: jobs (0: skip)")
    ap.add_argument("--batch-lines", type=int, default=2000)
    ap.add_argument("--batch-op", default="relative-dem")
    ap.add_argument("--only-batch", action="store_true", help="only the Dask scaling table")
    ap.add_argument(
        "--alternate",
        help="code trees (comma-separated) whose --also operations alone are timed in turn",
    )
    ap.add_argument("--rounds", type=int, default=3, help="rounds of --alternate kept")
    ap.add_argument("--json", help="also write every figure to this JSON file")
    ap.add_argument(
        "--geotiff",
        action="store_true",
        help="the main line as tiled, band-interleaved GeoTIFFs (every band read through GDAL)",
    )
    args = ap.parse_args(argv)
    try:
        memory_lines = [int(x) for x in args.memory_lines.split(",") if x.strip()]
    except ValueError:
        ap.error(f"--memory-lines: line counts separated by commas, got {args.memory_lines!r}")
    unknown = sorted({o for o in args.also.split(",") if o} - set(commands("", "")))
    if unknown:
        ap.error(f"--also: not an operation of this script: {', '.join(unknown)}")
    if any(n < 1 for n in [args.lines, *memory_lines]):
        ap.error("--lines and --memory-lines: at least 1 line (an empty --memory-lines skips)")
    if not os.path.isdir(args.workdir or tempfile.gettempdir()):
        ap.error(f"--workdir {args.workdir} is not a folder")

    work = tempfile.mkdtemp(prefix="gb-flightline-", dir=args.workdir)
    log = os.path.join(work, "stderr.log")
    figures: dict = {"load_start": load(), "lines": args.lines}
    print(f"work folder {work}; load average {figures['load_start']}", flush=True)

    def own_peak() -> str:
        import resource

        return f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2:.3f} GB"

    try:
        scene = simulate(work, args.tile, args.seed)
        if args.batch_jobs:
            rows = batch_scaling(scene, work, args.batch_jobs, args.batch_lines, args.batch_op, log)
            print(
                f"\n{args.batch_jobs} × {args.batch_op} on a {args.batch_lines}-line line, "
                f"load average now {load()}\n"
            )
            print(table(rows, ("how", "wall (s)", "speed-up vs one after another")))
            figures["batch"] = rows
            if args.only_batch:
                return 0
        sizes = sorted({args.lines, *memory_lines})
        need = max(sizes) * COLS * BYTES_PER_PIXEL_LINE / 1e9
        if free_gb(work) < need + 2:
            print(f"not enough space in {work} for a {need:.1f} GB line", file=sys.stderr)
            return 1

        # 1–2: the nine operations and the report on the main line, each in RX-limits: the
        # limit is measured before and after them (the machine may be shared; their mean is
        # the unit), in a fresh cache folder so that the first operation needing the boresight
        # offset measures it and the later ones find it, as on a user's new line.
        line = make_line(scene, os.path.join(work, f"line{args.lines}"), args.lines)
        gb = sum(os.path.getsize(os.path.join(line, f"{n}.img")) for n in ("vnir", "swir")) / 1e9
        print(f"line of {args.lines} lines: {gb:.2f} GB", flush=True)
        if args.geotiff:
            as_geotiff(line)
        if args.alternate:
            os.environ[CACHE_ENV] = os.path.join(work, "cache")
            trees = [t for t in args.alternate.split(",") if t]
            also = [o for o in args.also.split(",") if o]
            rows = alternate(line, also, trees, args.rounds, work, log)
            print(f"\n{args.lines} lines, load average {figures['load_start']} -> {load()}\n")
            header = ("operation: code", "wall (s)", "CPU (s)", "peak RSS (GB)", "wall / first's")
            print(table(rows, header))
            return 0
        v, s = images(line)
        limits = []
        if not args.no_rx_limit:
            limits.append(run([sys.executable, "-c", RX_LIMIT, v, s], log))
            print(f"  RX limit            {limits[-1]['seconds']:7.1f} s", flush=True)
        os.environ[CACHE_ENV] = os.path.join(work, "cache")
        res = run_ops(line, NINE, os.path.join(work, "out"), log)
        if not args.no_rx_limit:
            limits.append(run([sys.executable, "-c", RX_LIMIT, v, s], log))
            print(f"  RX limit            {limits[-1]['seconds']:7.1f} s", flush=True)
            # rx and svdd alone on the line, the offset not yet measured (a cold cache).
            os.environ[CACHE_ENV] = os.path.join(work, "cache-cold")
            cold = {
                f"{op} (alone: measures the offset)": run_ops(
                    line, [op], os.path.join(work, "out"), log
                )[op]
                for op in ("rx", "svdd")
            }
            os.environ[CACHE_ENV] = os.path.join(work, "cache")
            with open(os.path.join(work, "out", "offset.json")) as f:
                offset = json.load(f)
            shifted = [str(offset["along_px"]), str(offset["across_px"])]
            coregistered = run([sys.executable, "-c", RX_LIMIT_COREGISTERED, v, s, *shifted], log)
            print(f"  RX limit, co-registered {coregistered['seconds']:5.1f} s", flush=True)
        unit = sum(x["seconds"] for x in limits) / len(limits) if limits else float("nan")
        total = sum(r["seconds"] for r in res.values())
        peak = max(r["peak_gb"] for r in res.values())

        def row(op, r):
            return (op, f"{r['seconds']:.1f}", f"{r['seconds'] / unit:.2f}", f"{r['peak_gb']:.2f}")

        rows = [row(op, r) for op, r in res.items()]
        rows.append(
            ("**nine products**", f"**{total:.1f}**", f"**{total / unit:.2f}**", f"**{peak:.2f}**")
        )
        figures["operations"] = res
        if limits:
            rows += [row(op, r) for op, r in cold.items()]
            rows.append(row("RX limit on co-registered strips", coregistered))
            figures["rx_limit"] = {
                "runs": limits,
                "unit_s": unit,
                "cold": cold,
                "coregistered": coregistered,
            }
        also = [o for o in args.also.split(",") if o]
        if also:
            extra = run_ops(line, also, os.path.join(work, "out"), log)
            rows += [row(op, r) for op, r in extra.items()]
            figures["also"] = extra
        if not args.no_report:
            rep = run_ops(line, ["report"], os.path.join(work, "out"), log)["report"]
            rows.append(row("`report --products`", rep))
            figures["report"] = rep
        print(
            f"\n{args.lines} lines ({gb:.2f} GB), load average now {load()}; RX limit "
            + ", ".join(f"{x['seconds']:.1f}" for x in limits)
            + f" s (unit: their mean, {unit:.1f} s); this script's own peak RSS (the floor of "
            f"the figures) {own_peak()}\n"
        )
        print(table(rows, ("operation", "wall (s)", "RX-limits", "peak RSS (GB)")))
        if limits:
            print(
                "\nrx / the RX limit on co-registered strips = "
                f"{res['rx']['seconds'] / coregistered['seconds']:.2f}"
            )
        if res["relative-dem"]["status"] == 0:
            acc = dem_accuracy(os.path.join(work, "out", "dem.tif"), scene, args.lines)
            figures["dem_accuracy"] = acc
            print(
                f"\nrelative-dem against the tiled true DSM: r {acc['r']:.3f}, RMSE "
                f"{acc['rmse_m']:.2f} m (mean difference removed) on {acc['pixels']:,} pixels"
            )
        if not args.keep:
            shutil.rmtree(line, ignore_errors=True)

        # 3: memory against the line's length (an empty --memory-lines skips it).
        if memory_lines:
            ops = [o for o in args.memory_ops.split(",") if o]
            mem: dict = {}
            for n in sizes:
                if n == args.lines and set(ops) <= set(res):
                    mem[n] = {o: res[o] for o in ops}
                    continue
                print(f"\nmemory run: {n} lines", flush=True)
                ln = make_line(scene, os.path.join(work, f"line{n}"), n)
                mem[n] = run_ops(ln, ops, os.path.join(work, f"out{n}"), log)
                shutil.rmtree(ln, ignore_errors=True)
                shutil.rmtree(os.path.join(work, f"out{n}"), ignore_errors=True)
            lo, hi = min(sizes), max(sizes)
            header = ("operation", *(f"{n:,} lines (GB)" for n in sizes), f"{hi:,} / {lo:,}")
            rows = [
                (
                    o,
                    *(f"{mem[n][o]['peak_gb']:.3f}" for n in sizes),
                    f"{mem[hi][o]['peak_gb'] / mem[lo][o]['peak_gb']:.2f}×",
                )
                for o in ops
            ]
            figures["memory"] = {str(n): mem[n] for n in sizes}
            print(f"\npeak RSS against line length, load average now {load()}\n")
            print(table(rows, header))
        figures["load_end"] = load()
        if args.json:
            with open(args.json, "w", encoding="utf-8") as f:
                json.dump(figures, f, indent=1)
    finally:
        leave(work, args.keep)
    return 0


if __name__ == "__main__":
    sys.exit(main())
