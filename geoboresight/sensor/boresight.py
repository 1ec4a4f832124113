"""The boresight (sensor frame to body frame) and the lever arm (navigation point to sensor)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Boresight:
    """The rotation from a sensor's frame to the body (INS) frame, in degrees:
    ``R_bs = Rz(heading_deg)·Ry(pitch_deg)·Rx(roll_deg)`` (Brook & Ben-Dor 2011, Eq. 1–2)."""

    roll_deg: float = 0.0
    pitch_deg: float = 0.0
    heading_deg: float = 0.0

    def rotation(self):
        """The rotation as a :class:`scipy.spatial.transform.Rotation`."""
        from scipy.spatial.transform import Rotation

        # intrinsic Z-Y-X: the matrix Rz(h) @ Ry(p) @ Rx(r)
        return Rotation.from_euler(
            "ZYX", [self.heading_deg, self.pitch_deg, self.roll_deg], degrees=True
        )

    def matrix(self) -> np.ndarray:
        """``R_bs`` (3, 3): a sensor-frame vector ``v`` is ``R_bs @ v`` in the body frame."""
        return self.rotation().as_matrix()

    def as_tuple(self) -> tuple[float, float, float]:
        return (float(self.roll_deg), float(self.pitch_deg), float(self.heading_deg))


@dataclass(frozen=True)
class LeverArm:
    """From the navigation's reference point to the sensor, in body-frame metres (x forward,
    y right, z down)."""

    x: float = 0.0
    y: float = 0.0
    z: float = 0.0

    def vector(self) -> np.ndarray:
        """The lever arm as a (3,) float64 array."""
        return np.array([self.x, self.y, self.z], dtype=np.float64)

    def as_tuple(self) -> tuple[float, float, float]:
        return (float(self.x), float(self.y), float(self.z))
