"""Run inside the QGIS desktop (``qgis --code desktop_script.py`` under Xvfb) by
test_qgis_desktop.py, in a fresh profile, with QGIS's own Python and no PYTHONPATH: what a new
user does, step by step. Reads the job from $GB_DESKTOP_JOB, writes a JSON report, then exits.

Not a test module (no ``test_`` prefix): it imports nothing of geoboresight, and nothing of
pytest. The assertions are in test_qgis_desktop.py.
"""

import json
import os
import sys
import time
import traceback

from qgis.core import QgsApplication, QgsProject
from qgis.PyQt.QtCore import QCoreApplication
from qgis.utils import iface

JOB = json.load(open(os.environ["GB_DESKTOP_JOB"], encoding="utf-8"))
REPORT = {"steps": []}


def step(name):
    REPORT["steps"].append(name)


def spin(seconds, until=lambda: False):
    end = time.monotonic() + seconds
    while time.monotonic() < end and not until():
        QCoreApplication.processEvents()
        time.sleep(0.02)
    return until()


def provider_algorithms():
    provider = QgsApplication.processingRegistry().providerById("geoboresight")
    return None if provider is None else sorted(a.name() for a in provider.algorithms())


def run_all(processing):
    """Every case through processing.run: results, log, declared outputs, and how each raster
    output opens in QGIS (renderer, legend entries)."""
    from qgis.core import QgsProcessingFeedback, QgsRasterLayer

    class Feedback(QgsProcessingFeedback):
        def __init__(self):
            super().__init__()
            self.infos = []

        def pushInfo(self, info):  # noqa: N802
            self.infos.append(info)
            super().pushInfo(info)

    runs = {}
    registry = QgsApplication.processingRegistry()
    for name, params in JOB["cases"].items():
        fb = Feedback()
        alg = registry.algorithmById(f"geoboresight:{name}")
        entry = {"declared": {o.name(): o.type() for o in alg.outputDefinitions()}}
        try:
            result = processing.run(f"geoboresight:{name}", params, feedback=fb)
            entry.update(ok=True, result={k: _plain(v) for k, v in result.items()})
        except Exception as exc:  # reported, asserted by the test
            entry.update(ok=False, error=str(exc))
            result = {}
        entry["infos"] = fb.infos
        rasters = {}
        for out in alg.outputDefinitions():
            path = result.get(out.name())
            if out.type() == "outputRaster" and isinstance(path, str) and os.path.exists(path):
                layer = QgsRasterLayer(path, "check", "gdal")
                renderer = layer.renderer()
                rasters[out.name()] = {
                    "bands": layer.bandCount(),
                    "renderer": renderer.type(),
                    "classes": [c.label for c in renderer.classes()]
                    if renderer.type() == "paletted"
                    else None,
                }
        entry["rasters"] = rasters
        runs[name] = entry
    return runs


def _plain(v):
    if v is None or isinstance(v, bool | int | float | str):
        return v
    if isinstance(v, list | tuple):
        return [_plain(x) for x in v]
    return str(v)


def dialog_check(processing):
    """The ratio dialog: opens with its help, runs (in a background task, as a user clicks
    Run), and the output layer is added to the project with its style."""
    from qgis.PyQt.QtWidgets import QTextBrowser

    QgsProject.instance().clear()
    dlg = processing.createAlgorithmDialog("geoboresight:ratio", JOB["dialog_params"])
    dlg.resize(1000, 700)
    dlg.show()
    spin(1.0)
    helps = [w.toHtml() for w in dlg.findChildren(QTextBrowser)]
    REPORT["dialog_help"] = "\n".join(helps)
    dlg.grab().save(JOB["dialog_shot"])
    dlg.runAlgorithm()
    spin(180, lambda: len(QgsProject.instance().mapLayers()) > 0)
    spin(2.0)
    layers = list(QgsProject.instance().mapLayers().values())
    REPORT["dialog_layers"] = [
        {"name": lay.name(), "source": lay.source(), "renderer": lay.renderer().type()}
        for lay in layers
    ]
    log = dlg.findChildren(QTextBrowser)
    REPORT["dialog_log"] = "\n".join(w.toPlainText() for w in log)[-4000:]
    dlg.close()
    if layers:
        canvas = iface.mapCanvas()
        canvas.setExtent(layers[0].extent())
        canvas.refresh()
        spin(3.0, lambda: not canvas.isDrawing())
        spin(1.0)
        canvas.grab().save(JOB["canvas_shot"])
    iface.mainWindow().grab().save(JOB["screenshot"])


def toolbox_node(text):
    """The Processing Toolbox's tree view and the index of its top-level node ``text``."""
    from qgis.PyQt.QtWidgets import QDockWidget, QTreeView

    dock = iface.mainWindow().findChild(QDockWidget, "ProcessingToolbox")
    view = dock.findChild(QTreeView) if dock is not None else None
    if view is None:
        return None, None
    model = view.model()
    for row in range(model.rowCount()):
        index = model.index(row, 0)
        if str(model.data(index)).startswith(text):
            return view, index
    return view, None


def newcomer(processing):
    """Setup with no field filled (the zip's wheel; dependencies from the package index, or
    from $GEOBORESIGHT_WHEELHOUSE), the toolbox kept expanded, then Plugins > geoboresight >
    Open the sample scene: its products on its orthophoto, and a screenshot of the map."""
    import qgis.utils
    from qgis.core import QgsProcessingFeedback

    lines, texts = [], []

    class Feedback(QgsProcessingFeedback):
        def pushInfo(self, info):  # noqa: N802
            lines.append(info)

        def pushConsoleInfo(self, info):  # noqa: N802
            lines.append(info)

        def setProgressText(self, text):  # noqa: N802
            texts.append(text)

    view, node = toolbox_node("geoboresight")
    if view is not None and node is not None:
        view.expand(node)
    start = time.monotonic()
    try:
        result = processing.run("geoboresight:setup-engine", {}, feedback=Feedback())
        setup = {"ok": True, "result": {k: str(v) for k, v in result.items()}}
    except Exception as exc:
        setup = {"ok": False, "error": str(exc)}
    setup.update(seconds=time.monotonic() - start, log=lines, progress_texts=texts)
    spin(0.5)
    view, node = toolbox_node("geoboresight")
    setup["toolbox_expanded"] = bool(
        view is not None and node is not None and view.isExpanded(node)
    )
    REPORT["setup"] = setup
    step("setup")
    if not setup["ok"]:
        return
    plugin = qgis.utils.plugins["geoboresight_qgis"]
    REPORT["menu"] = [
        sub.text()
        for a in iface.pluginMenu().actions()
        if a.menu() is not None and a.text() == "geoboresight"
        for sub in a.menu().actions()
    ]
    QgsProject.instance().clear()
    start = time.monotonic()
    plugin.sample_action.trigger()  # Plugins > geoboresight > Open the sample scene
    spin(900, lambda: plugin.task is None and hasattr(plugin, "last_tour"))
    tour = getattr(plugin, "last_tour", None)
    REPORT["tour"] = {
        "seconds": time.monotonic() - start,
        "error": None if tour is None else tour.error,
        "files": None if tour is None else tour.files,
    }
    layers = list(QgsProject.instance().mapLayers().values())
    REPORT["tour"]["layers"] = [
        {
            "name": lay.name(),
            "crs": lay.crs().authid(),
            "extent": [
                lay.extent().xMinimum(),
                lay.extent().yMinimum(),
                lay.extent().xMaximum(),
                lay.extent().yMaximum(),
            ],
            "renderer": lay.renderer().type(),
            "classes": [(c.value, c.label, c.color.alpha()) for c in lay.renderer().classes()]
            if lay.renderer().type() == "paletted"
            else None,
        }
        for lay in layers
    ]
    REPORT["tour"]["project_crs"] = QgsProject.instance().crs().authid()
    canvas = iface.mapCanvas()
    canvas.refresh()
    spin(10.0, lambda: not canvas.isDrawing())
    spin(1.0)
    image = canvas.grab().toImage()
    image.save(JOB["tour_shot"])
    colours = {
        image.pixel(x, y)
        for x in range(0, image.width(), max(1, image.width() // 60))
        for y in range(0, image.height(), max(1, image.height() // 60))
    }
    REPORT["tour"]["canvas_colours"] = len(colours)
    step("tour")


def main():
    import pyplugin_installer

    step("started")
    REPORT["before_install"] = provider_algorithms()
    pyplugin_installer.instance().installFromZipFile(JOB["zip"])
    spin(1.0)
    import qgis.utils

    REPORT["plugin_loaded"] = "geoboresight_qgis" in qgis.utils.plugins
    REPORT["listed_without_engine"] = provider_algorithms()
    step("installed")

    import processing

    # No engine yet: the tools are listed (bundled operation list); running one says how to
    # set the engine up.
    try:
        processing.run("geoboresight:ratio", JOB["dialog_params"])
        REPORT["no_engine_error"] = None
    except Exception as exc:
        REPORT["no_engine_error"] = str(exc)
    step("no engine")

    newcomer(processing)

    os.environ["GEOBORESIGHT_ENGINE"] = JOB["engine"]
    QgsApplication.processingRegistry().providerById("geoboresight").refreshAlgorithms()
    REPORT["listed_with_engine"] = provider_algorithms()
    REPORT["runs"] = run_all(processing)
    step("ran every operation")

    dialog_check(processing)
    step("dialog")

    # What this QGIS process has loaded after all those runs.
    REPORT["modules"] = sorted(
        m for m in sys.modules if m.split(".")[0] in JOB["forbidden"] + ["numpy"]
    )
    with open("/proc/self/maps", encoding="utf-8") as f:
        REPORT["gdal_libraries"] = sorted(
            {line.split()[-1] for line in f if "libgdal" in line and "/" in line}
        )
    step("done")


try:
    main()
except Exception:
    REPORT["crash"] = traceback.format_exc()
finally:
    with open(JOB["report"], "w", encoding="utf-8") as f:
        json.dump(REPORT, f, indent=1)
    os._exit(0)  # no "save the project?" prompt, no teardown to hang on
