"""The list of operations. Each module in this package defines ``ALGORITHMS``, a tuple of
:class:`~geoboresight.algorithms.spec.Algorithm`; adding an operation is adding one module.
"""

from __future__ import annotations

import importlib
import pkgutil
from functools import cache

from .spec import GROUPS, Algorithm, execute

__all__ = ["GROUPS", "MODULES", "Algorithm", "execute", "get", "registry"]

#: The spec module of each operation, so that running one operation imports its own module
#: (and the kernels it needs) rather than all of them: the command line starts in ~0.3 s
#: instead of ~0.8 s, paid again by every operation a user, a script or QGIS runs.
#: tests/test_house.py checks it against the modules' ``ALGORITHMS``.
MODULES = {
    **dict.fromkeys(
        ("rx", "svdd", "boresight-indicator", "unmix", "roc", "anomaly-polygons"), "anomaly"
    ),
    **dict.fromkeys(("disparity", "relative-dem", "view-3d"), "dem"),
    **dict.fromkeys(
        ("geolocate", "georeference", "auto-georeference", "reproject-to", "simulate-ortho"),
        "georef",
    ),
    **dict.fromkeys(("boresight-offset", "coregister"), "offset"),
    "ratio": "ratio",
    "report": "report",
    **dict.fromkeys(
        (
            "shadow-classes",
            "shadow-cluster",
            "shadow-fraction-fit",
            "shadow-fraction-apply",
            "shadow-polygons",
        ),
        "shadow",
    ),
    "shadow-map": "shadow_map",
    **dict.fromkeys(("sun-shadow", "dark-pixel-shadow"), "shadow_truth"),
    "simulate": "simulate",
    "stats": "stats",
}


@cache
def registry() -> dict[str, Algorithm]:
    """All algorithms by name, ordered by group (the paper's applications) then name."""
    found: list[Algorithm] = []
    for info in pkgutil.iter_modules(__path__):
        if info.name == "spec" or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        found.extend(getattr(module, "ALGORITHMS", ()))
    found.sort(key=lambda a: (GROUPS.index(a.group), a.name))
    names = [a.name for a in found]
    dupes = {n for n in names if names.count(n) > 1}
    if dupes:
        raise RuntimeError(f"duplicate algorithm names: {sorted(dupes)}")
    return {a.name: a for a in found}


def find(name: str) -> Algorithm | None:
    """The algorithm called ``name``, importing only its own spec module; None if unknown."""
    if name in MODULES:
        module = importlib.import_module(f"{__name__}.{MODULES[name]}")
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
