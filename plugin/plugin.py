"""The plugin class: registers the geoboresight Processing provider, nothing else."""

from __future__ import annotations

from qgis.core import Qgis, QgsApplication, QgsMessageLog

INSTALL_HINT = (
    "The geoboresight QGIS plugin needs the geoboresight Python library in the Python that QGIS "
    "uses (on Debian/Ubuntu QGIS 3.22 with numpy<2). See the plugin's homepage (docs/qgis.md) "
    "for how to install it. Import error: {error}"
)


class GeoboresightPlugin:
    """Adds the provider in :meth:`initProcessing`, which QGIS calls even without a GUI."""

    def __init__(self, iface=None):
        self.iface = iface
        self.provider = None

    def initProcessing(self):  # noqa: N802 (QGIS's name)
        if self.provider is not None:
            return
        try:
            from .provider import GeoboresightProvider

            provider = GeoboresightProvider()
        except ImportError as exc:  # the library (or one of its dependencies) is missing
            message = INSTALL_HINT.format(error=exc)
            QgsMessageLog.logMessage(message, "geoboresight", Qgis.Critical)
            if self.iface is not None:
                self.iface.messageBar().pushCritical("geoboresight", message)
            return
        if QgsApplication.processingRegistry().addProvider(provider):
            self.provider = provider

    def initGui(self):  # noqa: N802 (QGIS's name)
        self.initProcessing()

    def unload(self):
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
