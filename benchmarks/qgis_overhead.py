"""What running the operations in an engine process costs: the boresight ratio run
by the library in a warm Python (as a plugin running inside QGIS's own Python would), by the engine as a new
process (``geoboresight engine run``: process start, imports, JSON lines), through
``processing.run`` in QGIS (the plugin starts the engine), and by ``qgis_process.bin`` (a new
QGIS per call). On the sample scene and on a synthetic 20,000-line flight line. Run with the
QGIS venv (Debian's Python, which sees QGIS), the engine being the project's .venv:

    QT_QPA_PLATFORM=offscreen .venv-qgis/bin/python benchmarks/qgis_overhead.py

Prints a side-by-side table (best of 3, all measured in this one run); exits quietly when QGIS
is not importable (``make bench`` venv).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "sample_data" / "scene"
ENGINE = REPO / ".venv" / "bin" / "geoboresight"
QGIS_PROCESS = "/usr/bin/qgis_process.bin"
LONG_LINES, LONG_SAMPLES, LONG_BANDS = 20_000, 128, 8

# The library in a warm interpreter of the engine's environment: the call 0.1 made in QGIS.
_WARM = """
import json, sys, time
from geoboresight.algorithms import registry
vnir, swir, out = sys.argv[1:4]
ratio = registry()["ratio"]
ratio(vnir=vnir, swir=swir, output=out, overwrite=True)  # warm: imports, GDAL caches
times = []
for _ in range(3):
    t0 = time.perf_counter()
    ratio(vnir=vnir, swir=swir, output=out, overwrite=True)
    times.append(time.perf_counter() - t0)
best = min(times)
print(json.dumps(best))
"""


def best_of(n, fn):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def long_line(folder: Path) -> tuple[str, str]:
    """A 20,000-line VNIR/SWIR pair (ENVI, uint16), written with the engine's own Python."""
    code = f"""
import numpy as np
from geoboresight.io import write_envi
rng = np.random.default_rng(0)
shape = ({LONG_LINES}, {LONG_SAMPLES})
for name, wl in (("vnir", np.linspace(870.0, 970.0, {LONG_BANDS})),
                 ("swir", 980.0 + 30.0 * np.arange({LONG_BANDS}))):
    cube = rng.integers(200, 4000, ({LONG_BANDS}, *shape)).astype("uint16")
    write_envi(r"{folder}/" + name + ".img", cube, wl)
"""
    subprocess.run([str(ENGINE.parent / "python"), "-c", code], check=True)
    return str(folder / "vnir.img"), str(folder / "swir.img")


def engine_env() -> dict:
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}


def measure_scene(label, vnir, swir, work: Path, processing_run, qgis_env) -> list:
    out = str(work / "out.tif")
    warm = json.loads(
        subprocess.run(
            [str(ENGINE.parent / "python"), "-c", _WARM, vnir, swir, out],
            check=True,
            capture_output=True,
            text=True,
            env=engine_env(),
        ).stdout
    )
    params = work / "params.json"
    params.write_text(json.dumps({"vnir": vnir, "swir": swir, "output": out}))
    engine = best_of(
        3,
        lambda: subprocess.run(
            [str(ENGINE), "engine", "run", "ratio", "--params-json", str(params), "--overwrite"],
            check=True,
            capture_output=True,
            env=engine_env(),
        ),
    )
    qgis = best_of(
        3, lambda: processing_run("geoboresight:ratio", {"vnir": vnir, "swir": swir, "output": out})
    )
    rows = [
        (f"{label}: library, warm Python (0.1's call in QGIS)", warm),
        (f"{label}: engine process (geoboresight engine run)", engine),
        (f"{label}: processing.run in QGIS (plugin + engine)", qgis),
    ]
    if qgis_env is not None:
        args = [QGIS_PROCESS, "run", "geoboresight:ratio", "--"]
        args += [f"vnir={vnir}", f"swir={swir}", f"output={out}"]
        cli = best_of(
            2, lambda: subprocess.run(args, env=qgis_env, capture_output=True, check=True)
        )
        rows.append((f"{label}: qgis_process.bin (new QGIS per call)", cli))
    return rows


def main() -> int:
    try:
        from qgis.core import QgsApplication
    except ImportError:
        print("qgis_overhead: QGIS not importable in this Python; skipped")
        return 0
    if not ENGINE.exists():
        print(f"qgis_overhead: no engine at {ENGINE} (make .venv/.installed); skipped")
        return 0
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    os.environ["GEOBORESIGHT_ENGINE"] = str(ENGINE)
    work = Path(tempfile.mkdtemp(prefix="gb-bench-qgis-"))
    for name in ("vnir.img", "vnir.hdr", "swir.img", "swir.hdr"):
        shutil.copy(SCENE / name, work / name)

    # the plugin as installed from the zip, in a fresh profile
    zip_path = work / "plugin.zip"
    subprocess.run(
        ["make", "-s", "-C", str(REPO), "plugin-zip", f"PLUGIN_ZIP={zip_path}"],
        check=True,
        capture_output=True,
    )
    plugins = work / "plugins"
    with zipfile.ZipFile(zip_path) as z:
        z.extractall(plugins)
    sys.path.append("/usr/share/qgis/python/plugins")
    sys.path.insert(0, str(plugins))
    app = QgsApplication([], False, str(work / "profile"))
    app.initQgis()
    from processing.core.Processing import Processing

    Processing.initialize()
    import geoboresight_qgis
    import processing

    t0 = time.perf_counter()
    plugin = geoboresight_qgis.classFactory(None)
    plugin.initProcessing()  # engine version + describe (first start: no cache yet)
    first_load = time.perf_counter() - t0
    plugin.provider.refreshAlgorithms()  # later starts: engine version + the cached list
    t0 = time.perf_counter()
    plugin.provider.refreshAlgorithms()
    cached_load = time.perf_counter() - t0

    qgis_env = None
    if os.path.exists(QGIS_PROCESS):
        qgis_env = dict(
            engine_env(),
            HOME=str(work / "home"),
            QGIS_PLUGINPATH=str(plugins),
            XDG_RUNTIME_DIR=str(work),
        )
        subprocess.run(
            [QGIS_PROCESS, "plugins", "enable", "geoboresight_qgis"],
            env=qgis_env,
            capture_output=True,
        )

    version = best_of(
        3,
        lambda: subprocess.run(
            [str(ENGINE), "engine", "version"], check=True, capture_output=True, env=engine_env()
        ),
    )
    rows = measure_scene(
        "sample scene",
        str(work / "vnir.img"),
        str(work / "swir.img"),
        work,
        processing.run,
        qgis_env,
    )
    long_dir = work / "long"
    long_dir.mkdir()
    vnir, swir = long_line(long_dir)
    rows += measure_scene("20,000 lines", vnir, swir, work, processing.run, None)

    with open(SCENE / "vnir.hdr", encoding="utf-8") as f:
        lines = next(int(ln.split("=")[1]) for ln in f if ln.strip().startswith("lines"))
    print(
        f"boresight ratio: sample_data/scene ({lines} lines x 286 px) and a synthetic line of "
        f"{LONG_LINES} x {LONG_SAMPLES} px ({LONG_BANDS}+{LONG_BANDS} bands); best of 2-3"
    )
    print(f"{'how':<60}{'seconds':>9}{'overhead':>10}")
    base = {}
    for how, seconds in rows:
        scene = how.split(":")[0]
        base.setdefault(scene, seconds)
        print(f"{how:<60}{seconds:>9.3f}{seconds - base[scene]:>+10.3f}")
    print(f"{'engine version (at QGIS start, and per setup check)':<60}{version:>9.3f}")
    print(f"{'provider load, first start (engine version + describe)':<60}{first_load:>9.3f}")
    print(f"{'provider load, later starts (engine version + cache)':<60}{cached_load:>9.3f}")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
