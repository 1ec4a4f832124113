"""Specs: the boresight offset between the VNIR and SWIR images, and the co-registration that
removes it (paper §3.2)."""

from __future__ import annotations

from ..operations.offset import boresight_offset_file, coregister_file
from ..sensor.coregister import DEFAULT_ORDER
from ..sensor.offset import PROFILE_ROWS
from ._common import BLOCK_ROWS, DUAL_PARAMS
from ._dem_params import CLOUD, GEOMETRY, GROUP, OFFSET_MATCH
from .spec import Algorithm, Enum, FileOut, Flag, Number, RasterOut, Result

OFFSET = Algorithm(
    name="boresight-offset",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "offset.json"},
    results=(
        Result("along_px", "number", "Offset along track (pixels)"),
        Result("across_px", "number", "Offset across track (pixels)"),
        Result("match_error", "number", "Residual of the match"),
        Result("vnir_band", "number", "VNIR band used (1-based)"),
        Result("vnir_wavelength_nm", "number", "Centre of the VNIR band used (nm)"),
        Result("swir_band", "number", "SWIR band used (1-based)"),
        Result("swir_wavelength_nm", "number", "Centre of the SWIR band used (nm)"),
        Result("convention", "string", "Sign convention of the offset"),
    ),
    display_name="Boresight offset (image-based)",
    group=GROUP,
    short_help="Sub-pixel VNIR→SWIR shift from the images alone, in pixels and angles, per block for drift.",
    help=(
        "Measures the boresight offset between the VNIR and the SWIR image: the sub-pixel shift "
        "(along-track, across-track) that brings the VNIR band nearest 920 nm onto the SWIR band "
        "nearest 1010 nm (the two bands of the boresight ratio). It uses Fourier "
        "cross-correlation with upsampled-DFT refinement (scikit-image) and needs no GPS/INS.\n\n"
        "Convention: a ground feature at VNIR line r, column c appears at SWIR line r + along, "
        "column c + across. Over relief the shift also contains parallax, so the global value is "
        "the offset of the average ground.\n\n"
        "With the IFOV (and the flying height) the offset is also given as angles between the two "
        "lines of sight (and metres on the ground). With 'profile rows' > 0 the offset is also "
        "measured per block of lines, so drift along the flight line can be seen (JSON and an "
        "optional PNG plot).\n\n"
        "Output: a JSON report."
    ),
    params=(
        *DUAL_PARAMS,
        OFFSET_MATCH,
        CLOUD,
        GEOMETRY,
        Number(
            name="profile_rows",
            label="Lines per profile block",
            description="Also measure the offset per block of this many lines (0 = global only)",
            default=PROFILE_ROWS,
            minimum=0,
            integer=True,
        ),
        FileOut(
            name="output",
            label="Offset report",
            description="Offset report (JSON)",
            extension="json",
        ),
        FileOut(
            name="plot",
            label="Offset plot",
            description="Plot of the offset along the flight line (PNG)",
            extension="png",
            optional=True,
        ),
    ),
    run=boresight_offset_file,
)


COREGISTER = Algorithm(
    name="coregister",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "swir_on_vnir.tif"},
    results=(
        Result("bands", "number", "Bands resampled"),
        Result("along_px", "number", "Offset along track applied (pixels)"),
        Result("across_px", "number", "Offset across track applied (pixels)"),
    ),
    display_name="Co-register SWIR onto VNIR",
    group=GROUP,
    short_help="Resample every SWIR band onto the VNIR pixel grid, removing the boresight offset.",
    help=(
        "Corrects the boresight effect after it has been used: every SWIR band is resampled "
        "(cubic convolution by default) so that SWIR pixel (r, c) sees the ground of VNIR pixel "
        "(r, c). The offset is measured from the images (as 'Boresight offset') unless given; "
        "with 'follow drift' it is measured per block of lines and interpolated line by line.\n\n"
        "Output: a float32 GeoTIFF with all SWIR bands (band descriptions and tags carry the "
        "wavelengths in nm), nodata -9999 where the shifted image has no data, on the VNIR grid "
        "(CRS and transform carried over; raw sensor geometry stays raw)."
    ),
    params=(
        *DUAL_PARAMS,
        OFFSET_MATCH,
        CLOUD,
        Number(
            name="along",
            label="Offset along-track",
            description="Known along-track offset (px); empty = measure it",
            optional=True,
        ),
        Number(
            name="across",
            label="Offset across-track",
            description="Known across-track offset (px); empty = measure it",
            optional=True,
        ),
        Flag(
            name="follow_drift",
            label="Follow drift",
            description="Measure the offset per block of lines and follow it",
        ),
        Number(
            name="profile_rows",
            label="Lines per drift block",
            description="Block of lines for 'follow drift'",
            default=PROFILE_ROWS,
            minimum=16,
            integer=True,
            advanced=True,
        ),
        Enum(
            name="order",
            label="Interpolation",
            description="Interpolation: 1 linear, 3 cubic convolution (Keys)",
            choices=("1", "3"),
            default=str(DEFAULT_ORDER),
        ),
        BLOCK_ROWS,
        RasterOut(
            name="output", label="Co-registered SWIR", description="Co-registered SWIR (GeoTIFF)"
        ),
    ),
    run=coregister_file,
)

ALGORITHMS = (OFFSET, COREGISTER)
