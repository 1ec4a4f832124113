"""VRT files that present a product's image to GDAL: raw binary layouts at an offset, a subset
of lines (Specim's image lines before its dark frames), radiance scaling, masks.

The VRTs are written to one temporary folder per process, removed when the process ends; they
refer to the product's own files by absolute path, so nothing is copied.
"""

from __future__ import annotations

import atexit
import itertools
import os
import shutil
import tempfile

_DIR: list[str] = []
_COUNT = itertools.count()


def _folder() -> str:
    if not _DIR:
        _DIR.append(tempfile.mkdtemp(prefix="geoboresight-vrt-"))
        atexit.register(shutil.rmtree, _DIR[0], True)
    return _DIR[0]


def write_vrt(xml: str, stem: str = "product") -> str:
    """Write ``xml`` (a whole ``<VRTDataset>``) to a new .vrt file; its path."""
    path = os.path.join(_folder(), f"{stem}-{os.getpid()}-{next(_COUNT)}.vrt")
    with open(path, "w", encoding="utf-8") as f:
        f.write(xml)
    return path


__all__ = ["write_vrt"]
