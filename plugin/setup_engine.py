"""The "Set up the geoboresight engine" tool: a Python environment for the engine, made from
QGIS in a few clicks.

1. finds a Python >= 3.11: the one given, else QGIS's own on Windows and macOS, else
   ``/usr/bin/python3`` or another ``python3.1x`` on the PATH (Linux);
2. creates a venv under the QGIS profile folder (``<profile>/geoboresight/engine``, where the
   plugin finds it without any setting);
3. installs the library into it with pip: the wheel bundled in the plugin's zip (``wheels/``)
   when no field is filled, its dependencies from the package index; or a wheel, sdist or
   source folder the user picks; or everything from a folder of wheels (a wheelhouse:
   ``--no-index --find-links``, offline). Progress follows pip's stages (collecting n
   packages, installing m), and cancelling stops pip;
4. checks the engine answers with a version compatible with the plugin's, and says how much
   disk the engine takes.

Every failure ends in one message saying what to install or do (docs/qgis.md lists them).
"""

from __future__ import annotations

import glob
import json
import os
import re
import shutil
import sys
import time

from qgis.core import (
    Qgis,
    QgsApplication,
    QgsProcessingAlgorithm,
    QgsProcessingException,
    QgsProcessingOutputNumber,
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
#: The wheels shipped in the plugin's zip (``make plugin-zip``): the library's own wheel, and
#: any dependency wheels a site adds to make the zip a complete offline wheelhouse.
BUNDLED_WHEELS = os.path.join(engine_client.PLUGIN_DIR, "wheels")
#: A folder of wheels to install from instead of the package index, when the tool's field is
#: empty (a site's or CI's wheelhouse, e.g. made with ``pip wheel``).
WHEELHOUSE_VAR = "GEOBORESIGHT_WHEELHOUSE"


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


def library_wheel(folder: str, version: str | None = None) -> str | None:
    """The geoboresight wheel in ``folder`` (of ``version`` when given; the newest name
    otherwise), or None."""
    if not folder or not os.path.isdir(folder):
        return None
    pattern = f"geoboresight-{version or '*'}-*.whl"
    found = sorted(glob.glob(os.path.join(folder, pattern)))
    return found[-1] if found else None


def install_plan(package: str, folder: str, wheelhouse: str, version: str) -> tuple[str, list]:
    """What pip installs and with which options: (target, options).

    - a wheelhouse: everything from it, offline (``--no-index --find-links``), the library's
      wheel from it when there, else the plugin's version by name;
    - a wheel, sdist or folder the user chose: that, dependencies from the index;
    - nothing chosen: the wheel bundled in the zip (dependencies from the index, or from the
      zip's ``wheels/`` too when it holds them); without one, the plugin's version from the
      index.
    """
    if wheelhouse:
        target = package or folder or library_wheel(wheelhouse, version)
        return target or f"geoboresight=={version}", ["--no-index", "--find-links", wheelhouse]
    if package or folder:
        return package or folder, []
    bundled = library_wheel(BUNDLED_WHEELS, version)
    if bundled:
        others = [w for w in glob.glob(os.path.join(BUNDLED_WHEELS, "*.whl")) if w != bundled]
        return bundled, (["--find-links", BUNDLED_WHEELS] if others else [])
    return f"geoboresight=={version}", []


def folder_size(path: str) -> int:
    """Bytes on disk under ``path`` (files counted once; links not followed)."""
    total, seen = 0, set()
    for root, _dirs, files in os.walk(path):
        for name in files:
            try:
                st = os.lstat(os.path.join(root, name))
            except OSError:
                continue
            if (st.st_dev, st.st_ino) in seen:
                continue
            seen.add((st.st_dev, st.st_ino))
            blocks = getattr(st, "st_blocks", None)
            total += blocks * 512 if blocks is not None else st.st_size
    return total


class PipProgress:
    """Progress from pip's output lines, stage by stage: collecting (n packages so far),
    downloading, installing (m packages), done. Progress runs from ``start`` to ``end`` %."""

    _COLLECT = re.compile(r"^(Collecting|Processing|Requirement already satisfied:?)\s+(\S+)")
    _DOWNLOAD = re.compile(r"^Downloading\s+(\S+)(?:\s+\((.*)\))?")
    _INSTALLING = re.compile(r"^Installing collected packages:\s*(.*)$")
    _DONE = re.compile(r"^Successfully installed\s+(.*)$")

    def __init__(self, feedback, start: float = 15.0, end: float = 90.0):
        self.feedback = feedback
        self.start, self.end = start, end
        self.collected: list[str] = []
        self.downloads = 0
        self.total: int | None = None
        self.stage = "starting"

    def _set(self, fraction: float, text: str) -> None:
        if self.feedback is None:
            return
        self.feedback.setProgress(self.start + (self.end - self.start) * min(fraction, 1.0))
        self.feedback.setProgressText(text)

    def line(self, line: str) -> None:
        text = line.strip()
        m = self._COLLECT.match(text)
        if m:
            self.stage = "collecting"
            name = os.path.basename(m.group(2)).split("==")[0].split(">=")[0]
            self.collected.append(name)
            n = len(self.collected)
            # The total is known only when pip starts installing: creep towards half-way.
            self._set(0.5 * n / (n + 10), f"pip: collecting package {n} ({name})")
            return
        m = self._DOWNLOAD.match(text)
        if m:
            self.downloads += 1
            size = f", {m.group(2)}" if m.group(2) else ""
            n = len(self.collected)
            self._set(0.5 * n / (n + 10), f"pip: downloading {os.path.basename(m.group(1))}{size}")
            return
        m = self._INSTALLING.match(text)
        if m:
            self.stage = "installing"
            names = [x.strip() for x in m.group(1).split(",") if x.strip()]
            self.total = len(names)
            self._set(
                0.6, f"pip: installing {self.total} packages ({len(self.collected)} collected)"
            )
            return
        m = self._DONE.match(text)
        if m:
            self.stage = "done"
            n = len(m.group(1).split())
            self._set(1.0, f"pip: installed {n} of {self.total or n} packages")


def pip_failure(output: str, code: int, source: str, from_index: bool) -> str:
    """One line saying why pip failed and what to do."""
    tail = " | ".join(line.strip() for line in output.strip().splitlines()[-3:] if line.strip())
    if _NETWORK.search(output):
        return (
            "pip could not reach the package index (no network, or a proxy is needed): connect "
            "to the network (set a proxy with 'Extra pip options', e.g. --proxy "
            "http://host:port), or download the geoboresight wheel and its dependencies on "
            "another machine (pip download geoboresight -d <folder>) and choose that folder in "
            f"'Or a folder of wheels' (pip install --no-index --find-links <folder>) (pip: {tail})"
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
    WHEELHOUSE = "WHEELHOUSE"
    PYTHON = "PYTHON"
    PIP_OPTIONS = "PIP_OPTIONS"
    ENGINE = "ENGINE"
    VERSION = "VERSION"
    SIZE_MB = "SIZE_MB"

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
            f"{engine_client.plugin_version()} into it with pip.</p>"
            "<p><b>Leave every field empty</b> to install the geoboresight wheel that comes "
            "with the plugin, its dependencies (NumPy, SciPy, rasterio, ...) from the Python "
            "Package Index: a network connection and a few hundred MB. <b>Offline</b>, choose a "
            "folder of wheels (the geoboresight wheel and its dependencies, made on another "
            "machine with <i>pip download geoboresight -d folder</i>). Or choose a wheel, sdist "
            "or source folder. The progress bar follows pip's stages; Cancel stops pip and "
            "removes the half-made environment. Run the tool again to update the engine.</p>"
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
        self.addParameter(
            QgsProcessingParameterFile(
                self.WHEELHOUSE,
                "Or a folder of wheels, to install offline (the geoboresight wheel and its "
                "dependencies)",
                folder,
                "",
                None,
                True,
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
        self.addOutput(QgsProcessingOutputNumber(self.SIZE_MB, "Engine size on disk (MB)"))

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
        wheelhouse = self.parameterAsFile(parameters, self.WHEELHOUSE, context)
        wheelhouse = wheelhouse or os.environ.get(WHEELHOUSE_VAR, "").strip()
        options = self.parameterAsString(parameters, self.PIP_OPTIONS, context).split()
        expected = engine_client.plugin_version()
        for chosen in (package, folder, wheelhouse):
            if chosen and not os.path.exists(chosen):
                raise SetupError(
                    f"{chosen} does not exist: choose the wheel, sdist or folder again"
                )
        target, plan_options = install_plan(package, folder, wheelhouse, expected)
        options = plan_options + options
        source = package or folder or (target if os.path.exists(target) else "")
        started = time.monotonic()

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
        if wheelhouse:
            feedback.pushInfo(f"installing offline from the wheels in {wheelhouse}")
        elif os.path.dirname(os.path.abspath(target)) == os.path.abspath(BUNDLED_WHEELS):
            feedback.pushInfo(
                "installing the geoboresight wheel that came with the plugin"
                + ("" if "--find-links" in options else "; its dependencies from the package index")
            )
        feedback.pushInfo(f"pip install {target} {' '.join(options)}".strip())
        progress = PipProgress(feedback, 15.0, 90.0)

        def on_line(line):
            feedback.pushConsoleInfo(line)
            progress.line(line)

        code, out = engine_client.stream(
            venv_python(venv),
            ["-m", "pip", "install", "--disable-pip-version-check", target, *options],
            feedback,
            on_line,
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
        megabytes = folder_size(venv) / 1e6
        feedback.pushInfo(
            f"engine: {megabytes:.0f} MB on disk ({venv}); set up in "
            f"{time.monotonic() - started:.0f} s"
        )
        if engine_client.locate() is not None and engine_client.locate().path != engine.path:
            feedback.pushWarning(
                f"note: {engine_client.locate().source} points at another engine "
                f"({engine_client.locate().path}), which takes precedence over this one"
            )
        feedback.setProgress(100)
        return {
            self.ENGINE: engine.path,
            self.VERSION: info["version"],
            self.SIZE_MB: round(megabytes, 1),
        }

    def postProcessAlgorithm(self, context, feedback):  # noqa: N802 (main thread)
        provider = QgsApplication.processingRegistry().providerById("geoboresight")
        if provider is not None:
            # the tools now come from the new engine; the toolbox keeps its expanded groups
            # unless the operation list changed (a full refresh collapses the tree)
            provider.use_new_engine()
        return {}

    @staticmethod
    def _remove(venv: str) -> None:
        # A half-made environment must not be auto-detected as an engine.
        shutil.rmtree(venv, ignore_errors=True)
