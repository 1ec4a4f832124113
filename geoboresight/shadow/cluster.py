"""Scene-adaptive shadow detection: the isolated cluster of Figure 4 (paper §3.1).

Table 2's thresholds were found on AISA-Dual DN; on other sensors or calibrations the shadow
pixels still form an isolated cluster in the 2-D distribution of (boresight ratio, VNIR band
at 941 nm): high ratio, low near-infrared signal. This module finds that cluster with a
**Gaussian mixture model** (scikit-learn ``GaussianMixture``, full covariances, the number of
components chosen by the Bayesian information criterion) fitted on a random sample of pixels,
and labels every pixel by its posterior probability of belonging to the shadow component.

Features are the log of the ratio and the log of the 941 nm signal, each standardised by the
sample's median and inter-quartile range, so the fit does not depend on the DN scale. The shadow
component is the one whose mean is furthest along (high ratio, low 941 nm); optionally,
components that overlap it (Bhattacharyya distance below ``merge_distance``) are merged into it,
as in Hennig's (2010) merging of mixture components, since a real cluster is rarely one
Gaussian. Its isolation is reported
as the Bhattacharyya distance to the nearest remaining component.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._threads import default_workers, single_threaded_blas
from ..errors import InputError, ParameterError
from .classes import MASK_NODATA

#: The near-infrared axis of Figure 4 (nm).
NIR_NM = 941.0
#: Posterior probability of the shadow component that makes a pixel shadow.
PROBABILITY = 0.5
#: Pixels drawn at random from the whole flight line to fit the mixture.
SAMPLE_SIZE = 50000
#: Below this isolation (Bhattacharyya distance) the shadow component is not a cluster of its
#: own: it overlaps the rest of the scene (on independent scenes 0.5–0.9 went with F1 0.31–0.41).
MIN_ISOLATION = 2.0


@dataclass(frozen=True)
class ShadowCluster:
    """A fitted mixture and which of its components is shadow."""

    means: np.ndarray  # (k, 2) in standardised feature space
    covariances: np.ndarray  # (k, 2, 2)
    weights: np.ndarray  # (k,)
    shadow: tuple[int, ...]  # indexes of the components that make up the shadow cluster
    center: np.ndarray  # (2,) feature median
    scale: np.ndarray  # (2,) feature IQR
    n_components: int
    n_sample: int
    isolation: float  # Bhattacharyya distance shadow ↔ nearest other component
    shadow_share: float  # fraction of the sample assigned to shadow

    def features(self, ratio: np.ndarray, nir: np.ndarray) -> np.ndarray:
        return _features(ratio, nir, self.center, self.scale)

    def probability(
        self, ratio: np.ndarray, nir: np.ndarray, valid: np.ndarray | None = None
    ) -> np.ndarray:
        """Posterior probability (float32) that each pixel is shadow; NaN where invalid."""
        ratio = np.asarray(ratio, dtype=np.float64)
        nir = np.asarray(nir, dtype=np.float64)
        ok = _usable(ratio, nir, valid)
        out = np.full(ratio.shape, np.nan, dtype=np.float32)
        if ok.any():
            x = self.features(ratio[ok], nir[ok])
            logp = np.stack(
                [
                    np.log(w) + _log_gauss(x, m, c)
                    for w, m, c in zip(self.weights, self.means, self.covariances, strict=True)
                ],
                axis=1,
            )
            logp -= logp.max(axis=1, keepdims=True)
            p = np.exp(logp)
            out[ok] = (p[:, list(self.shadow)].sum(axis=1) / p.sum(axis=1)).astype(np.float32)
        return out

    def warning(self, min_isolation: float = MIN_ISOLATION) -> str | None:
        """A warning when the shadow component is not isolated (None when it is)."""
        if self.isolation >= min_isolation:
            return None
        return (
            f"the shadow cluster's isolation is {self.isolation:.2f} (Bhattacharyya distance; "
            f"below {min_isolation:g} it is not a cluster of its own): the 'shadow' component "
            "overlaps the rest of the scene and the mask likely holds sunlit dark materials; "
            "use 'shadow-map', and check the scatter plot"
        )

    def ellipse(self, n_sigma: float = 2.0, points: int = 100) -> tuple[np.ndarray, np.ndarray]:
        """(ratio, nir) outline of the shadow component at ``n_sigma``, in data units."""
        mean, cov = _moment_match(self.weights, self.means, self.covariances, self.shadow)
        vals, vecs = np.linalg.eigh(cov)
        t = np.linspace(0, 2 * np.pi, points)
        circle = np.stack([np.cos(t), np.sin(t)])
        xy = (vecs @ (np.sqrt(np.maximum(vals, 0))[:, None] * circle)) * n_sigma
        xy = xy + mean[:, None]
        logs = xy * self.scale[:, None] + self.center[:, None]
        return np.exp(logs[0]), np.exp(logs[1])


def _usable(ratio, nir, valid):
    ok = np.isfinite(ratio) & np.isfinite(nir) & (ratio > 0) & (nir > 0)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    return ok


def _features(ratio, nir, center, scale):
    x = np.stack([np.log(ratio), np.log(nir)], axis=-1)
    return (x - center) / scale


def _log_gauss(x, mean, cov):
    d = x - mean
    inv = np.linalg.inv(cov)
    _, logdet = np.linalg.slogdet(cov)
    # (d Σ⁻¹) · d row by row: one small matrix product, not a three-operand einsum (which
    # loops over the pixels and took half of the labelling of a long line).
    quad = np.einsum("ni,ni->n", d @ inv, d)
    return -0.5 * (quad + logdet + 2 * np.log(2 * np.pi))


def _moment_match(weights, means, covs, idx):
    """Mean and covariance of the mixture of components ``idx`` (one Gaussian with its moments)."""
    idx = list(idx)
    w = weights[idx] / weights[idx].sum()
    mean = (w[:, None] * means[idx]).sum(axis=0)
    d = means[idx] - mean
    cov = (w[:, None, None] * (covs[idx] + d[:, :, None] * d[:, None, :])).sum(axis=0)
    return mean, cov


def bhattacharyya(m1, c1, m2, c2) -> float:
    """Bhattacharyya distance between two Gaussians (a standard separability measure)."""
    c = (c1 + c2) / 2
    d = m1 - m2
    term1 = d @ np.linalg.solve(c, d) / 8
    term2 = 0.5 * np.log(np.linalg.det(c) / np.sqrt(np.linalg.det(c1) * np.linalg.det(c2)))
    return float(term1 + term2)


def fit_shadow_cluster(
    ratio: np.ndarray,
    nir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    n_components: int | None = None,
    max_components: int = 5,
    merge_distance: float = 0.0,
    seed: int = 0,
) -> ShadowCluster:
    """Fit a Gaussian mixture to (log ratio, log 941 nm) samples and pick the shadow component.

    Parameters
    ----------
    ratio, nir : arrays of the same shape
        Boresight ratio (Eq. 3) and the VNIR signal near 941 nm: a sample of pixels (the file
        operation draws a random sample of a large raster with ``io.sample_windows``).
    valid : bool array, optional
        Pixels to use; non-finite and non-positive values are always left out.
    n_components : int, optional
        Number of mixture components (≥ 2); by default 2..``max_components`` chosen by BIC.
    max_components : int
        Largest number of components tried when ``n_components`` is not given (at least 2).
    merge_distance : float
        Components within this Bhattacharyya distance of the shadow cluster (and above the
        scene's median ratio) are merged into it. The default 0 merges nothing: one component,
        the core shadow, as the paper prefers ("it is preferable to underestimate the shadow
        areas"); about 1 also takes in overlapping partial-shadow components.
    seed : int
        Random seed of the mixture's initialisation (results are reproducible).

    Returns
    -------
    ShadowCluster
        The fitted mixture in standardised (log ratio, log 941 nm) space (``means``,
        ``covariances``, ``weights``), the indexes of the components that make up the shadow
        cluster (``shadow``), the standardisation (``center``, ``scale``), the number of
        components and of sample pixels, the cluster's ``isolation`` (Bhattacharyya distance to
        the nearest other component) and ``shadow_share`` (fraction of the sample assigned to
        it). :meth:`ShadowCluster.probability` gives each pixel's posterior probability of
        shadow.

    Raises
    ------
    InputError
        When fewer than 50 pixels have a valid, positive ratio and 941 nm value.
    ParameterError
        When ``n_components`` is below 2.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Figure 4: the
    isolated shadow cluster of the ratio against 941 nm; a scene-adaptive alternative to the
    fixed thresholds of Table 2).
    Schwarz, G. Estimating the dimension of a model. Ann. Stat. 1978, 6, 461–464.
    Hennig, C. Methods for merging Gaussian mixture components. Adv. Data Anal. Classif. 2010,
    4, 3–34.
    Bhattacharyya, A. On a measure of divergence between two statistical populations defined
    by their probability distributions. Bull. Calcutta Math. Soc. 1943, 35, 99–109.
    """
    from concurrent.futures import ThreadPoolExecutor

    from sklearn.mixture import GaussianMixture

    ratio = np.asarray(ratio, dtype=np.float64).ravel()
    nir = np.asarray(nir, dtype=np.float64).ravel()
    ok = _usable(ratio, nir, None if valid is None else np.asarray(valid).ravel())
    if ok.sum() < 50:
        raise InputError(
            f"only {int(ok.sum())} pixels have a valid, positive ratio and 941 nm value: "
            "too few to find a shadow cluster (check the nodata value and the bands)"
        )
    logs = np.stack([np.log(ratio[ok]), np.log(nir[ok])], axis=1)
    center = np.median(logs, axis=0)
    q75, q25 = np.percentile(logs, [75, 25], axis=0)
    scale = np.where(q75 - q25 > 0, q75 - q25, np.maximum(logs.std(axis=0), 1e-6))
    x = (logs - center) / scale
    if n_components is not None:
        if int(n_components) < 2:
            raise ParameterError("parameter 'n_components': need at least 2 (shadow + the rest)")
        candidates = [int(n_components)]
    else:
        candidates = list(range(2, max(2, int(max_components)) + 1))

    def fit(k):
        gm = GaussianMixture(k, covariance_type="full", n_init=2, random_state=seed, reg_covar=1e-4)
        gm.fit(x)
        return gm, gm.bic(x)

    # The candidates are independent fits (NumPy releases Python's lock in their E and M
    # steps): fitted in worker threads, then compared in order, so the first of equal BICs
    # wins as in a loop (the same mixture).
    with (
        single_threaded_blas(),
        ThreadPoolExecutor(min(len(candidates), default_workers())) as pool,
    ):
        fits = list(pool.map(fit, candidates))
    best, best_bic = None, np.inf
    for gm, bic in fits:
        if bic < best_bic:
            best, best_bic = gm, bic
    means, covs, weights = best.means_, best.covariances_, best.weights_
    # Shadow: high ratio, low 941 nm (Figure 4): the largest (z_ratio − z_nir). A cluster that
    # is not Gaussian takes several components: merge the nearest ones into it while they
    # overlap it (Bhattacharyya distance below ``merge_distance``; Hennig 2010).
    shadow = [int(np.argmax(means[:, 0] - means[:, 1]))]
    while len(shadow) < len(means) - 1:
        m, c = _moment_match(weights, means, covs, shadow)
        rest = [j for j in range(len(means)) if j not in shadow]
        d = [bhattacharyya(m, c, means[j], covs[j]) for j in rest]
        j = int(np.argmin(d))
        # Only components on the shadow side (higher ratio than the scene's main mode) join.
        if d[j] >= merge_distance or means[rest[j], 0] <= 0:
            break
        shadow.append(rest[j])
    m, c = _moment_match(weights, means, covs, shadow)
    rest = [j for j in range(len(means)) if j not in shadow]
    isolation = min(bhattacharyya(m, c, means[j], covs[j]) for j in rest)
    share = float(np.mean(np.isin(best.predict(x), shadow)))
    return ShadowCluster(
        means=means,
        covariances=covs,
        weights=weights,
        shadow=tuple(shadow),
        center=center,
        scale=scale,
        n_components=len(means),
        n_sample=int(ok.sum()),
        isolation=isolation,
        shadow_share=share,
    )


def shadow_mask(probability: np.ndarray, threshold: float = PROBABILITY) -> np.ndarray:
    """uint8 shadow mask from :meth:`ShadowCluster.probability`: 1 where the probability
    reaches ``threshold``, 0 below, 255 where it is NaN (no valid pixel)."""
    p = np.asarray(probability)
    ok = np.isfinite(p)
    with np.errstate(invalid="ignore"):
        m = np.where(ok, (p >= threshold).astype(np.uint8), MASK_NODATA)
    return m.astype(np.uint8)
