"""A pushbroom sensor's pixel look directions (its sensor model)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError


@dataclass(frozen=True)
class SensorModel:
    """One look direction per detector pixel, in radians: ``across_rad`` positive to the
    right, ``along_rad`` positive forward. The look vector in the sensor frame (x forward,
    y right, z down) is ``[tan along, tan across, 1]``, normalised. ``source`` names where it
    was read from, for error messages."""

    across_rad: np.ndarray
    along_rad: np.ndarray
    source: str = "the sensor model"

    def __post_init__(self):
        across = np.atleast_1d(np.array(self.across_rad, dtype=np.float64))
        along = np.atleast_1d(np.array(self.along_rad, dtype=np.float64))
        if across.ndim != 1 or across.shape != along.shape or across.size == 0:
            raise InputError(
                f"{self.source}: {across.size} across-track and {along.size} along-track "
                "angles; it needs one of each per pixel"
            )
        bad = ~np.isfinite(across) | ~np.isfinite(along)
        big = (np.abs(across) >= np.pi / 2) | (np.abs(along) >= np.pi / 2)
        if bad.any() or big.any():
            i = int(np.flatnonzero(bad | big)[0])
            raise InputError(
                f"{self.source}: pixel {i} has angles ({across[i]}, {along[i]}) rad; each "
                "must be finite and within ±90° (radians, not degrees)"
            )
        for name, a in (("across_rad", across), ("along_rad", along)):
            a.setflags(write=False)
            object.__setattr__(self, name, a)

    def __len__(self) -> int:
        return self.across_rad.size

    @property
    def n_pixels(self) -> int:
        return self.across_rad.size

    def look_vectors(self) -> np.ndarray:
        """(n, 3) unit look vectors in the sensor frame: ``[tan along, tan across, 1]``
        normalised."""
        v = np.stack(
            [np.tan(self.along_rad), np.tan(self.across_rad), np.ones(self.n_pixels)], axis=1
        )
        return v / np.linalg.norm(v, axis=1, keepdims=True)

    @classmethod
    def ideal(cls, n_pixels: int, fov_deg: float) -> SensorModel:
        """A straight linear array on a flat focal plane: ``n_pixels`` equal pixels across
        ``fov_deg`` degrees (edge to edge), centred, no along-track angle."""
        n_pixels = int(n_pixels)
        if n_pixels < 1:
            raise ParameterError(f"the sensor needs at least one pixel, not {n_pixels}")
        if not 0.0 < float(fov_deg) < 180.0:
            raise ParameterError(
                f"fov_deg={fov_deg}: the field of view is in degrees, above 0 and below 180",
                params=("fov",),
            )
        half = np.tan(np.radians(float(fov_deg)) / 2.0)
        # pixel centres are equally spaced on the focal plane, not in angle
        u = (np.arange(n_pixels) + 0.5) / n_pixels * 2.0 - 1.0
        return cls(np.arctan(u * half), np.zeros(n_pixels), source=f"an ideal {fov_deg}° array")

    def binned(self, factor: int) -> SensorModel:
        """The model of the image binned by ``factor`` pixels across track: each binned
        pixel's direction is the centre of its detector pixels on the focal plane."""
        factor = int(factor)
        if factor < 1 or self.n_pixels % factor:
            raise ParameterError(f"{self.source}: {self.n_pixels} pixels do not bin by {factor}")
        if factor == 1:
            return self
        ta = np.tan(self.across_rad).reshape(-1, factor).mean(axis=1)
        tl = np.tan(self.along_rad).reshape(-1, factor).mean(axis=1)
        return SensorModel(np.arctan(ta), np.arctan(tl), source=self.source)

    def trimmed(self, offset: int, count: int) -> SensorModel:
        """The pixels ``offset`` to ``offset + count`` (a spatial subset of the detector)."""
        offset, count = int(offset), int(count)
        if offset < 0 or count < 1 or offset + count > self.n_pixels:
            raise ParameterError(
                f"{self.source}: pixels {offset}–{offset + count - 1} are not within its "
                f"{self.n_pixels} pixels"
            )
        sl = slice(offset, offset + count)
        return SensorModel(self.across_rad[sl], self.along_rad[sl], source=self.source)

    def for_image(self, samples: int, *, offset: int = 0, binning: int | None = None):
        """The model for an image of ``samples`` pixels: trimmed by ``offset`` detector
        pixels then binned by ``binning`` (as its header records it). Without ``binning``, the
        one factor that makes the counts match is taken; an image whose width matches no
        binning of the model is refused."""
        samples = int(samples)
        if binning is not None:
            return self.trimmed(offset, samples * int(binning)).binned(binning)
        left = self.n_pixels - int(offset)
        if left == samples:
            return self.trimmed(offset, samples) if offset else self
        for factor in (2, 3, 4, 5, 6, 8, 10, 12, 16):
            if left == samples * factor:
                return self.trimmed(offset, left).binned(factor)
        raise InputError(
            f"{self.source} has {self.n_pixels} pixels, which match no binning of the "
            f"image's {samples} samples (offset {offset}); give the sensor model of this "
            "instrument or the image's binning"
        )
