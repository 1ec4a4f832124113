"""A surface model's cast shadow as the shadow map's prior, in steps on arrays.

The shadow map with a surface model (:func:`geoboresight.shadow.darkness.dsm_shadow_fraction`)
starts from the shadow the DSM casts for the sun. The steps here take the heights of a block of
lines and one small value, :class:`SurfacePrior` (the sun, the grid's geometry, the relief,
the clearance, the reach, the registration's move), and give what the map needs of the
model: the cast on sub-cells (:func:`sub_cell_cast`), the cell fractions moved by the
registration (:func:`prior_fraction`), the heights moved with them
(:func:`registered_heights`), the pixels a caster beyond the model's edge could shade
(:func:`unseen_pixels`), the move that registers the cast onto the image
(:func:`register_prior`) and the block's shadow fraction with the model
(:func:`prior_map_block`).

References
----------
Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the shadow
simulated from a surface model and the sun).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from . import darkness
from .illumination import (
    SUPERSAMPLE,
    SURFACES,
    cell_fraction,
    march_steps,
    shadow_fraction,
    sub_cell_shadow,
    sun_step,
    unseen_casters,
)
from .surface import edge_tolerance

#: Share of the valid pixels in shadow above which the scene's sunlit mode is suspect: a
#: shadow map calibrates itself on the sunlit ground, which must be the larger part.
MOSTLY_SHADOW = 0.6
#: Share of the predicted shadow (away from its edges) spectrally lit above which the
#: surface model is suspect (another date, not registered, wrong sun): on the validation
#: scenes with their own DSM it stays below a tenth.
LIT_PREDICTION = 0.2
#: Gain in IoU with the dark pixels that a whole-pixel shift of the predicted shadow must
#: bring before the model is reported as not registered with the image (a tie of a few
#: pixels at the edges is noise).
SHIFT_IOU_GAIN = 0.05


@dataclass(frozen=True, kw_only=True)
class SurfacePrior:
    """What casting a surface model's shadow on a grid needs, besides the heights.

    ``zenith`` and ``azimuth`` (degrees; azimuth clockwise from the grid's north towards the
    sun), ``matrix`` (:func:`geoboresight.shadow.illumination.grid_matrix`: the grid's
    geometry in metres), ``relief`` (m, how far shadows reach), ``surface`` (``"blocks"`` or
    ``"smooth"``, :data:`geoboresight.shadow.illumination.SURFACES`), ``clearance`` (m: a
    caster must rise this far above the sun line), ``top`` (m, the highest valid height),
    ``height`` (lines of the whole grid), ``ray`` ((Δrow, Δcol) per cell towards the sun, and
    the steps that clear the relief), ``reach`` (cells down-sun by which the clearance
    shortens a shadow on level ground), ``shift`` (rows, columns by which the cast shadow
    is moved: the registration), ``noise`` (m, the heights' noise,
    :func:`geoboresight.shadow.surface.height_noise`) and ``tolerance`` (px within which the
    cast edges are taken, :func:`geoboresight.shadow.surface.edge_tolerance`)."""

    zenith: float
    azimuth: float
    matrix: np.ndarray
    relief: float
    surface: str
    clearance: float = 0.0
    top: float = 0.0
    height: int = 0
    ray: tuple = (0.0, 0.0, 0)
    reach: float = 0.0
    shift: tuple = (0.0, 0.0)
    noise: float = 0.0
    tolerance: int = darkness.DSM_TOLERANCE


def surface_prior(
    relief: float,
    top: float,
    *,
    sun_zenith: float,
    sun_azimuth: float,
    transform: np.ndarray,
    surface: str,
    clearance: float,
    shape: tuple[int, int],
    noise: float = 0.0,
) -> SurfacePrior:
    """The :class:`SurfacePrior` of a surface model: the ray towards the sun, one cell a
    step, the steps it takes to clear the relief, and the ``reach`` of the clearance.

    The sun line rises ``rise`` m per cell towards the sun
    (:func:`geoboresight.shadow.illumination.sun_step`), so a caster that must clear it by
    ``clearance`` m casts a shadow on level ground ``clearance / rise`` cells short
    (``clearance · tan(zenith)`` metres).

    Parameters
    ----------
    relief : float
        Highest minus lowest height (m): how far a shadow can reach.
    top : float
        The highest valid height (m).
    sun_zenith, sun_azimuth : float
        Degrees; the azimuth clockwise from the grid's north towards the sun.
    transform : array (2, 2)
        The grid's geometry in metres (:func:`geoboresight.shadow.illumination.grid_matrix`).
    surface : {"blocks", "smooth"}
        Flat-topped cells or an interpolated surface
        (:data:`geoboresight.shadow.illumination.SURFACES`).
    clearance : float
        Height (m) a caster must rise above the sun line to cast shadow.
    shape : (int, int)
        Lines and columns of the whole grid.
    noise : float
        The heights' noise (m, :func:`geoboresight.shadow.surface.height_noise`): a DSM of
        another source has its cast edges taken within one more pixel
        (:func:`geoboresight.shadow.surface.edge_tolerance`).

    Returns
    -------
    SurfacePrior
        Unmoved (``shift`` (0, 0)).

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1: the shadow simulated from a surface model and the sun).
    """
    drow, dcol, rise = sun_step(sun_zenith, sun_azimuth, transform, 1.0)
    steps = march_steps(relief, rise, shape, drow, dcol)
    return SurfacePrior(
        zenith=sun_zenith,
        azimuth=sun_azimuth,
        matrix=transform,
        relief=relief,
        surface=surface,
        clearance=float(clearance),
        top=float(top),
        height=shape[0],
        ray=(drow, dcol, steps),
        reach=float(clearance) / rise if rise > 0 else 0.0,
        noise=float(noise),
        tolerance=edge_tolerance(noise, darkness.DSM_TOLERANCE),
    )


def _cast(surface_prior: SurfacePrior) -> dict:
    """The cast's keywords: the sun, the grid, the relief, the surface, the clearance."""
    p = surface_prior
    return dict(
        sun_zenith=p.zenith,
        sun_azimuth=p.azimuth,
        transform=p.matrix,
        relief=p.relief,
        interpolation=SURFACES[p.surface],
        clearance=p.clearance,
    )


def sub_cell_cast(
    heights: np.ndarray, valid: np.ndarray | None = None, *, surface_prior: SurfacePrior
) -> np.ndarray:
    """The cast shadow on the sub-cell grid, as the prior casts it (with the clearance),
    unmoved: what is registered is the prior the refinement starts from.

    Parameters
    ----------
    heights : array (lines, columns)
        The surface model's heights (m).
    valid : bool array (lines, columns), optional
        Cells with a height.
    surface_prior : SurfacePrior

    Returns
    -------
    bool array (lines × :data:`~geoboresight.shadow.illumination.SUPERSAMPLE`, columns × it)
        :func:`geoboresight.shadow.illumination.sub_cell_shadow`.
    """
    return sub_cell_shadow(heights, valid, **_cast(surface_prior))


def prior_fraction(
    heights: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    surface_prior: SurfacePrior,
    sub_cells: np.ndarray | None = None,
) -> np.ndarray:
    """The cast-shadow fraction of each cell: the shadow map's prior.

    Parameters
    ----------
    heights : array (lines, columns)
        The surface model's heights (m).
    valid : bool array (lines, columns), optional
        Cells with a height.
    surface_prior : SurfacePrior
        Its ``shift`` moves the cast shadow (the registration).
    sub_cells : bool array, optional
        :func:`sub_cell_cast` of the same block, when already cast.

    Returns
    -------
    float32 array (lines, columns)
        0–1, NaN where invalid: :func:`geoboresight.shadow.illumination.shadow_fraction`, or
        :func:`geoboresight.shadow.illumination.cell_fraction` of ``sub_cells``.
    """
    if sub_cells is None:
        return shadow_fraction(heights, valid, shift=surface_prior.shift, **_cast(surface_prior))
    ok = np.isfinite(heights) if valid is None else np.asarray(valid, bool) & np.isfinite(heights)
    return cell_fraction(sub_cells, SUPERSAMPLE, surface_prior.shift, ok).astype(np.float32)


def registered_heights(
    heights: np.ndarray, valid: np.ndarray | None = None, *, surface_prior: SurfacePrior
) -> np.ndarray:
    """The heights moved with the cast shadow, so that a caster's top stays beside its
    shadow.

    Parameters
    ----------
    heights : array (lines, columns)
        The surface model's heights (m).
    valid : bool array (lines, columns), optional
        Cells with a height.
    surface_prior : SurfacePrior
        Its ``shift`` (rows, columns) is the move.

    Returns
    -------
    array (lines, columns)
        Moved bilinearly (:func:`scipy.ndimage.shift`); NaN where the nearest source cell
        has no height, or is invalid.
    """
    from scipy import ndimage

    z = np.asarray(heights, np.float64) if valid is None else np.where(valid, heights, np.nan)
    if tuple(surface_prior.shift) == (0.0, 0.0):
        return z
    ok = ndimage.shift(np.isfinite(z).astype(np.float64), surface_prior.shift, order=0, cval=0.0)
    filled = np.where(np.isfinite(z), z, np.nanmean(z) if np.isfinite(z).any() else 0.0)
    moved = ndimage.shift(filled, surface_prior.shift, order=1, mode="nearest")
    return np.where(ok > 0.5, moved, np.nan)


def unseen_pixels(
    heights: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    surface_prior: SurfacePrior,
    row0: int = 0,
) -> np.ndarray:
    """The pixels a caster beyond the surface model's edge could shade.

    Parameters
    ----------
    heights : array (lines, columns)
        The surface model's heights (m) on lines ``row0`` on of the grid.
    valid : bool array (lines, columns), optional
        Cells with a height.
    surface_prior : SurfacePrior
        Its ``top``, ``clearance`` and ``height`` (the whole grid's lines) bound the casters.
    row0 : int
        The block's first line in the grid.

    Returns
    -------
    bool array (lines, columns)
        :func:`geoboresight.shadow.illumination.unseen_casters`.
    """
    p = surface_prior
    return unseen_casters(
        heights,
        valid,
        sun_zenith=p.zenith,
        sun_azimuth=p.azimuth,
        top=p.top,
        transform=p.matrix,
        row0=row0,
        height=p.height,
        clearance=p.clearance,
    )


def prior_halo(
    surface_prior: SurfacePrior, halo: int, cast_halo: tuple[int, int]
) -> tuple[int, int]:
    """Lines a block of the map with a surface model needs around it.

    Parameters
    ----------
    surface_prior : SurfacePrior
    halo : int
        The spectral halo (:func:`geoboresight.shadow.darkness.shadow_map_halo`).
    cast_halo : (int, int)
        The cast's (above, below) (:func:`geoboresight.shadow.illumination.halo_rows`).

    Returns
    -------
    (int, int)
        Lines above and below: both halos (the spectral one widened to the prior's
        ``tolerance``), and towards the sun the sweep of the predicted
        shadow's far end, ``ceil(reach · |Δrow|) + 1`` lines
        (:func:`geoboresight.shadow.darkness.dsm_shadow_fraction`).
    """
    drow = surface_prior.ray[0]
    sweep = int(np.ceil(surface_prior.reach * abs(drow))) + 1
    up, down = (sweep, 0) if drow < 0 else (0, sweep)
    # The spectral halo holds the registration's tolerance; a wider one needs the rest.
    halo += max(0, surface_prior.tolerance - darkness.DSM_TOLERANCE)
    return halo + cast_halo[0] + up, halo + cast_halo[1] + down


def _model_fraction(blue, nir, swir, valid, heights, heights_valid, prior, unseen, p, **block):
    """:func:`geoboresight.shadow.darkness.shadow_fraction_block` with the surface model: the
    ``prior`` and the ``unseen`` pixels of the block, ``p`` its :class:`SurfacePrior`."""
    return darkness.shadow_fraction_block(
        blue,
        nir,
        swir,
        valid,
        prior=prior,
        heights=registered_heights(heights, heights_valid, surface_prior=p),
        clearance=p.clearance,
        unseen=unseen,
        ray=p.ray,
        reach=p.reach,
        tolerance=p.tolerance,
        **block,
    )


class PriorBlock(NamedTuple):
    """What :func:`prior_map_block` gives of a block (arrays of its lines and columns)."""

    fraction: np.ndarray  # float32 shadow fraction, NaN where invalid
    deep: np.ndarray  # bool: predicted shadow away from its edges
    lit: np.ndarray  # bool: of ``deep``, the pixels spectrally lit
    unseen: np.ndarray  # bool: pixels a caster beyond the model's edge could shade
    holes: np.ndarray  # bool: valid pixels the model has no height for


def prior_map_block(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    heights: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    heights_valid: np.ndarray,
    calibration: darkness.SceneCalibration,
    dark_levels: tuple,
    edge_pixels: int,
    surface_prior: SurfacePrior,
    row0: int = 0,
) -> PriorBlock:
    """The shadow fraction of a block of lines with a surface model, and how the model and
    the image agree on it.

    The fraction is :func:`geoboresight.shadow.darkness.shadow_fraction_block` with the prior
    (:func:`prior_fraction`), the moved heights, the unseen pixels and the model's ray and
    reach. Pixels the model has no height for (``holes``: beyond its extent, its nodata)
    take the spectral estimate alone, as without a model: no prior says anything there (its
    "no shadow away from the predicted shadow" would drop them all).

    Parameters
    ----------
    blue, nir, swir : arrays (n_bands, lines, columns)
        As :func:`geoboresight.shadow.darkness.shadow_map_block`.
    heights : array (lines, columns)
        The surface model's heights (m) on the image's grid.
    valid : bool array (lines, columns), optional
        Pixels valid in every band read.
    heights_valid : bool array (lines, columns)
        Cells with a height.
    calibration, dark_levels, edge_pixels
        As :func:`geoboresight.shadow.darkness.shadow_map_block`.
    surface_prior : SurfacePrior
    row0 : int
        The block's first line in the grid.

    Returns
    -------
    PriorBlock
        The fraction; ``deep``, the predicted shadow (≥ 0.5) eroded by a pixel; ``lit``, the
        pixels of ``deep`` brighter than
        :data:`~geoboresight.shadow.darkness.LIT_DARKNESS`; ``unseen`` and ``holes`` (all
        where the fraction is defined).
    """
    from scipy import ndimage

    ok = np.ones(np.shape(heights), bool) if valid is None else np.asarray(valid, bool)
    kw = dict(calibration=calibration, dark_levels=dark_levels, edge_pixels=edge_pixels)
    prior = prior_fraction(heights, heights_valid, surface_prior=surface_prior)
    unseen = unseen_pixels(heights, heights_valid, surface_prior=surface_prior, row0=row0)
    f, d = _model_fraction(
        blue,
        nir,
        swir,
        ok,
        heights,
        heights_valid,
        prior,
        unseen,
        surface_prior,
        **kw,
    )
    holes = ok & ~np.asarray(heights_valid, bool)
    if holes.any():
        f_spectral, _ = darkness.shadow_fraction_block(blue, nir, swir, ok, **kw)
        f = np.where(holes, f_spectral, f)
    defined = np.isfinite(f)
    deep = ndimage.binary_erosion(prior >= darkness.PREDICTED_SHADOW) & defined
    with np.errstate(invalid="ignore"):
        lit = deep & (d > darkness.LIT_DARKNESS)
    return PriorBlock(f, deep, lit, unseen & defined, holes & defined)


def register_prior(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    heights: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    heights_valid: np.ndarray,
    calibration: darkness.SceneCalibration,
    dark_levels: tuple,
    edge_pixels: int,
    surface_prior: SurfacePrior,
    row0: int = 0,
    register: bool = True,
) -> tuple[SurfacePrior, dict]:
    """Register the surface model's cast shadow onto the image on a block of lines (a central
    block of the flight line), and measure how the two agree there.

    With ``register``, the cast shadow is moved by the sub-pixel shift that best matches the
    NIR's darkness (:func:`geoboresight.shadow.darkness.prior_registration`), kept only where the
    image's parts agree on it. Then the best whole-pixel shift of what remains onto the dark
    pixels is measured (:func:`geoboresight.shadow.darkness.prior_agreement`: a DSM more than a
    pixel off, another date). The block's arguments are those of :func:`prior_map_block`.

    Returns
    -------
    (SurfacePrior, dict)
        ``surface_prior`` with the move as its ``shift``, and the registration's and the
        agreement's figures (:func:`geoboresight.shadow.darkness.registration_result`,
        :func:`geoboresight.shadow.darkness.prior_agreement`).
    """
    ok = np.ones(np.shape(heights), bool) if valid is None else np.asarray(valid, bool)
    sub_cells = sub_cell_cast(heights, heights_valid, surface_prior=surface_prior)
    agreement = darkness.registration_result()
    if register:
        n = darkness.signal(nir, dark_levels[1])
        evidence = darkness.nir_darkness(n, calibration, ok & heights_valid)
        agreement = darkness.prior_registration(evidence, sub_cells, SUPERSAMPLE)
        surface_prior = dataclasses.replace(
            surface_prior,
            shift=(agreement["dsm_registration_rows"], agreement["dsm_registration_columns"]),
        )
    prior = prior_fraction(heights, heights_valid, surface_prior=surface_prior, sub_cells=sub_cells)
    unseen = unseen_pixels(heights, heights_valid, surface_prior=surface_prior, row0=row0)
    _, d = _model_fraction(
        blue,
        nir,
        swir,
        ok,
        heights,
        heights_valid,
        prior,
        unseen,
        surface_prior,
        calibration=calibration,
        dark_levels=dark_levels,
        edge_pixels=edge_pixels,
    )
    agreement.update(darkness.prior_agreement(d, prior, ok))
    return surface_prior, agreement


def prior_method(surface_prior: SurfacePrior, *, registered: bool, edge_pixels: int) -> str:
    """The method of the shadow map with a surface model, in words, its numbers taken from
    the kernels' constants and ``surface_prior``: the product's ``method`` tag."""
    p = surface_prior
    moved = (
        f", moved by {p.shift[0]:+.2f} rows and {p.shift[1]:+.2f} columns to match the NIR's "
        "darkness"
        if registered
        else ""
    )
    return (
        f"surface model prior: cast shadow from the DSM and the sun (ray march, {p.surface} "
        f"surface{moved}), refined by SWIR/NIR darkness within {p.tolerance} px (height noise "
        f"{p.noise:.2f} m; lit "
        f"above {darkness.log_fraction_text(darkness.LIT_DARKNESS)} of the sunlit mode, rim shadow at "
        f"or below {darkness.log_fraction_text(darkness.RIM_DARKNESS)} unless more than the clearance "
        f"({p.clearance:g} m) above the shadow: a caster's top; beyond it, down-sun of the "
        f"predicted shadow by the {p.reach:.2f} cells the clearance shortens a shadow, where "
        "connected to it along the sun's direction) and unmixed within "
        f"{edge_pixels} px (at least half shaded only where as dark as core shadow or "
        "deep in the prediction; beside it, no more shaded than the signal says against "
        "the darkest lit pixel next to the zone); no shadow away from the predicted "
        "shadow except where a caster beyond the surface model's edge could shade (spectral "
        "estimate there) and in cells the model shades in part that are as dark as core "
        "shadow; classes by Table 2's fraction intervals"
    )


def spectral_method(core: float, edge_pixels: int) -> str:
    """The method of the shadow map without a surface model, in words (its ``method`` tag)."""
    return (
        "dark-object subtraction; SWIR darkness against its sunlit mode (core ≤ "
        f"{core:.3f}, natural log) on the SWIR resampled by the boresight offset; "
        "not water (blue/NIR); shadow fraction of the pixels within "
        f"{edge_pixels} px by unmixing between the local sunlit and core-shadow signals; "
        "classes by Table 2's fraction intervals"
    )
