"""Declarative algorithm specs: the single list every face (CLI, QGIS, rio) is generated from.

An :class:`Algorithm` is data (name, group, help, typed parameters with defaults and ranges)
plus ``run=``, one file-level operation of :mod:`geoboresight.operations`. Outputs are
parameters too (like QGIS "destination" parameters), so each face can ask the user where to
write them. At import, each spec checks that its parameters and its operation's signature agree
(names and defaults), so no face can drift from the library.

The spec wraps its operation: :attr:`Algorithm.operation` is ``run`` checked against the spec
(``geoboresight.<name>_file`` for a Python caller). Faces never validate by themselves: they
collect raw values and call :func:`execute`, which fills defaults, checks types and ranges, and
checks bands against their rasters. Either way the run refuses outputs that would overwrite an
input or an existing file, and removes every output of a run that failed.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import math
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ..errors import GeoboresightError, ParameterError
from ..progress import Progress, as_progress

#: Groups, following the paper's applications (QGIS toolbox groups, CLI listing order).
GROUPS = (
    "Boresight ratio and statistics",
    "Shadow",
    "Relative DEM",
    "Anomaly",
    "Simulation",
    "Georeferencing",
    "Report",
)


@dataclass(frozen=True, kw_only=True)
class Param:
    """One parameter. ``default=None`` with ``optional=False`` means required.

    ``label`` is the field's name in a dialog, a few words as QGIS names its own parameters
    ("Input layer", "Band number", "Output CRS"); ``description`` is the sentence that explains
    it (the QGIS help pane and tooltip, the command line's ``--help``).
    """

    name: str
    label: str = ""
    description: str
    default: Any = None
    optional: bool = False
    advanced: bool = False
    #: Former names still accepted (hidden on the command line) for one release.
    aliases: tuple[str, ...] = ()
    kind: ClassVar[str] = "param"
    is_output: ClassVar[bool] = False

    @property
    def required(self) -> bool:
        return self.default is None and not self.optional

    def coerce(self, value: Any) -> Any:
        return value

    def _fail(self, what: str) -> ParameterError:
        return ParameterError(f"parameter '{self.name}': {what}", params=(self.name,))


@dataclass(frozen=True, kw_only=True)
class RasterIn(Param):
    """A raster file (anything GDAL reads: ENVI .hdr/.img, GeoTIFF, ...)."""

    #: File types taken besides GDAL's rasters, as (label, "*.a *.b") pairs: the sensor
    #: products of VNIR/SWIR inputs (a file dialog offers them).
    formats: tuple[tuple[str, str], ...] = ()
    kind: ClassVar[str] = "raster"

    def coerce(self, value):
        from ..io.image import dataset_path

        value = dataset_path(value)  # an open rasterio dataset: read through its name
        if hasattr(value, "files"):  # an opened dataset (DualSensor), as rasterio takes one
            return value
        return _path(self, value)


@dataclass(frozen=True, kw_only=True)
class MultiRaster(Param):
    """Several raster files (a list of paths, or one comma-separated string)."""

    kind: ClassVar[str] = "multiraster"

    def coerce(self, value):
        from ..io.image import dataset_path
        from ..io.write import split_paths

        if isinstance(value, list | tuple):
            value = [dataset_path(v) for v in value]  # open rasterio datasets: their names
        else:
            value = dataset_path(value)
        if not (isinstance(value, str | os.PathLike) or isinstance(value, list | tuple)) or (
            isinstance(value, list | tuple)
            and not all(isinstance(v, str | os.PathLike) for v in value)
        ):
            raise self._fail(f"expected file paths, got {_short(value)}")
        paths = split_paths(value)
        if not paths:
            raise self._fail("give at least one raster")
        return paths


@dataclass(frozen=True, kw_only=True)
class FileIn(Param):
    """A non-raster input file (CSV table, spectral library, JSON)."""

    extensions: tuple[str, ...] = ()
    kind: ClassVar[str] = "file"

    def coerce(self, value):
        return _path(self, value)


@dataclass(frozen=True, kw_only=True)
class Band(Param):
    """A 1-based band number of the raster parameter named ``raster``; with ``wavelength``,
    the name of the parameter that chooses the band by its centre wavelength instead (nm,
    :func:`geoboresight.io.band_at`), which wins when given."""

    raster: str = ""
    wavelength: str = ""
    kind: ClassVar[str] = "band"

    def coerce(self, value):
        if not _scalar(value):
            raise self._fail(f"band must be a whole number, got {_short(value)}")
        try:
            band = int(value)
        except (TypeError, ValueError, OverflowError):
            raise self._fail(f"band must be a whole number, got {_short(value)}") from None
        if float(value) != band:
            raise self._fail(f"band must be a whole number, got {_short(value)}")
        if band < 1:
            raise self._fail(f"bands are numbered from 1, got {band}")
        return band


@dataclass(frozen=True, kw_only=True)
class Number(Param):
    """A finite number with an optional inclusive range; ``integer=True`` for whole numbers."""

    minimum: float | None = None
    maximum: float | None = None
    integer: bool = False
    unit: str = ""
    kind: ClassVar[str] = "number"

    def coerce(self, value):
        # JSON's true is not 1, and a list is not a number (the engine and batch pass JSON
        # values as they come; the CLI passes text).
        if not _scalar(value):
            raise self._fail(f"expected a number, got {_short(value)}")
        try:
            number = float(value)
        except (TypeError, ValueError, OverflowError):
            raise self._fail(f"expected a number, got {_short(value)}") from None
        if not math.isfinite(number):
            raise self._fail(f"expected a finite number, got {_short(value)}")
        if self.integer:
            if number != int(number):
                raise self._fail(f"expected a whole number, got {_short(value)}")
            number = int(number)
        unit = f" {self.unit}" if self.unit else ""
        if self.minimum is not None and number < self.minimum:
            raise self._fail(f"{number}{unit} is below the minimum {self.minimum}{unit}")
        if self.maximum is not None and number > self.maximum:
            raise self._fail(f"{number}{unit} is above the maximum {self.maximum}{unit}")
        return number


@dataclass(frozen=True, kw_only=True)
class Numbers(Param):
    """A fixed count of finite numbers (``count``, three by default: ``X Y Z``), as rio's
    ``--bounds`` takes four: a list or tuple, or text with the numbers separated by spaces or
    commas (``"0.4 -0.3 0.5"``); ``names`` name each one in messages and help."""

    count: int = 3
    names: tuple[str, ...] = ()
    unit: str = ""
    kind: ClassVar[str] = "numbers"

    def coerce(self, value):
        items = value.as_tuple() if hasattr(value, "as_tuple") else value
        if isinstance(value, str):
            items = [v for v in value.replace(",", " ").split() if v]
        if _scalar(items) or not isinstance(items, list | tuple):
            raise self._fail(f"expected {self.count} numbers, got {_short(value)}")
        if len(items) != self.count:
            what = " ".join(self.names) if self.names else f"{self.count} numbers"
            raise self._fail(f"expected {self.count} numbers ({what}), got {_short(value)}")
        out = []
        for item in items:
            if not _scalar(item) or isinstance(item, bool):
                raise self._fail(f"expected numbers, got {_short(value)}")
            try:
                number = float(item)
            except (TypeError, ValueError, OverflowError):
                raise self._fail(f"expected numbers, got {_short(value)}") from None
            if not math.isfinite(number):
                raise self._fail(f"expected finite numbers, got {_short(value)}")
            out.append(number)
        return tuple(out)


@dataclass(frozen=True, kw_only=True)
class Wavelength(Number):
    """A wavelength in nanometres."""

    minimum: float | None = 300.0
    maximum: float | None = 2600.0
    unit: str = "nm"
    kind: ClassVar[str] = "wavelength"


@dataclass(frozen=True, kw_only=True)
class Enum(Param):
    """One of a fixed set of strings."""

    choices: tuple[str, ...] = ()
    kind: ClassVar[str] = "enum"

    def coerce(self, value):
        if isinstance(value, int) and not isinstance(value, bool):
            # QGIS passes enums as indexes: 0 … n-1 (no negative index from the end).
            if 0 <= value < len(self.choices):
                return self.choices[value]
            raise self._fail(
                f"choice number {value} does not exist: give one of {', '.join(self.choices)} "
                f"(or 0–{len(self.choices) - 1})"
            )
        if not isinstance(value, str):
            raise self._fail(f"{_short(value)} is not one of {', '.join(self.choices)}")
        if value not in self.choices:
            raise self._fail(f"{_short(value)} is not one of {', '.join(self.choices)}")
        return value


@dataclass(frozen=True, kw_only=True)
class Flag(Param):
    """A yes/no switch (default False unless given)."""

    default: Any = False
    kind: ClassVar[str] = "bool"

    def coerce(self, value):
        if isinstance(value, str):
            low = value.strip().lower()
            if low in ("1", "true", "yes", "on"):
                return True
            if low in ("0", "false", "no", "off", ""):
                return False
            raise self._fail(f"expected yes or no, got {_short(value)}")
        if isinstance(value, bool) or (_scalar(value) and value in (0, 1)):
            return bool(value)
        raise self._fail(f"expected yes or no (true/false), got {_short(value)}")


@dataclass(frozen=True, kw_only=True)
class Text(Param):
    """Free text (e.g. a comma-separated list of wavelengths)."""

    kind: ClassVar[str] = "string"

    def coerce(self, value):
        if isinstance(value, str):
            return value
        if _scalar(value):
            return str(value)
        raise self._fail(f"expected text, got {_short(value)}")


@dataclass(frozen=True, kw_only=True)
class _Out(Param):
    extension: str = ""
    is_output: ClassVar[bool] = True

    def coerce(self, value):
        return _path(self, value)


@dataclass(frozen=True, kw_only=True)
class RasterOut(_Out):
    """A raster to write (GeoTIFF): a path ending .tif or .tiff (a GeoTIFF named .png
    would open nowhere as a PNG)."""

    extension: str = "tif"
    #: Other endings the operation writes by (reproject-to: a vector input gives a vector).
    also: tuple[str, ...] = ()
    kind: ClassVar[str] = "raster_out"

    def coerce(self, value):
        path = _path(self, value)
        ends = (".tif", ".tiff", *self.also)
        if path and os.path.splitext(str(path))[1].lower() not in ends:
            raise self._fail(
                f"{path} does not end in {', '.join(ends)}: the output is a GeoTIFF"
                + (" (or a vector layer for a vector input)" if self.also else "")
            )
        return path


@dataclass(frozen=True, kw_only=True)
class VectorOut(_Out):
    """A vector layer to write (GeoPackage or GeoJSON, by extension)."""

    extension: str = "gpkg"
    kind: ClassVar[str] = "vector_out"


@dataclass(frozen=True, kw_only=True)
class FileOut(_Out):
    """A file to write (HTML, JSON, PNG, CSV: ``extension``)."""

    kind: ClassVar[str] = "file_out"


@dataclass(frozen=True, kw_only=True)
class FolderOut(_Out):
    """A folder to create and fill (e.g. a simulated scene)."""

    kind: ClassVar[str] = "folder_out"


@dataclass(frozen=True, kw_only=True)
class Group:
    """Parameters that travel together (a band choice, the flight geometry, the matching
    options): flat in every face (CLI options, QGIS fields, engine and batch keys), one small
    frozen value for the operation, as rasterio passes a profile rather than its keys.

    ``value`` is a frozen dataclass whose fields include the members' names; its defaults are
    the members' defaults (checked at import). The operation takes the value under ``name``;
    a Python caller passes either the value or nothing (the defaults). With ``prefix``, every
    member's name is the prefix and its field (``swir_sensor_model`` for the field
    ``sensor_model``): one value for two sensors' parameters side by side.
    """

    name: str
    value: type
    params: tuple[Param, ...]
    #: The operation's default value, when it is not ``value()`` (e.g. dense matching's
    #: band means beside the offset's single bands).
    default: Any = None
    #: What every member's name adds before its field's name ("": the field's name).
    prefix: str = ""

    @property
    def initial(self) -> Any:
        return self.value() if self.default is None else self.default

    def field(self, param: Param) -> str:
        """The value's field a member sets: its name without the group's prefix."""
        return param.name.removeprefix(self.prefix)

    def build(self, values: Mapping[str, Any], base: Any = None) -> Any:
        """The value from the members' validated values: ``base`` (a caller's own value, else
        the default) with those members replaced."""
        fields = {self.field(p): values[p.name] for p in self.params if p.name in values}
        return dataclasses.replace(self.initial if base is None else base, **fields)


@dataclass(frozen=True)
class Result:
    """One scalar value an operation returns beside its output files: its name, type
    ("number", "string" or "boolean") and what it is. The engine declares them (QGIS: output
    numbers and strings a model can chain); results not declared (e.g. ROC's per-score
    ``auc_<name>``, named after the inputs) are still returned and logged."""

    name: str
    kind: str
    description: str

    def __iter__(self):  # (name, kind, description), as the engine's schema lists them
        return iter((self.name, self.kind, self.description))


@dataclass(frozen=True, kw_only=True)
class Algorithm:
    """One GIS operation: what every face shows, and the one function that does the work.

    ``run`` is a file-level function of :mod:`geoboresight.operations` whose keyword
    arguments are the parameters (and ``progress``); it returns a dict of results: the output
    paths plus any small values worth showing (e.g. an offset in pixels). The spec wraps it:
    :attr:`operation` is ``run`` with the spec's checks, the files its parameters declare
    (inputs, outputs) guarded, and ``overwrite``, as a Python caller gets it.
    """

    name: str
    display_name: str
    group: str
    short_help: str
    help: str
    params: tuple[Param | Group, ...]
    run: Callable[[dict, Progress], dict] = field(repr=False)
    #: The values ``run`` returns beside its outputs (the engine's result schema).
    results: tuple[Result, ...] = ()
    #: A typical run, flat values by parameter name, files named as in the sample scene
    #: (``vnir.hdr``, ``ratio.tif``, ...): shown in ``--help``, and the base of the project's
    #: own hostile-input catalogue. Every required parameter is in it.
    example: Mapping[str, str] = field(default_factory=dict)
    #: A result holding the whole result as text for a person (``info``'s description): the
    #: command line prints it instead of one ``name: value`` line per result ("": none).
    text: str = ""
    #: Parameters the command line also takes as positional arguments, in this order
    #: (``geoboresight info PATH``, as ``gdalinfo PATH``).
    positional: tuple[str, ...] = ()
    #: The parameter groups among ``params`` (``params`` itself is flattened: what faces see).
    groups: tuple[Group, ...] = field(default=(), init=False, repr=False)
    #: ``run`` checked against this spec (``geoboresight.<name>_file``).
    operation: Callable = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self):
        groups = tuple(p for p in self.params if isinstance(p, Group))
        flat = tuple(q for p in self.params for q in (p.params if isinstance(p, Group) else (p,)))
        object.__setattr__(self, "groups", groups)
        object.__setattr__(self, "params", flat)
        if self.group not in GROUPS:
            raise ValueError(f"{self.name}: unknown group {self.group!r}")
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError(f"{self.name}: duplicate parameter names")
        for p in self.params:
            if isinstance(p, Band) and p.raster not in names:
                raise ValueError(f"{self.name}: band {p.name} refers to unknown {p.raster}")
            if isinstance(p, Band) and p.wavelength and p.wavelength not in names:
                raise ValueError(f"{self.name}: band {p.name} refers to unknown {p.wavelength}")
        _check_signature(self)
        missing = sorted(p.name for p in flat if p.required and p.name not in self.example)
        unknown = sorted(set(self.example) - {p.name for p in flat})
        if missing or unknown:
            raise ValueError(
                f"{self.name}: example lacks required {missing} / names unknown {unknown}"
            )
        object.__setattr__(self, "operation", _wrap(self))

    @property
    def inputs(self) -> tuple[Param, ...]:
        return tuple(p for p in self.params if not p.is_output)

    @property
    def outputs(self) -> tuple[Param, ...]:
        return tuple(p for p in self.params if p.is_output)

    @property
    def files_read(self) -> tuple[str, ...]:
        """The arguments naming files the operation reads: a parameter, or a group's member
        as ``"group.member"`` (``"surface.dsm"``)."""
        member_of = {p.name: f"{g.name}.{g.field(p)}" for g in self.groups for p in g.params}
        return tuple(
            member_of.get(p.name, p.name)
            for p in self.inputs
            if p.kind in ("raster", "multiraster", "file")
        )

    @property
    def files_written(self) -> tuple[str, ...]:
        """The arguments naming the files or folders the operation writes."""
        return tuple(p.name for p in self.outputs)

    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    def validate(self, values: Mapping[str, Any]) -> dict:
        """Fill defaults and coerce; raise ParameterError naming the parameter at fault."""
        values = _resolve_aliases(self, values)
        known = {p.name for p in self.params}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ParameterError(
                f"{self.name}: unknown parameter(s) {', '.join(unknown)}; "
                f"known: {', '.join(sorted(known))}",
                params=tuple(unknown),
            )
        out = {}
        for p in self.params:
            value = values.get(p.name)
            if value is None or (isinstance(value, str) and value == "" and p.kind != "string"):
                if p.required:
                    raise ParameterError(
                        f"{self.name}: parameter '{p.name}' is required ({p.description})",
                        params=(p.name,),
                    )
                out[p.name] = p.default
            else:
                out[p.name] = p.coerce(value)
        _check_bands(self, out)
        return out

    def flatten(self, kwargs: Mapping[str, Any]) -> tuple[dict, dict]:
        """The flat values of an operation's keyword arguments (each group's value spread
        into its members), and the group values given, so that a Python call goes through
        the same checks as every face (:meth:`validate`)."""
        flat = dict(kwargs)
        given = {}
        for g in self.groups:
            if g.name not in flat:
                continue
            value = flat.pop(g.name)
            if value is None:
                continue
            if not isinstance(value, g.value):
                raise ParameterError(
                    f"parameter '{g.name}': expected a {g.value.__name__}, got {_short(value)}",
                    params=(g.name,),
                )
            given[g.name] = value
            for p in g.params:
                flat[p.name] = getattr(value, g.field(p))
        return flat, given

    def example_command(self, program: str = "geoboresight") -> str:
        """:attr:`example` as a command line."""
        words = [program, self.name]
        for name, value in self.example.items():
            if isinstance(value, list | tuple):  # a Numbers parameter: its values in a row
                value = " ".join(f"{v:g}" for v in value)
            words += [f"--{name.replace('_', '-')}", str(value)]
        return " ".join(words)

    def bind(self, values: Mapping[str, Any], given: Mapping[str, Any] | None = None) -> dict:
        """The operation's keyword arguments from validated flat values: each group's members
        become its value (the caller's own value, with its members validated, when given)."""
        out = dict(values)
        for g in self.groups:
            members = {p.name: out.pop(p.name) for p in g.params if p.name in out}
            out[g.name] = g.build(members, (given or {}).get(g.name))
        return out

    def __call__(
        self,
        progress: Progress | None = None,
        overwrite: bool = False,
        cog: bool = False,
        co=None,
        raw_gsd=None,
        **values,
    ):
        """Run from Python: ``registry()['ratio'](vnir='a.hdr', output='r.tif')``."""
        return execute(
            self, values, progress=progress, overwrite=overwrite, cog=cog, co=co, raw_gsd=raw_gsd
        )


def _check_bands(alg: Algorithm, values: dict) -> None:
    # QGIS does not validate a band number against the raster (QGIS.md): we must.
    from ..io.image import band_at, require_band

    for p in alg.params:
        if not isinstance(p, Band) or not values.get(p.raster):
            continue
        nm = values.get(p.wavelength) if p.wavelength else None
        if nm is not None:
            values[p.name] = band_at(values[p.raster], nm, label=p.raster, param=p.wavelength)
        elif values.get(p.name) is not None:
            require_band(values[p.raster], values[p.name], label=p.raster, param=p.name)


def _resolve_aliases(alg: Algorithm, values: Mapping[str, Any]) -> dict:
    """Values given under a former parameter name, under the current one."""
    rename = {a: p.name for p in alg.params for a in p.aliases}
    out = {k: v for k, v in values.items() if k not in rename}
    for key, value in values.items():
        if key not in rename or value is None:
            continue
        name = rename[key]
        if out.get(name) is not None:
            raise ParameterError(
                f"{alg.name}: '{key}' is the former name of '{name}': give only one of them",
                params=(key, name),
            )
        out[name] = value
    return out


#: Parameters of every file-level operation that are not spec parameters.
_RUN_ONLY = ("progress", "overwrite")


def _check_signature(alg: Algorithm) -> None:
    """The spec and its operation must agree: same names, same defaults, and the function takes
    ``progress``. Raised at import, so a renamed parameter cannot reach a face."""
    sig = inspect.signature(alg.run)
    fn = {n: p for n, p in sig.parameters.items() if n not in _RUN_ONLY}
    grouped = {p.name for g in alg.groups for p in g.params}
    names = {p.name for p in alg.params} - grouped | {g.name for g in alg.groups}
    where = f"spec {alg.name!r} and {getattr(alg.run, '__name__', alg.run)}()"
    for g in alg.groups:
        default = fn[g.name].default if g.name in fn else inspect.Parameter.empty
        if default is inspect.Parameter.empty or default != g.initial:
            raise TypeError(f"{where}: group '{g.name}' must default to {g.initial!r}")
        for p in g.params:
            if not p.name.startswith(g.prefix) or not hasattr(default, g.field(p)):
                raise TypeError(f"{where}: {g.value.__name__} has no field '{p.name}'")
            if not p.required and getattr(default, g.field(p)) != p.default:
                raise TypeError(
                    f"{where}: '{p.name}' defaults to {p.default!r} in the spec but "
                    f"{getattr(default, g.field(p))!r} in {g.value.__name__}"
                )
    if set(fn) != names:
        raise TypeError(
            f"{where} disagree: only in the spec {sorted(names - set(fn))}, "
            f"only in the function {sorted(set(fn) - names)}"
        )
    for p in alg.params:
        if p.name in grouped:
            continue
        default = fn[p.name].default
        if p.required:
            if default is not inspect.Parameter.empty and default is not None:
                raise TypeError(f"{where}: '{p.name}' is required but has a default {default!r}")
        elif default is inspect.Parameter.empty or default != p.default:
            raise TypeError(
                f"{where}: '{p.name}' defaults to {p.default!r} in the spec but "
                f"{'nothing' if default is inspect.Parameter.empty else repr(default)} "
                "in the function"
            )
    if "progress" not in sig.parameters:
        raise TypeError(f"{where}: the function takes no 'progress'")


def execute(
    alg: Algorithm,
    values: Mapping[str, Any],
    progress: Progress | None = None,
    overwrite: bool = False,
    cog: bool = False,
    co=None,
    raw_gsd=None,
) -> dict:
    """Validate ``values`` and run ``alg``'s operation (refusing unsafe outputs and removing
    the outputs it created when it fails); ``cog``/``co`` say how its GeoTIFF outputs are
    written (Cloud-Optimised, GDAL creation options ``NAME=VALUE``)."""
    from ..io.raster import writer_options
    from ..progress import library_messages_logged

    progress = as_progress(progress)
    with library_messages_logged(progress):
        values = alg.bind(alg.validate(values))
    with writer_options(cog=cog, co=co, raw_gsd=raw_gsd), library_messages_logged(progress):
        return _run(alg, values, progress, overwrite)


def _run(alg: Algorithm, values: dict, progress, overwrite: bool) -> dict:
    """Run ``alg.run`` on validated keyword arguments, its files guarded."""
    from ..operations._guard import run_guarded

    return run_guarded(
        alg.run,
        {**values, "progress": progress},
        inputs=alg.files_read,
        outputs=alg.files_written,
        overwrite=overwrite,
        params=[p.name for p in alg.params],
    )


def _wrap(alg: Algorithm) -> Callable:
    """``alg.run`` for a Python caller: its arguments go through the spec's coercion and
    checks, as the command line, QGIS, the engine and batch get them (types, ranges, choices,
    finite numbers, bands), then run as :func:`execute` runs them; it gains ``overwrite``."""
    sig = inspect.signature(alg.run)

    @functools.wraps(alg.run)
    def operation(*args, overwrite: bool = False, **kwargs):
        bound = sig.bind(*args, **kwargs)
        bound.apply_defaults()
        values = dict(bound.arguments)
        progress = as_progress(values.pop("progress", None))
        flat, given = alg.flatten(values)
        return _run(alg, alg.bind(alg.validate(flat), given), progress, overwrite)

    params = list(sig.parameters.values())
    params.append(inspect.Parameter("overwrite", inspect.Parameter.KEYWORD_ONLY, default=False))
    operation.__signature__ = sig.replace(parameters=params)
    operation.spec = alg
    return operation


def _scalar(value: Any) -> bool:
    """A number or text: not a bool, list, dict or None (NumPy scalars count as numbers)."""
    if isinstance(value, bool):
        return False
    if isinstance(value, str | int | float):
        return True
    return hasattr(value, "dtype") and getattr(value, "ndim", 1) == 0 and value.dtype.kind in "iuf"


def _path(param: Param, value: Any) -> str:
    """A file path given as text or a path object; anything else (a number, a list) refused
    naming the parameter."""
    if isinstance(value, str | os.PathLike):
        path = os.fspath(value)
        if "\0" in path:
            raise param._fail("the path holds a NUL character")
        return path
    raise param._fail(f"expected a file path, got {_short(value)}")


def _short(value: Any, limit: int = 80) -> str:
    """``repr(value)`` cut to a readable length for an error line."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 1] + "…"


__all__ = [
    "GROUPS",
    "Algorithm",
    "Band",
    "Enum",
    "FileIn",
    "FileOut",
    "Flag",
    "FolderOut",
    "GeoboresightError",
    "Group",
    "MultiRaster",
    "Number",
    "Param",
    "RasterIn",
    "RasterOut",
    "Result",
    "Text",
    "VectorOut",
    "Wavelength",
    "execute",
]
