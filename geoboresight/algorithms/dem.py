"""Specs: disparity map, relative DEM and 3-D view (paper §3.2, Figure 9); the parameters every
Relative DEM operation shares are in :mod:`._dem_params`, the boresight offset and
co-registration in :mod:`.offset`."""

from __future__ import annotations

from ..dem.disparity import (
    MIN_PEAK,
    MIN_SHARPNESS,
    REFINE,
    SEARCH_ACROSS,
    SEARCH_ALONG,
    WINDOW,
    Matching,
)
from ..dem.kriging import MODELS, N_CLOSEST_POINTS, VARIOGRAM
from ..dem.relative import POINT_SPACING, Kriging
from ..dem.view3d import AZIMUTH, BLUE_NM, ELEVATION, EXAGGERATION, GREEN_NM, RED_NM
from ..operations.dem import disparity_file, relative_dem_file, view_3d_file
from ._common import DUAL_PARAMS, TOLERANCE
from ._dem_params import (
    CLOUD,
    DENSE_MATCH_BANDS,
    FLIGHT_GEOMETRY,
    GROUP,
)
from .spec import (
    Algorithm,
    Enum,
    FileOut,
    Flag,
    Group,
    Number,
    RasterIn,
    RasterOut,
    Result,
    Wavelength,
)

MATCHING = Group(
    name="matching",
    value=Matching,
    params=(
        Number(
            name="window",
            label="Matching window",
            description="Matching window (odd number of pixels): larger matches more pixels but blurs relief",
            default=WINDOW,
            minimum=3,
            maximum=101,
            integer=True,
        ),
        Number(
            name="search_along",
            label="Search along-track",
            description="Search ± this many pixels along-track (paper: 3)",
            default=SEARCH_ALONG,
            minimum=1,
            maximum=50,
            integer=True,
        ),
        Number(
            name="search_across",
            label="Search across-track",
            description="Search ± this many pixels across-track (paper: 1)",
            default=SEARCH_ACROSS,
            minimum=0,
            maximum=50,
            integer=True,
        ),
        Number(
            name="min_peak",
            label="Minimum peak",
            description="Reliable only where the correlation peak is at least this (0–1)",
            default=MIN_PEAK,
            minimum=-1.0,
            maximum=1.0,
            advanced=True,
        ),
        Number(
            name="min_sharpness",
            label="Minimum sharpness",
            description="Reliable only where the correlation peak is at least this sharp (curvature)",
            default=MIN_SHARPNESS,
            minimum=0.0,
            advanced=True,
        ),
        Number(
            name="refine",
            label="Refinement passes",
            description="Sub-pixel refinement passes (warp and re-match: removes peak-locking bias)",
            default=REFINE,
            minimum=0,
            maximum=5,
            integer=True,
            advanced=True,
        ),
    ),
)


DISPARITY = Algorithm(
    name="disparity",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "disparity.tif"},
    results=(
        Result("reliable_pixels", "number", "Pixels with a reliable disparity"),
        Result("offset_along_px", "number", "Mean offset along track (pixels)"),
        Result("offset_across_px", "number", "Mean offset across track (pixels)"),
    ),
    display_name="Disparity map (VNIR/SWIR matching)",
    group=GROUP,
    short_help="Dense sub-pixel VNIR/SWIR disparity with per-pixel reliability.",
    help=(
        "Matches the VNIR image with the SWIR image pixel by pixel (by default the mean of the "
        "bands centred in 900–970 nm against that of 980–1,100 nm: the single 1,010 nm band is "
        "too weak to match well): normalised cross-correlation in a window, searching ± 3 pixels along-track and ± 1 "
        "across-track (the paper's matching accuracy) around the global boresight offset, "
        "refined to sub-pixel by parabola fits.\n\n"
        "Output: a 5-band float32 GeoTIFF: disparity along-track and across-track (px, SWIR "
        "minus VNIR position), correlation peak (0–1), peak sharpness, and reliable (1/0). Clouds "
        "(optional mask) and nodata are masked (-9999)."
    ),
    params=(
        *DUAL_PARAMS,
        DENSE_MATCH_BANDS,
        CLOUD,
        MATCHING,
        RasterOut(
            name="output",
            label="Disparity",
            description="Disparity and reliability bands (GeoTIFF)",
        ),
    ),
    run=disparity_file,
)


DEM = Algorithm(
    name="relative-dem",
    example={
        "vnir": "vnir.hdr",
        "swir": "swir.hdr",
        "squint_deg": "3",
        "flying_height": "1500",
        "ifov_mrad": "1",
        "output": "dem.tif",
    },
    results=(
        Result("sigma_d_px", "number", "Disparity noise (pixels)"),
        Result("sigma_h_m", "number", "Height noise (m)"),
        Result("relief_to_noise", "number", "Relief over the noise of a block's mean height"),
        Result("meaningful", "boolean", "Whether the relief stands above the noise"),
        Result("message", "string", "What the product can be used for"),
        Result("height_factor_px_per_m", "number", "Height factor (pixels of disparity per metre)"),
        Result("offset_along_px", "number", "Mean offset along track (pixels)"),
        Result("offset_across_px", "number", "Mean offset across track (pixels)"),
        Result("reliable_pixels", "number", "Pixels with a reliable disparity"),
        Result("control_points", "number", "Control points kriged"),
        Result("variogram", "string", "Fitted variogram (JSON)"),
        Result("cross_validation", "string", "Cross-validation of the kriging (JSON)"),
        Result("dem_range_m", "string", "Range of the relative DEM (m, JSON)"),
        Result("vnir_band", "number", "VNIR band used (1-based)"),
        Result("vnir_wavelength_nm", "number", "Centre of the VNIR band used (nm)"),
        Result("swir_band", "number", "SWIR band used (1-based)"),
        Result("swir_wavelength_nm", "number", "Centre of the SWIR band used (nm)"),
        Result("vnir_bands_averaged", "string", "VNIR bands averaged (JSON)"),
        Result("swir_bands_averaged", "string", "SWIR bands averaged (JSON)"),
        Result(
            "relief_std_m", "number", "Relief: std of the block mean heights above their noise (m)"
        ),
        Result("relief_block_px", "string", "Blocks the relief test compares (px, JSON)"),
        Result("relief_noise_m", "number", "Noise of a block's mean height, sigma_h / 2 (m)"),
        Result("relief_chi2", "number", "Chi-square of the relief against the noise"),
        Result("relief_dof", "number", "Degrees of freedom of the relief test"),
        Result("relief_p_value", "number", "p-value of the relief test"),
    ),
    display_name="Relative DEM (kriging)",
    group=GROUP,
    short_help="Relative heights from VNIR/SWIR parallax, kriged onto the grid; reports σ_h.",
    help=(
        "Builds the relative DEM of Brook & Ben-Dor (2011, 3.2). The VNIR and SWIR images are "
        "matched pixel by pixel (as 'Disparity map'); relief shifts a feature by h·tan θ / GSD "
        "pixels, θ being the squint between the two lines of sight, so the disparity divided by "
        "the height-to-disparity factor k = tan θ / GSD (px per metre) is a height. Give k, or "
        "the flying height, IFOV and squint angle to derive it. The lowest reliable region is "
        "0 m; every other height is relative to it (not above sea level).\n\n"
        "Reliable heights are thinned to control points (the median of each cell of 'point "
        "spacing' pixels) and interpolated onto every pixel by ordinary kriging (PyKrige) with a "
        "fitted variogram and a local neighbourhood, so a full flight line fits in memory. "
        "Clouds (optional mask) and nodata are masked.\n\n"
        "Precision: the matching precision σ_d is estimated from the data and the height "
        "precision σ_h = σ_d·GSD/tan θ of one matching window is reported (log, tags, report). "
        "The DEM resolves blocks of 2 × 2 matching windows, whose mean heights carry the noise "
        "σ_h/2: the relief is the standard deviation of those block means above their noise, "
        "and a χ² test checks the hypothesis 'the relief is no larger than that noise' "
        "(statistic, degrees of freedom, p-value). "
        "With the small squint of a real instrument σ_h is usually larger than the relief: when "
        "the test does not reject that hypothesis (p ≥ 0.05) the tool stops and says that no "
        "meaningful DEM can be made, rather than output noise that looks like terrain ('force' "
        "writes it anyway, tagged as not meaningful).\n\n"
        "Outputs: the DEM (float32 GeoTIFF, metres, nodata -9999, same georeference as the "
        "input: in raw sensor geometry it stays raw; georeferenced, it opens in QGIS's 3D view), "
        "optionally the kriging variance, the disparity with its reliability bands and a JSON "
        "report with the cross-validation of the kriging."
    ),
    params=(
        *DUAL_PARAMS,
        DENSE_MATCH_BANDS,
        CLOUD,
        FLIGHT_GEOMETRY,
        MATCHING,
        Group(
            name="kriging",
            value=Kriging,
            params=(
                Number(
                    name="point_spacing",
                    label="Control point spacing",
                    description="One control point per cell of this many pixels (median)",
                    default=POINT_SPACING,
                    minimum=1,
                    maximum=100,
                    integer=True,
                ),
                Enum(
                    name="variogram",
                    label="Variogram model",
                    description="Variogram model fitted for kriging",
                    choices=MODELS,
                    default=VARIOGRAM,
                ),
                Number(
                    name="n_closest_points",
                    label="Kriging neighbours",
                    description="Control points in each local kriging neighbourhood",
                    default=N_CLOSEST_POINTS,
                    minimum=3,
                    maximum=500,
                    integer=True,
                    advanced=True,
                ),
            ),
        ),
        Flag(
            name="force",
            label="Force output",
            description="Write the DEM even where σ_h exceeds the relief (tagged as not meaningful)",
        ),
        RasterOut(name="output", label="Relative DEM", description="Relative DEM (GeoTIFF, m)"),
        RasterOut(
            name="variance",
            label="Kriging variance",
            description="Kriging variance (GeoTIFF, m²)",
            optional=True,
        ),
        RasterOut(
            name="disparity",
            label="Disparity",
            description="Disparity and reliability bands (GeoTIFF)",
            optional=True,
        ),
        FileOut(
            name="report",
            label="Report",
            description="Report: σ_d, σ_h, offset, variogram, cross-validation (JSON)",
            extension="json",
            optional=True,
        ),
    ),
    run=relative_dem_file,
)


VIEW = Algorithm(
    name="view-3d",
    example={"dem": "dem.tif", "vnir": "vnir.hdr", "swir": "swir.hdr", "output": "dem_3d.png"},
    display_name="3-D view (image draped on the DEM)",
    group=GROUP,
    short_help="PNG of an RGB of the image draped on the relative DEM with vertical exaggeration (Figure 9E).",
    help=(
        "Renders the image (an RGB of three VNIR wavelengths, 2–98 % stretch) draped on the "
        "relative DEM, with vertical exaggeration, as Figure 9E of the paper. Pixels without a "
        "height (clouds, nodata) are drawn black. Axes are in metres when the DEM is "
        "georeferenced or records its pixel size, in pixels otherwise.\n\n"
        "For an interactive view, open the DEM GeoTIFF in QGIS's 3D map view with the image "
        "as texture (georeferenced data only)."
    ),
    params=(
        RasterIn(
            name="dem", label="Relative DEM", description="Relative DEM (from 'Relative DEM')"
        ),
        *DUAL_PARAMS,
        Wavelength(
            name="red_nm",
            label="Red wavelength",
            description="Red channel wavelength (nm)",
            default=RED_NM,
        ),
        Wavelength(
            name="green_nm",
            label="Green wavelength",
            description="Green channel wavelength (nm)",
            default=GREEN_NM,
        ),
        Wavelength(
            name="blue_nm",
            label="Blue wavelength",
            description="Blue channel wavelength (nm)",
            default=BLUE_NM,
        ),
        TOLERANCE,
        Number(
            name="exaggeration",
            label="Vertical exaggeration",
            description="Vertical exaggeration",
            default=EXAGGERATION,
            minimum=0.01,
            maximum=1000.0,
        ),
        Number(
            name="elevation",
            label="Viewing elevation",
            description="Viewing elevation (degrees)",
            default=ELEVATION,
            minimum=0.0,
            maximum=90.0,
            advanced=True,
        ),
        Number(
            name="azimuth",
            label="Viewing azimuth",
            description="Viewing azimuth (degrees)",
            default=AZIMUTH,
            minimum=-360.0,
            maximum=360.0,
            advanced=True,
        ),
        FileOut(name="output", label="3-D view", description="3-D view (PNG)", extension="png"),
    ),
    run=view_3d_file,
)

ALGORITHMS = (DISPARITY, DEM, VIEW)
