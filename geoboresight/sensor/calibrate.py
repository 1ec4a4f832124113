"""Boresight angles (and the clock offset) measured on tie points by robust least squares.

A tie point is an image position ``(pixel, line)`` of one sensor whose ground position is
known: from a GCP, or from a feature matched to a reference orthophoto. The forward model
(the navigation, the lever arm, the sensor model and the DEM: the paper's Eq. 1–2) puts
every image position on the ground for trial boresight angles ``(roll, pitch, heading)`` and
a trial clock offset; the angles are those that bring the tie points' image positions onto
their ground positions.

The residuals are measured in the image: each ground misfit is carried back into image
pixels through the forward model's local derivative ``∂(x, y)/∂(pixel, line)`` at the tie
point, so that one robust scale (pixels) serves a nadir and an off-nadir point, a VNIR and a
SWIR pixel. SciPy's trust-region least squares with a robust loss (``soft_l1`` or ``huber``)
finds the angles; tie points whose residual stays beyond three robust standard deviations are
rejected and the angles solved again. The standard errors come from the Jacobian at the
solution, ``σ²·(JᵀJ)⁻¹`` with ``σ²`` the residuals' variance.

Before solving, the tie points are checked for what they can determine: too few of them,
all on one image line (the boresight cannot be told from that instant's attitude), or a
Jacobian whose columns are dependent (e.g. the clock offset and the pitch on a line flown
without any attitude change) are refused with the reason.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: Fewest tie points accepted (two equations each; redundancy for the rejection and the
#: standard errors).
MIN_TIE_POINTS = 6
#: Robust loss scale (image pixels): residuals beyond it count less than quadratically.
F_SCALE_PX = 0.5
#: A tie point is rejected beyond this many robust standard deviations (of each axis: a
#: residual length beyond 3.72 σ has a chance of 0.1 % for a Gaussian matching error)...
REJECT_SIGMA = 3.72
#: ...and never below this residual (pixels): matching noise alone reaches it.
REJECT_FLOOR_PX = 0.5
#: Solves at most (the first, then one after each rejection).
ROUNDS = 6
#: Step (pixels) of the finite differences of the forward model in the image.
STEP_PX = 0.5
#: Step of the finite differences in the parameters (degrees; seconds for the clock).
STEP_DEG = 1e-3
STEP_S = 1e-4
#: Largest condition number of the (column-normalised) Jacobian accepted.
MAX_CONDITION = 1e5
LOSSES = ("soft_l1", "huber", "linear", "cauchy")
PARAMETERS = ("roll", "pitch", "heading", "time offset")


@dataclass(frozen=True)
class BoresightCalibration:
    """Boresight angles measured on tie points.

    ``angles_deg`` (roll, pitch, heading) and their standard errors ``angles_se_deg``;
    ``time_offset_s`` and ``time_offset_se_s`` (NaN when the offset was held); per tie point
    (n,): ``used`` (kept in the final solution), ``rejected`` (why not: ``""`` when used)
    and the residuals at the solution, image ``residuals_px`` (n, 2: pixel, line) and ground
    ``residuals_m`` (n, 2: x, y, model minus tie point); ``rms``/``p90`` of the used
    residuals' lengths in pixels and metres.
    """

    angles_deg: np.ndarray
    angles_se_deg: np.ndarray
    time_offset_s: float
    time_offset_se_s: float
    used: np.ndarray
    rejected: np.ndarray
    residuals_px: np.ndarray
    residuals_m: np.ndarray
    rms_px: float
    p90_px: float
    rms_m: float
    p90_m: float
    loss: str
    iterations: int

    def report(self) -> dict:
        """JSON-ready summary (angles, standard errors, clock offset, residual statistics)."""
        r, p, h = (float(v) for v in self.angles_deg)
        sr, sp, sh = (float(v) for v in self.angles_se_deg)
        return {
            "roll_deg": r,
            "roll_se_deg": sr,
            "pitch_deg": p,
            "pitch_se_deg": sp,
            "heading_deg": h,
            "heading_se_deg": sh,
            "time_offset_s": float(self.time_offset_s),
            "time_offset_se_s": None
            if not np.isfinite(self.time_offset_se_s)
            else float(self.time_offset_se_s),
            "tie_points_used": int(self.used.sum()),
            "tie_points_rejected": int((~self.used).sum()),
            "rms_px": self.rms_px,
            "p90_px": self.p90_px,
            "rms_m": self.rms_m,
            "p90_m": self.p90_m,
            "loss": self.loss,
        }


def _stats(lengths: np.ndarray) -> tuple[float, float]:
    if not len(lengths):
        return float("nan"), float("nan")
    return float(np.sqrt(np.mean(lengths**2))), float(np.percentile(lengths, 90))


def image_jacobians(
    pixel_line: np.ndarray, ground: Callable, *, step_px: float = STEP_PX
) -> np.ndarray:
    """The forward model's derivative ``∂(x, y)/∂(pixel, line)`` at each image position.

    Parameters
    ----------
    pixel_line : (n, 2) array
        Continuous image positions (pixel, line).
    ground : callable (n, 2) -> (n, 2)
        Image positions to ground positions (metres) for fixed angles.
    step_px : float
        Central-difference step (pixels).

    Returns
    -------
    (n, 2, 2) array
        ``J[i, :, 0]`` the ground step of one pixel across, ``J[i, :, 1]`` of one line.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Eq. 1–2).
    """
    pl = np.asarray(pixel_line, "float64")
    out = np.empty((len(pl), 2, 2))
    for k in range(2):
        d = np.zeros(2)
        d[k] = step_px
        out[:, :, k] = (ground(pl + d) - ground(pl - d)) / (2 * step_px)
    return out


def to_pixels(residual_m: np.ndarray, jacobians: np.ndarray) -> np.ndarray:
    """Ground misfits (n, 2) carried into image pixels (n, 2) through ``jacobians`` (n, 2, 2)."""
    out = np.full_like(np.asarray(residual_m, "float64"), np.nan)
    ok = np.isfinite(jacobians).all(axis=(1, 2)) & (np.abs(np.linalg.det(jacobians)) > 0)
    ok &= np.isfinite(residual_m).all(axis=1)
    if ok.any():
        out[ok] = np.linalg.solve(jacobians[ok], residual_m[ok][..., None])[..., 0]
    return out


def _check_geometry(pl: np.ndarray, what: str) -> None:
    n = len(pl)
    if n < MIN_TIE_POINTS:
        raise InputError(
            f"{what}: only {n} tie point(s) on the ground model; at least {MIN_TIE_POINTS} are "
            "needed to measure the boresight angles: add GCPs or give a reference that covers "
            "more of the line"
        )
    if np.ptp(pl[:, 1]) < 1.0:
        raise InputError(
            f"{what}: all {n} tie points lie on one image line (line {pl[0, 1]:.1f}): one "
            "instant's attitude cannot be told from the boresight; give tie points spread "
            "along the line"
        )
    if np.ptp(pl[:, 0]) < 1.0:
        raise InputError(
            f"{what}: all {n} tie points lie in one image column (pixel {pl[0, 0]:.1f}): the "
            "heading angle cannot be measured; give tie points spread across the swath"
        )


def _jacobian(fun: Callable, p: np.ndarray, step: np.ndarray) -> np.ndarray:
    """Forward differences of ``fun`` in each parameter (columns)."""
    f0 = fun(p)
    return np.column_stack(
        [(fun(p + np.eye(len(p))[k] * step[k]) - f0) / step[k] for k in range(len(p))]
    )


def _check_rank(jac: np.ndarray, names: tuple[str, ...], what: str) -> None:
    """Refuse a Jacobian whose (normalised) columns are nearly dependent, naming the
    parameters the weakest direction mixes."""
    norms = np.linalg.norm(jac, axis=0)
    if np.any(~np.isfinite(jac)) or np.any(norms == 0):
        dead = [names[i] for i in np.flatnonzero(~(norms > 0))]
        raise InputError(
            f"{what}: the tie points do not constrain the {', '.join(dead) or 'angles'} "
            "(rank-deficient): give tie points spread along and across the line"
        )
    _, s, vt = np.linalg.svd(jac / norms, full_matrices=False)
    if s[-1] <= 0 or s[0] / s[-1] > MAX_CONDITION:
        weak = [names[i] for i in np.flatnonzero(np.abs(vt[-1]) > 0.3)]
        raise InputError(
            f"{what}: the tie points cannot tell the {' and '.join(weak)} apart (rank-deficient,"
            f" condition number {s[0] / max(s[-1], 1e-300):.3g}): give tie points spread along "
            "and across the line, over relief"
            + (", or hold the clock offset" if "time offset" in weak else "")
        )


def calibrate_boresight(
    pixel_line: np.ndarray,
    ground_xy: np.ndarray,
    project: Callable,
    valid: np.ndarray | None = None,
    *,
    initial_deg=(0.0, 0.0, 0.0),
    time_offset: float = 0.0,
    estimate_time_offset: bool = False,
    loss: str = "soft_l1",
    f_scale_px: float = F_SCALE_PX,
    reject_sigma: float = REJECT_SIGMA,
    what: str = "boresight-calibrate",
) -> BoresightCalibration:
    """Boresight angles (and clock offset) that carry the tie points onto their ground.

    Parameters
    ----------
    pixel_line : (n, 2) array
        Tie points' continuous image positions (pixel, line; 0, 0 the top-left corner).
    ground_xy : (n, 2) array
        Their ground positions in a metric map CRS (metres).
    project : callable (angles_deg, time_offset_s, pixel_line) -> (n, 2)
        The forward model: image positions to ground positions (same CRS) for boresight
        angles (roll, pitch, heading, degrees) and a clock offset (seconds, as the direct
        georeferencing takes it); NaN where a ray misses the ground model.
    valid : bool (n,), optional
        Tie points to use (False: left out, reported as disabled).
    initial_deg : 3 numbers
        Starting angles (degrees).
    time_offset : float
        The clock offset (seconds): held, or the starting value when estimated.
    estimate_time_offset : bool
        Estimate the clock offset too.
    loss : {"soft_l1", "huber", "linear", "cauchy"}
        SciPy's robust loss; ``f_scale_px`` its scale (image pixels).
    reject_sigma : float
        Tie points beyond this many robust standard deviations (and beyond
        ``REJECT_FLOOR_PX``) are rejected and the angles solved again.
    what : str
        How error messages name the tie points' source.

    Returns
    -------
    BoresightCalibration

    Raises
    ------
    InputError
        When the tie points cannot determine the angles: too few, all on one line or one
        column, or a rank-deficient Jacobian (the reason is named).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Eq. 1–2: the
    boresight rotation between the INS and each sensor).
    Branch, M.A.; Coleman, T.F.; Li, Y. A subspace, interior, and conjugate gradient method
    for large-scale bound-constrained minimization problems. SIAM J. Sci. Comput. 1999, 21,
    1–23 (SciPy's ``least_squares``, method ``trf``).
    """
    from scipy.optimize import least_squares

    pl = np.asarray(pixel_line, "float64").reshape(-1, 2)
    xy = np.asarray(ground_xy, "float64").reshape(-1, 2)
    n = len(pl)
    rejected = np.full(n, "", dtype=object)
    if valid is not None:
        rejected[~np.asarray(valid, bool)] = "disabled"
    rejected[~np.isfinite(pl).all(axis=1) | ~np.isfinite(xy).all(axis=1)] = "no coordinates"
    x0 = np.array([*np.asarray(initial_deg, "float64"), float(time_offset)])
    free = [0, 1, 2, 3] if estimate_time_offset else [0, 1, 2]
    names = tuple(PARAMETERS[i] for i in free)
    step = np.array([STEP_DEG] * 3 + [STEP_S])[free]

    def full(p):
        x = x0.copy()
        x[free] = p
        return x

    def ground(p, pts):
        x = full(p)
        return np.asarray(project(x[:3], float(x[3]), pts), "float64").reshape(-1, 2)

    p = x0[free].copy()
    sel = rejected == ""
    start = ground(p, pl[sel])
    missed = ~np.isfinite(start).all(axis=1)
    rejected[np.flatnonzero(sel)[missed]] = "off the ground model"
    iterations = 0
    # The first solve starts from the initial angles, where the image derivatives (which
    # follow the slope under each ray) belong to other ground: no point is judged on it.
    for round_ in range(ROUNDS):
        sel = rejected == ""
        _check_geometry(pl[sel], what)
        jac_img = image_jacobians(pl[sel], lambda q, p=p: ground(p, q))
        bad = ~np.isfinite(jac_img).all(axis=(1, 2)) | ~(np.abs(np.linalg.det(jac_img)) > 0)
        if bad.any():
            rejected[np.flatnonzero(sel)[bad]] = "off the ground model"
            continue
        pts, target = pl[sel], xy[sel]

        def residual(q, pts=pts, target=target, jac_img=jac_img):
            r = to_pixels(ground(q, pts) - target, jac_img).ravel()
            return np.where(np.isfinite(r), r, 1e3)  # a ray that leaves the DEM: far off

        _check_rank(_jacobian(residual, p, step), names, what)
        fit = least_squares(
            residual, p, loss=loss, f_scale=f_scale_px, x_scale=step, diff_step=None
        )
        p = fit.x
        iterations += int(fit.nfev)
        res = fit.fun.reshape(-1, 2)
        length = np.hypot(*res.T)
        sigma = np.median(length) / np.sqrt(np.log(4.0))  # a Rayleigh length's median is σ·√ln 4
        limit = max(reject_sigma * sigma, REJECT_FLOOR_PX)
        out = length > limit
        if round_ == 0:
            continue
        if not out.any() or round_ == ROUNDS - 1:
            break  # the last solve's points are the ones used
        rejected[np.flatnonzero(sel)[out]] = f"residual over {limit:.2f} px"
    sel = rejected == ""
    # Final residuals of every point with coordinates, at the solution.
    have = np.isfinite(pl).all(axis=1) & np.isfinite(xy).all(axis=1)
    res_m = np.full((n, 2), np.nan)
    res_px = np.full((n, 2), np.nan)
    res_m[have] = ground(p, pl[have]) - xy[have]
    res_px[have] = to_pixels(res_m[have], image_jacobians(pl[have], lambda q: ground(p, q)))
    # Standard errors from the Jacobian of the pixel residuals (no loss weighting) at the
    # solution, over the tie points used.
    jac_img = image_jacobians(pl[sel], lambda q: ground(p, q))

    def residual_px(q):
        return to_pixels(ground(q, pl[sel]) - xy[sel], jac_img).ravel()

    r0 = residual_px(p)
    jac = _jacobian(residual_px, p, step)
    dof = max(len(r0) - len(p), 1)
    try:
        cov = np.linalg.inv(jac.T @ jac) * float(np.sum(r0**2)) / dof
        se = np.sqrt(np.clip(np.diag(cov), 0, None))
    except np.linalg.LinAlgError:
        se = np.full(len(p), np.nan)
    se_full = np.full(4, np.nan)
    se_full[free] = se
    x = full(p)
    rms_px, p90_px = _stats(np.hypot(*res_px[sel].T))
    rms_m, p90_m = _stats(np.hypot(*res_m[sel].T))
    return BoresightCalibration(
        angles_deg=x[:3],
        angles_se_deg=se_full[:3],
        time_offset_s=float(x[3]),
        time_offset_se_s=float(se_full[3]),
        used=sel,
        rejected=rejected,
        residuals_px=res_px,
        residuals_m=res_m,
        rms_px=rms_px,
        p90_px=p90_px,
        rms_m=rms_m,
        p90_m=p90_m,
        loss=loss,
        iterations=iterations,
    )


def residual_figure(calibrations: dict, pixel_lines: dict, *, scale: float | None = None):
    """Residual vectors of one or more sensors in their image (pixels, exaggerated).

    Parameters
    ----------
    calibrations : dict name -> BoresightCalibration
    pixel_lines : dict name -> (n, 2) array
        Each sensor's tie points (pixel, line).
    scale : float, optional
        Pixels drawn per pixel of residual (default: the longest residual drawn as a twentieth
        of the image's longer side).

    Returns
    -------
    matplotlib Figure

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2).
    """
    from ..figures import blank_figure

    names = list(calibrations)
    fig = blank_figure(4.0 * len(names) + 1.0, 6.0)
    axes = fig.subplots(1, len(names), squeeze=False)[0]
    for ax, name in zip(axes, names, strict=True):
        cal, pl = calibrations[name], np.asarray(pixel_lines[name], "float64")
        r = cal.residuals_px
        ok = np.isfinite(r).all(axis=1)
        longest = float(np.nanmax(np.hypot(*r[ok].T))) if ok.any() else 1.0
        extent = max(float(np.ptp(pl[:, 0])), float(np.ptp(pl[:, 1])), 1.0)
        s = scale or extent / 20.0 / max(longest, 1e-9)
        for used, colour, label in ((True, "tab:blue", "used"), (False, "tab:red", "rejected")):
            k = ok & (cal.used == used)
            if k.any():
                ax.quiver(
                    pl[k, 0],
                    pl[k, 1],
                    r[k, 0] * s,
                    r[k, 1] * s,
                    angles="xy",
                    scale_units="xy",
                    scale=1.0,
                    color=colour,
                    width=0.004,
                    label=f"{label} ({int(k.sum())})",
                )
        ax.invert_yaxis()
        ax.set_xlabel("Pixel")
        ax.set_ylabel("Line")
        ax.set_title(
            f"{name}: RMS {cal.rms_px:.2f} px ({cal.rms_m:.2f} m)\nvectors ×{s:.3g}", fontsize=9
        )
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8, loc="lower right")
    return fig


def _at(values: np.ndarray, position: np.ndarray) -> np.ndarray:
    """``values`` (one per pixel or line, at continuous centres i + 0.5) at continuous
    ``position``, linear between centres and extrapolated beyond the first and last."""
    v = np.asarray(values, "float64")
    i = np.asarray(position, "float64") - 0.5
    if v.size == 1:
        return np.full(i.shape, v[0])
    k = np.clip(np.floor(i).astype(int), 0, v.size - 2)
    t = i - k
    return v[k] * (1.0 - t) + v[k + 1] * t


def tie_point_ground(navigation, times, model, lever_arm, dem=None, *, height=None, crs=None):
    """The forward model at continuous image positions, as :func:`calibrate_boresight` takes
    it: ``project(angles_deg, time_offset_s, pixel_line) -> (n, 2)`` ground x, y in ``crs``.

    A position between pixel centres looks along the sensor model's look vectors
    interpolated on the focal plane (``tan`` of the angles, linear between centres); between
    line centres, at the line times interpolated linearly. Each ray is then the direct
    georeferencing's own (:mod:`geoboresight.sensor.georeference`): the navigation at
    ``time + time_offset``, the lever arm, the boresight, the first hit on the DEM.

    Parameters
    ----------
    navigation : Navigation
    times : (lines,) array
        Each image line's GPS time (s).
    model : SensorModel
        One look direction per image sample.
    lever_arm : LeverArm
    dem : Surface, optional
        The DEM (ellipsoidal heights), or give ``height``.
    height : float, optional
        A constant ellipsoidal height.
    crs : optional
        The ground coordinates' CRS (a metric one for metre residuals); default the DEM's.

    Returns
    -------
    callable

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Eq. 1–2).
    """
    from .boresight import Boresight
    from .georeference import ECEF, Surface, platform, transformer
    from .intersect import intersect

    if crs is None:
        crs = dem.crs if isinstance(dem, Surface) else None
    out_map = transformer(ECEF, crs)
    to_map = transformer(ECEF, dem.crs) if isinstance(dem, Surface) else out_map
    tan_across = np.tan(model.across_rad)
    tan_along = np.tan(model.along_rad)
    line_times = np.asarray(times, "float64")

    def project(angles_deg, time_offset, pixel_line):
        pl = np.asarray(pixel_line, "float64").reshape(-1, 2)
        look = np.column_stack(
            [_at(tan_along, pl[:, 0]), _at(tan_across, pl[:, 0]), np.ones(len(pl))]
        )
        look /= np.linalg.norm(look, axis=1, keepdims=True)
        t = _at(line_times, pl[:, 1])
        positions, body_to_ecef = platform(navigation, t, time_offset=float(time_offset))
        origins = positions + body_to_ecef @ lever_arm.vector()
        r_bs = Boresight(*(float(a) for a in angles_deg)).matrix()
        directions = np.einsum("nij,jk,nk->ni", body_to_ecef, r_bs, look)[:, None, :]
        if isinstance(dem, Surface):
            x, y, _ = intersect(origins, directions, dem.heights, dem.transform, to_map, out_map)
        else:
            x, y, _ = intersect(origins, directions, float(height), None, out_map, out_map)
        return np.column_stack([x[:, 0], y[:, 0]])

    return project
