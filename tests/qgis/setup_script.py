"""Run with QGIS's own Python (/usr/bin/python3, no venv, no PYTHONPATH) by test_qgis_setup.py:
a standalone QGIS with a fresh profile, the plugin from the zip, then the "Set up the
geoboresight engine" tool, as a user runs it. Reads $GB_SETUP_JOB, writes a JSON report.
Imports nothing of geoboresight or pytest."""

import json
import os
import sys
import traceback
import zipfile

JOB = json.load(open(os.environ["GB_SETUP_JOB"], encoding="utf-8"))
REPORT = {}


def run(processing, alg, params):
    from qgis.core import QgsProcessingFeedback

    lines = []

    class Feedback(QgsProcessingFeedback):
        def pushInfo(self, info):  # noqa: N802
            lines.append(info)

        def pushConsoleInfo(self, info):  # noqa: N802
            lines.append(info)

    try:
        result = processing.run(alg, params, feedback=Feedback())
        return {"ok": True, "result": {k: str(v) for k, v in result.items()}, "log": lines}
    except Exception as exc:
        return {"ok": False, "error": str(exc), "log": lines}


def main():
    sys.path.append("/usr/share/qgis/python/plugins")
    from qgis.core import QgsApplication

    app = QgsApplication([], False, JOB["profile"])
    app.initQgis()
    from processing.core.Processing import Processing

    Processing.initialize()
    with zipfile.ZipFile(JOB["zip"]) as z:
        z.extractall(JOB["plugins"])
    sys.path.insert(0, JOB["plugins"])
    import geoboresight_qgis

    plugin = geoboresight_qgis.classFactory(None)
    plugin.initProcessing()
    import processing

    REPORT["settings_dir"] = QgsApplication.qgisSettingsDirPath()
    for name, params in JOB["failures"].items():
        REPORT[name] = run(processing, "geoboresight:setup-engine", params)
    REPORT["setup"] = run(processing, "geoboresight:setup-engine", {"PACKAGE": JOB["wheel"]})
    provider = QgsApplication.processingRegistry().providerById("geoboresight")
    REPORT["engine_after"] = None if provider.engine is None else provider.engine.path
    REPORT["engine_source"] = None if provider.engine is None else provider.engine.source
    REPORT["listed"] = sorted(a.name() for a in provider.algorithms())
    REPORT["ratio"] = run(processing, "geoboresight:ratio", JOB["ratio"])
    REPORT["modules"] = sorted(m for m in sys.modules if m.split(".")[0] in JOB["forbidden"])


try:
    main()
except Exception:
    REPORT["crash"] = traceback.format_exc()
finally:
    with open(JOB["report"], "w", encoding="utf-8") as f:
        json.dump(REPORT, f, indent=1)
    os._exit(0)
