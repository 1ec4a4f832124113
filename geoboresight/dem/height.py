"""Disparity to relative height (paper §3.2), with the precision the geometry allows.

A point raised by ``h`` above the ground is seen by two lines of sight that differ by the squint
``θ`` at ground positions ``h · tan θ`` apart: a relief parallax of ``h · tan θ / GSD`` pixels on
top of the flat-ground boresight offset. The height-to-disparity factor ``k = tan θ / GSD``
(px per metre, with ``GSD = H · IFOV`` at flying height ``H``) turns disparity into height, and a
matching precision ``σ_d`` into a height precision ``σ_h = σ_d · GSD / tan θ = σ_d / k``.
The paper leaves this physics out; with the small squint of a real instrument (fractions of a
degree) ``σ_h`` is larger than the relief, and no meaningful DEM can be made: we say so instead
of returning noise that looks like terrain.

The result is relative: the lowest reliable region is 0 m, everything else relative to it
("the lowest region ... is defined as 0 and other regions are defined relative to 0").
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError

#: Significance level of the relief test: the DEM is made when the hypothesis "the relief
#: parallax is no larger than the matching noise" is rejected at this level.
ALPHA = 0.05
#: Windows per side of the blocks the relief test compares (:func:`relief_test`): 2 × 2, the
#: smallest scale a DEM resolves beyond one matching window.
RELIEF_BLOCK = 2
#: Heights farther than this many robust standard deviations (normal-consistent MAD) from the
#: median are gross mismatches, left out of the relief test.
GROSS = 10.0


@dataclass(frozen=True)
class HeightFactor:
    """Disparity per metre of height (px/m), along-track and across-track.

    Positive ``along``: an elevated feature appears further along-track (higher line number) in
    the SWIR image than on the ground next to it.
    """

    along: float
    across: float = 0.0

    @property
    def magnitude(self) -> float:
        return math.hypot(self.along, self.across)

    def check(self) -> HeightFactor:
        if not (math.isfinite(self.along) and math.isfinite(self.across)):
            raise ParameterError("the height-to-disparity factor must be finite")
        if self.magnitude <= 0:
            raise ParameterError(
                "the height-to-disparity factor is 0: the two lines of sight are parallel, so "
                "relief makes no parallax; give a non-zero factor (px per metre) or squint angle"
            )
        return self


def height_factor(
    flying_height: float,
    ifov_mrad: float,
    squint_along_deg: float,
    squint_across_deg: float = 0.0,
) -> HeightFactor:
    """``k = tan θ / GSD`` per axis from flying height, IFOV and the squint between the sensors.

    ``θ`` is the angle between the SWIR and the VNIR lines of sight in the along-track
    (resp. across-track) plane, signed like :class:`HeightFactor`; ``GSD = H · IFOV``.
    """
    if not (flying_height > 0):
        raise ParameterError(f"parameter 'flying_height': must be > 0 m, got {flying_height}")
    if not (ifov_mrad > 0):
        raise ParameterError(f"parameter 'ifov_mrad': must be > 0, got {ifov_mrad}")
    gsd = ground_sample_distance(flying_height, ifov_mrad)
    return HeightFactor(
        along=math.tan(math.radians(squint_along_deg)) / gsd,
        across=math.tan(math.radians(squint_across_deg)) / gsd,
    ).check()


#: ``height_factor`` under another name, for :func:`parallax_factor`, whose parameter of the
#: same name is the factor itself.
_factor_from_geometry = height_factor


def ground_sample_distance(flying_height: float | None, ifov_mrad: float | None) -> float | None:
    """Pixel size on the ground at nadir, ``GSD = H · IFOV`` (m, with ``flying_height`` in m);
    None unless both are given."""
    if flying_height is None or ifov_mrad is None:
        return None
    if not (flying_height > 0 and ifov_mrad > 0):
        raise ParameterError("parameters 'flying_height' and 'ifov_mrad' must both be > 0")
    return flying_height * ifov_mrad * 1e-3


def parallax_factor(
    height_factor: float | None = None,
    *,
    squint_deg: float | None = None,
    flying_height: float | None = None,
    ifov_mrad: float | None = None,
    parallax_axis: str = "along",
    invert_parallax: bool = False,
) -> HeightFactor:
    """The height-to-disparity factor of a flight: given (px per metre), or ``tan θ / GSD``.

    Parameters
    ----------
    height_factor : float, optional
        ``k`` itself in px per metre, > 0 (its direction is ``parallax_axis`` and
        ``invert_parallax``).
    squint_deg, flying_height, ifov_mrad : float, optional
        Without ``k``: the angle between the two lines of sight (degrees), the flying height
        (m) and the IFOV (mrad), giving ``k = tan θ / (H · IFOV)``.
    parallax_axis : {"along", "across"}
        The plane of the squint: the parallax is along-track or across-track.
    invert_parallax : bool
        Elevated features appear at lower line (column) numbers in the SWIR image.
    """
    sign = -1.0 if invert_parallax else 1.0
    k = height_factor
    if k is None:
        if squint_deg is None or flying_height is None or ifov_mrad is None:
            raise ParameterError(
                "give the height-to-disparity factor 'height_factor' (px per metre), or the "
                "squint angle between the two lines of sight 'squint_deg', the flying height "
                "'flying_height' and the IFOV 'ifov_mrad'",
                params=("height_factor", "squint_deg", "flying_height", "ifov_mrad"),
            )
        if not squint_deg > 0:
            raise ParameterError(
                f"parameter 'squint_deg': must be > 0, got {squint_deg}; a zero squint makes no "
                "parallax (use 'invert_parallax' for the direction)",
                params=("squint_deg", "invert_parallax"),
            )
        k = _factor_from_geometry(flying_height, ifov_mrad, squint_deg).along
    if not (isinstance(k, int | float) and math.isfinite(k) and k > 0):
        raise ParameterError(
            f"parameter 'height_factor': must be > 0 px per metre, got {k}; it is the size of the "
            "parallax (use 'invert_parallax' for its direction)"
        )
    if parallax_axis not in ("along", "across"):
        raise ParameterError(
            f"parameter 'parallax_axis': 'along' or 'across', got {parallax_axis!r}"
        )
    return HeightFactor(sign * k, 0.0) if parallax_axis == "along" else HeightFactor(0.0, sign * k)


@dataclass(frozen=True)
class FlightGeometry:
    """The flight geometry the relative DEM needs (§3.2): the height-to-disparity factor
    ``k`` itself, or the squint, flying height and IFOV that give it; the parallax's axis
    and direction. The flying height and IFOV alone give the ground sample distance.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.FlightGeometry(squint_deg=3, flying_height=1500, ifov_mrad=1)
    FlightGeometry(height_factor=None, squint_deg=3, flying_height=1500, ifov_mrad=1,
        parallax_axis='along', invert_parallax=False)
    """

    height_factor: float | None = None
    squint_deg: float | None = None
    flying_height: float | None = None
    ifov_mrad: float | None = None
    parallax_axis: str = "along"
    invert_parallax: bool = False

    def factor(self) -> HeightFactor:
        """:func:`parallax_factor` of this geometry."""
        return parallax_factor(**dataclasses.asdict(self))

    @property
    def gsd(self) -> float | None:
        """:func:`ground_sample_distance` (m), None without flying height and IFOV."""
        return ground_sample_distance(self.flying_height, self.ifov_mrad)


def disparity_to_height(along: np.ndarray, across: np.ndarray, factor: HeightFactor) -> np.ndarray:
    """Height (m, up to a constant) whose parallax best explains the disparity.

    The least-squares projection of the disparity vector on the parallax direction:
    ``h = (d · k) / |k|²``. The constant (flat-ground offset) is removed by :func:`zero_lowest`.
    """
    factor.check()
    k2 = factor.along**2 + factor.across**2
    return (
        np.asarray(along, np.float64) * factor.along
        + np.asarray(across, np.float64) * factor.across
    ) / k2


def zero_lowest(height: np.ndarray, reliable: np.ndarray, percentile: float = 1.0) -> np.ndarray:
    """Shift ``height`` so that the lowest reliable region (its ``percentile``) is 0 m.

    A low percentile rather than the minimum, so that one bad match does not set the datum.
    """
    h = np.asarray(height, np.float64)
    ok = reliable & np.isfinite(h)
    if not ok.any():
        raise InputError("no reliable height to set the lowest region to 0")
    return h - np.percentile(h[ok], percentile)


@dataclass(frozen=True)
class HeightPrecision:
    """How precise the heights are, and whether the relief stands out of that noise.

    The test works at the smallest scale a DEM resolves beyond one matching window: *blocks*
    of ``block × block`` non-overlapping windows (2 × 2 by default), whose mean heights carry
    the noise ``σ_h / block`` (:func:`relief_test`). *Relief* is defined once, at that scale:
    the standard deviation of the blocks' mean heights with their noise removed
    (``relief_m``); ``snr`` is ``relief_m`` over the noise of a block's mean (``noise_m``).
    """

    sigma_d_px: float  # matching precision (from the data)
    sigma_h_m: float  # = σ_d / k = σ_d · GSD / tan θ: the noise of one window's height
    relief_m: float  # relief: std of the blocks' mean heights with their noise removed
    snr: float  # relief_m / noise_m
    meaningful: bool  # H0 rejected: p_value < ALPHA
    statistic: float = float("nan")  # χ² = Σ (m_b − m̄)² / (σ_h²/B² + σ_h²/n_b)
    dof: int = 0  # blocks − 1
    p_value: float = float("nan")
    alpha: float = ALPHA
    block: int = RELIEF_BLOCK  # windows per side of a block
    window: tuple[int, int] = (1, 1)  # matching window (lines, columns)
    windows: int = 0  # reliable independent windows the test used
    blocks: int = 0

    @property
    def noise_m(self) -> float:
        """The noise of a full block's mean height, σ_h / block."""
        return self.sigma_h_m / self.block

    def scale(self) -> str:
        wr, wc = self.window
        b = self.block
        return f"blocks of {b} × {b} matching windows ({b * wr} × {b * wc} px)"

    def test(self) -> str:
        return (
            f"χ² test of H0 'relief ≤ noise' between {self.scale()}: χ² = "
            f"{self.statistic:.1f} on {self.dof} degrees of freedom, p = {self.p_value:.3g}"
        )

    def message(self) -> str:
        relief = (
            f"height precision σ_h = {self.sigma_h_m:.2f} m per matching window (σ_d = "
            f"{self.sigma_d_px:.3f} px); relief {self.relief_m:.2f} m (standard deviation of "
            f"the blocks' mean heights, their noise removed) = {self.snr:.2f} × the noise of "
            f"a block's mean (σ_h / {self.block} = {self.noise_m:.2f} m)"
        )
        if self.meaningful:
            return f"{relief}; {self.test()} < {self.alpha:g}"
        if self.blocks < 2:
            return (
                f"no meaningful DEM can be made: the relief test compares {self.scale()}, and "
                f"the reliable matches fill only {self.blocks} (it needs 2 or more). Use a "
                "longer part of the line or a smaller matching window"
            )
        return (
            f"no meaningful DEM can be made from this squint: {relief}; {self.test()} ≥ "
            f"{self.alpha:g}. A surface made from it would be noise that looks like terrain. "
            "A larger angle between the two lines of sight (or a lower flight) is needed for "
            "relief to show"
        )


def window_centres(
    height: np.ndarray,
    reliable: np.ndarray,
    window: int | tuple[int, int],
    first_line: int = 0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The heights of non-overlapping matching windows: the reliable ones at the windows'
    centres on the flight line's lattice.

    Neighbouring heights share their window's pixels; one height per window tiling the line
    (line ``L`` with ``L mod wr = wr // 2``, column ``C`` with ``C mod wc = wc // 2``) gives
    independent heights. ``first_line`` is the flight line's line of the array's first row,
    so strips of a line give the lattice of the whole line.

    Returns (lattice row ``L // wr``, lattice column ``C // wc``, height), one per reliable
    finite window centre.
    """
    wr, wc = _window(window)
    height = np.asarray(height)
    rows = np.arange(height.shape[0]) + int(first_line)
    r = np.nonzero(rows % wr == wr // 2)[0]
    c = np.arange(wc // 2, height.shape[1], wc)
    h = height[np.ix_(r, c)]
    ok = np.asarray(reliable)[np.ix_(r, c)] & np.isfinite(h)
    ir, ic = np.nonzero(ok)
    return ((rows[r][ir] // wr).astype(np.int64), (c[ic] // wc).astype(np.int64), h[ok])


def not_gross(values: np.ndarray) -> np.ndarray:
    """True where a value is within ``GROSS`` robust standard deviations (scipy's
    normal-consistent MAD) of the median: everything but gross blunders (all of it when the
    MAD is 0)."""
    from scipy.special import ndtri

    values = np.asarray(values, np.float64)
    if values.size == 0:
        return np.ones(0, bool)
    # scipy.stats.median_abs_deviation(values, scale="normal"), operation by operation:
    # importing scipy.stats costs a third of a second, more than a flight line's test.
    median = np.median(values)
    spread = np.median(np.abs(values - median)) / ndtri(0.75)
    if not spread > 0:
        return np.ones(values.shape, bool)
    return np.abs(values - median) <= GROSS * spread


def _window(window) -> tuple[int, int]:
    wr, wc = (window, window) if np.ndim(window) == 0 else tuple(window)
    if int(wr) < 1 or int(wc) < 1:
        raise ParameterError(f"matching window {window!r} must be at least 1 px")
    return int(wr), int(wc)


def relief_test(
    heights: np.ndarray,
    rows: np.ndarray,
    cols: np.ndarray,
    sigma_d_px: float,
    factor: HeightFactor,
    *,
    window: int | tuple[int, int] = 1,
    block: int = RELIEF_BLOCK,
    alpha: float = ALPHA,
) -> HeightPrecision:
    """σ_h from σ_d, the relief that stands out of it, and the test of whether it does.

    Parameters
    ----------
    heights : 1-D array
        Heights (m) of independent matching windows (:func:`window_centres`).
    rows, cols : 1-D int arrays
        Their windows' lattice row and column.
    sigma_d_px : float
        Matching precision σ_d (px), e.g. :func:`~geoboresight.dem.disparity.disparity_noise`.
    factor : HeightFactor
    window : int or (int, int)
        The matching window (px), for the report.
    block : int
        Windows per side of the blocks compared (2: the smallest scale above one window).
    alpha : float
        Significance level (0–1) of the test.

    Returns
    -------
    HeightPrecision
        ``σ_h = σ_d / |k|``; the blocks of ``block × block`` windows holding at least two
        heights (gross mismatches, more than 10 robust standard deviations from the median,
        left out), their mean
        heights ``m_b`` from ``n_b`` windows; the relief ``sqrt(max(var(m_b) − mean(σ_h² /
        n_b), 0))``; and the one-sided χ² test of H0 "the relief between blocks is no larger
        than the noise of a full block's mean, σ_h / block": under H0 each ``m_b`` varies by
        at most ``τ² + σ_h² / n_b`` with ``τ² = σ_h² / block²``, so ``χ² = Σ (m_b − m̄)² /
        (τ² + σ_h² / n_b)`` (``m̄`` weighted by the inverse of those variances) on
        ``blocks − 1`` degrees of freedom, p = ``scipy.stats.chi2.sf``; the DEM is meaningful
        when ``p < alpha``.

    Notes
    -----
    Why blocks: a kriged DEM averages several windows, so relief that is smaller than one
    window's noise but coherent over a few windows still makes a good DEM (on the independent
    scene model at 2° squint, r 0.93 against the true surface with relief 0.88–1.18 σ_h per
    window, which a per-window test refused). Why "relief ≤ noise" rather than "no relief":
    σ_d's estimate was 1.2–1.6× below the true error at small squints, and a test against the
    noise alone accepts any scene whose σ_d is underestimated by a few per cent.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2, the relative DEM).
    Kraus, K. Photogrammetry: Geometry from Images and Laser Scans, 2nd ed.; de Gruyter: Berlin,
    2007 (height precision σ_h = σ_parallax · H / B).
    Snedecor, G.W.; Cochran, W.G. Statistical Methods, 8th ed.; Iowa State University Press:
    Ames, IA, USA, 1989 (χ² test of a variance against a hypothesised value; weighted means).
    """
    # chi2.sf is scipy.special's chdtrc (scipy.stats, 0.3 s to import, calls it).
    from scipy.special import chdtrc

    if not (0 < alpha < 1):
        raise ParameterError(f"parameter 'alpha': {alpha} is not between 0 and 1")
    if int(block) < 1:
        raise ParameterError(f"parameter 'block': {block} must be at least 1 window")
    block = int(block)
    win = _window(window)
    sigma_h = float(sigma_d_px) / factor.check().magnitude
    h = np.asarray(heights, np.float64)
    rows, cols = np.asarray(rows, np.int64), np.asarray(cols, np.int64)
    fin = np.isfinite(h)
    h, rows, cols = h[fin], rows[fin], cols[fin]
    nan = float("nan")
    base = dict(alpha=alpha, block=block, window=win, windows=int(h.size))
    if h.size < 2 or not math.isfinite(sigma_h) or sigma_h <= 0:
        return HeightPrecision(float(sigma_d_px), sigma_h, nan, nan, False, **base)
    # Gross mismatches (a wrong correlation peak) would inflate the spread. Only those go:
    # trimming a fixed share (the 0.5th–99.5th percentiles) drops the largest relief too and
    # made the test reject a true H0 in 1 % of the cases instead of 5 %.
    keep = not_gross(h)
    h, rows, cols = h[keep], rows[keep], cols[keep]
    key = (rows // block) * (int(cols.max()) // block + 1) + cols // block
    _, inv, n = np.unique(key, return_inverse=True, return_counts=True)
    m = np.bincount(inv, h) / n
    use = n >= min(2, block * block)
    m, n = m[use], n[use]
    base.update(windows=int(n.sum()), blocks=int(m.size))
    if m.size < 2:
        return HeightPrecision(float(sigma_d_px), sigma_h, nan, nan, False, **base)
    tau2 = sigma_h**2 / block**2
    var = tau2 + sigma_h**2 / n
    mbar = float(np.sum(m / var) / np.sum(1.0 / var))
    stat = float(np.sum((m - mbar) ** 2 / var))
    dof = m.size - 1
    p = float(chdtrc(dof, stat))
    relief = math.sqrt(max(float(np.var(m, ddof=1)) - float(np.mean(sigma_h**2 / n)), 0.0))
    snr = relief / math.sqrt(tau2)
    return HeightPrecision(float(sigma_d_px), sigma_h, relief, snr, p < alpha, stat, dof, p, **base)


def height_precision(
    height: np.ndarray,
    reliable: np.ndarray,
    sigma_d_px: float,
    factor: HeightFactor,
    *,
    window: int | tuple[int, int] = 1,
    block: int = RELIEF_BLOCK,
    alpha: float = ALPHA,
) -> HeightPrecision:
    """:func:`relief_test` on the heights of a 2-D image: one height per matching window
    (:func:`window_centres`).

    Parameters
    ----------
    height : 2-D array
        Heights (m) from the disparity (:func:`disparity_to_height`).
    reliable : bool array
        Pixels with a reliable match.
    sigma_d_px : float
        Matching precision σ_d (px).
    factor : HeightFactor
    window : int or (int, int)
        Matching window (px): the lattice of independent heights.
    block, alpha
        As :func:`relief_test`.
    """
    rows, cols, h = window_centres(height, reliable, window)
    return relief_test(h, rows, cols, sigma_d_px, factor, window=window, block=block, alpha=alpha)
