"""Spec: radiance from raw DN through the vendor's calibration (Specim, HySpex)."""

from __future__ import annotations

from ..io.bil import BIL_ENDINGS
from ..io.products import FILE_FORMATS
from ..io.radiance import SMEAR_CHOICES
from ..operations.radiance import radiance_file
from ._common import BLOCK_ROWS, CALIBRATION
from .spec import Algorithm, Enum, RasterIn, RasterOut, Result

RADIANCE = Algorithm(
    name="radiance",
    example={"input": "capture.hdr", "calibration": "calibration.cal", "output": "radiance.tif"},
    results=(
        Result("bands", "number", "Bands written"),
        Result("lines", "number", "Image lines written"),
        Result("valid_fraction", "number", "Fraction of values that are radiance (not nodata)"),
        Result("units", "string", "Units of the radiance written"),
    ),
    display_name="Radiance from raw DN",
    group="Boresight ratio and statistics",
    short_help="L = (DN − dark) · gain / tint[ms] through the Specim calibration file, or a HySpex file's own calibration.",
    help=(
        "Converts a raw capture to at-sensor radiance in µW cm⁻² sr⁻¹ nm⁻¹, as NERC-ARF's APL "
        "does: the dark frames (mean within 3σ) are subtracted, the gains of the calibration "
        "file applied and each detector's integration time divided out (an AisaFENIX's VNIR "
        "bands by tint1, its SWIR bands by tint2). An Eagle's frame-transfer smear is "
        "removed; a calibration measured at a finer binning is binned. Saturated pixels, the "
        "bad cells of the calibration's .bad file and the frame counter become nodata.\n\n"
        "Input: a raw Specim capture (ENVI with its Specim header) and its calibration file "
        "(.cal or .dat with its .hdr), or a HySpex .hyspex file, which carries its own "
        "calibration (HyPro's formula). A calibration for another sensor or binning is "
        "refused.\n\n"
        "Output: float32, one band per band of the capture, wavelengths and FWHM in its band "
        "metadata, nodata -9999, every choice and source in its tags: a GeoTIFF (.tif), or an "
        "ENVI BIL cube (.img), uncompressed and much faster to write and to read."
    ),
    params=(
        RasterIn(
            name="input",
            label="Raw capture",
            description="Raw Specim capture (ENVI .hdr/.raw) or HySpex .hyspex file",
            formats=FILE_FORMATS,
        ),
        CALIBRATION,
        Enum(
            name="smear",
            label="Smear correction",
            description="Eagle frame-transfer smear: auto (Eagle only), on or off",
            choices=SMEAR_CHOICES,
            default="auto",
            advanced=True,
        ),
        BLOCK_ROWS,
        RasterOut(
            name="output",
            label="Radiance",
            description="Radiance cube, float32: GeoTIFF (.tif) or ENVI BIL (.img, .bil, .dat)",
            also=BIL_ENDINGS,
        ),
    ),
    run=radiance_file,
)

ALGORITHMS = (RADIANCE,)
