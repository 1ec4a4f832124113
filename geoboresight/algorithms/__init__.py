"""The list of operations. Each module in this package defines ``ALGORITHMS``, a tuple of
:class:`~geoboresight.algorithms.spec.Algorithm`: an operation is registered by its spec, and
nowhere else (the command line, rio, the engine's schema, QGIS and the top-level Python names
are derived from the specs and the operations' modules).

Another installed package adds its own operations the same way: a module of its own with
``ALGORITHMS``, named in the ``geoboresight.algorithms`` entry-point group of its metadata
(``[project.entry-points."geoboresight.algorithms"] my_ops = "my_package.specs"``), as
``rio`` finds its plugins. Its operations join every face: the command line, ``rio
boresight``, the engine (and so QGIS) and batch.
"""

from __future__ import annotations

import importlib
import pkgutil
import re
from functools import cache
from pathlib import Path

from .spec import GROUPS, Algorithm, execute

__all__ = [
    "ENTRY_POINTS",
    "GROUPS",
    "Algorithm",
    "execute",
    "get",
    "registry",
    "spec_modules",
    "spec_of_operation",
]

#: An operation is declared once, by its spec (``Algorithm(name="ratio", ...)`` in a module of
#: this package); this index of the spec module of each operation is read from the modules'
#: text, so that running one operation imports its own spec module only (and the kernels it
#: needs) rather than all of them: the command line starts in ~0.3 s instead of ~0.8 s, paid
#: again by every operation a user, a script or QGIS runs. tests/test_house.py checks it
#: against the modules' ``ALGORITHMS``.
_DECLARED = re.compile(r'Algorithm\(\s*name="([a-z0-9-]+)"')
#: ... and the file-level operation each spec runs (``run=ratio_file``).
_RUNS = re.compile(r"\brun=(\w+_file)\b")


@cache
def _declarations() -> tuple[dict[str, str], dict[str, str]]:
    """``({operation name: spec module}, {operation function: spec module})``, read once
    from the spec modules' source text."""
    names, runs = {}, {}
    for path in sorted(Path(__file__).parent.glob("*.py")):
        if path.stem == "spec" or path.stem.startswith("_"):
            continue
        text = path.read_text(encoding="utf-8")
        names.update(dict.fromkeys(_DECLARED.findall(text), path.stem))
        runs.update(dict.fromkeys(_RUNS.findall(text), path.stem))
    return names, runs


def spec_modules() -> dict[str, str]:
    """``{operation name: spec module}``, from the spec modules' source text."""
    return dict(_declarations()[0])


def spec_of_operation(function: str) -> Algorithm | None:
    """The spec whose ``run`` is the file-level operation called ``function`` (e.g.
    ``"ratio_file"``), importing its spec module only; None if no spec runs it."""
    stem = _declarations()[1].get(function)
    if stem is not None:
        module = importlib.import_module(f"{__name__}.{stem}")
        for alg in getattr(module, "ALGORITHMS", ()):
            if getattr(alg.run, "__name__", None) == function:
                return alg
    return None


def __getattr__(name: str):
    if name == "MODULES":  # the index, under its former name
        return spec_modules()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


#: The entry-point group whose entries name modules of other packages holding ``ALGORITHMS``.
ENTRY_POINTS = "geoboresight.algorithms"


def _added_modules() -> list:
    """The modules other installed packages register in :data:`ENTRY_POINTS`; one that fails
    to import is left out with a warning naming it (the other operations still run)."""
    import warnings
    from importlib.metadata import entry_points

    modules = []
    for entry in entry_points(group=ENTRY_POINTS):
        try:
            modules.append(entry.load())
        except Exception as exc:  # a broken add-on must not take the built-in operations down
            warnings.warn(
                f"operations of {entry.value} ({entry.name}) not loaded: {exc}", stacklevel=2
            )
    return modules


@cache
def registry() -> dict[str, Algorithm]:
    """All algorithms by name, ordered by group (the paper's applications) then name: this
    package's, then those other packages add (:data:`ENTRY_POINTS`)."""
    found: list[Algorithm] = []
    for info in pkgutil.iter_modules(__path__):
        if info.name == "spec" or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        found.extend(getattr(module, "ALGORITHMS", ()))
    for module in _added_modules():
        found.extend(getattr(module, "ALGORITHMS", ()))
    found.sort(key=lambda a: (GROUPS.index(a.group), a.name))
    names = [a.name for a in found]
    dupes = {n for n in names if names.count(n) > 1}
    if dupes:
        raise RuntimeError(f"duplicate algorithm names: {sorted(dupes)}")
    return {a.name: a for a in found}


def find(name: str) -> Algorithm | None:
    """The algorithm called ``name``, importing only its own spec module; None if unknown."""
    modules = spec_modules()
    if name in modules:
        module = importlib.import_module(f"{__name__}.{modules[name]}")
        for alg in getattr(module, "ALGORITHMS", ()):
            if alg.name == name:
                return alg
    return registry().get(name)


def get(name: str) -> Algorithm:
    """The algorithm called ``name``; a clear error listing the known ones otherwise."""
    from ..errors import ParameterError

    alg = find(name)
    if alg is not None:
        return alg
    algs = registry()
    if name not in algs:
        raise ParameterError(f"unknown operation {name!r}; known: {', '.join(algs)}")
    return algs[name]
