"""The list of operations. Each module in this package defines ``ALGORITHMS``, a tuple of
:class:`~geoboresight.algorithms.spec.Algorithm`; adding an operation is adding one module.
"""

from __future__ import annotations

import importlib
import pkgutil
from functools import cache

from .spec import GROUPS, Algorithm, execute

__all__ = ["GROUPS", "Algorithm", "execute", "get", "registry"]


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


def get(name: str) -> Algorithm:
    """The algorithm called ``name``; a clear error listing the known ones otherwise."""
    from ..errors import ParameterError

    algs = registry()
    if name not in algs:
        raise ParameterError(f"unknown operation {name!r}; known: {', '.join(algs)}")
    return algs[name]
