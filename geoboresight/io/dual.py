"""A dual-sensor dataset: the VNIR and SWIR halves of one flight line.

Either two files (VNIR, SWIR), or one merged cube that is split at a seam wavelength
(default 975 nm: AISA-Dual's EAGLE ends at ~970 nm, its HAWK starts at ~980 nm).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError
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
class DualLayout:
    """How a dual-sensor dataset is read when its files do not say it all: the seam of a
    merged cube, band centres for files without wavelength metadata.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.DualLayout()
    DualLayout(seam_nm=975.0, vnir_wavelengths=None, swir_wavelengths=None, vnir_calibration=None,
        swir_calibration=None)
    >>> gb.DualLayout(seam_nm=1000)  # a merged cube split at 1000 nm: --seam-nm 1000
    DualLayout(seam_nm=1000, vnir_wavelengths=None, swir_wavelengths=None, vnir_calibration=None,
        swir_calibration=None)
    """

    seam_nm: float = SEAM_NM
    vnir_wavelengths: str | None = None
    swir_wavelengths: str | None = None
    #: Calibration of a raw capture (a Specim ``.cal``/``.dat`` or its ``.hdr``, a
    #: :class:`~geoboresight.Calibration`; a HySpex file: the file itself): the VNIR (or
    #: one-file) capture and the SWIR capture are then read as radiance.
    vnir_calibration: object = None
    swir_calibration: object = None


@dataclass(frozen=True)
class BandChoice:
    """Which two bands make the boresight ratio (Eq. 3): nearest ``vnir_nm`` and ``swir_nm``
    within ``tolerance_nm`` (``band_mode="wavelength"``), or the last VNIR band and the first
    SWIR band (``"edges"``).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.BandChoice()
    BandChoice(band_mode='wavelength', vnir_nm=920.0, swir_nm=1010.0, tolerance_nm=10.0)
    >>> bands = gb.BandChoice(vnir_nm=900, swir_nm=1050)  # --vnir-nm 900 --swir-nm 1050
    >>> result = gb.ratio_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...     output="out/ratio.tif", bands=bands,
    ... )
    >>> result["vnir_wavelength_nm"], result["swir_wavelength_nm"]
    (898.0, 1052.772)
    """

    band_mode: str = "wavelength"
    vnir_nm: float = VNIR_NM
    swir_nm: float = SWIR_NM
    tolerance_nm: float = TOLERANCE_NM


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
    #: What GDAL opens for the pixels: ``path`` itself, or a product's VRT
    #: (:mod:`geoboresight.io.products`); ``path`` stays the user's file, for messages and tags.
    source: str | None = None
    #: Dark level per band of ``bands`` and column, shape (len(bands), width), or None.
    dark: np.ndarray | None = None
    #: Where ``dark`` comes from ("frames", "DARKREF file", "background matrix"); "" if none.
    dark_source: str = ""
    #: What the values are: "DN" or a radiance unit.
    units: str = "DN"
    #: The seam wavelength (nm) a merged cube was split at into this sensor's bands, or None.
    seam_nm: float | None = None

    @property
    def reads(self) -> str:
        """What GDAL opens for this sensor's pixels."""
        return self.source or self.path

    def band_for(self, target_nm: float, tolerance_nm: float) -> int:
        """1-based file band nearest ``target_nm`` among this sensor's bands."""
        label = f"{self.path} ({self.name} bands)"
        if self.seam_nm is not None:
            side = "below" if self.name == "VNIR" else "at or above"
            label = (
                f"{self.path} ({self.name} bands: those {side} the seam, seam_nm {self.seam_nm:g})"
            )
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
    #: The sensor product recognised (:class:`geoboresight.io.products.Product`), or None for
    #: a plain ENVI/GeoTIFF pair.
    product: object = None

    @property
    def width(self) -> int:
        return self.grid.width

    @property
    def files(self) -> tuple[str, ...]:
        """The user's files this dataset reads (one for a merged cube or a product)."""
        return tuple(dict.fromkeys((self.vnir.path, self.swir.path)))

    @property
    def height(self) -> int:
        return self.grid.height

    @property
    def crs(self):
        return self.grid.crs

    @property
    def transform(self):
        return self.grid.transform

    def ratio_bands(self, choice: BandChoice = BandChoice()) -> RatioBands:
        """The two bands of the boresight ratio b(1010 nm) / b(920 nm) (Eq. 3).

        ``band_mode="wavelength"``: the band centres nearest ``vnir_nm`` (VNIR) and ``swir_nm``
        (SWIR), within ``tolerance_nm``. ``band_mode="edges"``: the first SWIR band over the
        last VNIR band, whatever their wavelengths (the paper's choice on AISA-Dual).
        """
        band_mode, vnir_nm, swir_nm = choice.band_mode, choice.vnir_nm, choice.swir_nm
        tolerance_nm = choice.tolerance_nm
        if band_mode == "edges":
            vb, sb = self.vnir.last, self.swir.first
        elif band_mode == "wavelength":
            sb = self.swir.band_for(swir_nm, tolerance_nm)  # the numerator first, as in 0.1
            vb = self.vnir.band_for(vnir_nm, tolerance_nm)
        else:
            raise InputError(f"unknown band mode {band_mode!r}: use 'wavelength' or 'edges'")
        return RatioBands(vb, self.vnir.wavelength_of(vb), sb, self.swir.wavelength_of(sb))


def _sensor_wavelengths(
    src, path: str, user: str | None, sensor: str
) -> tuple[np.ndarray, np.ndarray | None]:
    """(centres, fwhm) of the file of ``sensor`` ("VNIR" or "SWIR"), or the user's list."""
    return wavelengths_of(src, f"{sensor} {path}", user, _option(sensor))


def _good(src, label: str, path: str) -> np.ndarray:
    """The bands the ENVI ``bbl`` keeps; refuse a file whose bands are all bad."""
    good = good_bands(src)
    if not good.any():
        raise InputError(
            f"{label} {path}: its header's 'bbl' marks every band bad: nothing to work with "
            "(fix the 'bbl' list)"
        )
    return good


def _image(path: str, label: str, user: str | None, sensor: str, calibration=None):
    """(SensorImage, Grid, Product or None) of one file given for ``sensor`` ("VNIR" or
    "SWIR"): a recognised sensor product's images (as radiance with ``calibration``), or the
    file as GDAL reads it (one image, named "cube")."""
    from .products import SensorImage, recognise

    product = recognise(path)
    images = product.images if product is not None else None
    if calibration is not None and calibration != "":
        from .radiance import radiance_image

        if product is None or product.kind not in ("Specim raw ENVI", "HySpex"):
            raise InputError(
                f"{label} {path}: a calibration ({sensor.lower()}_calibration) applies to a "
                "raw Specim capture or a HySpex file in DN, and this is "
                + (f"a {product.kind} product" if product else "not one")
            )
        image, plan = radiance_image(product, calibration, f"{sensor.lower()}_calibration")
        images = (image,)
        product = dataclasses.replace(product, notes=product.notes + (_calibration_note(plan),))
    if images is None:
        with open_raster(path, label) as src:
            wl, fw = _sensor_wavelengths(src, path, user, sensor)
            images = (SensorImage("cube", path, wl, fw, _good(src, label, path), src.nodata),)
            grid = Grid.of(src)
        return images, grid, None
    with open_raster(images[0].source, f"{label} {product.kind}") as src:
        grid = Grid.of(src)
    for im in images[1:]:
        with open_raster(im.source, f"{label} {product.kind}") as src:
            grid.require_same(Grid.of(src), f"{product.kind} {path} ({images[0].name})", im.name)
    return images, grid, product


def _calibration_note(plan) -> str:
    tags = plan.tags
    parts = [f"radiance in {tags['units']} through {tags['calibration_file']}"]
    for key in ("integration_time", "binning_ratio", "dark", "bad_pixels"):
        if key in tags:
            parts.append(f"{key.replace('_', ' ')}: {tags[key]}")
    if tags.get("sensor") == "Eagle":
        parts.append("Eagle frame-transfer smear not corrected on the fly (radiance corrects it)")
    return "; ".join(parts)


def _sensor(path: str, name: str, image, pick: np.ndarray, seam_nm=None) -> SensorFile:
    """The bands ``pick`` (0-based, of ``image``) as one sensor of a dual dataset."""
    return SensorFile(
        path,
        name,
        tuple(int(i) + 1 for i in pick),
        np.asarray(image.wavelengths, float)[pick],
        None if image.fwhm is None else np.asarray(image.fwhm, float)[pick],
        image.nodata,
        source=None if image.source == path else image.source,
        dark=None if image.dark is None else np.asarray(image.dark)[pick],
        dark_source=image.dark_source,
        units=image.units,
        seam_nm=seam_nm,
    )


def _good_of(image) -> np.ndarray:
    n = len(image.wavelengths)
    return np.ones(n, bool) if image.good is None else np.asarray(image.good, bool)


def open_dual(
    vnir: str,
    swir: str | None = None,
    seam_nm: float = SEAM_NM,
    vnir_wavelengths: str | None = None,
    swir_wavelengths: str | None = None,
    vnir_calibration=None,
    swir_calibration=None,
) -> DualSensor:
    """Describe a dual-sensor dataset (reads metadata only, no pixels).

    Parameters
    ----------
    vnir : path or open rasterio dataset
        The VNIR file, a merged VNIR+SWIR cube, or a sensor product holding both detectors
        (EnMAP L1B, PRISMA L1: :mod:`geoboresight.io.products`) when ``swir`` is None.
    swir : path or open rasterio dataset, optional
        The SWIR file, on the same pixel grid as ``vnir``.
    seam_nm : float
        In a merged cube, bands below the seam are VNIR, bands at or above it SWIR.
    vnir_wavelengths, swir_wavelengths : str, optional
        Comma-separated band centres (nm) for files without wavelength metadata.
    vnir_calibration, swir_calibration : path or Calibration, optional
        The calibration of a raw capture given as ``vnir`` (also a one-file capture of both
        detectors) or ``swir``: it is then read as radiance
        (:func:`geoboresight.io.radiance.radiance_image`).

    Examples
    --------
    >>> import geoboresight as gb
    >>> dual = gb.open_dual("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr")
    >>> dual.grid.width, dual.grid.height
    (286, 192)
    >>> dual.ratio_bands()  # the bands nearest 920 and 1010 nm
    RatioBands(vnir_band=88, vnir_nm=922.0, swir_band=3, swir_nm=1009.109)
    """
    from .image import dataset_path

    # Open rasterio datasets are read through their names, as every raster input is.
    vnir, swir = str(dataset_path(vnir)), dataset_path(swir)
    if swir is None and swir_calibration is not None and swir_calibration != "":
        raise ParameterError(
            "parameter 'swir_calibration': there is no SWIR file; give the calibration of a "
            "one-file capture as vnir_calibration",
            params=("swir_calibration",),
        )
    label = "VNIR" if swir else "merged cube"
    images, grid_v, product = _image(vnir, label, vnir_wavelengths, "VNIR", vnir_calibration)
    named = {im.name: im for im in images}
    if swir is None and "VNIR" in named and "SWIR" in named:
        # One product holding both detectors (EnMAP L1B, PRISMA L1).
        v, s = named["VNIR"], named["SWIR"]
        return DualSensor(
            _sensor(vnir, "VNIR", v, np.flatnonzero(_good_of(v))),
            _sensor(vnir, "SWIR", s, np.flatnonzero(_good_of(s))),
            grid_v,
            False,
            product,
        )
    if swir is None:
        if len(images) != 1:
            raise InputError(
                f"{label} {vnir}: this {product.kind} product holds {', '.join(named)} only: "
                "give the SWIR file as well"
            )
        cube = images[0]
        wl_v, good_v = np.asarray(cube.wavelengths, float), _good_of(cube)
        # Bands the ENVI 'bbl' marks bad belong to neither sensor: never picked nor read.
        below = np.flatnonzero((wl_v < seam_nm) & good_v)
        above = np.flatnonzero((wl_v >= seam_nm) & good_v)
        if below.size == 0 or above.size == 0:
            raise InputError(
                f"{label} {vnir}: its bands ({wl_v.min():.1f}–{wl_v.max():.1f} nm) do not "
                f"straddle the seam at {seam_nm:g} nm, so it cannot be split into VNIR and "
                "SWIR; give the SWIR file separately or change the seam wavelength"
            )
        return DualSensor(
            _sensor(vnir, "VNIR", cube, below, seam_nm),
            _sensor(vnir, "SWIR", cube, above, seam_nm),
            grid_v,
            True,
            product,
        )

    swir = str(swir)
    s_images, grid_s, s_product = _image(swir, "SWIR", swir_wavelengths, "SWIR", swir_calibration)
    v = named.get("VNIR", images[0])
    s = {im.name: im for im in s_images}.get("SWIR", s_images[0])
    grid_v.require_same(grid_s, f"VNIR {vnir}", f"SWIR {swir}")
    grid = Grid(
        grid_v.width, grid_v.height, grid_v.crs or grid_s.crs, grid_v.transform or grid_s.transform
    )
    return DualSensor(
        _sensor(vnir, "VNIR", v, np.flatnonzero(_good_of(v))),
        _sensor(swir, "SWIR", s, np.flatnonzero(_good_of(s))),
        grid,
        False,
        product or s_product,
    )


def as_dual(vnir, swir=None, layout: DualLayout = DualLayout()) -> DualSensor:
    """``vnir`` itself when it is an opened :class:`DualSensor` (as rasterio accepts a path or
    a dataset), else :func:`open_dual` of the paths with ``layout``."""
    if isinstance(vnir, DualSensor):
        if swir is not None:
            raise InputError(
                "give either an opened dual-sensor dataset or two files, not both (swir)"
            )
        return vnir
    return open_dual(
        vnir,
        swir,
        layout.seam_nm,
        layout.vnir_wavelengths,
        layout.swir_wavelengths,
        layout.vnir_calibration,
        layout.swir_calibration,
    )


def _option(label: str) -> str:
    return f"--{label.lower()}-wavelengths / {label.lower()}_wavelengths="
