"""The plugin class: registers the geoboresight Processing provider and, in the desktop, a
menu action for the engine's setup tool.

Nothing here (nor anywhere in the plugin) imports the geoboresight library: the tools run it
in its own process, the engine (see engine_client.py).
"""

from __future__ import annotations

import os

from qgis.core import QgsApplication, QgsMessageLog

from . import compat

SETUP_ID = "geoboresight:setup-engine"


class GeoboresightPlugin:
    """Adds the provider in :meth:`initProcessing`, which QGIS calls even without a GUI
    (``qgis_process``, where ``iface`` is None)."""

    def __init__(self, iface=None):
        self.iface = iface
        self.provider = None
        self.action = None

    def initProcessing(self):  # noqa: N802 (QGIS's name)
        if self.provider is not None:
            return
        from .provider import GeoboresightProvider

        provider = GeoboresightProvider()
        if QgsApplication.processingRegistry().addProvider(provider):
            self.provider = provider
        else:
            QgsMessageLog.logMessage(
                "could not register the geoboresight provider", "geoboresight", compat.CRITICAL
            )

    def initGui(self):  # noqa: N802 (QGIS's name)
        self.initProcessing()
        if self.iface is None:
            return
        from qgis.PyQt.QtGui import QIcon
        from qgis.PyQt.QtWidgets import QAction

        icon = QIcon(os.path.join(os.path.dirname(__file__), "icons", "engine.svg"))
        self.action = QAction(icon, "Set up the geoboresight engine…", self.iface.mainWindow())
        self.action.triggered.connect(self.open_setup)
        self.iface.addPluginToMenu("geoboresight", self.action)
        if self.provider is not None and self.provider.engine is None:
            self.iface.messageBar().pushMessage(
                "geoboresight",
                "The tools need their engine: Plugins > geoboresight > Set up the geoboresight "
                "engine (once).",
                compat.INFO,
                15,
            )

    def open_setup(self):
        import processing

        processing.execAlgorithmDialog(SETUP_ID, {})

    def unload(self):
        if self.action is not None and self.iface is not None:
            self.iface.removePluginMenu("geoboresight", self.action)
            self.action = None
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
