"""Specs of the shadow application (paper §3.1) on the boresight ratio: classes, cluster,
fraction model (fit and apply), polygons. Declarations only: each ``run`` is a file-level
operation of :mod:`geoboresight.operations.shadow`. The ground truth from a surface model and the
dark-pixel baseline are in :mod:`geoboresight.algorithms.shadow_truth`."""

from __future__ import annotations

from ..io.products import FILE_FORMATS
from ..io.windows import Sample
from ..operations.shadow import (
    NirBand,
    shadow_classes_file,
    shadow_cluster_file,
    shadow_fraction_apply_file,
    shadow_fraction_fit_file,
    shadow_polygons_file,
)
from ..shadow.classes import MASK_FRACTION
from ..shadow.cluster import NIR_NM, PROBABILITY, SAMPLE_SIZE
from ..shadow.fraction import PAPER_INTERCEPT, PAPER_SLOPE
from ..shadow.polygons import MIN_PIXELS
from ._common import BAND_NM, BLOCK_ROWS, TOLERANCE, sample_size, seed
from .spec import (
    Algorithm,
    Band,
    FileIn,
    FileOut,
    Flag,
    Group,
    Number,
    RasterIn,
    RasterOut,
    Result,
    Text,
    VectorOut,
    Wavelength,
)

GROUP = "Shadow"

RATIO = RasterIn(
    name="ratio",
    label="Boresight ratio",
    description="Boresight ratio raster (output of 'ratio')",
    formats=FILE_FORMATS,
)
RATIO_BAND = (
    Band(
        name="band",
        label="Band number",
        description="Band of the ratio raster",
        default=1,
        raster="ratio",
        wavelength="band_nm",
    ),
    BAND_NM,
)


CLASSES = Algorithm(
    name="shadow-classes",
    example={"ratio": "ratio.tif", "output": "shadow_classes.tif"},
    results=(
        Result("valid_pixels", "number", "Valid pixels"),
        Result("class_1_pixels", "number", "Pixels in class 1"),
        Result("class_2_pixels", "number", "Pixels in class 2"),
        Result("class_3_pixels", "number", "Pixels in class 3"),
        Result("class_4_pixels", "number", "Pixels in class 4"),
        Result("no_shadow_pixels", "number", "Pixels without shadow"),
        Result("ratio_mode", "number", "Most common ratio of the scene (its sunlit ground)"),
    ),
    display_name="Shadow classes (Table 2)",
    group=GROUP,
    short_help="Classify the boresight ratio into shadow-fraction classes and a shadow mask.",
    help=(
        "Maps each boresight ratio value to a shadow-fraction class, by default Table 2 of "
        "Brook & Ben-Dor (2011): class 1 ratio 3.4–4 → 80–100 % shadow (maroon), class 2 "
        "2.5–3.4 → 50–80 % (magenta), class 3 2.1–2.5 → 20–50 % (cyan), class 4 1.9–2.1 → "
        "10–20 % (yellow); 0 = no shadow, 255 = nodata.\n\n"
        "The output is a byte raster with an embedded colour table and class names, so it opens "
        "styled in QGIS. The optional mask is 1 where the class means at least 'mask fraction' "
        "shadow.\n\n"
        "Table 2's thresholds were found on AISA-Dual DN; for other data give your own table "
        "(CSV with columns class,min,max,fraction_min,fraction_max,name,colour; intervals "
        "min ≤ ratio < max, listed in ratio order, not overlapping) or use 'Shadow cluster'."
    ),
    params=(
        RATIO,
        *RATIO_BAND,
        FileIn(
            name="classes",
            label="Class table",
            description="Class table (CSV or JSON: class,min,max,fraction_min,fraction_max,name,colour); empty = Table 2",
            optional=True,
            extensions=("csv", "json"),
        ),
        Number(
            name="mask_fraction",
            label="Mask fraction",
            description="The shadow mask holds classes whose shadow fraction starts at or above this (0–1)",
            default=MASK_FRACTION,
            minimum=0.0,
            maximum=1.0,
        ),
        BLOCK_ROWS,
        RasterOut(
            name="output",
            label="Shadow classes",
            description="Shadow class raster (byte, colour table)",
        ),
        RasterOut(
            name="mask",
            label="Shadow mask",
            description="Binary shadow mask (1 shadow, 0 not)",
            optional=True,
        ),
    ),
    run=shadow_classes_file,
)

CLUSTER = Algorithm(
    name="shadow-cluster",
    example={"ratio": "ratio.tif", "vnir": "vnir.hdr", "output": "shadow_cluster.tif"},
    results=(
        Result("components", "number", "Mixture components"),
        Result("isolation", "number", "Isolation of the shadow cluster"),
        Result("shadow_pixels", "number", "Shadow pixels"),
        Result("nir_band", "number", "NIR band used (1-based)"),
    ),
    display_name="Shadow cluster (scene-adaptive)",
    group=GROUP,
    short_help="Find the isolated shadow cluster in the (boresight ratio, 941 nm) scatter (Figure 4).",
    help=(
        "Shadowed pixels form an isolated cluster in the scatter of the boresight ratio against "
        "the VNIR band at 941 nm: high ratio, dark near-infrared (Brook & Ben-Dor 2011, "
        "Figure 4). This tool finds it without fixed thresholds: a Gaussian mixture "
        "(scikit-learn GaussianMixture, full covariances, 2–5 components chosen by the "
        "Bayesian information criterion) is fitted to the logarithms of both values on a random "
        "sample of pixels, the component furthest towards high ratio and low 941 nm is the "
        "shadow, and each pixel is shadow when its posterior probability reaches the threshold.\n\n"
        "Outputs: a byte mask (1 shadow, 0 not, 255 nodata), optionally the probability and a PNG "
        "scatter with the cluster outlined."
    ),
    params=(
        RATIO,
        *RATIO_BAND,
        RasterIn(
            name="vnir",
            label="VNIR image",
            description="VNIR image (or a merged cube) on the ratio's grid, with wavelengths",
        ),
        Group(
            name="nir",
            value=NirBand,
            params=(
                Wavelength(
                    name="nir_nm",
                    label="NIR wavelength",
                    description="Wavelength of the near-infrared axis (nm; paper: 941)",
                    default=NIR_NM,
                ),
                TOLERANCE,
                Text(
                    name="vnir_wavelengths",
                    label="VNIR band centres",
                    description="Band centres of the VNIR file in nm, comma-separated (only if the file has none)",
                    optional=True,
                    advanced=True,
                    aliases=("wavelengths",),
                ),
            ),
        ),
        Number(
            name="n_components",
            label="Mixture components",
            description="Mixture components (empty = chosen by BIC among 2–5)",
            optional=True,
            minimum=2,
            maximum=10,
            integer=True,
            advanced=True,
        ),
        Number(
            name="probability",
            label="Probability threshold",
            description="Posterior probability of the shadow component needed to call a pixel shadow",
            default=PROBABILITY,
            minimum=0.0,
            maximum=1.0,
        ),
        Group(
            name="sample",
            value=Sample,
            params=(
                sample_size(
                    "Pixels sampled at random (to fit the mixture)", SAMPLE_SIZE, 500, 5_000_000
                ),
                seed(),
            ),
        ),
        BLOCK_ROWS,
        RasterOut(
            name="output", label="Shadow mask", description="Shadow mask (byte: 1 shadow, 0 not)"
        ),
        RasterOut(
            name="probability_output",
            label="Shadow probability",
            description="Shadow probability (0–1)",
            optional=True,
        ),
        FileOut(
            name="plot",
            label="Scatter plot",
            description="Scatter plot with the shadow cluster outlined (PNG)",
            extension="png",
            optional=True,
        ),
    ),
    run=shadow_cluster_file,
)

FRACTION_FIT = Algorithm(
    name="shadow-fraction-fit",
    example={
        "ratio": "ratio.tif",
        "truth": "truth_shadow_fraction.tif",
        "report": "fraction_fit.json",
    },
    results=(
        Result("slope", "number", "Slope of the fraction model"),
        Result("intercept", "number", "Intercept of the fraction model"),
        Result("r2", "number", "Coefficient of determination R²"),
        Result("n", "number", "Pixels used in the fit"),
    ),
    display_name="Shadow fraction model: fit (Figure 5B)",
    group=GROUP,
    short_help="Fit ratio = a · fraction + b over detected shadow against a ground-truth shadow fraction.",
    help=(
        "Fits the straight line of Figure 5(B) of Brook & Ben-Dor (2011) between the boresight "
        "ratio and a ground-truth shadow fraction (e.g. from 'Sun shadow'), over the detected "
        "shadow pixels (the mask from 'Shadow classes' or 'Shadow cluster'; without a mask, over "
        "pixels whose ground truth is above 0). Reports slope a, intercept b and R² (paper: "
        "a = −0.74, b = 1.31, R² = 0.913); optionally a JSON report for 'Shadow fraction model: "
        "apply' and a PNG of the regression. The fit is exact least squares over every pixel, "
        "streamed block by block."
    ),
    params=(
        RATIO,
        *RATIO_BAND,
        RasterIn(
            name="truth",
            label="Shadow fraction truth",
            description="Ground-truth shadow fraction (0–1) on the ratio's grid",
        ),
        RasterIn(
            name="mask",
            label="Shadow mask",
            description="Detected shadow mask (1 = shadow) on the same grid",
            optional=True,
        ),
        BLOCK_ROWS,
        FileOut(
            name="report",
            label="Model",
            description="Fitted model (JSON)",
            extension="json",
            optional=True,
        ),
        FileOut(
            name="plot",
            label="Regression plot",
            description="Regression plot (PNG)",
            extension="png",
            optional=True,
        ),
    ),
    run=shadow_fraction_fit_file,
)

FRACTION_APPLY = Algorithm(
    name="shadow-fraction-apply",
    example={"ratio": "ratio.tif", "output": "shadow_fraction.tif"},
    results=(
        Result("slope", "number", "Slope of the fraction model"),
        Result("intercept", "number", "Intercept of the fraction model"),
        Result("valid_pixels", "number", "Valid pixels"),
        Result(
            "outside_line_pixels", "number", "Pixels with a ratio outside the fitted line's range"
        ),
    ),
    display_name="Shadow fraction model: apply",
    group=GROUP,
    short_help="Turn the boresight ratio into a continuous shadow fraction with a fitted line.",
    help=(
        "Inverts ratio = a · fraction + b: fraction = (ratio − b) / a, limited to 0–1 unless "
        "'no clip' is set. Give a and b (default: the paper's Figure 5B, a = −0.74, b = 1.31, "
        "fitted on its own data) or the JSON report of 'Shadow fraction model: fit' on your "
        "scene, which takes precedence."
    ),
    params=(
        RATIO,
        *RATIO_BAND,
        Number(
            name="slope",
            label="Slope",
            description="Slope a of ratio = a · fraction + b",
            default=PAPER_SLOPE,
        ),
        Number(
            name="intercept",
            label="Intercept",
            description="Intercept b of ratio = a · fraction + b",
            default=PAPER_INTERCEPT,
        ),
        FileIn(
            name="model",
            label="Fitted model",
            description="JSON report of 'shadow-fraction-fit' (overrides slope and intercept)",
            optional=True,
            extensions=("json",),
        ),
        Flag(
            name="no_clip",
            label="Do not clip",
            description="Do not limit the fraction to 0–1",
            advanced=True,
        ),
        BLOCK_ROWS,
        RasterOut(
            name="output", label="Shadow fraction", description="Shadow fraction (0–1, float32)"
        ),
    ),
    run=shadow_fraction_apply_file,
)

POLYGONS = Algorithm(
    name="shadow-polygons",
    example={"classes_raster": "shadow_classes.tif", "output": "shadow.gpkg"},
    results=(
        Result("polygons", "number", "Polygons written"),
        Result("geometry", "string", "Geometry of the polygons (map or raw sensor geometry)"),
    ),
    display_name="Shadow polygons",
    group=GROUP,
    short_help="Vectorise a shadow class raster into polygons with class and area attributes.",
    help=(
        "Turns the output of 'Shadow classes' into polygons (GeoPackage or GeoJSON): each "
        "4-connected patch of one class becomes a polygon with the class id, its name, the "
        "shadow-fraction interval, its area and its number of pixels, in the raster's CRS. A "
        "raster in raw sensor geometry (no CRS) gives polygons in pixel coordinates "
        "(x = column, y = −line) with the area in pixels; the layer description says so."
    ),
    params=(
        RasterIn(
            name="classes_raster",
            label="Shadow classes",
            description="Shadow class raster (output of 'shadow-classes')",
        ),
        FileIn(
            name="classes",
            label="Class table",
            description="Class table used for it (empty = Table 2)",
            optional=True,
            extensions=("csv", "json"),
        ),
        Number(
            name="min_pixels",
            label="Minimum pixels",
            description="Drop polygons smaller than this many pixels",
            default=MIN_PIXELS,
            minimum=1,
            integer=True,
        ),
        VectorOut(
            name="output",
            label="Shadow polygons",
            description="Shadow polygons (.gpkg or .geojson)",
        ),
    ),
    run=shadow_polygons_file,
)

ALGORITHMS = (CLASSES, CLUSTER, FRACTION_FIT, FRACTION_APPLY, POLYGONS)
