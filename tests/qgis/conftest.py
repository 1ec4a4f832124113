"""Real QGIS, in process: one QgsApplication per test run, Processing initialised, and the
plugin's provider registered through the plugin class itself (``classFactory`` ->
``initProcessing``), exactly as QGIS does it. No mocks. The provider runs every operation in
the engine (GEOBORESIGHT_ENGINE = the project's .venv/bin/geoboresight, numpy 2); this pytest
process imports the library only to make inputs and compare outputs.

Skipped (not failed) when QGIS is not importable, unless GEOBORESIGHT_REQUIRE_QGIS=1 (CI): then
tests/conftest.py turns the skips into failures.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

import pytest
from qgis_harness import QGIS_PLUGINS, REPO, import_plugin, require_engine


@pytest.fixture(scope="session")
def qgis_app():
    try:
        from qgis.core import QgsApplication
    except ImportError as exc:
        pytest.skip(f"QGIS Python bindings not importable ({exc}); see docs/qgis.md")
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    runtime = tempfile.mkdtemp(prefix="gb-xdg-")
    os.environ.setdefault("XDG_RUNTIME_DIR", runtime)
    profile = tempfile.mkdtemp(prefix="gb-qgis-profile-")  # no dependence on ~/.local state
    # The provider runs the engine in its own process; the tests use the project's .venv.
    os.environ["GEOBORESIGHT_ENGINE"] = require_engine()
    if QGIS_PLUGINS not in sys.path:
        sys.path.append(QGIS_PLUGINS)
    app = QgsApplication.instance()
    if app is None:
        app = QgsApplication([], False, profile)
        app.initQgis()
    from processing.core.Processing import Processing

    Processing.initialize()
    yield app


@pytest.fixture(scope="session")
def plugin(qgis_app):
    """The plugin object QGIS would create; its initProcessing registers the provider."""
    module = import_plugin()
    instance = module.classFactory(None)  # iface is None in qgis_process too
    instance.initProcessing()
    assert instance.provider is not None, "initProcessing did not register the provider"
    yield instance
    instance.unload()


@pytest.fixture(scope="session")
def provider(plugin):
    return plugin.provider


@pytest.fixture(scope="session")
def inputs(tmp_path_factory):
    """The small scene (simulated when the simulator exists) and a library-made ratio raster."""
    from qgis_cases import Inputs
    from qgis_scene import make_scene

    from geoboresight.algorithms import registry

    folder = tmp_path_factory.mktemp("scene")
    scene = make_scene(str(folder))
    ratio = str(folder / "ratio.tif")
    registry()["ratio"](vnir=scene["vnir"], swir=scene["swir"], output=ratio)
    return Inputs(scene, ratio, str(folder))


@pytest.fixture(scope="session")
def plugin_zip(tmp_path_factory):
    """The zip ``make plugin-zip`` builds (the wheel inside it included), built once for every
    test that installs the plugin: they only read it."""
    path = tmp_path_factory.mktemp("plugin-zip") / "geoboresight-plugin.zip"
    make = ["make", "-s", "-C", str(REPO), "plugin-zip", f"PLUGIN_ZIP={path}"]
    done = subprocess.run(make, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    return path
