"""Paths and the plugin import shared by the QGIS tests (tests/qgis is not a package: a
package named "qgis" would shadow QGIS itself)."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PLUGIN_DIR = REPO / "plugin"
#: The plugin's folder name when installed (dist/geoboresight-plugin.zip): not "geoboresight",
#: which would shadow the library on sys.path.
PLUGIN_NAME = "geoboresight_qgis"
QGIS_PLUGINS = "/usr/share/qgis/python/plugins"


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
