"""Declarative algorithm specs: the single list every face (CLI, QGIS, rio) is generated from.

An :class:`Algorithm` is data (name, group, help, typed parameters with defaults and ranges)
plus one ``run(values, progress) -> dict`` function. Outputs are parameters too (like QGIS
"destination" parameters), so each face can ask the user where to write them.

Faces never validate by themselves: they collect raw values and call :func:`execute`, which
fills defaults, checks types and ranges, checks bands against their rasters, refuses outputs that
would overwrite an input or an existing file, and removes every output of a run that failed.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, ClassVar

from ..errors import GeoboresightError, OutputError, ParameterError
from ..progress import Progress, as_progress

#: Groups, following the paper's applications (QGIS toolbox groups, CLI listing order).
GROUPS = (
    "Boresight ratio and statistics",
    "Shadow",
    "Relative DEM",
    "Anomaly",
    "Simulation",
    "Report",
)


@dataclass(frozen=True, kw_only=True)
class Param:
    """One parameter. ``default=None`` with ``optional=False`` means required."""

    name: str
    description: str
    default: Any = None
    optional: bool = False
    advanced: bool = False
    kind: ClassVar[str] = "param"
    is_output: ClassVar[bool] = False

    @property
    def required(self) -> bool:
        return self.default is None and not self.optional

    def coerce(self, value: Any) -> Any:
        return value

    def _fail(self, what: str) -> ParameterError:
        return ParameterError(f"parameter '{self.name}': {what}")


@dataclass(frozen=True, kw_only=True)
class RasterIn(Param):
    """A raster file (anything GDAL reads: ENVI .hdr/.img, GeoTIFF, ...)."""

    kind: ClassVar[str] = "raster"

    def coerce(self, value):
        return os.fspath(value)


@dataclass(frozen=True, kw_only=True)
class MultiRaster(Param):
    """Several raster files (a list of paths, or one comma-separated string)."""

    kind: ClassVar[str] = "multiraster"

    def coerce(self, value):
        if isinstance(value, str | os.PathLike):
            value = [v for v in str(value).split(",") if v.strip()]
        paths = [os.fspath(v).strip() for v in value]
        if not paths:
            raise self._fail("give at least one raster")
        return paths


@dataclass(frozen=True, kw_only=True)
class FileIn(Param):
    """A non-raster input file (CSV table, spectral library, JSON)."""

    extensions: tuple[str, ...] = ()
    kind: ClassVar[str] = "file"

    def coerce(self, value):
        return os.fspath(value)


@dataclass(frozen=True, kw_only=True)
class Band(Param):
    """A 1-based band number of the raster parameter named ``raster``."""

    raster: str = ""
    kind: ClassVar[str] = "band"

    def coerce(self, value):
        try:
            band = int(value)
        except (TypeError, ValueError):
            raise self._fail(f"band must be a whole number, got {value!r}") from None
        if band < 1:
            raise self._fail(f"bands are numbered from 1, got {band}")
        return band


@dataclass(frozen=True, kw_only=True)
class Number(Param):
    """A number with an optional inclusive range; ``integer=True`` for whole numbers."""

    minimum: float | None = None
    maximum: float | None = None
    integer: bool = False
    unit: str = ""
    kind: ClassVar[str] = "number"

    def coerce(self, value):
        try:
            number = int(value) if self.integer else float(value)
        except (TypeError, ValueError):
            raise self._fail(f"expected a number, got {value!r}") from None
        if self.integer and float(value) != number:
            raise self._fail(f"expected a whole number, got {value!r}")
        unit = f" {self.unit}" if self.unit else ""
        if self.minimum is not None and number < self.minimum:
            raise self._fail(f"{number}{unit} is below the minimum {self.minimum}{unit}")
        if self.maximum is not None and number > self.maximum:
            raise self._fail(f"{number}{unit} is above the maximum {self.maximum}{unit}")
        return number


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
        if isinstance(value, int) and not isinstance(value, bool) and value < len(self.choices):
            return self.choices[value]  # QGIS passes enums as indexes
        value = str(value)
        if value not in self.choices:
            raise self._fail(f"{value!r} is not one of {', '.join(self.choices)}")
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
            raise self._fail(f"expected yes or no, got {value!r}")
        return bool(value)


@dataclass(frozen=True, kw_only=True)
class Text(Param):
    """Free text (e.g. a comma-separated list of wavelengths)."""

    kind: ClassVar[str] = "string"

    def coerce(self, value):
        return str(value)


@dataclass(frozen=True, kw_only=True)
class _Out(Param):
    extension: str = ""
    is_output: ClassVar[bool] = True

    def coerce(self, value):
        return os.fspath(value)


@dataclass(frozen=True, kw_only=True)
class RasterOut(_Out):
    """A raster to write (GeoTIFF)."""

    extension: str = "tif"
    kind: ClassVar[str] = "raster_out"


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
class Algorithm:
    """One GIS operation: what every face shows, and the one function that does the work.

    ``run(values, progress)`` receives validated values (defaults filled in, outputs included)
    and returns a dict of results: the output paths plus any small values worth showing
    (e.g. an offset in pixels). It must write outputs through
    :func:`geoboresight.io.atomic_output` so a failure leaves no half file.
    """

    name: str
    display_name: str
    group: str
    short_help: str
    help: str
    params: tuple[Param, ...]
    run: Callable[[dict, Progress], dict] = field(repr=False)

    def __post_init__(self):
        if self.group not in GROUPS:
            raise ValueError(f"{self.name}: unknown group {self.group!r}")
        names = [p.name for p in self.params]
        if len(set(names)) != len(names):
            raise ValueError(f"{self.name}: duplicate parameter names")
        for p in self.params:
            if isinstance(p, Band) and p.raster not in names:
                raise ValueError(f"{self.name}: band {p.name} refers to unknown {p.raster}")

    @property
    def inputs(self) -> tuple[Param, ...]:
        return tuple(p for p in self.params if not p.is_output)

    @property
    def outputs(self) -> tuple[Param, ...]:
        return tuple(p for p in self.params if p.is_output)

    def param(self, name: str) -> Param:
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(name)

    def validate(self, values: Mapping[str, Any]) -> dict:
        """Fill defaults and coerce; raise ParameterError naming the parameter at fault."""
        known = {p.name for p in self.params}
        unknown = sorted(set(values) - known)
        if unknown:
            raise ParameterError(
                f"{self.name}: unknown parameter(s) {', '.join(unknown)}; "
                f"known: {', '.join(sorted(known))}"
            )
        out = {}
        for p in self.params:
            value = values.get(p.name)
            if value is None or (isinstance(value, str) and value == "" and p.kind != "string"):
                if p.required:
                    raise ParameterError(
                        f"{self.name}: parameter '{p.name}' is required ({p.description})"
                    )
                out[p.name] = p.default
            else:
                out[p.name] = p.coerce(value)
        _check_bands(self, out)
        return out

    def __call__(self, progress: Progress | None = None, overwrite: bool = False, **values):
        """Run from Python: ``registry()['ratio'](vnir='a.hdr', output='r.tif')``."""
        return execute(self, values, progress=progress, overwrite=overwrite)


def _check_bands(alg: Algorithm, values: dict) -> None:
    # QGIS does not validate a band number against the raster (QGIS.md): we must.
    from ..io.raster import band_count

    for p in alg.params:
        if isinstance(p, Band) and values.get(p.name) is not None and values.get(p.raster):
            count = band_count(values[p.raster])
            if values[p.name] > count:
                raise ParameterError(
                    f"parameter '{p.name}': band {values[p.name]} does not exist in "
                    f"{values[p.raster]}, which has {count} band(s)"
                )


def output_paths(alg: Algorithm, values: Mapping[str, Any]) -> list[str]:
    return [values[p.name] for p in alg.outputs if values.get(p.name)]


def input_paths(alg: Algorithm, values: Mapping[str, Any]) -> list[str]:
    paths: list[str] = []
    for p in alg.inputs:
        v = values.get(p.name)
        if v is None:
            continue
        if p.kind in ("raster", "file"):
            paths.append(v)
        elif p.kind == "multiraster":
            paths.extend(v)
    return paths


def check_outputs(alg: Algorithm, values: Mapping[str, Any], overwrite: bool) -> None:
    """Refuse an output equal to an input (or its ENVI sidecar), or an existing one."""
    from ..io.write import check_output_path

    ins = input_paths(alg, values)
    outs = output_paths(alg, values)
    seen: set[str] = set()
    for p in alg.outputs:
        path = values.get(p.name)
        if not path:
            continue
        real = os.path.realpath(path)
        if real in seen:
            raise OutputError(f"output '{p.name}' ({path}) is also given for another output")
        seen.add(real)
        check_output_path(path, ins, overwrite=overwrite, label=f"output '{p.name}'")
    del outs


def execute(
    alg: Algorithm,
    values: Mapping[str, Any],
    progress: Progress | None = None,
    overwrite: bool = False,
) -> dict:
    """Validate ``values``, run ``alg``, and on any failure remove the outputs it created."""
    values = alg.validate(values)
    check_outputs(alg, values, overwrite)
    outs = output_paths(alg, values)
    existed = {o for o in outs if os.path.lexists(o)}
    try:
        return alg.run(values, as_progress(progress))
    except BaseException:
        for o in outs:
            if o not in existed:
                _remove(o)
        raise


def _remove(path: str) -> None:
    import shutil

    try:
        if os.path.isdir(path) and not os.path.islink(path):
            shutil.rmtree(path)
        elif os.path.lexists(path):
            os.remove(path)
    except OSError:
        pass


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
    "MultiRaster",
    "Number",
    "Param",
    "RasterIn",
    "RasterOut",
    "Text",
    "VectorOut",
    "Wavelength",
    "execute",
]
