"""Disparity to relative height (paper §3.2), with the precision the geometry allows.

A point raised by ``h`` above the ground is seen by two lines of sight that differ by the squint
``θ`` at ground positions ``h · tan θ`` apart: a relief parallax of ``h · tan θ / GSD`` pixels on
top of the flat-ground boresight offset. The height-to-disparity factor ``k = tan θ / GSD``
(px per metre, with ``GSD = H · IFOV`` at flying height ``H``) turns disparity into height, and a
matching precision ``σ_d`` into a height precision ``σ_h = σ_d · GSD / tan θ = σ_d / k``.
The paper leaves this physics out; with the small squint of a real instrument (fractions of a
degree) ``σ_h`` is larger than the relief, and no meaningful DEM can be made: we say so instead
of returning noise that looks like terrain.

The result is relative: the lowest reliable region is 0 m, everything else relative to it
("the lowest region ... is defined as 0 and other regions are defined relative to 0").
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

#: The relief's standard deviation must exceed σ_h by this factor for a meaningful DEM. Above 1
#: because σ_d is itself an estimate (on simulated scenes the true error was up to 1.3× it).
MIN_SNR = 1.5


@dataclass(frozen=True)
class HeightFactor:
    """Disparity per metre of height (px/m), along-track and across-track.

    Positive ``along``: an elevated feature appears further along-track (higher line number) in
    the SWIR image than on the ground next to it.
    """

    along: float
    across: float = 0.0

    @property
    def magnitude(self) -> float:
        return math.hypot(self.along, self.across)

    def check(self) -> HeightFactor:
        if not (math.isfinite(self.along) and math.isfinite(self.across)):
            raise ParameterError("the height-to-disparity factor must be finite")
        if self.magnitude <= 0:
            raise ParameterError(
                "the height-to-disparity factor is 0: the two lines of sight are parallel, so "
                "relief makes no parallax; give a non-zero factor (px per metre) or squint angle"
            )
        return self


def height_factor(
    flying_height_m: float,
    ifov_mrad: float,
    squint_along_deg: float,
    squint_across_deg: float = 0.0,
) -> HeightFactor:
    """``k = tan θ / GSD`` per axis from flying height, IFOV and the squint between the sensors.

    ``θ`` is the angle between the SWIR and the VNIR lines of sight in the along-track
    (resp. across-track) plane, signed like :class:`HeightFactor`; ``GSD = H · IFOV``.
    """
    if not (flying_height_m > 0):
        raise ParameterError(f"parameter 'flying_height': must be > 0 m, got {flying_height_m}")
    if not (ifov_mrad > 0):
        raise ParameterError(f"parameter 'ifov_mrad': must be > 0, got {ifov_mrad}")
    gsd = ground_sample_distance(flying_height_m, ifov_mrad)
    return HeightFactor(
        along=math.tan(math.radians(squint_along_deg)) / gsd,
        across=math.tan(math.radians(squint_across_deg)) / gsd,
    ).check()


def ground_sample_distance(flying_height_m: float | None, ifov_mrad: float | None) -> float | None:
    """Pixel size on the ground at nadir, ``GSD = H · IFOV`` (m); None unless both are given."""
    if flying_height_m is None or ifov_mrad is None:
        return None
    if not (flying_height_m > 0 and ifov_mrad > 0):
        raise ParameterError("parameters 'flying_height' and 'ifov_mrad' must both be > 0")
    return flying_height_m * ifov_mrad * 1e-3


def parallax_factor(
    height_factor_px_per_m: float | None = None,
    *,
    squint_deg: float | None = None,
    flying_height_m: float | None = None,
    ifov_mrad: float | None = None,
    axis: str = "along",
    invert: bool = False,
) -> HeightFactor:
    """The height-to-disparity factor of a flight: given (px per metre), or ``tan θ / GSD``.

    Parameters
    ----------
    height_factor_px_per_m : float, optional
        ``k`` itself, > 0 (its direction is ``axis`` and ``invert``).
    squint_deg, flying_height_m, ifov_mrad : float, optional
        Without ``k``: the angle between the two lines of sight, the flying height and the IFOV,
        giving ``k = tan θ / (H · IFOV)`` (:func:`height_factor`).
    axis : {"along", "across"}
        The plane of the squint: the parallax is along-track or across-track.
    invert : bool
        Elevated features appear at lower line (column) numbers in the SWIR image.
    """
    sign = -1.0 if invert else 1.0
    k = height_factor_px_per_m
    if k is None:
        if squint_deg is None or flying_height_m is None or ifov_mrad is None:
            raise ParameterError(
                "give the height-to-disparity factor ('height_factor', px per metre), or the "
                "flying height, the IFOV and the squint angle between the two lines of sight"
            )
        if not squint_deg > 0:
            raise ParameterError(
                f"parameter 'squint_deg': must be > 0, got {squint_deg}; a zero squint makes no "
                "parallax (use 'invert_parallax' for the direction)"
            )
        k = height_factor(flying_height_m, ifov_mrad, squint_deg).along
    if not (isinstance(k, int | float) and math.isfinite(k) and k > 0):
        raise ParameterError(
            f"parameter 'height_factor': must be > 0 px per metre, got {k}; it is the size of the "
            "parallax (use 'invert_parallax' for its direction)"
        )
    if axis not in ("along", "across"):
        raise ParameterError(f"parameter 'parallax_axis': 'along' or 'across', got {axis!r}")
    return HeightFactor(sign * k, 0.0) if axis == "along" else HeightFactor(0.0, sign * k)


def disparity_to_height(along: np.ndarray, across: np.ndarray, factor: HeightFactor) -> np.ndarray:
    """Height (m, up to a constant) whose parallax best explains the disparity.

    The least-squares projection of the disparity vector on the parallax direction:
    ``h = (d · k) / |k|²``. The constant (flat-ground offset) is removed by :func:`zero_lowest`.
    """
    factor.check()
    k2 = factor.along**2 + factor.across**2
    return (
        np.asarray(along, np.float64) * factor.along
        + np.asarray(across, np.float64) * factor.across
    ) / k2


def zero_lowest(height: np.ndarray, reliable: np.ndarray, percentile: float = 1.0) -> np.ndarray:
    """Shift ``height`` so that the lowest reliable region (its ``percentile``) is 0 m.

    A low percentile rather than the minimum, so that one bad match does not set the datum.
    """
    h = np.asarray(height, np.float64)
    ok = reliable & np.isfinite(h)
    if not ok.any():
        raise InputError("no reliable height to set the lowest region to 0")
    return h - np.percentile(h[ok], percentile)


@dataclass(frozen=True)
class HeightPrecision:
    """How precise the heights are, and whether the relief stands out of that noise."""

    sigma_d_px: float  # matching precision (from the data)
    sigma_h_m: float  # = σ_d / k = σ_d · GSD / tan θ
    relief_m: float  # noise-corrected relief: 4 × sqrt(var(h) − σ_h²) (≈ 2nd–98th percentile)
    snr: float  # relief standard deviation (noise removed) / σ_h
    meaningful: bool  # snr >= MIN_SNR

    def message(self) -> str:
        if self.meaningful:
            return (
                f"height precision σ_h = {self.sigma_h_m:.2f} m (matching precision σ_d = "
                f"{self.sigma_d_px:.3f} px); relief above the noise ≈ {self.relief_m:.1f} m "
                f"(relief/noise {self.snr:.1f})"
            )
        return (
            f"no meaningful DEM can be made from this squint: the height precision σ_h = "
            f"{self.sigma_h_m:.2f} m (σ_d = {self.sigma_d_px:.3f} px divided by the parallax "
            f"factor) is too large for the relief that stands out of the noise "
            f"(≈ {self.relief_m:.1f} m; relief/noise {self.snr:.1f} < {MIN_SNR}). A surface made from it would be noise that looks like "
            "terrain. A larger angle between the two lines of sight (or a lower flight) is "
            "needed for relief to show"
        )


def height_precision(
    height: np.ndarray, reliable: np.ndarray, sigma_d_px: float, factor: HeightFactor
) -> HeightPrecision:
    """σ_h from σ_d, and the relief that stands out of it.

    The spread of the measured heights is relief plus noise: ``var(h) = var_relief + σ_h²``.
    The DEM is meaningful when the relief's standard deviation exceeds ``MIN_SNR · σ_h``: below
    that, a kriged surface would mostly show matching noise shaped like terrain.
    """
    sigma_h = float(sigma_d_px) / factor.check().magnitude
    h = np.asarray(height, np.float64)[reliable & np.isfinite(height)]
    if h.size < 2 or not math.isfinite(sigma_h):
        return HeightPrecision(float(sigma_d_px), sigma_h, float("nan"), float("nan"), False)
    lo, hi = np.percentile(h, [0.5, 99.5])
    h = h[(h >= lo) & (h <= hi)]  # gross mismatches would inflate the spread
    relief_std = math.sqrt(max(float(np.var(h)) - sigma_h**2, 0.0))
    snr = relief_std / sigma_h if sigma_h > 0 else float("inf")
    return HeightPrecision(float(sigma_d_px), sigma_h, 4.0 * relief_std, snr, snr >= MIN_SNR)
