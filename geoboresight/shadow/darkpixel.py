"""A statistical dark-pixel shadow detector of the ATCOR-4 kind: the baseline of §3.1.

ATCOR's de-shadowing (Richter & Müller 2005, Int. J. Remote Sens. 26:3137) finds shadow by image
statistics: core-shadow candidates are pixels dark in the near infrared and in the visible; a
matched filter tuned to their mean spectrum, using the scene's mean and covariance, gives every
pixel a shadow function Φ (≈ 0 for the scene average, ≈ 1 for the dark candidates); pixels with
Φ above a threshold form the shadow mask. This is the detector the paper compares the boresight
ratio against, and its weakness is the one the paper names: "dark targets other than shadow"
(asphalt, dark roofs, water) look like shadow to it.

What is implemented (and what is not): the candidate step uses scene percentiles of the NIR band
and of the mean of the visible bands (both below ``dark_percentile``); the matched filter uses a
few broad bands (blue, green, red, NIR by default). ATCOR's atmospheric correction, cloud and
water masking and its de-shadowing itself are not part of this baseline.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError
from .classes import MASK_NODATA, MASK_SHADOW

#: Bands (nm) of the matched filter: blue, green, red, NIR.
DEFAULT_BANDS_NM = (480.0, 550.0, 660.0, 850.0)
#: Core-shadow candidates are darker than this percentile of the scene (NIR and visible).
DARK_PERCENTILE = 10.0
#: Shadow where the shadow function Φ reaches this value.
THRESHOLD = 0.5
#: Pixels drawn at random from the whole flight line for the scene statistics.
SAMPLE_SIZE = 50000


@dataclass(frozen=True)
class DarkPixelModel:
    """Scene statistics of the dark-pixel detector (fitted on a sample of pixels)."""

    nir_threshold: float
    vis_threshold: float
    mean: np.ndarray  # (n_bands,) scene mean
    filter: np.ndarray  # (n_bands,) matched-filter vector, Φ = filter · (x − mean)
    dark_mean: np.ndarray  # (n_bands,) mean of the core-shadow candidates
    n_candidates: int
    threshold: float

    def shadow_function(self, bands: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
        """Φ of each pixel (float32; NaN invalid) from a (n_bands, rows, cols) stack."""
        x = np.asarray(bands, dtype=np.float64)
        ok = np.all(np.isfinite(x), axis=0)
        if valid is not None:
            ok &= np.asarray(valid, bool)
        phi = np.tensordot(self.filter, x - self.mean[:, None, None], axes=1)
        return np.where(ok, phi, np.nan).astype(np.float32)

    def mask(self, bands: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
        """uint8 shadow mask: 1 where Φ ≥ threshold, 0 elsewhere, 255 invalid."""
        phi = self.shadow_function(bands, valid)
        out = np.zeros(phi.shape, dtype=np.uint8)
        with np.errstate(invalid="ignore"):
            out[phi >= self.threshold] = MASK_SHADOW
        out[~np.isfinite(phi)] = MASK_NODATA
        return out


def fit_dark_pixel(
    bands: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    nir_index: int = -1,
    vis_indices: tuple[int, ...] | None = None,
    dark_percentile: float = DARK_PERCENTILE,
    threshold: float = THRESHOLD,
) -> DarkPixelModel:
    """Fit the detector on a sample: ``bands`` is (n_bands, n_pixels) or (n_bands, rows, cols).

    ``nir_index`` is the NIR band's position, ``vis_indices`` the visible ones (default: all
    others). Candidates are pixels below the ``dark_percentile`` percentile in both NIR and
    visible mean; the matched filter ``v = C⁻¹(d − m) / ((d − m)ᵀ C⁻¹ (d − m))`` gives
    Φ = vᵀ(x − m), 0 at the scene mean m and 1 at the candidates' mean d.

    Parameters
    ----------
    bands : array (n_bands, n_pixels) or (n_bands, rows, cols)
        The matched-filter bands of a sample of pixels (by default blue, green, red and NIR:
        ``DEFAULT_BANDS_NM``), in any consistent unit (DN, radiance, reflectance).
    valid : bool array, optional
        Pixels to use (the shape of one band); pixels with a non-finite value in any band are
        always left out.
    nir_index : int
        Position of the NIR band in ``bands`` (negative counts from the end).
    vis_indices : tuple of int, optional
        Positions of the visible bands, averaged for the darkness test; default: all but NIR.
    dark_percentile : float
        Core-shadow candidates are at or below this percentile (0–100, exclusive) of the scene
        in NIR and in the visible mean (in NIR alone when fewer than 3 pixels are dark in both).
    threshold : float
        Shadow-function value Φ at or above which a pixel is shadow.

    Returns
    -------
    DarkPixelModel
        The darkness thresholds in NIR and visible, the scene mean, the matched-filter vector,
        the candidates' mean, their number and ``threshold``;
        :meth:`DarkPixelModel.shadow_function` gives Φ and :meth:`DarkPixelModel.mask` the
        uint8 shadow mask.

    Raises
    ------
    ParameterError
        When ``dark_percentile`` is not between 0 and 100.
    InputError
        When there are fewer valid pixels than 10 per band (10 × n_bands).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the ATCOR-4
    shadow detector the boresight ratio is compared with, Figures 5(A) and 6).
    Richter, R.; Müller, A. De-shadowing of satellite/airborne imagery. Int. J. Remote Sens.
    2005, 26, 3137–3148.
    """
    if not (0 < dark_percentile < 100):
        raise ParameterError(
            f"parameter 'dark_percentile': {dark_percentile!r} must be between 0 and 100"
        )
    x = np.asarray(bands, dtype=np.float64).reshape(np.shape(bands)[0], -1)
    ok = np.all(np.isfinite(x), axis=0)
    if valid is not None:
        ok &= np.asarray(valid, bool).ravel()
    x = x[:, ok]
    if x.shape[1] < 10 * x.shape[0]:
        raise InputError(
            f"only {x.shape[1]} valid pixels: too few for the dark-pixel statistics "
            "(check the nodata value)"
        )
    n = x.shape[0]
    nir_index = nir_index % n
    if vis_indices is None:
        vis_indices = tuple(i for i in range(n) if i != nir_index)
    nir = x[nir_index]
    vis = x[list(vis_indices)].mean(axis=0)
    t_nir = float(np.percentile(nir, dark_percentile))
    t_vis = float(np.percentile(vis, dark_percentile))
    cand = (nir <= t_nir) & (vis <= t_vis)
    if cand.sum() < 3:
        cand = nir <= t_nir
    m = x.mean(axis=1)
    cov = np.cov(x) + np.eye(n) * 1e-9 * np.trace(np.cov(x))
    d = x[:, cand].mean(axis=1)
    w = np.linalg.solve(cov, d - m)
    v = w / float((d - m) @ w)
    return DarkPixelModel(t_nir, t_vis, m, v, d, int(cand.sum()), float(threshold))
