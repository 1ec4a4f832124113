"""The relative DEM chain of §3.2, arrays in, DEM out.

1. boresight offset (global, sub-pixel): where to centre the search;
2. dense disparity around it, with reliability (peak, sharpness), clouds and nodata masked;
3. disparity → height with the height-to-disparity factor; the lowest reliable region is 0;
4. σ_d from the data, σ_h = σ_d / k; refuse when the relief does not stand out of σ_h;
5. control points (block medians of reliable heights) → ordinary kriging (PyKrige, local
   neighbourhood, blockwise) → DEM + kriging variance on every valid pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..progress import Progress, as_progress
from .disparity import (
    MIN_PEAK,
    MIN_SHARPNESS,
    REFINE,
    SEARCH_ACROSS,
    SEARCH_ALONG,
    WINDOW,
    Disparity,
    disparity_map,
    disparity_noise,
)
from .height import (
    HeightFactor,
    HeightPrecision,
    disparity_to_height,
    height_precision,
    zero_lowest,
)
from .kriging import (
    N_CLOSEST_POINTS,
    VARIOGRAM,
    Variogram,
    cross_validate,
    fit_variogram,
    krige_grid,
)
from .offset import Offset, estimate_offset

#: Fewest reliable pixels worth a DEM.
MIN_RELIABLE = 100
#: One control point per cell of this many pixels (the median of its reliable heights).
POINT_SPACING = 5


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
    variogram_model: str = VARIOGRAM,
    n_closest_points: int = N_CLOSEST_POINTS,
    backend: str = "C",
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
        (:func:`~geoboresight.dem.bands.band_mean`).
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
    variogram_model : {"spherical", "exponential", "gaussian", "linear", "power"}
        Variogram model fitted to the control points (PyKrige).
    n_closest_points : int
        Control points in each local kriging neighbourhood.
    backend : {"C", "loop"}
        PyKrige's backend for moving-window kriging.
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
    offset = estimate_offset(vnir, swir, ok)
    progress.info(
        f"boresight offset: {offset.along:+.3f} px along-track, {offset.across:+.3f} px "
        "across-track (search centre)"
    )
    disp = disparity_map(
        vnir,
        swir,
        ok,
        window=window,
        search_along=search_along,
        search_across=search_across,
        center=(offset.along, offset.across),
        refine=refine,
        min_peak=min_peak,
        min_sharpness=min_sharpness,
        progress=progress.sub(0.0, 0.3),
    )
    n_rel = int(disp.reliable.sum())
    progress.info(
        f"disparity: {n_rel} reliable pixels of {int(ok.sum())} valid "
        f"({100.0 * n_rel / max(ok.sum(), 1):.1f} %), window {window} px"
    )
    if n_rel < MIN_RELIABLE:
        raise InputError(
            f"no reliable matches between the VNIR and SWIR images ({n_rel} pixels pass the "
            f"reliability test with a {window} px window, min_peak {min_peak}): use a larger "
            f"matching window (e.g. {2 * (window // 2) + 1 + 10} px) or lower min_peak, and "
            "check that both bands see the same scene"
        )
    h = disparity_to_height(disp.along, disp.across, factor)
    h = np.where(disp.reliable, zero_lowest(h, disp.reliable, zero_percentile), np.nan)
    # The disparity component along the parallax direction carries the height.
    k = factor.magnitude
    d_par = (disp.along * factor.along + disp.across * factor.across) / k
    sigma_d = disparity_noise(d_par, disp.reliable, spacing=disp.window[0])
    precision = height_precision(h, disp.reliable, sigma_d, factor)
    progress.info(precision.message())
    if not precision.meaningful and require_meaningful:
        raise InputError(precision.message())
    x, y, z = control_points(h, disp.reliable, point_spacing)
    if x.size < 10:
        raise InputError(
            f"only {x.size} control points: too few reliable matches for a surface; use a "
            "larger matching window or a smaller point spacing"
        )
    vg = fit_variogram(x, y, z, model=variogram_model)
    progress.info(f"{x.size} control points; variogram {vg.model}: {vg.describe()}")
    dem, var = krige_grid(
        x,
        y,
        z,
        vnir.shape,
        vg,
        mask=ok,
        n_closest_points=n_closest_points,
        backend=backend,
        progress=progress.sub(0.3, 0.95),
    )
    cv = None
    if validate:
        cv = cross_validate(x, y, z, vg, n_closest_points=n_closest_points, backend=backend)
        progress.info(
            f"kriging cross-validation ({cv['n']} held-out points): RMSE {cv['rmse_m']:.2f} m, "
            f"mean error {cv['mean_error_m']:+.2f} m"
        )
    progress.update(1.0, "relative DEM done")
    return RelativeDem(
        dem, var, h.astype(np.float32), disp, offset, factor, precision, vg, (x, y, z), cv
    )
