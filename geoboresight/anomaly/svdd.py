"""Support Vector Data Description with a Gaussian RBF kernel (paper §3.3, Eq. 7–9; Figure 11C).

SVDD (Tax & Duin 2004) encloses the background sample in the smallest hypersphere in the
kernel's feature space; a pixel's anomaly score is its squared distance to the centre ``a``
minus the squared radius ``R²``, positive outside the sphere (the paper's Eq. 7 with the sign
turned so that high = anomalous):

    score(y) = ‖Φ(y) − a‖² − R² = 2 (ρ − Σᵢ αᵢ K(y, xᵢ)) / Σᵢ αᵢ       (K(y, y) = 1, Eq. 9)

For a kernel with constant ``K(x, x)`` (the Gaussian RBF) the SVDD dual and the ν-one-class
SVM dual of Schölkopf et al. (2001, "Estimating the support of a high-dimensional
distribution") are the same quadratic programme with the box constraint ``C = 1/(ν N)``, so the
two give the same decision function up to a positive scale (Tax & Duin 2004, §4; Schölkopf et
al. 2001, Prop. 4). Training therefore uses scikit-learn's ``OneClassSVM``; scoring does not:
``decision_function`` evaluates the kernel pixel by pixel, whereas :meth:`SVDDModel.decision`
computes all kernel exponents of a chunk of pixels against the support vectors with one BLAS
matrix product (``‖y − x‖² = ‖y‖² + ‖x‖² − 2 yᵀx``), for equal results.

Kernel width: ``K(x, y) = exp(−‖x − y‖² / (2σ²))``. When σ is not given it is the median
pairwise Euclidean distance within the training sample (the "median heuristic", Schölkopf &
Smola 2002; Gretton et al. 2012), which makes the kernel scale with the data (DN, radiance or
reflectance alike).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import InputError, ParameterError

#: Fraction of background pixels allowed outside the description (ν).
NU = 0.01
#: Background pixels drawn at random for training.
SAMPLE_SIZE = 1000


@dataclass(frozen=True)
class SVDDModel:
    """A trained SVDD: support vectors (m, k), their dual weights (m,), offset and kernel."""

    support_vectors: np.ndarray
    alpha: np.ndarray  # scikit-learn dual_coef_ (sums to ν·N)
    intercept: float  # scikit-learn intercept_ (= −ρ)
    gamma: float  # 1 / (2σ²)
    sigma: float
    nu: float
    center: np.ndarray  # training mean, subtracted before distances (numerical range)

    @cached_property
    def _kernel_rows(self) -> np.ndarray:
        """(m, k + 2) matrix ``A`` with ``A [y; 1; ‖y‖²] = −γ ‖y − xᵢ‖²`` (centred data).

        ``‖y − x‖² = ‖y‖² + ‖x‖² − 2 yᵀx``: one GEMM gives the kernel exponents of a chunk of
        pixels against all support vectors, with the squared norms and γ folded in, so the
        (m × chunk) result needs only a clip and an exp.
        """
        sv = self.support_vectors - self.center
        sv_sq = np.einsum("ij,ij->i", sv, sv)
        m = len(sv)
        return np.hstack(
            [2.0 * self.gamma * sv, -self.gamma * sv_sq[:, None], np.full((m, 1), -self.gamma)]
        )

    @cached_property
    def _local(self) -> threading.local:
        return threading.local()

    def decision(
        self, X: np.ndarray, chunk: int | None = None, valid: np.ndarray | None = None
    ) -> np.ndarray:
        """``OneClassSVM.decision_function`` of pixels ``X`` (k, n): Σ αᵢ K(y, xᵢ) − ρ.

        Positive inside the description (background), negative outside. ``X`` may be of any
        numeric type (integer DN are converted chunk by chunk into a reused buffer). Computed
        in chunks of ``chunk`` pixels (default: about 10⁶ kernel values per chunk) with one
        GEMM each; thread-safe (each thread has its own buffers). With ``valid`` (bool, n),
        the other pixels are NaN and their values are never used (nodata, NaN): the valid
        pixels need no copy of their own.
        """
        X = np.asarray(X)
        k, n = X.shape
        A = self._kernel_rows
        m = A.shape[0]
        if chunk is None:  # ~10⁶ kernel values per chunk, chunks of about equal size
            chunk = int(np.clip(2**20 // max(m, 1), 256, 16384))
            chunk = -(-n // -(-n // chunk)) if n else chunk
        c_max = min(chunk, n)
        ws = self._local
        if getattr(ws, "Y", None) is None or ws.Y.size < (k + 2) * c_max or ws.G.size < m * c_max:
            ws.Y = np.empty((k + 2) * c_max)
            ws.G = np.empty(m * c_max)
        out = np.empty(n)
        skip = None if valid is None or valid.all() else ~np.asarray(valid, bool)
        for a in range(0, n, chunk):
            c = min(chunk, n - a)
            Y = ws.Y[: (k + 2) * c].reshape(k + 2, c)
            # Converted, then centred in place: a subtraction across types is buffered, twice
            # as slow (the same values).
            np.copyto(Y[:k], X[:, a : a + c], casting="unsafe")
            Y[:k] -= self.center[:, None]
            if skip is not None:
                Y[:k, skip[a : a + c]] = 0.0  # the centre: finite, whatever was there
            Y[k] = 1.0
            np.einsum("ij,ij->j", Y[:k], Y[:k], out=Y[k + 1])
            G = ws.G[: m * c].reshape(m, c)
            np.matmul(A, Y, out=G)  # −γ‖y − xᵢ‖²
            np.minimum(G, 0.0, out=G)  # ‖y − x‖² ≥ 0 (rounding)
            np.exp(G, out=G)
            np.matmul(self.alpha, G, out=out[a : a + c])
        out += self.intercept
        if skip is not None:
            out[skip] = np.nan
        return out

    def score(
        self, X: np.ndarray, chunk: int | None = None, valid: np.ndarray | None = None
    ) -> np.ndarray:
        """SVDD anomaly score ``‖Φ(y) − a‖² − R²`` (positive outside the sphere) of pixels
        ``X`` (k, n); NaN where not ``valid``."""
        return -2.0 * self.decision(X, chunk, valid) / float(self.alpha.sum())

    def score_cube(self, cube: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
        """Scores of a (k, rows, cols) cube of any numeric type; NaN where not valid."""
        k, rows, cols = cube.shape
        if valid is not None and not valid.any():
            return np.full((rows, cols), np.nan)
        v = None if valid is None else valid.ravel()
        return self.score(cube.reshape(k, -1), valid=v).reshape(rows, cols)


def median_sigma(sample: np.ndarray, max_pairs: int = 2000, seed: int = 0) -> float:
    """Median pairwise Euclidean distance of a (n, k) sample (on at most ``max_pairs`` points)."""
    rng = np.random.default_rng(seed)
    if len(sample) > max_pairs:
        sample = sample[rng.choice(len(sample), max_pairs, replace=False)]
    from scipy.spatial.distance import pdist

    d = pdist(sample)
    d = d[d > 0]
    if d.size == 0:
        raise InputError(
            "all background sample pixels are identical: SVDD cannot set a kernel width"
        )
    return float(np.median(d))


def sample_positions(n_pixels: int, size: int, rng: np.random.Generator) -> np.ndarray:
    """Sorted flat positions (line × width + column) of ``1.5 × size + 10`` distinct pixels
    drawn uniformly from an image of ``n_pixels`` (extra, since some may be nodata)."""
    return np.sort(rng.choice(n_pixels, min(n_pixels, int(size * 1.5) + 10), replace=False))


def keep_at_most(sample: np.ndarray, size: int, rng: np.random.Generator) -> np.ndarray:
    """``sample`` (n, k), or ``size`` of its rows drawn at random when it has more."""
    if len(sample) > size:
        return sample[rng.permutation(len(sample))[:size]]
    return sample


def fit_svdd(
    sample: np.ndarray, sigma: float | None = None, nu: float = NU, tol: float = 1e-4
) -> SVDDModel:
    """Train an RBF SVDD on a background sample (n, k) with scikit-learn's OneClassSVM.

    Parameters
    ----------
    sample : (n, k) array
        Background pixels (a random sample of the scene: anomalies are rare, so they barely
        move the description; ν bounds the fraction of training pixels left outside).
    sigma : float, optional
        Gaussian kernel width in data units; default: :func:`median_sigma`.
    nu : float
        Upper bound on the fraction of training pixels outside the sphere (0 < ν ≤ 1).
    tol : float
        Stopping tolerance of the quadratic-programme solver (scikit-learn's ``tol``).

    Returns
    -------
    SVDDModel
        Support vectors (m, k), their dual weights ``alpha``, the offset ``intercept`` (−ρ), the
        kernel's ``gamma`` = 1/(2σ²) and ``sigma``, ``nu`` and the training mean ``center``;
        :meth:`SVDDModel.score_cube` gives each pixel's score ``‖Φ(y) − a‖² − R²`` (positive
        outside the sphere: anomalous).

    Raises
    ------
    InputError
        When ``sample`` is not 2-D with at least 10 pixels, or (without ``sigma``) all its
        pixels are identical.
    ParameterError
        When ``nu`` is not in (0, 1] or ``sigma`` is not positive.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eqs. 7–9: SVDD
    with a Gaussian RBF kernel; Figure 11(C), compared in Figure 12).
    Tax, D.M.J.; Duin, R.P.W. Support vector data description. Mach. Learn. 2004, 54, 45–66.
    Schölkopf, B.; Platt, J.C.; Shawe-Taylor, J.; Smola, A.J.; Williamson, R.C. Estimating the
    support of a high-dimensional distribution. Neural Comput. 2001, 13, 1443–1471.
    Banerjee, A.; Burlina, P.; Diehl, C. A support vector method for anomaly detection in
    hyperspectral imagery. IEEE Trans. Geosci. Remote Sens. 2006, 44, 2282–2291.
    """
    from sklearn.svm import OneClassSVM

    sample = np.asarray(sample, dtype=np.float64)
    if sample.ndim != 2 or sample.shape[0] < 10:
        raise InputError(f"SVDD needs at least 10 background pixels, got {sample.shape[0]}")
    if not 0 < nu <= 1:
        raise ParameterError(f"parameter 'nu' must be in (0, 1], got {nu}")
    if sigma is None:
        sigma = median_sigma(sample)
    if not sigma > 0:
        raise ParameterError(f"parameter 'sigma' must be > 0, got {sigma}")
    gamma = 1.0 / (2.0 * sigma**2)
    center = sample.mean(axis=0)
    model = OneClassSVM(kernel="rbf", gamma=gamma, nu=nu, tol=tol).fit(sample)
    return SVDDModel(
        support_vectors=model.support_vectors_.copy(),
        alpha=model.dual_coef_.ravel().copy(),
        intercept=float(model.intercept_[0]),
        gamma=gamma,
        sigma=float(sigma),
        nu=nu,
        center=center,
    )
