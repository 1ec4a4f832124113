"""The plugin class: registers the geoboresight Processing provider and, in the desktop, menu
actions for the engine's setup tool and the first-run tour (the sample scene on its map).

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
        self.sample_action = None
        self.task = None

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
        tour = QIcon(os.path.join(os.path.dirname(__file__), "icon.svg"))
        self.sample_action = QAction(tour, "Open the sample scene", self.iface.mainWindow())
        self.sample_action.triggered.connect(self.open_sample_scene)
        self.iface.addPluginToMenu("geoboresight", self.sample_action)
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

    def open_sample_scene(self, folder=None):
        """The tour: the sample scene's products on its orthophoto (see sample_scene.py), made
        in a background task through the engine; the engine's setup first if there is none."""
        from qgis.core import QgsApplication as App

        from . import engine_client
        from .sample_scene import SampleSceneTask

        bar = self.iface.messageBar() if self.iface is not None else None
        try:
            engine = engine_client.locate(required=True)
        except engine_client.EngineError as exc:
            if bar is not None:
                bar.pushMessage("geoboresight", str(exc), compat.WARNING, 15)
            self.open_setup()
            return None
        if self.task is not None:
            return self.task  # a tour is already under way
        self.task = SampleSceneTask(engine, self._sample_done, folder)
        if bar is not None:
            bar.pushMessage(
                "geoboresight",
                "Preparing the sample scene (simulated line, boresight ratio, shadow map, on its "
                "orthophoto): a few seconds the first time, see the task in the status bar.",
                compat.INFO,
                10,
            )
        App.taskManager().addTask(self.task)
        return self.task

    def _sample_done(self, task):
        from .sample_scene import add_layers

        self.task = None
        self.last_tour = task
        bar = self.iface.messageBar() if self.iface is not None else None
        if task.files is None:
            text = task.error or "cancelled"
            QgsMessageLog.logMessage(f"sample scene: {text}", "geoboresight", compat.WARNING)
            if bar is not None:
                bar.pushMessage("geoboresight", f"The sample scene: {text}", compat.WARNING, 15)
            return
        canvas = self.iface.mapCanvas() if self.iface is not None else None
        task.layers = add_layers(task.files, canvas=canvas)
        if bar is not None:
            bar.pushMessage(
                "geoboresight",
                "The sample scene: the boresight ratio and the shadow classes of a simulated "
                "AISA-Dual line on its orthophoto. Try the tools in the Processing Toolbox "
                f"(geoboresight) on its files in {task.files['scene']}.",
                compat.SUCCESS,
                20,
            )

    def unload(self):
        if self.action is not None and self.iface is not None:
            self.iface.removePluginMenu("geoboresight", self.action)
            self.action = None
        if self.sample_action is not None and self.iface is not None:
            self.iface.removePluginMenu("geoboresight", self.sample_action)
            self.sample_action = None
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
