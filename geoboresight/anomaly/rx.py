"""Global and local RX anomaly detectors (Reed & Yu 1990; paper §3.3, Figure 11B).

The RX score of a pixel spectrum ``x`` is its squared Mahalanobis distance to the background,
``(x - μ)ᵀ Σ⁻¹ (x - μ)``. Global RX estimates μ and Σ from the whole scene in one streaming
pass (float64: one symmetric rank-k update per strip of lines gives Σxxᵀ and Σx together, so
memory does not grow with the flight line), factors ``Σ = L Lᵀ`` (Cholesky) once, and scores
each strip in a second pass as ``‖L⁻¹ (x - μ)‖²``: a triangular matrix product per strip (as
GEMMs on row blocks of ``L⁻¹``), then a sum of squares per pixel. Strips may be of any numeric type (integer DN are
converted once, into a reused buffer) and may be processed by several threads at once.

Σ is the unbiased sample covariance (divides by N - 1), as in Spectral Python's ``spectral.rx``.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError
from .bands import band_label

#: Global (scene mean) or local (windowed mean) RX.
MODES = ("global", "local")
#: Arithmetic of the scoring pass.
PRECISIONS = ("float64", "float32")
#: Local RX: inner guard window and outer window sizes (odd, pixels).
INNER = 3
OUTER = 17


@dataclass(frozen=True)
class RXBackground:
    """What an RX score measures a pixel against: the scene mean (``mode="global"``), or the
    mean of an ``outer`` window minus an ``inner`` guard window around the pixel
    (``"local"``; odd sizes in pixels, inner < outer). The covariance is the scene's either way.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.RXBackground()
    RXBackground(mode='global', inner=3, outer=17)
    >>> gb.RXBackground(mode="local", outer=25)  # a local window: --mode local --outer 25
    RXBackground(mode='local', inner=3, outer=25)
    """

    mode: str = "global"
    inner: int = INNER
    outer: int = OUTER

    @property
    def local(self) -> bool:
        return self.mode == "local"


@dataclass(frozen=True)
class GaussianStats:
    """Background mean (k,), covariance (k, k) and number of pixels."""

    mean: np.ndarray
    cov: np.ndarray
    n: int


class CovarianceAccumulator:
    """Streaming mean and covariance in float64, in one pass over the data.

    Each strip is converted into a reused float64 buffer as ``d = x − c`` (``c``: the first
    strip's mean, rounded to integers for integer data so that ``d`` and every product are
    exact), with a row of ones appended, and ``[d; 1][d; 1]ᵀ`` is added with one symmetric
    rank-k update (NumPy turns ``X @ X.T`` into BLAS ``syrk``): the top-left block is Σddᵀ, the
    last row Σd and the count, so the mean costs no extra pass. Shifting keeps the digits of a
    small variance on a large signal (DN of several thousand) in ``Σddᵀ − N d̄d̄ᵀ``. Invalid
    pixels are zeroed, ones row included, so they add nothing.

    Thread-safe: each thread adds into its own partial sums, added up by :meth:`stats` (give
    ``shift`` when several threads add, so that it does not depend on which strip came first).
    """

    def __init__(self, k: int, shift=None):
        self.k = k
        self.shift = None if shift is None else np.asarray(shift, dtype=np.float64)
        self._lock = threading.Lock()
        self._local = threading.local()
        self._parts: list[np.ndarray] = []

    @staticmethod
    def strip_shift(cube: np.ndarray, valid: np.ndarray | None = None) -> np.ndarray:
        """Mean of a strip's valid pixels, rounded for integer data (a good shift ``c``)."""
        X = np.asarray(cube).reshape(cube.shape[0], -1)
        if valid is not None and not valid.all():
            X = X[:, valid.ravel()]
        if X.shape[1] == 0:
            return np.zeros(cube.shape[0])
        m = X.mean(axis=1, dtype=np.float64)
        return np.round(m) if X.dtype.kind in "iub" else m

    def _workspace(self, n: int):
        ws = self._local
        if getattr(ws, "acc", None) is None:
            ws.acc = np.zeros((self.k + 1, self.k + 1))
            ws.buf = np.empty(0)
            with self._lock:
                self._parts.append(ws.acc)
        if ws.buf.size < (self.k + 1) * n:
            ws.buf = np.empty((self.k + 1) * n)
        return ws.acc, ws.buf[: (self.k + 1) * n].reshape(self.k + 1, n)

    def add_cube(self, cube: np.ndarray, valid: np.ndarray | None = None) -> None:
        """Add the valid pixels of a (k, rows, cols) strip of any numeric type (not modified)."""
        self.add_product(self.strip_product(cube, valid))

    def strip_product(self, cube: np.ndarray, valid: np.ndarray | None = None):
        """``[d; 1][d; 1]ᵀ`` of a strip's valid pixels (a new (k + 1, k + 1) matrix; None when
        none is valid), for :meth:`add_product`. Computed in worker threads and added in strip
        order, the sums do not depend on which thread took which strip."""
        cube = np.asarray(cube)
        k = cube.shape[0]
        n = cube.size // k if k else 0
        if n == 0 or (valid is not None and not valid.any()):
            return None
        if self.shift is None:
            with self._lock:
                if self.shift is None:
                    self.shift = self.strip_shift(cube, valid)
        _, X = self._workspace(n)
        # Converted, then shifted in place: a subtraction across types is twice as slow.
        # Copied as the strip lies (a reshape of a strip that is a view of a larger array
        # would be a copy of its own).
        np.copyto(X[:k].reshape(cube.shape), cube, casting="unsafe")
        X[:k] -= self.shift[:, None]
        X[k] = 1.0
        if valid is not None and not valid.all():
            X[:, ~valid.ravel()] = 0.0
        return X @ X.T  # syrk: the other triangle is filled by NumPy

    def add_product(self, product: np.ndarray | None) -> None:
        """Add a strip's :meth:`strip_product` (None: nothing) to this thread's sums."""
        if product is not None:
            acc, _ = self._workspace(0)
            acc += product

    def add(self, X: np.ndarray) -> None:
        """Add pixels ``X`` of shape (k, n)."""
        X = np.asarray(X)
        self.add_cube(X.reshape(X.shape[0], 1, -1))

    def _total(self) -> np.ndarray:
        with self._lock:
            return sum(self._parts, np.zeros((self.k + 1, self.k + 1)))

    @property
    def n(self) -> int:
        return int(round(self._total()[self.k, self.k]))

    def stats(self, ddof: int = 1) -> GaussianStats:
        T = self._total()
        n = int(round(T[self.k, self.k]))
        if n <= ddof:
            raise InputError(
                f"only {n} valid pixel(s): RX needs a background of many pixels "
                "(check nodata and the valid-pixel mask)"
            )
        m = T[self.k, : self.k] / n
        cov = (T[: self.k, : self.k] - n * np.outer(m, m)) / (n - ddof)
        cov = 0.5 * (cov + cov.T)
        return GaussianStats(mean=m + self.shift, cov=cov, n=n)


def pixels(cube: np.ndarray, valid: np.ndarray | None = None, dtype="float64") -> np.ndarray:
    """(k, n) matrix of the valid pixels of a (k, rows, cols) cube (a copy in ``dtype``)."""
    X = np.asarray(cube).reshape(cube.shape[0], -1)
    if valid is not None and not valid.all():
        return X[:, valid.ravel()].astype(dtype, copy=True)
    return X.astype(dtype, copy=True)


def background_stats(blocks, k: int) -> GaussianStats:
    """Mean and covariance from an iterable of ``(cube (k, rows, cols), valid)`` strips."""
    acc = CovarianceAccumulator(k)
    for cube, valid in blocks:
        acc.add_cube(cube, valid)
    return acc.stats()


#: A band whose variance is explained by the other bands to within this fraction makes the
#: covariance numerically singular (RX scores would be noise).
SINGULAR_TOLERANCE = 1e-10


class RXDetector:
    """Squared Mahalanobis distance to a Gaussian background.

    Parameters
    ----------
    stats : GaussianStats
    regularize : float
        Ridge added to the diagonal, as a fraction of the mean band variance (0: none). Only
        use it when asked: it changes the scores.
    wavelengths : array, optional
        Band centres (nm) of the bands in ``stats``, to name bands in error messages.
    band_numbers : array, optional
        1-based band numbers in the file, for the same purpose.

    Raises
    ------
    InputError
        When the covariance is singular: it names the constant bands, or the bands that are
        linear combinations of others, and suggests excluding them or ``regularize``.
    """

    def __init__(
        self, stats: GaussianStats, regularize: float = 0.0, wavelengths=None, band_numbers=None
    ):
        if regularize < 0:
            raise ParameterError("parameter 'regularize' must be >= 0")
        self.stats = stats
        cov = stats.cov
        k = cov.shape[0]
        var = np.diag(cov).copy()
        names = self._namer(wavelengths, band_numbers)
        if regularize > 0:
            cov = cov + regularize * max(float(var.mean()), np.finfo(float).tiny) * np.eye(k)
            var = np.diag(cov).copy()
        scale = max(float(var.max()), np.finfo(float).tiny)
        const = np.flatnonzero(var <= 1e-14 * scale)
        if const.size:
            raise InputError(
                f"the covariance is singular: {const.size} band(s) are constant over the valid "
                f"pixels ({', '.join(names(i) for i in const[:12])}{' …' if const.size > 12 else ''}). "
                "Exclude them (exclude_nm) or pass regularize > 0"
            )
        # NumPy's LAPACK, not SciPy's: the same factorisation, and RX (and every command that
        # imports it) starts without loading SciPy (0.2 s a process).
        try:
            if not np.isfinite(cov).all():
                raise np.linalg.LinAlgError("non-finite covariance")
            L = np.linalg.cholesky(cov)
            unexplained = np.diag(L) ** 2 / var
        except np.linalg.LinAlgError:
            unexplained = np.zeros(k)
        bad = np.flatnonzero(unexplained < SINGULAR_TOLERANCE)
        if bad.size:
            dependent = _dependent_bands(cov)
            raise InputError(
                "the covariance is singular: band(s) "
                f"{', '.join(names(i) for i in dependent[:12])}{' …' if dependent.size > 12 else ''} "
                "are (almost) linear combinations of the other bands (duplicated or "
                "interpolated bands, or more bands than pixels). Exclude them (exclude_nm) "
                "or pass regularize > 0"
            )
        self.L = L
        # W = L⁻¹ once: scoring is then ‖W (x − μ)‖², a triangular matrix product per strip.
        # (solved by LU: as accurate as a triangular solve here, its upper triangle dropped)
        self.W = np.tril(np.linalg.solve(L, np.eye(k)))
        self._W = {dt: _triangular_blocks(self.W, dt) for dt in (np.float64, np.float32)}
        self._mu = {np.float64: stats.mean, np.float32: stats.mean.astype(np.float32)}
        self._local = threading.local()

    @staticmethod
    def _namer(wavelengths, band_numbers):
        def name(i):
            if band_numbers is not None:
                b = int(band_numbers[i])
                wl = f" ({wavelengths[i]:.1f} nm)" if wavelengths is not None else ""
                return f"band {b}{wl}"
            return band_label(int(i), wavelengths)

        return name

    def score(self, X: np.ndarray, precision: str = "float64", inplace: bool = False) -> np.ndarray:
        """RX scores of pixels ``X`` (k, n) of any numeric type; returns float64 (n,).

        ``precision="float32"`` does the product in single precision (about 2× faster; relative
        error ~1e-5 for a well-conditioned covariance); the covariance is always float64.
        ``inplace`` is accepted for compatibility: ``X`` is never modified.
        """
        X = np.asarray(X)
        return self.score_cube(X.reshape(X.shape[0], 1, -1), None, precision).ravel()

    def score_cube(self, cube, valid=None, precision="float64", inplace=False):
        """RX scores (float64) of a (k, rows, cols) strip of any numeric type; NaN where not valid.

        ``x − μ`` is written into a reused buffer of the scoring precision (so integer data is
        converted once, without a float64 copy of the strip), whitened by ``W = L⁻¹`` and
        squared-summed per pixel. Thread-safe: each thread has its own buffers.
        """
        dt = {"float32": np.float32, "float64": np.float64}.get(precision)
        if dt is None:
            raise ParameterError(f"precision must be 'float64' or 'float32', got {precision!r}")
        cube = np.asarray(cube)
        k, rows, cols = cube.shape
        n = rows * cols
        out = np.full(n, np.nan)
        v = None if valid is None or valid.all() else valid.ravel()
        if n == 0 or (v is not None and not v.any()):
            return out.reshape(rows, cols)
        buf = getattr(self._local, dt.__name__, None)
        if buf is None or buf.size < 2 * k * n:
            buf = np.empty(2 * k * n, dtype=dt)
            setattr(self._local, dt.__name__, buf)
        D = buf[: k * n].reshape(k, n)
        Z = buf[k * n : 2 * k * n].reshape(k, n)
        np.copyto(D.reshape(cube.shape), cube, casting="unsafe")
        D -= self._mu[dt][:, None]
        if v is not None:
            D[:, ~v] = 0.0
        for Wb, a, b in self._W[dt]:  # rows a:b of Z = W[a:b, :b] D[:b]
            np.matmul(Wb, D[:b], out=Z[a:b])
        out[:] = np.einsum("ij,ij->j", Z, Z)
        if v is not None:
            out[~v] = np.nan
        return out.reshape(rows, cols)


def _triangular_blocks(W: np.ndarray, dtype, nblocks: int = 6):
    """Row blocks ``(W[a:b, :b], a, b)`` of a lower-triangular ``W``.

    ``W D`` as one GEMM per block row skips the zero upper blocks: 7/12 of a full GEMM's
    work with 6 blocks, close to a triangular product (1/2). BLAS ``trmm`` itself is not used
    because SciPy's wrapper holds the GIL (measured), which would serialise the worker threads;
    NumPy's matmul releases it.
    """
    k = W.shape[0]
    edges = np.unique(np.linspace(0, k, min(nblocks, k) + 1).round().astype(int))
    return [
        (np.ascontiguousarray(W[a:b, :b], dtype=dtype), int(a), int(b))
        for a, b in zip(edges[:-1], edges[1:], strict=True)
    ]


def _dependent_bands(cov: np.ndarray) -> np.ndarray:
    """Bands left over by a rank-revealing (pivoted) QR of the correlation matrix."""
    d = np.sqrt(np.maximum(np.diag(cov), np.finfo(float).tiny))
    corr = cov / np.outer(d, d)
    from scipy import linalg  # NumPy's QR does not pivot; only this error path needs it

    _, R, piv = linalg.qr(corr, pivoting=True)
    diag = np.abs(np.diag(R))
    rank = int(np.sum(diag > np.sqrt(SINGULAR_TOLERANCE) * diag[0]))
    rank = min(rank, len(piv) - 1)
    return np.sort(piv[rank:])


def rx(
    cube: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    regularize: float = 0.0,
    precision: str = "float64",
    wavelengths=None,
) -> np.ndarray:
    """Global RX of an in-memory cube (k, rows, cols); NaN where not ``valid``.

    Equal to ``spectral.rx(cube.transpose(1, 2, 0))`` on valid data.

    Parameters
    ----------
    cube : array (k, rows, cols)
        The image, k bands, of any numeric type (DN, radiance or reflectance).
    valid : bool array (rows, cols), optional
        Pixels that make up the background and are scored; all pixels when None.
    regularize : float
        Ridge added to the covariance's diagonal, as a fraction of the mean band variance
        (0: none; it changes the scores).
    precision : {"float64", "float32"}
        Arithmetic of the scoring product (float32: about 2× faster, relative error ~1e-5);
        the mean and covariance are always float64.
    wavelengths : array, optional
        Band centres (nm), to name the bands in error messages.

    Returns
    -------
    score : float64 array (rows, cols)
        Squared Mahalanobis distance ``(x − μ)ᵀ Σ⁻¹ (x − μ)`` of each pixel to the scene's mean
        μ and unbiased covariance Σ (high = anomalous); NaN where not valid.

    Raises
    ------
    InputError
        When there are too few valid pixels, or the covariance is singular (constant bands, or
        bands that are linear combinations of others).
    ParameterError
        When ``regularize`` < 0 or ``precision`` is unknown.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3: the global RX
    detector, Figure 11(B), compared in Figure 12).
    Reed, I.S.; Yu, X. Adaptive multiple-band CFAR detection of an optical pattern with unknown
    spectral distribution. IEEE Trans. Acoust. Speech Signal Process. 1990, 38, 1760–1770.

    Examples
    --------
    A planted anomaly scores highest, and the score is the squared Mahalanobis distance:

    >>> import numpy as np
    >>> import geoboresight as gb
    >>> cube = np.random.default_rng(0).normal(size=(5, 32, 32))
    >>> cube[:, 10, 20] += 6
    >>> scores = gb.rx(cube)
    >>> divmod(int(np.argmax(scores)), 32)
    (10, 20)
    >>> x = cube.reshape(5, -1) - cube.reshape(5, -1).mean(axis=1, keepdims=True)
    >>> d2 = np.einsum("ij,ik,kj->j", x, np.linalg.inv(np.cov(x)), x).reshape(32, 32)
    >>> bool(np.allclose(scores, d2))
    True
    """
    cube = np.asarray(cube)
    stats = background_stats([(cube, valid)], cube.shape[0])
    det = RXDetector(stats, regularize=regularize, wavelengths=wavelengths)
    return det.score_cube(cube, valid, precision)


def _window_bounds(n: int, size: int, inner: int):
    """Per index: outer [o0, o1) and inner [i0, i1) windows, both shifted to lie in [0, n)."""
    idx = np.arange(n)
    o0 = np.clip(idx - size // 2, 0, n - size)
    i0 = np.clip(idx - inner // 2, 0, n - inner)
    return o0, o0 + size, i0, i0 + inner


def check_windows(inner: int, outer: int, height: int, width: int) -> None:
    """Raise :class:`ParameterError` unless the local RX windows are odd, inner < outer, and
    the outer window fits in an image of ``height`` × ``width`` pixels."""
    if inner % 2 == 0 or outer % 2 == 0 or inner >= outer:
        raise ParameterError(
            "local RX windows must be odd sizes with inner < outer (e.g. 3 and 17)"
        )
    if outer > height or outer > width:
        raise ParameterError(
            f"the outer window ({outer} px) is larger than the image ({height} × {width})"
        )


def local_rx(
    cube: np.ndarray,
    detector: RXDetector,
    inner: int,
    outer: int,
    valid: np.ndarray | None = None,
    *,
    first_row: int = 0,
    height: int | None = None,
    rows: tuple[int, int] | None = None,
    precision: str = "float64",
) -> np.ndarray:
    """Local RX: the background mean comes from an ``outer`` × ``outer`` window around each pixel
    minus an ``inner`` × ``inner`` guard window; the covariance is the detector's (global) one.

    Windows follow Spectral Python's ``rx(X, window=(inner, outer), cov=C)``: the outer window
    and the inner window are shifted to stay inside the image (as its code does). Only valid
    pixels count.

    For strip-wise use: ``cube`` holds image lines ``first_row …`` of an image ``height`` lines
    tall (include ``outer - 1`` extra lines each side: the windows of the image's first and
    last lines are shifted inwards, so they reach that far), and ``rows`` = (start, stop) are the
    image lines to score. Returns (stop - start, cols) float64 scores, NaN where not valid.

    Parameters
    ----------
    cube : array (k, lines, cols)
        Image lines ``first_row …`` of the image (the whole image by default), any numeric type.
    detector : RXDetector
        Gives the covariance: each pixel's ``x − mean`` is whitened by the detector's
        ``W = L⁻¹`` (``Σ = L Lᵀ``, usually the scene's global covariance).
    inner : int
        Side (odd, pixels) of the guard window left out of the background mean.
    outer : int
        Side (odd, > ``inner``, at most the image's height and width) of the background window.
    valid : bool array (lines, cols), optional
        Valid pixels of ``cube``: only they enter the background means and are scored.
    first_row : int
        Image line of ``cube``'s first line.
    height : int, optional
        Lines in the whole image (default: ``cube``'s lines).
    rows : (int, int), optional
        ``(start, stop)`` image lines to score (default: all lines of ``cube``).
    precision : {"float64", "float32"}
        Arithmetic of the whitening product.

    Returns
    -------
    score : float64 array (stop − start, cols)
        ``‖W (x − m)‖²``, the squared Mahalanobis distance of each pixel to its local
        background mean ``m``; NaN where not valid or where the background window has no valid
        pixel.

    Raises
    ------
    ParameterError
        When the windows are not odd with ``inner < outer``, the outer window does not fit in
        the image, or the strip lacks the margin lines it needs.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3: the RX detector
    (RXD), Figure 11(B)).
    Reed, I.S.; Yu, X. Adaptive multiple-band CFAR detection of an optical pattern with unknown
    spectral distribution. IEEE Trans. Acoust. Speech Signal Process. 1990, 38, 1760–1770.
    """
    k, nr, nc = cube.shape
    height = nr if height is None else height
    r0, r1 = rows if rows is not None else (first_row, first_row + nr)
    check_windows(inner, outer, height, nc)
    v = np.ones((nr, nc), bool) if valid is None else valid
    data = np.where(v, cube, 0.0).astype(np.float64)
    # Integral images of the values and of the valid-pixel count.
    S = np.zeros((k, nr + 1, nc + 1))
    np.cumsum(np.cumsum(data, axis=1), axis=2, out=S[:, 1:, 1:])
    N = np.zeros((nr + 1, nc + 1))
    np.cumsum(np.cumsum(v, axis=0), axis=1, out=N[1:, 1:])

    ro0, ro1, ri0, ri1 = (a[r0:r1] - first_row for a in _window_bounds(height, outer, inner))
    if ro0.min() < 0 or ro1.max() > nr:
        raise ParameterError(
            "local RX strip lacks the margin lines it needs (outer - 1 above and below)"
        )
    co0, co1, ci0, ci1 = _window_bounds(nc, outer, inner)

    def box(T, a0, a1, b0, b1):
        A0, A1, B0, B1 = a0[:, None], a1[:, None], b0[None, :], b1[None, :]
        return T[..., A1, B1] - T[..., A0, B1] - T[..., A1, B0] + T[..., A0, B0]

    count = box(N, ro0, ro1, co0, co1) - box(N, ri0, ri1, ci0, ci1)
    total = box(S, ro0, ro1, co0, co1) - box(S, ri0, ri1, ci0, ci1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = total / count
    x = cube[:, r0 - first_row : r1 - first_row].astype(np.float64)
    D = (x - mean).reshape(k, -1)
    if precision == "float32":
        Z = detector.W.astype(np.float32) @ D.astype(np.float32)
    else:
        Z = detector.W @ D
    out = np.einsum("ij,ij->j", Z, Z, dtype=np.float64).reshape(r1 - r0, nc)
    ok = v[r0 - first_row : r1 - first_row] & (count > 0)
    out[~ok] = np.nan
    return out
