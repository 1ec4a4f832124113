"""Writing outputs without ever losing data.

An output is written to a temporary file in the same folder and renamed into place only when
complete (``os.replace`` is atomic on one file system), so a failed or cancelled run leaves no half
file. An output may never be one of the inputs, nor one of an input's ENVI sidecar files.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator

from ..errors import OutputError

# ENVI keeps data and header side by side: "scene.hdr" + "scene", "scene.img", "scene.bsq" ...
_ENVI_SIDECARS = ("", ".hdr", ".img", ".dat", ".raw", ".bsq", ".bil", ".bip", ".aux.xml")


def _family(path: str) -> set[str]:
    """The real paths of a file and its likely sidecars (ENVI header/data, .aux.xml)."""
    real = os.path.realpath(path)
    stem, _ = os.path.splitext(real)
    names = {real, real + ".aux.xml"}
    names.update(stem + ext for ext in _ENVI_SIDECARS)
    return names


def check_output_path(
    path: str | os.PathLike,
    inputs: Iterable[str | os.PathLike] = (),
    overwrite: bool = False,
    label: str = "output",
) -> None:
    """Raise :class:`OutputError` if ``path`` is an input, or exists and ``overwrite`` is False."""
    path = os.fspath(path)
    real = os.path.realpath(path)
    for inp in inputs:
        if real in _family(os.fspath(inp)):
            raise OutputError(
                f"{label} {path} is the input file {inp} (or one of its sidecars): "
                "choose another output path; inputs are never overwritten"
            )
    if os.path.lexists(path) and not overwrite:
        raise OutputError(
            f"{label} {path} already exists: choose another path, or pass --overwrite "
            "(overwrite=True) to replace it"
        )
    parent = os.path.dirname(real) or "."
    if not os.path.isdir(parent):
        raise OutputError(f"{label} {path}: the folder {parent} does not exist; create it first")


@contextlib.contextmanager
def atomic_output(path: str | os.PathLike, overwrite: bool = True) -> Iterator[str]:
    """Yield a temporary path beside ``path``; rename it to ``path`` only if the block succeeds.

    The temporary name keeps the extension so that GDAL picks the same driver. Sidecar files
    GDAL writes next to it (``.aux.xml``, an ENVI ``.hdr``) are renamed along with it.

    >>> with atomic_output("ratio.tif") as tmp:   # doctest: +SKIP
    ...     with rasterio.open(tmp, "w", **profile) as dst: ...
    """
    path = os.fspath(path)
    if os.path.lexists(path) and not overwrite:
        raise OutputError(f"output {path} already exists: pass --overwrite to replace it")
    folder = os.path.dirname(os.path.abspath(path))
    stem, ext = os.path.splitext(os.path.basename(path))
    fd, tmp = tempfile.mkstemp(prefix=f".{stem}.", suffix=f".tmp{ext}", dir=folder)
    os.close(fd)
    os.remove(tmp)  # GDAL wants to create the file itself
    tmp_stem = os.path.splitext(tmp)[0]
    try:
        yield tmp
        # Move sidecars first so that the main file appears last, complete with its header.
        for side in (".hdr", ".aux.xml"):
            src = (tmp_stem + side) if side == ".hdr" else (tmp + side)
            if os.path.exists(src):
                dst = (os.path.splitext(path)[0] + side) if side == ".hdr" else (path + side)
                os.replace(src, dst)
        if os.path.isdir(tmp):
            if os.path.isdir(path):
                shutil.rmtree(path)
            os.replace(tmp, path)
        else:
            os.replace(tmp, path)
    finally:
        for leftover in (tmp, tmp + ".aux.xml", tmp_stem + ".hdr"):
            if os.path.isdir(leftover):
                shutil.rmtree(leftover, ignore_errors=True)
            elif os.path.lexists(leftover):
                os.remove(leftover)


def write_text(path: str | os.PathLike, text: str, overwrite: bool = True) -> str:
    """Write a text file (HTML, CSV, JSON) atomically."""
    with atomic_output(path, overwrite=overwrite) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    return os.fspath(path)


def write_json(path: str | os.PathLike, data, overwrite: bool = True) -> str:
    """Write ``data`` as indented JSON atomically (NumPy scalars as numbers)."""
    import json

    return write_text(path, json.dumps(data, indent=2, default=float), overwrite=overwrite)


def split_paths(value) -> list[str]:
    """Paths from one path, a comma-separated string of paths, or a list of either (the command
    line gives a list of options, each of which may hold commas)."""
    items = [value] if isinstance(value, str | os.PathLike) else list(value or ())
    return [p.strip() for v in items for p in os.fspath(v).split(",") if p.strip()]
