"""Talk to the geoboresight engine: the ``geoboresight`` command of its own Python environment,
run as a separate process, as QGIS runs GRASS, SAGA or Orfeo ToolBox.

QGIS's own Python never imports the library (nor rasterio, shapely, pyproj, scikit-learn or a
numpy of ours): this module is PyQGIS plus the standard library. The protocol is the engine's
machine mode (``geoboresight engine version | describe | run``, see ``geoboresight/engine.py``):
JSON on stdout, one object per line while an operation runs.

Where the engine is, first found wins:

1. the environment variable ``GEOBORESIGHT_ENGINE`` (path to the engine's ``geoboresight``);
2. the Processing option *Settings > Options > Processing > Providers > geoboresight >
   geoboresight engine*;
3. the environment the setup tool makes: ``<QGIS profile>/geoboresight/engine``.
"""

from __future__ import annotations

import configparser
import json
import os
import sys
import tempfile
import time

from qgis.core import QgsApplication, QgsProcessingException
from qgis.PyQt.QtCore import QProcess, QProcessEnvironment

PLUGIN_DIR = os.path.dirname(os.path.abspath(__file__))
#: Environment variable and Processing option naming the engine's executable.
ENV_VAR = "GEOBORESIGHT_ENGINE"
SETTING = "GEOBORESIGHT_ENGINE"
#: The engine's JSON-lines protocol this plugin speaks (geoboresight.engine.PROTOCOL).
PROTOCOL = 1
#: The operation list shipped with the plugin, so the tools appear before any engine exists.
BUNDLED = os.path.join(PLUGIN_DIR, "operations.json")
#: Seconds between asking a cancelled engine to stop (SIGTERM) and killing it.
KILL_AFTER_S = 10.0
#: Variables of QGIS's own Python and libraries that must not leak into the engine's Python
#: (its wheels bring their own GDAL and PROJ data; QGIS may point these at the system's).
_DROPPED_ENV = (
    "PYTHONPATH",
    "PYTHONHOME",
    "PYTHONSTARTUP",
    "GDAL_DATA",
    "GDAL_DRIVER_PATH",
    "PROJ_LIB",
    "PROJ_DATA",
)

SETUP_HINT = (
    "run 'Set up the geoboresight engine' (Processing Toolbox > geoboresight > Engine), "
    "or give the path of an existing engine's geoboresight command in Settings > Options > "
    "Processing > Providers > geoboresight"
)


class EngineError(QgsProcessingException):
    """A problem with the engine itself (missing, wrong version, crashed): the message says
    what to do."""


def plugin_version() -> str:
    """The plugin's version (metadata.txt; the same as the library's, see the Makefile)."""
    meta = configparser.ConfigParser(interpolation=None)
    meta.read(os.path.join(PLUGIN_DIR, "metadata.txt"), encoding="utf-8")
    return meta["general"]["version"].strip()


def _major_minor(version: str) -> tuple:
    parts = version.split(".")
    return tuple(parts[:2])


def compatible(engine_version: str, expected: str | None = None) -> bool:
    """Same major.minor version as the plugin (a patch release of the engine is fine)."""
    return _major_minor(engine_version) == _major_minor(expected or plugin_version())


def engine_home() -> str:
    """The folder the setup tool works in: ``<QGIS profile>/geoboresight``."""
    return os.path.join(QgsApplication.qgisSettingsDirPath(), "geoboresight")


def venv_dir() -> str:
    return os.path.join(engine_home(), "engine")


def venv_executable(venv: str) -> str:
    """The ``geoboresight`` command of a venv (``Scripts\\geoboresight.exe`` on Windows)."""
    if sys.platform == "win32":
        return os.path.join(venv, "Scripts", "geoboresight.exe")
    return os.path.join(venv, "bin", "geoboresight")


def setting_value() -> str:
    """The Processing option's value ('' when unset or when Processing is not loaded)."""
    try:
        from processing.core.ProcessingConfig import ProcessingConfig

        value = ProcessingConfig.getSetting(SETTING)
    except Exception:  # Processing not initialised (e.g. a bare QgsApplication)
        from qgis.core import QgsSettings

        value = QgsSettings().value(f"Processing/Configuration/{SETTING}", "")
    return (value or "").strip()


class Engine:
    """An engine executable and where its path came from (for messages)."""

    def __init__(self, path: str, source: str):
        self.path = path
        self.source = source

    def __repr__(self):
        return f"Engine({self.path!r}, from {self.source})"


def locate(required: bool = False) -> Engine | None:
    """The engine to use, or None (``required``: raise :class:`EngineError` saying what to do).
    A path that is configured but missing is always an error: silently falling back to another
    engine would hide the user's mistake."""
    configured = (
        (os.environ.get(ENV_VAR, "").strip(), f"the environment variable {ENV_VAR}"),
        (setting_value(), "the Processing option 'geoboresight engine'"),
    )
    for path, source in configured:
        if not path:
            continue
        if os.path.isdir(path):  # a venv or its bin folder given instead of the command
            for candidate in (venv_executable(path), os.path.join(path, "geoboresight")):
                if os.path.isfile(candidate):
                    return Engine(candidate, source)
        if os.path.isfile(path):
            return Engine(path, source)
        raise EngineError(
            f"the geoboresight engine set in {source} does not exist: {path}; correct it, or "
            + SETUP_HINT
        )
    auto = venv_executable(venv_dir())
    if os.path.isfile(auto):
        return Engine(auto, "the engine set up by the plugin")
    if required:
        raise EngineError("the geoboresight engine is not set up yet: " + SETUP_HINT)
    return None


def engine_environment() -> QProcessEnvironment:
    env = QProcessEnvironment.systemEnvironment()
    for name in _DROPPED_ENV:
        env.remove(name)
    env.insert("PYTHONUNBUFFERED", "1")
    env.insert("PYTHONIOENCODING", "utf-8")
    return env


def call(program: str, args: list[str], timeout_s: float = 120.0) -> tuple[int, str, str]:
    """Run ``program args`` to completion: (exit code, stdout, stderr). Exit code -1 when it
    could not start or crashed."""
    proc = QProcess()
    proc.setProcessEnvironment(engine_environment())
    proc.start(program, args)
    if not proc.waitForStarted(30000):
        return -1, "", f"could not start {program}: {proc.errorString()}"
    proc.waitForFinished(int(timeout_s * 1000))
    if proc.state() != QProcess.NotRunning:
        proc.kill()
        proc.waitForFinished(5000)
        return -1, "", f"{program} did not finish within {timeout_s:g} s"
    out = bytes(proc.readAllStandardOutput()).decode("utf-8", "replace")
    err = bytes(proc.readAllStandardError()).decode("utf-8", "replace")
    code = proc.exitCode() if proc.exitStatus() == QProcess.NormalExit else -1
    return code, out, err


def _last_lines(text: str, n: int = 3) -> str:
    lines = [s.strip() for s in text.strip().splitlines() if s.strip()]
    return " | ".join(lines[-n:])


def version(engine: Engine) -> dict:
    """``engine version`` as a dict; :class:`EngineError` when it does not answer."""
    code, out, err = call(engine.path, ["engine", "version"], timeout_s=60)
    try:
        info = json.loads(out.strip().splitlines()[-1]) if code == 0 else None
    except (ValueError, IndexError):
        info = None
    if not isinstance(info, dict) or "version" not in info:
        raise EngineError(
            f"the geoboresight engine at {engine.path} (from {engine.source}) did not answer "
            f"'engine version' (exit code {code}: {_last_lines(err) or 'no message'}); it may "
            f"be older than this plugin (version {plugin_version()}): " + SETUP_HINT
        )
    return info


def check_version(engine_version: str, protocol, engine: Engine) -> None:
    if protocol != PROTOCOL or not compatible(engine_version):
        raise EngineError(
            f"the geoboresight engine at {engine.path} is version {engine_version} "
            f"(protocol {protocol}) but this plugin is version {plugin_version()} (protocol "
            f"{PROTOCOL}): update the engine with 'Set up the geoboresight engine', or the "
            "plugin in Plugins > Manage and Install Plugins"
        )


def bundled() -> dict:
    """The operation list shipped with the plugin (``make plugin-zip`` writes it from the
    engine it builds with); empty in a source checkout without it."""
    try:
        with open(BUNDLED, encoding="utf-8") as f:
            return json.load(f)
    except (OSError, ValueError):
        return {"version": plugin_version(), "protocol": PROTOCOL, "groups": [], "algorithms": []}


def _cache_path() -> str:
    return os.path.join(engine_home(), "operations-cache.json")


def describe(engine: Engine) -> dict:
    """The engine's operation list, cached per engine path, file time and version (one
    ``engine version`` call, 0.1 s, instead of ``engine describe`` at every QGIS start)."""
    info = version(engine)
    check_version(info["version"], info.get("protocol"), engine)
    key = {
        "path": engine.path,
        "mtime": os.path.getmtime(engine.path),
        "version": info["version"],
    }
    cache = _cache_path()
    try:
        with open(cache, encoding="utf-8") as f:
            cached = json.load(f)
        if cached.get("key") == key:
            return cached["describe"]
    except (OSError, ValueError, KeyError):
        pass
    code, out, err = call(engine.path, ["engine", "describe"], timeout_s=120)
    try:
        doc = json.loads(out) if code == 0 else None
    except ValueError:
        doc = None
    if not isinstance(doc, dict) or "algorithms" not in doc:
        raise EngineError(
            f"the geoboresight engine at {engine.path} could not list its operations "
            f"(exit code {code}: {_last_lines(err) or 'no message'})"
        )
    try:
        os.makedirs(os.path.dirname(cache), exist_ok=True)
        tmp = cache + ".tmp"
        with open(tmp, "w", encoding="utf-8") as f:
            json.dump({"key": key, "describe": doc}, f)
        os.replace(tmp, cache)
    except OSError:
        pass  # a cache is a convenience
    return doc


class _LineReader:
    """Split a byte stream into complete lines (a read may end mid-line)."""

    def __init__(self):
        self.buffer = b""

    def feed(self, data: bytes) -> list[str]:
        self.buffer += data
        *lines, self.buffer = self.buffer.split(b"\n")
        return [line.decode("utf-8", "replace").strip() for line in lines if line.strip()]

    def rest(self) -> list[str]:
        tail, self.buffer = self.buffer, b""
        return [tail.decode("utf-8", "replace").strip()] if tail.strip() else []


def run(
    engine: Engine, name: str, values: dict, feedback, overwrite: bool = True, outputs=()
) -> dict:
    """Run operation ``name`` in the engine, relaying progress, messages and the result to
    ``feedback`` (a QgsProcessingFeedback). Cancelling ``feedback`` terminates the engine (it
    removes the run's outputs); :class:`EngineError` or QgsProcessingException on failure, with
    the engine's one-line message. ``outputs``: the run's output paths, whose temporary files
    are removed if the engine is killed before it can clean up itself."""
    started = time.time()
    fd, params = tempfile.mkstemp(prefix="geoboresight-params-", suffix=".json")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        json.dump(values, f)
    args = ["engine", "run", name, "--params-json", params] + (["--overwrite"] if overwrite else [])
    proc = QProcess()
    proc.setProcessEnvironment(engine_environment())
    state = {"header": None, "result": None, "error": None}
    reader, stderr = _LineReader(), []
    try:
        proc.start(engine.path, args)
        if not proc.waitForStarted(30000):
            raise EngineError(
                f"could not start the geoboresight engine {engine.path} (from {engine.source}): "
                f"{proc.errorString()}; " + SETUP_HINT
            )
        cancel_at = None
        while True:
            finished = proc.waitForFinished(50)
            for line in reader.feed(bytes(proc.readAllStandardOutput())):
                _handle(line, state, feedback, engine, proc)
            err = bytes(proc.readAllStandardError()).decode("utf-8", "replace")
            if err:
                stderr.append(err)
            if finished or proc.state() == QProcess.NotRunning:
                break
            if feedback is not None and feedback.isCanceled():
                if cancel_at is None:
                    proc.terminate()  # SIGTERM: the engine removes its outputs and exits
                    cancel_at = time.monotonic()
                elif time.monotonic() - cancel_at > KILL_AFTER_S:
                    proc.kill()
        for line in reader.feed(bytes(proc.readAllStandardOutput())) + reader.rest():
            _handle(line, state, feedback, engine, proc)
        stderr.append(bytes(proc.readAllStandardError()).decode("utf-8", "replace"))
    finally:
        if proc.state() != QProcess.NotRunning:
            proc.kill()
            proc.waitForFinished(5000)
        os.remove(params)
    errors = "".join(stderr)
    if errors.strip() and feedback is not None:
        for line in errors.strip().splitlines()[-20:]:
            feedback.pushDebugInfo(f"engine: {line}")
    if state["error"]:
        raise QgsProcessingException(state["error"])
    if feedback is not None and feedback.isCanceled():
        if state["result"] is not None:
            # The engine had finished (its outputs in place) before the cancel reached it:
            # say so rather than claim that nothing was written.
            feedback.pushInfo(
                "the run had finished before the cancel reached the engine: its outputs are kept"
            )
            return state["result"]
        remove_partial(outputs, started)  # in case the engine had to be killed (Windows)
        raise QgsProcessingException("cancelled by the user: no output was written")
    if proc.exitStatus() == QProcess.CrashExit:
        remove_partial(outputs, started)
        raise EngineError(
            f"the geoboresight engine stopped unexpectedly while running '{name}' (it was "
            f"killed or crashed: {_last_lines(errors) or 'no message'}); no output was "
            "completed. If the machine ran out of memory, lower 'block_rows'."
        )
    if state["header"] is None:
        raise EngineError(
            f"the geoboresight engine at {engine.path} (from {engine.source}) did not answer "
            f"in the engine protocol (exit code {proc.exitCode()}: "
            f"{_last_lines(errors) or 'no message'}); it may be older than this plugin "
            f"(version {plugin_version()}): " + SETUP_HINT
        )
    if state["result"] is None:
        raise EngineError(
            f"the geoboresight engine ended without a result while running '{name}' (exit code "
            f"{proc.exitCode()}: {_last_lines(errors) or 'no message'})"
        )
    return state["result"]


def remove_partial(outputs, since: float) -> list[str]:
    """Remove what a killed engine left: the hidden temporary files its atomic writers make
    beside each output (``.<stem>.<random>.tmp<ext>``, geoboresight.io.write.atomic_output),
    made since the run started. Complete outputs are never touched (a killed run never
    renamed its temporary file into place)."""
    import shutil

    removed = []
    for path in outputs:
        folder = os.path.dirname(os.path.abspath(path))
        stem = os.path.splitext(os.path.basename(path))[0]
        try:
            names = os.listdir(folder)
        except OSError:
            continue
        for entry in names:
            full = os.path.join(folder, entry)
            if not (entry.startswith(f".{stem}.") and ".tmp" in entry):
                continue
            try:
                if os.path.getmtime(full) < since - 1:
                    continue
                if os.path.isdir(full):
                    shutil.rmtree(full, ignore_errors=True)
                else:
                    os.remove(full)
                removed.append(full)
            except OSError:
                pass
    return removed


def _handle(line: str, state: dict, feedback, engine: Engine, proc: QProcess) -> None:
    try:
        msg = json.loads(line)
    except ValueError:
        if feedback is not None:
            feedback.pushDebugInfo(f"engine: {line}")
        return
    if not isinstance(msg, dict):
        return
    if "engine" in msg and isinstance(msg["engine"], dict):
        header = msg["engine"]
        state["header"] = header
        try:
            check_version(str(header.get("version")), header.get("protocol"), engine)
        except EngineError:
            proc.kill()  # an engine of another version must not run the operation
            raise
    elif "progress" in msg:
        # after a cancel, blocks the engine finished before SIGTERM reached it are not shown
        if feedback is not None and not feedback.isCanceled():
            feedback.setProgress(100.0 * float(msg["progress"]))
            if msg.get("message"):
                feedback.setProgressText(str(msg["message"]))
    elif "info" in msg:
        if feedback is not None:
            feedback.pushInfo(str(msg["info"]))
    elif "result" in msg:
        state["result"] = msg["result"]
    elif "error" in msg:
        state["error"] = str(msg["error"])


def stream(
    program: str, args: list[str], feedback, on_line=None, timeout_s=None
) -> tuple[int, str]:
    """Run ``program args``, passing each output line (stdout and stderr merged) to
    ``on_line`` as it comes; cancelling ``feedback`` terminates it. (exit code or -1 when it
    could not start, crashed or was cancelled; the whole output)."""
    proc = QProcess()
    proc.setProcessEnvironment(engine_environment())
    proc.setProcessChannelMode(QProcess.MergedChannels)
    proc.start(program, args)
    if not proc.waitForStarted(30000):
        return -1, f"could not start {program}: {proc.errorString()}"
    reader, seen = _LineReader(), []
    start, cancel_at = time.monotonic(), None
    try:
        while True:
            finished = proc.waitForFinished(100)
            lines = reader.feed(bytes(proc.readAllStandardOutput()))
            if finished or proc.state() == QProcess.NotRunning:
                lines += reader.rest()
            for line in lines:
                seen.append(line)
                if on_line is not None:
                    on_line(line)
            if finished or proc.state() == QProcess.NotRunning:
                break
            late = timeout_s is not None and time.monotonic() - start > timeout_s
            if (feedback is not None and feedback.isCanceled()) or late:
                if cancel_at is None:
                    proc.terminate()
                    cancel_at = time.monotonic()
                elif time.monotonic() - cancel_at > KILL_AFTER_S:
                    proc.kill()
    finally:
        if proc.state() != QProcess.NotRunning:
            proc.kill()
            proc.waitForFinished(5000)
    if cancel_at is not None or proc.exitStatus() != QProcess.NormalExit:
        return -1, "\n".join(seen)
    return proc.exitCode(), "\n".join(seen)
