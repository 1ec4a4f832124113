"""The SWIR's tie points carried to the VNIR: features matched between the two images of one
line, placed by the line's VNIR/SWIR offset, so a SWIR band that matches an RGB orthophoto
poorly still gets its boresight (:func:`geoboresight.sensor.calibrate.calibrate_boresight`)."""

from __future__ import annotations

import numpy as np

from ..sensor.offset import estimate_offset
from .tiepoints import match_tie_points


def transfer_tie_points(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    detector: str = "sift",
    model_block_lines: int = 16,
    max_shift_px: float = 10.0,
    seed: int = 0,
):
    """Tie points between the SWIR and the VNIR image of one line, through the VNIR/SWIR
    offset.

    The line's offset (:func:`~geoboresight.dem.offset.estimate_offset`, SWIR minus VNIR
    position) places the VNIR image into the SWIR's geometry; features are matched between
    the two by the matcher of the orthophoto tie points
    (:func:`~geoboresight.georef.tiepoints.match_tie_points`), whose RANSAC per block of
    lines follows what one offset for the line misses: the relief parallax between the two
    instruments' views and the attitude changing between the instants they see a feature.
    Each SWIR tie point's ground is then the calibrated VNIR's ground at its VNIR position.

    Parameters
    ----------
    vnir, swir : 2-D arrays (lines, columns)
        One VNIR and one SWIR band on the same pixel grid (bands whose radiometry is close
        across the seam, e.g. 920 and 1010 nm).
    valid : bool array, optional
        Pixels usable in both bands.
    detector, model_block_lines, max_shift_px, seed
        The matcher's settings (``max_shift_px``: largest departure from the line's offset).

    Returns
    -------
    swir_pixel_line, vnir_pixel_line : (n, 2) arrays
        The same features in the SWIR and the VNIR image (continuous pixel, line).
    offset : (along, across)
        The line's offset (pixels, SWIR minus VNIR).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Figure 1: the
    boresight shift between the VNIR and SWIR images; §3.2).
    """
    v = np.asarray(vnir, "float64")
    s = np.asarray(swir, "float64")
    ok = np.isfinite(v) & np.isfinite(s)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    whole = estimate_offset(v, s, ok)

    def placement(pixel, line):
        # a SWIR position to the VNIR position of the same ground, by the line's offset
        return np.asarray(pixel) - whole.across, np.asarray(line) - whole.along

    tie = match_tie_points(
        np.where(ok, s, np.nan),
        np.where(ok, v, np.nan),
        ok,
        ref_transform=(1.0, 0.0, 0.0, 0.0, 1.0, 0.0),  # "map" coordinates: VNIR pixels
        placement=placement,
        ref_valid=ok,
        detector=detector,
        model_block_lines=int(model_block_lines),
        max_shift_px=float(max_shift_px),
        seed=int(seed),
    )
    swir_pl = tie.pixel_line[tie.inlier]
    vnir_pl = np.column_stack(placement(tie.placed[tie.inlier, 0], tie.placed[tie.inlier, 1]))
    return swir_pl, vnir_pl, (float(whole.along), float(whole.across))


__all__ = ["transfer_tie_points"]
