"""Run-time state shared by the spec layer and the operations (no imports: the command line
and the engine's ``version`` stay free of NumPy and GDAL)."""

from __future__ import annotations

import contextvars

#: True while :func:`geoboresight.algorithms.execute` calls an operation whose arguments it
#: has just validated against the spec; a Python call is validated by the operation itself
#: (:func:`geoboresight.operations.operation`).
VALIDATED: contextvars.ContextVar[bool] = contextvars.ContextVar("validated", default=False)
