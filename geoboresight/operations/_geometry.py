"""The values direct georeferencing and boresight calibration share: a sensor's geometry on
the aircraft and the surface its rays meet."""

from __future__ import annotations

import os
from dataclasses import dataclass

from ..errors import ParameterError
from ..sensor.boresight import Boresight, LeverArm


@dataclass(frozen=True)
class SensorGeometry:
    """A sensor's geometry on the aircraft: its pixels' look directions (``sensor_model``, a
    file, or an ideal array of ``fov`` degrees), one GPS time per image line (``line_times``,
    a file; default the header's GPS start time and fps), the ``lever_arm`` from the
    navigation point to the sensor (body-frame metres x y z) and its ``boresight`` angles
    (degrees roll pitch heading)."""

    sensor_model: str | os.PathLike | None = None
    fov: float | None = None
    line_times: str | os.PathLike | None = None
    lever_arm: LeverArm | tuple | None = None
    boresight: Boresight | tuple | None = None


@dataclass(frozen=True)
class Terrain:
    """The surface the rays meet: a ``dem`` (its CRS in metres; ellipsoidal heights, or
    above the geoid ``dem_vertical_crs`` names, e.g. ``EPSG:5773``), or a constant
    ellipsoidal ``height``, one of them."""

    dem: str | os.PathLike | None = None
    height: float | None = None
    dem_vertical_crs: str | None = None

    def check(self) -> None:
        """Refuse both a DEM and a height, or neither."""
        if (self.dem is None) == (self.height is None):
            raise ParameterError(
                "give a DEM or a constant height, one of them", params=("dem", "height")
            )
