"""Worker threads for per-pixel work: how many, and one BLAS thread each while they run.

Below every other layer, so that a kernel that runs independent fits at once (the shadow
cluster's candidates) and the strip loop of :func:`geoboresight.io.map_windows` share them.
"""

from __future__ import annotations

import contextlib
import os


def default_workers() -> int:
    """Worker threads for per-pixel spectral work: the CPU count, at most 4."""
    return max(1, min(os.cpu_count() or 1, 4))


@contextlib.contextmanager
def single_threaded_blas():
    """One BLAS thread while worker threads run (threadpoolctl ships with scikit-learn)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:  # pragma: no cover - then BLAS keeps its own threads
        yield
        return
    with threadpool_limits(1, user_api="blas"):
        yield
