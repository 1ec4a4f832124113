"""Paths and the plugin import shared by the QGIS tests (tests/qgis is not a package: a
package named "qgis" would shadow QGIS itself)."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PLUGIN_DIR = REPO / "plugin"
#: The plugin's folder name when installed (dist/geoboresight-plugin.zip): not "geoboresight",
#: which would shadow the library on sys.path.
PLUGIN_NAME = "geoboresight_qgis"
QGIS_PLUGINS = "/usr/share/qgis/python/plugins"
#: The engine the QGIS tests run: the project's own numpy-2 environment (no network needed).
#: GEOBORESIGHT_TEST_ENGINE overrides it.
ENGINE = os.environ.get("GEOBORESIGHT_TEST_ENGINE") or str(REPO / ".venv" / "bin" / "geoboresight")
QGIS_PROCESS = "/usr/bin/qgis_process.bin"  # /usr/bin/qgis_process is a broken wrapper on Debian
#: Modules QGIS's own process must never load: the engine runs them in its own process.
FORBIDDEN_MODULES = ("geoboresight", "rasterio", "shapely", "pyproj", "sklearn", "matplotlib")


def require_engine() -> str:
    """The engine's path; a clear failure when it is missing (run `make test`, which builds
    .venv first)."""
    if not os.path.isfile(ENGINE):
        raise FileNotFoundError(
            f"the QGIS tests run the engine {ENGINE}, which is missing: run `make .venv/.installed` "
            "(or set GEOBORESIGHT_TEST_ENGINE)"
        )
    return ENGINE


def import_plugin():
    """Import plugin/ as the package QGIS would import (its folder name in the zip)."""
    if PLUGIN_NAME in sys.modules:
        return sys.modules[PLUGIN_NAME]
    spec = importlib.util.spec_from_file_location(
        PLUGIN_NAME, PLUGIN_DIR / "__init__.py", submodule_search_locations=[str(PLUGIN_DIR)]
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[PLUGIN_NAME] = module
    spec.loader.exec_module(module)
    return module


_LIBRARY_RUN = """
import json, sys
from geoboresight.algorithms import execute, registry
name, values = json.load(sys.stdin)
result = execute(registry()[name], values)
from geoboresight.engine import _plain
print(json.dumps(_plain(result)))
"""


def library_run(name: str, values: dict) -> dict:
    """The reference: the library called directly (no QGIS, no engine protocol) in the
    engine's own environment, so that both runs use the same NumPy, GDAL and matplotlib."""
    import json
    import subprocess

    python = str(Path(require_engine()).parent / "python")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    done = subprocess.run(
        [python, "-c", _LIBRARY_RUN],
        input=json.dumps([name, values]),
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def fake_engine(folder, name: str, body: str) -> str:
    """A stand-in engine (a script of Debian's Python) for failures a real engine rarely shows:
    another version, no machine mode, a crash."""
    path = Path(folder) / name
    path.write_text("#!/usr/bin/python3\nimport json, os, sys, time\n" + body)
    path.chmod(0o755)
    return str(path)
