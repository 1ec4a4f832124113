"""Specs: put raw-geometry products on a map (IGM/GLT, GCPs), onto a reference raster's grid,
and simulate a jittered line with its orthophoto (automatic tie points: georef_auto.py)."""

from __future__ import annotations

from ..georef.transforms import METHODS
from ..operations.georef import (
    geolocate_file,
    georeference_file,
    reproject_to_file,
    simulate_ortho_file,
)
from ..simulate.ortho import HEADING_DEG, JITTER_DEG, JITTER_LINES, ORTHO_CELL
from ..simulate.presets import SCENES
from ._common import seed
from ._georef_params import (
    GCP_CRS,
    GRID,
    GROUP,
    IGM_OUTPUT,
    INPUT,
    REPORT,
    RESAMPLING,
)
from .spec import (
    Algorithm,
    Enum,
    FileIn,
    FolderOut,
    Number,
    RasterIn,
    RasterOut,
    Result,
    Text,
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

ALGORITHMS = (GEOLOCATE, GEOREFERENCE, REPROJECT_TO, SIMULATE_ORTHO)
