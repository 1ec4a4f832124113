"""EnMAP Level-1B (DLR): a product folder, its zip (one top folder), its ``*-METADATA.XML`` or one
of its ``*-SPECTRAL_IMAGE_VNIR/SWIR`` images.

Read from the XML (element names as GFZ EnPT ``enpt/model/metadata/metadata_sensorgeo.py`` and
EnMAP-Box ``importenmapl1balgorithm.py`` read them):

- ``specific/bandCharacterisation/bandID``: ``wavelengthCenterOfBand``, ``FWHMOfBand``,
  ``GainOfBand``, ``OffsetOfBand``, all VNIR bands first, then all SWIR bands;
- ``product/image/{vnir,swir}``: ``channels`` (bands per detector), ``name`` (the image file),
  ``dimension/rows`` and ``dimension/columns``;
- ``base/level`` (``L1B``).

Each detector is presented through a Float32 VRT: radiance = gain · DN + offset, in
W m⁻² sr⁻¹ nm⁻¹ (EnPT multiplies by 1000 to get mW m⁻² sr⁻¹ nm⁻¹, so the XML gains give
W m⁻² sr⁻¹ nm⁻¹). ``*-QL_PIXELMASK_VNIR/_SWIR`` becomes a per-band mask: nonzero = defective
(EnPT turns the map into booleans, True = dead pixel), when it has the image's rows and columns.
The images stay in raw (sensor) geometry: the per-band RPCs are not used, and the SWIR image sees
the ground about 20 lines from the VNIR image (a known property of L1B, noted in EnPT's issue
tracker), which is what the boresight operations measure.
"""

from __future__ import annotations

import os
import posixpath
import re
import zipfile
from dataclasses import dataclass
from xml.etree import ElementTree

import numpy as np

from ...errors import InputError
from .base import Product, SensorImage, read_once

KIND = "EnMAP L1B"
UNITS = "radiance (W m-2 sr-1 nm-1)"
XML_SUFFIX = "-METADATA.XML"
_IMAGE = re.compile(r"-SPECTRAL_IMAGE_(VNIR|SWIR)(\.[A-Za-z0-9]+)?$", re.IGNORECASE)
_EXTS = (".TIF", ".TIFF", ".GEOTIFF", ".BSQ", ".BIL", ".BIP", ".JP2", "")


@dataclass(frozen=True)
class _Files:
    """The files of one product: in a folder, or in a zip next to its METADATA.XML."""

    label: str  # the product as the user named it, for messages
    xml: str  # the XML's name among ``names``
    names: tuple[str, ...]  # file names beside the XML
    folder: str | None = None
    zip_path: str | None = None
    zip_dir: str = ""  # the XML's folder inside the zip

    def gdal_path(self, name: str) -> str:
        if self.zip_path is None:
            return os.path.join(self.folder, name)
        member = posixpath.join(self.zip_dir, name) if self.zip_dir else name
        return f"/vsizip/{os.path.abspath(self.zip_path)}/{member}"

    def read_xml(self) -> bytes:
        if self.zip_path is None:
            with open(os.path.join(self.folder, self.xml), "rb") as f:
                return f.read()
        with zipfile.ZipFile(self.zip_path) as z:
            return z.read(posixpath.join(self.zip_dir, self.xml) if self.zip_dir else self.xml)

    def find(self, pattern: str) -> str | None:
        """The first file named ``*<pattern><ext>`` (case-insensitive), by extension order."""
        upper = {n.upper(): n for n in self.names}
        for ext in _EXTS:
            for key, name in sorted(upper.items()):
                if key.endswith((pattern + ext).upper()):
                    return name
        return None


def _xml_names(names) -> list[str]:
    return sorted(n for n in names if n.upper().endswith(XML_SUFFIX))


def _locate(path: str) -> _Files | None:
    """The product's files, or None when ``path`` is not shaped like an EnMAP product."""
    if os.path.isdir(path):
        names = os.listdir(path)
        xmls = _xml_names(names)
        if not xmls:
            return None
        if len(xmls) > 1:
            raise InputError(
                f"{KIND} {path}: the folder holds several METADATA.XML files "
                f"({', '.join(xmls)}): give one of them instead of the folder"
            )
        return _Files(path, xmls[0], tuple(names), folder=path)
    if not os.path.isfile(path):
        return None
    base = os.path.basename(path)
    if base.lower().endswith(".zip"):
        try:
            with zipfile.ZipFile(path) as z:
                members = [m for m in z.namelist() if not m.endswith("/")]
        except (zipfile.BadZipFile, OSError):
            if base.upper().startswith("ENMAP") and "L1B" in base.upper():
                raise InputError(
                    f"{KIND} {path}: not a readable zip archive (truncated download?): "
                    "download it again or give the unpacked folder"
                ) from None
            return None
        xmls = _xml_names(posixpath.basename(m) for m in members)
        if not xmls:
            return None
        found = [m for m in members if m.upper().endswith(XML_SUFFIX)]
        if len(found) > 1:
            raise InputError(
                f"{KIND} {path}: the zip holds several METADATA.XML files: unpack it and give "
                "one product folder"
            )
        top = posixpath.dirname(found[0])
        names = tuple(posixpath.basename(m) for m in members if posixpath.dirname(m) == top)
        return _Files(path, posixpath.basename(found[0]), names, zip_path=path, zip_dir=top)
    folder = os.path.dirname(os.path.abspath(path))
    if base.upper().endswith(XML_SUFFIX):
        return _Files(path, base, tuple(os.listdir(folder)), folder=folder)
    m = _IMAGE.search(base)
    if m:
        want = (base[: m.start()] + XML_SUFFIX).upper()
        names = os.listdir(folder)
        xml = next((n for n in names if n.upper() == want), None)
        if xml is None:
            return None  # a lone image: GDAL opens it as any GeoTIFF
        return _Files(path, xml, tuple(names), folder=folder)
    return None


def read(path) -> Product | None:
    """The EnMAP L1B product at ``path`` (folder, zip, METADATA.XML or SPECTRAL_IMAGE), or None
    when ``path`` is not one; :class:`InputError` when it is one but damaged."""
    path = os.fspath(path)
    files = _locate(path)
    if files is None:
        return None
    container = files.zip_path or os.path.join(files.folder, files.xml)
    return read_once(container, ("enmap", path), lambda: _read(path, files))


def _text(root, where: str) -> str | None:
    el = root.find(where)
    return None if el is None or el.text is None else el.text.strip()


def _read(path: str, files: _Files) -> Product | None:
    where = f"{KIND} {path}"
    xml_label = f"{where} ({files.xml})"
    try:
        root = ElementTree.fromstring(files.read_xml())
    except (ElementTree.ParseError, KeyError, OSError) as exc:
        if not files.xml.upper().startswith("ENMAP"):
            return None
        raise InputError(f"{xml_label}: the metadata XML cannot be read ({exc})") from None
    if root.find("product/image/vnir") is None and not files.xml.upper().startswith("ENMAP"):
        return None  # another sensor's METADATA.XML (DESIS names its files alike)
    level = _text(root, "base/level")
    if level is not None and level.upper() != "L1B":
        raise InputError(
            f"{where}: an EnMAP {level} product; only L1B (raw geometry, VNIR and SWIR apart) "
            "is read: the boresight offset is gone after L1C/L2A orthorectification"
        )
    wl, fwhm, gains, offsets = _bands(root, xml_label)
    images, notes = [], []
    start = 0
    for det in ("vnir", "swir"):
        name = det.upper()
        channels = _text(root, f"product/image/{det}/channels")
        image = _image_name(root, files, det)
        if image is None:
            raise InputError(
                f"{where}: no *-SPECTRAL_IMAGE_{name} image (.TIF) beside {files.xml}: the "
                "product is incomplete; download or unpack it again"
            )
        info = _raster_info(files.gdal_path(image), f"{where} ({image})")
        n = int(channels) if channels and channels.isdigit() else info["count"]
        if info["count"] != n:
            raise InputError(
                f"{where}: {image} has {info['count']} bands but the XML lists {n} {name} "
                "channels (product/image/" + det + "/channels): the image and its metadata "
                "do not belong together"
            )
        stop = start + n
        if stop > len(wl):
            raise InputError(
                f"{xml_label}: the XML characterises {len(wl)} bands "
                "(specific/bandCharacterisation/bandID) but its VNIR and SWIR images have "
                f"{start + n} bands together: the band list is incomplete"
            )
        rows = _text(root, f"product/image/{det}/dimension/rows")
        cols = _text(root, f"product/image/{det}/dimension/columns")
        if rows and cols and (int(rows), int(cols)) != (info["height"], info["width"]):
            raise InputError(
                f"{where}: {image} is {info['height']} x {info['width']} pixels but the XML "
                f"says {rows} x {cols} (product/image/{det}/dimension): the image and its "
                "metadata do not belong together"
            )
        sl = slice(start, stop)
        mask, mask_bands, note = _mask(files, name, info, n)
        if note:
            notes.append(note)
        from ._calibrated import calibrated_vrt

        source = calibrated_vrt(
            files.gdal_path(image),
            info["width"],
            info["height"],
            info["dtype"],
            gains[sl],
            offsets[sl],
            wavelengths=wl[sl],
            fwhm=None if fwhm is None else fwhm[sl],
            units=UNITS,
            source_nodata=info["nodata"],
            mask=mask,
            mask_bands=mask_bands,
            metadata={"dn_gain": list(gains[sl]), "dn_offset": list(offsets[sl])},
            stem=f"enmap-{det}",
        )
        if info["nodata"] is not None and mask is not None:
            notes.append(
                f"{name}: the image has a nodata value ({info['nodata']:g}), which is used; "
                "its pixel mask is not"
            )
        images.append(
            SensorImage(
                name,
                source,
                wl[sl].copy(),
                None if fwhm is None else fwhm[sl].copy(),
                nodata=None if info["nodata"] is None else -9999.0,
                units=UNITS,
            )
        )
        start = stop
    if start != len(wl):
        raise InputError(
            f"{xml_label}: the XML characterises {len(wl)} bands but the VNIR and SWIR images "
            f"have {start} together: the image and its metadata do not belong together"
        )
    notes.append("raw (sensor) geometry: the per-band RPCs (product/navigation/RPC) are not used")
    return Product(KIND, path, tuple(images), None, tuple(notes))


def _bands(root, label: str):
    """(wavelength, FWHM or None, gain, offset) of every band, VNIR then SWIR."""
    ids = root.findall("specific/bandCharacterisation/bandID")
    if not ids:
        raise InputError(
            f"{label}: no band wavelengths (no specific/bandCharacterisation/bandID elements): "
            "the metadata XML is incomplete"
        )
    wl, fw, gain, off = [], [], [], []
    for i, el in enumerate(ids):
        number = el.get("number", str(i + 1))
        values = {}
        for tag in ("wavelengthCenterOfBand", "FWHMOfBand", "GainOfBand", "OffsetOfBand"):
            t = _text(el, tag)
            try:
                values[tag] = None if t is None else float(t)
            except ValueError:
                values[tag] = None
        for tag in ("wavelengthCenterOfBand", "GainOfBand", "OffsetOfBand"):
            if values[tag] is None:
                raise InputError(
                    f"{label}: band {number} has no {tag} "
                    "(specific/bandCharacterisation/bandID): the metadata XML is incomplete"
                )
        wl.append(values["wavelengthCenterOfBand"])
        fw.append(values["FWHMOfBand"])
        gain.append(values["GainOfBand"])
        off.append(values["OffsetOfBand"])
    fwhm = None if any(v is None for v in fw) else np.asarray(fw, float)
    return np.asarray(wl, float), fwhm, np.asarray(gain, float), np.asarray(off, float)


def _image_name(root, files: _Files, det: str) -> str | None:
    named = _text(root, f"product/image/{det}/name")
    if named and named in files.names:
        return named
    return files.find(f"-SPECTRAL_IMAGE_{det.upper()}")


def _raster_info(source: str, label: str) -> dict:
    import rasterio
    from rasterio.errors import RasterioIOError

    from ..raster import quiet_georef

    try:
        with quiet_georef(), rasterio.open(source) as src:
            return {
                "count": src.count,
                "width": src.width,
                "height": src.height,
                "dtype": src.dtypes[0],
                "nodata": src.nodata,
            }
    except RasterioIOError as exc:
        raise InputError(f"{label} cannot be read as a raster ({exc})") from None


def _mask(files: _Files, name: str, info: dict, bands: int):
    """(mask source, its band per image band, note) of the detector's pixel mask."""
    mask = files.find(f"-QL_PIXELMASK_{name}")
    if mask is None:
        return None, None, f"{name}: no QL_PIXELMASK_{name}: every pixel taken as valid"
    source = files.gdal_path(mask)
    m = _raster_info(source, f"{KIND} {files.label} ({mask})")
    if (m["height"], m["width"]) != (info["height"], info["width"]) or m["count"] not in (
        1,
        bands,
    ):
        return (
            None,
            None,
            f"{name}: {mask} is {m['count']} x {m['height']} x {m['width']} (bands x rows x "
            "columns), not the image's shape: not used",
        )
    per_band = [1] * bands if m["count"] == 1 else list(range(1, bands + 1))
    return source, per_band, ""


__all__ = ["KIND", "UNITS", "read"]
