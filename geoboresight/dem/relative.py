"""The relative DEM chain of §3.2, arrays in, DEM out — whole or strip by strip.

1. boresight offset (global, sub-pixel), merged over blocks of lines: where to centre the search;
2. dense disparity around it, with reliability (peak, sharpness), clouds and nodata masked;
3. disparity → height with the height-to-disparity factor; the lowest reliable region is 0;
4. σ_d from the data, σ_h = σ_d / k; refuse when the relief does not stand out of σ_h;
5. control points (cell medians of reliable heights) → ordinary kriging (local, by blocks,
   the variogram fitted once) → DEM + kriging variance on every valid pixel.

Steps 2–4 run per strip of lines (:func:`match_strip`) and are merged by
:func:`line_statistics`, so a flight line streams in memory bounded by a strip: what a strip
keeps is its control points (one per cell), its counts and a regular sample of its heights and
second differences for the line's robust statistics (the datum, σ_d and the relief). The
sample holds every value while the line has at most ``SAMPLE_SIZE`` pixels, so those
statistics are exact up to there, and a regular lattice of ``SAMPLE_SIZE`` values beyond.
:func:`relative_dem` runs the same steps on whole arrays.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..progress import Progress, as_progress
from ..sensor.offset import Offset, merged_offset
from .disparity import (
    MIN_PEAK,
    MIN_SHARPNESS,
    REFINE,
    SEARCH_ACROSS,
    SEARCH_ALONG,
    WINDOW,
    Disparity,
    _window,
    disparity_halo,
    disparity_map,
    noise_from_differences,
    second_differences,
)
from .height import (
    HeightFactor,
    HeightPrecision,
    disparity_to_height,
    relief_test,
    window_centres,
)
from .kriging import (
    N_CLOSEST_POINTS,
    VARIOGRAM,
    LocalKriging,
    Variogram,
    cross_validate,
    fit_variogram,
)

#: Fewest reliable pixels worth a DEM.
MIN_RELIABLE = 100
#: One control point per cell of this many pixels (the median of its reliable heights).
POINT_SPACING = 5
#: Lines per strip of a streamed flight line (rounded to whole control-point cells).
STRIP_ROWS = 512
#: Values kept for the line's robust statistics (heights; as many second differences).
SAMPLE_SIZE = 2**21


@dataclass(frozen=True)
class Kriging:
    """How the DEM is interpolated from the matched heights (§3.2, "kriging"): one control
    point per ``point_spacing`` pixels, the ``variogram`` model, and ``n_closest_points`` in
    each local kriging neighbourhood.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.Kriging()
    Kriging(point_spacing=5, variogram='spherical', n_closest_points=32)
    """

    point_spacing: int = POINT_SPACING
    variogram: str = VARIOGRAM
    n_closest_points: int = N_CLOSEST_POINTS


@dataclass(frozen=True)
class RelativeDem:
    dem: np.ndarray  # float32 m, 0 = lowest reliable region, NaN outside the valid mask
    variance: np.ndarray  # kriging variance, m²
    height: np.ndarray  # per-pixel height from the disparity (NaN where not reliable)
    disparity: Disparity
    offset: Offset
    factor: HeightFactor
    precision: HeightPrecision
    variogram: Variogram
    points: tuple[np.ndarray, np.ndarray, np.ndarray]  # control points: col, row, height
    cross_validation: dict | None


def control_points(
    height: np.ndarray, reliable: np.ndarray, spacing: int, min_fill: float = 0.5
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One control point per ``spacing × spacing`` cell: the median of its reliable heights.

    The cell median is robust to the odd mismatch and thins the strongly correlated
    neighbouring disparities (windows overlap) to a point set kriging can handle.
    Cells with fewer than ``min_fill`` reliable pixels give no point.
    Returns (x = column, y = row, z) of the cell centres.
    """
    s = int(spacing)
    rows, cols = height.shape
    ny, nx = -(-rows // s), -(-cols // s)
    pad = np.full((ny * s, nx * s), np.nan)
    pad[:rows, :cols] = np.where(reliable, height, np.nan)
    cells = pad.reshape(ny, s, nx, s).transpose(0, 2, 1, 3).reshape(ny, nx, s * s)
    count = np.isfinite(cells).sum(axis=2)
    keep = count >= max(1, min_fill * s * s)
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            med = np.nanmedian(cells[keep], axis=1)
    iy, ix = np.nonzero(keep)
    y = np.minimum(iy * s + (s - 1) / 2.0, rows - 1)
    x = np.minimum(ix * s + (s - 1) / 2.0, cols - 1)
    return x.astype(float), y.astype(float), med


def strip_rows(point_spacing: int = POINT_SPACING, rows: int = STRIP_ROWS) -> int:
    """Lines per strip: about ``rows``, whole control-point cells (so cells never straddle
    two strips)."""
    s = int(point_spacing)
    return s * max(1, round(rows / s))


def match_halo(
    window: int | tuple[int, int] = WINDOW,
    *,
    search_along: int = SEARCH_ALONG,
    refine: int = REFINE,
    center_along: float = 0.0,
) -> int:
    """Lines read above and below a strip for :func:`match_strip`: the matching's own
    (:func:`~geoboresight.dem.disparity.disparity_halo`) plus one window for the second
    differences of σ_d."""
    size = _window(window)
    return size[0] + disparity_halo(
        size, search_along=search_along, refine=refine, center_along=center_along
    )


def _pair(vnir, swir, valid=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The two matching images as float64 on one grid, and where both are usable (finite and
    ``valid``); a clear error when the images or the mask are on different grids."""
    vnir = np.asarray(vnir, np.float64)
    swir = np.asarray(swir, np.float64)
    if vnir.shape != swir.shape:
        raise InputError(
            f"VNIR band {vnir.shape} and SWIR band {swir.shape} are not on the same pixel grid"
        )
    ok = np.isfinite(vnir) & np.isfinite(swir)
    if valid is not None:
        if valid.shape != vnir.shape:
            raise InputError(
                f"the mask {valid.shape} is not on the image grid {vnir.shape}: mismatched grids"
            )
        ok &= valid
    return vnir, swir, ok


def _lattice(index: np.ndarray, stride: int) -> np.ndarray:
    """The regular sample: every ``stride``-th value of the line (by its index)."""
    return index % stride == 0 if stride > 1 else np.ones(index.shape, bool)


@dataclass(frozen=True)
class StripMatches:
    """What one strip of lines contributes to the relative DEM of its flight line."""

    disparity: Disparity  # the strip's own lines
    valid: np.ndarray  # the strip's valid pixels (the DEM covers them)
    points: tuple[np.ndarray, np.ndarray, np.ndarray]  # column, line, raw height (m)
    heights: np.ndarray  # lattice sample of the reliable raw heights (m)
    seconds: np.ndarray  # lattice sample of second differences of the parallax disparity
    centres: tuple[np.ndarray, np.ndarray, np.ndarray]  # independent windows: row, col, height
    reliable: int
    valid_count: int


def match_strip(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    factor: HeightFactor,
    center: tuple[float, float],
    rows: slice | None = None,
    first_line: int = 0,
    line_shape: tuple[int, int] | None = None,
    window: int = WINDOW,
    search_along: int = SEARCH_ALONG,
    search_across: int = SEARCH_ACROSS,
    min_peak: float = MIN_PEAK,
    min_sharpness: float = MIN_SHARPNESS,
    refine: int = REFINE,
    point_spacing: int = POINT_SPACING,
    sample_size: int = SAMPLE_SIZE,
    progress: Progress | None = None,
) -> StripMatches:
    """Match one strip of a flight line and reduce it to what the line's DEM needs (§3.2).

    Parameters
    ----------
    vnir, swir : 2-D arrays
        The strip's matching images with their halo (:func:`match_halo` lines above and below),
        or a whole image.
    valid : bool array, optional
        Pixels usable in both images (no nodata, no cloud).
    factor : HeightFactor
        Disparity per metre of height (px/m).
    center : (along, across)
        The flight line's global offset: where the search is centred.
    rows : slice, optional
        The strip's own lines within the arrays (all of them by default).
    first_line : int
        The line of the flight line that the arrays' first line is.
    line_shape : (lines, columns), optional
        The flight line's size (default: the arrays'); sets the sample's stride.
    window, search_along, search_across, min_peak, min_sharpness, refine
        The matching (:func:`~geoboresight.dem.disparity.disparity_map`).
    point_spacing : int
        Side of the control-point cells; a strip starts on a cell boundary
        (:func:`strip_rows`).
    sample_size : int
        Values kept over the whole line for its robust statistics.
    progress : Progress, optional

    Returns
    -------
    StripMatches
        The strip's disparity and valid pixels, its control points (raw heights, before the
        datum), lattice samples of its reliable heights and of the second differences of its
        parallax disparity, the heights of its independent windows for the relief test
        (:func:`~geoboresight.dem.height.window_centres`), and its counts of reliable and
        valid pixels.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2: image matching,
    disparity to relative height, Figures 8 and 9).
    """
    vnir, swir, ok = _pair(vnir, swir, valid)
    height, width = line_shape or vnir.shape
    own = range(vnir.shape[0])[rows if rows is not None else slice(None)]
    own = slice(own.start, own.stop)
    # One internal block: the caller's halo is the block's.
    disp = disparity_map(
        vnir,
        swir,
        ok,
        window=window,
        search_along=search_along,
        search_across=search_across,
        center=center,
        refine=refine,
        min_peak=min_peak,
        min_sharpness=min_sharpness,
        block_rows=vnir.shape[0] if rows is not None else 256,
        open_ends=(first_line > 0, first_line + vnir.shape[0] < height),
        progress=progress,
    )
    # The disparity component along the parallax direction carries the height.
    k = factor.magnitude
    d_par = (disp.along * factor.along + disp.across * factor.across) / k
    sec = second_differences(d_par, disp.reliable, disp.window[0], rows=own)
    # The lattice of second differences: along the lines then along the columns, by centre.
    s = disp.window[0]
    line0 = first_line + own.start
    n_lines = own.stop - own.start
    index = _second_index(disp.reliable, d_par, own, s, line0, height, width)
    seconds = sec[_lattice(index, _stride(2 * height * width, sample_size))].astype(np.float32)
    reliable = disp.reliable[own]
    h = disparity_to_height(disp.along[own], disp.across[own], factor)
    ok_h = reliable & np.isfinite(h)
    pix = (line0 + np.arange(n_lines))[:, None] * width + np.arange(width)[None, :]
    # What the line keeps of a strip is stored in float32 (memory; x and y are exact).
    heights = h[ok_h & _lattice(pix, _stride(height * width, sample_size))].astype(np.float32)
    x, y, z = (a.astype(np.float32) for a in control_points(h, reliable, point_spacing))
    # The relief test's independent heights: one per window on the line's lattice.
    cr, cc, ch = window_centres(h, ok_h, disp.window, first_line=line0)
    own_disp = Disparity(
        along=disp.along[own],
        across=disp.across[own],
        peak=disp.peak[own],
        sharpness=disp.sharpness[own],
        reliable=reliable,
        window=disp.window,
        search=disp.search,
    )
    return StripMatches(
        own_disp,
        ok[own],
        (x, y + np.float32(line0), z),
        heights,
        seconds,
        (cr.astype(np.int32), cc.astype(np.int32), ch.astype(np.float32)),
        int(reliable.sum()),
        int(ok[own].sum()),
    )


def _stride(n_values: int, sample_size: int) -> int:
    return max(1, math.ceil(n_values / max(1, int(sample_size))))


def _second_index(reliable, d_par, own, s, line0, height, width) -> np.ndarray:
    """The index on the line of every finite second difference of
    :func:`~geoboresight.dem.disparity.second_differences` (same order): its centre's pixel
    index, offset by the line's size for the differences along the columns."""
    d = np.where(reliable, d_par, np.nan)
    out = []
    lo, hi = max(own.start, s), min(own.stop, d.shape[0] - s)
    if hi > lo:
        fin = np.isfinite(d[lo - s : hi - s] - 2 * d[lo:hi] + d[lo + s : hi + s])
        r, c = np.nonzero(fin)
        out.append((line0 + lo - own.start + r) * width + c)
    if d.shape[1] > 2 * s and own.stop > own.start:
        o = d[own]
        fin = np.isfinite(o[:, : -2 * s] - 2 * o[:, s:-s] + o[:, 2 * s :])
        r, c = np.nonzero(fin)
        out.append(height * width + (line0 + r) * width + c + s)
    return np.concatenate(out) if out else np.empty(0, np.int64)


@dataclass(frozen=True)
class LineStatistics:
    """The flight line's matching merged from its strips."""

    datum: float  # raw height (m) of the lowest reliable region, set to 0 m
    precision: HeightPrecision
    points: tuple[np.ndarray, np.ndarray, np.ndarray]  # column, line, height above the datum
    reliable: int
    valid: int


def line_statistics(
    strips,
    *,
    factor: HeightFactor,
    window: int = WINDOW,
    min_peak: float = MIN_PEAK,
    zero_percentile: float = 1.0,
    progress: Progress | None = None,
) -> LineStatistics:
    """Merge the strips of a flight line (:func:`match_strip`, in line order): the datum (the
    ``zero_percentile`` of the reliable heights is 0 m), σ_d and the height precision, and the
    control points above the datum.

    Raises :class:`InputError` when there are too few reliable matches or control points.
    """
    progress = as_progress(progress)
    strips = list(strips)
    n_rel = sum(p.reliable for p in strips)
    n_ok = sum(p.valid_count for p in strips)
    progress.info(
        f"disparity: {n_rel} reliable pixels of {n_ok} valid "
        f"({100.0 * n_rel / max(n_ok, 1):.1f} %), window {window} px"
    )
    if n_rel < MIN_RELIABLE:
        raise InputError(
            f"no reliable matches between the VNIR and SWIR images ({n_rel} pixels pass the "
            f"reliability test with a {window} px window, min_peak {min_peak}): use a larger "
            f"matching window (e.g. {2 * (window // 2) + 1 + 10} px) or lower min_peak, and "
            "check that both bands see the same scene"
        )
    heights = np.concatenate([p.heights for p in strips])
    if heights.size == 0:
        raise InputError("no reliable height to set the lowest region to 0")
    datum = float(np.percentile(heights, zero_percentile))
    sigma_d = noise_from_differences(np.concatenate([p.seconds for p in strips]))
    cr, cc, ch = (np.concatenate([p.centres[i] for p in strips]) for i in range(3))
    precision = relief_test(ch, cr, cc, sigma_d, factor, window=window)
    x, y, z = (np.concatenate([p.points[i] for p in strips]) for i in range(3))
    return LineStatistics(datum, precision, (x, y, z - datum), n_rel, n_ok)


def relative_dem(
    vnir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    factor: HeightFactor,
    window: int = WINDOW,
    search_along: int = SEARCH_ALONG,
    search_across: int = SEARCH_ACROSS,
    min_peak: float = MIN_PEAK,
    min_sharpness: float = MIN_SHARPNESS,
    refine: int = REFINE,
    point_spacing: int = POINT_SPACING,
    variogram: str = VARIOGRAM,
    n_closest_points: int = N_CLOSEST_POINTS,
    zero_percentile: float = 1.0,
    validate: bool = True,
    require_meaningful: bool = True,
    progress: Progress | None = None,
) -> RelativeDem:
    """Relative DEM from one VNIR and one SWIR band on the same grid (paper §3.2).

    ``factor`` is the height-to-disparity factor (:func:`~geoboresight.dem.height.parallax_factor`).

    Raises :class:`InputError` when there are no reliable matches, and when the relief does not
    stand out of the height noise σ_h (unless ``require_meaningful=False``).

    Parameters
    ----------
    vnir, swir : 2-D arrays (lines, columns) on the same grid
        The matched images, e.g. band means of 900–970 nm and 980–1100 nm
        (:func:`~geoboresight.sensor.bands.band_mean`).
    valid : bool array, optional
        Pixels usable in both images (no nodata, no cloud); non-finite pixels are always left
        out. The DEM covers exactly these pixels.
    factor : HeightFactor
        Disparity per metre of height (px/m), along- and across-track
        (:func:`~geoboresight.dem.height.parallax_factor` or
        :func:`~geoboresight.dem.height.height_factor`).
    window : int
        Matching window (odd, pixels), as in :func:`~geoboresight.dem.disparity.disparity_map`.
    search_along, search_across : int
        Integer search range (±px) around the global boresight offset.
    min_peak, min_sharpness : float
        Reliability thresholds on the NCC peak (0–1) and on its curvature.
    refine : int
        Sub-pixel refinement passes of the matching.
    point_spacing : int
        Side (pixels) of the cells that each give one control point, the median of their
        reliable heights.
    variogram : {"spherical", "exponential", "gaussian", "linear", "power"}
        Variogram model fitted to the control points (PyKrige).
    n_closest_points : int
        Control points in each local kriging neighbourhood
        (:class:`~geoboresight.dem.kriging.LocalKriging`).
    zero_percentile : float
        Percentile (0–100) of the reliable heights set to 0 m: the lowest region.
    validate : bool
        Run a hold-out cross-validation of the kriging.
    require_meaningful : bool
        Refuse (InputError) a DEM whose relief does not stand out of the height noise σ_h.
    progress : Progress, optional
        Receives progress and messages (offset, reliable pixels, precision, variogram).

    Returns
    -------
    RelativeDem
        ``dem`` (float32, m; 0 = lowest reliable region, NaN outside the valid pixels) and its
        kriging ``variance`` (float32, m²); ``height``, the per-pixel height from the
        disparity (NaN where not reliable); the ``disparity``, the global ``offset``, the
        ``factor``, the height ``precision`` (σ_d, σ_h, relief, whether it is meaningful), the
        fitted ``variogram``, the control ``points`` (column, row, height) and the
        ``cross_validation`` statistics (None unless ``validate``).

    Raises
    ------
    InputError
        When the images or the mask are not on one grid, there are too few reliable matches or
        control points, or (with ``require_meaningful``) the relief does not stand out of σ_h.
    ParameterError
        When the factor is zero or not finite, an option is out of range, or the variogram fit
        fails.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2: relative DEM, the
    lowest region defined as 0, interpolated by kriging; Figure 9(D)).
    Guizar-Sicairos, M.; Thurman, S.T.; Fienup, J.R. Efficient subpixel image registration
    algorithms. Opt. Lett. 2008, 33, 156–158. https://doi.org/10.1364/OL.33.000156
    Matheron, G. Principles of geostatistics. Econ. Geol. 1963, 58, 1246–1266.
    Cressie, N.A.C. Statistics for Spatial Data, revised ed.; Wiley: New York, NY, USA, 1993.
    """
    progress = as_progress(progress)
    factor.check()
    vnir, swir, ok = _pair(vnir, swir, valid)
    offset = merged_offset(vnir, swir, ok)
    progress.info(
        f"boresight offset: {offset.along:+.3f} px along-track, {offset.across:+.3f} px "
        "across-track (search centre)"
    )
    strip = match_strip(
        vnir,
        swir,
        ok,
        factor=factor,
        center=(offset.along, offset.across),
        window=window,
        search_along=search_along,
        search_across=search_across,
        min_peak=min_peak,
        min_sharpness=min_sharpness,
        refine=refine,
        point_spacing=point_spacing,
        progress=progress.sub(0.0, 0.3),
    )
    line = line_statistics(
        [strip],
        factor=factor,
        window=window,
        min_peak=min_peak,
        zero_percentile=zero_percentile,
        progress=progress,
    )
    precision = line.precision
    progress.info(precision.message())
    if not precision.meaningful and require_meaningful:
        raise InputError(precision.message())
    x, y, z = line.points
    vg = fit_points(x, y, z, variogram, progress, precision.sigma_h_m)
    kr = LocalKriging(x, y, z, vg, n_closest_points)
    dem, var = kr.grid_rows(0, vnir.shape[0], vnir.shape[1], ok)
    cv = None
    if validate:
        cv = validate_kriging(x, y, z, vg, n_closest_points, progress, kr)
    progress.update(1.0, "relative DEM done")
    disp = strip.disparity
    h = disparity_to_height(disp.along, disp.across, factor) - line.datum
    h = np.where(disp.reliable, h, np.nan)
    return RelativeDem(
        dem.astype(np.float32),
        var.astype(np.float32),
        h.astype(np.float32),
        disp,
        offset,
        factor,
        precision,
        vg,
        (x, y, z),
        cv,
    )


def fit_points(
    x, y, z, model: str, progress: Progress | None = None, sigma_h: float = 0.0
) -> Variogram:
    """The variogram of the line's control points (:func:`~geoboresight.dem.kriging.
    fit_variogram`), refusing fewer than 10 points with the remedy. Its nugget is at least
    ``sigma_h²``: the heights' matching noise is a measurement error the kriging filters."""
    if x.size < 10:
        raise InputError(
            f"only {x.size} control points: too few reliable matches for a surface; use a "
            "larger matching window or a smaller point spacing"
        )
    vg = fit_variogram(x, y, z, model=model, min_nugget=float(sigma_h) ** 2)
    as_progress(progress).info(f"{x.size} control points; variogram {vg.model}: {vg.describe()}")
    return vg


def validate_kriging(
    x, y, z, variogram, n_closest_points, progress=None, kriging: LocalKriging | None = None
) -> dict:
    """Hold-out cross-validation of the kriging (:func:`~geoboresight.dem.kriging.
    cross_validate`, reusing ``kriging`` when given), reported."""
    cv = cross_validate(x, y, z, variogram, n_closest_points=n_closest_points, kriging=kriging)
    as_progress(progress).info(
        f"kriging cross-validation ({cv['n']} held-out points): RMSE {cv['rmse_m']:.2f} m, "
        f"mean error {cv['mean_error_m']:+.2f} m"
    )
    return cv
