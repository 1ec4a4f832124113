"""Spec: simulate a dual pushbroom (AISA-Dual VNIR + SWIR) scene with its ground truth."""

from __future__ import annotations

from ..operations.simulate import MAX_BORESIGHT_DEG, simulate_file
from ..simulate.atmosphere import AOT550, WATER_VAPOUR_CM
from ..simulate.presets import GEOMETRIES, SCENES
from ..simulate.scene import (
    GEOMETRY,
    LINES,
    MIN_LINES,
    PRESET,
    SUPERSAMPLE,
    SensorOptions,
    SimulatedFlight,
    Sky,
)
from ._common import seed
from .spec import Algorithm, Enum, Flag, FolderOut, Group, Number, Result, Text

HELP = """\
Simulates a raw-geometry AISA-Dual scene (VNIR 400–970 nm and SWIR 980–2,450 nm, 198 bands,
286 pixels across track) from a surface model, real material spectra (earthlib), the sun and a
simple atmosphere, with the two instruments' own lines of sight, so that the SWIR image is
displaced from the VNIR image by the boresight offset and by relief parallax, exactly as the
truth files say.

The output folder holds vnir.img/.hdr and swir.img/.hdr (ENVI, 12-bit DN), optionally
merged.img/.hdr, truth rasters on the VNIR grid (truth_dsm.tif, truth_shadow_fraction.tif,
truth_target_abundance.tif, truth_cloud_mask.tif, truth_material.tif), truth.json (offset in
pixels, disparity per metre, height precision, sun, targets) and endmembers.csv (the material
spectra, for unmixing). With --navigation, also igm.tif (the map coordinates of every VNIR
pixel, for geolocate --igm) and ortho.tif (an RGB orthophoto of the ground, 1 m cells, in the
same UTM CRS).

Geometry "realistic" is the paper's regime (squint 0.3°, 1,500 m flying height against a
6,000 ft nominal altitude: about one pixel of residual offset, relief not measurable);
"large-squint" (3°) makes about 1 pixel of parallax per 30 m of relief, for relative DEMs.
The same seed always gives the same files. See docs/simulator.md for what is and is not
modelled.
"""


SIMULATE = Algorithm(
    name="simulate",
    example={"output": "scene", "lines": "16"},
    results=(
        Result("offset_along_px", "number", "Simulated offset along track (pixels)"),
        Result("offset_across_px", "number", "Simulated offset across track (pixels)"),
        Result("disparity_px_per_m", "number", "Simulated disparity (pixels per metre)"),
        Result(
            "height_precision_m_per_px", "number", "Height precision (m per pixel of disparity)"
        ),
    ),
    display_name="Simulate a dual-sensor scene",
    group="Simulation",
    short_help="Simulate an AISA-Dual VNIR+SWIR scene with shadows, relief, targets and its ground truth",
    help=HELP,
    params=(
        Enum(
            name="preset",
            label="Scene type",
            description="Scene type: urban (buildings, streets, trees), dunes (~30 m sand relief), glade (forest clearing), mixed (relief + village + targets)",
            choices=SCENES,
            default=PRESET,
        ),
        Number(
            name="lines",
            label="Lines",
            description="Number of along-track lines to simulate (286 pixels each)",
            default=LINES,
            minimum=MIN_LINES,
            maximum=10000,
            integer=True,
        ),
        seed(
            "Random seed: the same seed gives the same scene, byte for byte",
            advanced=False,
        ),
        Group(
            name="flight",
            value=SimulatedFlight,
            params=(
                Enum(
                    name="geometry",
                    label="Viewing geometry",
                    description="Viewing geometry: realistic (0.3° squint, the paper's regime) or large-squint (3°, relief measurable)",
                    choices=tuple(GEOMETRIES),
                    default=GEOMETRY,
                ),
                Number(
                    name="squint_deg",
                    label="Squint angle",
                    description="Angle between the VNIR and SWIR lines of sight (degrees, along-track and signed; default from the geometry)",
                    optional=True,
                    minimum=-10.0,
                    maximum=10.0,
                    unit="°",
                ),
                Number(
                    name="flying_height",
                    label="Flying height",
                    description="Flying height above the ground (m, above its lowest point; default 1,500 m = 1.5 m pixels)",
                    optional=True,
                    minimum=100.0,
                    maximum=10000.0,
                    unit="m",
                ),
                Number(
                    name="nominal_altitude",
                    label="Nominal altitude",
                    description="Altitude for which the vendor co-registered SWIR to VNIR (m; default 1,828.8 m = 6,000 ft, or the flying height for large-squint)",
                    optional=True,
                    minimum=100.0,
                    maximum=10000.0,
                    unit="m",
                ),
                Text(
                    name="boresight_vnir_deg",
                    label="VNIR boresight angles",
                    description=f"VNIR boresight angles roll,pitch,yaw in degrees, each within ±{MAX_BORESIGHT_DEG:g} (default 0,0,0)",
                    optional=True,
                    advanced=True,
                    aliases=("boresight_vnir",),
                ),
                Text(
                    name="boresight_swir_deg",
                    label="SWIR boresight angles",
                    description=f"SWIR boresight angles roll,pitch,yaw in degrees, each within ±{MAX_BORESIGHT_DEG:g} (default 0,<squint>,0; overrides the squint)",
                    optional=True,
                    advanced=True,
                    aliases=("boresight_swir",),
                ),
            ),
        ),
        Group(
            name="sky",
            value=Sky,
            params=(
                Number(
                    name="sun_zenith",
                    label="Sun zenith",
                    description="Sun zenith angle (degrees; default from the paper's scene for the preset)",
                    optional=True,
                    minimum=0.0,
                    maximum=85.0,
                    unit="°",
                ),
                Number(
                    name="sun_azimuth",
                    label="Sun azimuth",
                    description="Sun azimuth (degrees clockwise from the flight direction; default from the paper). The raw image runs along the flight from row 0 with columns to the right of the track, so sun-shadow and shadow-map take 180° minus this on it",
                    optional=True,
                    minimum=0.0,
                    maximum=360.0,
                    unit="°",
                ),
                Number(
                    name="aot550",
                    label="Aerosol optical depth",
                    description="Aerosol optical depth at 550 nm",
                    default=AOT550,
                    minimum=0.0,
                    maximum=2.0,
                    advanced=True,
                ),
                Number(
                    name="water_vapour_cm",
                    label="Water vapour",
                    description="Water vapour column (cm)",
                    default=WATER_VAPOUR_CM,
                    minimum=0.0,
                    maximum=8.0,
                    unit="cm",
                    advanced=True,
                ),
                Flag(
                    name="sky_obstruction",
                    label="Sky obstruction",
                    description="Walls, tree crowns and slopes hide part of the sky from the "
                    "ground around them (street canyons get less skylight; off: every cell sees "
                    "the sky of its own tilt, as the bundled sample)",
                    advanced=True,
                ),
            ),
        ),
        Number(
            name="targets",
            label="Targets",
            description="Number of sub-pixel gray plastic bags (35 × 55 cm) on open ground (default: 24 for mixed, 12 for glade, else 0)",
            optional=True,
            minimum=0,
            maximum=1000,
            integer=True,
        ),
        Number(
            name="clouds",
            label="Clouds",
            description="Number of small clouds (seen with parallax, casting shadows); 0 for none",
            default=0,
            minimum=0,
            maximum=50,
            integer=True,
        ),
        Number(
            name="cloud_height",
            label="Cloud height",
            description="Cloud height above the ground (m; default 40 % of the flying height)",
            optional=True,
            minimum=10.0,
            maximum=9000.0,
            unit="m",
            advanced=True,
        ),
        Group(
            name="sensor",
            value=SensorOptions,
            params=(
                Flag(
                    name="noise_free",
                    label="Noise free",
                    description="Write noise-free DN (no shot/read noise); still rounded to 12 bits",
                    advanced=True,
                ),
                Number(
                    name="supersample",
                    label="Supersampling",
                    description="Rays per pixel side (footprint integration, sub-pixel shadow fraction)",
                    default=SUPERSAMPLE,
                    minimum=1,
                    maximum=8,
                    integer=True,
                    advanced=True,
                ),
            ),
        ),
        Flag(
            name="merged",
            label="Write merged cube",
            description="Also write merged.img/.hdr with all 198 bands",
        ),
        Flag(
            name="capture",
            label="Raw capture with calibration",
            description="Also write capture.raw/.hdr (both detectors as one AisaFENIX-like raw capture: two integration times, dark frames) and its calibration capture_cal.cal/.hdr",
        ),
        Flag(
            name="navigation",
            label="Navigation",
            description="Also place the scene on a map (UTM 36N) and write igm.tif (easting, northing of each VNIR pixel, for geolocate --igm) and ortho.tif (an RGB orthophoto of the ground)",
        ),
        FolderOut(
            name="output",
            label="Output folder",
            description="Folder to create for the scene (ENVI images, truth rasters, truth.json)",
        ),
    ),
    run=simulate_file,
)

ALGORITHMS = (SIMULATE,)
