"""Image-to-map transforms fitted to ground control points: polynomials of order 1–3 and the
thin-plate spline, with per-point residuals and their RMSE.

Pixel coordinates follow GDAL and QGIS's Georeferencer: ``pixel`` (column) and ``line`` are
continuous, ``(0, 0)`` is the top-left corner of the top-left pixel, so the centre of pixel
``[i, j]`` is ``(j + 0.5, i + 0.5)``. Map coordinates are those of the GCPs' CRS.

The polynomial is GDAL's ``gdalwarp -order n`` model (a full bivariate polynomial of total
degree ``n`` in each map coordinate, least squares); the thin-plate spline is Bookstein's
(SciPy's :class:`~scipy.interpolate.RBFInterpolator`, ``thin_plate_spline`` kernel with its
affine part), GDAL's ``-tps``. Coordinates are centred and scaled before the fit, so that a
third-order polynomial on a 10,000-line flight line stays well conditioned.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ParameterError, shown

#: GCPs a polynomial of each order needs: its number of terms, (n + 1)(n + 2) / 2.
MIN_GCPS = {1: 3, 2: 6, 3: 10}
#: GCPs the thin-plate spline needs (its affine part).
MIN_GCPS_TPS = 3
#: Singular values below this fraction of the largest make the GCP layout degenerate
#: (collinear or clustered for the order).
RANK_TOLERANCE = 1e-9
#: Above this many GCPs the thin-plate spline's cross-validation is 10-fold, not leave-one-out.
LOO_MAX = 200
METHODS = ("polynomial", "tps")


def _terms(u: np.ndarray, v: np.ndarray, order: int) -> np.ndarray:
    """Design matrix of a full polynomial of total degree ``order``: 1, u, v, u², uv, v², ..."""
    cols = [u**a * v ** (d - a) for d in range(order + 1) for a in range(d, -1, -1)]
    return np.stack(cols, axis=-1)


@dataclass(frozen=True)
class _Scale:
    centre: np.ndarray
    scale: float

    @classmethod
    def of(cls, pts: np.ndarray) -> _Scale:
        centre = pts.mean(axis=0)
        scale = float(np.abs(pts - centre).max()) or 1.0
        return cls(centre, scale)

    def __call__(self, pts: np.ndarray) -> np.ndarray:
        return (pts - self.centre) / self.scale


@dataclass(frozen=True)
class Fit:
    """A fitted image-to-map transform and how well it fits its GCPs.

    ``pixel_line`` (n, 2) and ``xy`` (n, 2): the GCPs; ``residuals`` (n, 2): map minus
    predicted coordinates (for the thin-plate spline, which passes through every GCP, the
    cross-validated residuals: each GCP predicted by the spline fitted without it);
    ``rmse``: root mean square of the residual lengths (map units); ``rmse_px``: the same in
    pixels of the product (map residuals divided by the local pixel size).
    """

    method: str
    order: int | None
    pixel_line: np.ndarray
    xy: np.ndarray
    residuals: np.ndarray
    rmse: float
    rmse_px: float
    smoothing: float = 0.0
    _predict: object = field(default=None, repr=False, compare=False)
    #: Numbers (1-based, in the caller's list) of GCPs that repeat an earlier one exactly
    #: (same image position, same map point): kept by the polynomial (least squares weighs
    #: them twice, harmlessly), left out of the thin-plate spline (which interpolates each
    #: point once).
    repeated: tuple[int, ...] = ()

    def __call__(self, pixel, line) -> tuple[np.ndarray, np.ndarray]:
        """Map coordinates (x, y) of continuous pixel coordinates (arrays of any shape)."""
        pixel = np.asarray(pixel, "float64")
        line = np.asarray(line, "float64")
        shape = np.broadcast(pixel, line).shape
        pts = np.column_stack(
            [np.broadcast_to(pixel, shape).ravel(), np.broadcast_to(line, shape).ravel()]
        )
        xy = self._predict(pts)
        return xy[:, 0].reshape(shape), xy[:, 1].reshape(shape)

    def residual_px(self) -> np.ndarray:
        """Residual length of each GCP in product pixels."""
        return np.hypot(*self.residuals.T) / _pixel_size(self, self.pixel_line)

    def report(self) -> dict:
        """The fit as a JSON-ready dict: method, order, RMSE and one row per GCP."""
        res_px = self.residual_px()
        return {
            "method": self.method,
            "order": self.order,
            "smoothing": self.smoothing,
            "gcps": int(len(self.xy)),
            "rmse": float(self.rmse),
            "rmse_px": float(self.rmse_px),
            "residuals_are": "cross-validated" if self.method == "tps" else "least-squares",
            "points": [
                {
                    "pixel": float(p[0]),
                    "line": float(p[1]),
                    "x": float(q[0]),
                    "y": float(q[1]),
                    "dx": float(r[0]),
                    "dy": float(r[1]),
                    "residual": float(np.hypot(*r)),
                    "residual_px": float(rp),
                }
                for p, q, r, rp in zip(
                    self.pixel_line, self.xy, self.residuals, res_px, strict=True
                )
            ],
        }


def _pixel_size(fit_or_predict, pts: np.ndarray) -> np.ndarray:
    """Local pixel size (map units) at points: the mean length of the map steps of one pixel
    and one line."""
    predict = fit_or_predict._predict if isinstance(fit_or_predict, Fit) else fit_or_predict
    base = predict(pts)
    dp = predict(pts + [1.0, 0.0]) - base
    dl = predict(pts + [0.0, 1.0]) - base
    size = 0.5 * (np.hypot(*dp.T) + np.hypot(*dl.T))
    return np.where(size > 0, size, 1.0)


def _check_points(pixel_line, xy, label: str) -> tuple[np.ndarray, np.ndarray]:
    pl = np.asarray(pixel_line, "float64").reshape(-1, 2)
    q = np.asarray(xy, "float64").reshape(-1, 2)
    if len(pl) != len(q):
        raise ParameterError(f"{label}: {len(pl)} pixel positions for {len(q)} map positions")
    bad = ~(np.isfinite(pl).all(axis=1) & np.isfinite(q).all(axis=1))
    if bad.any():
        raise ParameterError(
            f"{label}: GCP(s) {', '.join(str(i + 1) for i in np.flatnonzero(bad))} have "
            "missing or non-numeric coordinates"
        )
    return pl, q


def _polynomial_predict(pl: np.ndarray, q: np.ndarray, order: int, label: str):
    s_in, s_out = _Scale.of(pl), _Scale.of(q)
    A = _terms(*s_in(pl).T, order)
    sv = np.linalg.svd(A, compute_uv=False)
    if sv[-1] < RANK_TOLERANCE * sv[0]:
        raise ParameterError(
            f"{label}: the {len(pl)} GCPs are collinear (or too clustered) for a polynomial of "
            f"order {order}: spread them over the image, in both directions"
        )
    coef, *_ = np.linalg.lstsq(A, s_out(q), rcond=None)

    def predict(pts: np.ndarray) -> np.ndarray:
        return _terms(*s_in(pts).T, order) @ coef * s_out.scale + s_out.centre

    return predict


def _tps_predict(pl: np.ndarray, q: np.ndarray, smoothing: float):
    from scipy.interpolate import RBFInterpolator

    s_in, s_out = _Scale.of(pl), _Scale.of(q)
    rbf = RBFInterpolator(
        s_in(pl), s_out(q), kernel="thin_plate_spline", degree=1, smoothing=smoothing
    )

    def predict(pts: np.ndarray) -> np.ndarray:
        out = np.empty((len(pts), 2))
        for i in range(0, len(pts), 65536):  # RBF evaluation memory: chunk × GCPs
            out[i : i + 65536] = rbf(s_in(pts[i : i + 65536]))
        return out * s_out.scale + s_out.centre

    return predict


def _collinear(pl: np.ndarray) -> bool:
    centred = pl - pl.mean(axis=0)
    sv = np.linalg.svd(centred, compute_uv=False)
    return sv.size < 2 or sv[1] < RANK_TOLERANCE * max(sv[0], 1e-300) or sv[0] == 0


def _same_rows(a: np.ndarray) -> list[np.ndarray]:
    """Groups (indices) of rows of ``a`` equal to within a millionth of the points' spread."""
    tol = 1e-6 * max(float(np.ptp(a, axis=0).max()) if len(a) else 0.0, 1e-12)
    key = np.round(a / tol).astype("int64") if np.isfinite(a / tol).all() else a
    _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
    inverse = np.asarray(inverse).reshape(-1)
    return [np.flatnonzero(inverse == k) for k in np.flatnonzero(counts > 1)]


def _numbers(idx) -> str:
    n = [str(int(i)) for i in idx]
    return " and ".join(n) if len(n) <= 2 else ", ".join(n[:-1]) + " and " + n[-1]


def exact_repeats(pl, q) -> np.ndarray:
    """True for each GCP that repeats an earlier one exactly: the same image position (to a
    millionth of the points' spread, as :func:`check_degenerate` compares them) and the same
    map point."""
    pl = np.asarray(pl, "float64").reshape(-1, 2)
    q = np.asarray(q, "float64").reshape(-1, 2)
    out = np.zeros(len(pl), bool)
    for group in _same_rows(pl):
        for k, i in enumerate(group[1:], start=1):
            out[i] = any(np.array_equal(q[i], q[j]) for j in group[:k])
    return out


def check_degenerate(pl, q, number, label: str = "GCPs") -> None:
    """Refuse a GCP set no transform can be fitted to, naming the GCPs (by ``number``) and
    what is wrong: a GCP repeated at one image position, GCPs on one line in the image, all
    GCPs on one map point or on one line on the map, two image positions given one map
    point."""
    pl = np.asarray(pl, "float64").reshape(-1, 2)
    q = np.asarray(q, "float64").reshape(-1, 2)
    number = np.asarray(number).reshape(-1)
    for group in _same_rows(pl):
        p = pl[group[0]]
        same_map = bool(np.all(np.ptp(q[group], axis=0) == 0))
        raise ParameterError(
            f"{label}: GCPs {_numbers(number[group])} are at the same image position (pixel "
            f"{p[0]:g}, line {p[1]:g})"
            + (
                ": remove the repeated one"
                if same_map
                else " with different map points: one of them is wrong; remove it"
            )
        )
    if _collinear(pl):
        raise ParameterError(
            f"{label}: the {len(pl)} GCPs lie on one line in the image: spread them over the "
            "image, in both directions"
        )
    if np.all(np.ptp(q, axis=0) == 0):
        raise ParameterError(
            f"{label}: the {len(q)} GCPs share one map point ({q[0, 0]:.10g}, {q[0, 1]:.10g}): "
            "give each GCP the map coordinates of its own place (a copied row or column?)"
        )
    for group in _same_rows(q):
        m = q[group[0]]
        raise ParameterError(
            f"{label}: GCPs {_numbers(number[group])} lie at different image positions but "
            f"share the map point ({m[0]:.10g}, {m[1]:.10g}): one of them is wrong; correct "
            "or remove it"
        )
    if _collinear(q):
        raise ParameterError(
            f"{label}: the map points of the {len(q)} GCPs lie on one line: check their x and "
            "y columns (a copied or swapped column?)"
        )


def fit_transform(
    pixel_line,
    xy,
    valid=None,
    *,
    method: str = "polynomial",
    order: int = 1,
    smoothing: float = 0.0,
    label: str = "GCPs",
) -> Fit:
    """Fit an image-to-map transform to ground control points.

    Parameters
    ----------
    pixel_line : (n, 2) array
        GCP positions in the image: continuous (pixel, line), ``(0, 0)`` the top-left corner.
    xy : (n, 2) array
        The same GCPs' map coordinates (x, y) in the map CRS.
    valid : (n,) bool array, optional
        GCPs to use (e.g. the ``enable`` column of a QGIS ``.points`` file); all by default.
    method : {"polynomial", "tps"}
        A polynomial of total degree ``order`` (least squares; GDAL's ``-order``) or the
        thin-plate spline (exact at the GCPs, or smoothed; GDAL's ``-tps``).
    order : {1, 2, 3}
        Polynomial order; it needs 3, 6 or 10 GCPs not on one line.
    smoothing : float
        Thin-plate spline only: 0 interpolates the GCPs exactly; larger values trade
        closeness for smoothness (for automatic tie points, which carry matching noise).
    label : str
        Names the GCPs in error messages (e.g. the file they came from).

    Returns
    -------
    Fit
        Callable on pixel coordinates, with residuals per GCP and their RMSE in map units and
        in product pixels.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: raw AISA-Dual
    data without GPS/INS are "geo-rectified by conventional methods"; Figure 10 overlays the
    results on a topographic map and an orthophoto).
    Bookstein, F.L. Principal warps: thin-plate splines and the decomposition of deformations.
    IEEE Trans. Pattern Anal. Mach. Intell. 1989, 11, 567–585. https://doi.org/10.1109/34.24792
    """
    if method not in METHODS:
        raise ParameterError(
            f"parameter 'method': {shown(method)} is not one of {', '.join(METHODS)}"
        )
    pl, q = _check_points(pixel_line, xy, label)
    number = np.arange(1, len(pl) + 1)  # each GCP's number in the caller's list (1-based)
    if valid is not None:
        keep = np.asarray(valid, bool).reshape(-1)
        if len(keep) != len(pl):
            raise ParameterError(f"{label}: {len(keep)} enable flags for {len(pl)} GCPs")
        if len(pl) and not keep.any():
            raise ParameterError(
                f"{label}: all {len(pl)} GCPs are disabled (enable = 0): enable the ones to use"
            )
        pl, q, number = pl[keep], q[keep], number[keep]
    need = MIN_GCPS.get(order) if method == "polynomial" else MIN_GCPS_TPS
    if method == "polynomial" and need is None:
        raise ParameterError(f"parameter 'order': {order} is not 1, 2 or 3")
    if len(pl) < need:
        what = f"a polynomial of order {order}" if method == "polynomial" else "a thin-plate spline"
        raise ParameterError(
            f"{label}: {len(pl)} GCP(s) given but {what} needs at least {need}: add GCPs"
            + (" or lower the order" if method == "polynomial" and order > 1 else "")
        )
    repeat = exact_repeats(pl, q)
    repeated = tuple(int(n) for n in number[repeat])
    check_degenerate(pl[~repeat], q[~repeat], number[~repeat], label)
    if method == "tps":
        pl, q = pl[~repeat], q[~repeat]
    if method == "polynomial":
        predict = _polynomial_predict(pl, q, order, label)
        residuals = q - predict(pl)
    else:
        try:
            predict = _tps_predict(pl, q, smoothing)
            residuals = _tps_cross_validated(pl, q, smoothing, predict)
        except np.linalg.LinAlgError:
            raise ParameterError(
                f"{label}: the thin-plate spline through these {len(pl)} GCPs has no solution "
                "(GCPs too close together for their map points): remove near-duplicate GCPs "
                "or use --method polynomial"
            ) from None
    rmse = float(np.sqrt(np.mean(np.sum(residuals**2, axis=1))))
    size = _pixel_size(predict, pl)
    rmse_px = float(np.sqrt(np.mean(np.sum(residuals**2, axis=1) / size**2)))
    return Fit(
        method=method,
        order=order if method == "polynomial" else None,
        pixel_line=pl,
        xy=q,
        residuals=residuals,
        rmse=rmse,
        rmse_px=rmse_px,
        smoothing=float(smoothing) if method == "tps" else 0.0,
        _predict=predict,
        repeated=repeated,
    )


def _tps_cross_validated(pl, q, smoothing, predict) -> np.ndarray:
    """Residual of each GCP predicted by the spline fitted without it (leave-one-out up to
    :data:`LOO_MAX` GCPs, else 10-fold): a spline through every GCP has zero fit residuals,
    which say nothing about its accuracy between them."""
    n = len(pl)
    folds = np.arange(n) if n <= LOO_MAX else np.arange(n) % 10
    out = np.full((n, 2), np.nan)
    for f in np.unique(folds):
        test = folds == f
        train = ~test
        if train.sum() < MIN_GCPS_TPS + 1 or _collinear(pl[train]):
            continue  # this GCP is needed to span the image: no honest cross-check exists
        out[test] = q[test] - _tps_predict(pl[train], q[train], smoothing)(pl[test])
    if np.isnan(out).all():
        return q - predict(pl)
    return np.where(np.isnan(out), 0.0, out)


def outside_image(pixel_line, width: int, height: int) -> np.ndarray:
    """Boolean mask of GCPs outside the image ``[0, width] × [0, height]`` (continuous pixel
    coordinates; QGIS's negative line numbers are already turned positive by the reader).

    Parameters
    ----------
    pixel_line : (n, 2) array
        GCP positions (pixel, line).
    width, height : int
        Image size in pixels and lines.

    Returns
    -------
    (n,) bool array

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2).
    """
    pl = np.asarray(pixel_line, "float64").reshape(-1, 2)
    return (pl[:, 0] < 0) | (pl[:, 0] > width) | (pl[:, 1] < 0) | (pl[:, 1] > height)
