"""Run-time state shared by the spec layer and the operations (no imports at the top: the
command line and the engine's ``version`` stay free of NumPy and GDAL)."""

from __future__ import annotations

import contextvars

#: True while :func:`geoboresight.algorithms.execute` calls an operation whose arguments it
#: has just validated against the spec; a Python call is validated by the operation itself
#: (:func:`geoboresight.operations.operation`).
VALIDATED: contextvars.ContextVar[bool] = contextvars.ContextVar("validated", default=False)


def spec_of(function) -> object | None:
    """The spec (:class:`geoboresight.algorithms.Algorithm`) whose ``run`` is the file-level
    operation ``function``, or None: the one attached to it, else the one the spec modules
    declare for its name (importing that spec module only), which is then attached.

    An operation checks a Python caller's arguments against its spec whatever module it was
    imported from; the spec layer sits above the operations, so it is found by name here, as
    ``geoboresight``'s lazy API finds it, rather than imported by them.
    """
    spec = getattr(function, "spec", None)
    if spec is None:
        import importlib

        algorithms = importlib.import_module("geoboresight.algorithms")
        spec = algorithms.spec_of_operation(function.__name__)
        if spec is not None and spec.run is function:
            function.spec = spec
    return spec
