"""A dual-sensor dataset: the VNIR and SWIR halves of one flight line.

Either two files (VNIR, SWIR), or one merged cube that is split at a seam wavelength
(default 975 nm: AISA-Dual's EAGLE ends at ~970 nm, its HAWK starts at ~980 nm).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .grid import Grid
from .raster import open_raster
from .wavelengths import good_bands, nearest_band, wavelengths_of

#: Eq. 3 of Brook & Ben-Dor (2011): b(1010 nm) / b(920 nm), the SWIR band over the VNIR band.
SWIR_NM = 1010.0
VNIR_NM = 920.0
SEAM_NM = 975.0
#: Largest distance between a requested wavelength and a band centre, for every operation.
TOLERANCE_NM = 10.0


@dataclass(frozen=True)
class RatioBands:
    """The two bands of the boresight ratio (Eq. 3): 1-based band numbers in their files and
    their centre wavelengths (nm). The ratio is SWIR over VNIR."""

    vnir_band: int
    vnir_nm: float
    swir_band: int
    swir_nm: float


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
    grid: Grid  # raw sensor geometry: crs and transform None
    merged: bool

    @property
    def width(self) -> int:
        return self.grid.width

    @property
    def height(self) -> int:
        return self.grid.height

    @property
    def crs(self):
        return self.grid.crs

    @property
    def transform(self):
        return self.grid.transform

    def ratio_bands(
        self,
        vnir_nm: float = VNIR_NM,
        swir_nm: float = SWIR_NM,
        band_mode: str = "wavelength",
        tolerance_nm: float = TOLERANCE_NM,
    ) -> RatioBands:
        """The two bands of the boresight ratio b(1010 nm) / b(920 nm) (Eq. 3).

        ``band_mode="wavelength"``: the band centres nearest ``vnir_nm`` (VNIR) and ``swir_nm``
        (SWIR), within ``tolerance_nm``. ``band_mode="edges"``: the first SWIR band over the
        last VNIR band, whatever their wavelengths (the paper's choice on AISA-Dual).
        """
        if band_mode == "edges":
            vb, sb = self.vnir.last, self.swir.first
        elif band_mode == "wavelength":
            sb = self.swir.band_for(swir_nm, tolerance_nm)  # the numerator first, as in 0.1
            vb = self.vnir.band_for(vnir_nm, tolerance_nm)
        else:
            raise InputError(f"unknown band mode {band_mode!r}: use 'wavelength' or 'edges'")
        return RatioBands(vb, self.vnir.wavelength_of(vb), sb, self.swir.wavelength_of(sb))


def _sensor_wavelengths(
    src, path: str, user: str | None, label: str
) -> tuple[np.ndarray, np.ndarray | None]:
    option = f"--{label.lower()}-wavelengths / {label.lower()}_wavelengths="
    return wavelengths_of(src, f"{label} {path}", user, option)


def _good(src, label: str, path: str) -> np.ndarray:
    """The bands the ENVI ``bbl`` keeps; refuse a file whose bands are all bad."""
    good = good_bands(src)
    if not good.any():
        raise InputError(
            f"{label} {path}: its header's 'bbl' marks every band bad: nothing to work with "
            "(fix the 'bbl' list)"
        )
    return good


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
        grid_v = Grid.of(src)
        nodata_v = src.nodata
        good_v = _good(src, label, vnir)
    if swir is None:
        # Bands the ENVI 'bbl' marks bad belong to neither sensor: never picked nor read.
        below = np.flatnonzero((wl_v < seam_nm) & good_v)
        above = np.flatnonzero((wl_v >= seam_nm) & good_v)
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
        return DualSensor(mk(below, "VNIR"), mk(above, "SWIR"), grid_v, True)

    with open_raster(swir, "SWIR") as src:
        wl_s, fw_s = _sensor_wavelengths(src, swir, swir_wavelengths, "SWIR")
        grid_s = Grid.of(src)
        nodata_s = src.nodata
        good_s = _good(src, "SWIR", swir)
    grid_v.require_same(grid_s, f"VNIR {vnir}", f"SWIR {swir}")
    pick = lambda path, name, wl, fw, nd, good: SensorFile(  # noqa: E731
        path,
        name,
        tuple(int(i) + 1 for i in np.flatnonzero(good)),
        wl[good],
        None if fw is None else fw[good],
        nd,
    )
    vn = pick(vnir, "VNIR", wl_v, fw_v, nodata_v, good_v)
    sw = pick(swir, "SWIR", wl_s, fw_s, nodata_s, good_s)
    grid = Grid(
        grid_v.width, grid_v.height, grid_v.crs or grid_s.crs, grid_v.transform or grid_s.transform
    )
    return DualSensor(vn, sw, grid, False)
