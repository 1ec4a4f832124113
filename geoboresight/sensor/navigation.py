"""The platform's trajectory: position and attitude against GPS time."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

_FIELDS = ("time", "lat_deg", "lon_deg", "height", "roll_deg", "pitch_deg", "heading_deg")


@dataclass(frozen=True)
class Navigation:
    """A GNSS/INS trajectory: arrays of equal length, sorted by ``time`` (GPS seconds).

    ``lat_deg``, ``lon_deg`` WGS84 geodetic degrees; ``height`` WGS84 ellipsoidal metres;
    ``roll_deg`` (right wing down positive), ``pitch_deg`` (nose up positive) and
    ``heading_deg`` (true heading, clockwise from north) of the body frame (x forward, y
    right, z down): ``R_nb = Rz(heading)·Ry(pitch)·Rx(roll)`` to north-east-down.
    ``source`` names where it was read from, for error messages.
    """

    time: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    height: np.ndarray
    roll_deg: np.ndarray
    pitch_deg: np.ndarray
    heading_deg: np.ndarray
    source: str = "the navigation"

    def __post_init__(self):
        arrays = [np.atleast_1d(np.array(getattr(self, f), dtype=np.float64)) for f in _FIELDS]
        n = arrays[0].size
        for name, a in zip(_FIELDS, arrays, strict=True):
            if a.ndim != 1 or a.size != n:
                raise InputError(
                    f"{self.source}: {name} has {a.size} values, time has {n}; every field "
                    "needs one value per record"
                )
            if not np.isfinite(a).all():
                raise InputError(f"{self.source}: {name} holds NaN or infinite values")
        for name, a in zip(_FIELDS, arrays, strict=True):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def cleaned(self) -> Navigation:
        """The records sorted by time, repeated times dropped (the first kept)."""
        order = np.argsort(self.time, kind="stable")
        keep = order[np.concatenate([[True], np.diff(self.time[order]) > 0])]
        if keep.size == self.time.size and np.all(keep == np.arange(keep.size)):
            return self
        return Navigation(*(getattr(self, f)[keep] for f in _FIELDS), source=self.source)

    def __len__(self) -> int:
        return self.time.size

    @property
    def time_range(self) -> tuple[float, float]:
        return float(self.time[0]), float(self.time[-1])

    def rotations(self):
        """Body to north-east-down, one :class:`~scipy.spatial.transform.Rotation` per record."""
        from scipy.spatial.transform import Rotation

        angles = np.stack([self.heading_deg, self.pitch_deg, self.roll_deg], axis=1)
        return Rotation.from_euler("ZYX", angles, degrees=True)

    def check_covers(self, times, label: str = "the line times") -> None:
        """Raise :class:`InputError` naming both time ranges when ``times`` leave the
        navigation's range."""
        times = np.asarray(times, dtype=np.float64)
        if times.size == 0:
            return
        lo, hi = float(np.min(times)), float(np.max(times))
        t0, t1 = self.time_range
        if lo < t0 or hi > t1:
            raise InputError(
                f"{self.source} covers GPS time {t0:.3f}–{t1:.3f} s but {label} run "
                f"{lo:.3f}–{hi:.3f} s; give the navigation that covers the line (or check "
                "the time offset and the week's seconds)"
            )

    def at(self, times) -> Navigation:
        """The navigation at ``times``: position linear in latitude, longitude and height,
        attitude by spherical linear interpolation (SLERP) of the body rotations.

        Raises :class:`InputError` (naming both ranges) for a time outside the navigation.
        """
        from scipy.spatial.transform import Slerp

        if self.time.size < 2 or np.any(np.diff(self.time) <= 0):
            raise InputError(
                f"{self.source}: its {self.time.size} records need at least 2 strictly "
                "increasing times to be interpolated"
            )
        times = np.atleast_1d(np.asarray(times, dtype=np.float64))
        if not np.isfinite(times).all():
            raise ParameterError("the line times hold NaN or infinite values")
        self.check_covers(times)
        # only the records around the requested times: a block of lines of a long line
        # interpolates between a few hundred records, not the whole trajectory
        i0 = max(int(np.searchsorted(self.time, times.min(), side="right")) - 2, 0)
        i1 = min(int(np.searchsorted(self.time, times.max(), side="left")) + 2, self.time.size)
        part = slice(i0, i1)
        t = self.time[part]
        lon = np.unwrap(self.lon_deg[part], period=360.0)
        lat = np.interp(times, t, self.lat_deg[part])
        lon = (np.interp(times, t, lon) + 180.0) % 360.0 - 180.0
        height = np.interp(times, t, self.height[part])
        angles = np.stack(
            [self.heading_deg[part], self.pitch_deg[part], self.roll_deg[part]], axis=1
        )
        from scipy.spatial.transform import Rotation

        rot = Slerp(t, Rotation.from_euler("ZYX", angles, degrees=True))(times)
        heading, pitch, roll = rot.as_euler("ZYX", degrees=True).T
        return Navigation(times, lat, lon, height, roll, pitch, heading % 360.0, source=self.source)
