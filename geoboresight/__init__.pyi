"""Type stub of geoboresight's flat API, for type checkers and IDEs.

geoboresight/__init__.py loads these names lazily (a module ``__getattr__`` over its
``KERNELS``, ``OPERATIONS``, ``VALUES`` and ``IO`` tables), which static tools cannot follow:
this stub says where each name comes from. The idea is lazy_loader's ``attach_stub`` (a .pyi as the
lazy table) without the dependency: here the tables are the source, and tests/test_house.py
checks that this stub names exactly ``geoboresight.__all__``, each from its table's module.
"""

from .algorithms.anomaly import boresight_indicator_file as boresight_indicator_file
from .algorithms.anomaly import rx_file as rx_file
from .algorithms.anomaly import svdd_file as svdd_file
from .algorithms.anomaly import unmix_file as unmix_file
from .algorithms.boresight_calibrate import boresight_calibrate_file as boresight_calibrate_file
from .algorithms.dem import disparity_file as disparity_file
from .algorithms.dem import relative_dem_file as relative_dem_file
from .algorithms.dem import view_3d_file as view_3d_file
from .algorithms.deshadow import deshadow_file as deshadow_file
from .algorithms.direct_georef import direct_georeference_file as direct_georeference_file
from .algorithms.georef import geolocate_file as geolocate_file
from .algorithms.georef import georeference_file as georeference_file
from .algorithms.georef import reproject_to_file as reproject_to_file
from .algorithms.georef import simulate_ortho_file as simulate_ortho_file
from .algorithms.georef_auto import auto_georeference_file as auto_georeference_file
from .algorithms.info import info_file as info_file
from .algorithms.offset import boresight_offset_file as boresight_offset_file
from .algorithms.offset import coregister_file as coregister_file
from .algorithms.radiance import radiance_file as radiance_file
from .algorithms.ratio import ratio_file as ratio_file
from .algorithms.report import report_file as report_file
from .algorithms.roc import anomaly_polygons_file as anomaly_polygons_file
from .algorithms.roc import roc_file as roc_file
from .algorithms.shadow import shadow_classes_file as shadow_classes_file
from .algorithms.shadow import shadow_cluster_file as shadow_cluster_file
from .algorithms.shadow import shadow_fraction_apply_file as shadow_fraction_apply_file
from .algorithms.shadow import shadow_fraction_fit_file as shadow_fraction_fit_file
from .algorithms.shadow import shadow_polygons_file as shadow_polygons_file
from .algorithms.shadow_map import shadow_map_file as shadow_map_file
from .algorithms.shadow_truth import dark_pixel_shadow_file as dark_pixel_shadow_file
from .algorithms.shadow_truth import sun_shadow_file as sun_shadow_file
from .algorithms.simulate import simulate_file as simulate_file
from .algorithms.stats import stats_file as stats_file
from .anomaly.bands import BandSelection as BandSelection
from .anomaly.indicator import Eq3Reference as Eq3Reference
from .anomaly.indicator import boresight_indicator as boresight_indicator
from .anomaly.physical import Detectability as Detectability
from .anomaly.physical import Dipole as Dipole
from .anomaly.polygons import label_anomalies as label_anomalies
from .anomaly.roc import roc_curve as roc_curve
from .anomaly.rx import RXBackground as RXBackground
from .anomaly.rx import local_rx as local_rx
from .anomaly.rx import rx as rx
from .anomaly.svdd import fit_svdd as fit_svdd
from .anomaly.unmix import unmix as unmix
from .anomaly.unmix import unmix_cube as unmix_cube
from .dem.disparity import Matching as Matching
from .dem.disparity import disparity_map as disparity_map
from .dem.height import FlightGeometry as FlightGeometry
from .dem.relative import Kriging as Kriging
from .dem.relative import relative_dem as relative_dem
from .errors import Cancelled as Cancelled
from .errors import GeoboresightError as GeoboresightError
from .errors import InputError as InputError
from .errors import OutputError as OutputError
from .errors import ParameterError as ParameterError
from .errors import ResourceError as ResourceError
from .georef.geoloc import clean_igm as clean_igm
from .georef.geoloc import corner_geoloc as corner_geoloc
from .georef.geoloc import glt_indices as glt_indices
from .georef.tiepoints import TieMatching as TieMatching
from .georef.tiepoints import match_tie_points as match_tie_points
from .georef.tiepoints import place_reference as place_reference
from .georef.transfer import transfer_tie_points as transfer_tie_points
from .georef.transforms import fit_transform as fit_transform
from .io.bands import BoresightOffset as BoresightOffset
from .io.bands import Coregistration as Coregistration
from .io.bands import MatchBands as MatchBands
from .io.calibration import read_calibration as read_calibration
from .io.cube import open_cube as open_cube
from .io.dual import BandChoice as BandChoice
from .io.dual import DualLayout as DualLayout
from .io.dual import open_dual as open_dual
from .io.grid import Grid as Grid
from .io.grid import OutputGrid as OutputGrid
from .io.navigation import read_navigation as read_navigation
from .io.navigation import read_sensor_model as read_sensor_model
from .io.products import recognise as recognise
from .io.raster import writer_options as writer_options
from .io.scene import write_scene as write_scene
from .io.windows import Sample as Sample
from .io.windows import map_windows as map_windows
from .io.windows import reduce_windows as reduce_windows
from .operations.boresight_calibrate import BoresightFit as BoresightFit
from .operations.boresight_calibrate import TieSources as TieSources
from .operations.deshadow import LightModel as LightModel
from .operations.direct_georef import SensorGeometry as SensorGeometry
from .operations.direct_georef import Terrain as Terrain
from .operations.shadow import NirBand as NirBand
from .operations.shadow_map import Detection as Detection
from .operations.shadow_map import MapCalibration as MapCalibration
from .operations.shadow_map import SurfaceModel as SurfaceModel
from .progress import Progress as Progress
from .ratio import boresight_ratio as boresight_ratio
from .sensor.bands import band_mean as band_mean
from .sensor.boresight import Boresight as Boresight
from .sensor.boresight import LeverArm as LeverArm
from .sensor.calibrate import calibrate_boresight as calibrate_boresight
from .sensor.calibrate import tie_point_ground as tie_point_ground
from .sensor.calibration import Calibration as Calibration
from .sensor.calibration import radiance as radiance
from .sensor.coregister import coregister as coregister
from .sensor.dark import DarkLevels as DarkLevels
from .sensor.dark import dark_object as dark_object
from .sensor.georeference import Surface as Surface
from .sensor.georeference import ground_points as ground_points
from .sensor.model import SensorModel as SensorModel
from .sensor.navigation import Navigation as Navigation
from .sensor.offset import estimate_offset as estimate_offset
from .sensor.offset import offset_profile as offset_profile
from .shadow.cluster import fit_shadow_cluster as fit_shadow_cluster
from .shadow.darkness import calibrate_shadow_map as calibrate_shadow_map
from .shadow.darkness import shadow_fraction_estimate as shadow_fraction_estimate
from .shadow.darkpixel import fit_dark_pixel as fit_dark_pixel
from .shadow.fraction import fit_fraction_model as fit_fraction_model
from .shadow.illumination import cast_shadow as cast_shadow
from .shadow.illumination import shadow_fraction as shadow_fraction
from .shadow.incidence import hillshade as hillshade
from .shadow.surface import choose_surface as choose_surface
from .simulate.ortho import attitude_jitter as attitude_jitter
from .simulate.ortho import simulate_ortho as simulate_ortho
from .simulate.scene import SensorOptions as SensorOptions
from .simulate.scene import SimulatedFlight as SimulatedFlight
from .simulate.scene import Sky as Sky
from .simulate.scene import simulate_scene as simulate_scene
from .stats import describe as describe

__version__: str
__all__: list[str]

#: name -> module of the kernels, the file-level operations, their values and the I/O entry
#: points.
KERNELS: dict[str, str]
OPERATIONS: dict[str, str]
VALUES: dict[str, str]
IO: dict[str, str]
