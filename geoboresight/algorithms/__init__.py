"""The list of operations. Each spec module of this package, named in :data:`SPECS` with the
operations it declares, defines ``ALGORITHMS``, a tuple of
:class:`~geoboresight.algorithms.spec.Algorithm`: an operation is registered by its spec, and
nowhere else (the command line, rio, the engine's schema, QGIS and the top-level Python names
are derived from the specs).

Another installed package adds its own operations the same way: a module of its own with
``ALGORITHMS``, named in the ``geoboresight.algorithms`` entry-point group of its metadata
(``[project.entry-points."geoboresight.algorithms"] my_ops = "my_package.specs"``), as
``rio`` finds its plugins. Its operations join every face: the command line, ``rio
boresight``, the engine (and so QGIS) and batch.
"""

from __future__ import annotations

import importlib
from functools import cache

from .spec import GROUPS, Algorithm, execute

__all__ = [
    "ENTRY_POINTS",
    "GROUPS",
    "SPECS",
    "Algorithm",
    "execute",
    "get",
    "registry",
]

#: The spec modules of this package and the operations each declares, so that running one
#: operation imports its own spec module only (and the kernels it needs) rather than all of
#: them: the command line starts in ~0.3 s instead of ~0.8 s, paid again by every operation a
#: user, a script or QGIS runs. Each operation ``name`` runs ``<name>_file`` (``-`` as ``_``),
#: which is also its top-level Python name. tests/test_house.py checks this list against the
#: modules' ``ALGORITHMS``.
SPECS: dict[str, tuple[str, ...]] = {
    "ratio": ("ratio",),
    "stats": ("stats",),
    "info": ("info",),
    "shadow": (
        "shadow-classes",
        "shadow-cluster",
        "shadow-fraction-fit",
        "shadow-fraction-apply",
        "shadow-polygons",
    ),
    "shadow_map": ("shadow-map",),
    "shadow_truth": ("sun-shadow", "dark-pixel-shadow"),
    "deshadow": ("deshadow",),
    "offset": ("boresight-offset", "coregister"),
    "dem": ("disparity", "relative-dem", "view-3d"),
    "anomaly": ("rx", "svdd", "boresight-indicator", "unmix"),
    "roc": ("roc", "anomaly-polygons"),
    "simulate": ("simulate",),
    "georef": ("geolocate", "georeference", "reproject-to", "simulate-ortho"),
    "georef_auto": ("auto-georeference",),
    "direct_georef": ("direct-georeference",),
    "boresight_calibrate": ("boresight-calibrate",),
    "radiance": ("radiance",),
    "report": ("report",),
}


def spec_module(name: str) -> str | None:
    """The module (under this package) declaring operation ``name``, or None."""
    for module, names in SPECS.items():
        if name in names:
            return f"{__name__}.{module}"
    return None


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
    for module in SPECS:
        found.extend(importlib.import_module(f"{__name__}.{module}").ALGORITHMS)
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
    module = spec_module(name)
    if module is not None:
        for alg in importlib.import_module(module).ALGORITHMS:
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
