"""The geoboresight Processing provider: a thin client of the geoboresight engine.

Its algorithms are generated from the engine's operation list (``geoboresight engine
describe``, cached), or from the copy shipped with the plugin (``operations.json``) when no
engine is set up yet: the tools are there at once, and running one says how to set up the
engine. Each run starts the engine in its own process (:mod:`.engine_client`).
"""

from __future__ import annotations

import os

from qgis.core import QgsMessageLog, QgsProcessingProvider
from qgis.PyQt.QtGui import QIcon

from . import compat, engine_client
from .algorithm import EngineAlgorithm
from .setup_engine import SetupEngineAlgorithm

_ICON = os.path.join(os.path.dirname(__file__), "icon.svg")


def _log(message: str, level=compat.INFO) -> None:
    QgsMessageLog.logMessage(message, "geoboresight", level)


class GeoboresightProvider(QgsProcessingProvider):
    """Algorithms from the engine's operation list; the engine path is a Processing option."""

    def __init__(self):
        super().__init__()
        self.description = None
        self.engine = None
        self.problem = ""

    def id(self):
        return "geoboresight"

    def name(self):
        return "geoboresight"

    def longName(self):  # noqa: N802 (QGIS API names)
        version = (self.description or {}).get("version") or engine_client.plugin_version()
        return f"geoboresight {version} (boresight effect, Brook & Ben-Dor 2011)"

    def icon(self):
        return QIcon(_ICON)

    def load(self):
        """Register the Processing option for the engine's path (as OTB and SAGA set their
        folders), then the algorithms."""
        try:
            from processing.core.ProcessingConfig import ProcessingConfig, Setting

            ProcessingConfig.settingIcons[self.name()] = self.icon()
            ProcessingConfig.addSetting(
                Setting(
                    self.name(),
                    engine_client.SETTING,
                    "geoboresight engine (its 'geoboresight' command; empty: the one the "
                    "setup tool made)",
                    "",
                    valuetype=Setting.FILE,
                )
            )
            ProcessingConfig.readSettings()
        except ImportError:  # Processing's Python side is not loaded: environment variable only
            pass
        self.refreshAlgorithms()
        return True

    def unload(self):
        try:
            from processing.core.ProcessingConfig import ProcessingConfig

            ProcessingConfig.removeSetting(engine_client.SETTING)
        except (ImportError, KeyError):
            pass

    def operation_list(self) -> dict:
        """The engine's list when an engine is set up and answers; the bundled copy otherwise
        (with the reason kept in ``self.problem`` and shown in each tool's help)."""
        self.problem = ""
        try:
            self.engine = engine_client.locate()
            if self.engine is not None:
                return engine_client.describe(self.engine)
            self.problem = "The geoboresight engine is not set up yet: " + engine_client.SETUP_HINT
        except engine_client.EngineError as exc:
            self.problem = str(exc)
            _log(self.problem, compat.WARNING)
        return engine_client.bundled()

    def loadAlgorithms(self):  # noqa: N802
        self.description = self.operation_list()
        for spec in self.description["algorithms"]:
            self.addAlgorithm(EngineAlgorithm(spec, self.problem))
        self.addAlgorithm(SetupEngineAlgorithm())

    def use_new_engine(self) -> None:
        """After the setup tool: take the new engine. When its operation list is the one
        already shown (the usual case: the zip's list is the engine's), the algorithms are
        updated in place, so the Processing Toolbox keeps its expanded groups (a full
        refresh rebuilds and collapses the tree); otherwise the provider is refreshed."""
        old = self.description
        new = self.operation_list()
        if old is None or old.get("algorithms") != new.get("algorithms"):
            self.refreshAlgorithms()
            return
        self.description = new
        for alg in self.algorithms():
            if isinstance(alg, EngineAlgorithm):
                alg.engine_note = self.problem

    # The engine writes GeoTIFF rasters and GeoPackage/GeoJSON vectors itself.
    def supportedOutputRasterLayerExtensions(self):  # noqa: N802
        return ["tif"]

    def supportedOutputVectorLayerExtensions(self):  # noqa: N802
        return ["gpkg", "geojson"]

    def defaultRasterFileExtension(self):  # noqa: N802
        return "tif"

    def defaultVectorFileExtension(self, hasGeometry=True):  # noqa: N802, N803
        return "gpkg"
