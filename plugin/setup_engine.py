"""The "Set up the geoboresight engine" tool: a Python environment for the engine, made from
QGIS in a few clicks.

1. finds a Python >= 3.11: the one given, else QGIS's own on Windows and macOS, else
   ``/usr/bin/python3`` or another ``python3.1x`` on the PATH (Linux);
2. creates a venv under the QGIS profile folder (``<profile>/geoboresight/engine``, where the
   plugin finds it without any setting);
3. installs the library into it with pip, from the package index (the plugin's version) or from
   a wheel, sdist or source folder the user picks, showing pip's output;
4. checks the engine answers with a version compatible with the plugin's.

Every failure ends in one message saying what to install or do (docs/qgis.md lists them).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import sys

from qgis.core import (
    Qgis,
    QgsApplication,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingOutputString,
    QgsProcessingParameterFile,
    QgsProcessingParameterString,
)
from qgis.PyQt.QtGui import QIcon

from . import compat, engine_client

MIN_PYTHON = (3, 11)
_CHECK = (
    "import json, sys\n"
    "try:\n    import ensurepip, venv\n    ok = True\nexcept ImportError:\n    ok = False\n"
    "print(json.dumps({'version': list(sys.version_info[:3]), 'venv': ok, "
    "'executable': sys.executable}))"
)
#: What to install, per platform, when no suitable Python is found.
INSTALL_PYTHON = (
    "Debian/Ubuntu: sudo apt install python3 python3-venv (Python 3.11 or later; on older "
    "releases e.g. python3.11 python3.11-venv); Fedora: sudo dnf install python3; Windows and "
    "macOS: QGIS's own Python is used, so update QGIS to a release with Python 3.11 or later, "
    "or install Python from python.org and give it in 'Python to use'"
)
_NETWORK = re.compile(
    r"Failed to establish a new connection|Temporary failure in name resolution|"
    r"Network is unreachable|ProxyError|Could not fetch URL|ConnectTimeout|ReadTimeout|"
    r"Name or service not known|No route to host",
    re.I,
)
_NOT_FOUND = re.compile(r"No matching distribution found|Could not find a version", re.I)


class SetupError(QgsProcessingException):
    pass


def python_candidates(given: str = "") -> list[str]:
    """Pythons to try, best first."""
    found: list[str] = []
    if given:
        return [given]
    if sys.platform == "win32":
        found.append(os.path.join(sys.exec_prefix, "python.exe"))  # QGIS's own (OSGeo4W)
        found.append(os.path.join(sys.exec_prefix, "python3.exe"))
    elif sys.platform == "darwin":
        found.append(os.path.join(sys.exec_prefix, "bin", "python3"))  # inside QGIS.app
    else:
        found.append("/usr/bin/python3")
    for name in ("python3.13", "python3.12", "python3.11", "python3", "python"):
        path = shutil.which(name)
        if path:
            found.append(path)
    unique = []
    for path in found:
        if path and os.path.isfile(path) and path not in unique:
            unique.append(path)
    return unique


def probe(python: str) -> dict | None:
    """Version and venv support of ``python`` (None when it does not run)."""
    code, out, _ = engine_client.call(python, ["-c", _CHECK], timeout_s=60)
    try:
        return json.loads(out.strip().splitlines()[-1]) if code == 0 else None
    except (ValueError, IndexError):
        return None


def find_python(given: str = "", log=None) -> str:
    """The first candidate with Python >= 3.11 and a working ``venv`` (with pip)."""
    tried, no_venv = [], []
    for python in python_candidates(given):
        info = probe(python)
        if info is None:
            tried.append(f"{python} (does not run)")
            continue
        version = tuple(info["version"])
        text = ".".join(map(str, version))
        if version < MIN_PYTHON:
            tried.append(f"{python} ({text})")
            continue
        if not info["venv"]:
            no_venv.append(f"{python} ({text})")
            continue
        if log:
            log(f"Python {text}: {python}")
        return python
    if no_venv:
        raise SetupError(
            f"Python {no_venv[0]} has no 'venv' module with pip (ensurepip): install it "
            "(Debian/Ubuntu: sudo apt install python3-venv) and run this tool again"
        )
    raise SetupError(
        f"no Python {MIN_PYTHON[0]}.{MIN_PYTHON[1]} or later found"
        + (f" (tried: {', '.join(tried)})" if tried else "")
        + f". Install one: {INSTALL_PYTHON}"
    )


def venv_python(venv: str) -> str:
    if sys.platform == "win32":
        return os.path.join(venv, "Scripts", "python.exe")
    return os.path.join(venv, "bin", "python")


def pip_failure(output: str, code: int, source: str, from_index: bool) -> str:
    """One line saying why pip failed and what to do."""
    tail = " | ".join(line.strip() for line in output.strip().splitlines()[-3:] if line.strip())
    if _NETWORK.search(output):
        return (
            "pip could not reach the package index (no network, or a proxy is needed): connect "
            "to the network (set a proxy with 'Extra pip options', e.g. --proxy "
            "http://host:port), or download the geoboresight wheel and its dependencies on "
            "another machine and choose the wheel in 'Wheel, sdist or source folder' with "
            f"'Extra pip options' --no-index --find-links <folder> (pip: {tail})"
        )
    if from_index and _NOT_FOUND.search(output):
        return (
            f"{source} was not found on the package index (pip: {tail}); check the index "
            "(--index-url in 'Extra pip options') or install from a wheel or source folder"
        )
    return f"pip failed installing {source} (exit code {code}): {tail}"


class SetupEngineAlgorithm(QgsProcessingAlgorithm):
    """Processing tool (and desktop menu action) that makes the engine's environment."""

    PACKAGE = "PACKAGE"
    FOLDER = "FOLDER"
    PYTHON = "PYTHON"
    PIP_OPTIONS = "PIP_OPTIONS"
    ENGINE = "ENGINE"
    VERSION = "VERSION"

    def createInstance(self):  # noqa: N802
        return SetupEngineAlgorithm()

    def name(self):
        return "setup-engine"

    def displayName(self):  # noqa: N802
        return "Set up the geoboresight engine"

    def group(self):
        return "Engine"

    def groupId(self):  # noqa: N802
        return "engine"

    def icon(self):
        return QIcon(os.path.join(os.path.dirname(__file__), "icons", "engine.svg"))

    def shortDescription(self):  # noqa: N802
        return "Create the Python environment the geoboresight tools run in."

    def shortHelpString(self):  # noqa: N802
        return (
            "<p><b>Create the Python environment the geoboresight tools run in.</b></p>"
            "<p>The tools run the geoboresight library in its own process (the engine), never "
            "inside QGIS's Python. This tool finds a Python 3.11 or later (QGIS's own on "
            "Windows and macOS, /usr/bin/python3 on Linux), creates a virtual environment in "
            "your QGIS profile folder and installs geoboresight "
            f"{engine_client.plugin_version()} into it with pip, from the package index or "
            "from a wheel, sdist or source folder you choose. It needs a few hundred MB and, "
            "from the index, a network connection. Run it again to update the engine.</p>"
            "<p>Afterwards the plugin finds the engine by itself. To use another engine, give "
            "its geoboresight command in Settings > Options > Processing > Providers > "
            "geoboresight, or in the environment variable GEOBORESIGHT_ENGINE.</p>"
        )

    def initAlgorithm(self, config=None):  # noqa: N802
        self.addParameter(
            QgsProcessingParameterFile(
                self.PACKAGE,
                "Wheel or sdist to install (empty: from the package index)",
                compat.FILE_BEHAVIOR_FILE,
                "",
                None,
                True,
                "Python packages (*.whl *.tar.gz *.zip);;All files (*.*)",
            )
        )
        folder = compat.pick(
            Qgis, "ProcessingFileParameterBehavior.Folder", QgsProcessingParameterFile, "Folder"
        )
        self.addParameter(
            QgsProcessingParameterFile(
                self.FOLDER, "Or a source folder (a geoboresight checkout)", folder, "", None, True
            )
        )
        python = QgsProcessingParameterFile(
            self.PYTHON,
            "Python to use (3.11 or later; empty: found automatically)",
            compat.FILE_BEHAVIOR_FILE,
            "",
            None,
            True,
        )
        python.setFlags(python.flags() | compat.FLAG_ADVANCED)
        self.addParameter(python)
        pip = QgsProcessingParameterString(
            self.PIP_OPTIONS,
            "Extra pip options (e.g. --proxy http://host:port, or --no-index --find-links DIR)",
            "",
            False,
            True,
        )
        pip.setFlags(pip.flags() | compat.FLAG_ADVANCED)
        self.addParameter(pip)
        self.addOutput(QgsProcessingOutputString(self.ENGINE, "Engine (geoboresight command)"))
        self.addOutput(QgsProcessingOutputString(self.VERSION, "Engine version"))

    def processAlgorithm(self, parameters, context, feedback):  # noqa: N802
        try:
            return self.set_up(parameters, context, feedback)
        except (SetupError, engine_client.EngineError) as exc:
            # a plain QgsProcessingException: QGIS shows its message alone, no traceback
            raise QgsProcessingException(str(exc)) from None

    def set_up(self, parameters, context, feedback) -> dict:
        package = self.parameterAsFile(parameters, self.PACKAGE, context)
        folder = self.parameterAsFile(parameters, self.FOLDER, context)
        given = self.parameterAsFile(parameters, self.PYTHON, context)
        options = self.parameterAsString(parameters, self.PIP_OPTIONS, context).split()
        expected = engine_client.plugin_version()
        source = package or folder
        if source and not os.path.exists(source):
            raise SetupError(f"{source} does not exist: choose the wheel, sdist or folder again")
        target = source or f"geoboresight=={expected}"

        feedback.setProgressText("Finding a Python 3.11 or later")
        python = find_python(given, feedback.pushInfo)
        feedback.setProgress(5)

        venv = engine_client.venv_dir()
        os.makedirs(os.path.dirname(venv), exist_ok=True)
        feedback.setProgressText(f"Creating the environment {venv}")
        code, out = engine_client.stream(
            python, ["-m", "venv", "--clear", venv], feedback, feedback.pushConsoleInfo
        )
        if feedback.isCanceled():
            self._remove(venv)
            raise SetupError("cancelled: the engine was not set up")
        if code != 0:
            self._remove(venv)
            if "ensurepip" in out:
                raise SetupError(
                    f"{python} cannot create a virtual environment with pip (ensurepip is "
                    "missing): install it (Debian/Ubuntu: sudo apt install python3-venv) and "
                    "run this tool again"
                )
            raise SetupError(f"{python} -m venv {venv} failed (exit code {code}): {out[-500:]}")
        feedback.setProgress(15)

        feedback.setProgressText(f"Installing {target} (pip; this can take a few minutes)")
        feedback.pushInfo(f"pip install {target} {' '.join(options)}".strip())
        code, out = engine_client.stream(
            venv_python(venv),
            ["-m", "pip", "install", "--disable-pip-version-check", target, *options],
            feedback,
            feedback.pushConsoleInfo,
        )
        if feedback.isCanceled():
            self._remove(venv)
            raise SetupError("cancelled: the engine was not set up")
        if code != 0:
            self._remove(venv)
            raise SetupError(pip_failure(out, code, target, from_index=not source))
        feedback.setProgress(90)

        feedback.setProgressText("Checking the engine")
        engine = engine_client.Engine(engine_client.venv_executable(venv), "the setup tool")
        if not os.path.isfile(engine.path):
            raise SetupError(
                f"pip installed {target} but {engine.path} is missing: is it the geoboresight "
                "library?"
            )
        info = engine_client.version(engine)
        if not engine_client.compatible(info["version"], expected):
            raise SetupError(
                f"the installed engine is version {info['version']} but this plugin is "
                f"{expected}: install geoboresight {expected} (or update the plugin)"
            )
        feedback.pushInfo(
            f"geoboresight engine {info['version']} ready (Python {info.get('python')}): "
            f"{engine.path}"
        )
        if engine_client.locate() is not None and engine_client.locate().path != engine.path:
            feedback.pushWarning(
                f"note: {engine_client.locate().source} points at another engine "
                f"({engine_client.locate().path}), which takes precedence over this one"
            )
        feedback.setProgress(100)
        return {self.ENGINE: engine.path, self.VERSION: info["version"]}

    def postProcessAlgorithm(self, context, feedback):  # noqa: N802 (main thread)
        provider = QgsApplication.processingRegistry().providerById("geoboresight")
        if provider is not None:
            provider.refreshAlgorithms()  # the tools now come from the new engine
        return {}

    @staticmethod
    def _remove(venv: str) -> None:
        # A half-made environment must not be auto-detected as an engine.
        shutil.rmtree(venv, ignore_errors=True)
