"""Anomaly score map → groups of flagged pixels, the features of an anomaly vector layer.

Pixels with a score at or above the threshold are grouped 8-connected; each group gets the
attributes ``n_pixels``, ``score_max``, ``score_mean``, ``row``, ``col`` (of the peak, 0-based).
The groups become polygons (their pixel outlines) or points (centre of the peak pixel) in the
raster's coordinates in :mod:`geoboresight.io.anomaly`.

SciPy's image module is imported on first use.
"""

from __future__ import annotations

import numpy as np

from ..errors import ParameterError

GEOMETRIES = ("polygon", "point")
#: Attribute columns of an anomaly layer (besides the geometry).
FIELDS = ("n_pixels", "score_max", "score_mean", "row", "col")


def label_anomalies(
    score: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    threshold: float,
    min_pixels: int = 1,
):
    """(labels int32, table dict of arrays) for groups of pixels with score ≥ threshold.

    Labels run 1…n in the table's ``id`` order (0: not an anomaly); groups smaller than
    ``min_pixels`` are dropped. Pixels outside ``valid`` (and NaN scores) are never flagged.

    Parameters
    ----------
    score : 2-D array (rows, cols)
        Anomaly score map (RX, SVDD, boresight indicator), higher = more anomalous.
    valid : bool array (rows, cols), optional
        Pixels that may be flagged; non-finite scores never are.
    threshold : float
        Pixels with a score at or above it are flagged; flagged pixels are grouped 8-connected.
    min_pixels : int
        Smallest group kept.

    Returns
    -------
    labels : int32 array (rows, cols)
        The group of each pixel, 1…n; 0 where not an anomaly (or in a dropped group).
    table : dict of 1-D arrays
        One entry per group, in label order: ``id`` (the label), ``n_pixels``, ``score_max``,
        ``score_mean``, and ``row``, ``col`` of the peak pixel (0-based).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 11: the
    anomalous targets the detectors flag).
    Rosenfeld, A.; Pfaltz, J.L. Sequential operations in digital picture processing. J. ACM
    1966, 13, 471–494.
    """
    from scipy import ndimage

    s = np.asarray(score, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        hot = np.isfinite(s) & (s >= threshold)
    if valid is not None:
        hot &= valid
    labels, n = ndimage.label(hot, structure=np.ones((3, 3), bool))
    if n == 0:
        return labels.astype(np.int32), {k: np.array([]) for k in ("id", *FIELDS)}
    ids = np.arange(1, n + 1)
    filled = np.where(hot, s, 0.0)
    count = ndimage.sum_labels(hot, labels, ids).astype(int)
    smax = ndimage.maximum(filled, labels, ids)
    smean = ndimage.sum_labels(filled, labels, ids) / count
    peaks = np.array(ndimage.maximum_position(np.where(hot, s, -np.inf), labels, ids)).reshape(
        -1, 2
    )
    keep = count >= min_pixels
    if not keep.all():
        relabel = np.zeros(n + 1, np.int32)
        relabel[ids[keep]] = np.arange(1, keep.sum() + 1)
        labels = relabel[labels]
    table = {
        "id": np.arange(1, keep.sum() + 1),
        "n_pixels": count[keep],
        "score_max": smax[keep],
        "score_mean": smean[keep],
        "row": peaks[keep, 0],
        "col": peaks[keep, 1],
    }
    return labels.astype(np.int32), table


def check_geometry(geometry: str) -> None:
    """Raise :class:`ParameterError` unless ``geometry`` is 'polygon' or 'point'."""
    if geometry not in GEOMETRIES:
        raise ParameterError(f"parameter 'geometry' must be 'polygon' or 'point', got {geometry!r}")
