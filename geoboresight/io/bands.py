"""Bands of a dual-sensor dataset read as whole images, strip by strip: band ranges, their
means, and the VNIR/SWIR pair matched for the boresight offset and the relative DEM (§3.2).

Every read goes through :func:`~geoboresight.io.windows.map_windows`; the per-pixel work (the
mean of a band range) is the kernel :func:`geoboresight.sensor.bands.band_mean`.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from rasterio.windows import Window

from ..errors import InputError, ParameterError
from ..progress import Progress
from ..sensor.bands import (
    MATCH_SWIR_NM,
    MATCH_SWIR_TO_NM,
    MATCH_VNIR_NM,
    MATCH_VNIR_TO_NM,
    band_mean,
)
from .cube import raw_bands_reader
from .dual import SWIR_NM, TOLERANCE_NM, VNIR_NM, DualSensor, SensorFile
from .grid import require_on_grid
from .image import open_raster
from .windows import (
    DEFAULT_BLOCK_ROWS,
    band_reader,
    bands_reader,
    map_windows,
    masks_to_read,
    read_masked,
)


@dataclass(frozen=True)
class MatchBands:
    """The VNIR and SWIR images matched for the boresight offset and the relative DEM (§3.2):
    the band nearest ``vnir_nm`` (``swir_nm``), or the mean of the bands centred in
    [``vnir_nm``, ``vnir_to_nm``] ([``swir_nm``, ``swir_to_nm``]). By default the ratio's two
    bands (Eq. 3); dense matching averages band ranges (:data:`DENSE_MATCH`).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.MatchBands()  # the ratio's two bands
    MatchBands(vnir_nm=920.0, swir_nm=1010.0, vnir_to_nm=None, swir_to_nm=None, tolerance_nm=10.0)
    >>> gb.MatchBands(vnir_nm=900, vnir_to_nm=970, swir_nm=980, swir_to_nm=1100)  # band means
    MatchBands(vnir_nm=900, swir_nm=980, vnir_to_nm=970, swir_to_nm=1100, tolerance_nm=10.0)
    """

    vnir_nm: float = VNIR_NM
    swir_nm: float = SWIR_NM
    vnir_to_nm: float | None = None
    swir_to_nm: float | None = None
    tolerance_nm: float = TOLERANCE_NM


@dataclass(frozen=True)
class BoresightOffset:
    """The boresight offset of the SWIR relative to the VNIR (px, SWIR minus VNIR position),
    along- and across-track, when the user gives it; both None = measured on the data
    (:func:`geoboresight.sensor.offset.estimate_offset`), one None = 0.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.BoresightOffset()  # measured on the scene
    BoresightOffset(offset_along=None, offset_across=None)
    >>> gb.BoresightOffset(offset_along=0.87, offset_across=-0.07)  # known (pixels)
    BoresightOffset(offset_along=0.87, offset_across=-0.07)
    """

    offset_along: float | None = None
    offset_across: float | None = None


@dataclass(frozen=True)
class Coregistration(BoresightOffset):
    """Whether RX and SVDD shift the SWIR onto the VNIR grid first (``coregister``), and by
    which boresight offset (given, or both None: measured).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Coregistration()  # the offset measured on the scene, the SWIR shifted onto the VNIR
    Coregistration(offset_along=None, offset_across=None, coregister=True)
    >>> result = gb.rx_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                     output="out/rx.tif", coregistration=gb.Coregistration(coregister=False))
    >>> result["coregistered"]
    False
    """

    coregister: bool = True


#: Dense matching's images: band means 900–970 nm against 980–1,100 nm (the single 1,010 nm
#: band is too weak to match pixel by pixel; docs/dem.md).
DENSE_MATCH = MatchBands(MATCH_VNIR_NM, MATCH_SWIR_NM, MATCH_VNIR_TO_NM, MATCH_SWIR_TO_NM)


def band_range(
    sensor: SensorFile,
    from_nm: float,
    to_nm: float | None = None,
    tolerance_nm: float = TOLERANCE_NM,
    name: str = "to_nm",
) -> list[int]:
    """File bands of ``sensor`` whose centres lie in [``from_nm``, ``to_nm``], by wavelength.

    The band nearest ``from_nm`` (within ``tolerance_nm``) when no range is given or the range
    holds no band centre. ``name`` is the parameter named in the error for a reversed range.
    """
    if to_nm is not None:
        lo, hi = float(from_nm), float(to_nm)
        if hi < lo:
            raise ParameterError(
                f"parameter '{name}': {hi:g} nm is below the start of the range ({lo:g} nm); "
                "give the upper end of the wavelength range to average"
            )
        inside = [b for b in sensor.bands if lo <= sensor.wavelength_of(b) <= hi]
        if inside:
            return sorted(inside, key=sensor.wavelength_of)
    return [sensor.band_for(from_nm, tolerance_nm)]


def masked_bands_reader(src, bands) -> Callable[[int, int], tuple[np.ndarray, np.ndarray]]:
    """``read(row0, row1) -> (values (n, rows, cols) float32, valid (n, rows, cols))`` of
    several bands of one dataset, each with its own validity (nodata, masks)."""
    read_masks = masks_to_read([(src, b) for b in bands])

    def read(row0: int, row1: int):
        window = Window(0, row0, src.width, row1 - row0)
        pairs = [
            read_masked(src, b, window, read_mask=m) for b, m in zip(bands, read_masks, strict=True)
        ]
        return np.stack([p[0] for p in pairs]), np.stack([p[1] for p in pairs])

    return read


def read_bands(
    src, bands, *, block_rows: int = DEFAULT_BLOCK_ROWS, progress: Progress | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Whole bands of an open dataset: ``(values (n, lines, cols) float32, valid per band)``."""
    values = np.empty((len(bands), src.height, src.width), np.float32)
    valid = np.empty(values.shape, bool)
    for win, (v, ok) in map_windows(
        masked_bands_reader(src, bands),
        lambda v, ok: (v, ok),
        height=src.height,
        width=src.width,
        block_rows=block_rows,
        progress=progress,
        message="reading",
    ):
        rows = slice(win.row_off, win.row_off + win.height)
        values[:, rows], valid[:, rows] = v, ok
    return values, valid


@dataclass(frozen=True)
class MatchingPair:
    """The VNIR and SWIR images matched against each other (one band each, or band-range
    means, float64), where both are valid and cloud-free, and the bands they come from."""

    vnir: np.ndarray
    swir: np.ndarray
    valid: np.ndarray
    vnir_bands: list[int]
    swir_bands: list[int]
    dual: DualSensor

    def info(self) -> dict:
        """The bands matched, for tags and reports (the bands averaged, if more than one)."""
        vb, sb = self.vnir_bands[0], self.swir_bands[0]
        info = {
            "vnir_band": vb,
            "vnir_wavelength_nm": round(self.dual.vnir.wavelength_of(vb), 3),
            "swir_band": sb,
            "swir_wavelength_nm": round(self.dual.swir.wavelength_of(sb), 3),
        }
        if len(self.vnir_bands) > 1 or len(self.swir_bands) > 1:
            info["vnir_bands_averaged"] = self.vnir_bands
            info["swir_bands_averaged"] = self.swir_bands
        return info


class MatchingReader:
    """The VNIR and SWIR matching images of a flight line, read strip by strip.

    ``read(row0, row1) -> (vnir, swir, valid)`` (float64, float64, bool) for
    :func:`~geoboresight.io.windows.map_windows`: each image is one band or the mean of a band
    range (:func:`~geoboresight.sensor.bands.band_mean`), valid where every band read is valid and
    cloud-free. Use :func:`open_matching_pair` (a context manager: the files stay open).
    """

    def __init__(self, dual, vbs, sbs, read_bands, read_cloud, cloud_mask=None):
        self.dual = dual
        self.vnir_bands, self.swir_bands = vbs, sbs
        self.height, self.width = dual.grid.shape
        self._bands, self._c = read_bands, read_cloud
        self._lock = threading.Lock()
        #: The cloud mask's file, and the pixels read and those it marked cloud.
        self.cloud_mask = cloud_mask
        self.pixels_read = self.cloud_pixels = 0

    def read(self, row0: int, row1: int):
        # One open dataset per file: worker threads of map_windows read one at a time.
        with self._lock:
            (v, ok_v), (s, ok_s) = self._bands(row0, row1)
            cloud = self._c(row0, row1) if self._c is not None else None
        v, _ = band_mean(v, ok_v)
        s, _ = band_mean(s, ok_s)
        ok = ok_v & ok_s
        if cloud is not None:
            values = cloud[0][cloud[1]]
            if values.size and np.any(values % 1):
                lo, hi = float(values.min()), float(values.max())
                raise InputError(
                    f"cloud mask {self.cloud_mask} holds fractional values ({lo:g} to {hi:g}): "
                    "a mask marks cloud with a non-zero whole number and clear sky with 0, and "
                    "every pixel above 0 here would be cloud; give a mask (a cloud "
                    "probability thresholded, e.g. > 0.5)"
                )
            cloudy = (cloud[0] != 0) & cloud[1]
            ok &= ~cloudy
            with self._lock:
                self.pixels_read += cloudy.size
                self.cloud_pixels += int(cloudy.sum())
        return v.astype(np.float64), s.astype(np.float64), ok

    def info(self) -> dict:
        """The bands matched, for tags and reports (the bands averaged, if more than one)."""
        vb, sb = self.vnir_bands[0], self.swir_bands[0]
        info = {
            "vnir_band": vb,
            "vnir_wavelength_nm": round(self.dual.vnir.wavelength_of(vb), 3),
            "swir_band": sb,
            "swir_wavelength_nm": round(self.dual.swir.wavelength_of(sb), 3),
        }
        if len(self.vnir_bands) > 1 or len(self.swir_bands) > 1:
            info["vnir_bands_averaged"] = self.vnir_bands
            info["swir_bands_averaged"] = self.swir_bands
        return info


@contextlib.contextmanager
def open_matching_pair(
    dual: DualSensor,
    bands: MatchBands = MatchBands(),
    cloud_mask: str | None = None,
):
    """Open the VNIR and SWIR matching images of a flight line for reading strip by strip
    (yields a :class:`MatchingReader`).

    Each image is ``bands``' VNIR (SWIR) band or band mean (:class:`MatchBands`). Valid
    where every band read is valid and, with a ``cloud_mask`` (non-zero = cloud) on the same
    grid, cloud-free. Raw ENVI files are read directly (the same values and validity as
    through GDAL).
    """
    tol = bands.tolerance_nm
    vbs = band_range(dual.vnir, bands.vnir_nm, bands.vnir_to_nm, tol, "vnir_to_nm")
    sbs = band_range(dual.swir, bands.swir_nm, bands.swir_to_nm, tol, "swir_to_nm")
    raw, cube = raw_bands_reader(dual.vnir.reads, dual.swir.reads, vbs, sbs)
    with (
        open_raster(dual.vnir.reads, "VNIR") as v_src,
        open_raster(dual.swir.reads, "SWIR") as s_src,
        open_raster(cloud_mask, "cloud mask") if cloud_mask else contextlib.nullcontext() as c_src,
        cube if cube is not None else contextlib.nullcontext(),
    ):
        if c_src is not None:
            require_on_grid(c_src, dual.grid, f"cloud mask {cloud_mask}")
        if raw is None:
            read_v = bands_reader([(v_src, b) for b in vbs])
            read_s = bands_reader([(s_src, b) for b in sbs])

            def raw(row0: int, row1: int):
                return read_v(row0, row1), read_s(row0, row1)

        yield MatchingReader(
            dual,
            vbs,
            sbs,
            raw,
            band_reader(c_src, 1) if c_src is not None else None,
            cloud_mask,
        )


def read_matching_pair(
    dual: DualSensor,
    bands: MatchBands = MatchBands(),
    cloud_mask: str | None = None,
    *,
    block_rows: int = DEFAULT_BLOCK_ROWS,
    progress: Progress | None = None,
) -> MatchingPair:
    """Read the whole VNIR and SWIR matching images of a flight line, strip by strip
    (:func:`open_matching_pair`; for the whole-array kernels)."""
    height, width = dual.grid.shape
    vnir = np.empty((height, width), np.float64)
    swir = np.empty((height, width), np.float64)
    valid = np.empty((height, width), bool)
    with open_matching_pair(dual, bands, cloud_mask) as pair:
        for win, (v, s, ok) in map_windows(
            pair.read,
            lambda v, s, ok: (v, s, ok),
            height=height,
            width=width,
            block_rows=block_rows,
            progress=progress,
            message="reading the matching bands",
        ):
            rows = slice(win.row_off, win.row_off + win.height)
            vnir[rows], swir[rows], valid[rows] = v, s, ok
    return MatchingPair(vnir, swir, valid, pair.vnir_bands, pair.swir_bands, dual)
