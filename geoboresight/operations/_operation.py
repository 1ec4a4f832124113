"""What every file-level operation shares: outputs checked before any work, removed after a
failure, and progress optional.

A file-level operation is a plain function a rasterio script calls (``ratio_file(vnir, swir,
output="ratio.tif")``); the specs declare the same function as their ``run``. Decorating it with
:func:`operation` makes the promises of docs/DEVELOPING.md hold for scripts and faces alike:

- an output may not be an input, nor one of an input's sidecar files (ENVI header, .aux.xml);
- an existing output is replaced only with ``overwrite=True``;
- an output the run created is removed when the run fails or is cancelled (the writers in
  :mod:`geoboresight.io` are atomic, so a replaced output is either the old or the new file);
- every numeric argument is finite (NaN passes range checks silently);
- an OS or GDAL error (unreadable input, full disk, read-only folder, memory) reaches the
  caller as a one-line :class:`~geoboresight.errors.GeoboresightError` naming the file.
"""

from __future__ import annotations

import dataclasses
import errno
import functools
import inspect
import math
import numbers
import os
import shutil
from collections.abc import Callable

from .._state import VALIDATED, spec_of
from ..errors import (
    GeoboresightError,
    InputError,
    OutputError,
    ParameterError,
    ResourceError,
    shown,
)
from ..io.write import check_output_path, output_error
from ..progress import as_progress

#: The files a dual-sensor dataset's layout (:class:`~geoboresight.io.dual.DualLayout`) names.
LAYOUT_FILES = ("vnir_calibration", "swir_calibration")


def operation(*, inputs: tuple[str, ...] = (), outputs: tuple[str, ...] = ()) -> Callable:
    """Declare a file-level operation whose parameters ``inputs`` name files it reads (a path
    or a list of paths) and ``outputs`` the files or folders it writes. A file inside a
    parameter group's value is named ``"group.member"`` (``"surface.dsm"``: the ``dsm`` of the
    ``surface`` value), and is checked as an input like any other.

    The decorated function takes ``progress`` (a :class:`~geoboresight.progress.Progress` or
    None) and gains ``overwrite`` (default False). How GeoTIFF outputs are written
    (Cloud-Optimised, GDAL creation options, a local metric CRS for raw geometry) is set for
    every writer at once by the context :func:`geoboresight.writer_options`, as rasterio's
    ``Env`` sets GDAL's options: ``with gb.writer_options(cog=True): gb.ratio_file(...)``.
    """

    def decorate(func: Callable) -> Callable:
        nonlocal inputs
        sig = inspect.signature(func)
        if "layout" in sig.parameters:
            # A dual-sensor dataset's layout carries its captures' calibration files: inputs of
            # every operation that reads one (an output may not overwrite them).
            inputs = (
                *inputs,
                *(f"layout.{n}" for n in LAYOUT_FILES if f"layout.{n}" not in inputs),
            )
        missing = [
            n for n in (*inputs, *outputs, "progress") if n.split(".")[0] not in sig.parameters
        ]
        if missing:
            raise TypeError(f"{func.__name__}: no parameter(s) {', '.join(missing)}")

        @functools.wraps(func)
        def run(*args, overwrite: bool = False, **kwargs):
            bound = sig.bind(*args, **kwargs)
            bound.apply_defaults()
            values = bound.arguments
            spec = spec_of(run)
            if spec is not None and not VALIDATED.get():
                # A Python call: the spec's coercion and checks, as the CLI, QGIS, the engine
                # and batch get them (types, ranges, choices, finite numbers, bands).
                flat, given = spec.flatten({k: v for k, v in values.items() if k != "progress"})
                values.update(spec.bind(spec.validate(flat), given))
            values["progress"] = as_progress(values.get("progress"))
            check_finite(values)
            outs = check_paths(values, inputs, outputs, overwrite)
            existed = {o for o in outs if os.path.lexists(o)}
            token = VALIDATED.set(False)  # operations it calls check their own arguments
            try:
                return func(*bound.args, **bound.kwargs)
            except BaseException as exc:
                for o in outs:
                    if o not in existed:
                        _remove(o)
                if isinstance(exc, GeoboresightError) or not isinstance(exc, OSError | MemoryError):
                    raise
                ins = [p for name in inputs for p in _paths(_value(values, name))]
                names = [p.name for p in spec.params] if spec is not None else list(values)
                raise translate_error(exc, ins, outs, names) from exc
            finally:
                VALIDATED.reset(token)

        params = list(sig.parameters.values())
        params.append(inspect.Parameter("overwrite", inspect.Parameter.KEYWORD_ONLY, default=False))
        run.__signature__ = sig.replace(parameters=params)
        run.inputs = tuple(inputs)
        run.outputs = tuple(outputs)
        return run

    return decorate


def _value(values: dict, name: str):
    """The value of parameter ``name``, or of ``"group.member"``: that member of a group's
    value (None when the group is not given)."""
    group, _, member = name.partition(".")
    value = values.get(group)
    return getattr(value, member, None) if member else value


def _paths(value) -> list[str]:
    if value is None or value == "":
        return []
    if isinstance(value, str | os.PathLike):
        return [os.fspath(value)]
    files = getattr(value, "files", None)  # an opened dual-sensor value (DualSensor)
    if files is not None:
        return list(files)
    return [os.fspath(v) for v in value]


def check_paths(values: dict, inputs, outputs, overwrite: bool) -> list[str]:
    """Refuse an output that is an input (or its sidecar), given twice, or existing without
    ``overwrite``; return the output paths."""
    ins = [p for name in inputs for p in _paths(_value(values, name))]
    outs: list[str] = []
    seen: set[str] = set()
    for name in outputs:
        for path in _paths(values.get(name)):
            real = os.path.realpath(path)
            if real in seen:
                raise OutputError(
                    f"parameter '{name}' ({path}) is also given for another output",
                    params=(name,),
                )
            seen.add(real)
            try:
                check_output_path(path, ins, overwrite=overwrite, label=f"parameter '{name}'")
            except OutputError as exc:  # the faces name the parameter their own way
                raise OutputError(str(exc), params=(*exc.params, name)) from None
            outs.append(path)
    return outs


def check_finite(values: dict) -> None:
    """Raise :class:`ParameterError` naming the first numeric argument that is NaN or
    infinite (``nan < minimum`` is False: NaN would pass every range check), the members of a
    parameter group's value (``bands=BandChoice(vnir_nm=nan)``) included."""
    for name, value in values.items():
        if hasattr(value, "files"):  # an opened dataset: its metadata is not an argument
            continue
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            # A parameter group's value (BandChoice, FlightGeometry, ...): its fields.
            check_finite({f.name: getattr(value, f.name) for f in dataclasses.fields(value)})
            continue
        if (
            isinstance(value, numbers.Real)
            and not isinstance(value, bool | numbers.Integral)
            and not math.isfinite(float(value))
        ):
            raise ParameterError(
                f"parameter '{name}': expected a finite number, got {shown(value)}"
            )


#: What to do with each parameter that bounds an operation's memory, in the order offered.
MEMORY_PARAMETERS = {
    "block_rows": "lower block_rows",
    "sample_size": "lower sample_size",
    "resolution": "give a coarser resolution",
    "lines": "simulate fewer lines",
}


def translate_error(
    exc: BaseException, inputs: list[str], outputs: list[str], params=()
) -> GeoboresightError:
    """The one-line error for an OS/GDAL/memory error that escaped an operation: it names the
    input or output at fault when the error does, and says what to do (for memory, with the
    operation's own parameters among ``params`` that bound it)."""
    if isinstance(exc, MemoryError):
        do = [what for name, what in MEMORY_PARAMETERS.items() if name in params]
        advice = (
            " or ".join(do + ["close other programs"])
            if do
            else ("close other programs or use a machine with more memory")
        )
        return ResourceError(f"not enough memory for this run: {advice}")
    text = " ".join(str(exc).split())
    name = getattr(exc, "filename", None)
    for out in outputs:
        if name == out or out in text:
            return output_error(exc, out, mine=True) or OutputError(
                f"output {out} could not be written ({text})"
            )
    for inp in inputs:
        if name == inp or inp in text or os.path.basename(inp) in text:
            return InputError(
                f"input {inp} could not be read ({text}): the file may be truncated, damaged "
                "or not readable for you; check it (e.g. with gdalinfo -checksum)"
            )
    code = getattr(exc, "errno", None)
    if code in (errno.ENOSPC, errno.EDQUOT, errno.EFBIG) and outputs:
        return output_error(exc, outputs[0], mine=True)
    if code in (errno.EACCES, errno.EPERM, errno.EROFS):
        return InputError(f"permission denied: {name or text}; check the file's permissions")
    return InputError(f"a file could not be read or written: {text}")


def _remove(path: str) -> None:
    try:
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        elif os.path.lexists(path):
            os.remove(path)
    except OSError:
        pass
