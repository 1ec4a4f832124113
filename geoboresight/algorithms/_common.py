"""Parameters and helpers shared by the specs (not an operation: the registry skips ``_`` modules)."""

from __future__ import annotations

import dataclasses

from .. import io
from ..anomaly.bands import WATER_BANDS_NM, BandSelection
from ..anomaly.physical import TARGET_CONTRAST, TARGET_FRACTION, Detectability
from ..io.bands import BoresightOffset, Coregistration
from ..io.dual import SEAM_NM, SWIR_NM, TOLERANCE_NM, VNIR_NM, BandChoice, DualLayout
from ..io.products import FILE_FORMATS
from ..sensor.dark import DarkLevels
from .spec import Enum, FileIn, Flag, Group, Number, RasterIn, Result, Text, Wavelength


@dataclasses.dataclass(frozen=True, kw_only=True)
class CalibrationIn(FileIn):
    """A radiometric calibration: its file (``.cal``/``.dat`` or ``.hdr``) on every face, or a
    :class:`~geoboresight.Calibration` value in Python."""

    def coerce(self, value):
        from ..sensor.calibration import Calibration

        if isinstance(value, Calibration):
            return value
        return super().coerce(value)


CALIBRATION = CalibrationIn(
    name="calibration",
    label="Calibration",
    description="Specim calibration file (.cal or .dat with its .hdr); empty for HySpex",
    optional=True,
    extensions=("cal", "dat", "hdr"),
)

VNIR = RasterIn(
    name="vnir",
    label="VNIR image",
    description=(
        "VNIR image (ENVI .hdr/.img or GeoTIFF), a merged VNIR+SWIR cube, or a sensor product "
        "holding both (EnMAP L1B, PRISMA L1)"
    ),
    formats=FILE_FORMATS,
)
SWIR = RasterIn(
    name="swir",
    label="SWIR image",
    description="SWIR image on the same pixel grid (leave empty for a merged cube or a product)",
    optional=True,
    formats=FILE_FORMATS,
)

#: How a dual-sensor dataset is read where its files do not say it all (io.DualLayout).
LAYOUT = Group(
    name="layout",
    value=DualLayout,
    params=(
        Wavelength(
            name="seam_nm",
            label="Seam wavelength",
            description="Merged cube only: bands below this wavelength are VNIR, the rest SWIR (nm)",
            default=SEAM_NM,
            advanced=True,
        ),
        Text(
            name="vnir_wavelengths",
            label="VNIR band centres",
            description="Band centres of the VNIR file in nm, comma-separated (only if the file has none)",
            optional=True,
            advanced=True,
        ),
        Text(
            name="swir_wavelengths",
            label="SWIR band centres",
            description="Band centres of the SWIR file in nm, comma-separated (only if the file has none)",
            optional=True,
            advanced=True,
        ),
        CalibrationIn(
            name="vnir_calibration",
            label="VNIR calibration",
            description=(
                "Calibration of a raw VNIR (or one-file) capture: Specim .cal/.dat, or the "
                "HySpex file itself; the capture is then read as radiance"
            ),
            optional=True,
            extensions=("cal", "dat", "hdr", "hyspex"),
        ),
        CalibrationIn(
            name="swir_calibration",
            label="SWIR calibration",
            description=(
                "Calibration of a raw SWIR capture: Specim .cal/.dat, or the HySpex file "
                "itself; the capture is then read as radiance"
            ),
            optional=True,
            extensions=("cal", "dat", "hdr", "hyspex"),
        ),
    ),
)

#: A band chosen by its centre wavelength instead of its number (a sensor product's bands, a
#: file with wavelength metadata): pair it with ``Band(..., wavelength="band_nm")``.
BAND_NM = Wavelength(
    name="band_nm",
    label="Band wavelength",
    description="Band by its centre wavelength in nm, instead of its number (nearest within 10 nm)",
    optional=True,
)

#: Parameters shared by every operation that reads a dual-sensor dataset: the operation takes
#: ``vnir`` (a path or an opened DualSensor), ``swir`` and ``layout``.
DUAL_PARAMS = (VNIR, SWIR, LAYOUT)

TOLERANCE = Number(
    name="tolerance_nm",
    label="Wavelength tolerance",
    description="Largest allowed distance between a requested wavelength and a band centre (nm)",
    default=TOLERANCE_NM,
    minimum=0.0,
    maximum=500.0,
    unit="nm",
    advanced=True,
)

#: The VNIR and SWIR band an operation reads, nearest a wavelength: the boresight ratio's
#: denominator and numerator (Eq. 3), the bands the offset matches, the dense matching's band
#: ranges (from here). One name, one meaning; only the default differs (:func:`band_param`).
VNIR_BAND = Wavelength(
    name="vnir_nm",
    label="VNIR wavelength",
    description="VNIR band: the one nearest this wavelength (nm)",
    default=VNIR_NM,
    aliases=("denominator_nm",),
)
SWIR_BAND = Wavelength(
    name="swir_nm",
    label="SWIR wavelength",
    description="SWIR band: the one nearest this wavelength (nm)",
    default=SWIR_NM,
    aliases=("numerator_nm",),
)


def band_param(band: Wavelength, default: float) -> Wavelength:
    """``band`` (:data:`VNIR_BAND` or :data:`SWIR_BAND`) with another default."""
    return dataclasses.replace(band, default=default)


#: The ratio's band choice (io.BandChoice), the operation's ``bands``.
BANDS = Group(
    name="bands",
    value=BandChoice,
    params=(
        Enum(
            name="band_mode",
            label="Band choice",
            description=(
                "How to pick the two bands: nearest to the wavelengths below, or the first SWIR "
                "band over the last VNIR band"
            ),
            choices=("wavelength", "edges"),
            default="wavelength",
        ),
        VNIR_BAND,
        SWIR_BAND,
        TOLERANCE,
    ),
)
BAND_PARAMS = (BANDS,)


def block_rows(default: int = io.DEFAULT_BLOCK_ROWS) -> Number:
    """Lines read at a time: memory is bounded by a few blocks, whatever the flight line."""
    return Number(
        name="block_rows",
        label="Lines per block",
        description="Lines read at a time (memory is bounded by a few blocks of lines)",
        default=default,
        minimum=1,
        maximum=100000,
        integer=True,
        advanced=True,
    )


BLOCK_ROWS = block_rows()


def seed(description: str = "Random seed (same seed, same result)", advanced=True) -> Number:
    """A random seed parameter: the same seed gives the same result. The range is a 32-bit
    integer's, which every face (QGIS's integer parameters included) can hold."""
    return Number(
        name="seed",
        label="Random seed",
        description=description,
        default=0,
        minimum=0,
        maximum=2**31 - 1,
        integer=True,
        advanced=advanced,
    )


def sample_size(
    description: str, default: int, minimum: int, maximum: int, advanced=True
) -> Number:
    """How many pixels a statistical fit draws at random from the whole flight line."""
    return Number(
        name="sample_size",
        label="Sample size",
        description=description,
        default=default,
        minimum=minimum,
        maximum=maximum,
        integer=True,
        advanced=advanced,
    )


#: The dark levels the user gives (sensor.dark.DarkLevels); empty = product, header or estimated.
DARK = Group(
    name="dark",
    value=DarkLevels,
    params=(
        Number(
            name="vnir_dark",
            label="VNIR dark level",
            description="VNIR dark level (DN of zero signal; empty = from the header or estimated; 0 for radiance)",
            optional=True,
            unit="DN",
            advanced=True,
        ),
        Number(
            name="swir_dark",
            label="SWIR dark level",
            description="SWIR dark level (DN of zero signal; empty = from the header or estimated; 0 for radiance)",
            optional=True,
            unit="DN",
            advanced=True,
        ),
    ),
)

#: The boresight offset the user gives (BoresightOffset); empty = measured.
OFFSET = Group(
    name="offset",
    value=BoresightOffset,
    params=(
        Number(
            name="offset_along",
            label="Offset along-track",
            description="Boresight offset of the SWIR along-track (px; empty = measured)",
            optional=True,
            unit="px",
            advanced=True,
        ),
        Number(
            name="offset_across",
            label="Offset across-track",
            description="Boresight offset of the SWIR across-track (px; empty = measured)",
            optional=True,
            unit="px",
            advanced=True,
        ),
    ),
)


#: The target whose detectability (expected d′) each detector reports.
DETECTABILITY = Group(
    name="detectability",
    value=Detectability,
    params=(
        Number(
            name="target_fraction",
            label="Target fill fraction",
            description="Detectability: the target's fill fraction of a pixel (0–1]",
            default=TARGET_FRACTION,
            minimum=1e-4,
            maximum=1.0,
            advanced=True,
        ),
        Number(
            name="target_contrast",
            label="Target contrast",
            description="Detectability: the target's contrast, signal above dark relative to the background's minus 1 (e.g. -0.3: 30 % darker)",
            default=TARGET_CONTRAST,
            minimum=-1.0,
            maximum=100.0,
            advanced=True,
        ),
    ),
)

COREGISTER = Flag(
    name="coregister",
    label="Co-register the SWIR",
    description="Shift the SWIR onto the VNIR grid by the boresight offset first (measured, or given)",
    default=True,
)

#: Whether and by which offset RX and SVDD co-register the SWIR (io.bands.Coregistration).
COREGISTRATION = Group(
    name="coregistration", value=Coregistration, params=(COREGISTER, *OFFSET.params)
)

#: Co-registration, dark levels and detectability: what RX and SVDD add to the image.
CHAIN_PARAMS = (COREGISTRATION, DARK, DETECTABILITY)

DPRIME_RESULTS = (
    Result("coregistered", "boolean", "SWIR co-registered onto the VNIR grid"),
    Result("offset_along_px", "number", "Boresight offset removed, along-track (px)"),
    Result("offset_across_px", "number", "Boresight offset removed, across-track (px)"),
    Result("dprime", "number", "Expected d′ of the given target (measured noise and clutter)"),
    Result("dprime_low", "boolean", "d′ below 3: such targets are not detectable"),
)

GREY_RESULT = Result(
    "dprime_grey", "number", "Expected d′ of a grey target (its change along brightness)"
)


#: The bands per-pixel spectral work uses, by wavelength (anomaly.bands.BandSelection).
SPECTRAL = Group(
    name="spectral",
    value=BandSelection,
    params=(
        Text(
            name="include_nm",
            label="Include wavelengths",
            description="Use only bands in these wavelength ranges, e.g. '400-900,1000-1300' (empty: all)",
            default="",
            optional=True,
        ),
        Text(
            name="exclude_nm",
            label="Exclude wavelengths",
            description="Leave out bands in these wavelength ranges (default: water-vapour absorption)",
            default=WATER_BANDS_NM,
            optional=True,
        ),
    ),
)

IMAGE_PARAMS = (
    RasterIn(
        name="vnir",
        label="VNIR image",
        description=(
            "VNIR image (ENVI .hdr/.img or GeoTIFF), a merged VNIR+SWIR cube, or a sensor "
            "product holding both (EnMAP L1B, PRISMA L1): every good band is used"
        ),
        aliases=("image",),
    ),
    RasterIn(
        name="swir",
        label="SWIR image",
        description="SWIR image on the same pixel grid (its bands stacked after the VNIR bands; leave empty for a merged cube or a product)",
        optional=True,
    ),
    # VNIR and SWIR are stacked whole: a seam is never needed, band centres may be.
    Group(
        name="layout",
        value=DualLayout,
        params=tuple(p for p in LAYOUT.params if p.name != "seam_nm"),
    ),
    SPECTRAL,
)
