"""Co-registration: resample a SWIR band onto the VNIR pixel grid (removing the boresight offset).

The method of the paper uses the boresight effect first (ratio, shadow, relief); the same tool
then corrects it: with the offset measured by :func:`geoboresight.dem.offset.estimate_offset`
(a constant, or a profile along the flight line to follow drift), SWIR pixel values are
interpolated at ``(r + along, c + across)`` so that they line up with VNIR pixel ``(r, c)``.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage

from ..errors import InputError, ParameterError

#: Spline order of the resampling (cubic).
SPLINE_ORDER = 3
#: Lines beyond the shift over which a strip's edge still changes a cubic spline's values: the
#: spline prefilter is a recursive filter whose pole (−0.268) decays below 1e-17 in 30 lines.
SPLINE_MARGIN = 32


def coregister(
    swir: np.ndarray,
    along: float | np.ndarray,
    across: float | np.ndarray,
    valid: np.ndarray | None = None,
    *,
    order: int = SPLINE_ORDER,
    fill: float | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Resample one SWIR band onto the VNIR grid.

    Parameters
    ----------
    swir : 2-D array (lines, columns)
        The SWIR band to resample (DN or radiance; non-finite values are invalid).
    along, across : float, or 1-D array with one value per line
        Offset of the SWIR image relative to VNIR (see :class:`~geoboresight.dem.offset.Offset`).
        Per-line values (e.g. an interpolated :class:`~geoboresight.dem.offset.OffsetProfile`)
        follow drift along the flight line.
    valid : bool array, optional
        Valid SWIR pixels. Output pixels whose interpolation touches an invalid or outside pixel
        are invalid.
    order : int
        Spline order (0 nearest, 1 bilinear, 3 cubic).
    fill : float, optional
        Value given to invalid pixels before interpolation, so that they carry no texture: the
        mean of the valid pixels by default. Strip by strip (:func:`coregister_halo`), give the
        whole band's mean.

    Returns
    -------
    resampled : float32 array (lines, columns)
        The SWIR values interpolated at ``(r + along, c + across)``, on the VNIR grid; NaN
        where invalid.
    valid : bool array (lines, columns)
        Pixels whose interpolation used only valid SWIR pixels inside the image (for cubic and
        higher orders, also one pixel away from any invalid one).

    Raises
    ------
    InputError
        When ``swir`` is not one 2-D band.
    ParameterError
        When ``order`` is not 0–5 or the offset has non-finite values.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Figure 1: the
    boresight shift between the VNIR and SWIR images, "automatically corrected prior to data
    analysis" (§5)).
    Unser, M. Splines: a perfect fit for signal and image processing. IEEE Signal Process. Mag.
    1999, 16(6), 22–38.
    """
    img = np.asarray(swir, dtype=np.float64)
    if img.ndim != 2:
        raise InputError(f"expected one 2-D SWIR band, got an array of shape {img.shape}")
    if order not in (0, 1, 2, 3, 4, 5):
        raise ParameterError(f"parameter 'order': spline order 0–5, got {order}")
    rows, cols = img.shape
    ok = np.isfinite(img) if valid is None else (np.asarray(valid, bool) & np.isfinite(img))
    along = np.broadcast_to(np.asarray(along, dtype=np.float64), (rows,))
    across = np.broadcast_to(np.asarray(across, dtype=np.float64), (rows,))
    if not (np.all(np.isfinite(along)) and np.all(np.isfinite(across))):
        raise ParameterError("the offset has non-finite values: fill gaps in the profile first")
    if fill is None:
        fill = np.mean(img[ok]) if ok.any() else 0.0
    filled = np.where(ok, img, fill)
    if np.ptp(along) == 0 and np.ptp(across) == 0:
        # A constant shift: output[r, c] = input[r + along, c + across].
        shift = (-float(along[0]), -float(across[0]))
        out = ndimage.shift(filled, shift, order=order, mode="nearest", prefilter=order > 1)
        # The mask is shifted bilinearly; any weight from an invalid pixel invalidates.
        inside = ndimage.shift(ok.astype(np.float32), shift, order=1, mode="constant", cval=0.0)
    else:
        r, c = np.mgrid[0:rows, 0:cols].astype(np.float64)
        coords = np.array([r + along[:, None], c + across[:, None]])
        out = ndimage.map_coordinates(filled, coords, order=order, mode="nearest")
        inside = ndimage.map_coordinates(ok.astype(np.float32), coords, order=1, cval=0.0)
    out_ok = inside > 0.999
    if order > 1:
        # Cubic splines reach one pixel further: invalid pixels' neighbours are unreliable too.
        out_ok = ndimage.binary_erosion(out_ok, np.ones((3, 3), bool), border_value=0)
    result = np.where(out_ok, out, np.nan).astype(np.float32)
    return result, out_ok


def coregister_halo(along: float | np.ndarray, order: int = SPLINE_ORDER) -> int:
    """Lines above and below a strip that :func:`coregister` needs to give, on the strip, the
    values of the whole image: the largest along-track shift, the spline's reach and the
    prefilter's decay."""
    reach = float(np.max(np.abs(np.asarray(along, dtype=np.float64))))
    return int(np.ceil(reach)) + int(order) + 1 + (SPLINE_MARGIN if order > 1 else 0)


def profile_to_lines(rows: np.ndarray, values: np.ndarray, height: int) -> np.ndarray:
    """Interpolate a per-block offset profile to one value per line (constant beyond the ends)."""
    rows = np.asarray(rows, dtype=float)
    values = np.asarray(values, dtype=float)
    good = np.isfinite(values)
    if not good.any():
        raise InputError("no block of the flight line gave an offset (all clouded or nodata?)")
    return np.interp(np.arange(height, dtype=float), rows[good], values[good])
