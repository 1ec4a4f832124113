"""Specs: sub-pixel anomaly detection and unmixing (paper §3.3): RX, SVDD, the boresight
indicator, linear unmixing, ROC curves and anomaly polygons.

Declarations only; the work is done by :mod:`geoboresight.operations.anomaly`.
"""

from __future__ import annotations

from ..anomaly.indicator import TAILS, THRESHOLD, Eq3Reference
from ..anomaly.physical import SIGNS, Dipole
from ..anomaly.physical import WINDOW as DIPOLE_WINDOW
from ..anomaly.rx import INNER, MODES, OUTER, PRECISIONS, RXBackground
from ..anomaly.svdd import NU, SAMPLE_SIZE
from ..anomaly.unmix import METHODS
from ..operations.anomaly import (
    CUBE_BLOCK_ROWS,
    INDICATOR_METHODS,
    boresight_indicator_file,
    rx_file,
    svdd_file,
    unmix_file,
)
from ._common import (
    BLOCK_ROWS,
    CHAIN_PARAMS,
    DARK,
    DETECTABILITY,
    DPRIME_RESULTS,
    GREY_RESULT,
    IMAGE_PARAMS,
    LAYOUT,
    OFFSET,
    block_rows,
    sample_size,
    seed,
)
from .spec import (
    Algorithm,
    Enum,
    FileIn,
    Group,
    Number,
    RasterIn,
    RasterOut,
    Result,
    Text,
)

#: Per-pixel spectral work reads every band of a strip: few lines at a time.
CUBE_BLOCK = block_rows(CUBE_BLOCK_ROWS)

RX = Algorithm(
    name="rx",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "rx.tif"},
    results=(
        Result("bands", "number", "Bands used"),
        Result("background_pixels", "number", "Background pixels"),
        *DPRIME_RESULTS,
        GREY_RESULT,
    ),
    display_name="RX anomaly detector",
    group="Anomaly",
    short_help="Reed–Xiaoli: squared Mahalanobis distance of each pixel to the scene background.",
    help=(
        "Global RX (Reed & Yu 1990), one of the paper's reference detectors (§3.3, Figure 11B): "
        "each pixel's score is (x − μ)ᵀ Σ⁻¹ (x − μ), its squared Mahalanobis distance to the "
        "scene mean μ under the scene covariance Σ. High scores are spectrally unusual pixels.\n\n"
        "The mean and covariance are accumulated in one pass over blocks of lines (float64), the "
        "scores in a second pass, so memory does not grow with the flight line. Water-vapour "
        "absorption bands are left out by default (exclude_nm); choose bands by wavelength with "
        "include_nm. Give the SWIR file to stack VNIR and SWIR bands.\n\n"
        "Local mode: the mean is taken from a window around each pixel (outer size, minus an inner "
        "guard window), the covariance is still the scene's.\n\n"
        "If the covariance is singular (constant or duplicated bands) the run stops and names the "
        "bands; exclude them, or set 'regularize' to add a small ridge (it changes the scores).\n\n"
        "Co-registration (default on): with VNIR and SWIR files (or a product) the SWIR bands "
        "are first shifted onto the VNIR grid by the boresight offset (measured, or given), so a "
        "sub-pixel target's two signals fall in one pixel; --no-coregister keeps the raw "
        "geometry. Detectability: the expected d′ of a target (target_fraction, "
        "target_contrast) from the scene's statistics and dark levels; a warning below 3.\n\n"
        "Output: float32 GeoTIFF score map on the image grid, nodata -9999."
    ),
    params=(
        *IMAGE_PARAMS,
        Group(
            name="background",
            value=RXBackground,
            params=(
                Enum(
                    name="mode",
                    label="Mode",
                    description="Global (scene mean) or local (windowed mean) RX",
                    choices=MODES,
                    default="global",
                ),
                Number(
                    name="inner",
                    label="Inner window",
                    description="Local RX: inner guard window size (odd, pixels)",
                    default=INNER,
                    minimum=1,
                    maximum=99,
                    integer=True,
                    advanced=True,
                ),
                Number(
                    name="outer",
                    label="Outer window",
                    description="Local RX: outer window size (odd, pixels)",
                    default=OUTER,
                    minimum=3,
                    maximum=301,
                    integer=True,
                    advanced=True,
                ),
            ),
        ),
        Number(
            name="regularize",
            label="Covariance ridge",
            description="Ridge added to the covariance diagonal, as a fraction of the mean band variance (0: none)",
            default=0.0,
            minimum=0.0,
            maximum=1.0,
            advanced=True,
        ),
        Enum(
            name="precision",
            label="Precision",
            description="Arithmetic of the scoring pass: float64 (exact) or float32 (about 2× faster)",
            choices=PRECISIONS,
            default="float64",
            advanced=True,
        ),
        *CHAIN_PARAMS,
        CUBE_BLOCK,
        RasterOut(name="output", label="RX score", description="RX score raster (GeoTIFF)"),
    ),
    run=rx_file,
)


SVDD = Algorithm(
    name="svdd",
    example={"vnir": "vnir.hdr", "swir": "swir.hdr", "output": "svdd.tif"},
    results=(
        Result("sigma", "number", "Kernel width used"),
        Result("support_vectors", "number", "Support vectors"),
        *DPRIME_RESULTS,
        GREY_RESULT,
    ),
    display_name="SVDD anomaly detector (RBF kernel)",
    group="Anomaly",
    short_help="Support Vector Data Description with a Gaussian kernel, trained on a random background sample.",
    help=(
        "SVDD (paper §3.3, Eq. 7–9, Figure 11C): the smallest hypersphere, in the feature space of "
        "a Gaussian radial-basis kernel, that encloses a random sample of the scene's pixels. The "
        "score is a pixel's squared distance to the centre minus the squared radius: positive "
        "outside the background description. Unlike RX it needs no covariance inverse and copes "
        "with multimodal backgrounds.\n\n"
        "Training uses scikit-learn's one-class SVM, which for this kernel gives the same decision "
        "function as SVDD (Tax & Duin 2004; Schölkopf et al. 2001). Scoring is done block by "
        "block with matrix products.\n\n"
        "sigma: kernel width in image units; 0 chooses it as the median distance between sample "
        "pixels. nu: the fraction of training pixels allowed outside the sphere.\n\n"
        "Co-registration (default on) and detectability as for RX (d′ from the training "
        "sample's mean and covariance).\n\n"
        "Output: float32 GeoTIFF score map on the image grid, nodata -9999."
    ),
    params=(
        *IMAGE_PARAMS,
        Number(
            name="sigma",
            label="Kernel width",
            description="Gaussian kernel width in image units (0: median pairwise distance of the sample)",
            default=0.0,
            minimum=0.0,
        ),
        Number(
            name="nu",
            label="Outlier fraction (nu)",
            description="Fraction of background pixels allowed outside the description (0–1)",
            default=NU,
            minimum=1e-4,
            maximum=1.0,
        ),
        sample_size(
            "Pixels sampled at random (the background SVDD trains on)",
            SAMPLE_SIZE,
            20,
            20000,
            advanced=False,
        ),
        seed("Random seed (of the background sample: same seed, same result)"),
        *CHAIN_PARAMS,
        CUBE_BLOCK,
        RasterOut(name="output", label="SVDD score", description="SVDD score raster (GeoTIFF)"),
    ),
    run=svdd_file,
)


INDICATOR = Algorithm(
    name="boresight-indicator",
    example={"ratio": "ratio.tif", "output": "indicator.tif"},
    results=(
        Result("count", "number", "Anomalous pixels"),
        Result("method", "string", "Method used (eq3 or physical)"),
        Result("median", "number", "Median of the reference (eq3: the ratio)"),
        Result("robust_sigma", "number", "Robust standard deviation of the reference"),
        *DPRIME_RESULTS[1:],
    ),
    display_name="Boresight anomaly indicator",
    group="Anomaly",
    short_help="Sub-pixel targets from the boresight ratio: the paper's Eq. 3 z-score, or the dipole of the dark-corrected log ratio along the offset.",
    help=(
        "The paper's proposal (§3.3, Figure 11D): the boresight band ratio as a sub-pixel anomaly "
        "indicator. Two methods:\n\n"
        "eq3 (a reproduction of the paper): z = (ratio − median) / (1.4826 × MAD) of the ratio "
        "raster (the 'ratio' operation), scene-wide or against a local median (window); tail "
        "'both' scores |z|, 'high' z, 'low' −z. On raw DN with dark offsets in, brightness "
        "texture leaks into the ratio and a grey target shows only as a dipole along the offset: "
        "docs/anomaly.md measures AUC below 0.5 for it.\n\n"
        "physical (needs vnir, swir): the log ratio of dark-corrected band means 1,000–1,100 over "
        "900–975 nm, minus itself at the boresight offset (measured, or given): a grey target's "
        "two lobes add up; scored against its dipole_window neighbourhood, one-sided when "
        "target_sign is known. It reports the expected d′ of a target and warns below 3.\n\n"
        "auto (default): physical with the cube, else eq3. Pixels above the threshold (default "
        "3, the paper's 3σ rule) are anomalies.\n\n"
        "Outputs: the score (float32 GeoTIFF, nodata -9999) and optionally a 0/1 anomaly mask."
    ),
    params=(
        RasterIn(
            name="ratio",
            label="Boresight ratio",
            description="Boresight ratio raster (method eq3)",
            optional=True,
        ),
        RasterIn(
            name="vnir",
            label="VNIR image",
            description="VNIR image (method physical)",
            optional=True,
        ),
        RasterIn(
            name="swir",
            label="SWIR image",
            description="SWIR image on the same pixel grid (method physical)",
            optional=True,
        ),
        Enum(
            name="method",
            label="Method",
            description="eq3: the paper's z of the ratio; physical: dipole of the dark-corrected log ratio; auto: physical with the cube",
            choices=INDICATOR_METHODS,
            default="auto",
        ),
        Number(
            name="threshold",
            label="Threshold",
            description="Anomaly threshold on the score (σ units)",
            default=THRESHOLD,
            minimum=0.1,
            maximum=100.0,
        ),
        Group(
            name="reference",
            value=Eq3Reference,
            params=(
                Enum(
                    name="tail",
                    label="Tail",
                    description="eq3: which side stands out: both, high or low ratios",
                    choices=TAILS,
                    default="both",
                ),
                Number(
                    name="window",
                    label="Reference window",
                    description="eq3: local reference, median ratio in this odd window (pixels); 0 = whole scene",
                    default=0,
                    minimum=0,
                    maximum=101,
                    integer=True,
                ),
            ),
        ),
        Group(
            name="dipole",
            value=Dipole,
            params=(
                Enum(
                    name="target_sign",
                    label="Target sign",
                    description="physical: the targets against their ground at 900–1,100 nm (unknown: two-sided)",
                    choices=SIGNS,
                    default="unknown",
                ),
                Number(
                    name="dipole_window",
                    label="Dipole window",
                    description="physical: odd window of the dipole's local median and spread (pixels)",
                    default=DIPOLE_WINDOW,
                    minimum=3,
                    maximum=101,
                    integer=True,
                    advanced=True,
                ),
                *OFFSET.params,
            ),
        ),
        LAYOUT,
        DARK,
        DETECTABILITY,
        BLOCK_ROWS,
        RasterOut(
            name="output", label="Indicator score", description="Indicator score raster (GeoTIFF)"
        ),
        RasterOut(
            name="anomalies",
            label="Anomaly mask",
            description="0/1 anomaly mask (GeoTIFF, optional)",
            optional=True,
        ),
    ),
    run=boresight_indicator_file,
)


UNMIX = Algorithm(
    name="unmix",
    example={
        "vnir": "vnir.hdr",
        "swir": "swir.hdr",
        "endmembers": "endmembers.csv",
        "output": "abundances.tif",
    },
    results=(Result("endmembers", "string", "Endmembers used (JSON)"),),
    display_name="Linear spectral unmixing",
    group="Anomaly",
    short_help="Abundance of each endmember per pixel (fully constrained: ≥ 0, sum to 1), with the residual.",
    help=(
        "Linear unmixing (paper Eq. 10–11): each pixel spectrum is modelled as a sum of endmember "
        "spectra weighted by abundances, plus a residual φ. 'fcls' (fully constrained, the paper's "
        "choice) keeps abundances ≥ 0 summing to 1; 'nnls' only ≥ 0; 'ucls' unconstrained.\n\n"
        "Endmembers: a CSV (first column wavelength in nm, one column per material, e.g. the "
        "simulator's endmembers.csv or field spectra) or an ENVI spectral library (.sli + .hdr). "
        "They are resampled to the image's band centres with Gaussian responses of the image's "
        "FWHM. The library must cover the image's wavelengths (exclude bands it does not). The "
        "image must be in the library's units: use image_scale (e.g. 0.0001 for reflectance × "
        "10000).\n\n"
        "Output: one float32 band per endmember (abundance) and a last band with the residual RMS "
        "over bands; nodata -9999."
    ),
    params=(
        *IMAGE_PARAMS,
        FileIn(
            name="endmembers",
            label="Endmembers",
            description="Endmember spectra: CSV (wavelength_nm, one column per material) or ENVI .sli/.hdr",
            extensions=("csv", "sli", "hdr"),
        ),
        Text(
            name="names",
            label="Endmember names",
            description="Endmembers to use, comma-separated (empty: all in the file)",
            default="",
            optional=True,
        ),
        Enum(
            name="method",
            label="Constraint",
            description="fcls: ≥ 0 and sum to 1 (Eq. 11); nnls: ≥ 0; ucls: unconstrained",
            choices=METHODS,
            default="fcls",
        ),
        Number(
            name="image_scale",
            label="Image scale factor",
            description="Factor turning image values into the library's units (e.g. 0.0001)",
            default=1.0,
            minimum=0.0,
        ),
        CUBE_BLOCK,
        RasterOut(
            name="output", label="Abundances", description="Abundances + residual raster (GeoTIFF)"
        ),
    ),
    run=unmix_file,
)


ALGORITHMS = (RX, SVDD, INDICATOR, UNMIX)
