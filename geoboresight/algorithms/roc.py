"""Specs: ROC curves of anomaly scores against a truth raster, and anomaly polygons (paper
§3.3, Figure 12).

Declarations only; the work is done by :mod:`geoboresight.operations.anomaly`.
"""

from __future__ import annotations

from ..anomaly.polygons import GEOMETRIES
from ..anomaly.roc import PFA, TITLE
from ..operations.anomaly import anomaly_polygons_file, roc_file
from .spec import Algorithm, Enum, FileOut, MultiRaster, Number, RasterIn, Result, Text, VectorOut

ROC = Algorithm(
    name="roc",
    example={"scores": "rx.tif", "truth": "truth_target_abundance.tif", "output": "roc.png"},
    display_name="ROC curves of anomaly detectors",
    group="Anomaly",
    short_help="Probability of detection vs false alarm, and AUC, for several score maps against a truth raster.",
    help=(
        "ROC curves as in the paper's Figure 12: for each score map (RX, SVDD, boresight indicator, "
        "…), every threshold gives a probability of detection (share of target pixels above it) and "
        "of false alarm (share of background pixels above it). The area under the curve (AUC) and "
        "Pd at a chosen Pfa summarise each detector.\n\n"
        "Truth: a 0/1 mask, or an abundance raster (e.g. the simulator's truth_target_abundance.tif) "
        "with a threshold (default: any abundance > 0 is a target). guard_px leaves pixels next to "
        "targets out of the background, since a sub-pixel target spills into its neighbours.\n\n"
        "Outputs: one PNG figure (linear and logarithmic Pfa) and optionally a CSV of the curves."
    ),
    params=(
        MultiRaster(
            name="scores",
            label="Score rasters",
            description="Score rasters, higher = more anomalous (comma-separated paths)",
        ),
        Text(
            name="names",
            label="Detector names",
            description="Detector names for the legend, comma-separated (default: file names)",
            default="",
            optional=True,
        ),
        RasterIn(
            name="truth",
            label="Truth raster",
            description="Truth: 0/1 target mask or abundance raster, on the same grid",
        ),
        Number(
            name="truth_threshold",
            label="Truth threshold",
            description="Abundance at or above which a pixel is a target (empty: > 0)",
            optional=True,
            minimum=0.0,
        ),
        Number(
            name="guard_px",
            label="Guard distance",
            description="Leave pixels within this distance of a target out of the background",
            default=0,
            minimum=0,
            maximum=50,
            integer=True,
        ),
        Number(
            name="pfa",
            label="False-alarm rate",
            description="False-alarm rate at which Pd is reported",
            default=PFA,
            minimum=1e-9,
            maximum=1.0,
        ),
        Text(
            name="title",
            label="Title",
            description="Figure title",
            default=TITLE,
            optional=True,
        ),
        FileOut(name="output", label="ROC figure", description="ROC figure (PNG)", extension="png"),
        FileOut(
            name="csv",
            label="ROC table",
            description="ROC curves (CSV: detector, pfa, pd, threshold)",
            extension="csv",
            optional=True,
        ),
    ),
    run=roc_file,
)


POLYGONS = Algorithm(
    name="anomaly-polygons",
    example={"score": "rx.tif", "threshold": "5", "output": "anomalies.gpkg"},
    results=(Result("features", "number", "Features written"),),
    display_name="Anomaly score to polygons",
    group="Anomaly",
    short_help="Groups of pixels above a score threshold as GeoPackage polygons or points with score attributes.",
    help=(
        "Turns any anomaly score map (RX, SVDD, boresight indicator) into a vector layer: pixels "
        "with a score at or above the threshold are grouped (8-connected); each group becomes a "
        "polygon (its pixel outline) or a point (its highest-scoring pixel), with the number of "
        "pixels, the maximum and mean score and the peak's row and column.\n\n"
        "Coordinates follow the raster's CRS and geotransform; a raster in raw sensor geometry "
        "gives pixel coordinates (column, row) with an undefined CRS.\n\n"
        "Output: a GeoPackage layer 'anomalies'."
    ),
    params=(
        RasterIn(name="score", label="Score raster", description="Anomaly score raster"),
        Number(
            name="threshold",
            label="Threshold",
            description="Score at or above which a pixel is an anomaly",
        ),
        Enum(
            name="geometry",
            label="Geometry",
            description="Polygons (pixel outlines) or points (peak pixel centres)",
            choices=GEOMETRIES,
            default="polygon",
        ),
        Number(
            name="min_pixels",
            label="Minimum pixels",
            description="Drop groups smaller than this many pixels",
            default=1,
            minimum=1,
            integer=True,
        ),
        VectorOut(
            name="output",
            label="Anomalies",
            description="Anomaly layer (GeoPackage)",
            extension="gpkg",
        ),
    ),
    run=anomaly_polygons_file,
)

ALGORITHMS = (ROC, POLYGONS)
