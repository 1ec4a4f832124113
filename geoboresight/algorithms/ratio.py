"""Spec: the boresight band ratio raster (Eq. 3)."""

from __future__ import annotations

from ..operations.ratio import ratio_file
from ._common import BAND_PARAMS, BLOCK_ROWS, DUAL_PARAMS
from .spec import Algorithm, RasterOut, Result

RATIO = Algorithm(
    name="ratio",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "ratio.tif"},
    results=(
        Result("swir_band", "number", "SWIR band used (numerator, 1-based)"),
        Result("swir_wavelength_nm", "number", "Centre of the SWIR band used (nm)"),
        Result("vnir_band", "number", "VNIR band used (denominator, 1-based)"),
        Result("vnir_wavelength_nm", "number", "Centre of the VNIR band used (nm)"),
        Result("valid_pixels", "number", "Pixels with a valid ratio"),
    ),
    display_name="Boresight band ratio",
    group="Boresight ratio and statistics",
    short_help="b(1010 nm) / b(920 nm): the first SWIR band over the last VNIR band (Eq. 3).",
    help=(
        "Computes the boresight band ratio of Brook & Ben-Dor (2011, Eq. 3): the SWIR band "
        "nearest 1010 nm divided by the VNIR band nearest 920 nm. The two optics of a dual "
        "pushbroom sensor (e.g. AISA-Dual) see slightly different ground, so the ratio is high in "
        "core shadow and at sub-pixel anomalies.\n\n"
        "Input: two files (VNIR and SWIR on the same pixel grid) or one merged cube, split at the "
        "seam wavelength. Wavelengths are read from the ENVI header or the band metadata; give "
        "them by hand for files without any. Works in raw sensor geometry (no CRS is invented) "
        "as well as on georeferenced data (CRS and transform are carried to the output).\n\n"
        "Output: a float32 GeoTIFF, nodata -9999 where either band is nodata or the denominator "
        "is zero or negative, with tags recording the bands and wavelengths used."
    ),
    params=(
        *DUAL_PARAMS,
        *BAND_PARAMS,
        BLOCK_ROWS,
        RasterOut(
            name="output", label="Boresight ratio", description="Boresight ratio raster (GeoTIFF)"
        ),
    ),
    run=ratio_file,
)

ALGORITHMS = (RATIO,)
