"""What the QGIS face costs: the boresight ratio of the sample scene run from Python, through
``processing.run`` in process, and through ``qgis_process.bin`` (a new QGIS per call, as a batch
script runs it). Run with the QGIS venv (Debian's /usr/bin/python3 + numpy<2), e.g.

    QT_QPA_PLATFORM=offscreen .venv-qgis/bin/python benchmarks/qgis_overhead.py

Prints a side-by-side table; exits quietly when QGIS is not importable (``make bench`` venv).
"""

from __future__ import annotations

import importlib.util
import os
import shutil
import site
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SCENE = REPO / "sample_data" / "scene"
QGIS_PROCESS = "/usr/bin/qgis_process.bin"


def best_of(n, fn):
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> int:
    try:
        from qgis.core import QgsApplication
    except ImportError:
        print("qgis_overhead: QGIS not importable in this Python; skipped")
        return 0
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from geoboresight.algorithms import registry

    work = Path(tempfile.mkdtemp(prefix="gb-bench-qgis-"))
    for name in ("vnir.img", "vnir.hdr", "swir.img", "swir.hdr"):
        shutil.copy(SCENE / name, work / name)
    vnir, swir = str(work / "vnir.img"), str(work / "swir.img")
    ratio = registry()["ratio"]

    lib = best_of(
        3, lambda: ratio(vnir=vnir, swir=swir, output=str(work / "lib.tif"), overwrite=True)
    )

    sys.path.append("/usr/share/qgis/python/plugins")
    t0 = time.perf_counter()
    app = QgsApplication([], False, tempfile.mkdtemp(prefix="gb-bench-profile-"))
    app.initQgis()
    from processing.core.Processing import Processing

    Processing.initialize()
    spec = importlib.util.spec_from_file_location(
        "geoboresight_qgis",
        REPO / "plugin" / "__init__.py",
        submodule_search_locations=[str(REPO / "plugin")],
    )
    plugin = importlib.util.module_from_spec(spec)
    sys.modules["geoboresight_qgis"] = plugin
    spec.loader.exec_module(plugin)
    instance = plugin.classFactory(None)
    instance.initProcessing()
    startup = time.perf_counter() - t0
    import processing

    params = {"vnir": vnir, "swir": swir}
    in_process = best_of(
        3, lambda: processing.run("geoboresight:ratio", {**params, "output": str(work / "q.tif")})
    )

    cli = None
    if os.path.exists(QGIS_PROCESS):
        plugins = work / "plugins"
        shutil.copytree(
            REPO / "plugin",
            plugins / "geoboresight_qgis",
            ignore=shutil.ignore_patterns("__pycache__"),
        )
        import geoboresight

        paths = [p for p in site.getsitepackages() if "site-packages" in p]
        paths.append(str(Path(geoboresight.__file__).resolve().parents[1]))
        env = dict(
            os.environ,
            QGIS_CUSTOM_CONFIG_PATH=str(work / "profile"),
            QGIS_PLUGINPATH=str(plugins),
            XDG_RUNTIME_DIR=str(work),
            PYTHONPATH=os.pathsep.join(paths),
        )
        subprocess.run(
            [QGIS_PROCESS, "plugins", "enable", "geoboresight_qgis"], env=env, capture_output=True
        )
        args = [
            QGIS_PROCESS,
            "run",
            "geoboresight:ratio",
            "--",
            f"vnir={vnir}",
            f"swir={swir}",
            f"output={work / 'p.tif'}",
        ]
        cli = best_of(2, lambda: subprocess.run(args, env=env, capture_output=True, check=True))

    with open(SCENE / "vnir.hdr", encoding="utf-8") as f:
        lines = next(int(ln.split("=")[1]) for ln in f if ln.strip().startswith("lines"))
    print(f"boresight ratio of sample_data/scene ({lines} lines x 286 pixels), best of 2-3 runs")
    print(f"{'how':<44}{'seconds':>10}{'x library':>11}")
    print(f"{'library call (geoboresight ratio)':<44}{lib:>10.3f}{1.0:>11.1f}")
    print(f"{'processing.run in process':<44}{in_process:>10.3f}{in_process / lib:>11.1f}")
    print(f"{'  + one-off QGIS start-up in process':<44}{startup:>10.3f}{'':>11}")
    if cli is not None:
        print(f"{'qgis_process.bin run (new QGIS per call)':<44}{cli:>10.3f}{cli / lib:>11.1f}")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
