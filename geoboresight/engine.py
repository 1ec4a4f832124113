"""The engine's machine mode: ``geoboresight engine ...`` for front-ends that run the library in
its own process (the QGIS plugin, as QGIS runs GRASS, SAGA or Orfeo ToolBox).

Why a separate process: QGIS's Python already has the system's GDAL, GEOS and PROJ loaded;
the rasterio, shapely and pyproj wheels bring their own copies, and two versions of one C
library in one process is a gamble (docs/qgis.md). The engine is the ``geoboresight`` command
of any Python >= 3.11 environment (numpy 2 welcome); the front-end only talks to it:

``geoboresight engine version``
    one JSON object: ``{"engine": "geoboresight", "version": ..., "protocol": 1, "python": ...}``
    (imports nothing heavy).
``geoboresight engine describe``
    one JSON document: every operation with its group, help, parameters (kinds, defaults,
    ranges, choices, units, the raster a band belongs to, file extensions) and its declared
    results (files and scalar values), so a front-end generates its tools from it.
``geoboresight engine run NAME --params-json FILE`` (``-`` for stdin)
    JSON lines on stdout, one object each:
    ``{"engine": {"version", "protocol", "pid"}}`` first (before any heavy import, so the caller
    can check the version at once), then ``{"progress": 0.25, "message": ...}``,
    ``{"info": "..."}``, and finally ``{"result": {...}}`` (exit 0) or ``{"error": "one line"}``
    (exit 1 for a problem the user can fix, 2 for an internal error whose traceback goes to
    stderr, 3 when cancelled). SIGTERM (what QGIS's cancel sends) stops the run like Ctrl-C:
    the operation removes its outputs, so a cancelled run leaves nothing behind.

Nothing else is ever written to stdout during a run (the library's own prints go to stderr),
so every stdout line is one JSON object.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import sys
import traceback
from typing import Any

from . import __version__

#: Version of the JSON-lines protocol; a front-end refuses an engine with another one.
PROTOCOL = 1

#: Results any operation may return, declared for all: warnings about the result's validity
#: (the QGIS plugin also shows each as a warning in the log).
COMMON_RESULTS = (("warnings", "string", "Warnings about this result (JSON list)"),)


def version_info() -> dict:
    """What ``engine version`` prints (no heavy import)."""
    return {
        "engine": "geoboresight",
        "version": __version__,
        "protocol": PROTOCOL,
        "python": ".".join(map(str, sys.version_info[:3])),
        "executable": sys.executable,
    }


def _plain(value: Any) -> Any:
    """A JSON-safe copy of a result value (NumPy scalars as Python numbers, paths as text)."""
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return value  # NaN stays NaN (JSON's NaN literal, which Python's json reads back)
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    item = getattr(value, "item", None)  # NumPy scalar
    if callable(item):
        with contextlib.suppress(TypeError, ValueError):
            return _plain(item())
    return os.fspath(value) if isinstance(value, os.PathLike) else str(value)


def field_label(p) -> str:
    """The field's label in a dialog: the spec's short label, with its unit ("VNIR wavelength
    (nm)")."""
    unit = getattr(p, "unit", "") or ""
    return f"{p.label} ({unit})" if unit and f"({unit}" not in p.label else p.label


def describe_param(p) -> dict:
    """One parameter as data: every field a front-end needs to build its own widget (the
    dialog's ``label``, and the ``description`` sentence for its help)."""
    out = {
        "name": p.name,
        "kind": p.kind,
        "label": field_label(p),
        "description": p.description,
        "default": _plain(p.default),
        "required": p.required,
        "optional": not p.required,
        "advanced": p.advanced,
        "is_output": p.is_output,
        "aliases": list(p.aliases),
    }
    for attr in ("minimum", "maximum", "integer", "unit", "raster", "extension", "count"):
        if hasattr(p, attr):
            out[attr] = _plain(getattr(p, attr))
    for attr in ("choices", "extensions", "names"):
        if hasattr(p, attr):
            out[attr] = list(getattr(p, attr))
    if getattr(p, "formats", ()):
        out["formats"] = [list(f) for f in p.formats]
    return out


def group_id(group: str) -> str:
    """A stable lowercase id for a group ("Relative DEM" -> "relative_dem")."""
    import re

    return re.sub(r"[^a-z0-9]+", "_", group.lower()).strip("_")


def describe() -> dict:
    """Every operation as data (what ``engine describe`` prints)."""
    from .algorithms import GROUPS, registry

    algorithms = []
    for alg in registry().values():
        algorithms.append(
            {
                "name": alg.name,
                "display_name": alg.display_name,
                "group": alg.group,
                "group_id": group_id(alg.group),
                "short_help": alg.short_help,
                "help": alg.help,
                "params": [describe_param(p) for p in alg.params],
                "results": [
                    {"name": n, "type": t, "description": d}
                    for n, t, d in (*alg.results, *COMMON_RESULTS)
                ],
            }
        )
    info = {k: v for k, v in version_info().items() if k not in ("python", "executable")}
    return {
        **info,
        "groups": [{"id": group_id(g), "name": g} for g in GROUPS],
        "algorithms": algorithms,
    }


class _Cancel(BaseException):
    """Raised by the SIGTERM handler; turned into the library's Cancelled."""


def _on_sigterm(signum, frame):
    # Once only: a second SIGTERM while the operation cleans up must not cut the cleanup short.
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    raise _Cancel()


class _Lines:
    """Writes one JSON object per line to the real stdout (kept apart from sys.stdout, which
    points at stderr during a run)."""

    def __init__(self, stream):
        self.stream = stream

    def __call__(self, obj: dict) -> None:
        self.stream.write(json.dumps(obj, default=str) + "\n")
        self.stream.flush()


def read_params(source: str) -> dict:
    """The parameters: a JSON object in the file ``source`` (``-``: stdin)."""
    from .errors import ParameterError

    try:
        if source == "-":
            values = json.load(sys.stdin)
        else:
            with open(source, encoding="utf-8") as f:
                values = json.load(f)
    except OSError as exc:
        raise ParameterError(f"cannot read the parameters file {source}: {exc.strerror}") from None
    except json.JSONDecodeError as exc:
        raise ParameterError(f"the parameters in {source} are not valid JSON: {exc}") from None
    if not isinstance(values, dict):
        raise ParameterError(f"the parameters in {source} must be a JSON object")
    return values


def field_worded(exc, spec) -> str:
    """``exc``'s message with its parameters named as the QGIS dialog shows them: each
    field's label (:func:`field_label`), e.g. 'VNIR image' for ``vnir``."""
    from .errors import worded

    def label(name: str) -> str:
        if name == "overwrite":
            return "the engine's overwrite option"
        try:
            text = field_label(spec.param(name)) if spec is not None else name
        except KeyError:
            text = name
        return f"'{text}'"

    text = worded(exc, label)
    if spec is not None:  # "'VNIR image' is required (VNIR image … )": the label says it once
        for name in getattr(exc, "params", ()):
            with contextlib.suppress(KeyError):
                p = spec.param(name)
                text = text.replace(
                    f"'{field_label(p)}' is required ({p.description})",
                    f"'{field_label(p)}' is required",
                )
    return text


def run(name: str, params_source: str, overwrite: bool = False, stdout=None) -> int:
    """Run operation ``name`` with the parameters in ``params_source``, speaking JSON lines;
    the exit code (0 done, 1 user error, 2 internal error, 3 cancelled)."""
    emit = _Lines(stdout or sys.stdout)
    emit({"engine": {"version": __version__, "protocol": PROTOCOL, "pid": os.getpid()}})
    previous = signal.signal(signal.SIGTERM, _on_sigterm)
    real_stdout, sys.stdout = sys.stdout, sys.stderr  # stray prints must not break the protocol
    try:
        from .algorithms import execute, get
        from .errors import Cancelled, GeoboresightError
        from .progress import Progress

        spec = None
        try:
            values = read_params(params_source)
            spec = get(name)

            said = [None]

            def report(fraction, message=None):
                # A stage's message once, when it starts (an operation repeats it with every
                # block: "RX: scoring" twelve times would be twelve log lines in QGIS).
                line = {"progress": float(fraction)}
                if message and message != said[0]:
                    line["message"] = message
                    said[0] = message
                emit(line)

            progress = Progress(callback=report, log=lambda m: emit({"info": str(m)}))
            result = None
            try:
                result = execute(spec, values, progress=progress, overwrite=overwrite)
                # Done: the outputs are in place, so a SIGTERM from now on comes too late to
                # cancel anything; the result is reported (the client says the cancel was late).
                signal.signal(signal.SIGTERM, signal.SIG_IGN)
            except _Cancel:
                if result is None:
                    raise Cancelled("cancelled by the user") from None
        except Cancelled:
            emit({"error": "cancelled by the user: no output was written"})
            return 3
        except GeoboresightError as exc:
            emit({"error": field_worded(exc, spec)})
            return 1
        emit({"result": _plain(result)})
        return 0
    except _Cancel:  # SIGTERM before the operation started: nothing was written
        emit({"error": "cancelled by the user: no output was written"})
        return 3
    except Exception as exc:  # a bug, not bad input: one line for the user, the trace on stderr
        traceback.print_exc()
        emit(
            {
                "error": f"internal error in '{name}' ({type(exc).__name__}: "
                f"{' '.join(str(exc).split())}); please report it with the engine's log"
            }
        )
        return 2
    finally:
        sys.stdout = real_stdout
        signal.signal(signal.SIGTERM, previous)


def engine_command():
    """The ``engine`` click group mounted by :mod:`geoboresight.cli`."""
    import click

    @click.group(name="engine", short_help="Machine mode for front-ends (JSON).")
    def engine():
        """Machine mode: describe the operations and run them speaking JSON lines (used by the
        QGIS plugin, which runs this command in its own process)."""

    @engine.command(name="version")
    def _version():
        """Print the engine's version and protocol as JSON."""
        click.echo(json.dumps(version_info()))

    @engine.command(name="describe")
    @click.option("--indent", type=int, default=None, help="Pretty-print with this indent.")
    def _describe(indent):
        """Print every operation (groups, parameters, defaults, ranges, help, results) as JSON."""
        click.echo(json.dumps(describe(), indent=indent, allow_nan=False))

    @engine.command(name="run")
    @click.argument("name")
    @click.option(
        "--params-json",
        "params",
        required=True,
        help="A JSON file with the parameters (an object), or - for stdin.",
    )
    @click.option("--overwrite", is_flag=True, help="Replace outputs that already exist.")
    def _run(name, params, overwrite):
        """Run operation NAME; JSON lines on stdout (progress, info, result or error)."""
        sys.exit(run(name, params, overwrite=overwrite))

    return engine
