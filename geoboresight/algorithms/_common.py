"""Parameters and helpers shared by the specs (not an operation: the registry skips ``_`` modules)."""

from __future__ import annotations

import dataclasses

from .. import io
from ..io.dual import SEAM_NM, SWIR_NM, TOLERANCE_NM, VNIR_NM, BandChoice, DualLayout
from ..io.products import FILE_FORMATS
from .spec import Enum, Group, Number, RasterIn, Text, Wavelength

VNIR = RasterIn(
    name="vnir",
    description=(
        "VNIR image (ENVI .hdr/.img or GeoTIFF), a merged VNIR+SWIR cube, or a sensor product "
        "holding both (EnMAP L1B, PRISMA L1)"
    ),
    formats=FILE_FORMATS,
)
SWIR = RasterIn(
    name="swir",
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
            description="Merged cube only: bands below this wavelength are VNIR, the rest SWIR (nm)",
            default=SEAM_NM,
            advanced=True,
        ),
        Text(
            name="vnir_wavelengths",
            description="Band centres of the VNIR file in nm, comma-separated (only if the file has none)",
            optional=True,
            advanced=True,
        ),
        Text(
            name="swir_wavelengths",
            description="Band centres of the SWIR file in nm, comma-separated (only if the file has none)",
            optional=True,
            advanced=True,
        ),
    ),
)

#: Parameters shared by every operation that reads a dual-sensor dataset: the operation takes
#: ``vnir`` (a path or an opened DualSensor), ``swir`` and ``layout``.
DUAL_PARAMS = (VNIR, SWIR, LAYOUT)

TOLERANCE = Number(
    name="tolerance_nm",
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
    description="VNIR band: the one nearest this wavelength (nm)",
    default=VNIR_NM,
    aliases=("denominator_nm",),
)
SWIR_BAND = Wavelength(
    name="swir_nm",
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
        description=description,
        default=default,
        minimum=minimum,
        maximum=maximum,
        integer=True,
        advanced=advanced,
    )
