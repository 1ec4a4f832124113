"""Ordinary kriging of scattered heights onto the image grid, in bounded memory (paper §3.2).

The paper interpolates the relative DEM by kriging. PyKrige's ordinary kriging builds the full
``N × N`` kriging matrix (and, in its default vectorised mode, an ``N × grid`` distance matrix),
so a flight line with tens of thousands of control points does not fit in memory. Here:

- the variogram model is fitted once by PyKrige on a random subset of the points
  (``max_fit_points``: the experimental variogram needs all pairwise distances);
- the grid is kriged block by block with a local neighbourhood of the ``n_closest_points``
  nearest control points (PyKrige's moving-window kriging, C backend). Each block builds a
  PyKrige :class:`~pykrige.ok.OrdinaryKriging` with the fitted variogram on exactly the control
  points that are among the nearest neighbours of some target of the block, so the result is
  identical to PyKrige's global moving-window kriging while memory is bounded by a block.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from ..errors import InputError, ParameterError
from ..progress import Progress, as_progress

MODELS = ("spherical", "exponential", "gaussian", "linear", "power")
#: The variogram model fitted by default.
VARIOGRAM = "spherical"
#: Control points in each local kriging neighbourhood.
N_CLOSEST_POINTS = 32


@dataclass(frozen=True)
class Variogram:
    """A fitted PyKrige variogram model (parameters in PyKrige's order)."""

    model: str
    parameters: tuple[float, ...]
    n_points: int  # control points used for the fit

    def describe(self) -> str:
        if self.model in ("linear",):
            names = ("slope", "nugget")
        elif self.model == "power":
            names = ("scale", "exponent", "nugget")
        else:
            names = ("partial_sill", "range_px", "nugget")
        return ", ".join(f"{n}={v:.4g}" for n, v in zip(names, self.parameters, strict=False))


def _check_points(x, y, z):
    x, y, z = (np.asarray(v, np.float64).ravel() for v in (x, y, z))
    if not (x.size == y.size == z.size):
        raise InputError("control point coordinates and values differ in length")
    ok = np.isfinite(x) & np.isfinite(y) & np.isfinite(z)
    return x[ok], y[ok], z[ok]


def fit_variogram(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    model: str = VARIOGRAM,
    nlags: int = 20,
    max_fit_points: int = 2000,
    seed: int = 0,
) -> Variogram:
    """Fit ``model`` to the experimental variogram of (a random subset of) the points (PyKrige)."""
    from pykrige.ok import OrdinaryKriging

    if model not in MODELS:
        raise ParameterError(f"parameter 'variogram': {model!r} is not one of {', '.join(MODELS)}")
    x, y, z = _check_points(x, y, z)
    if x.size < 10:
        raise InputError(
            f"only {x.size} control points: too few to fit a variogram (at least 10 are needed); "
            "use a larger matching window or lower the reliability thresholds"
        )
    if not np.ptp(z) > 0:
        raise ParameterError(
            "variogram fit failed: all control points have the same height, so there is no "
            "spatial variation to model"
        )
    if x.size > max_fit_points:
        pick = np.random.default_rng(seed).choice(x.size, int(max_fit_points), replace=False)
        x, y, z = x[pick], y[pick], z[pick]
    try:
        ok = OrdinaryKriging(
            x,
            y,
            z,
            variogram_model=model,
            nlags=int(nlags),
            weight=True,
            enable_statistics=False,
        )
        params = tuple(float(p) for p in ok.variogram_model_parameters)
    except Exception as exc:  # PyKrige/SciPy raise assorted errors for degenerate data
        raise ParameterError(
            f"variogram fit failed for the {model} model ({exc}); try another model "
            "(--variogram exponential/linear) or more control points"
        ) from None
    bad = not all(math.isfinite(p) for p in params)
    if model in ("spherical", "exponential", "gaussian"):
        bad = bad or params[0] <= 0 or params[1] <= 0 or params[2] < 0
    else:
        bad = bad or params[0] <= 0 or params[-1] < 0
    if bad:
        raise ParameterError(
            f"variogram fit failed: the {model} model fitted to the control points has "
            f"unusable parameters ({params}); try another model or more control points"
        )
    return Variogram(model, params, int(x.size))


def krige_points(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    xt: np.ndarray,
    yt: np.ndarray,
    variogram: Variogram,
    n_closest_points: int = N_CLOSEST_POINTS,
    backend: str = "C",
    chunk: int = 8192,
    max_local_points: int = 2500,
    progress: Progress | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Ordinary kriging estimate and variance at targets ``(xt, yt)``, chunk by chunk.

    Targets are processed in chunks of ``chunk`` points in the given order (give them spatially
    sorted, e.g. row by row, so that a chunk needs few control points). A chunk whose targets
    need more than ``max_local_points`` control points is split: PyKrige builds the dense
    kriging matrix of the points it is given, so this bounds memory (≈ 8 · 3 · m² bytes).
    """
    from pykrige.ok import OrdinaryKriging

    progress = as_progress(progress)
    if backend not in ("C", "loop"):
        raise ParameterError(f"parameter 'backend': 'C' or 'loop', got {backend!r}")
    x, y, z = _check_points(x, y, z)
    k = int(n_closest_points)
    if k < 2:
        raise ParameterError(f"parameter 'n_closest_points': at least 2, got {n_closest_points}")
    k = min(k, x.size)
    xt = np.asarray(xt, np.float64).ravel()
    yt = np.asarray(yt, np.float64).ravel()
    tree = cKDTree(np.column_stack([x, y]))
    est = np.empty(xt.size)
    var = np.empty(xt.size)
    n_chunks = max(1, math.ceil(xt.size / chunk))
    params = {
        "variogram_model": variogram.model,
        "variogram_parameters": list(variogram.parameters),
        "enable_statistics": False,
        "exact_values": False,  # noisy heights: smooth at the control points (nugget)
    }

    def solve(sl: slice) -> None:
        _, idx = tree.query(np.column_stack([xt[sl], yt[sl]]), k=k)
        local = np.unique(idx)
        if local.size > max_local_points and sl.stop - sl.start > 1:
            # Targets spread too far apart (e.g. cross-validation): split the chunk.
            mid = (sl.start + sl.stop) // 2
            solve(slice(sl.start, mid))
            solve(slice(mid, sl.stop))
            return
        ok = OrdinaryKriging(x[local], y[local], z[local], **params)
        e, v = ok.execute("points", xt[sl], yt[sl], n_closest_points=k, backend=backend)
        est[sl] = np.asarray(e)
        var[sl] = np.asarray(v)

    for i in range(n_chunks):
        solve(slice(i * chunk, min((i + 1) * chunk, xt.size)))
        progress.update((i + 1) / n_chunks, "kriging")
    return est, np.maximum(var, 0.0)


def krige_grid(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    shape: tuple[int, int],
    variogram: Variogram,
    mask: np.ndarray | None = None,
    n_closest_points: int = N_CLOSEST_POINTS,
    backend: str = "C",
    block_rows: int = 32,
    progress: Progress | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Krige onto every pixel ``(row, col)`` of a ``shape`` grid (x = column, y = row).

    Pixels where ``mask`` is False (clouds, nodata) are skipped and returned as NaN.
    Returns float32 (estimate, kriging variance).
    """
    height, width = shape
    if mask is None:
        mask = np.ones(shape, bool)
    rows, cols = np.nonzero(mask)  # row-major: spatially sorted along the flight line
    est, var = krige_points(
        x,
        y,
        z,
        cols.astype(float),
        rows.astype(float),
        variogram,
        n_closest_points=n_closest_points,
        backend=backend,
        chunk=max(1, int(block_rows)) * width,
        progress=progress,
    )
    dem = np.full(shape, np.nan, np.float32)
    kv = np.full(shape, np.nan, np.float32)
    dem[rows, cols] = est
    kv[rows, cols] = var
    return dem, kv


def cross_validate(
    x: np.ndarray,
    y: np.ndarray,
    z: np.ndarray,
    variogram: Variogram,
    n_closest_points: int = N_CLOSEST_POINTS,
    backend: str = "C",
    fraction: float = 0.1,
    max_points: int = 2000,
    seed: int = 0,
) -> dict:
    """Hold-out cross-validation: krige a random ``fraction`` of points from the others.

    Returns RMSE, MAE and mean error (m), and the mean squared standardised error
    (error² / kriging variance; ≈ 1 when the kriging variance is honest).
    """
    x, y, z = _check_points(x, y, z)
    rng = np.random.default_rng(seed)
    n_test = int(min(max_points, max(1, round(fraction * x.size))))
    if x.size - n_test < 3:
        raise InputError(f"only {x.size} control points: too few for cross-validation")
    test = np.zeros(x.size, bool)
    test[rng.choice(x.size, n_test, replace=False)] = True
    order = np.lexsort((x[test], y[test]))
    xt, yt, zt = x[test][order], y[test][order], z[test][order]
    est, var = krige_points(
        x[~test],
        y[~test],
        z[~test],
        xt,
        yt,
        variogram,
        n_closest_points=n_closest_points,
        backend=backend,
    )
    err = est - zt
    with np.errstate(divide="ignore", invalid="ignore"):
        msse = float(np.nanmean(err**2 / var))
    return {
        "n": int(n_test),
        "rmse_m": float(np.sqrt(np.mean(err**2))),
        "mae_m": float(np.mean(np.abs(err))),
        "mean_error_m": float(np.mean(err)),
        "mean_squared_standardised_error": msse,
    }
