"""VRT text shared by the spaceborne readers (EnMAP, PRISMA): a raw BIL cube inside another file
(PRISMA's HDF5 cube at its byte offset), and radiance = ratio · DN + offset per band as Float32
(ComplexSource ScaleRatio/ScaleOffset) with an optional per-band mask (nonzero = defective),
and a product's VNIR and SWIR images stacked as one raster.

Nothing here reads pixels: the VRTs only point at the product's own files.
"""

from __future__ import annotations

import os
from xml.sax.saxutils import escape

import numpy as np

from .vrt import _folder, write_vrt

#: NumPy dtype name -> GDAL data type name.
GDAL_TYPES = {
    "uint8": "Byte",
    "int8": "Int8",
    "uint16": "UInt16",
    "int16": "Int16",
    "uint32": "UInt32",
    "int32": "Int32",
    "float32": "Float32",
    "float64": "Float64",
}


def gdal_type(dtype) -> str | None:
    """The GDAL name of a NumPy dtype, or None when GDAL has none."""
    return GDAL_TYPES.get(np.dtype(dtype).name)


def temp_path(stem: str, suffix: str) -> str:
    """A new file name in the process's VRT folder (removed when the process ends)."""
    from .vrt import _COUNT

    return os.path.join(_folder(), f"{stem}-{os.getpid()}-{next(_COUNT)}{suffix}")


def raw_bil_vrt(
    filename: str,
    offset: int,
    lines: int,
    bands: int,
    samples: int,
    dtype,
    stem: str = "raw",
) -> str:
    """A VRT reading a band-interleaved-by-line cube of shape (lines, bands, samples) stored
    uncompressed in ``filename`` from byte ``offset`` (VRTRawRasterBand: no copy)."""
    dt = np.dtype(dtype)
    size = dt.itemsize
    order = "MSB" if dt.byteorder == ">" or (dt.byteorder == "=" and not _little()) else "LSB"
    name = gdal_type(dt)
    src = escape(os.path.abspath(filename))
    parts = [f'<VRTDataset rasterXSize="{samples}" rasterYSize="{lines}">']
    for b in range(bands):
        parts.append(
            f'  <VRTRasterBand dataType="{name}" band="{b + 1}" subClass="VRTRawRasterBand">\n'
            f'    <SourceFilename relativetoVRT="0">{src}</SourceFilename>\n'
            f"    <ImageOffset>{int(offset) + b * samples * size}</ImageOffset>\n"
            f"    <PixelOffset>{size}</PixelOffset>\n"
            f"    <LineOffset>{bands * samples * size}</LineOffset>\n"
            f"    <ByteOrder>{order}</ByteOrder>\n"
            "  </VRTRasterBand>"
        )
    parts.append("</VRTDataset>\n")
    return write_vrt("\n".join(parts), stem)


def _little() -> bool:
    import sys

    return sys.byteorder == "little"


def calibrated_vrt(
    source: str,
    width: int,
    height: int,
    dtype,
    ratios,
    offsets,
    *,
    wavelengths,
    fwhm=None,
    units: str = "",
    source_nodata: float | None = None,
    mask: str | None = None,
    mask_bands: list[int] | None = None,
    metadata: dict[str, list] | None = None,
    stem: str = "radiance",
) -> str:
    """A Float32 VRT whose band i is ``ratios[i] · source band i + offsets[i]``.

    ``mask`` (with ``mask_bands``, the mask's 1-based band for each band) becomes a per-band
    mask: mask value 0 valid, anything else invalid. ``source_nodata`` becomes the VRT's
    nodata (-9999) instead. ``metadata`` adds one metadata item per band (key -> values).
    """
    from ..grid import FLOAT_NODATA

    src = escape(source)
    src_type = gdal_type(dtype)
    parts = [f'<VRTDataset rasterXSize="{width}" rasterYSize="{height}">']
    rect = f'xOff="0" yOff="0" xSize="{width}" ySize="{height}"'
    for i, (ratio, off) in enumerate(zip(ratios, offsets, strict=True)):
        wl = float(wavelengths[i])
        items = [f'      <MDI key="wavelength">{wl:.4f}</MDI>']
        items.append('      <MDI key="wavelength_units">nm</MDI>')
        if fwhm is not None:
            items.append(f'      <MDI key="fwhm">{float(fwhm[i]):.4f}</MDI>')
        for key, values in (metadata or {}).items():
            items.append(f'      <MDI key="{escape(key)}">{escape(str(values[i]))}</MDI>')
        nodata = ""
        src_nodata = ""
        if source_nodata is not None:
            nodata = f"    <NoDataValue>{FLOAT_NODATA}</NoDataValue>\n"
            src_nodata = f"      <NODATA>{source_nodata!r}</NODATA>\n"
        mask_xml = ""
        if mask is not None and source_nodata is None:
            mask_xml = (
                "    <MaskBand>\n"
                '      <VRTRasterBand dataType="Byte">\n'
                "        <ComplexSource>\n"
                f'          <SourceFilename relativeToVRT="0">{escape(mask)}</SourceFilename>\n'
                f"          <SourceBand>{mask_bands[i]}</SourceBand>\n"
                "          <LUT>0:255,1:0</LUT>\n"
                "        </ComplexSource>\n"
                "      </VRTRasterBand>\n"
                "    </MaskBand>\n"
            )
        parts.append(
            f'  <VRTRasterBand dataType="Float32" band="{i + 1}">\n'
            f"    <Description>band {i + 1} ({wl:.2f} nm)</Description>\n"
            "    <Metadata>\n" + "\n".join(items) + "\n    </Metadata>\n"
            f"{nodata}"
            f"    <UnitType>{escape(units)}</UnitType>\n"
            "    <ComplexSource>\n"
            f'      <SourceFilename relativeToVRT="0">{src}</SourceFilename>\n'
            f"      <SourceBand>{i + 1}</SourceBand>\n"
            f'      <SourceProperties RasterXSize="{width}" RasterYSize="{height}" '
            f'DataType="{src_type}" />\n'
            f"      <SrcRect {rect} />\n"
            f"      <DstRect {rect} />\n"
            f"{src_nodata}"
            f"      <ScaleOffset>{float(off)!r}</ScaleOffset>\n"
            f"      <ScaleRatio>{float(ratio)!r}</ScaleRatio>\n"
            "    </ComplexSource>\n"
            f"{mask_xml}"
            "  </VRTRasterBand>"
        )
    parts.append("</VRTDataset>\n")
    return write_vrt("\n".join(parts), stem)


def stacked_vrt(sources, stem: str = "stack") -> str:
    """A VRT of every band of each of ``sources`` (what GDAL opens for a product's images, on
    one grid: a product's VNIR and SWIR images as one raster) one after the other: band values, nodata, masks, band metadata (wavelength),
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
        gdal = gdal_type(dtype)
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


__all__ = ["calibrated_vrt", "gdal_type", "raw_bil_vrt", "stacked_vrt", "temp_path"]
