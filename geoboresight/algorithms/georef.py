"""Specs: put raw-geometry products on a map (IGM/GLT, GCPs, automatic tie points), onto a
reference raster's grid, and simulate a jittered line with its orthophoto."""

from __future__ import annotations

from ..georef.tiepoints import (
    DETECTORS,
    MAX_RMSE_PX,
    MAX_SHIFT_PX,
    MIN_INLIERS,
    MODEL_BLOCK_LINES,
    MODELS,
    TieMatching,
)
from ..georef.transforms import METHODS
from ..io.georef import RESAMPLINGS
from ..io.grid import OutputGrid
from ..io.products import FILE_FORMATS
from ..operations.georef import (
    auto_georeference_file,
    geolocate_file,
    georeference_file,
    reproject_to_file,
    simulate_ortho_file,
)
from ..simulate.ortho import HEADING_DEG, JITTER_DEG, JITTER_LINES, ORTHO_CELL
from ..simulate.presets import SCENES
from ._common import BAND_NM, seed
from .spec import (
    Algorithm,
    Band,
    Enum,
    FileIn,
    FileOut,
    FolderOut,
    Group,
    Number,
    RasterIn,
    RasterOut,
    Result,
    Text,
)

GROUP = "Georeferencing"

INPUT = RasterIn(
    name="input",
    label="Input raster",
    description="Raw-geometry product (ratio, classes, DEM, scores, a cube: any raster)",
    formats=FILE_FORMATS,
)
CRS = Text(
    name="crs",
    label="Output CRS",
    description="Output CRS (EPSG code, PROJ string or WKT; default: that of the coordinates, their UTM zone when in degrees)",
    optional=True,
)
RESOLUTION = Number(
    name="resolution",
    label="Output cell size",
    description="Output cell size in the output CRS's units (0: the product's median pixel spacing)",
    default=0.0,
    minimum=0.0,
    unit="",
)
RESAMPLING = Enum(
    name="resampling",
    label="Resampling",
    description="Resampling: auto (nearest for class rasters, bilinear for continuous data), nearest, bilinear or cubic",
    choices=RESAMPLINGS,
    default="auto",
)
#: The map grid a raw product is warped onto (io.grid.OutputGrid), the operations' ``grid``.
GRID = Group(name="grid", value=OutputGrid, params=(CRS, RESOLUTION, RESAMPLING))
GCP_CRS = Text(
    name="gcp_crs",
    label="GCP CRS",
    description="CRS of the GCPs' map coordinates, when the GCP file names none (or to override it)",
    optional=True,
)
REPORT = FileOut(
    name="report",
    label="Report",
    description="JSON report: the model, RMSE and each point's residual",
    extension="json",
    optional=True,
)

IGM_OUTPUT = RasterOut(
    name="igm_output",
    label="Fitted IGM",
    description="The fitted IGM (x, y of every raw pixel), to geolocate the line's other products",
    optional=True,
)

GEOLOCATE = Algorithm(
    name="geolocate",
    example={
        "input": "ratio.tif",
        "igm": "igm.tif",
        "igm_crs": "EPSG:32636",
        "output": "ratio_map.tif",
    },
    results=(
        Result("masked_nan", "number", "IGM pixels masked: NaN or nodata"),
        Result("masked_non_monotonic", "number", "IGM pixels masked: folded over"),
        Result("width", "number", "Columns of the map grid"),
        Result("height", "number", "Lines of the map grid"),
        Result("valid_pixels", "number", "Pixels inside the footprint"),
        Result("bands", "number", "Bands warped"),
    ),
    display_name="Geolocate a raw product (IGM, GLT)",
    group=GROUP,
    short_help="Put a raw-geometry product on a map grid with the per-pixel coordinates of an IGM, a GLT or GDAL geolocation arrays.",
    help=(
        "Puts any raw-geometry product (band ratio, shadow classes, relative DEM, anomaly "
        "scores, a cube) on a north-up map grid, using the per-pixel coordinates a processing "
        "chain already made:\n"
        "- an IGM (input geometry map: NERC-ARF APL, CaliGeoPRO, gref4hsi), an ENVI or GeoTIFF "
        "file with the easting or longitude (band 1) and northing or latitude (band 2) of "
        "every raw pixel's centre (APL's lon/lat IGMs go on their UTM zone);\n"
        "- a GLT (geometry lookup table: AVIRIS, EMIT), the one-based sample and line of the raw "
        "pixel seen in each map cell;\n"
        "- GDAL geolocation arrays (a dataset with a GEOLOCATION metadata domain), given as "
        "the IGM or carried by the product itself.\n\n"
        "The warp is GDAL's geolocation-array warper (no hand-made resampler): nearest "
        "neighbour for class rasters, bilinear for continuous data, unless chosen. Pixels of "
        "the IGM without coordinates (NaN, nodata) or out of order along the line or the "
        "track are masked (reported) and left as nodata. The output has no gaps inside the "
        "footprint and nodata outside it. An IGM of another size than the product is refused."
    ),
    params=(
        INPUT,
        RasterIn(
            name="igm",
            label="IGM",
            description="IGM (easting, northing per raw pixel) or a dataset with GDAL geolocation arrays",
            optional=True,
        ),
        RasterIn(
            name="glt",
            label="GLT",
            description="GLT: one-based sample and line on a map grid",
            optional=True,
        ),
        Text(
            name="igm_crs",
            label="IGM/GLT CRS",
            description="CRS of the IGM or GLT when its header carries none (e.g. EPSG:32636)",
            optional=True,
        ),
        GRID,
        RasterOut(
            name="output", label="Geolocated", description="The product on a map grid (GeoTIFF)"
        ),
    ),
    run=geolocate_file,
)

GEOREFERENCE = Algorithm(
    name="georeference",
    example={"input": "ratio.tif", "gcps": "gcps.csv", "output": "ratio_map.tif"},
    results=(
        Result("rmse", "number", "RMSE of the GCP residuals (map units)"),
        Result("rmse_px", "number", "RMSE of the GCP residuals (pixels)"),
        Result("width", "number", "Columns of the map grid"),
        Result("height", "number", "Lines of the map grid"),
        Result("valid_pixels", "number", "Pixels inside the footprint"),
        Result("bands", "number", "Bands warped"),
    ),
    display_name="Georeference from GCPs",
    group=GROUP,
    short_help="Georeference a raw product from ground control points: polynomial (order 1–3) or thin-plate spline, with residuals.",
    help=(
        "For lines without navigation data (the paper's AISA-Dual had no GPS/INS): fits an "
        "image-to-map transform to ground control points and warps the product onto a "
        "north-up grid.\n\n"
        "GCPs: a CSV with columns pixel,line,x,y (pixel coordinates as GDAL's: 0,0 is the "
        "top-left corner of the image; a line '# CRS: EPSG:...' gives the CRS) or a QGIS "
        "Georeferencer .points file. Transform: a polynomial of order 1, 2 or 3 (at least 3, 6 "
        "or 10 GCPs, least squares, as gdalwarp -order) or a thin-plate spline (through every "
        "GCP, as gdalwarp -tps; its residuals are cross-validated: each GCP predicted without "
        "it). The JSON report gives each GCP's residual in map units and pixels, and the RMSE. "
        "Too few, collinear or outside GCPs are refused."
    ),
    params=(
        INPUT,
        FileIn(
            name="gcps",
            label="GCP file",
            description="GCP file: CSV (pixel,line,x,y) or QGIS Georeferencer .points",
            extensions=("csv", "points", "txt"),
        ),
        GCP_CRS,
        Enum(
            name="method",
            label="Transform",
            description="Transform: polynomial (of the order below) or thin-plate spline",
            choices=METHODS,
            default="polynomial",
        ),
        Number(
            name="order",
            label="Polynomial order",
            description="Polynomial order (1: affine, needs 3 GCPs; 2: 6 GCPs; 3: 10 GCPs)",
            default=1,
            minimum=1,
            maximum=3,
            integer=True,
        ),
        GRID,
        RasterOut(
            name="output", label="Georeferenced", description="The product on a map grid (GeoTIFF)"
        ),
        REPORT,
        IGM_OUTPUT,
    ),
    run=georeference_file,
)

AUTO = Algorithm(
    name="auto-georeference",
    example={"input": "ratio.tif", "reference": "ortho.tif", "output": "ratio_map.tif"},
    results=(
        Result("matches", "number", "Feature matches"),
        Result("inliers", "number", "RANSAC inliers"),
        Result("rmse_px", "number", "Cross-validated RMSE of the inliers (pixels)"),
        Result("width", "number", "Columns of the map grid"),
        Result("height", "number", "Lines of the map grid"),
        Result("valid_pixels", "number", "Pixels inside the footprint"),
        Result("bands", "number", "Bands warped"),
    ),
    display_name="Georeference on an orthophoto (automatic tie points)",
    group=GROUP,
    short_help="Georeference a raw line on a reference orthophoto by automatic tie points (SIFT/ORB + RANSAC) and a model of the line's wobble.",
    help=(
        "Georeferences a raw-geometry product on a reference orthophoto without navigation "
        "data and without picking GCPs by hand. A rough placement (a few GCPs, or the map "
        "coordinates of the four image corners) puts the orthophoto into the product's raw "
        "geometry; features (scikit-image SIFT or ORB) are matched between one product band "
        "and one orthophoto band (similar wavelengths, e.g. NIR), RANSAC per block of lines "
        "keeps the consistent matches, and a piecewise model follows the pushbroom line's "
        "attitude wobble (an affine model per block of lines, blended from block to block, or "
        "a thin-plate spline on the inliers).\n\n"
        "The report gives the matches, the inliers and each tie point's cross-validated "
        "residual (pixels). The run is refused, writing nothing, when fewer than the minimum "
        "inliers are found or their RMSE exceeds the maximum."
    ),
    params=(
        INPUT,
        RasterIn(
            name="reference",
            label="Reference orthophoto",
            description="Reference orthophoto (with its CRS)",
        ),
        FileIn(
            name="gcps",
            label="GCP file",
            description="Rough placement from a few GCPs (CSV or QGIS .points), or give the corners",
            extensions=("csv", "points", "txt"),
            optional=True,
        ),
        Text(
            name="corners",
            label="Corners",
            description="Rough placement from the corners: x,y of the top-left, top-right, bottom-right, bottom-left image corners (8 numbers)",
            optional=True,
        ),
        GCP_CRS,
        Band(
            name="band",
            label="Band",
            description="Product band to match (e.g. a NIR band)",
            default=1,
            raster="input",
            wavelength="band_nm",
        ),
        BAND_NM,
        Band(
            name="reference_band",
            label="Reference band",
            description="Orthophoto band to match (a similar wavelength)",
            default=1,
            raster="reference",
        ),
        Group(
            name="matching",
            value=TieMatching,
            params=(
                Enum(
                    name="detector",
                    label="Feature detector",
                    description="Feature detector (scikit-image)",
                    choices=DETECTORS,
                    default="sift",
                ),
                Enum(
                    name="model",
                    label="Wobble model",
                    description="Wobble model: affine per block of lines (blended) or thin-plate spline on the inliers",
                    choices=MODELS,
                    default="blocks",
                ),
                Number(
                    name="model_block_lines",
                    label="Lines per block",
                    description="Lines per block of the wobble model and of RANSAC (its resolution along the track)",
                    default=MODEL_BLOCK_LINES,
                    minimum=8,
                    maximum=10000,
                    integer=True,
                    advanced=True,
                    aliases=("block_lines",),
                ),
                Number(
                    name="max_shift_px",
                    label="Largest shift",
                    description="Largest error of the rough placement (product pixels)",
                    default=MAX_SHIFT_PX,
                    minimum=1.0,
                    maximum=500.0,
                    unit="px",
                    advanced=True,
                ),
                Number(
                    name="min_inliers",
                    label="Minimum inliers",
                    description="Fewest tie points accepted",
                    default=MIN_INLIERS,
                    minimum=6,
                    maximum=100000,
                    integer=True,
                    advanced=True,
                ),
                Number(
                    name="max_rmse_px",
                    label="Largest RMSE",
                    description="Largest cross-validated RMSE of the tie points accepted (product pixels)",
                    default=MAX_RMSE_PX,
                    minimum=0.01,
                    maximum=100.0,
                    unit="px",
                ),
                seed("Random seed (of RANSAC: same seed, same result)"),
            ),
        ),
        GRID,
        RasterOut(
            name="output", label="Georeferenced", description="The product on a map grid (GeoTIFF)"
        ),
        REPORT,
        IGM_OUTPUT,
    ),
    run=auto_georeference_file,
)

REPROJECT_TO = Algorithm(
    name="reproject-to",
    example={"input": "ratio_map.tif", "reference": "ortho.tif", "output": "ratio_on_ortho.tif"},
    results=(
        Result("crs", "string", "CRS of the reference grid"),
        Result("width", "number", "Columns of the reference grid"),
        Result("height", "number", "Lines of the reference grid"),
    ),
    display_name="Reproject onto a reference grid",
    group=GROUP,
    short_help="Put a map product onto the exact grid (CRS, transform, size) of a reference raster; vectors to its CRS.",
    help=(
        "Puts a georeferenced product onto the exact pixel grid of a reference raster (an "
        "orthophoto or a scanned topographic map): same CRS, geotransform and size, so that "
        "the two overlay cell for cell (GDAL's warper; the CRS handled by PROJ). Nearest "
        "neighbour for class rasters, bilinear for continuous data, unless chosen. A vector "
        "layer (GeoPackage or GeoJSON, e.g. shadow or anomaly polygons) is reprojected to the "
        "reference's CRS with pyproj. A raw-geometry product is refused: geolocate or "
        "georeference it first."
    ),
    params=(
        RasterIn(
            name="input",
            label="Input layer",
            description="Georeferenced raster, or a .gpkg/.geojson vector layer",
        ),
        RasterIn(
            name="reference",
            label="Reference raster",
            description="Raster whose grid (or CRS, for a vector) the output takes",
        ),
        RESAMPLING,
        RasterOut(
            name="output",
            label="Reprojected",
            description="The product on the reference's grid",
            also=(".gpkg", ".geojson", ".json"),
        ),
    ),
    run=reproject_to_file,
)

SIMULATE_ORTHO = Algorithm(
    name="simulate-ortho",
    example={"output": "line", "lines": "16"},
    results=(Result("files", "string", "Files written (JSON)"),),
    display_name="Simulate a jittered line with its orthophoto",
    group="Simulation",
    short_help="Simulate a raw line with roll/pitch/yaw jitter, its true IGM and an orthophoto of the scene.",
    help=(
        "Simulates, over one of the simulator's scenes, a raw pushbroom line (one NIR band, "
        "286 pixels, 1.5 m) whose aircraft rolls, pitches and yaws along the track (smooth "
        "random series), its true IGM (the map coordinates of every raw pixel: the ray's hit "
        "on the surface model), and a north-up orthophoto (red, green, blue, NIR) of the same "
        "scene in UTM. It validates geolocate and auto-georeference: their result can be "
        "compared with the true IGM. See docs/georef.md."
    ),
    params=(
        Enum(
            name="preset",
            label="Scene type",
            description="Scene type",
            choices=SCENES,
            default="urban",
        ),
        Number(
            name="lines",
            label="Lines",
            description="Lines of the raw band",
            default=128,
            minimum=8,
            maximum=20000,
            integer=True,
        ),
        Number(
            name="jitter_deg",
            label="Jitter",
            description="Standard deviation of roll, pitch and yaw along the track (degrees)",
            default=JITTER_DEG,
            minimum=0.0,
            maximum=2.0,
            unit="°",
        ),
        Number(
            name="jitter_lines",
            label="Jitter length",
            description="Correlation length of the jitter (lines)",
            default=JITTER_LINES,
            minimum=1.0,
            maximum=10000.0,
            advanced=True,
        ),
        Number(
            name="heading_deg",
            label="Heading",
            description="Flight heading, clockwise from north (degrees)",
            default=HEADING_DEG,
            minimum=0.0,
            maximum=360.0,
            unit="°",
        ),
        Number(
            name="ortho_cell",
            label="Orthophoto cell size",
            description="Orthophoto cell size (m)",
            default=ORTHO_CELL,
            minimum=0.2,
            maximum=20.0,
            unit="m",
        ),
        seed("Random seed: the same seed gives the same scene", advanced=False),
        FolderOut(name="output", label="Output folder", description="Folder to create"),
    ),
    run=simulate_ortho_file,
)

ALGORITHMS = (GEOLOCATE, GEOREFERENCE, AUTO, REPROJECT_TO, SIMULATE_ORTHO)
