"""Spec parameters every Relative DEM operation shares: the group, the bands matched between
VNIR and SWIR, the cloud mask and the flight geometry. Kept apart from the DEM's own specs so
that the offset and co-registration specs import them without the matching and kriging
modules (and SciPy's), which those operations do not run."""

from __future__ import annotations

from ..dem.height import FlightGeometry
from ..io.bands import DENSE_MATCH, MatchBands
from ._common import SWIR_BAND, TOLERANCE, VNIR_BAND, band_param
from .spec import Enum, Flag, Group, Number, RasterIn, Wavelength

GROUP = "Relative DEM"


def match_bands(default: MatchBands = MatchBands()) -> Group:
    """The bands matched between VNIR and SWIR (io.MatchBands): one band each, or band ranges
    averaged. The wavelengths' names and meanings are the ratio's (:data:`._common.VNIR_BAND`):
    the VNIR (SWIR) band an operation reads; only their defaults differ."""
    return Group(
        name="match",
        value=MatchBands,
        default=default,
        params=(
            band_param(VNIR_BAND, default.vnir_nm),
            band_param(SWIR_BAND, default.swir_nm),
            Wavelength(
                name="vnir_to_nm",
                label="VNIR up to wavelength",
                description=(
                    "Average the VNIR bands from 'vnir_nm' up to this wavelength (nm) into the "
                    "matching image (more signal, e.g. 900 to 970 nm); empty or equal to "
                    "'vnir_nm' = one band"
                ),
                default=default.vnir_to_nm,
                optional=True,
                advanced=True,
            ),
            Wavelength(
                name="swir_to_nm",
                label="SWIR up to wavelength",
                description=(
                    "Average the SWIR bands from 'swir_nm' up to this wavelength (nm) into the "
                    "matching image (the 1,010 nm band is weak; e.g. 980 to 1,100 nm); empty or "
                    "equal to 'swir_nm' = one band"
                ),
                default=default.swir_to_nm,
                optional=True,
                advanced=True,
            ),
            TOLERANCE,
        ),
    )


#: Offset and co-registration: the ratio's own two bands (Eq. 3).
OFFSET_MATCH = match_bands()
#: Dense matching: band means (900–970 nm against 980–1,100 nm; see geoboresight.sensor.bands).
DENSE_MATCH_BANDS = match_bands(DENSE_MATCH)

CLOUD = RasterIn(
    name="cloud_mask",
    label="Cloud mask",
    description="Cloud mask on the same grid (non-zero = cloud): masked in matching and in the DEM",
    optional=True,
)

FLYING_HEIGHT = Number(
    name="flying_height",
    label="Flying height",
    description="Flying height above the ground (m): with the IFOV gives the pixel size",
    optional=True,
    minimum=0.0,
    unit="m",
)
IFOV = Number(
    name="ifov_mrad",
    label="IFOV",
    description="Instantaneous field of view of one pixel (mrad; AISA-Dual ≈ 1)",
    optional=True,
    minimum=0.0,
    unit="mrad",
)
HEIGHT_FACTOR = Number(
    name="height_factor",
    label="Height factor",
    description="Height-to-disparity factor k = tan θ / GSD (px per metre of height)",
    optional=True,
    unit="px/m",
)
SQUINT = Number(
    name="squint_deg",
    label="Squint angle",
    description="Angle between the VNIR and SWIR lines of sight (degrees), if k is not given",
    optional=True,
    minimum=0.0,
    maximum=45.0,
    unit="°",
)
#: The relative DEM's flight geometry (dem.height.FlightGeometry): k, or squint, flying
#: height and IFOV; the parallax's axis and direction.
FLIGHT_GEOMETRY = Group(
    name="geometry",
    value=FlightGeometry,
    params=(
        HEIGHT_FACTOR,
        SQUINT,
        FLYING_HEIGHT,
        IFOV,
        Enum(
            name="parallax_axis",
            label="Parallax axis",
            description="Direction of the parallax (the squint plane)",
            choices=("along", "across"),
            default="along",
        ),
        Flag(
            name="invert_parallax",
            label="Invert parallax",
            description="Elevated features appear at lower line (column) numbers in the SWIR image",
        ),
    ),
)

#: The flying height and IFOV alone (the offset's angles and metres): a FlightGeometry.
GEOMETRY = Group(name="geometry", value=FlightGeometry, params=(FLYING_HEIGHT, IFOV))
