"""Spec of the shadow map (paper §3.1, made physical): VNIR + SWIR in, a shadow mask and the
four shadow-fraction classes out. Declaration only: ``run`` is
:func:`geoboresight.operations.shadow_map.shadow_map_file`."""

from __future__ import annotations

from ..io.dual import BandChoice
from ..operations.shadow_map import (
    SAMPLE_SIZE,
    Detection,
    MapCalibration,
    SurfaceModel,
    shadow_map_file,
)
from ..shadow.context import SKY_BLUE
from ..shadow.darkness import CORE_DARKNESS, EDGE_PIXELS
from ._common import (
    BLOCK_ROWS,
    DARK,
    DUAL_PARAMS,
    OFFSET,
    SWIR_BAND,
    TOLERANCE,
    VNIR_BAND,
    sample_size,
    seed,
)
from .spec import Algorithm, FileIn, Flag, Group, Number, RasterIn, RasterOut, Result, Text

GROUP = "Shadow"

#: The ratio's bands, always by wavelength here (no 'band_mode': BandChoice's default).
RATIO_BANDS = Group(name="bands", value=BandChoice, params=(VNIR_BAND, SWIR_BAND, TOLERANCE))

#: How the map is calibrated (MapCalibration): the boresight offset the user gives (empty =
#: measured) and the random sample (200,000 pixels by default).
CALIBRATION = Group(
    name="calibration",
    value=MapCalibration,
    params=(
        *OFFSET.params,
        sample_size(
            "Pixels sampled at random (to calibrate the map)", SAMPLE_SIZE, 1000, 5_000_000
        ),
        seed(),
    ),
)

#: The spectral shadow test (Detection).
DETECTION = Group(
    name="detection",
    value=Detection,
    params=(
        Number(
            name="core_darkness",
            label="Core darkness",
            description="Core shadow: natural log of the SWIR signal over its sunlit mode at or below this (default ln 1/6; with a surface model only at its predicted edges and near its sunward edge)",
            default=CORE_DARKNESS,
            minimum=-10.0,
            maximum=-0.01,
            advanced=True,
        ),
        Number(
            name="edge_pixels",
            label="Edge pixels",
            description="Look for partial shadow this many pixels around the core (0 = core only)",
            default=EDGE_PIXELS,
            minimum=0,
            maximum=10,
            integer=True,
            advanced=True,
        ),
        Number(
            name="sky_blue",
            label="Sunlit blue limit",
            description="Without a surface model (and where its spectral estimate holds): a pixel dark in the NIR and SWIR whose blue is at least this (natural log of its blue over the scene's sunlit blue; default −0.3, three quarters) and whose blue/NIR is a flat dark material's, or whose blue is at least this − 0.2 and whose SWIR is not darker at 2.0–2.3 µm than at 1.55–1.75 µm against the sunlit ground, is a sunlit dark material, not shadow; higher flags more shadow and more dark materials",
            default=SKY_BLUE,
            minimum=-3.0,
            maximum=3.0,
        ),
    ),
)

#: A surface model and the sun (SurfaceModel): the cast shadow it predicts is the prior.
SURFACE = Group(
    name="surface",
    value=SurfaceModel,
    params=(
        RasterIn(
            name="dsm",
            label="Surface model (DSM)",
            description="Surface model (DSM, m) on the image's grid, or on a map grid with the line's IGM or GLT: its cast shadow is the prior (empty = spectra only)",
            optional=True,
        ),
        RasterIn(
            name="igm",
            label="IGM",
            description="The line's IGM (map coordinates of each raw pixel), to read a DSM on a map grid at the image's pixels",
            optional=True,
        ),
        RasterIn(
            name="glt",
            label="GLT",
            description="Or the line's GLT (one-based sample and line of each map cell), to read a DSM on a map grid at the image's pixels",
            optional=True,
            advanced=True,
        ),
        Text(
            name="igm_crs",
            label="IGM/GLT CRS",
            description="CRS of the IGM or GLT when its header carries none (e.g. EPSG:32636)",
            optional=True,
            advanced=True,
        ),
        Text(
            name="acquisition_time",
            label="Acquisition time",
            description="Acquisition date and time, ISO 8601 (e.g. 2009-06-20T10:32:00Z; UTC without an offset): the sun's zenith and azimuth are computed from it at the scene's centre (instead of giving them)",
            optional=True,
        ),
        Number(
            name="sun_zenith",
            label="Sun zenith",
            description="Sun zenith angle (degrees from vertical, below 90; at acquisition, with the DSM; or give the acquisition time)",
            optional=True,
            minimum=0.0,
            maximum=90.0,
            unit="°",
        ),
        Number(
            name="sun_azimuth",
            label="Sun azimuth",
            description="Sun azimuth (degrees clockwise from the grid's up: north on a map grid or with the IGM; on the raw grid, towards row 0, so with lines recorded along the flight and columns to the right of the track it is 180° minus the azimuth from the flight direction; at acquisition, with the DSM)",
            optional=True,
            minimum=0.0,
            maximum=360.0,
            unit="°",
        ),
        Number(
            name="cell_size",
            label="DSM cell size",
            description="Cell size of the DSM in metres, when neither it nor the image has a geotransform",
            optional=True,
            minimum=0.0,
            unit="m",
            advanced=True,
        ),
        Number(
            name="clearance",
            label="Clearance",
            description="Height a caster must rise above the sun line to cast shadow: about 3 × the DSM's height noise (m; 0 = exact)",
            default=1.0,
            minimum=0.0,
            maximum=100.0,
            unit="m",
            advanced=True,
        ),
        Flag(
            name="register",
            label="Register the shadow",
            description="Register the predicted shadow to the image first: move it by the sub-pixel shift (up to 1 px each way) that best matches the image's NIR darkness, where the image's parts agree on it (reported); off = the prediction where the DSM puts it",
            default=True,
            advanced=True,
        ),
    ),
)

SHADOW_MAP = Algorithm(
    name="shadow-map",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "shadow_map.tif"},
    results=(
        Result("valid_pixels", "number", "Valid pixels"),
        Result("shadow_pixels", "number", "Shadow pixels"),
        Result("shadow_share", "number", "Share of the valid pixels in shadow"),
        Result("vnir_dark_dn", "number", "VNIR dark level (DN)"),
        Result("vnir_dark_source", "string", "Where the VNIR dark level comes from"),
        Result("swir_dark_dn", "number", "SWIR dark level (DN)"),
        Result("swir_dark_source", "string", "Where the SWIR dark level comes from"),
        Result("sunlit_nir_signal_dn", "number", "Sunlit NIR signal above dark (DN)"),
        Result("sunlit_swir_signal_dn", "number", "Sunlit SWIR signal above dark (DN)"),
        Result("sunlit_ratio", "number", "Ratio of the sunlit ground"),
        Result("class_scale", "number", "Scale of the class thresholds to the scene"),
        Result("water_blue_nir_limit", "number", "Blue/NIR limit of the water test"),
        Result("offset_along_px", "number", "Offset along track (pixels)"),
        Result("offset_across_px", "number", "Offset across track (pixels)"),
        Result("sample_pixels", "number", "Pixels sampled"),
        Result("sunlit_blue_signal_dn", "number", "Sunlit blue signal above dark (DN)"),
        Result(
            "sunlit_swir_tilt",
            "number",
            "ln of the sunlit ground's 2.0–2.3 µm signal over its 1.55–1.75 µm signal",
        ),
        Result("dark_pixels", "number", "Pixels dark enough for core shadow (without a DSM)"),
        Result(
            "dark_declined_share",
            "number",
            "Share of those dark pixels left sunlit (water, sunlit dark materials)",
        ),
        Result(
            "table2_ratio_bounds_on_scene",
            "string",
            "Table 2's classes as ratio bounds on this scene",
        ),
        Result("class_1_pixels", "number", "Pixels in class 1"),
        Result("class_2_pixels", "number", "Pixels in class 2"),
        Result("class_3_pixels", "number", "Pixels in class 3"),
        Result("class_4_pixels", "number", "Pixels in class 4"),
        Result("no_shadow_pixels", "number", "Pixels without shadow"),
        Result("dsm_surface", "string", "Surface model read as blocks or smooth"),
        Result("dsm_relief_m", "number", "Relief of the surface model (m)"),
        Result("dsm_predicted_shadow_pixels", "number", "Pixels the surface model shades"),
        Result(
            "dsm_predicted_shadow_lit_share",
            "number",
            "Share of the predicted shadow that is spectrally lit",
        ),
        Result(
            "dsm_registration_rows",
            "number",
            "Sub-pixel shift applied to the predicted shadow to register the DSM (rows)",
        ),
        Result(
            "dsm_registration_columns",
            "number",
            "Sub-pixel shift applied to the predicted shadow to register the DSM (columns)",
        ),
        Result(
            "dsm_registration_r0",
            "number",
            "Correlation of the unmoved predicted shadow with the NIR's darkness",
        ),
        Result(
            "dsm_registration_r",
            "number",
            "Correlation of the registered predicted shadow with the NIR's darkness",
        ),
        Result(
            "dsm_registration_t",
            "number",
            "Agreement of the image's tiles on the registration (mean gain over its standard error)",
        ),
        Result("dsm_shift_rows", "number", "Best whole-pixel shift left after registration (rows)"),
        Result(
            "dsm_shift_columns",
            "number",
            "Best whole-pixel shift left after registration (columns)",
        ),
        Result("dsm_iou", "number", "IoU of predicted shadow and dark pixels"),
        Result("dsm_iou_at_shift", "number", "IoU at the best shift"),
        Result(
            "dsm_unseen_share",
            "number",
            "Share of pixels a caster beyond the surface model's edge could shade",
        ),
        Result(
            "dsm_missing_share",
            "number",
            "Share of pixels without a surface-model height (judged by the spectra alone)",
        ),
    ),
    display_name="Boresight shadow map (VNIR + SWIR): mask and shadow-fraction classes",
    group=GROUP,
    short_help="Shadow mask and Table 2 shadow-fraction classes that do not mistake dark "
    "materials for shadow.",
    help=(
        "The shadow product to start with. Reads the VNIR and SWIR images (raw DN or radiance) "
        "and writes the four shadow-fraction classes of Brook & Ben-Dor (2011, Table 2: 80–100, "
        "50–80, 20–50, 10–20 % shadow, coloured as Figures 6–7) and, optionally, a binary "
        "shadow mask (fraction ≥ 50 %).\n\n"
        "Unlike the fixed thresholds of 'Shadow classes (Table 2)', it separates shadow from "
        "dark materials (asphalt, dark roofs, dark soil, water):\n"
        "• each instrument's dark level (DN of zero signal) is taken from you, from the ENVI "
        "header ('dark level'), or estimated from the darkest pixels, so that signal, not "
        "offset, is compared;\n"
        "• a shadow is lit by the blue sky alone, which brings a few per cent of the sun's light "
        "in the SWIR: core shadow is where the SWIR signal is at most a sixth of the scene's "
        "sunlit mode ('core darkness', ln 1/6), which sunlit dark roofs and roads stay above; "
        "pixels bluer than skylight makes a shadow (clear water) are left out;\n"
        "• without a surface model, a dark pixel whose blue (over its dark neighbours) keeps "
        "three quarters of the scene's sunlit blue, with the flat blue/NIR balance of a dark "
        "material (2.5 × the sunlit scene's), is a dark material in the sun (parking lots, "
        "dark roofs, roads), since the sky leaves a shadow a fifth to a half of the sunlit "
        "blue ('sunlit blue limit': ln of the pixel's blue over the sunlit blue from which it "
        "can be in the sun, −0.3 by default; lower flags fewer dark materials and misses more "
        "shadow on blue-bright ground);\n"
        "• the SWIR is first shifted by the boresight offset (measured, or given) so that "
        "shadow edges line up with the VNIR;\n"
        "• around the core, each pixel's shadow fraction is unmixed between its sunlit and "
        "shadowed neighbours, giving the 20–50 and 50–80 % classes along edges.\n\n"
        "What it did is in the log, the result and the output's tags: dark levels and their "
        "source, the sunlit signals, the offset, the sunlit boresight ratio and the ratio "
        "bounds Table 2 would have on this scene, the share of the pixels dark enough for "
        "core shadow it left sunlit (water, dark materials), and warnings.\n\n"
        "With a surface model (DSM on the image's grid) and the sun's zenith and azimuth at "
        "acquisition, the cast shadow the DSM predicts is the prior: the spectra refine its "
        "edges (within a pixel) and fraction, a predicted shadow that is spectrally lit is "
        "dropped, and nothing away from it is shadow (a black roof in the sun is not), except "
        "near the DSM's sunward edge, where a caster beyond it could shade: there a dark pixel "
        "whose way to the edge is dark too is judged by its spectrum, as is a pixel the DSM "
        "has no height for (beyond its extent, its nodata). How far "
        "the DSM and the image disagree (best shift, share of predicted shadow spectrally lit) "
        "is reported. Validated on two independent "
        "scene models (docs/shadow.md): it still misses shadow under strong skylight (hazy "
        "air, high sun zenith) and in narrow courtyards lit by sunlit walls, and, without a "
        "surface model, takes materials dark in the blue too (char) for shadow."
    ),
    params=(
        *DUAL_PARAMS,
        FileIn(
            name="classes",
            label="Class table",
            description="Class table (CSV or JSON) whose shadow-fraction intervals make the classes; empty = Table 2",
            optional=True,
            extensions=("csv", "json"),
            advanced=True,
        ),
        RATIO_BANDS,
        DARK,
        SURFACE,
        DETECTION,
        CALIBRATION,
        BLOCK_ROWS,
        RasterOut(
            name="output",
            label="Shadow classes",
            description="Shadow-fraction classes (byte, colour table)",
        ),
        RasterOut(
            name="mask",
            label="Shadow mask",
            description="Shadow mask (1 shadow, 0 not)",
            optional=True,
        ),
        RasterOut(
            name="fraction",
            label="Shadow fraction",
            description="Estimated shadow fraction (float, 0–1; the input of De-shadow)",
            optional=True,
        ),
    ),
    run=shadow_map_file,
)

ALGORITHMS = (SHADOW_MAP,)
