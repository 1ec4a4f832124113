"""Shared by the raw-binary readers (Specim raw ENVI, HySpex): the VRT of a raw interleaved
cube (a subset of its lines), a mask hiding a few columns of one band, and streaming means of
lines (dark frames).

The VRT bands are ``VRTRawRasterBand`` (GDAL's raw reader: image offset, pixel and line
offsets, byte order), so GDAL reads the product's own file in place; a mask is a per-band
``<MaskBand>`` (GDAL mask convention: 255 valid, 0 not), which
:func:`geoboresight.io.windows.read_masked` honours when the band has no nodata.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from xml.sax.saxutils import escape

import numpy as np

from .vrt import _folder, write_vrt

#: Lines read at a time when averaging dark frames (bounded memory whatever their number).
BLOCK_LINES = 256

#: GDAL data type names of the NumPy types raw sensor files hold.
_GDAL_TYPES = {
    "u1": "Byte",
    "i2": "Int16",
    "u2": "UInt16",
    "i4": "Int32",
    "u4": "UInt32",
    "f4": "Float32",
    "f8": "Float64",
}

_LOCK = threading.Lock()


@dataclass(frozen=True)
class RawCube:
    """The byte layout of an uncompressed cube in ``path``: ``lines`` × ``bands`` ×
    ``samples`` values of ``dtype`` (with its byte order) from byte ``offset``."""

    path: str
    lines: int
    bands: int
    samples: int
    offset: int
    dtype: np.dtype
    interleave: str = "bil"  # "bil", "bsq" or "bip"

    @property
    def nbytes(self) -> int:
        return self.lines * self.bands * self.samples * self.dtype.itemsize

    def band_layout(self, band: int) -> tuple[int, int, int]:
        """(image offset, pixel offset, line offset) in bytes of 0-based ``band``."""
        size = self.dtype.itemsize
        b, s, n = self.bands, self.samples, self.lines
        if self.interleave == "bil":
            return self.offset + band * s * size, size, b * s * size
        if self.interleave == "bsq":
            return self.offset + band * n * s * size, size, s * size
        return self.offset + band * size, b * size, s * b * size  # bip

    def memmap(self) -> np.ndarray:
        """The cube as (lines, bands, samples), read-only, without reading it."""
        shape = {
            "bil": (self.lines, self.bands, self.samples),
            "bsq": (self.bands, self.lines, self.samples),
            "bip": (self.lines, self.samples, self.bands),
        }[self.interleave]
        mm = np.memmap(self.path, dtype=self.dtype, mode="r", offset=self.offset, shape=shape)
        if self.interleave == "bsq":
            return mm.transpose(1, 0, 2)
        if self.interleave == "bip":
            return mm.transpose(0, 2, 1)
        return mm

    def line_mean(self, first: int, stop: int) -> np.ndarray:
        """Mean of lines ``first`` … ``stop - 1`` per band and sample, (bands, samples) float64,
        accumulated in float64 over blocks of :data:`BLOCK_LINES` lines."""
        mm = self.memmap()
        total = np.zeros((self.bands, self.samples), np.float64)
        for r0 in range(first, stop, BLOCK_LINES):
            r1 = min(stop, r0 + BLOCK_LINES)
            total += np.asarray(mm[r0:r1]).sum(axis=0, dtype=np.float64)
        del mm
        return total / (stop - first)


def _valid_pixel() -> str:
    """A 1 × 1 Byte GeoTIFF holding 255 (valid), stretched over a mask's valid columns."""
    path = os.path.join(_folder(), "valid-pixel.tif")
    with _LOCK:
        if not os.path.exists(path):
            import rasterio

            from ..raster import quiet_georef

            tmp = f"{path}.{os.getpid()}.tmp.tif"
            with (
                quiet_georef(),
                rasterio.open(
                    tmp, "w", driver="GTiff", width=1, height=1, count=1, dtype="uint8"
                ) as dst,
            ):
                dst.write(np.full((1, 1, 1), 255, np.uint8))
            os.replace(tmp, path)
    return path


def _mask_xml(width: int, height: int, hidden: tuple[int, ...]) -> str:
    """A band mask valid everywhere but the columns ``hidden`` (0-based)."""
    one = escape(_valid_pixel())
    sources = []
    cols = [c for c in range(width) if c not in hidden]
    runs: list[list[int]] = []
    for c in cols:
        if runs and runs[-1][1] == c:
            runs[-1][1] = c + 1
        else:
            runs.append([c, c + 1])
    for c0, c1 in runs:
        sources.append(
            "      <SimpleSource>"
            f'<SourceFilename relativeToVRT="0">{one}</SourceFilename>'
            "<SourceBand>1</SourceBand>"
            '<SrcRect xOff="0" yOff="0" xSize="1" ySize="1"/>'
            f'<DstRect xOff="{c0}" yOff="0" xSize="{c1 - c0}" ySize="{height}"/>'
            "</SimpleSource>"
        )
    body = "\n".join(sources)
    return (
        '    <MaskBand>\n     <VRTRasterBand dataType="Byte">\n'
        f"{body}\n     </VRTRasterBand>\n    </MaskBand>\n"
    )


def raw_vrt(
    cube: RawCube,
    lines: int,
    wavelengths=None,
    masked: dict[int, tuple[int, ...]] | None = None,
    stem: str = "raw",
) -> str:
    """Write a VRT showing lines 0 … ``lines - 1`` of ``cube``, every band, in place; its path.

    ``wavelengths`` (nm, one per band) become band tags and descriptions (other tools see
    them too); ``masked`` maps a 0-based band to the 0-based columns its mask hides.
    """
    kind = _GDAL_TYPES[cube.dtype.str[1:]]
    order = "MSB" if cube.dtype.byteorder == ">" else "LSB"
    src = escape(os.path.abspath(cube.path))
    parts = [f'<VRTDataset rasterXSize="{cube.samples}" rasterYSize="{lines}">\n']
    for b in range(cube.bands):
        image, pixel, line = cube.band_layout(b)
        meta = ""
        if wavelengths is not None:
            w = float(wavelengths[b])
            meta = (
                f"    <Description>{w:.3f} nm</Description>\n"
                f'    <Metadata><MDI key="wavelength">{w:.6f}</MDI>'
                '<MDI key="wavelength_units">nm</MDI></Metadata>\n'
            )
        mask = ""
        if masked and b in masked:
            mask = _mask_xml(cube.samples, lines, masked[b])
        parts.append(
            f'  <VRTRasterBand dataType="{kind}" band="{b + 1}" subClass="VRTRawRasterBand">\n'
            f"{meta}"
            f'    <SourceFilename relativeToVRT="0">{src}</SourceFilename>\n'
            f"    <ImageOffset>{image}</ImageOffset>\n"
            f"    <PixelOffset>{pixel}</PixelOffset>\n"
            f"    <LineOffset>{line}</LineOffset>\n"
            f"    <ByteOrder>{order}</ByteOrder>\n"
            f"{mask}"
            "  </VRTRasterBand>\n"
        )
    parts.append("</VRTDataset>\n")
    return write_vrt("".join(parts), stem)


__all__ = ["BLOCK_LINES", "RawCube", "raw_vrt"]
