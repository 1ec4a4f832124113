"""The shadow map's kernels on a block of lines: the spectral map
(:func:`shadow_fraction_block`, with a surface model's part as a :class:`ModelOnBlock`;
:func:`shadow_map_block` its classes and mask), and with a surface model the map with its
cast shadow as the prior (:func:`prior_map_block`) and the move that registers
that cast onto the image (:func:`register_prior`). Each takes the arrays of one block and
small values; the operation runs them over the image with ``io.map_windows``. They build on
the spectral steps (:mod:`geoboresight.shadow.darkness`) and the surface prior's steps
(:mod:`geoboresight.shadow.prior`).

References
----------
Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2, Figure 4).
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from ..sensor.coregister import coregister
from .context import sunlit_dark
from .darkness import (
    DSM_TOLERANCE,
    EDGE_PIXELS,
    EDGE_WINDOW,
    LIT_DARKNESS,
    PREDICTED_SHADOW,
    SceneCalibration,
    darkness,
    nir_darkness,
    shadow_classes,
    shadow_fraction_estimate,
    shadow_mask,
    signal,
    too_blue,
)
from .illumination import SUPERSAMPLE
from .prior import (
    SurfacePrior,
    dsm_shadow_fraction,
    prior_agreement,
    prior_fraction,
    prior_registration,
    registered_heights,
    registration_result,
    sub_cell_cast,
    unseen_pixels,
)


def shadow_map_halo(calibration: SceneCalibration, edge_pixels: int = EDGE_PIXELS) -> int:
    """Lines above and below a block that :func:`shadow_fraction_block` needs to give, on the
    block, the values of the whole image: the SWIR's along-track shift and its bilinear
    reach, and the edge search (``edge_pixels`` and half the unmixing window)."""
    return (
        math.ceil(abs(calibration.offset_along))
        + 3
        + int(edge_pixels)
        + EDGE_WINDOW // 2
        + DSM_TOLERANCE
    )


@dataclasses.dataclass(frozen=True)
class ModelOnBlock:
    """A surface model's part in a block's shadow fraction (:func:`dsm_shadow_fraction`):
    the cast-shadow fraction it predicts on the block (``prior``; no shadow away from it),
    its heights and their tolerance (``heights``, ``clearance`` in m: the top of a caster
    beside its shadow is not shadow), the pixels a caster beyond the model could shade
    (``unseen``: the spectral estimate holds there if the way to the edge along ``ray`` is
    not lit), how far (cells) the clearance shortens a shadow's far end down-sun along
    ``ray`` (``reach``) and the registration's tolerance (px)."""

    prior: np.ndarray
    heights: np.ndarray | None = None
    clearance: float = 0.0
    unseen: np.ndarray | None = None
    ray: tuple[float, float, int] | None = None
    reach: float = 0.0
    tolerance: int = DSM_TOLERANCE


def shadow_fraction_block(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    calibration: SceneCalibration,
    dark_levels: tuple = (0.0, 0.0, 0.0),
    edge_pixels: int = EDGE_PIXELS,
    model: ModelOnBlock | None = None,
    sky_blue: float | None = None,
    long_swir: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(shadow fraction, darkness) of a block of lines: the shadow map's per-pixel pipeline.

    1. **Signal**: DN minus the instrument's dark level, averaged over the bands of each range
       (:func:`signal`; blue, NIR, SWIR).
    2. **Co-registration**: the SWIR signal is resampled onto the VNIR grid by the boresight
       offset of ``calibration`` (bilinear; invalid pixels filled with the sunlit SWIR signal,
       so they carry no edge), so that shadow edges line up.
    3. **Darkness** against the scene's sunlit modes (:func:`darkness`).
    4. **Shadow fraction**: core shadow at or below ``calibration.core``, not water
       (:func:`too_blue`), unmixed between sunlit and shadowed neighbours within
       ``edge_pixels`` (:func:`shadow_fraction_estimate`); with a surface ``model``, the
       predicted shadow refined by the darkness (:func:`dsm_shadow_fraction`).

    A block read with :func:`shadow_map_halo` lines above and below gives, on its own lines,
    what the whole image gives.

    Parameters
    ----------
    blue, nir, swir : arrays (n_bands, lines, columns)
        DN (or radiance) of the bands of :data:`BLUE_NM` and :data:`NIR_NM` (VNIR) and of
        :data:`SWIR_NM` (SWIR, on its own grid: not yet shifted).
    valid : bool array (lines, columns), optional
        Pixels valid in every band read.
    calibration : SceneCalibration
        From :func:`calibrate_shadow_map` on a sample of the whole flight line.
    dark_levels : (blue, nir, swir[, long SWIR])
        The dark level to subtract from each range: one number, or one per band
        (:meth:`DarkLevel.for_bands`).
    edge_pixels : int
        Partial shadow is looked for this many pixels around the core (0 = core only).
    model : ModelOnBlock, optional
        The surface model on the block (needs :data:`DSM_TOLERANCE` more lines of halo).
    sky_blue : float, optional
        A limit: the dark pixels whose blue or long SWIR is sunlit stay out of the core
        (:func:`geoboresight.shadow.context.sunlit_dark`; needs
        :data:`~geoboresight.shadow.context.HALO` more lines of halo); with a ``model``, where
        the spectral estimate holds (its ``unseen`` pixels).
    long_swir : array (n_bands, lines, columns), optional
        The DN of the long-SWIR bands (SWIR grid), whose dark level is ``dark_levels``'
        fourth entry.

    Returns
    -------
    fraction : float32 array (lines, columns)
        The shadow fraction (0–1), NaN where invalid.
    darkness : array (lines, columns)
        Step 3's darkness.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2).
    Chavez, P.S. Remote Sens. Environ. 1988, 24, 459–479 (dark-object subtraction).
    """
    blue_level, nir_level, swir_level, *long_level = dark_levels
    b = signal(blue, blue_level)
    n = signal(nir, nir_level)
    s = signal(swir, swir_level)
    ok = np.ones(n.shape, bool) if valid is None else np.asarray(valid, bool)
    shift = (calibration.offset_along, calibration.offset_across)
    s, s_ok = coregister(s, *shift, ok, order=1)
    good = ok & s_ok
    # With a surface model the test counts only on its unseen pixels: without them, skip it.
    test = sky_blue is not None and (model is None or model.unseen is not None)
    g = None
    if test and long_swir is not None and long_level:
        g, _ = coregister(signal(long_swir, long_level[0]), *shift, ok, order=1)
    d = darkness(n, s, calibration, good)
    water = too_blue(b, n, calibration.blue_limit)
    sunlit = None
    if test:
        levels = (calibration.blue_level, calibration.blue_nir_level, calibration.tilt_level)
        sunlit = sunlit_dark(
            b, n, d, good, core=calibration.core, levels=levels, limit=sky_blue, swir=s, long_swir=g
        )
    if model is not None:
        if sunlit is not None and model.unseen is not None:
            # Near the model's sunward edge the spectral estimate holds: so does its test.
            water = water | (sunlit & np.asarray(model.unseen, bool))
        f = dsm_shadow_fraction(
            d,
            model.prior,
            good,
            edge_pixels=edge_pixels,
            water=water,
            heights=model.heights,
            clearance=model.clearance,
            unseen=model.unseen,
            ray=model.ray,
            core=calibration.core,
            reach=model.reach,
            tolerance=model.tolerance,
        )
    else:
        if sunlit is not None:
            water = water | sunlit
        f = shadow_fraction_estimate(
            d, good, core=calibration.core, edge_pixels=edge_pixels, water=water
        )
    return f, d


def shadow_map_block(
    blue: np.ndarray, nir: np.ndarray, swir: np.ndarray, valid: np.ndarray | None = None, **options
) -> tuple[np.ndarray, np.ndarray]:
    """Shadow classes and shadow mask of a block of lines: :func:`shadow_fraction_block`
    (``options``: its keywords), then

    5. **Mask**: fraction ≥ 50 % (:func:`shadow_mask`).
    6. **Classes**: Table 2's shadow-fraction intervals (:func:`shadow_classes` with the
       calibration's table).

    Returns
    -------
    classes : uint8 array (lines, columns)
        0 no shadow, the class ids of the calibration's table, 255 nodata.
    mask : uint8 array (lines, columns)
        1 shadow, 0 not, 255 nodata.

    References
    ----------
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484
    (§3.1, Table 2: the shadow-fraction classes, 80–100, 50–80, 20–50 and 10–20 % shadow).
    """
    f, _ = shadow_fraction_block(blue, nir, swir, valid, **options)
    return shadow_classes(f, options["calibration"].table), shadow_mask(f)


def _model_fraction(blue, nir, swir, valid, heights, heights_valid, prior, unseen, p, **block):
    """:func:`shadow_fraction_block` with the surface model: the ``prior`` and the ``unseen``
    pixels of the block, ``p`` its :class:`SurfacePrior`."""
    model = ModelOnBlock(
        prior,
        registered_heights(heights, heights_valid, surface_prior=p),
        p.clearance,
        unseen,
        p.ray,
        p.reach,
        p.tolerance,
    )
    return shadow_fraction_block(blue, nir, swir, valid, model=model, **block)


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
    calibration: SceneCalibration,
    dark_levels: tuple,
    edge_pixels: int,
    surface_prior: SurfacePrior,
    row0: int = 0,
    sky_blue: float | None = None,
    long_swir: np.ndarray | None = None,
) -> PriorBlock:
    """The shadow fraction of a block of lines with a surface model, and how the model and
    the image agree on it.

    The fraction is :func:`geoboresight.shadow.blocks.shadow_fraction_block` with the prior
    (:func:`prior_fraction`), the moved heights, the unseen pixels and the model's ray and
    reach. Pixels the model has no height for (``holes``: beyond its extent, its nodata)
    take the spectral estimate alone, as without a model: no prior says anything there (its
    "no shadow away from the predicted shadow" would drop them all).

    Parameters
    ----------
    blue, nir, swir : arrays (n_bands, lines, columns)
        As :func:`geoboresight.shadow.blocks.shadow_fraction_block`.
    heights : array (lines, columns)
        The surface model's heights (m) on the image's grid.
    valid : bool array (lines, columns), optional
        Pixels valid in every band read.
    heights_valid : bool array (lines, columns)
        Cells with a height.
    calibration, dark_levels, edge_pixels
        As :func:`geoboresight.shadow.blocks.shadow_fraction_block`.
    surface_prior : SurfacePrior
    row0 : int
        The block's first line in the grid.
    sky_blue, long_swir
        The spectral test of sunlit dark materials where the spectral estimate holds (the
        ``holes`` and the ``unseen`` pixels), as
        :func:`geoboresight.shadow.blocks.shadow_fraction_block` takes them.

    Returns
    -------
    PriorBlock
        The fraction; ``deep``, the predicted shadow (≥ 0.5) eroded by a pixel; ``lit``, the
        pixels of ``deep`` brighter than
        :data:`~geoboresight.shadow.LIT_DARKNESS`; ``unseen`` and ``holes`` (all
        where the fraction is defined).
    """
    from scipy import ndimage

    ok = np.ones(np.shape(heights), bool) if valid is None else np.asarray(valid, bool)
    kw = dict(calibration=calibration, dark_levels=dark_levels, edge_pixels=edge_pixels)
    test = dict(sky_blue=sky_blue, long_swir=long_swir)
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
        **test,
    )
    holes = ok & ~np.asarray(heights_valid, bool)
    if holes.any():
        f_spectral, _ = shadow_fraction_block(blue, nir, swir, ok, **kw, **test)
        f = np.where(holes, f_spectral, f)
    defined = np.isfinite(f)
    deep = ndimage.binary_erosion(prior >= PREDICTED_SHADOW) & defined
    with np.errstate(invalid="ignore"):
        lit = deep & (d > LIT_DARKNESS)
    return PriorBlock(f, deep, lit, unseen & defined, holes & defined)


def register_prior(
    blue: np.ndarray,
    nir: np.ndarray,
    swir: np.ndarray,
    heights: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    heights_valid: np.ndarray,
    calibration: SceneCalibration,
    dark_levels: tuple,
    edge_pixels: int,
    surface_prior: SurfacePrior,
    row0: int = 0,
    register: bool = True,
) -> tuple[SurfacePrior, dict]:
    """Register the surface model's cast shadow onto the image on a block of lines (a central
    block of the flight line), and measure how the two agree there.

    With ``register``, the cast shadow is moved by the sub-pixel shift that best matches the
    NIR's darkness (:func:`geoboresight.shadow.prior.prior_registration`), kept only where the
    image's parts agree on it. Then the best whole-pixel shift of what remains onto the dark
    pixels is measured (:func:`geoboresight.shadow.prior.prior_agreement`: a DSM more than a
    pixel off, another date). The block's arguments are those of :func:`prior_map_block`.

    Returns
    -------
    (SurfacePrior, dict)
        ``surface_prior`` with the move as its ``shift``, and the registration's and the
        agreement's figures (:func:`geoboresight.shadow.prior.registration_result`,
        :func:`geoboresight.shadow.prior.prior_agreement`).
    """
    ok = np.ones(np.shape(heights), bool) if valid is None else np.asarray(valid, bool)
    sub_cells = sub_cell_cast(heights, heights_valid, surface_prior=surface_prior)
    agreement = registration_result()
    if register:
        n = signal(nir, dark_levels[1])
        evidence = nir_darkness(n, calibration, ok & heights_valid)
        agreement = prior_registration(evidence, sub_cells, SUPERSAMPLE)
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
    agreement.update(prior_agreement(d, prior, ok))
    return surface_prior, agreement
