"""Spec: direct georeferencing, from the aircraft's navigation to an IGM per sensor."""

from __future__ import annotations

from ..io.products import FILE_FORMATS
from ..operations.direct_georef import SensorGeometry, Terrain, direct_georeference_file
from .spec import Algorithm, FileIn, Group, Number, Numbers, RasterIn, RasterOut, Result, Text

GROUP = "Georeferencing"

#: The sensor's geometry (SensorGeometry): look directions, line times, lever arm, boresight.
GEOMETRY = Group(
    name="geometry",
    value=SensorGeometry,
    params=(
        FileIn(
            name="sensor_model",
            label="Sensor model",
            description="Pixel look directions: CSV, HySpex text or APL view vectors (or give fov)",
            optional=True,
        ),
        Number(
            name="fov",
            label="Field of view",
            description="Field of view of an ideal linear array, edge to edge (instead of a sensor model)",
            optional=True,
            minimum=0.01,
            maximum=179.0,
            unit="degrees",
        ),
        FileIn(
            name="line_times",
            label="Line times",
            description="One GPS time per image line (default: the header's GPS start time and fps)",
            optional=True,
            extensions=("txt", "csv"),
        ),
        Numbers(
            name="lever_arm",
            label="Lever arm",
            description="From the navigation point to the sensor, body frame (x forward, y right, z down)",
            names=("X", "Y", "Z"),
            unit="m",
            optional=True,
        ),
        Numbers(
            name="boresight",
            label="Boresight angles",
            description="Sensor to body rotation",
            names=("ROLL", "PITCH", "HEADING"),
            unit="degrees",
            optional=True,
        ),
    ),
)

#: The surface the rays meet (Terrain): a DEM or a constant height.
TERRAIN = Group(
    name="terrain",
    value=Terrain,
    params=(
        RasterIn(
            name="dem",
            label="DEM",
            description="DEM in metres with its CRS (ellipsoidal heights, or give its vertical CRS)",
            optional=True,
        ),
        Number(
            name="height",
            label="Constant height",
            description="A constant ellipsoidal height instead of a DEM",
            optional=True,
            unit="m",
        ),
        Text(
            name="dem_vertical_crs",
            label="DEM vertical CRS",
            description="The DEM's vertical CRS when its heights are above a geoid (e.g. EPSG:5773), converted to ellipsoidal through pyproj",
            optional=True,
            advanced=True,
        ),
    ),
)

DIRECT_GEOREFERENCE = Algorithm(
    name="direct-georeference",
    example={
        "input": "line_vnir.hdr",
        "navigation": "line.out",
        "line_times": "line_times.txt",
        "sensor_model": "vnir_model.csv",
        "boresight": [0.42, -0.31, 0.55],
        "lever_arm": [0.35, -0.12, 0.28],
        "dem": "dem.tif",
        "output": "vnir_igm.tif",
    },
    results=(
        Result("lines", "number", "Image lines"),
        Result("samples", "number", "Samples per line"),
        Result("missed_fraction", "number", "Share of the rays that meet no DEM height"),
        Result("first_line_time", "number", "GPS time of the first line (s)"),
    ),
    display_name="Direct georeference (navigation to IGM)",
    group=GROUP,
    short_help="Each raw pixel's map position from the navigation, line times, sensor model, lever arm, boresight and a DEM (the paper's Eq. 1–2).",
    help=(
        "Puts every pixel of a raw line on the map from what the aircraft recorded (Brook & "
        "Ben-Dor 2011, §2, Eq. 1–2): the GNSS/INS trajectory, each line's time, each pixel's "
        "look direction (the sensor model), the lever arm from the navigation point to the "
        "sensor, the sensor's boresight angles, and a DEM.\n\n"
        "Conventions: WGS84 ellipsoidal heights; body frame x forward, y right, z down; "
        "roll positive right wing down, pitch nose up, heading clockwise from true north; "
        "the boresight R = Rz(heading)·Ry(pitch)·Rx(roll) takes the sensor frame to the body "
        "frame; across-track angles positive to the right, along-track positive forward. "
        "The navigation is sampled at each line's time plus the time offset.\n\n"
        "Navigation: an Applanix SBET (.out), the CSV time,lat,lon,height,roll,pitch,heading "
        "(degrees), a Specim .nav or HySpex per-line text. Line times: a text file (one GPS "
        "time per line) or the image header's GPS start time and fps. Sensor model: a CSV "
        "pixel,across_track_rad,along_track_rad, a HySpex 'pixel vinkelx vinkely' file, "
        "APL's view-vector file, or --fov for an ideal array; it is trimmed and binned as "
        "the image header says.\n\n"
        "Each ray's first hit on the DEM is exact, at the DEM's own resolution. Output: "
        "the IGM (float64 easting, northing, ellipsoidal height; nodata where a ray misses) "
        "as GeoTIFF, or ENVI BIL (.bil, .img) in APL's layout, which geolocate --igm takes "
        "as it is."
    ),
    params=(
        RasterIn(
            name="input",
            label="Raw image",
            description="The raw line (its lines, samples and header)",
            formats=FILE_FORMATS,
        ),
        FileIn(
            name="navigation",
            label="Navigation",
            description="SBET (.out), navigation CSV, Specim .nav or HySpex navigation text",
            extensions=("out", "sbet", "csv", "nav", "txt"),
        ),
        GEOMETRY,
        Number(
            name="time_offset",
            label="Time offset",
            description="Seconds added to the line times before the navigation is sampled",
            default=0.0,
            unit="s",
        ),
        TERRAIN,
        Text(
            name="crs",
            label="Output CRS",
            description="The IGM's CRS (default: the DEM's; required with a constant height)",
            optional=True,
        ),
        RasterOut(
            name="output",
            label="IGM",
            description="IGM: easting, northing, height of each raw pixel (GeoTIFF, or ENVI .bil/.img)",
            also=(".bil", ".img"),
        ),
        RasterOut(
            name="view_angles_output",
            label="View angles",
            description="View zenith and azimuth of each pixel (degrees)",
            optional=True,
            also=(".bil", ".img"),
        ),
    ),
    run=direct_georeference_file,
    positional=("input",),
)

ALGORITHMS = (DIRECT_GEOREFERENCE,)
