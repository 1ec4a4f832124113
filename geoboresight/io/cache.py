"""Values measured from files, remembered between runs (the boresight offset).

Several operations of a flight line measure the same value from the same files: ``rx``,
``svdd``, ``relative-dem``, ``coregister`` and ``boresight-offset`` all measure the boresight
offset, each reading the whole line for it. The first measurement is kept as a small JSON file
in the user's cache folder, under a key of everything it depends on: each file's path, size,
modification time and inode (GDAL's list of the dataset's files, so an ENVI header's data
file counts), the parameters of the measurement and the library's version. The next operation
on the same files reads it instead of the line. A file written again has another key.

The folder is ``$GEOBORESIGHT_CACHE_DIR``, else ``$XDG_CACHE_HOME/geoboresight``, else
``~/.cache/geoboresight``. ``GEOBORESIGHT_CACHE_DIR=`` (empty) turns remembering off. A
folder that cannot be written only costs the measurement again.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import tempfile
from collections.abc import Callable

from .._version import __version__

#: The environment variable naming the cache folder (empty: no cache).
CACHE_ENV = "GEOBORESIGHT_CACHE_DIR"


def cache_dir() -> str | None:
    """The folder values are remembered in, or None when remembering is off."""
    given = os.environ.get(CACHE_ENV)
    if given is not None:
        return given or None
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return os.path.join(base, "geoboresight")


def _on_disk(name: str) -> str | None:
    """The file on disk behind a GDAL name: itself, the archive of a ``/vsizip/`` member, or
    the file of a ``DRIVER:"file":subdataset`` name."""
    quoted = re.search(r'"([^"]+)"', name)
    path = quoted.group(1) if quoted else re.sub(r"^/vsi\w+/", "", name)
    while path and not os.path.isfile(path):
        parent = os.path.dirname(path)
        if parent == path:
            return None
        path = parent
    return path or None


def files_key(paths) -> list | None:
    """``[path, size, mtime_ns, inode]`` of every file the datasets ``paths`` are read from
    (GDAL's file list), or None when one cannot be told (then nothing is remembered)."""
    from .raster import open_raster

    names = []
    for p in paths:
        if p is None:
            continue
        with open_raster(os.fspath(p), "image") as src:
            names += list(src.files or [src.name])
    key = []
    for name in dict.fromkeys(names):
        path = _on_disk(name)
        if path is None:
            return None
        st = os.stat(path)
        key.append([os.path.realpath(path), st.st_size, st.st_mtime_ns, st.st_ino])
    return key


def remembered(kind: str, key: dict | None, measure: Callable[[], dict]) -> tuple[dict, bool]:
    """``(value, from_cache)``: the value remembered under ``kind`` and ``key``, else
    ``measure()`` (a JSON-able dict), remembered for next time. ``key`` None: measured."""
    folder = cache_dir()
    if folder is None or key is None:
        return measure(), False
    text = json.dumps({"kind": kind, "version": __version__, **key}, sort_keys=True)
    path = os.path.join(folder, f"{kind}-{hashlib.sha256(text.encode()).hexdigest()[:32]}.json")
    try:
        with open(path, encoding="utf-8") as f:
            entry = json.load(f)
        if entry.get("key") == text:
            return entry["value"], True
    except (OSError, ValueError, KeyError):
        pass  # not remembered yet, or unreadable: measure
    value = measure()
    try:
        os.makedirs(folder, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=folder, suffix=".tmp")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump({"key": text, "value": value}, f)
        os.replace(tmp, path)  # atomic: a reader sees the whole entry or none
    except OSError:
        pass  # a read-only or full cache folder costs the measurement next time, nothing else
    return value, False
