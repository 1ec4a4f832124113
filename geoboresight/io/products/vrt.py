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
from xml.sax.saxutils import escape

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


def stacked_vrt(sources, stem: str = "stack") -> str:
    """A VRT of every band of each of ``sources`` (what GDAL opens for a product's images, on
    one grid) one after the other: band values, nodata, masks, band metadata (wavelength),
    descriptions and units as each source gives them; its path."""
    import rasterio
    from rasterio.enums import MaskFlags

    from ..raster import quiet_georef

    bands = []
    width = height = 0
    for source in sources:
        with quiet_georef(), rasterio.open(source) as src:
            width, height = src.width, src.height
            for b in range(1, src.count + 1):
                own_mask = MaskFlags.per_dataset in src.mask_flag_enums[b - 1] or (
                    src.nodata is None and MaskFlags.all_valid not in src.mask_flag_enums[b - 1]
                )
                bands.append(
                    (
                        source,
                        b,
                        src.dtypes[b - 1],
                        src.nodata,
                        own_mask,
                        src.tags(b),
                        src.descriptions[b - 1],
                        src.units[b - 1],
                    )
                )
    parts = [f'<VRTDataset rasterXSize="{width}" rasterYSize="{height}">']
    rect = f'xOff="0" yOff="0" xSize="{width}" ySize="{height}"'
    for i, (source, b, dtype, nodata, own_mask, tags, desc, unit) in enumerate(bands, start=1):
        name = escape(os.path.abspath(source) if os.path.exists(source) else source)
        gdal = _GDAL_NAMES[dtype]
        items = "".join(f'<MDI key="{escape(k)}">{escape(str(v))}</MDI>' for k, v in tags.items())
        mask = ""
        if own_mask:
            mask = (
                '    <MaskBand><VRTRasterBand dataType="Byte"><SimpleSource>'
                f'<SourceFilename relativeToVRT="0">{name}</SourceFilename>'
                f"<SourceBand>mask,{b}</SourceBand></SimpleSource></VRTRasterBand></MaskBand>\n"
            )
        parts.append(
            f'  <VRTRasterBand dataType="{gdal}" band="{i}">\n'
            + (f"    <Description>{escape(desc)}</Description>\n" if desc else "")
            + (f"    <Metadata>{items}</Metadata>\n" if items else "")
            + (f"    <NoDataValue>{nodata!r}</NoDataValue>\n" if nodata is not None else "")
            + (f"    <UnitType>{escape(unit)}</UnitType>\n" if unit else "")
            + "    <SimpleSource>"
            f'<SourceFilename relativeToVRT="0">{name}</SourceFilename>'
            f"<SourceBand>{b}</SourceBand><SrcRect {rect}/><DstRect {rect}/></SimpleSource>\n"
            f"{mask}"
            "  </VRTRasterBand>"
        )
    parts.append("</VRTDataset>\n")
    return write_vrt("\n".join(parts), stem)


#: GDAL's names of the data types rasterio reports.
_GDAL_NAMES = {
    "uint8": "Byte",
    "int8": "Int8",
    "uint16": "UInt16",
    "int16": "Int16",
    "uint32": "UInt32",
    "int32": "Int32",
    "float32": "Float32",
    "float64": "Float64",
}


__all__ = ["stacked_vrt", "write_vrt"]
