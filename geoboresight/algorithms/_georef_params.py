"""The parameters the georeferencing specs share: the input, the output grid, the GCPs' CRS,
the report and the IGM written beside a georeferenced raster."""

from __future__ import annotations

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
