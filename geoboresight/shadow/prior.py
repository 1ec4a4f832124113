"""The surface prior: a surface model's cast shadow as the shadow map's prior, in steps on
arrays.

The steps here take the heights of a block of lines and one small value,
:class:`SurfacePrior` (the sun, the grid's geometry, the relief, the clearance, the reach,
the registration's move), and give what the map needs of the model: the cast on sub-cells
(:func:`sub_cell_cast`), the cell fractions moved by the registration
(:func:`prior_fraction`), the heights moved with them (:func:`registered_heights`), the
pixels a caster beyond the model's edge could shade (:func:`unseen_pixels`); then the shadow
fraction refined from the predicted shadow and the image's darkness
(:func:`dsm_shadow_fraction`), the move that registers the cast onto the image's darkness
(:func:`prior_registration`) and how far the two agree (:func:`prior_agreement`). The block
kernels that run these steps with the spectral map's are in
:mod:`geoboresight.shadow.blocks`.

References
----------
Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1: the shadow
simulated from a surface model and the sun).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError
from . import darkness
from .context import local_mean
from .darkness import (
    CORE_DARKNESS,
    DSM_TOLERANCE,
    EDGE_PIXELS,
    EDGE_WINDOW,
    LIT_DARKNESS,
    PREDICTED_SHADOW,
    REGISTRATION_T,
    RIM_DARKNESS,
    TILES,
    shadow_fraction_estimate,
    unmix_edges,
)
from .illumination import (
    SUPERSAMPLE,
    SURFACES,
    along_ray,
    cell_fraction,
    march_steps,
    shadow_fraction,
    shifted,
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
        The spectral halo (:func:`geoboresight.shadow.blocks.shadow_map_halo`).
    cast_halo : (int, int)
        The cast's (above, below) (:func:`geoboresight.shadow.illumination.halo_rows`).

    Returns
    -------
    (int, int)
        Lines above and below: both halos (the spectral one widened to the prior's
        ``tolerance``), and towards the sun the sweep of the predicted
        shadow's far end, ``ceil(reach · |Δrow|) + 1`` lines
        (:func:`geoboresight.shadow.prior.dsm_shadow_fraction`).
    """
    drow = surface_prior.ray[0]
    sweep = int(np.ceil(surface_prior.reach * abs(drow))) + 1
    up, down = (sweep, 0) if drow < 0 else (0, sweep)
    # The spectral halo holds the registration's tolerance; a wider one needs the rest.
    halo += max(0, surface_prior.tolerance - darkness.DSM_TOLERANCE)
    return halo + cast_halo[0] + up, halo + cast_halo[1] + down


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


def dsm_shadow_fraction(
    dark: np.ndarray,
    prior: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    edge_pixels: int = EDGE_PIXELS,
    window: int = EDGE_WINDOW,
    water: np.ndarray | None = None,
    tolerance: int = DSM_TOLERANCE,
    rim: float = RIM_DARKNESS,
    lit: float = LIT_DARKNESS,
    heights: np.ndarray | None = None,
    clearance: float = 0.0,
    unseen: np.ndarray | None = None,
    ray: tuple[float, float, int] | None = None,
    core: float = CORE_DARKNESS,
    reach: float = 0.0,
) -> np.ndarray:
    """Estimated shadow fraction (float32, 0–1; NaN where invalid) from :func:`darkness` with
    the cast shadow a surface model predicts as the prior.

    Shadow can only be where the surface model puts it, give or take ``tolerance`` pixels of
    registration: outside that zone the fraction is 0, however dark the pixel (a black roof
    or road in the sun), except in a cell the model shades in part (``prior`` > 0: a shaded
    sub-cell) that is as dark as core shadow (``core``), which is at least half shaded: shade
    below the model's resolution (a crown beside a taller one) that it cannot rule out.
    Inside it:

    * a pixel the model shades (``prior`` ≥ 0.5) is shadow unless it is spectrally lit
      (``dark`` > ``lit``, more than half the sunlit mode: the surface model is wrong there,
      e.g. of another date);
    * a pixel within ``tolerance`` of that but not shaded by the model is shadow when it is
      at most ``exp(rim)`` of the sunlit mode and not water (a shadow edge the model puts a
      pixel off), unless (with ``heights``) it stands more than ``clearance`` above the
      lowest predicted-shadow cell within ``tolerance``: then it is the top of the caster
      (a roof or crown beside its own shadow), lit by the sun whatever its darkness;
    * around those, within ``edge_pixels`` (and the zone), the fraction is unmixed between the
      local sunlit and shadowed signals as in :func:`shadow_fraction_estimate`. Those more
      than ``tolerance + 1`` pixels inside the predicted shadow get at least the model's
      fraction (1 inside a cast shadow), and shadow pixels as dark as core shadow (``core``)
      at least 0.5; the others (the predicted shadow's edges and the
      rim) keep their unmixed fraction, so that a mixed edge pixel is shadow when more than
      half of it is shaded, not because it is darker than ``lit``;
    * a pixel beside the predicted shadow (within the zone, not shaded by the model) is
      shaded at most as much as its signal says against the darkest pixel next to it outside
      the zone, taken as its sunlit end: registered within ``tolerance``, no shadow reaches
      that pixel, so a dark material running on past the zone is as dark there in the sun and
      its pixel beside the shadow is not taken for shade.

    With ``ray`` and ``reach`` (cells), the zone of the rim also reaches ``reach`` cells
    down-sun of the predicted shadow, then ``tolerance``: the clearance shortens a shadow by
    ``clearance · tan(zenith)`` at its far end on level ground (``reach`` = the clearance over
    the sun's rise per cell). Beyond the tolerance a shadow goes on from the predicted one
    along the sun's direction, so a rim pixel there is shadow only when the pixel next to it
    towards the sun is shadow too, and is unmixed only next to such a pixel: a dark material
    cut from the shadow by a lit pixel is not taken.

    Where the surface model cannot rule shadow out (``unseen``: a caster beyond its edge could
    shade the pixel, :func:`geoboresight.shadow.illumination.unseen_casters`), the fraction is
    at least the spectral estimate without a surface model (:func:`shadow_fraction_estimate`
    with ``core``), provided (with ``ray``) that no pixel on the way towards the sun to the
    grid's edge is spectrally lit: the shadow of a caster beyond the edge covers the ground
    between the caster and the pixel it shades (on level ground), so it reaches the edge; a
    dark material alone near the edge does not.

    Strips need a halo of ``edge_pixels + window // 2 + tolerance + 1`` lines (and the prior's
    own, :func:`geoboresight.shadow.illumination.halo_rows`).

    Parameters
    ----------
    dark : array
        :func:`darkness` (natural log of the signal over its sunlit mode).
    prior : array
        Cast-shadow fraction from the surface model
        (:func:`geoboresight.shadow.illumination.shadow_fraction`) on the same grid; NaN = 0.
    valid : bool array, optional
    edge_pixels, window : int
        As :func:`shadow_fraction_estimate`.
    water : bool array, optional
        Pixels too blue for skylight (:func:`too_blue`): not shadow outside the prior.
    tolerance : int
        Registration tolerance of the surface model (px).
    rim, lit : float
        Darkness (natural log over the sunlit mode) at or below which a pixel next to the
        predicted shadow is shadow, and above which a predicted one is lit.
    heights : array, optional
        The surface model's heights (m) on the same grid: without them no rim pixel is
        taken for a caster.
    clearance : float
        Height (m) above the predicted shadow's ground beyond which a rim pixel is a caster
        (the prior's clearance: the surface model's height noise).
    unseen : bool array, optional
        Pixels whose casters the surface model may not hold (same grid).
    ray : (Δrow, Δcol, steps), optional
        The march towards the sun (:func:`geoboresight.shadow.illumination.along_ray`);
        strips need :func:`geoboresight.shadow.illumination.halo_rows` lines towards it.
    core : float
        Core-shadow darkness (natural log over the sunlit mode): a shadow pixel this dark is
        at least half shaded, and the spectral estimate on ``unseen`` pixels uses it.
    reach : float
        How far (cells) the clearance shortens a shadow's far end on level ground (0: no
        sweep; used with ``ray``). Strips need ``ceil(reach · |Δrow|) + 1`` more lines towards
        the sun.

    Returns
    -------
    float32 array

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1: the shadow simulated from a surface model and the sun).
    """
    from scipy import ndimage

    d, ok, p, z = _checked_inputs(dark, valid, prior, heights, edge_pixels, window, tolerance)
    shaded = p >= PREDICTED_SHADOW
    # Where the model shades at least half a pixel, give or take the tolerance (sub-cells
    # shaded by height noise on open ground stay out), and down-sun of it by the ``reach`` the
    # clearance takes off a shadow's far end (on level ground).
    base = np.where(shaded & np.isfinite(z), z, np.inf) if z is not None else None
    swept, base = _down_sun(shaded, ray, reach, base)
    near = ndimage.binary_dilation(shaded, iterations=tolerance) if tolerance else shaded
    zone = ndimage.binary_dilation(swept, iterations=tolerance) if tolerance else swept
    # Water (too blue for skylight) is not shadow outside the prior.
    dry = ok if water is None else ok & ~np.asarray(water, bool)
    with np.errstate(invalid="ignore"):
        core_px = ok & shaded & (d <= lit)
        rim_px = dry & zone & ~shaded & (d <= rim)
        # Outside the zone, a cell the model shades in part (a shaded sub-cell: a crown
        # beside a taller one, below the model's resolution) and as dark as core shadow is
        # shadow: the model cannot rule that shade out, and the spectrum says it is there. A
        # dark surface the model does not shade at all stays lit.
        part_px = dry & (p > 0) & ~zone & (d <= core)
    if z is not None:
        with np.errstate(invalid="ignore"):
            ground = ndimage.minimum_filter(base, size=2 * tolerance + 1)
            rim_px &= ~(z - ground > clearance)
    allowed = zone
    if swept is not shaded:
        rim_px, allowed = _connected_rim(core_px, rim_px, near, zone, ray, reach, tolerance)
    # Away from the predicted edges (by more than the tolerance) the model's shade is whole.
    deep = core_px & ndimage.binary_erosion(shaded, iterations=tolerance + 1)
    with np.errstate(invalid="ignore"):
        whole = deep | (d <= core)
    f = unmix_edges(
        d, ok, core_px | rim_px | part_px, edge_pixels, window, allowed=allowed, whole=whole
    )
    f[deep] = np.maximum(f[deep], p[deep]).astype(np.float32)
    _cap_beside_zone(f, d, ok, zone, shaded, core_px | rim_px, window)
    if unseen is not None:
        spectral = dict(core=core, edge_pixels=edge_pixels, window=window, water=water)
        _unseen_at_least_spectral(f, d, ok, unseen, ray, lit, spectral)
    return f


def _unseen_at_least_spectral(f, d, ok, unseen, ray, lit, spectral: dict) -> None:
    """Raise ``f`` (in place) to the spectral estimate (:func:`shadow_fraction_estimate` with
    ``spectral``) on the ``unseen`` pixels whose way towards the sun along ``ray`` to the
    grid's edge is not lit (darker than ``lit``): the shadow of a caster beyond the edge
    covers the ground between them."""
    u = np.asarray(unseen, bool)
    if u.shape != d.shape:
        raise InputError(f"parameter 'unseen': shape {u.shape} is not the image's {d.shape}")
    if ray is not None and u.any():
        with np.errstate(invalid="ignore"):
            u = u & along_ray(~(d > lit), ray)
    if u.any():
        f0 = shadow_fraction_estimate(d, ok, **spectral)
        f[u] = np.fmax(f[u], f0[u])


def _checked_inputs(dark, valid, prior, heights, edge_pixels, window, tolerance):
    """:func:`dsm_shadow_fraction`'s arrays checked: (darkness, valid, prior with NaN as 0,
    heights or None), float64, each of the darkness's shape."""
    d = np.asarray(dark, np.float64)
    ok = np.isfinite(d)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    if edge_pixels < 0 or window < 1 or tolerance < 0:
        raise ParameterError(
            "parameters 'edge_pixels' ≥ 0, 'edge_window' ≥ 1 and 'tolerance' ≥ 0 are required"
        )
    return d, ok, *_checked_prior(prior, heights, d.shape)


def _checked_prior(prior, heights, shape):
    """(prior with NaN as 0, heights or None) as float64, each of the image's ``shape``."""
    p = np.nan_to_num(np.asarray(prior, np.float64), nan=0.0)
    if p.shape != shape:
        raise InputError(f"the prior's shape {p.shape} is not the image's {shape}")
    if heights is None:
        return p, None
    z = np.asarray(heights, np.float64)
    if z.shape != shape:
        raise InputError(f"parameter 'heights': shape {z.shape} is not the image's {shape}")
    return p, z


def _connected_rim(core_px, rim_px, near, zone, ray, reach, tolerance):
    """(rim, where unmixing is allowed) beyond the tolerance: a shadow the clearance
    shortened goes on from the predicted shadow along the sun's direction, so a cell there is
    shadow only when the cell next to it towards the sun is, and it is unmixed only next to
    such a cell."""
    step = _toward_sun(ray)
    extra = rim_px & ~near
    taken = core_px | (rim_px & near)
    for _ in range(int(math.ceil(reach)) + tolerance):
        grow = extra & ~taken & _shift(taken, step)
        if not grow.any():
            break
        taken |= grow
    return taken & ~core_px, near | (zone & _shift(taken, step))


def _cap_beside_zone(f, d, ok, zone, shaded, shadow_px, window) -> None:
    """Cap ``f`` (in place) beside the predicted shadow (in the ``zone``, not ``shaded``).
    Outside the zone no shadow reaches (registration within the tolerance): a pixel there is
    lit. A rim pixel is shaded at most as much as its signal says against the darkest such
    pixel beside it, taken as its sunlit end: a dark material running on past the zone is as
    dark there, in the sun, so it is not taken for shade; a shaded pixel beside brighter lit
    ground keeps its fraction."""
    from scipy import ndimage

    beside = ok & ~zone
    if not beside.any():
        return
    ref = ndimage.minimum_filter(np.where(beside, d, np.inf), size=3, mode="constant", cval=np.inf)
    s = np.exp(np.where(ok, d, 0.0))
    sun = np.exp(np.where(np.isfinite(ref), ref, 0.0))
    shade = local_mean(s, shadow_px, window)
    with np.errstate(invalid="ignore", divide="ignore"):
        beside_est = np.clip((sun - s) / (sun - shade), 0.0, 1.0)
        cap = ok & zone & ~shaded & np.isfinite(ref) & (sun > shade) & np.isfinite(beside_est)
    f[cap] = np.minimum(f[cap], beside_est[cap]).astype(np.float32)


def _toward_sun(ray) -> tuple[int, int]:
    """The neighbouring cell (Δrow, Δcol) nearest the sun's direction (``ray``'s)."""
    drow, dcol = float(ray[0]), float(ray[1])
    n = max(abs(drow), abs(dcol), 1e-12)
    return int(np.floor(drow / n + 0.5)) if abs(drow) / n >= 0.5 else 0, (
        int(np.floor(dcol / n + 0.5)) if abs(dcol) / n >= 0.5 else 0
    )


def _shift(mask: np.ndarray, step: tuple[int, int]) -> np.ndarray:
    """``mask`` at the cell ``step`` away from each cell (False beyond the grid)."""
    return shifted(mask, step[0], step[1], False)


def _down_sun(mask, ray, reach, base=None):
    """(``mask`` swept up to ``reach`` cells away from the sun along ``ray``'s direction, the
    least ``base`` met on the way): a cell is in the sweep when a cell ``t ≤ reach`` cells
    towards the sun is in ``mask``."""
    if ray is None or not reach > 0:
        return mask, base
    drow, dcol = float(ray[0]), float(ray[1])
    out = mask.copy()
    low = None if base is None else base.copy()
    for k in range(1, int(math.ceil(2 * reach)) + 1):
        t = min(k / 2, reach)
        sr, sc = int(np.floor(t * drow + 0.5)), int(np.floor(t * dcol + 0.5))
        out |= shifted(mask, sr, sc, False)
        if low is not None:
            low = np.fmin(low, shifted(base, sr, sc, np.inf))
    return out, low


def prior_agreement(
    dark: np.ndarray,
    prior: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    max_shift: int = 3,
    rim: float = RIM_DARKNESS,
) -> dict:
    """How well a surface model's cast shadow matches the image's darkness: the shift (rows,
    columns, within ``max_shift``) of the predicted shadow (``prior`` ≥ 0.5) that best
    overlaps the dark pixels (``dark`` ≤ ``rim``), by intersection over union, and the IoU
    at that shift and unshifted. A best shift other than (0, 0) that gains much says the
    model and the image are not registered."""
    d = np.asarray(dark, np.float64)
    ok = np.isfinite(d)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    with np.errstate(invalid="ignore"):
        dk = ok & (d <= rim)
    pr = np.nan_to_num(np.asarray(prior, np.float64), nan=0.0) >= PREDICTED_SHADOW
    m = int(max_shift)
    h, w = d.shape
    inner = np.zeros(d.shape, bool)
    inner[m : h - m, m : w - m] = True
    inner &= ok
    best = (0, 0, -1.0)
    iou0 = float("nan")
    shifts = sorted(
        ((dy, dx) for dy in range(-m, m + 1) for dx in range(-m, m + 1)),
        key=lambda s: s[0] ** 2 + s[1] ** 2,
    )
    for dy, dx in shifts:  # nearest first: a tie keeps the smaller shift
        sh = np.roll(pr, (dy, dx), axis=(0, 1))
        union = ((sh | dk) & inner).sum()
        iou = float((sh & dk & inner).sum() / union) if union else float("nan")
        if (dy, dx) == (0, 0):
            iou0 = iou
        if np.isfinite(iou) and iou > best[2] + 1e-9:
            best = (dy, dx, iou)
    return {
        "dsm_shift_rows": best[0],
        "dsm_shift_columns": best[1],
        "dsm_iou_at_shift": round(best[2], 4) if best[2] >= 0 else None,
        "dsm_iou": round(iou0, 4) if np.isfinite(iou0) else None,
    }


def prior_registration(
    evidence: np.ndarray,
    fine: np.ndarray,
    supersample: int,
    valid: np.ndarray | None = None,
    *,
    max_shift: float = DSM_TOLERANCE,
) -> dict:
    """The sub-pixel shift of a surface model's cast shadow onto the image: the move (rows,
    columns; whole sub-cells, within ``max_shift`` cells each way) of the shadow cast on the
    sub-cell grid (``fine``, :func:`geoboresight.shadow.illumination.sub_cell_shadow`) whose
    cell fractions correlate best (Pearson) with the shadow ``evidence`` on the image's grid
    (:func:`nir_darkness`: the SWIR's darkness would bring in its own registration, the
    boresight offset and the relief's parallax).

    Moving the cast on its own sub-cell grid undoes a registration error without resampling
    the surface model, which would smooth its walls. At a high sun a shadow is a pixel or two
    wide, and half a pixel of registration is a large share of it. What is matched is the
    prior as the refinement uses it, cast with the clearance, whose far ends are shortened:
    the move also takes up that shortening, so it is not the DSM's own offset (on model 2 it
    went 0.5–1 px further down-sun, where ``clearance · tan(zenith)`` was 0.5–0.7 px).

    The move is kept only when the image's parts agree on it: on each of :data:`TILES` ×
    :data:`TILES` tiles the gain in correlation over the unmoved prediction is taken, and
    their mean must exceed :data:`REGISTRATION_T` standard errors (else the move is 0).

    Returns
    -------
    dict
        ``dsm_registration_rows`` / ``_columns`` (cells, the move kept), the correlation there
        and unmoved (``dsm_registration_r`` / ``dsm_registration_r0``), and the tiles' t
        (``dsm_registration_t``); None where undefined.
    """
    n = int(supersample)
    e = np.asarray(evidence, np.float64)
    ok = np.isfinite(e)
    if valid is not None:
        ok &= np.asarray(valid, bool)
    m = int(math.floor(float(max_shift) * n + 1e-9))
    edge = int(math.ceil(float(max_shift))) + 1
    inner = np.zeros(e.shape, bool)
    inner[edge : e.shape[0] - edge, edge : e.shape[1] - edge] = True
    inner &= ok

    def corr(sr, sc):
        return _pearson(cell_fraction(fine, n, (sr / n, sc / n))[inner], e[inner])

    still = cell_fraction(fine, n)
    r0 = _pearson(still[inner], e[inner])
    best = (0, 0, r0)
    if np.isfinite(r0):
        shifts = sorted(
            ((a, b) for a in range(-m, m + 1) for b in range(-m, m + 1)),
            key=lambda t: t[0] ** 2 + t[1] ** 2,
        )
        for a, b in shifts[1:]:  # nearest first: a tie keeps the smaller move
            r = corr(a, b)
            if np.isfinite(r) and r > best[2] + 1e-9:
                best = (a, b, r)
    # The move is kept only where the image's parts agree that it helps: the gain in
    # correlation on each of TILES × TILES tiles, its mean over twice its standard error.
    t = 0.0  # no move found that gains: nothing to agree on
    if best[:2] != (0, 0):
        t = float("nan")
        moved = cell_fraction(fine, n, (best[0] / n, best[1] / n))
        gains = []
        for rows in np.array_split(np.arange(edge, e.shape[0] - edge), TILES):
            for cols in np.array_split(np.arange(edge, e.shape[1] - edge), TILES):
                if rows.size == 0 or cols.size == 0:
                    continue
                tile = np.ix_(rows, cols)
                ok_t = inner[tile]
                g = _pearson(moved[tile][ok_t], e[tile][ok_t]) - _pearson(
                    still[tile][ok_t], e[tile][ok_t]
                )
                if np.isfinite(g):
                    gains.append(g)
        if len(gains) >= 3:
            g = np.asarray(gains)
            se = max(float(g.std(ddof=1)) / math.sqrt(g.size), 1e-12)
            t = float(g.mean()) / se
        if not t > REGISTRATION_T:
            best = (0, 0, r0)
    fin = lambda v: round(v, 4) if np.isfinite(v) else None  # noqa: E731
    return registration_result(best[0] / n, best[1] / n, fin(best[2]), fin(r0), fin(t))


def registration_result(rows=0.0, columns=0.0, r=None, r0=None, t=None) -> dict:
    """What :func:`prior_registration` reports; the defaults: no move, nothing measured (the
    registration turned off)."""
    return {
        "dsm_registration_rows": rows,
        "dsm_registration_columns": columns,
        "dsm_registration_r": r,
        "dsm_registration_r0": r0,
        "dsm_registration_t": t,
    }


def _pearson(a: np.ndarray, b: np.ndarray) -> float:
    a = a - a.mean() if a.size else a
    b = b - b.mean() if b.size else b
    den = float(np.sqrt((a @ a) * (b @ b))) if a.size else 0.0
    return float(a @ b) / den if den > 0 else float("nan")
