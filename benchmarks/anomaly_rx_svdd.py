"""Benchmark: global RX and SVDD scoring on a flight-line-sized cube, against the peers.

    python benchmarks/anomaly_rx_svdd.py [--lines 20000] [--tmp /tmp]

Generates a 286 × lines × 198 int16 ENVI BIL cube on disk block by block (20,000 lines:
2.27 GB), then, each in its own subprocess (time and peak RSS measured there; a crash or an OOM
kill cannot take this script down):

* ``geoboresight rx`` end to end (two streaming passes from disk, GeoTIFF written), float64 and
  float32 scoring;
* ``spectral.rx`` on the same cube loaded in memory (SPy needs it there; load time reported
  apart and *not* counted against SPy). SPy peaks at ~9× the cube size: if the machine's
  available memory does not allow that with a 4 GB margin, the SPy comparison uses the largest
  prefix of lines that fits (both sides then run on that same prefix) and says so;
* SVDD scoring (one model trained on a 1,000-pixel sample, ν = 0.01): scikit-learn's
  ``OneClassSVM.decision_function`` vs ``SVDDModel.decision`` (BLAS) on the same pixels, with
  the largest score difference.

The cube is deleted at the end.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

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
    hdr = os.path.splitext(path)[0] + ".hdr"
    with open(hdr, "w") as f:
        f.write(
            f"ENVI\nsamples = {COLS}\nlines = {lines}\nbands = {BANDS}\nheader offset = 0\n"
            "file type = ENVI Standard\ndata type = 2\ninterleave = bil\nbyte order = 0\n"
            "wavelength units = Nanometers\n"
            "wavelength = {" + ", ".join(f"{w:.2f}" for w in wl) + "}\n"
        )
    return hdr


CHILD = r"""
import json, resource, sys, time
import numpy as np
kind, path, lines, extra = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
out = {}
def peak_gb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2
if kind in ("ours64", "ours32"):
    from geoboresight.algorithms import get
    t = time.perf_counter()
    get("rx")(image=path, exclude_nm="", precision="float64" if kind == "ours64" else "float32",
              output=extra, overwrite=True)
    out["time"] = time.perf_counter() - t
    import rasterio
    with rasterio.open(extra) as src:
        s = src.read(1, window=((0, lines), (0, 286))).astype(np.float64)
    np.save(extra + ".npy", s)
elif kind == "spy":
    import spectral
    t = time.perf_counter()
    mm = np.memmap(path.replace(".hdr", ".img"), dtype="<i2", mode="r", shape=(lines, 198, 286))
    X = np.ascontiguousarray(mm[:lines].transpose(0, 2, 1))  # (rows, cols, bands) in memory
    out["load"] = time.perf_counter() - t
    t = time.perf_counter()
    s = spectral.rx(X)
    out["time"] = time.perf_counter() - t
    np.save(extra, s.astype(np.float64))
elif kind in ("svdd_sk", "svdd_ours"):
    from sklearn.svm import OneClassSVM
    from geoboresight.anomaly.svdd import fit_svdd
    mm = np.memmap(path.replace(".hdr", ".img"), dtype="<i2", mode="r", shape=(lines, 198, 286))
    rng = np.random.default_rng(0)
    rows = rng.integers(0, lines, 1000); cols = rng.integers(0, 286, 1000)
    sample = mm[rows, :, cols].astype(np.float64)
    model = fit_svdd(sample, nu=0.01)
    out["support_vectors"] = int(len(model.alpha))
    X = np.ascontiguousarray(mm[:lines].transpose(1, 0, 2)).reshape(198, -1)  # (bands, pixels)
    if kind == "svdd_sk":
        sk = OneClassSVM(kernel="rbf", gamma=model.gamma, nu=0.01, tol=1e-4).fit(sample)
        Xp = X.T.astype(np.float64)
        t = time.perf_counter()
        d = sk.decision_function(Xp)
        out["time"] = time.perf_counter() - t
    else:
        t = time.perf_counter()
        d = np.concatenate([model.decision(X[:, a:a + 65536]) for a in range(0, X.shape[1], 65536)])
        out["time"] = time.perf_counter() - t
    np.save(extra, d)
out["peak_gb"] = peak_gb()
print(json.dumps(out))
"""


def child(kind, path, lines, extra):
    t = time.perf_counter()
    p = subprocess.run(
        [sys.executable, "-c", CHILD, kind, path, str(lines), extra], capture_output=True, text=True
    )
    if p.returncode != 0:
        return {
            "error": f"exit {p.returncode}: {p.stderr.strip().splitlines()[-1:] if p.stderr else ''}",
            "wall": time.perf_counter() - t,
        }
    return json.loads(p.stdout.strip().splitlines()[-1])


def available_gb():
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemAvailable"):
                return int(line.split()[1]) / 1024**2
    return 0.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lines", type=int, default=20000)
    ap.add_argument("--svdd-lines", type=int, default=2000)
    ap.add_argument("--tmp", default="/tmp")
    a = ap.parse_args()
    work = tempfile.mkdtemp(prefix="gb_anom_bench_", dir=a.tmp)
    img = os.path.join(work, "cube.img")
    try:
        t = time.perf_counter()
        hdr = make_cube(img, a.lines)
        size = os.path.getsize(img) / 1e9
        print(
            f"cube: {COLS} × {a.lines} × {BANDS} int16 BIL, {size:.2f} GB, written in {time.perf_counter() - t:.0f} s"
        )
        per_line = COLS * BANDS * 2 * 9 / 1024**3
        avail = available_gb()
        spy_lines = int(min(a.lines, max(500, (avail - 6.0) / per_line)))
        note = ""
        if spy_lines < a.lines:
            note = (
                f"available memory {avail:.1f} GB: SPy needs ~{per_line * a.lines:.1f} GB for all "
                f"{a.lines} lines, so the SPy comparison uses the first {spy_lines} lines"
            )
            print(note)
        rows = []
        o64 = child("ours64", hdr, a.lines, os.path.join(work, "rx64.tif"))
        o32 = child("ours32", hdr, a.lines, os.path.join(work, "rx32.tif"))
        rows.append(("geoboresight rx float64 (full cube, from disk)", a.lines, o64))
        rows.append(("geoboresight rx float32 (full cube, from disk)", a.lines, o32))
        if spy_lines < a.lines:
            sub = os.path.join(work, "sub.img")
            with open(img, "rb") as src, open(sub, "wb") as dst:
                remaining = spy_lines * COLS * BANDS * 2
                while remaining:
                    chunk = src.read(min(remaining, 1 << 26))
                    dst.write(chunk)
                    remaining -= len(chunk)
            txt = open(hdr).read().replace(f"lines = {a.lines}", f"lines = {spy_lines}")
            sub_hdr = os.path.join(work, "sub.hdr")
            open(sub_hdr, "w").write(txt)
            s64 = child("ours64", sub_hdr, spy_lines, os.path.join(work, "rx64s.tif"))
            s32 = child("ours32", sub_hdr, spy_lines, os.path.join(work, "rx32s.tif"))
            rows.append((f"geoboresight rx float64 ({spy_lines} lines)", spy_lines, s64))
            rows.append((f"geoboresight rx float32 ({spy_lines} lines)", spy_lines, s32))
            spy_hdr = sub_hdr
            f64, f32 = os.path.join(work, "rx64s.tif.npy"), os.path.join(work, "rx32s.tif.npy")
        else:
            spy_hdr = hdr
            f64, f32 = os.path.join(work, "rx64.tif.npy"), os.path.join(work, "rx32.tif.npy")
        spy = child("spy", spy_hdr, spy_lines, os.path.join(work, "spy.npy"))
        rows.append((f"spectral.rx in memory ({spy_lines} lines)", spy_lines, spy))
        diffs = {}
        if "error" not in spy:
            ref = np.load(os.path.join(work, "spy.npy"))
            for name, f in (("float64", f64), ("float32", f32)):
                if os.path.exists(f):
                    ours = np.load(f)
                    diffs[name] = float(np.max(np.abs(ours - ref) / np.abs(ref)))
        print()
        print(
            "| RX | lines | time (s) | peak RSS (GB) | time vs spectral.rx | max rel. diff vs SPy |"
        )
        print("|---|---|---|---|---|---|")
        for name, n, r in rows:
            if "error" in r:
                print(f"| {name} | {n} | failed: {r['error']} | | | |")
                continue
            ratio = ""
            if "error" not in spy and n == spy_lines and not name.startswith("spectral"):
                ratio = f"{r['time'] / spy['time']:.2f}×"
            d = ""
            if n == spy_lines and not name.startswith("spectral"):
                d = f"{diffs.get('float32' if 'float32' in name else 'float64', float('nan')):.1e}"
            extra = (
                f" (+ {spy['load']:.1f} s load, not counted)"
                if name.startswith("spectral") and "load" in r
                else ""
            )
            print(f"| {name} | {n} | {r['time']:.1f}{extra} | {r['peak_gb']:.2f} | {ratio} | {d} |")
        if note:
            print(f"\nNote: {note}.")
        # SVDD scoring
        n = min(a.svdd_lines, a.lines)
        sk = child("svdd_sk", hdr, n, os.path.join(work, "sk.npy"))
        us = child("svdd_ours", hdr, n, os.path.join(work, "us.npy"))
        print()
        print("| SVDD scoring | pixels | support vectors | time (s) | speed-up | max abs diff |")
        print("|---|---|---|---|---|---|")
        if "error" in sk or "error" in us:
            print(f"| failed | | | {sk.get('error', '')} {us.get('error', '')} | | |")
        else:
            d = np.abs(
                np.load(os.path.join(work, "sk.npy")) - np.load(os.path.join(work, "us.npy"))
            ).max()
            print(
                f"| sklearn OneClassSVM.decision_function | {n * COLS} | {sk['support_vectors']} | {sk['time']:.2f} | 1× | |"
            )
            print(
                f"| geoboresight SVDDModel.decision (BLAS) | {n * COLS} | {us['support_vectors']} | {us['time']:.2f} | {sk['time'] / us['time']:.1f}× | {d:.1e} |"
            )
    finally:
        import shutil

        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    main()
