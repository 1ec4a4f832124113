"""Run inside the QGIS desktop (``qgis --code repository_script.py`` under Xvfb) by
test_qgis_repository.py, in a fresh profile with QGIS's own Python: add the plugin repository
that ``make plugin-repo`` wrote as a user adds one in the plugin manager's settings, fetch it,
install the plugin from it, list its tools; then, with the project's engine, open every
algorithm's dialog at 1,000 × 700 pixels with its advanced parameters shown and measure what
would make it scroll sideways. Reads the job from $GB_REPO_JOB, writes a JSON report, exits.

Not a test module: the assertions are in test_qgis_repository.py.
"""

import json
import os
import time
import traceback

from qgis.core import QgsApplication, QgsSettings
from qgis.PyQt.QtCore import QCoreApplication, QPoint, QTimer
from qgis.PyQt.QtWidgets import QApplication, QMessageBox

JOB = json.load(open(os.environ["GB_REPO_JOB"], encoding="utf-8"))
REPORT = {"steps": []}
#: The plugin manager's settings (pyplugin_installer.installer_data: reposGroup, settingsGroup).
REPOS = "app/plugin_repositories"
INSTALLER = "app/plugin_installer"


def spin(seconds, until=lambda: False):
    end = time.monotonic() + seconds
    while time.monotonic() < end and not until():
        QCoreApplication.processEvents()
        time.sleep(0.02)
    return until()


def close_message_boxes():
    """A message box the installer opens (an error) is recorded and closed, never waited on."""
    for w in QApplication.topLevelWidgets():
        if isinstance(w, QMessageBox) and w.isVisible():
            REPORT.setdefault("message_boxes", []).append(w.text())
            w.done(0)


def add_repository_and_install():
    import pyplugin_installer
    import qgis.utils
    from pyplugin_installer.installer_data import plugins, repositories

    settings = QgsSettings()
    # This machine has no network: only the project's repository is enabled.
    for key in ("QGIS Official Plugin Repository",):
        settings.setValue(f"{REPOS}/{key}/url", "https://plugins.qgis.org/plugins/plugins.xml")
        settings.setValue(f"{REPOS}/{key}/enabled", False)
    settings.setValue(f"{REPOS}/geoboresight/url", JOB["repository_url"])
    settings.setValue(f"{REPOS}/geoboresight/enabled", True)
    settings.setValue(f"{INSTALLER}/allowExperimental", True)  # the plugin is experimental
    timer = QTimer()
    timer.timeout.connect(close_message_boxes)
    timer.start(200)
    installer = pyplugin_installer.instance()
    installer.fetchAvailablePlugins(reloadMode=True)  # the manager's "Reload all repositories"
    repo = repositories.all().get("geoboresight", {})
    REPORT["repository"] = {"state": repo.get("state"), "error": repo.get("error")}
    found = plugins.all().get(JOB["plugin_id"])
    REPORT["available"] = (
        None
        if found is None
        else {
            k: found.get(k)
            for k in ("name", "version_available", "zip_repository", "status", "experimental")
        }
    )
    if found is None:
        return
    installer.installPlugin(JOB["plugin_id"], quiet=True, stable=not found["experimental"])
    spin(2.0)
    timer.stop()
    REPORT["installed"] = plugins.all()[JOB["plugin_id"]].get("version_installed")
    REPORT["loaded"] = JOB["plugin_id"] in qgis.utils.plugins
    REPORT["installed_path"] = os.path.join(qgis.utils.home_plugin_path, JOB["plugin_id"])
    provider = QgsApplication.processingRegistry().providerById("geoboresight")
    REPORT["tools"] = None if provider is None else sorted(a.name() for a in provider.algorithms())


def measure_dialog(processing, alg_id):
    """One dialog at 1,000 × 700 with its advanced parameters expanded: the parameters' scroll
    area, its horizontal scroll bar, and each browse button's right edge in the viewport."""
    from qgis.PyQt.QtWidgets import QGroupBox, QScrollArea, QToolButton

    dlg = processing.createAlgorithmDialog(alg_id, {})
    dlg.resize(1000, 700)
    dlg.show()
    spin(0.3)
    # "Advanced Parameters" is a collapsible group box (its Qt property "collapsed").
    for box in dlg.findChildren(QGroupBox):
        if box.property("collapsed") is not None:
            box.setProperty("collapsed", False)
    spin(0.3)
    areas = [a for a in dlg.findChildren(QScrollArea) if a.isVisible() and a.widget() is not None]
    # The parameters panel: the visible scroll area holding the most widgets.
    area = max(areas, key=lambda a: len(a.widget().findChildren(QToolButton)), default=None)
    entry = {
        "dialog_width": dlg.width(),
        "collapsed": [g.title() for g in dlg.findChildren(QGroupBox) if g.property("collapsed")],
    }
    if area is None:
        entry["error"] = "no scroll area"
    else:
        viewport = area.viewport()
        bar = area.horizontalScrollBar()
        entry.update(
            viewport_width=viewport.width(),
            content_width=area.widget().width(),
            content_min_width=area.widget().minimumSizeHint().width(),
            horizontal_bar_visible=bar.isVisible(),
            horizontal_range=bar.maximum(),
        )
        buttons = []
        for b in area.widget().findChildren(QToolButton):
            if not b.isVisible() or b.text() not in ("…", "..."):
                continue
            right = b.mapTo(viewport, QPoint(b.width(), 0)).x()
            buttons.append({"right": right, "parent": type(b.parent()).__name__})
        entry["browse_buttons"] = buttons
        entry["shot"] = os.path.join(JOB["shots"], alg_id.split(":")[1] + ".png")
        dlg.grab().save(entry["shot"])
    dlg.close()
    dlg.deleteLater()
    spin(0.1)
    return entry


def main():
    REPORT["steps"].append("started")
    add_repository_and_install()
    REPORT["steps"].append("installed")
    if not REPORT.get("loaded"):
        return
    import processing

    os.environ["GEOBORESIGHT_ENGINE"] = JOB["engine"]
    provider = QgsApplication.processingRegistry().providerById("geoboresight")
    provider.refreshAlgorithms()
    REPORT["dialogs"] = {
        a.name(): measure_dialog(processing, a.id())
        for a in provider.algorithms()
        if a.name() != "setup-engine"
    }
    REPORT["steps"].append("dialogs")


try:
    main()
except Exception:
    REPORT["crash"] = traceback.format_exc()
finally:
    with open(JOB["report"], "w", encoding="utf-8") as f:
        json.dump(REPORT, f, indent=1)
    os._exit(0)
