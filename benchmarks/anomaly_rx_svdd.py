"""Benchmark: global RX and SVDD scoring on a flight-line-sized cube, against the peers.

    python benchmarks/anomaly_rx_svdd.py [--lines 20000] [--spy-lines N] [--svdd-lines 1000]

Generates a 286 × lines × 198 int16 ENVI BIL cube on disk block by block (20,000 lines:
2.27 GB) in a temporary directory (deleted at the end), then measures, each in a fresh Python
process (benchmarks/_measure.py: wall time and peak RSS; a crash or an OOM kill cannot take this
script down):

* the peak RSS of importing numpy + rasterio alone (the floor of any raster tool in Python);
* ``geoboresight rx`` end to end (two streaming passes from disk, GeoTIFF written), float64
  and float32 scoring; time from the call (imports excluded), peak RSS of the whole process
  (imports included: the operation is looked up through the algorithm registry, as the CLI
  does; one more float64 row imports the operation's module alone, as a script does);
* ``spectral.rx`` on the same cube loaded in memory (SPy needs it there; load time reported
  apart and *not* counted against SPy), with its default BLAS threads and with one BLAS thread.
  SPy peaks at ~9× the cube (~20 GB at 20,000 lines): it runs on all lines only when at least
  ``--spy-min-gb`` (22) GB are available, else on the first ``--spy-lines`` (10,000) lines,
  and geoboresight is timed again on that same prefix for the ratio;
* SVDD scoring: scikit-learn's ``OneClassSVM.decision_function`` on the pixels in memory
  (float64, its best layout; conversion not counted) against geoboresight's scoring path
  (``map_windows`` over the file's strips + ``SVDDModel.decision``, reading and conversion
  counted),
  for models trained by ``fit_svdd``'s own rule (σ = median pairwise distance) on the
  operation's default sample (1,000 px, ν = 0.01) and on larger samples and ν, which give
  hundreds of support vectors. Scores must be equal (largest difference printed).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from _measure import measure  # noqa: E402

COLS, BANDS = 286, 198


def make_cube(path, lines, seed=0, block=500):
    rng = np.random.default_rng(seed)
    wl = np.concatenate([np.linspace(400, 970, 96), np.linspace(980, 2450, 102)])
    # A low-rank "scene" plus noise: smooth spectra of 6 materials mixed per pixel.
    mats = 1500 + 800 * np.sin(np.outer(np.arange(1, 7), wl / 700.0))
    with open(path, "wb") as f:
        for a in range(0, lines, block):
            n = min(block, lines - a)
            ab = rng.dirichlet(np.full(6, 0.7), n * COLS)  # (pixels, 6)
            spec = ab @ mats + rng.normal(0, 12, (n * COLS, BANDS))
            cube = spec.reshape(n, COLS, BANDS).transpose(0, 2, 1)  # BIL: line, band, sample
            cube.astype("<i2").tofile(f)
    write_header(path, lines, wl)
    return os.path.splitext(path)[0] + ".hdr"


def write_header(img, lines, wl=None):
    if wl is None:
        wl = np.concatenate([np.linspace(400, 970, 96), np.linspace(980, 2450, 102)])
    with open(os.path.splitext(img)[0] + ".hdr", "w") as f:
        f.write(
            f"ENVI\nsamples = {COLS}\nlines = {lines}\nbands = {BANDS}\nheader offset = 0\n"
            "file type = ENVI Standard\ndata type = 2\ninterleave = bil\nbyte order = 0\n"
            "wavelength units = Nanometers\n"
            "wavelength = {" + ", ".join(f"{w:.2f}" for w in wl) + "}\n"
        )


def prefix_cube(work, img, lines):
    """The first ``lines`` lines of the cube as their own ENVI file (a symlink + header)."""
    sub = os.path.join(work, f"first{lines}.img")
    os.symlink(img, sub)
    write_header(sub, lines)
    return os.path.splitext(sub)[0] + ".hdr"


def available_gb():
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemAvailable"):
                return int(line.split()[1]) / 1024**2
    return 0.0


def ours_rx(hdr, lines, out, precision, via="registry"):
    imp = (
        "from geoboresight.algorithms import get\nalg = get('rx')"
        if via == "registry"
        else "from geoboresight import rx_file as alg"
    )
    # The kernel modules the run imports lazily are imported before the clock starts, as
    # `import spectral` is for SPy (their memory still counts in the peak).
    imp += "\nimport geoboresight.anomaly.rx, threadpoolctl"
    return measure(f"""
{imp}
extra["import_peak_mib"] = peak_mib()
t = time.perf_counter()
alg(vnir={hdr!r}, exclude_nm="", precision={precision!r}, output={out!r}, overwrite=True)
extra["time"] = time.perf_counter() - t
extra["run_peak_mib"] = peak_mib()
import numpy as np, rasterio
with rasterio.open({out!r}) as src:
    np.save({out!r} + ".npy", src.read(1).astype(np.float64))
""")


def spy_rx(img, lines, out, threads=None):
    env = {"OPENBLAS_NUM_THREADS": str(threads)} if threads else None
    return measure(
        f"""
import numpy as np, spectral
t = time.perf_counter()
mm = np.memmap({img!r}, dtype="<i2", mode="r", shape=({lines}, {BANDS}, {COLS}))
X = np.ascontiguousarray(mm.transpose(0, 2, 1))  # (rows, cols, bands) in memory
del mm
extra["load"] = time.perf_counter() - t
t = time.perf_counter()
s = spectral.rx(X)
extra["time"] = time.perf_counter() - t
np.save({out!r}, s.astype(np.float64))
""",
        env=env,
    )


def svdd_pair(img, hdr, lines, size, nu):
    return measure(f"""
import numpy as np
from sklearn.svm import OneClassSVM
from geoboresight.anomaly.svdd import fit_svdd
from geoboresight.io.cube import open_cube
from geoboresight.io.windows import default_workers, map_windows
mm = np.memmap({img!r}, dtype="<i2", mode="r", shape=({lines}, {BANDS}, {COLS}))
rng = np.random.default_rng(0)
rows = rng.integers(0, {lines}, {size}); cols = rng.integers(0, {COLS}, {size})
sample = mm[rows, :, cols].astype(np.float64)
model = fit_svdd(sample, nu={nu})
extra["n_sv"] = int(len(model.alpha)); extra["sigma"] = model.sigma
sk = OneClassSVM(kernel="rbf", gamma=model.gamma, nu={nu}, tol=1e-4).fit(sample)
Xp = np.ascontiguousarray(mm.transpose(0, 2, 1)).reshape(-1, {BANDS}).astype(np.float64)
t = time.perf_counter()
ref = sk.decision_function(Xp)
extra["sk_time"] = time.perf_counter() - t
del Xp
with open_cube({hdr!r}) as cube:
    t = time.perf_counter()
    got = np.concatenate([d.ravel() for _, d in map_windows(
        cube.reader(None, None),
        lambda data, valid: model.decision(data.reshape({BANDS}, -1)),
        height=cube.height, width=cube.width, block_rows=16, workers=default_workers())])
    extra["ours_time"] = time.perf_counter() - t
extra["max_abs_diff"] = float(np.abs(got - ref).max())
extra["max_rel_diff"] = float(np.abs(got - ref).max() / np.abs(ref).max())
""")


def rel_diff(a_path, ref_path):
    a, ref = np.load(a_path).ravel(), np.load(ref_path).ravel()
    return float(np.max(np.abs(a - ref) / np.abs(ref)))


def median_range(values):
    v = sorted(values)
    mid = v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2])
    return mid, v[0], v[-1]


def fmt(values, digits=2):
    mid, lo, hi = median_range(values)
    if len(values) == 1:
        return f"{mid:.{digits}f}"
    return f"{mid:.{digits}f} ({lo:.{digits}f}–{hi:.{digits}f})"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lines", type=int, default=20000)
    ap.add_argument("--spy-lines", type=int, default=10000)
    ap.add_argument("--spy-min-gb", type=float, default=22.0)
    ap.add_argument("--repeat", type=int, default=3, help="runs of each geoboresight / SVDD case")
    ap.add_argument("--svdd-lines", type=int, default=1000)
    ap.add_argument("--svdd", default="1000:0.01,5000:0.05,5000:0.1", help="size:nu,...")
    ap.add_argument("--tmp", default="/tmp")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="gb_anom_bench_", dir=a.tmp)
    img = os.path.join(work, "cube.img")
    try:
        t = time.perf_counter()
        hdr = make_cube(img, a.lines)
        size = os.path.getsize(img) / 1e9
        print(
            f"cube: {COLS} × {a.lines} × {BANDS} int16 BIL, {size:.2f} GB, written in "
            f"{time.perf_counter() - t:.0f} s; load average {os.getloadavg()[0]:.1f} "
            f"on {os.cpu_count()} CPUs",
            flush=True,
        )
        base = measure("import numpy, rasterio")
        print(f"import numpy + rasterio alone: peak RSS {base['peak_mib']:.0f} MiB", flush=True)

        avail = available_gb()
        spy_lines, spy_img, spy_hdr = a.lines, img, hdr
        note = f"available memory before the runs: {avail:.1f} GB"
        if avail < a.spy_min_gb and a.lines > a.spy_lines:
            spy_lines = a.spy_lines
            spy_hdr = prefix_cube(work, img, spy_lines)
            spy_img = os.path.splitext(spy_hdr)[0] + ".img"
            note += (
                f" < {a.spy_min_gb:g} GB needed for SPy on {a.lines} lines (~9× the cube): "
                f"SPy and geoboresight compared on the first {spy_lines} lines"
            )
        print(note, flush=True)

        # Cases: (label, header, lines, precision, how the spec is imported). Our runs are
        # repeated and interleaved with SPy's so that a change of machine load hits both.
        cases = [
            (
                "geoboresight rx float64 (from disk, 2 passes, GeoTIFF)",
                hdr,
                a.lines,
                "float64",
                "registry",
            ),
            (
                "geoboresight rx float32 (from disk, 2 passes, GeoTIFF)",
                hdr,
                a.lines,
                "float32",
                "registry",
            ),
            (
                "geoboresight rx float64, operation module imported alone",
                hdr,
                a.lines,
                "float64",
                "module",
            ),
        ]
        if spy_lines != a.lines:
            cases += [
                (
                    f"geoboresight rx float64, first {spy_lines} lines",
                    spy_hdr,
                    spy_lines,
                    "float64",
                    "registry",
                ),
                (
                    f"geoboresight rx float32, first {spy_lines} lines",
                    spy_hdr,
                    spy_lines,
                    "float32",
                    "registry",
                ),
            ]
        results = {c[0]: [] for c in cases}
        npys = {}
        spy_out = os.path.join(work, "spy.npy")
        spy = spy1 = None
        for rep in range(a.repeat):
            for label, h, n, prec, via in cases:
                out = os.path.join(work, f"rx{len(npys)}.tif")
                r = ours_rx(h, n, out, prec, via)
                results[label].append(r)
                npys.setdefault(label, out + ".npy")
                print((label, rep, r), flush=True)
            if rep == 0:
                spy = spy_rx(spy_img, spy_lines, spy_out)
                print(("spectral.rx", spy), flush=True)
            if rep == min(1, a.repeat - 1):
                spy1 = spy_rx(spy_img, spy_lines, os.path.join(work, "spy1.npy"), threads=1)
                print(("spectral.rx 1 thread", spy1), flush=True)

        print(f"\nimport numpy + rasterio alone: peak RSS {base['peak_mib'] / 1024:.3f} GB")
        print(f"geoboresight: median (min–max) of {a.repeat} runs; SPy: one run each\n")
        print(
            "| RX | lines | time (s) | peak RSS (GB) | of which imports (GB) | time vs spectral.rx "
            "(default threads / 1 BLAS thread) | max rel. diff vs SPy |"
        )
        print("|---|---|---|---|---|---|---|")
        for label, _h, n, _prec, via in cases:
            rs = [r for r in results[label] if "error" not in r]
            if not rs:
                print(f"| {label} | {n} | failed: {results[label][0]['error']} | | | | |")
                continue
            times = [r["time"] for r in rs]
            ratio = diff = ""
            if n == spy_lines and "error" not in spy and "error" not in spy1:
                ratio = (
                    f"{median_range(times)[0] / spy['time']:.3f}× / "
                    f"{median_range(times)[0] / spy1['time']:.3f}×"
                )
            if n == spy_lines and "error" not in spy and via == "registry":
                diff = f"{rel_diff(npys[label], spy_out):.1e}"
            print(
                f"| {label} | {n} | {fmt(times)} | {max(r['run_peak_mib'] for r in rs) / 1024:.3f} | "
                f"{max(r['import_peak_mib'] for r in rs) / 1024:.3f} | {ratio} | {diff} |"
            )
        for name, r in (
            ("spectral.rx in memory, default BLAS threads", spy),
            ("spectral.rx in memory, OPENBLAS_NUM_THREADS=1", spy1),
        ):
            if "error" in r:
                print(f"| {name} | {spy_lines} | failed: {r['error']} | | | | |")
            else:
                print(
                    f"| {name} | {spy_lines} | {r['time']:.2f} (+ {r['load']:.1f} s load, not "
                    f"counted) | {r['peak_mib'] / 1024:.2f} | | | |"
                )
        print(f"\nNote: {note}.")

        n = min(a.svdd_lines, a.lines)
        sub_hdr = prefix_cube(work, img, n) if n < a.lines else hdr
        sub_img = os.path.splitext(sub_hdr)[0] + ".img"
        print(
            "\n| SVDD scoring | pixels | training sample | ν | support vectors | "
            "sklearn decision_function (s) | geoboresight (s) | speed-up | max abs diff "
            "(rel. to max) |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for spec in a.svdd.split(","):
            size, nu = spec.split(":")
            rs = [svdd_pair(sub_img, sub_hdr, n, int(size), float(nu)) for _ in range(a.repeat)]
            ok = [r for r in rs if "error" not in r]
            if not ok:
                print(f"| failed | {n * COLS} | {size} | {nu} | | {rs[0]['error']} | | | |")
                continue
            r = ok[0]
            sk, us = [x["sk_time"] for x in ok], [x["ours_time"] for x in ok]
            speed = [x["sk_time"] / x["ours_time"] for x in ok]
            print(
                f"| RBF SVDD, σ = median rule ({r['sigma']:.0f}) | {n * COLS:,} | {int(size):,} | "
                f"{nu} | {r['n_sv']} | {fmt(sk)} | {fmt(us)} | {fmt(speed, 1)}× | "
                f"{max(x['max_abs_diff'] for x in ok):.1e} "
                f"({max(x['max_rel_diff'] for x in ok):.0e}) |",
                flush=True,
            )
        print(f"\nload average at the end: {os.getloadavg()[0]:.1f}")
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
