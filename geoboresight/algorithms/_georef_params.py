"""The parameters the georeferencing specs share: the input, the output grid, the GCPs' CRS,
the report, the IGM written beside a georeferenced raster, and the tie-point matcher's settings
(``auto-georeference`` and ``boresight-calibrate``)."""

from __future__ import annotations

from ..georef.tiepoints import DETECTORS, MAX_SHIFT_PX, MODEL_BLOCK_LINES, MODELS
from ..io.georef import RESAMPLINGS
from ..io.grid import OutputGrid
from ..io.products import FILE_FORMATS
from .spec import (
    Enum,
    FileOut,
    Group,
    Number,
    RasterIn,
    RasterOut,
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

#: The tie-point matcher's settings (:class:`~geoboresight.georef.tiepoints.TieMatching`), the
#: same on every operation that matches an image to a reference.
DETECTOR = Enum(
    name="detector",
    label="Feature detector",
    description="Feature detector (scikit-image)",
    choices=DETECTORS,
    default="sift",
)
WOBBLE_MODEL = Enum(
    name="model",
    label="Wobble model",
    description="The model of the placement's error: affine per block of lines (blended) or thin-plate spline on the inliers",
    choices=MODELS,
    default="blocks",
)
MODEL_BLOCK = Number(
    name="model_block_lines",
    label="Lines per block",
    description="Lines per block of the wobble model and of RANSAC (its resolution along the track)",
    default=MODEL_BLOCK_LINES,
    minimum=8,
    maximum=10000,
    integer=True,
    advanced=True,
    aliases=("block_lines",),
)
MAX_SHIFT = Number(
    name="max_shift_px",
    label="Largest shift",
    description="Largest error of the rough placement (the image's pixels)",
    default=MAX_SHIFT_PX,
    minimum=1.0,
    maximum=500.0,
    unit="px",
    advanced=True,
)
