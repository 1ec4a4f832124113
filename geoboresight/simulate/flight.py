"""What an aircraft writes on a survey line: its trajectory (an SBET and the documented CSV),
the line times, the VNIR and SWIR sensor models, a DEM with real relief, and the true
boresight angles and lever arms: the truth for direct georeferencing and boresight
calibration.

The trajectory is analytic: a straight track on a projected map (constant ground speed,
a slow climb), roll, pitch and yaw as sums of sinusoids (a light aircraft's wobble, 0.2–2 Hz)
and a slowly turning wander angle (the SBET's platform heading is the true heading plus it).
The navigation is this trajectory sampled at ``nav_rate`` Hz; the lines are taken at
``line_rate`` Hz from a start that falls between navigation records. Geodetic positions
come from the map positions through pyproj.

Not modelled: GNSS/INS errors, the clock offset (a caller adds one to the line times).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..sensor.boresight import Boresight, LeverArm
from ..sensor.georeference import Surface
from ..sensor.model import SensorModel
from ..sensor.navigation import Navigation

#: The map CRS and the track's origin (first line's map position).
FLIGHT_CRS = "EPSG:32636"
FLIGHT_ORIGIN = (661000.0, 3451000.0)
#: The true boresight angles and lever arms of the two sensors.
TRUE_BORESIGHT = {
    "vnir": Boresight(0.42, -0.31, 0.55),
    "swir": Boresight(-0.27, 0.48, -0.36),
}
TRUE_LEVER_ARM = {"vnir": LeverArm(0.35, -0.12, 0.28), "swir": LeverArm(0.35, 0.14, 0.30)}
#: Wobble: (amplitude °, frequency Hz, phase rad) per angle.
_WOBBLE = {
    "roll": ((1.2, 0.23, 0.3), (0.35, 1.1, 1.7), (0.08, 2.0, 0.4)),
    "pitch": ((0.8, 0.17, 2.1), (0.25, 0.9, 0.2), (0.06, 1.7, 2.9)),
    "yaw": ((1.0, 0.11, 1.0), (0.2, 0.7, 2.5), (0.05, 1.9, 0.8)),
}


@dataclass(frozen=True)
class Flight:
    """An analytic survey line: ``track_deg`` clockwise from grid north, ``speed`` m/s,
    ``height`` ellipsoidal metres at the start, climbing ``climb`` m/s, from ``t0`` (GPS
    seconds of week) at ``origin`` in ``crs``; ``wobble`` scales the attitude wobble;
    ``wander_deg`` the wander angle at ``t0`` (turning 0.4°/s)."""

    t0: float = 302400.0
    origin: tuple = FLIGHT_ORIGIN
    crs: str = FLIGHT_CRS
    track_deg: float = 63.0
    speed: float = 60.0
    height: float = 1250.0
    climb: float = 0.8
    wobble: float = 1.0
    wander_deg: float = 23.7
    extra: dict = field(default_factory=dict, repr=False)

    def map_position(self, t):
        """Map easting, northing and ellipsoidal height at GPS times ``t``."""
        dt = np.asarray(t, dtype=float) - self.t0
        a = np.radians(self.track_deg)
        # a gentle S-curve across the track keeps the position non-linear in time
        side = 3.0 * np.sin(2 * np.pi * 0.05 * dt)
        e = self.origin[0] + self.speed * dt * np.sin(a) + side * np.cos(a)
        n = self.origin[1] + self.speed * dt * np.cos(a) - side * np.sin(a)
        return e, n, self.height + self.climb * dt

    def geodetic(self, t):
        """Latitude, longitude (degrees) and ellipsoidal height at ``t`` (pyproj)."""
        from pyproj import Transformer

        e, n, h = self.map_position(t)
        lon, lat = Transformer.from_crs(self.crs, "EPSG:4326", always_xy=True).transform(e, n)
        return np.asarray(lat), np.asarray(lon), h

    def attitude(self, t):
        """Roll, pitch and true heading (degrees) at ``t``."""
        dt = np.asarray(t, dtype=float) - self.t0
        out = {}
        for name, terms in _WOBBLE.items():
            out[name] = self.wobble * sum(
                amp * np.sin(2 * np.pi * f * dt + ph) for amp, f, ph in terms
            )
        lat, lon, _ = self.geodetic(t)
        # grid track to true heading: the nose points along the track on the map
        conv = _convergence(self.crs, lon, lat)
        heading = (self.track_deg + conv + out["yaw"]) % 360.0
        return out["roll"], out["pitch"], heading

    def wander(self, t):
        return self.wander_deg + 0.4 * (np.asarray(t, dtype=float) - self.t0)

    def navigation(self, start, stop, rate=200.0) -> Navigation:
        """The trajectory sampled at ``rate`` Hz from ``start`` to ``stop`` (GPS s)."""
        t = np.arange(start, stop + 0.5 / rate, 1.0 / rate)
        lat, lon, h = self.geodetic(t)
        roll, pitch, heading = self.attitude(t)
        return Navigation(t, lat, lon, h, roll, pitch, heading, source="the simulated navigation")

    def line_times(self, lines, rate=50.0, start=0.0137):
        """GPS times of ``lines`` lines at ``rate`` Hz, the first ``start`` s after ``t0``."""
        return self.t0 + start + np.arange(int(lines)) / rate


def _convergence(crs, lon, lat):
    """Meridian convergence (degrees) of ``crs`` at ``lon``, ``lat`` (pyproj's factors)."""
    from pyproj import Proj

    f = Proj(crs).get_factors(lon, lat)
    return np.asarray(f.meridian_convergence)


def relief_dem(
    flight: Flight, *, size_m=1100.0, cell=1.0, base=340.0, roughness=1.5, seed=0
) -> Surface:
    """A DEM with real relief around the track: rolling hills (±40 m), a knoll, a steep
    scarp (15 m over about 10 m) and fine roughness, ellipsoidal heights, north-up on
    ``cell`` metres in the flight's CRS, centred on the track's first 300 m; ``roughness``
    the standard deviation (m) of the fine roughness."""
    rng = np.random.default_rng(seed)
    a = np.radians(flight.track_deg)
    cx = flight.origin[0] + 150.0 * np.sin(a)
    cy = flight.origin[1] + 150.0 * np.cos(a)
    n = int(round(size_m / cell))
    x0, y1 = cx - size_m / 2, cy + size_m / 2
    xs = x0 + (np.arange(n) + 0.5) * cell - cx
    ys = y1 - (np.arange(n) + 0.5) * cell - cy
    x, y = np.meshgrid(xs, ys)
    z = (
        base
        + 40.0 * np.sin(x / 70.0) * np.cos(y / 90.0)
        + 30.0 * np.exp(-((x - 80.0) ** 2 + (y + 40.0) ** 2) / 60.0**2)
        + 15.0 * np.tanh((x - 0.6 * y + 50.0) / 5.0)
    )
    from scipy import ndimage

    rough = ndimage.gaussian_filter(rng.normal(size=z.shape), 2.0)
    z = z + roughness * rough / rough.std()
    return Surface(z, (cell, 0.0, x0, 0.0, -cell, y1), flight.crs, source="the simulated DEM")


def sensor_models(vnir_pixels=320, swir_pixels=128):
    """The VNIR (30° across, a slight smile and keystone) and SWIR (28°, its own smile)
    sensor models."""

    def model(n, fov, smile, keystone):
        ideal = SensorModel.ideal(n, fov)
        u = np.linspace(-1.0, 1.0, n)
        across = ideal.across_rad * (1.0 + keystone * u**2)
        along = smile * (u**2 - 1.0 / 3.0)
        return SensorModel(across, along, source=f"the simulated {n}-pixel sensor model")

    return model(vnir_pixels, 30.0, 1.2e-3, 4e-3), model(swir_pixels, 28.0, -2.0e-3, -3e-3)


#: The sample line's flight: the sample scene's heading, origin, flying height (1,500 m
#: above the ground), IFOV (1 mrad: 286 pixels across 16.4°) and line spacing (1.5 m).
SAMPLE_FLIGHT = dict(track_deg=35.0, origin=(660000.0, 3450000.0), height=1840.0, speed=60.0)
