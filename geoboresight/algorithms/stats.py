"""Spec: SPSS-style descriptive statistics of one raster band (Table 1, Figure 3)."""

from __future__ import annotations

from ..io.products import FILE_FORMATS
from ..operations.stats import BINS, PERCENTILES, stats_file
from ._common import BAND_NM, BLOCK_ROWS
from .spec import Algorithm, Band, FileOut, Number, RasterIn, Result, Text

STATS = Algorithm(
    name="stats",
    example={"input": "ratio.tif", "output": "stats.json"},
    results=(
        Result("n", "number", "Valid pixels (N)"),
        Result("mean", "number", "Mean"),
        Result("std", "number", "Standard deviation"),
        Result("skewness", "number", "Skewness"),
        Result("se_skewness", "number", "Standard error of the skewness"),
    ),
    display_name="Descriptive statistics (SPSS style)",
    group="Boresight ratio and statistics",
    short_help="N, mean and its SE, std, variance, skewness and kurtosis with SEs and z tests, 3σ outliers, histogram.",
    help=(
        "Descriptive statistics of one band as SPSS reports them (Table 1 of Brook & Ben-Dor "
        "2011): N, mean and its standard error, standard deviation, variance, skewness and "
        "kurtosis (bias-corrected G1, G2) with their standard errors and z tests, minimum, "
        "maximum, percentiles, the pixels beyond 3 standard deviations, and the histogram "
        "(Figure 3). Nodata pixels are ignored.\n\n"
        "Exact for flight lines of any length: the raster is read block by block and the "
        "moments merged exactly; percentiles are exact order statistics.\n\n"
        "Outputs: a JSON file (all numbers), optionally an HTML table and a histogram PNG."
    ),
    params=(
        RasterIn(
            name="input",
            label="Input raster",
            description="Raster to describe (typically the boresight ratio)",
            formats=FILE_FORMATS,
        ),
        Band(
            name="band",
            label="Band number",
            description="Band number (1 = first)",
            default=1,
            raster="input",
            wavelength="band_nm",
        ),
        BAND_NM,
        Number(
            name="bins",
            label="Histogram bins",
            description="Number of histogram bins",
            default=BINS,
            minimum=2,
            maximum=10000,
            integer=True,
        ),
        Text(
            name="percentiles",
            label="Percentiles",
            description="Percentiles to report, comma-separated (0–100)",
            default=PERCENTILES,
        ),
        BLOCK_ROWS,
        FileOut(
            name="output",
            label="Statistics (JSON)",
            description="Statistics as JSON",
            extension="json",
        ),
        FileOut(
            name="html",
            label="Statistics (HTML)",
            description="Statistics as an HTML table",
            extension="html",
            optional=True,
        ),
        FileOut(
            name="histogram",
            label="Histogram",
            description="Histogram (PNG)",
            extension="png",
            optional=True,
        ),
    ),
    run=stats_file,
)

ALGORITHMS = (STATS,)
