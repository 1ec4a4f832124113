"""The shadow-fraction model of Figure 5(B) (paper §3.1).

Over the detected shadow areas the paper fits the boresight ratio against the ground-truth shadow
fraction with a straight line, ``ratio = a · fraction + b`` (its Figure 5(B): a = −0.74,
b = 1.31, R² = 0.913), and uses the relation to read a shadow fraction from the ratio. The fit
is ordinary least squares (``scipy.stats.linregress``); R² is the squared Pearson correlation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

#: Figure 5(B) of the paper.
PAPER_SLOPE = -0.74
PAPER_INTERCEPT = 1.31
PAPER_R2 = 0.913


@dataclass(frozen=True)
class FractionModel:
    """``ratio = slope · fraction + intercept``, fitted on ``n`` pixels with ``r2``."""

    slope: float
    intercept: float
    r2: float = float("nan")
    n: int = 0
    stderr: float = float("nan")

    def __post_init__(self):
        if not np.isfinite(self.slope) or self.slope == 0:
            raise ParameterError(
                f"parameter 'slope': {self.slope!r} cannot be inverted (the ratio would not "
                "depend on the shadow fraction); give a non-zero slope"
            )
        if not np.isfinite(self.intercept):
            raise ParameterError(f"parameter 'intercept': {self.intercept!r} is not a number")

    def ratio(self, fraction: np.ndarray) -> np.ndarray:
        """The ratio the model predicts for a shadow fraction."""
        return self.slope * np.asarray(fraction) + self.intercept

    def fraction(
        self, ratio: np.ndarray, valid: np.ndarray | None = None, *, clip: bool = True
    ) -> np.ndarray:
        """Invert the model: ``fraction = (ratio − intercept) / slope`` (float32; NaN invalid).

        With ``clip`` the result is limited to 0–1 (a fraction).
        """
        ratio = np.asarray(ratio, dtype=np.float64)
        ok = np.isfinite(ratio) if valid is None else (np.asarray(valid, bool) & np.isfinite(ratio))
        f = (ratio - self.intercept) / self.slope
        if clip:
            f = np.clip(f, 0.0, 1.0)
        return np.where(ok, f, np.nan).astype(np.float32)

    def clipped(self, ratio: np.ndarray, valid: np.ndarray | None = None) -> tuple[int, int, int]:
        """(below 0, above 1, valid): pixels whose fraction from this line falls outside 0–1
        (counts of strips add up)."""
        ratio = np.asarray(ratio, np.float64)
        ok = np.isfinite(ratio) if valid is None else (np.asarray(valid, bool) & np.isfinite(ratio))
        f = (ratio[ok] - self.intercept) / self.slope
        return int((f < 0).sum()), int((f > 1).sum()), int(ok.sum())

    def range_warning(self, below: int, above: int, n: int, share: float = 0.9) -> str | None:
        """A warning when at least ``share`` of the ``n`` valid pixels fall outside the line's
        0–1 range on one side (:meth:`clipped`): the line does not fit the ratio's range (e.g.
        the paper's Figure 5B line, ratios 0.57–1.31, on DN ratios of 1.5–4)."""
        if n == 0:
            return None
        lo, hi = sorted((self.intercept, self.slope + self.intercept))
        for count, end in ((below, 0), (above, 1)):
            if count / n >= share:
                return (
                    f"{100 * count / n:.0f} % of the valid pixels have a ratio outside this "
                    f"line's range ({lo:.3g}–{hi:.3g} for fractions 0–1) and get fraction {end}: "
                    "the line does not fit this ratio; fit it on this scene "
                    "('shadow-fraction-fit') or use 'shadow-map'"
                )
        return None

    def as_dict(self) -> dict:
        return {
            "slope": self.slope,
            "intercept": self.intercept,
            "r2": self.r2,
            "n": self.n,
            "slope_stderr": self.stderr,
            "equation": f"ratio = {self.slope:.4g} * fraction + {self.intercept:.4g}",
        }


def fit_fraction_model(
    ratio: np.ndarray, fraction: np.ndarray, valid: np.ndarray | None = None
) -> FractionModel:
    """Least-squares ``ratio = a · fraction + b`` over the pixels in ``valid`` (Figure 5(B)).

    ``valid`` selects the pixels to fit: the detected shadow areas with a valid ratio and
    ground truth; non-finite values are always left out. Raises InputError when fewer than 3
    pixels remain or the fraction does not vary.

    Parameters
    ----------
    ratio : array
        Boresight ratio (Eq. 3), the dependent variable.
    fraction : array
        Ground-truth shadow fraction (0–1, e.g. from
        :func:`~geoboresight.shadow.illumination.shadow_fraction`), same shape as ``ratio``.
    valid : bool array, optional
        Pixels to fit (same shape): the detected shadow areas.

    Returns
    -------
    FractionModel
        ``slope`` a and ``intercept`` b of ``ratio = a · fraction + b`` (ordinary least
        squares), ``r2`` (squared Pearson correlation), ``n`` (pixels fitted) and ``stderr``
        (standard error of the slope); :meth:`FractionModel.fraction` inverts it.

    Raises
    ------
    InputError
        When ``ratio`` and ``fraction`` differ in shape, fewer than 3 pixels remain, or the
        fraction is constant.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Figure 5(B):
    y = −0.74x + 1.31, R² = 0.913; the ratio-to-fraction correspondence of Table 2).
    """
    from scipy.stats import linregress

    r = np.asarray(ratio, dtype=np.float64)
    f = np.asarray(fraction, dtype=np.float64)
    if r.shape != f.shape:
        raise InputError(f"ratio {r.shape} and shadow fraction {f.shape} differ in shape")
    ok = np.isfinite(r) & np.isfinite(f)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    if ok.sum() < 3:
        raise InputError(
            f"only {int(ok.sum())} shadow pixels have both a ratio and a ground-truth fraction: "
            "too few to fit the shadow-fraction model (check the shadow mask and the grids)"
        )
    x, y = f[ok], r[ok]
    if np.ptp(x) == 0:
        raise InputError(
            f"the ground-truth shadow fraction is {x[0]:g} on every shadow pixel: it must vary "
            "to fit a line (use a truth raster with partial shadow, e.g. a supersampled one)"
        )
    res = linregress(x, y)
    return FractionModel(
        float(res.slope),
        float(res.intercept),
        float(res.rvalue**2),
        int(ok.sum()),
        float(res.stderr),
    )


class FractionAccumulator:
    """Exact streaming least squares for :func:`fit_fraction_model` on rasters of any size.

    Feed blocks with :meth:`add`; :meth:`model` gives the same line and R² as fitting all the
    pixels at once (sums are accumulated about a running shift, so they stay accurate).
    """

    def __init__(self):
        self.n = 0
        self._shift: tuple[float, float] | None = None
        self._s = np.zeros(5)  # Σx, Σy, Σxx, Σyy, Σxy about the shift

    def add(
        self, ratio: np.ndarray, fraction: np.ndarray, valid: np.ndarray | None = None
    ) -> FractionAccumulator:
        """Add the pixels of a block selected by ``valid`` (and finite); returns itself, so it
        serves as the ``merge`` of :func:`~geoboresight.io.windows.reduce_windows`."""
        r = np.asarray(ratio, dtype=np.float64)
        f = np.asarray(fraction, dtype=np.float64)
        ok = np.isfinite(r) & np.isfinite(f)
        if valid is not None:
            ok &= np.asarray(valid, bool)
        if not ok.any():
            return self
        x, y = f[ok], r[ok]
        if self._shift is None:
            self._shift = (float(x.mean()), float(y.mean()))
        x = x - self._shift[0]
        y = y - self._shift[1]
        self._s += [x.sum(), y.sum(), (x * x).sum(), (y * y).sum(), (x * y).sum()]
        self.n += int(ok.sum())
        return self

    def model(self) -> FractionModel:
        n = self.n
        if n < 3:
            raise InputError(
                f"only {n} shadow pixels have both a ratio and a ground-truth fraction: too few "
                "to fit the shadow-fraction model (check the shadow mask and the grids)"
            )
        sx, sy, sxx, syy, sxy = self._s
        vx = sxx - sx * sx / n
        vy = syy - sy * sy / n
        cxy = sxy - sx * sy / n
        if vx <= 0:
            raise InputError(
                "the ground-truth shadow fraction is constant on every shadow pixel: it must vary "
                "to fit a line (use a truth raster with partial shadow, e.g. a supersampled one)"
            )
        slope = cxy / vx
        intercept = (sy / n + self._shift[1]) - slope * (sx / n + self._shift[0])
        r2 = cxy * cxy / (vx * vy) if vy > 0 else float("nan")
        resid = max(vy - slope * cxy, 0.0)
        stderr = float(np.sqrt(resid / (n - 2) / vx)) if n > 2 else float("nan")
        return FractionModel(float(slope), float(intercept), float(r2), n, stderr)
