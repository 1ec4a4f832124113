"""Specs of the references the boresight shadow map is validated against (paper §3.1): the
ground-truth shadow of a surface model and the ATCOR-4-style dark-pixel baseline. Declarations
only: each ``run`` is a file-level operation of :mod:`geoboresight.operations.shadow_truth`."""

from __future__ import annotations

from ..io.windows import Sample
from ..operations.shadow_truth import BANDS_NM, dark_pixel_shadow_file, sun_shadow_file
from ..shadow.darkpixel import DARK_PERCENTILE, SAMPLE_SIZE, THRESHOLD
from ..shadow.illumination import SUPERSAMPLE, SURFACES
from ..shadow.incidence import Z_FACTOR
from ..shadow.surface import AUTO
from ._common import BLOCK_ROWS, TOLERANCE, sample_size, seed
from .spec import Algorithm, Band, Enum, Group, Number, RasterIn, RasterOut, Result, Text

GROUP = "Shadow"

SUN_SHADOW = Algorithm(
    name="sun-shadow",
    example={
        "dsm": "dsm.tif",
        "sun_zenith": "40",
        "sun_azimuth": "135",
        "output": "sun_shadow.tif",
    },
    results=(
        Result("shadow_pixels", "number", "Shadow pixels"),
        Result("valid_pixels", "number", "Valid pixels"),
        Result("relief_m", "number", "Relief of the surface (m)"),
    ),
    display_name="Sun shadow (ground truth from a surface model)",
    group=GROUP,
    short_help="Shadow fraction, shadow mask and hillshade of a surface model for a sun position.",
    help=(
        "Simulates the ground-truth shadow map of Brook & Ben-Dor (2011, §3.1) from a surface "
        "model (DSM/DTM with buildings) and the sun's zenith and azimuth.\n\n"
        "Cast shadows are found by ray marching: from each cell, step towards the sun one cell "
        "at a time; the cell is shadowed when the surface along the ray rises above the sun line "
        "(the method of GRASS r.sunmask, which this tool reproduces). Cells are split into "
        "n × n sub-cells and the fraction of shaded sub-cells is the shadow fraction (0–1). "
        "'blocks' treats cells as flat-topped (buildings); 'smooth' interpolates the surface "
        "(natural terrain); 'auto' (default) chooses blocks when the surface model has walls "
        "(height steps of 2 m or more steeper than 70° between neighbouring cells, in at least "
        "0.2 % of the pairs) and smooth otherwise. The optional hillshade is the cosine of the solar incidence angle "
        "from Horn's gradient, as gdaldem hillshade (GDAL's byte value is 1 + 254·max(cos i, 0)).\n\n"
        "The zenith is 0° (sun overhead) to 90° (horizon); the azimuth is clockwise from north "
        "towards the sun. Or give the acquisition time: the angles are computed at the surface "
        "model's centre with NREL's Solar Position Algorithm. A surface model without a geotransform needs a cell size; its row 0 is "
        "then taken as the northern edge."
    ),
    params=(
        RasterIn(
            name="dsm",
            label="Surface model",
            description="Surface model (heights in metres; GeoTIFF or anything GDAL reads)",
        ),
        Band(
            name="band",
            label="Band number",
            description="Band of the surface model",
            default=1,
            raster="dsm",
        ),
        Number(
            name="sun_zenith",
            label="Sun zenith",
            description="Sun zenith angle (degrees from vertical, 0–90; or give the acquisition time)",
            optional=True,
            minimum=0.0,
            maximum=90.0,
            unit="°",
        ),
        Number(
            name="sun_azimuth",
            label="Sun azimuth",
            description="Sun azimuth (degrees clockwise from the grid's up: north on a map grid; on a raw grid without a geotransform, towards row 0, so with lines recorded along the flight and columns to the right of the track it is 180° minus the azimuth from the flight direction; 0–360)",
            optional=True,
            minimum=0.0,
            maximum=360.0,
            unit="°",
        ),
        Text(
            name="acquisition_time",
            label="Acquisition time",
            description="Acquisition date and time, ISO 8601 (e.g. 2009-06-20T10:32:00Z; UTC without an offset): the sun's zenith and azimuth are computed from it at the surface model's centre (instead of giving them; needs a georeferenced surface model)",
            optional=True,
        ),
        Number(
            name="cell_size",
            label="Cell size",
            description="Cell size in metres, for a surface model without a geotransform",
            optional=True,
            minimum=1e-6,
            unit="m",
        ),
        Number(
            name="supersample",
            label="Supersampling",
            description="Sub-cells per cell side for the shadow fraction",
            default=SUPERSAMPLE,
            minimum=1,
            maximum=16,
            integer=True,
        ),
        Enum(
            name="surface",
            label="Surface",
            description="How the surface between cell centres is modelled",
            choices=(AUTO, *SURFACES),
            default=AUTO,
        ),
        Number(
            name="z_factor",
            label="Z factor",
            description="Vertical exaggeration of the hillshade (as gdaldem -z)",
            default=Z_FACTOR,
            minimum=1e-6,
            advanced=True,
        ),
        BLOCK_ROWS,
        RasterOut(
            name="output", label="Shadow fraction", description="Shadow fraction (0–1, float32)"
        ),
        RasterOut(
            name="mask",
            label="Shadow mask",
            description="Shadow mask (fraction ≥ 0.5)",
            optional=True,
        ),
        RasterOut(
            name="hillshade",
            label="Hillshade",
            description="Hillshade: cosine of the solar incidence angle",
            optional=True,
        ),
    ),
    run=sun_shadow_file,
)

DARK_PIXEL = Algorithm(
    name="dark-pixel-shadow",
    example={"vnir": "vnir.hdr", "output": "dark_pixel_shadow.tif"},
    results=(
        Result("shadow_pixels", "number", "Shadow pixels"),
        Result("candidates", "number", "Candidate dark pixels"),
    ),
    display_name="Dark-pixel shadow (ATCOR-4-style baseline)",
    group=GROUP,
    short_help="Statistical dark-pixel shadow mask of the ATCOR-4 kind, for comparison.",
    help=(
        "The kind of shadow detector ATCOR-4 uses (Richter & Müller 2005), the baseline Brook & "
        "Ben-Dor (2011) compare the boresight shadow map with. Core-shadow candidates are the "
        "pixels darkest in the near infrared and in the visible (below the 'dark percentile' of "
        "the scene in both); a matched filter built from the scene mean and covariance and the "
        "candidates' mean spectrum gives each pixel a shadow function Φ (0 = scene average, "
        "1 = like the dark candidates); the mask is Φ ≥ threshold.\n\n"
        "It uses only image statistics, so dark materials (asphalt, dark roofs, water) look like "
        "shadow to it: that is the failure the paper's boresight method avoids. Not included: "
        "ATCOR's atmospheric correction, cloud and water masks and the de-shadowing itself."
    ),
    params=(
        RasterIn(
            name="vnir",
            label="VNIR image",
            description="VNIR image (or a merged cube) with wavelength metadata",
            aliases=("image",),
        ),
        Text(
            name="bands_nm",
            label="Wavelengths",
            description="Wavelengths of the bands used (nm, comma-separated; the longest is the NIR)",
            default=BANDS_NM,
        ),
        Text(
            name="vnir_wavelengths",
            label="VNIR band centres",
            description="Band centres of the VNIR file in nm, comma-separated (only if the file has none)",
            optional=True,
            advanced=True,
            aliases=("wavelengths",),
        ),
        TOLERANCE,
        Number(
            name="dark_percentile",
            label="Dark percentile",
            description="Core-shadow candidates: darker than this percentile of the scene (NIR and visible)",
            default=DARK_PERCENTILE,
            minimum=0.1,
            maximum=50.0,
        ),
        Number(
            name="threshold",
            label="Threshold",
            description="Shadow where the shadow function Φ reaches this value",
            default=THRESHOLD,
            minimum=0.0,
            maximum=2.0,
        ),
        Group(
            name="sample",
            value=Sample,
            params=(
                sample_size(
                    "Pixels sampled at random (for the statistics)", SAMPLE_SIZE, 500, 5_000_000
                ),
                seed(),
            ),
        ),
        BLOCK_ROWS,
        RasterOut(
            name="output",
            label="Shadow mask",
            description="Dark-pixel shadow mask (byte: 1 shadow, 0 not)",
        ),
        RasterOut(
            name="shadow_function",
            label="Shadow function",
            description="Shadow function Φ (float32)",
            optional=True,
        ),
    ),
    run=dark_pixel_shadow_file,
)

ALGORITHMS = (SUN_SHADOW, DARK_PIXEL)
