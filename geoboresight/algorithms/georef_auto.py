"""Spec: georeference a raw-geometry raster on a reference image by automatic tie points."""

from __future__ import annotations

from ..georef.tiepoints import (
    MAX_RMSE_PX,
    MIN_INLIERS,
    TieMatching,
)
from ..operations.georef import (
    auto_georeference_file,
)
from ._common import BAND_NM, seed
from ._georef_params import (
    DETECTOR,
    GCP_CRS,
    GRID,
    GROUP,
    IGM_OUTPUT,
    INPUT,
    MAX_SHIFT,
    MODEL_BLOCK,
    REPORT,
    WOBBLE_MODEL,
)
from .spec import (
    Algorithm,
    Band,
    FileIn,
    Group,
    Number,
    RasterIn,
    RasterOut,
    Result,
    Text,
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
                DETECTOR,
                WOBBLE_MODEL,
                MODEL_BLOCK,
                MAX_SHIFT,
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

ALGORITHMS = (AUTO,)
