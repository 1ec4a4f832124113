"""Spec: describe a flight line (sensor product, images, ratio bands, dark, geolocation)."""

from __future__ import annotations

from ..operations.info import info_file
from ._common import BAND_PARAMS, DUAL_PARAMS
from .spec import Algorithm, FileOut, Result

INFO = Algorithm(
    name="info",
    example={"vnir": "vnir.hdr", "output": "info.json"},
    results=(
        Result("product", "string", "Sensor product recognised ('GDAL raster' for a plain file)"),
        Result("lines", "number", "Image lines (along track)"),
        Result("samples", "number", "Samples per line (across track)"),
        Result("vnir_bands", "number", "VNIR bands the operations use (bad bands left out)"),
        Result("swir_bands", "number", "SWIR bands the operations use (bad bands left out)"),
        Result("vnir_band", "number", "VNIR band of the ratio (denominator, 1-based)"),
        Result("vnir_wavelength_nm", "number", "Centre of the ratio's VNIR band (nm)"),
        Result("swir_band", "number", "SWIR band of the ratio (numerator, 1-based)"),
        Result("swir_wavelength_nm", "number", "Centre of the ratio's SWIR band (nm)"),
        Result("dark_source", "string", "Where the dark reference comes from ('' if none)"),
        Result("summary", "string", "The description as text (what the command line prints)"),
        Result(
            "arrangement",
            "string",
            "How VNIR and SWIR are held: two files, a merged cube, a product",
        ),
        Result(
            "files",
            "string",
            "Each file described: images, bands, dark reference, geolocation (JSON)",
        ),
    ),
    display_name="Describe a flight line (info)",
    group="Boresight ratio and statistics",
    short_help="What a file, folder or zip holds: product, sizes, bands, ratio bands, dark, geolocation.",
    help=(
        "Describes a flight line as gdalinfo describes a raster, reading metadata only: the "
        "sensor product recognised (Specim raw ENVI, HySpex, EnMAP L1B, PRISMA L1, or a plain "
        "GDAL raster), each detector's image (lines × samples, interleave, data type, units, "
        "wavelength range and band count, bad bands), the dark reference and where it comes "
        "from, the two bands the boresight ratio would use (nearest 920 and 1010 nm unless "
        "chosen otherwise), the geolocation found (kind, CRS, size) and the reader's notes.\n\n"
        "Input: a VNIR file and a SWIR file, one merged cube, or one product (an EnMAP folder, "
        "zip or METADATA.XML; a PRISMA .he5). When the ratio's bands cannot be found (e.g. a "
        "VNIR file alone) the description says why instead of failing.\n\n"
        "Output: optionally the description as JSON."
    ),
    params=(
        *DUAL_PARAMS,
        *BAND_PARAMS,
        FileOut(
            name="output",
            label="Description (JSON)",
            description="The description as JSON (optional)",
            extension="json",
            optional=True,
        ),
    ),
    run=info_file,
    text="summary",
    positional=("vnir", "swir"),
)

ALGORITHMS = (INFO,)
