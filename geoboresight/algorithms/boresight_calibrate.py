"""Spec: measure each sensor's boresight angles (and the clock offset) on tie points."""

from __future__ import annotations

import dataclasses

from ..georef.tiepoints import (
    TieMatching,
)
from ..io.products import FILE_FORMATS
from ..operations.boresight_calibrate import BoresightFit, TieSources, boresight_calibrate_file
from ..operations.direct_georef import SensorGeometry
from ..sensor.calibrate import LOSSES
from ._common import BAND_NM, seed
from ._georef_params import DETECTOR, MAX_SHIFT, MODEL_BLOCK, WOBBLE_MODEL
from .direct_georef import TERRAIN
from .spec import (
    Algorithm,
    Band,
    Enum,
    FileIn,
    FileOut,
    Flag,
    Group,
    Number,
    Numbers,
    RasterIn,
    Result,
    Text,
    VectorOut,
)

GROUP = "Georeferencing"


def _geometry(prefix: str, sensor: str, optional_times: str) -> Group:
    """A sensor's geometry (SensorGeometry), named as ``direct-georeference`` names it
    (``prefix`` for the SWIR's: ``swir_geometry``, ``--swir-sensor-model``)."""
    members = (
        FileIn(
            name=f"{prefix}sensor_model",
            label=f"{sensor} sensor model",
            description=f"The {sensor}'s pixel look directions: CSV, HySpex text or APL view vectors (or give its field of view)",
            optional=True,
        ),
        Number(
            name=f"{prefix}fov",
            label=f"{sensor} field of view",
            description=f"Field of view of the {sensor} as an ideal linear array, edge to edge (instead of a sensor model)",
            optional=True,
            minimum=0.01,
            maximum=179.0,
            unit="degrees",
        ),
        FileIn(
            name=f"{prefix}line_times",
            label=f"{sensor} line times",
            description=f"One GPS time per {sensor} image line ({optional_times})",
            optional=True,
            extensions=("txt", "csv"),
        ),
        Numbers(
            name=f"{prefix}lever_arm",
            label=f"{sensor} lever arm",
            description=f"From the navigation point to the {sensor}, body frame (x forward, y right, z down)",
            names=("X", "Y", "Z"),
            unit="m",
            optional=True,
        ),
        Numbers(
            name=f"{prefix}boresight",
            label=f"{sensor} starting angles",
            description=f"The {sensor}'s boresight angles the search starts from (default 0 0 0)",
            names=("ROLL", "PITCH", "HEADING"),
            unit="degrees",
            optional=True,
            advanced=True,
        ),
    )
    return Group(name=f"{prefix}geometry", value=SensorGeometry, prefix=prefix, params=members)


MATCHING = Group(
    name="matching",
    value=TieMatching,
    params=(
        DETECTOR,
        dataclasses.replace(WOBBLE_MODEL, advanced=True),
        MODEL_BLOCK,
        MAX_SHIFT,
        seed("Random seed (RANSAC's): the same seed gives the same tie points"),
    ),
)

BORESIGHT_CALIBRATE = Algorithm(
    name="boresight-calibrate",
    example={
        "vnir": "line_vnir.hdr",
        "navigation": "line.out",
        "line_times": "line_times.txt",
        "sensor_model": "vnir_model.csv",
        "lever_arm": [0.35, -0.12, 0.28],
        "dem": "dem.tif",
        "gcps": "gcps.csv",
        "output": "boresight.json",
    },
    results=(
        Result("roll_deg", "number", "VNIR boresight roll (degrees)"),
        Result("pitch_deg", "number", "VNIR boresight pitch (degrees)"),
        Result("heading_deg", "number", "VNIR boresight heading (degrees)"),
        Result("time_offset_s", "number", "Clock offset added to the line times (s)"),
        Result("rms_px", "number", "VNIR residual RMS (pixels)"),
        Result("rms_m", "number", "VNIR residual RMS (metres)"),
        Result("tie_points_used", "number", "VNIR tie points used"),
        Result("swir_roll_deg", "number", "SWIR boresight roll (degrees), with a SWIR image"),
        Result("swir_pitch_deg", "number", "SWIR boresight pitch (degrees), with a SWIR image"),
        Result("swir_heading_deg", "number", "SWIR boresight heading (degrees), with a SWIR image"),
        Result("swir_rms_px", "number", "SWIR residual RMS (pixels), with a SWIR image"),
        Result("swir_rms_m", "number", "SWIR residual RMS (metres), with a SWIR image"),
        Result("swir_tie_points_used", "number", "SWIR tie points used, with a SWIR image"),
    ),
    display_name="Boresight calibration (angles from tie points)",
    group=GROUP,
    short_help="Each sensor's boresight angles (and the clock offset) by robust least squares on tie points to an orthophoto and/or GCPs.",
    help=(
        "Measures the boresight angles (roll, pitch, heading of the sensor-to-body rotation) "
        "that direct georeferencing needs, on tie points: automatic ones to a reference "
        "orthophoto (SIFT or ORB features and RANSAC, as 'Georeference on an orthophoto'), "
        "and/or GCPs (CSV pixel,line,x,y or a QGIS .points file; GCPs in another CRS are "
        "transformed). Every ray is traced as 'Direct georeference' traces it, and the angles "
        "are found by robust least squares (SciPy, soft-L1 loss by default) with residuals "
        "measured in image pixels; tie points far beyond the others are rejected. With "
        "'estimate the clock offset', the offset added to the line times is found too (the "
        "value 'Direct georeference' takes as its time offset).\n\n"
        "With a SWIR image on the VNIR's pixel grid, the VNIR's tie points are carried into "
        "the SWIR through the VNIR/SWIR offset measured around each of them (as 'Boresight "
        "offset' measures it), so the SWIR gets its own angles even where its bands match an "
        "RGB orthophoto poorly.\n\n"
        "The run is refused, with the reason, when the tie points cannot determine the "
        "angles: too few, all on one line, or a rank-deficient problem.\n\n"
        "Output: a JSON report (each sensor's angles with standard errors, the clock offset, "
        "every tie point used or rejected, residual RMS and 90th percentile in pixels and "
        "metres), the residual vectors (GeoPackage) and a residual plot (PNG)."
    ),
    params=(
        RasterIn(
            name="vnir",
            label="VNIR image",
            description="VNIR image: the raw line (its lines, samples and header)",
            formats=FILE_FORMATS,
        ),
        FileIn(
            name="navigation",
            label="Navigation",
            description="SBET (.out), navigation CSV, Specim .nav or HySpex navigation text",
            extensions=("out", "sbet", "csv", "nav", "txt"),
        ),
        RasterIn(
            name="swir",
            label="SWIR image",
            description="SWIR image on the same pixel grid: its angles too",
            formats=FILE_FORMATS,
            optional=True,
        ),
        Group(
            name="ties",
            value=TieSources,
            params=(
                RasterIn(
                    name="reference",
                    label="Reference orthophoto",
                    description="Orthophoto with its CRS, for automatic tie points",
                    optional=True,
                ),
                FileIn(
                    name="gcps",
                    label="GCP file",
                    description="GCPs on the VNIR image (CSV pixel,line,x,y or QGIS .points)",
                    extensions=("csv", "points", "txt"),
                    optional=True,
                ),
                Text(
                    name="gcp_crs",
                    label="GCP CRS",
                    description="CRS of the GCPs when their file names none (EPSG code, PROJ or WKT)",
                    optional=True,
                ),
                Band(
                    name="band",
                    label="VNIR band",
                    description="VNIR band matched to the orthophoto (a similar wavelength)",
                    default=1,
                    raster="vnir",
                    wavelength="band_nm",
                ),
                BAND_NM,
                Band(
                    name="reference_band",
                    label="Reference band",
                    description="Orthophoto band matched",
                    default=1,
                    raster="reference",
                ),
            ),
        ),
        _geometry("", "VNIR", "default: the header's GPS start time and fps"),
        _geometry("swir_", "SWIR", "default: its header's, else the VNIR's"),
        Number(
            name="time_offset",
            label="Time offset",
            description="Seconds added to the line times (held, or the start when estimated)",
            default=0.0,
            unit="s",
        ),
        TERRAIN,
        Group(
            name="fit",
            value=BoresightFit,
            params=(
                Flag(
                    name="estimate_time_offset",
                    label="Estimate the clock offset",
                    description="Also estimate the clock offset between the lines and the navigation",
                ),
                Enum(
                    name="loss",
                    label="Robust loss",
                    description="Loss of the least squares (SciPy): soft_l1 and huber down-weight outliers",
                    choices=LOSSES,
                    default="soft_l1",
                    advanced=True,
                ),
            ),
        ),
        MATCHING,
        FileOut(
            name="output",
            label="Calibration report",
            description="Calibration report (JSON)",
            extension="json",
        ),
        VectorOut(
            name="vectors",
            label="Residual vectors",
            description="Residual vectors, tie point to model (GeoPackage)",
            optional=True,
        ),
        FileOut(
            name="plot",
            label="Residual plot",
            description="Residual vectors in the image (PNG)",
            extension="png",
            optional=True,
        ),
    ),
    run=boresight_calibrate_file,
)

ALGORITHMS = (BORESIGHT_CALIBRATE,)
