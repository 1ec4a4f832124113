"""Writing outputs without ever losing data.

An output is written to a temporary file in the same folder, flushed, closed, checked and only
then renamed into place (``os.replace`` is atomic on one file system), so a failed, cancelled
or killed run never leaves a half file under the user's name and never replaces a good output
with a bad one. Temporary names follow one pattern, ``.{stem}.{pid}-{host}-{random}.tmp{ext}``,
so that the litter of a killed run (SIGKILL, power cut) is recognised and swept by the next run
writing into that folder: at once when the process that made it is gone, after
:data:`STALE_AGE_S` otherwise.

An output may never be one of the inputs, nor any file GDAL opens along with an input (ENVI
header in either naming convention, ``.aux.xml``, world file, overviews, mask): compared by
real path and by inode, so symbolic and hard links are caught too.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import os
import re
import secrets
import shutil
import socket
import stat
import time
from collections.abc import Collection, Iterable, Iterator

from ..errors import OutputError

# ENVI keeps data and header side by side: "scene.hdr" + "scene", "scene.img", "scene.bsq" ...
_ENVI_DATA = ("", ".img", ".dat", ".raw", ".bsq", ".bil", ".bip")
_ENVI_SIDECARS = (*_ENVI_DATA, ".hdr", ".aux.xml")
#: Output names that are sidecars GDAL reads with a raster, never a product of their own.
_SIDECAR_SUFFIXES = (".hdr", ".aux.xml", ".ovr", ".msk")
#: Temporary files of ours older than this are swept even when their writer may be alive
#: (another machine sharing the folder): no output takes a day to write.
STALE_AGE_S = 24 * 3600.0

_HOST = hashlib.blake2s(socket.gethostname().encode(), digest_size=2).hexdigest()
# ".{stem}.{pid}-{host}-{random}.tmp{ext}" (and the ".{stem}.{random}.tmp{ext}" of 0.1).
_TEMP = re.compile(r"^\..+\.(?:(?P<pid>\d+)-(?P<host>[0-9a-f]{4})-)?[A-Za-z0-9_]{6,}\.tmp(\..*)?$")
# A folder output moved aside while its replacement is renamed in.
_BACKUP = re.compile(
    r"^\.(?P<name>.+)\.(?P<pid>\d+)-(?P<host>[0-9a-f]{4})-[A-Za-z0-9_]{6,}\.tmp\.old$"
)
# errno values meaning "this folder cannot take the file", whatever the operation.
_NO_ROOM = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG}
_NOT_WRITABLE = {errno.EROFS, errno.EACCES, errno.EPERM}


def temp_name(path: str) -> str:
    """A fresh temporary path beside ``path`` (same extension, so GDAL picks the same driver)."""
    folder = os.path.dirname(os.path.abspath(path))
    stem, ext = os.path.splitext(os.path.basename(path))
    tag = f"{os.getpid()}-{_HOST}-{secrets.token_hex(4)}"
    return os.path.join(folder, f".{stem}.{tag}.tmp{ext}")


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # EPERM: it exists, owned by someone else
        return True
    return True


def sweep_stale(folder: str, now: float | None = None) -> list[str]:
    """Remove the temporary files and folders our killed runs left in ``folder``; their paths.

    Only names of our pattern are touched: those whose writer (same machine) is no longer
    running, and any older than :data:`STALE_AGE_S`. A folder output moved aside by a swap
    that was interrupted is put back if nothing took its place.
    """
    now = time.time() if now is None else now
    removed = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for entry in entries:
        back = _BACKUP.match(entry.name)
        m = back or _TEMP.match(entry.name)
        if not m:
            continue
        pid, host = m.group("pid"), m.group("host")
        gone = bool(pid) and host == _HOST and int(pid) != os.getpid() and not _alive(int(pid))
        if not gone:
            try:
                age = now - entry.stat(follow_symlinks=False).st_mtime
            except OSError:
                continue
            if age < STALE_AGE_S:
                continue  # its writer may still be at work
        if back is not None:
            original = os.path.join(folder, back.group("name"))
            if not os.path.lexists(original):
                # Killed between the two renames: the previous output is put back, never lost.
                with contextlib.suppress(OSError):
                    os.replace(entry.path, original)
                continue
        try:
            if entry.is_dir(follow_symlinks=False):
                shutil.rmtree(entry.path)
            else:
                os.remove(entry.path)
            removed.append(entry.path)
        except OSError:
            pass
    return removed


def gdal_family(path: str | os.PathLike) -> set[str]:
    """Every file GDAL may open as part of the raster ``path``: the data file, its ENVI header
    in both naming conventions (``scene.hdr``, ``scene.bsq.hdr``), the data file of a header,
    ``.aux.xml``, world files (``.tfw``, ``.tifw``, ``.wld``), overviews (``.ovr``) and masks
    (``.msk``); absolute, beside both the path as given and its real target."""
    names: set[str] = set()
    given = os.path.abspath(os.fspath(path))
    for p in {given, os.path.realpath(given)}:
        stem, ext = os.path.splitext(p)
        names.update({p, p + ".aux.xml", p + ".hdr", p + ".ovr", p + ".msk", p + "w"})
        names.update(stem + e for e in _ENVI_SIDECARS)
        names.add(stem + ".wld")
        if len(ext) >= 3:
            names.add(stem + ext[:2] + ext[-1] + "w")  # .tif -> .tfw, .jpg -> .jgw
        if ext.lower() == ".hdr":  # a header given: its data file and that file's sidecars
            for e in _ENVI_DATA:
                names.update({stem + e, stem + e + ".aux.xml"})
    return names


def _identity(path: str) -> tuple[int, int] | None:
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino) if stat.S_ISREG(st.st_mode) else None


def written_files(path: str) -> set[str]:
    """The files writing ``path`` may create or replace: the file, its ``.aux.xml`` (category
    names, GDAL's PAM) and, for an ENVI data file, its header."""
    p = os.path.abspath(path)
    stem, ext = os.path.splitext(p)
    out = {p, p + ".aux.xml"}
    if ext.lower() in _ENVI_DATA:
        out.add(stem + ".hdr")
    return out


def check_output_path(
    path: str | os.PathLike,
    inputs: Iterable[str | os.PathLike] = (),
    overwrite: bool = False,
    label: str = "output",
) -> None:
    """Raise :class:`OutputError` if writing ``path`` could touch an input (by real path or
    inode: the file, its sidecars, a link to either), if ``path`` exists and ``overwrite`` is
    False, if it is named like a sidecar, or if its folder is missing or not writable."""
    path = os.fspath(path)
    low = path.lower()
    if any(low.endswith(s) for s in _SIDECAR_SUFFIXES):
        raise OutputError(
            f"{label} {path}: names ending in {', '.join(_SIDECAR_SUFFIXES)} are sidecar files "
            "GDAL reads along with a raster: choose a name with the output's own extension "
            "(e.g. .tif)"
        )
    inputs = [os.fspath(i) for i in inputs]
    targets = {os.path.realpath(w) for w in written_files(path)} | written_files(path)
    target_ids = {i for i in map(_identity, targets) if i is not None}
    real = os.path.realpath(path)
    for inp in inputs:
        family = gdal_family(inp)
        family_real = {os.path.realpath(f) for f in family} | family
        family_ids = {i for i in map(_identity, family) if i is not None}
        if targets & family_real or target_ids & family_ids:
            raise OutputError(
                f"{label} {path} is the input {inp} or one of the files read with it (header, "
                ".aux.xml, world file, link): choose another output path; inputs are never "
                "overwritten"
            )
        if os.path.isdir(real) and os.path.realpath(inp).startswith(real + os.sep):
            raise OutputError(
                f"{label} {path} is a folder holding the input {inp}: choose another folder"
            )
    if os.path.lexists(path) and not overwrite:
        raise OutputError(
            f"{label} {path} already exists: choose another path, or pass overwrite=True to "
            "replace it",
            params=("overwrite",),
        )
    parent = os.path.dirname(real) or "."
    if not os.path.isdir(parent):
        raise OutputError(f"{label} {path}: the folder {parent} does not exist; create it first")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OutputError(
            f"{label} {path}: the folder {parent} is not writable (read-only or no "
            "permission): choose another folder"
        )


def output_error(
    exc: BaseException, path: str, tmp: str | None = None, mine: bool = False
) -> OutputError | None:
    """The one-line :class:`OutputError` for an OS or GDAL error met while writing ``path``
    (its temporary file ``tmp``), or None when the error is not about this output (``mine``:
    it is known to be)."""
    text = str(exc)
    code = getattr(exc, "errno", None)
    folder = os.path.dirname(os.path.abspath(path)) or "."
    mine = mine or (
        tmp is not None
        and (getattr(exc, "filename", None) in (tmp, path) or os.path.basename(tmp) in text)
    )
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        free = None
    if code in _NO_ROOM or (mine and free is not None and free < 1 << 20):
        return OutputError(
            f"output {path} could not be written: the disk holding {folder} is full or over "
            f"quota ({'?' if free is None else _size(free)} free); free some space or write "
            "elsewhere. Any previous file of that name is unchanged"
        )
    if code in _NOT_WRITABLE and (mine or getattr(exc, "filename", None) is None):
        return OutputError(
            f"output {path} could not be written: the folder {folder} is read-only or not "
            "writable for you; choose another folder"
        )
    if mine:
        if code:
            reason = os.strerror(code)
        elif text.startswith("Write failed"):
            reason = (
                "GDAL could not write it: the disk may be full, over quota or past a size limit"
            )
        else:
            reason = scrub(text, tmp or path, path)
        return OutputError(
            f"output {path} could not be written ({reason}); any previous file of that name "
            "is unchanged"
        )
    return None


def scrub(text: str, tmp: str, path: str) -> str:
    """A message about ``tmp`` rewritten to name the user's ``path``; on one line."""
    text = text.replace(tmp, path).replace(os.path.basename(tmp), os.path.basename(path))
    return " ".join(text.split())


def _size(n: int) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1024 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1024
    return f"{n} B"


def _fsync(path: str) -> None:
    """Flush a finished file to the disk before it replaces anything (a crash after the rename
    must not leave an empty file under the user's name)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def check_folder_replaceable(path: str, allowed: Collection[str] | None) -> None:
    """An existing folder output is replaced only when it holds nothing but files this
    writer makes (``allowed`` names): a folder of the user's other files is never emptied."""
    if not os.path.isdir(path) or os.path.islink(path):
        if os.path.lexists(path):
            raise OutputError(f"output folder {path} exists and is not a folder: choose another")
        return
    foreign = sorted(
        n for n in os.listdir(path) if allowed is None or n.removesuffix(".aux.xml") not in allowed
    )
    if foreign:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        raise OutputError(
            f"output folder {path} holds files geoboresight did not write ({shown}): it is "
            "never emptied; choose a new or empty folder"
        )


@contextlib.contextmanager
def atomic_output(
    path: str | os.PathLike, overwrite: bool = True, folder_files: Collection[str] | None = None
) -> Iterator[str]:
    """Yield a temporary path beside ``path``; rename it to ``path`` only if the block succeeds.

    The temporary name keeps the extension so that GDAL picks the same driver. Sidecar files
    GDAL writes next to it (``.aux.xml``, an ENVI ``.hdr``) are renamed along with it. A file
    is fsynced before the rename. OS errors about the output (disk full, read-only folder)
    become one-line :class:`OutputError` naming ``path``, never the temporary name. The caller
    creates a folder output at the yielded path; an existing folder is swapped out (never
    emptied) and only if it holds nothing but ``folder_files``.

    >>> with atomic_output("ratio.tif") as tmp:   # doctest: +SKIP
    ...     with rasterio.open(tmp, "w", **profile) as dst: ...
    """
    path = os.fspath(path)
    if os.path.lexists(path) and not overwrite:
        raise OutputError(
            f"output {path} already exists: pass overwrite=True to replace it",
            params=("overwrite",),
        )
    folder = os.path.dirname(os.path.abspath(path))
    sweep_stale(folder)
    if os.path.isdir(path) and not os.path.islink(path):
        check_folder_replaceable(path, folder_files)
    tmp = temp_name(path)
    tmp_stem = os.path.splitext(tmp)[0]
    sidecars = [(tmp + ".aux.xml", path + ".aux.xml")]
    if tmp_stem + ".hdr" != tmp:
        sidecars.insert(0, (tmp_stem + ".hdr", os.path.splitext(path)[0] + ".hdr"))
    try:
        try:
            yield tmp
            if os.path.isdir(tmp):
                _swap_folder(tmp, path, folder_files)
            else:
                if not os.path.isfile(tmp):
                    raise OutputError(f"output {path} was not written (nothing was produced)")
                for src, _ in sidecars:
                    if os.path.exists(src):
                        _fsync(src)
                _fsync(tmp)
                # Sidecars first, so that the main file appears last, complete with its header.
                for src, dst in sidecars:
                    if os.path.exists(src):
                        os.replace(src, dst)
                os.replace(tmp, path)
        except OSError as exc:
            if isinstance(exc, OutputError):
                raise
            # rasterio's "Write failed" is raised by the dataset being written: ours.
            err = output_error(exc, path, tmp, mine=str(exc).startswith("Write failed"))
            if err is None:
                raise
            raise err from exc
    finally:
        for leftover in (tmp, *(s for s, _ in sidecars)):
            with contextlib.suppress(OSError):
                if os.path.isdir(leftover) and not os.path.islink(leftover):
                    shutil.rmtree(leftover, ignore_errors=True)
                elif os.path.lexists(leftover):
                    os.remove(leftover)


def _swap_folder(tmp: str, path: str, folder_files) -> None:
    """Put the finished folder ``tmp`` in place of ``path``: the old one is moved aside under
    our temporary pattern, the new one renamed in, then the old one removed."""
    if not os.path.lexists(path):
        os.replace(tmp, path)
        return
    check_folder_replaceable(path, folder_files)  # it may have changed during the run
    head, name = os.path.split(os.path.abspath(path))
    backup = os.path.join(head, f".{name}.{os.getpid()}-{_HOST}-{secrets.token_hex(4)}.tmp.old")
    os.replace(path, backup)
    try:
        os.replace(tmp, path)
    except OSError:
        os.replace(backup, path)
        raise
    shutil.rmtree(backup, ignore_errors=True)


def write_text(path: str | os.PathLike, text: str, overwrite: bool = True) -> str:
    """Write a text file (HTML, CSV, JSON) atomically."""
    with atomic_output(path, overwrite=overwrite) as tmp, open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    return os.fspath(path)


def write_json(path: str | os.PathLike, data, overwrite: bool = True) -> str:
    """Write ``data`` as indented JSON atomically (NumPy scalars as numbers)."""
    import json

    return write_text(path, json.dumps(data, indent=2, default=float), overwrite=overwrite)


def save_figure(fig, path: str | os.PathLike, overwrite: bool = True) -> str:
    """Save the matplotlib figure ``fig`` (:mod:`geoboresight.figures` draws them) as PNG,
    atomically (temporary file, then rename); ``path``. ``fig`` is only asked to
    ``savefig``: this module does not import matplotlib."""
    path = os.fspath(path)
    with atomic_output(path, overwrite=overwrite) as tmp:
        fig.savefig(tmp, format="png")
    return path


def split_paths(value) -> list[str]:
    """Paths from one path, a comma-separated string of paths, or a list of either (the command
    line gives a list of options, each of which may hold commas)."""
    items = [value] if isinstance(value, str | os.PathLike) else list(value or ())
    return [p.strip() for v in items for p in os.fspath(v).split(",") if p.strip()]
