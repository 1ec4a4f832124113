"""Direct georeferencing (Brook & Ben-Dor 2011, §2, Eq. 1–2): each pixel's ray from the
navigation, the lever arm, the boresight and its look direction, to its first hit on a DEM.

A pixel's ray, in ECEF (EPSG:4978)::

    origin    = p_ecef(t) + R_en(t) · R_nb(t) · lever_arm
    direction = R_en(t) · R_nb(t) · R_bs · look

with ``t = line_time + time_offset`` (the navigation is sampled at the line's time plus the
offset), ``R_nb`` body to north-east-down from roll, pitch and true heading, ``R_en``
north-east-down to ECEF at the navigation point's geodetic latitude and longitude, ``R_bs``
the boresight (sensor to body) and ``look`` the pixel's unit look vector in the sensor frame.

References
----------
Brook, A. & Ben-Dor, E. (2011). Advantages of the boresight effect in hyperspectral data
analysis. Remote Sensing 3, 484–502, https://doi.org/10.3390/rs3030484 (§2, Eq. 1–2).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..errors import ParameterError
from .boresight import Boresight, LeverArm
from .intersect import intersect

#: Geocentric (ECEF) and geodetic 3D WGS84.
ECEF = "EPSG:4978"
GEODETIC = "EPSG:4979"


@dataclass(frozen=True)
class Surface:
    """A DEM: ``heights`` (rows, cols) float64 ellipsoidal metres (NaN no data) on
    ``transform`` (rasterio order a, b, c, d, e, f) in ``crs`` (projected or geographic,
    anything pyproj reads); ``source`` names it in messages."""

    heights: np.ndarray
    transform: tuple
    crs: object
    source: str = "the DEM"

    def __post_init__(self):
        z = np.asarray(self.heights, dtype=np.float64)
        if z.ndim != 2 or min(z.shape) < 1:
            raise ParameterError(f"{self.source}: heights must be a 2-D array, not {z.shape}")
        object.__setattr__(self, "heights", z)
        object.__setattr__(self, "transform", tuple(float(v) for v in tuple(self.transform)[:6]))

    @property
    def bounds(self) -> tuple[float, float, float, float]:
        """(left, bottom, right, top) of a north-up DEM."""
        a, _, c, _, e, f = self.transform
        ny, nx = self.heights.shape
        xs = (c, c + a * nx)
        ys = (f, f + e * ny)
        return min(xs), min(ys), max(xs), max(ys)


@lru_cache(maxsize=32)
def _transformer(src, dst):
    from pyproj import Transformer

    return Transformer.from_crs(src, dst, always_xy=True)


def transformer(src, dst):
    """A cached pyproj Transformer (always x, y order) from ``src`` to ``dst``."""
    from pyproj import CRS

    return _transformer(CRS.from_user_input(src), CRS.from_user_input(dst))


def ned_to_ecef(lat_deg, lon_deg) -> np.ndarray:
    """(n, 3, 3) rotations from north-east-down at geodetic ``lat_deg``, ``lon_deg`` to ECEF
    (the columns are north, east and down in ECEF)."""
    lat, lon = np.radians(np.asarray(lat_deg, float)), np.radians(np.asarray(lon_deg, float))
    sl, cl, so, co = np.sin(lat), np.cos(lat), np.sin(lon), np.cos(lon)
    north = np.stack([-sl * co, -sl * so, cl], axis=-1)
    east = np.stack([-so, co, np.zeros_like(so)], axis=-1)
    down = np.stack([-cl * co, -cl * so, -sl], axis=-1)
    return np.stack([north, east, down], axis=-1)


def platform(navigation, times, *, time_offset: float = 0.0):
    """The navigation point in ECEF and the body-to-ECEF rotation at each line.

    Parameters
    ----------
    navigation : Navigation
    times : (lines,) array
        Each line's GPS time (s).
    time_offset : float
        Seconds added to ``times`` before sampling the navigation.

    Returns
    -------
    positions : (lines, 3) float64 ECEF metres
    body_to_ecef : (lines, 3, 3) float64
    """
    nav = navigation.at(np.asarray(times, dtype=np.float64) + float(time_offset))
    x, y, z = transformer(GEODETIC, ECEF).transform(nav.lon_deg, nav.lat_deg, nav.height)
    positions = np.stack([x, y, z], axis=-1)
    r_nb = nav.rotations().as_matrix()
    return positions, ned_to_ecef(nav.lat_deg, nav.lon_deg) @ r_nb


def rays(positions, body_to_ecef, look, boresight=None, lever_arm=None):
    """Ray origins (lines, 3) and unit directions (lines, pixels, 3) in ECEF from
    :func:`platform`'s values and the sensor's unit ``look`` vectors (pixels, 3)."""
    boresight = Boresight() if boresight is None else boresight
    lever_arm = LeverArm() if lever_arm is None else lever_arm
    r = np.asarray(body_to_ecef, dtype=np.float64)
    origins = np.asarray(positions, dtype=np.float64) + r @ lever_arm.vector()
    sensor_to_ecef = r @ boresight.matrix()
    # (pixels, 3) @ (3, 3)ᵀ per line: one BLAS product per line
    look = np.asarray(look, dtype=np.float64)
    directions = np.matmul(look[None], np.transpose(sensor_to_ecef, (0, 2, 1)))
    return origins, directions


def trace(
    positions,
    body_to_ecef,
    look,
    boresight=None,
    lever_arm=None,
    dem=None,
    *,
    height=None,
    crs=None,
    engine: str = "auto",
):
    """Ground points of every pixel from per-line ECEF ``positions`` and ``body_to_ecef``
    rotations (:func:`platform`): the low-level step, for callers that vary the angles or
    the timing themselves.

    Returns (x, y, h), each (lines, pixels) float64 in ``crs`` (default the DEM's), h
    ellipsoidal metres; NaN where a ray misses.
    """
    dem, height, crs = _surface(dem, height, crs)
    origins, directions = rays(positions, body_to_ecef, look, boresight, lever_arm)
    out_map = transformer(ECEF, crs)
    if dem is None:
        return intersect(origins, directions, float(height), None, out_map, out_map)
    to_map = transformer(ECEF, dem.crs)
    return intersect(
        origins, directions, dem.heights, dem.transform, to_map, out_map, engine=engine
    )


def ground_points(
    navigation,
    times,
    model,
    boresight=None,
    lever_arm=None,
    dem=None,
    *,
    height=None,
    time_offset: float = 0.0,
    crs=None,
    engine: str = "auto",
):
    """Each pixel's first hit on the DEM (Brook & Ben-Dor 2011, Eq. 1–2).

    Parameters
    ----------
    navigation : Navigation
        The trajectory (it must cover ``times + time_offset``).
    times : (lines,) array
        Each line's GPS time (s).
    model : SensorModel
        The pixels' look directions (one per image sample).
    boresight : Boresight, optional
        Sensor frame to body frame (default none).
    lever_arm : LeverArm, optional
        Navigation point to sensor, body frame metres (default none).
    dem : Surface, float or None
        The DEM (ellipsoidal heights), or a constant ellipsoidal height.
    height : float, optional
        A constant ellipsoidal height instead of a DEM.
    time_offset : float
        Seconds added to the line times: the navigation is sampled at
        ``times + time_offset``.
    crs : optional
        The output CRS; default the DEM's (required with a constant height).
    engine : {'auto', 'numba', 'numpy'}
        The DEM march: compiled, or its NumPy reference.

    Returns
    -------
    x, y, h : (lines, pixels) float64
        Easting, northing (or the CRS's axes, x first) and ellipsoidal height; NaN where a
        ray misses.

    References
    ----------
    Brook, A. & Ben-Dor, E. (2011). Remote Sensing 3, 484–502,
    https://doi.org/10.3390/rs3030484 (§2, Eq. 1–2).
    """
    positions, r = platform(navigation, times, time_offset=time_offset)
    return trace(
        positions,
        r,
        model.look_vectors(),
        boresight,
        lever_arm,
        dem,
        height=height,
        crs=crs,
        engine=engine,
    )


def _surface(dem, height, crs):
    if dem is not None and not isinstance(dem, Surface):
        if np.ndim(dem) == 0:
            dem, height = None, float(dem)
        else:
            raise ParameterError("dem must be a Surface or a constant height", params=("dem",))
    if dem is None and height is None:
        raise ParameterError("give a DEM or a constant height", params=("dem", "height"))
    if dem is not None and height is not None:
        raise ParameterError("give a DEM or a constant height, not both", params=("dem", "height"))
    if crs is None:
        if dem is None:
            raise ParameterError("a constant height needs an output CRS", params=("crs",))
        crs = dem.crs
    return dem, height, crs
