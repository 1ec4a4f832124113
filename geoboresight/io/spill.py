"""Values spilled to a temporary file, to be read again pass after pass in bounded memory.

A statistic that needs several passes over values that are expensive to recompute (e.g. the
boresight indicator's local residuals, each strip a median filter) writes them once here and
reads them back block by block. The file lives beside the output (not in ``/tmp``, which may be
RAM-backed) and is deleted when the spill is closed, whether the run succeeds or fails.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterator

import numpy as np

#: Values per block read back (8 MB of float64).
SPILL_BLOCK = 1 << 20


class Spill:
    """An append-only float64 stream on disk: ``append`` arrays, then iterate ``blocks()``."""

    def __init__(self, near: str | os.PathLike | None = None, block: int = SPILL_BLOCK):
        folder = os.path.dirname(os.path.abspath(os.fspath(near))) if near else None
        self._file = tempfile.TemporaryFile(prefix=".geoboresight-spill-", dir=folder)
        self._block = int(block)
        self.size = 0

    def append(self, values: np.ndarray) -> None:
        v = np.ascontiguousarray(values, dtype=np.float64).ravel()
        self._file.write(v.tobytes())
        self.size += v.size

    def blocks(self) -> Iterator[np.ndarray]:
        self._file.flush()
        self._file.seek(0)
        left = self.size
        while left > 0:
            v = np.fromfile(self._file, dtype=np.float64, count=min(self._block, left))
            left -= v.size
            yield v

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> Spill:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
