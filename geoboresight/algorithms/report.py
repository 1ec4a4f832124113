"""Spec: the scene report (one self-contained HTML page running every application)."""

from __future__ import annotations

from ..dem.height import FlightGeometry
from ..report.scene import report_file
from ._common import BAND_PARAMS, DUAL_PARAMS
from ._dem_params import CLOUD, FLYING_HEIGHT, HEIGHT_FACTOR, IFOV, SQUINT
from .spec import Algorithm, FileOut, Flag, FolderOut, Group, RasterIn

REPORT = Algorithm(
    name="report",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "report.html"},
    display_name="Scene report (HTML)",
    group="Report",
    short_help="One self-contained HTML page: ratio statistics, shadow, relative DEM, anomalies and ROC for a scene.",
    help=(
        "Runs the paper's applications on one scene and writes a single HTML file with every "
        "figure embedded (it opens offline, in any browser, and can be mailed as is): the "
        "boresight ratio and its Table 1 statistics and histogram; the shadow classes "
        "(Table 2), the shadow cluster scatter (Figure 4) and, given a ground-truth shadow "
        "fraction, the linear model (Figure 5); the relative DEM and its 3-D view (Figure 9) "
        "when the sensor geometry is given; RX, SVDD and the boresight indicator as anomaly "
        "scores with ROC curves (Figure 12) given a target truth raster.\n\n"
        "The page opens with the scene in a reader's words (the files, the ratio's two bands "
        "in nm, the image's size and geometry, the flight geometry); each section lists the "
        "files and parameters its operations used. A section that cannot run "
        "(for example the DEM without the height factor or the flight geometry) says why "
        "instead of stopping the report.\n\n"
        "The intermediate products (ratio, classes, DEM, scores) are deleted unless a products "
        "folder is given."
    ),
    params=(
        *DUAL_PARAMS,
        *BAND_PARAMS,
        RasterIn(
            name="shadow_truth",
            label="Shadow fraction truth",
            description="Ground-truth shadow fraction (0–1) on the VNIR grid, for the Figure 5 fit",
            optional=True,
        ),
        RasterIn(
            name="target_truth",
            label="Target truth",
            description="Target mask or abundance on the VNIR grid, for the ROC curves",
            optional=True,
        ),
        CLOUD,
        # The relative DEM's flight geometry, as 'relative-dem' takes it (the parallax's axis
        # and direction at their defaults).
        Group(
            name="geometry",
            value=FlightGeometry,
            params=(HEIGHT_FACTOR, SQUINT, FLYING_HEIGHT, IFOV),
        ),
        Flag(
            name="svdd",
            label="Include SVDD",
            description="Include the SVDD detector (slower) among the anomaly scores",
            default=True,
        ),
        FileOut(
            name="output",
            label="Report",
            description="Report (self-contained HTML)",
            extension="html",
        ),
        FolderOut(
            name="products",
            label="Products folder",
            description="Folder to keep the intermediate rasters and figures in (created; empty: not kept)",
            optional=True,
        ),
    ),
    run=report_file,
)

ALGORITHMS = (REPORT,)
