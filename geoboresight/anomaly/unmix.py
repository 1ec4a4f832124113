"""Linear spectral unmixing (paper §3.3, Eq. 10–11), and endmember spectra resampled to a sensor.

Eq. 10 models a pixel spectrum as ``ρ(λ) = Σₙ fₙ aₙ(λ) + φ`` with endmember spectra ``aₙ`` and
abundances ``fₙ``; Eq. 11 constrains them to ``fₙ ≥ 0`` and ``Σ fₙ = 1`` (fully constrained
least squares, FCLS; Heinz & Chang 2001). Three variants:

- ``"fcls"``: ``f ≥ 0``, ``Σ f = 1`` (Eq. 11);
- ``"nnls"``: ``f ≥ 0`` only;
- ``"ucls"``: unconstrained least squares.

Solver (vectorised over pixels, no per-pixel loop and no QP library): the optimum of a convex
least-squares problem with non-negativity is the equality-constrained (or plain) least-squares
solution on its own support. For ``N`` endmembers we solve, for all pixels at once, the
closed-form KKT system on each of the ``2ᴺ − 1`` supports — only the (N × N) Gram matrix and
the (pixels × N) products ``Eᵀx`` are needed — and keep, per pixel, the feasible candidate with
the smallest residual. This is exact (not an approximation with a weighted sum-to-one row);
it is practical up to ~12 endmembers, the usual case for ground-spectra libraries.

The residual ``φ`` reported per pixel is the RMS over bands of ``x − Σ fₙ aₙ``.

Endmember libraries (CSV, ENVI .sli) are read by :func:`geoboresight.io.spectra.read_spectral_library`.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..errors import InputError, ParameterError

METHODS = ("fcls", "nnls", "ucls")
#: Enumerating supports costs 2ᴺ small solves; beyond this, ask for fewer endmembers.
MAX_ENDMEMBERS = 14


def check_endmembers(E: np.ndarray, names=None) -> np.ndarray:
    """Validate an (N, k) endmember matrix: N ≤ k, finite, linearly independent."""
    E = np.asarray(E, dtype=np.float64)
    if E.ndim != 2:
        raise InputError("endmembers must be a 2-D array (endmembers × bands)")
    n, k = E.shape
    names = list(names) if names is not None else [f"endmember {i + 1}" for i in range(n)]
    if n < 1:
        raise InputError("no endmembers given")
    if n > k:
        raise InputError(
            f"{n} endmembers ({', '.join(names)}) but only {k} bands: linear unmixing needs at "
            "most as many endmembers as bands; drop endmembers or use more bands"
        )
    if n > MAX_ENDMEMBERS:
        raise InputError(f"{n} endmembers: at most {MAX_ENDMEMBERS} are supported; drop some")
    if not np.isfinite(E).all():
        bad = [names[i] for i in np.flatnonzero(~np.isfinite(E).all(axis=1))]
        raise InputError(f"endmember(s) {', '.join(bad)} contain NaN or infinite values")
    rank = np.linalg.matrix_rank(E)
    if rank < n:
        raise InputError(
            f"the {n} endmembers ({', '.join(names)}) are linearly dependent (rank {rank}): "
            "remove duplicated or proportional spectra"
        )
    return E


def unmix(X: np.ndarray, E: np.ndarray, method: str = "fcls", chunk: int = 65536):
    """Abundances and residual of pixels ``X`` (k, n) for endmembers ``E`` (N, k).

    Returns ``(abundances (N, n), residual_rms (n,))`` in float64.

    Parameters
    ----------
    X : array (k, n)
        Pixel spectra, k bands by n pixels, in the endmembers' units (any numeric type).
    E : array (N, k)
        Endmember spectra a_n(λ) on the same k bands: N ≤ k (and at most 14), finite and
        linearly independent.
    method : {"fcls", "nnls", "ucls"}
        Fully constrained (f ≥ 0, Σ f = 1, Eq. 11), non-negative only, or unconstrained least
        squares.
    chunk : int
        Pixels solved at a time (bounds memory).

    Returns
    -------
    abundances : float64 array (N, n)
        Fractional abundance f_n of each endmember in each pixel (Eq. 10).
    residual_rms : float64 array (n,)
        RMS over bands of ``x − Σ f_n a_n``: the unmixing error φ of Eq. 10.

    Raises
    ------
    ParameterError
        When ``method`` is unknown.
    InputError
        When the endmembers are unusable (see above) or ``X`` and ``E`` differ in bands.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eqs. 10–11: linear
    unmixing of the detected anomalies, the basis of the ROC curves of Figure 12).
    Heinz, D.C.; Chang, C.-I. Fully constrained least squares linear spectral mixture analysis
    method for material quantification in hyperspectral imagery. IEEE Trans. Geosci. Remote
    Sens. 2001, 39, 529–545.

    Examples
    --------
    Two pixels mixed from two endmembers on four bands, their abundances recovered:

    >>> import numpy as np
    >>> import geoboresight as gb
    >>> endmembers = np.array([[0.1, 0.2, 0.4, 0.8], [0.5, 0.6, 0.2, 0.1]])
    >>> pixels = endmembers.T @ np.array([[0.25, 1.0], [0.75, 0.0]])  # bands × pixels
    >>> abundances, residual = gb.unmix(pixels, endmembers)
    >>> abundances.round(6)
    array([[0.25, 1.  ],
           [0.75, 0.  ]])
    """
    if method not in METHODS:
        raise ParameterError(f"unmixing method must be one of {', '.join(METHODS)}, got {method!r}")
    E = check_endmembers(E)
    X = np.asarray(X)
    if X.shape[0] != E.shape[1]:
        raise InputError(f"pixels have {X.shape[0]} bands but endmembers {E.shape[1]}")
    N, k = E.shape
    n = X.shape[1]
    A = np.empty((N, n))
    res = np.empty(n)
    gram = E @ E.T
    supports = _supports(gram, method)
    for a in range(0, n, chunk):
        x = X[:, a : a + chunk].astype(np.float64, copy=False)
        g = E @ x  # (N, c) = Eᵀx per pixel
        xx = np.einsum("ij,ij->j", x, x)
        if method == "ucls":
            f = supports[0][1] @ g
        else:
            f = _best_support(g, xx, gram, supports, N)
        A[:, a : a + chunk] = f
        r = x - E.T @ f
        res[a : a + chunk] = np.sqrt(np.einsum("ij,ij->j", r, r) / k)
    return A, res


def unmix_cube(
    cube: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    endmembers: np.ndarray,
    method: str = "fcls",
    scale: float = 1.0,
) -> np.ndarray:
    """Abundances and residual of a (k, rows, cols) cube: (N + 1, rows, cols) float64, one
    abundance per endmember then the residual RMS; NaN where not ``valid``.

    ``scale`` turns the cube's values into the endmembers' units (e.g. 0.0001 for
    reflectance × 10000).

    Parameters
    ----------
    cube : array (k, rows, cols)
        The image, k bands, any numeric type.
    valid : bool array (rows, cols), optional
        Pixels to unmix; all pixels when None.
    endmembers : array (N, k)
        Endmember spectra on the cube's k bands (see :func:`unmix`).
    method : {"fcls", "nnls", "ucls"}
        Constraints on the abundances (see :func:`unmix`).
    scale : float
        Factor applied to the cube's values before unmixing.

    Returns
    -------
    float64 array (N + 1, rows, cols)
        The abundance of each endmember, in the order of ``endmembers``, then the residual RMS
        φ; NaN where not valid.

    Raises
    ------
    ParameterError, InputError
        As :func:`unmix`.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Eqs. 10–11, Figure
    12).
    Heinz, D.C.; Chang, C.-I. Fully constrained least squares linear spectral mixture analysis
    method for material quantification in hyperspectral imagery. IEEE Trans. Geosci. Remote
    Sens. 2001, 39, 529–545.
    """
    k, rows, cols = cube.shape
    flat = np.asarray(cube).reshape(k, -1)
    v = np.ones(flat.shape[1], bool) if valid is None else np.asarray(valid).ravel()
    out = np.full((len(endmembers) + 1, flat.shape[1]), np.nan)
    if v.any():
        A, res = unmix(flat[:, v] * scale, endmembers, method)
        out[:-1, v] = A
        out[-1, v] = res
    return out.reshape(-1, rows, cols)


def select_endmembers(spectra: np.ndarray, names, wanted=None) -> tuple[np.ndarray, list[str]]:
    """The spectra (rows of ``spectra``) named in ``wanted`` (all when empty), in that order.

    Raises :class:`InputError` naming the missing endmembers and the available ones.
    """
    names = list(names)
    wanted = [n for n in (wanted or ()) if n]
    if not wanted:
        return np.asarray(spectra), names
    missing = [n for n in wanted if n not in names]
    if missing:
        raise InputError(
            f"endmember(s) {', '.join(missing)} not in the library (it has: {', '.join(names)})"
        )
    return np.asarray(spectra)[[names.index(n) for n in wanted]], wanted


def _supports(gram: np.ndarray, method: str):
    """Per support S: (indexes, M (|S|, |S|) acting on g_S, c (|S|,)) so that f_S = M g_S + c."""
    N = gram.shape[0]
    out = []
    sizes = [N] if method == "ucls" else range(1, N + 1)
    for size in sizes:
        for S in itertools.combinations(range(N), size):
            S = np.array(S)
            G = gram[np.ix_(S, S)]
            Ginv = np.linalg.inv(G)
            if method == "fcls":
                # min ‖x − E_Sᵀ f‖² s.t. 1ᵀf = 1:  f = G⁻¹g − G⁻¹1 (1ᵀG⁻¹g − 1) / (1ᵀG⁻¹1)
                u = Ginv.sum(axis=1)  # G⁻¹1
                s = u.sum()
                M = Ginv - np.outer(u, u) / s
                c = u / s
            else:
                M, c = Ginv, np.zeros(len(S))
            out.append((S, M, c))
    return out


def _best_support(g, xx, gram, supports, N):
    """Per pixel, the feasible (f ≥ 0) support solution with the least squared residual."""
    n = g.shape[1]
    best = np.full(n, np.inf)
    f_best = np.zeros((N, n))
    for S, M, c in supports:
        fS = M @ g[S] + c[:, None]
        feasible = (fS >= -1e-12).all(axis=0)
        # ‖x − Eᵀf‖² = xᵀx − 2 fᵀg + fᵀ G f
        GS = gram[np.ix_(S, S)]
        cost = xx - 2 * np.einsum("ij,ij->j", fS, g[S]) + np.einsum("ij,ij->j", fS, GS @ fS)
        take = feasible & (cost < best)
        if take.any():
            best[take] = cost[take]
            f_best[:, take] = 0.0
            f_best[np.ix_(S, np.flatnonzero(take))] = np.maximum(fS[:, take], 0.0)
    return f_best


def resample(
    wavelengths_nm: np.ndarray,
    spectra: np.ndarray,
    centres_nm: np.ndarray,
    fwhm_nm: np.ndarray | None = None,
    names=None,
) -> np.ndarray:
    """Resample library spectra (N, w) to sensor bands with Gaussian spectral response functions.

    Each band's response is a Gaussian centred on ``centres_nm`` with full width at half maximum
    ``fwhm_nm``; the library is linearly interpolated onto a 0.5 nm grid and integrated against
    it. When the library is already sampled at the band centres (within 0.01 nm) it is used as
    it is. Raises :class:`InputError` naming the bands the library does not cover (±1 FWHM).
    """
    wl = np.asarray(wavelengths_nm, dtype=float)
    spectra = np.atleast_2d(np.asarray(spectra, dtype=float))
    c = np.asarray(centres_nm, dtype=float)
    if wl.size == c.size and np.allclose(wl, c, atol=0.01):
        return spectra.copy()
    fw = (
        np.full(c.size, np.median(np.diff(np.sort(c))) if c.size > 1 else 10.0)
        if fwhm_nm is None
        else np.asarray(fwhm_nm, float)
    )
    lo_need, hi_need = c - fw, c + fw
    uncovered = np.flatnonzero((lo_need < wl.min() - 1e-6) | (hi_need > wl.max() + 1e-6))
    # A band whose centre is covered, with only its far tail outside, is acceptable.
    centre_out = np.flatnonzero((c < wl.min()) | (c > wl.max()))
    tail_out = np.setdiff1d(uncovered, centre_out)
    if centre_out.size or tail_out.size > 2:
        bad = centre_out if centre_out.size else tail_out
        raise InputError(
            f"the endmember library covers {wl.min():.1f}–{wl.max():.1f} nm but the image's "
            f"bands span {c.min():.1f}–{c.max():.1f} nm: {bad.size} band(s) are not covered "
            f"(e.g. {', '.join(f'{v:.1f} nm' for v in c[bad[:5]])}). Use a library covering the "
            "image's range, or exclude those bands (exclude_nm)"
        )
    grid = np.arange(
        max(wl.min(), (c - 3 * fw).min()), min(wl.max(), (c + 3 * fw).max()) + 0.5, 0.5
    )
    fine = np.array([np.interp(grid, wl, s) for s in spectra])  # (N, g)
    sd = fw / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    srf = np.exp(-0.5 * ((grid[None, :] - c[:, None]) / sd[:, None]) ** 2)  # (bands, g)
    srf /= srf.sum(axis=1, keepdims=True)
    return fine @ srf.T
