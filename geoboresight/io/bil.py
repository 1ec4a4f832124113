"""Writing an ENVI band-interleaved-by-line cube strip by strip: the layout raw sensor data and
radiance cubes are delivered in (NERC-ARF APL writes its level-1 radiance so), and the one
every cube operation reads fastest (:class:`geoboresight.io.Cube` reads it straight from disk).

A strip of lines in BIL order, (lines, bands, samples), is the file's bytes as they are: it is
appended without reordering, uncompressed, so writing costs what the disk does. The header
names the bands' wavelengths and FWHM (nm), the nodata value ("data ignore value") and the
tags a GeoTIFF would carry, as ENVI keys (GDAL reads them into the ENVI metadata domain).
Written atomically: the data file and its header appear together when complete.
"""

from __future__ import annotations

import contextlib
import os

import numpy as np

from .._version import __version__
from ..errors import OutputError
from .grid import FLOAT_NODATA, Grid
from .write import atomic_output

#: Output endings written as ENVI BIL (anything else is a GeoTIFF).
BIL_ENDINGS = (".img", ".bil", ".dat")


def is_bil(path) -> bool:
    """Whether an output path names an ENVI BIL cube (:data:`BIL_ENDINGS`)."""
    return os.path.splitext(os.fspath(path))[1].lower() in BIL_ENDINGS


def _value(text) -> str:
    # ENVI values are one line; braces would open a list, and GDAL drops a line holding a
    # second "=".
    text = str(text).replace("{", "(").replace("}", ")").replace(" = ", ": ").replace("=", ":")
    return " ".join(text.split())


class BilWriter:
    """Appends strips of float32 lines, (lines, bands, samples), in order."""

    def __init__(self, f, grid: Grid, count: int):
        self._f, self._grid, self._count, self.rows = f, grid, count, 0

    def write(self, block: np.ndarray, window=None) -> None:
        block = np.asarray(block)
        if window is not None and window.row_off != self.rows:
            raise ValueError(f"strip at line {window.row_off}, expected line {self.rows}")
        if block.shape[1:] != (self._count, self._grid.width):
            raise ValueError(f"strip of shape {block.shape} in a cube of {self._count} bands")
        np.ascontiguousarray(block, dtype="<f4").tofile(self._f)
        self.rows += block.shape[0]


@contextlib.contextmanager
def create_bil(
    path,
    grid: Grid,
    *,
    count: int,
    wavelengths,
    fwhm=None,
    nodata: float = FLOAT_NODATA,
    tags: dict | None = None,
    band_names=None,
    overwrite: bool = True,
):
    """Open a new float32 ENVI BIL cube of ``count`` bands on ``grid`` (raw sensor geometry:
    no map info) for strip-by-strip writing; yields a :class:`BilWriter`."""
    grid = Grid.of(grid)
    with atomic_output(path, overwrite=overwrite) as tmp:
        with open(tmp, "wb") as f:
            writer = BilWriter(f, grid, count)
            yield writer
        if writer.rows != grid.height:
            raise OutputError(f"output {path}: {writer.rows} of {grid.height} lines were written")
        lines = [
            "ENVI",
            f"description = {{geoboresight {__version__}: {_value((tags or {}).get('product', ''))}}}",
            f"samples = {grid.width}",
            f"lines = {grid.height}",
            f"bands = {count}",
            "header offset = 0",
            "file type = ENVI Standard",
            "data type = 4",
            "interleave = bil",
            "byte order = 0",
            f"data ignore value = {nodata:g}",
            "wavelength units = Nanometers",
            "wavelength = {" + ", ".join(f"{w:.4f}" for w in wavelengths) + "}",
        ]
        if fwhm is not None:
            lines.append("fwhm = {" + ", ".join(f"{w:.4f}" for w in fwhm) + "}")
        if band_names:
            lines.append(
                "band names = {" + ", ".join(_value(n).replace(",", ";") for n in band_names) + "}"
            )
        for key, value in (tags or {}).items():
            if key.lower() not in ("wavelength", "fwhm", "description"):
                lines.append(f"{key.lower().replace('_', ' ')} = {_value(value)}")
        with open(os.path.splitext(tmp)[0] + ".hdr", "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")


__all__ = ["BIL_ENDINGS", "BilWriter", "create_bil", "is_bil"]
