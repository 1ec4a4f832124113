"""The boresight band ratio (Brook & Ben-Dor 2011, Eq. 3): b(1010 nm) / b(920 nm).

The first SWIR band over the last VNIR band. Because the two optics see slightly different
ground, the ratio is high where the two bands disagree most: in core shadow (where the dim
signal is dominated by each sensor's offsets and by diffuse light) and at sub-pixel anomalies.
"""

from __future__ import annotations

import numpy as np


def boresight_ratio(
    numerator: np.ndarray, denominator: np.ndarray, valid: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Eq. 3: ``numerator / denominator`` as float32, with the mask of valid pixels.

    Parameters
    ----------
    numerator : array
        The SWIR band nearest 1010 nm (DN or radiance).
    denominator : array
        The VNIR band nearest 920 nm, same shape.
    valid : bool array, optional
        Pixels valid in both bands (nodata already removed).

    Returns
    -------
    ratio : float32 array
        The ratio; undefined (NaN) where not valid.
    valid : bool array
        False where either band is invalid or non-finite, or the denominator is <= 0.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (Eq. 3).

    Examples
    --------
    >>> import numpy as np
    >>> import geoboresight as gb
    >>> swir = np.array([[2.0, 3.0], [4.0, 1.0]])
    >>> vnir = np.array([[1.0, 1.5], [0.0, 2.0]])  # a zero denominator is not a ratio
    >>> ratio, valid = gb.boresight_ratio(swir, vnir)
    >>> ratio
    array([[2. , 2. ],
           [nan, 0.5]]...)
    >>> valid
    array([[ True,  True],
           [False,  True]])
    """
    num = np.asarray(numerator, dtype="float32")
    den = np.asarray(denominator, dtype="float32")
    if num.shape != den.shape:
        raise ValueError(f"numerator {num.shape} and denominator {den.shape} differ in shape")
    ok = np.isfinite(num) & np.isfinite(den) & (den > 0)
    if valid is not None:
        ok &= valid
    ratio = np.full(num.shape, np.nan, dtype="float32")
    np.divide(num, den, out=ratio, where=ok)
    ok &= np.isfinite(ratio)
    return ratio, ok
