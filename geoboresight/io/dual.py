"""A dual-sensor dataset: the VNIR and SWIR halves of one flight line.

Either two files (VNIR, SWIR), or one merged cube that is split at a seam wavelength
(default 975 nm: AISA-Dual's EAGLE ends at ~970 nm, its HAWK starts at ~980 nm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .raster import is_georeferenced, open_raster
from .wavelengths import nearest_band, wavelengths_of

#: Eq. 3 of Brook & Ben-Dor (2011): b(1010 nm) / b(920 nm).
NUMERATOR_NM = 1010.0
DENOMINATOR_NM = 920.0
SEAM_NM = 975.0


@dataclass(frozen=True)
class SensorFile:
    """The bands of one sensor inside one file."""

    path: str
    name: str  # "VNIR" or "SWIR"
    bands: tuple[int, ...]  # 1-based band numbers in the file
    wavelengths: np.ndarray  # centre of each of those bands, nm
    fwhm: np.ndarray | None = None
    nodata: float | None = None

    def band_for(self, target_nm: float, tolerance_nm: float) -> int:
        """1-based file band nearest ``target_nm`` among this sensor's bands."""
        label = f"{self.path} ({self.name} bands)"
        i = nearest_band(self.wavelengths, target_nm, tolerance_nm, label)
        return self.bands[i]

    def wavelength_of(self, band: int) -> float:
        return float(self.wavelengths[self.bands.index(band)])

    @property
    def first(self) -> int:
        return self.bands[int(np.argmin(self.wavelengths))]

    @property
    def last(self) -> int:
        return self.bands[int(np.argmax(self.wavelengths))]


@dataclass(frozen=True)
class DualSensor:
    """VNIR and SWIR on one grid (raw sensor geometry or georeferenced)."""

    vnir: SensorFile
    swir: SensorFile
    width: int
    height: int
    crs: object | None
    transform: object | None  # None in raw sensor geometry
    merged: bool

    @property
    def grid(self) -> dict:
        return {
            "width": self.width,
            "height": self.height,
            "crs": self.crs,
            "transform": self.transform,
        }

    def ratio_bands(
        self,
        numerator_nm: float = NUMERATOR_NM,
        denominator_nm: float = DENOMINATOR_NM,
        mode: str = "wavelength",
        tolerance_nm: float = 10.0,
    ) -> tuple[int, int]:
        """(SWIR band, VNIR band), 1-based, for the boresight ratio (Eq. 3).

        ``mode="wavelength"``: nearest centres to ``numerator_nm`` (SWIR) and ``denominator_nm``
        (VNIR) within ``tolerance_nm``. ``mode="edges"``: the first SWIR band over the last VNIR
        band, whatever their wavelengths (the paper's choice on AISA-Dual).
        """
        if mode == "edges":
            return self.swir.first, self.vnir.last
        if mode != "wavelength":
            raise InputError(f"unknown band mode {mode!r}: use 'wavelength' or 'edges'")
        return (
            self.swir.band_for(numerator_nm, tolerance_nm),
            self.vnir.band_for(denominator_nm, tolerance_nm),
        )


def _sensor_wavelengths(
    src, path: str, user: str | None, label: str
) -> tuple[np.ndarray, np.ndarray | None]:
    option = f"--{label.lower()}-wavelengths / {label.lower()}_wavelengths="
    return wavelengths_of(src, f"{label} {path}", user, option)


def open_dual(
    vnir: str,
    swir: str | None = None,
    seam_nm: float = SEAM_NM,
    vnir_wavelengths: str | None = None,
    swir_wavelengths: str | None = None,
) -> DualSensor:
    """Describe a dual-sensor dataset (reads metadata only, no pixels).

    Parameters
    ----------
    vnir : path
        The VNIR file, or the merged VNIR+SWIR cube when ``swir`` is None.
    swir : path, optional
        The SWIR file, on the same pixel grid as ``vnir``.
    seam_nm : float
        In a merged cube, bands below the seam are VNIR, bands at or above it SWIR.
    vnir_wavelengths, swir_wavelengths : str, optional
        Comma-separated band centres (nm) for files without wavelength metadata.
    """
    with open_raster(vnir, "VNIR" if swir else "merged cube") as src:
        label = "VNIR" if swir else "merged cube"
        wl_v, fw_v = _sensor_wavelengths(src, vnir, vnir_wavelengths, "VNIR")
        shape_v = (src.height, src.width)
        crs_v = src.crs
        tr_v = src.transform if is_georeferenced(src) else None
        nodata_v = src.nodata
    if swir is None:
        below = np.flatnonzero(wl_v < seam_nm)
        above = np.flatnonzero(wl_v >= seam_nm)
        if below.size == 0 or above.size == 0:
            raise InputError(
                f"{label} {vnir}: its bands ({wl_v.min():.1f}–{wl_v.max():.1f} nm) do not "
                f"straddle the seam at {seam_nm:g} nm, so it cannot be split into VNIR and "
                "SWIR; give the SWIR file separately or change the seam wavelength"
            )
        mk = lambda idx, name: SensorFile(  # noqa: E731
            vnir,
            name,
            tuple(int(i) + 1 for i in idx),
            wl_v[idx],
            None if fw_v is None else fw_v[idx],
            nodata_v,
        )
        return DualSensor(
            mk(below, "VNIR"), mk(above, "SWIR"), shape_v[1], shape_v[0], crs_v, tr_v, True
        )

    with open_raster(swir, "SWIR") as src:
        wl_s, fw_s = _sensor_wavelengths(src, swir, swir_wavelengths, "SWIR")
        shape_s = (src.height, src.width)
        crs_s = src.crs
        tr_s = src.transform if is_georeferenced(src) else None
        nodata_s = src.nodata
    if shape_v != shape_s:
        raise InputError(
            f"VNIR {vnir} is {shape_v[1]} × {shape_v[0]} pixels (columns × lines) but SWIR "
            f"{swir} is {shape_s[1]} × {shape_s[0]}: both must be on the same pixel grid "
            "(crop or resample one of them to the other first)"
        )
    if crs_v is not None and crs_s is not None and crs_v != crs_s:
        raise InputError(
            f"VNIR {vnir} is in {crs_v.to_string()} but SWIR {swir} is in {crs_s.to_string()}: "
            "reproject one onto the other's grid first"
        )
    if tr_v is not None and tr_s is not None and not tr_v.almost_equals(tr_s):
        raise InputError(
            f"VNIR {vnir} and SWIR {swir} have different geotransforms ({tuple(tr_v)[:6]} vs "
            f"{tuple(tr_s)[:6]}): they must share one pixel grid"
        )
    vn = SensorFile(vnir, "VNIR", tuple(range(1, len(wl_v) + 1)), wl_v, fw_v, nodata_v)
    sw = SensorFile(swir, "SWIR", tuple(range(1, len(wl_s) + 1)), wl_s, fw_s, nodata_s)
    return DualSensor(vn, sw, shape_v[1], shape_v[0], crs_v or crs_s, tr_v or tr_s, False)
