"""File-level shadow map (paper §3.1, made physical): VNIR + SWIR in, a shadow mask and the
four shadow-fraction classes out, calibrated to the scene (:mod:`geoboresight.shadow.darkness`).

Read → kernel steps → write. A random sample calibrates the map (dark levels, sunlit modes,
sunlit ratio, the scaled class table: :func:`geoboresight.shadow.darkness.calibrate_shadow_map`)
and a central block of lines gives the boresight offset; with a surface model, the same
block registers its cast shadow onto the image (:func:`geoboresight.shadow.blocks.register_prior`).
Then the map is written strip by strip, each strip's fraction by
:func:`geoboresight.shadow.blocks.shadow_fraction_block`, or with the surface model by
:func:`geoboresight.shadow.blocks.prior_map_block`. What this shares with other operations
is in :mod:`geoboresight.operations._dark` (dark levels), :mod:`geoboresight.operations._offset`
(the offset) and :mod:`geoboresight.operations._surface` (the surface model, the sun).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .. import io
from ..errors import ParameterError
from ..io.bands import BoresightOffset, band_range
from ..io.checks import no_valid_error
from ..io.cube import raw_bands_reader
from ..io.dark import recorded_dark_levels
from ..io.dual import BandChoice, DualLayout
from ..io.windows import Sample
from ..sensor.dark import ESTIMATED, DarkLevels, find_dark_levels
from ..shadow.blocks import (
    prior_map_block,
    register_prior,
    shadow_fraction_block,
    shadow_map_halo,
)
from ..shadow.classes import MASK_SHADOW, NO_SHADOW, NODATA_CLASS, fraction_text
from ..shadow.context import HALO as SKY_HALO
from ..shadow.context import LONG_SWIR_NM, SKY_BLUE, check_limit
from ..shadow.darkness import (
    BLUE_NM,
    CORE_DARKNESS,
    EDGE_PIXELS,
    NIR_NM,
    PAPER_SUNLIT_RATIO,
    SWIR_NM,
    calibrate_shadow_map,
    check_sample,
    shadow_classes,
    shadow_mask,
    signal,
)
from ..shadow.prior import (
    LIT_PREDICTION,
    MOSTLY_SHADOW,
    SHIFT_IOU_GAIN,
    prior_halo,
    prior_method,
    spectral_method,
)
from ._dark import DARK_BANDS, dual_dark_levels, saturation_value, spread_bands
from ._offset import boresight_offset, central_rows
from ._shadow_masks import mask_raster
from ._shadow_tables import class_table, class_table_csv
from ._surface import SurfaceModel, open_surface

__all__ = ["Detection", "MapCalibration", "MapSample", "SurfaceModel", "shadow_map_file"]

#: Pixels drawn at random to calibrate the map.
SAMPLE_SIZE = 200_000
#: Fewest SWIR bands in :data:`~geoboresight.shadow.context.LONG_SWIR_NM` the tilt test
#: averages (a shadow's long SWIR holds a few DN in each).
LONG_SWIR_BANDS = 3


@dataclass(frozen=True)
class MapSample(Sample):
    """The shadow map's calibration sample: :class:`~geoboresight.io.windows.Sample` with
    :data:`SAMPLE_SIZE` pixels by default."""

    sample_size: int = SAMPLE_SIZE


@dataclass(frozen=True)
class MapCalibration(MapSample, BoresightOffset):
    """How the shadow map is calibrated on the flight line: the random sample
    (``sample_size``, ``seed``; :class:`MapSample`) and the boresight offset of the SWIR
    (``offset_along``, ``offset_across``; :class:`BoresightOffset`: both None = measured).

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.MapCalibration()  # the offset measured; 200,000 pixels sampled, seed 0
    MapCalibration(offset_along=None, offset_across=None, sample_size=200000, seed=0)
    """


@dataclass(frozen=True)
class Detection:
    """The spectral shadow test: core shadow at or below ``core_darkness`` (natural log of the
    SWIR signal over its sunlit mode; with a surface model, whose prior replaces it, only for
    the edges a pixel this dark is at least half shaded, and near the model's sunward edge)
    and partial shadow looked for ``edge_pixels`` around it. Without a surface model a dark
    pixel whose blue is at least ``exp(sky_blue)`` times the scene's sunlit blue, with a flat
    dark material's blue/NIR, is a sunlit dark material, not shadow; so is one whose blue is
    at least ``exp(sky_blue − 0.2)`` times it and whose SWIR is not darker at 2.0–2.3 µm than
    at 1.55–1.75 µm against the sunlit ground, as the sky leaves a shadow
    (:func:`geoboresight.shadow.context.sunlit_dark`; lower flags fewer dark materials and
    misses more shadow on blue-bright ground). With a surface model the test applies where
    the spectral estimate holds (pixels without a height, and near the model's sunward edge).

    Examples
    --------
    >>> import math
    >>> import geoboresight as gb
    >>> detection = gb.Detection()
    >>> detection.core_darkness == math.log(1 / 6)  # core shadow: below a sixth of sunlit
    True
    >>> detection.edge_pixels
    2
    """

    core_darkness: float = CORE_DARKNESS
    edge_pixels: int = EDGE_PIXELS
    sky_blue: float = SKY_BLUE


def shadow_map_file(
    vnir,
    swir=None,
    classes=None,
    *,
    output,
    mask=None,
    fraction=None,
    layout=DualLayout(),
    bands=BandChoice(),
    dark=DarkLevels(),
    surface=SurfaceModel(),
    detection=Detection(),
    calibration=MapCalibration(),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Shadow mask and scene-calibrated shadow-fraction classes of a VNIR + SWIR flight line.

    Parameters
    ----------
    vnir : path
        VNIR file (ENVI or GeoTIFF, raw DN or radiance), or a merged VNIR+SWIR cube when
        ``swir`` is None.
    swir : path, optional
        SWIR file on the same pixel grid.
    classes : path, optional
        Class table (CSV or JSON) whose ratio intervals are scaled to the scene; None = Table 2.
    output : path
        Byte class raster (0 no shadow, 1–4 the classes, 255 nodata) with a colour table.
    mask : path, optional
        Binary shadow mask (1 shadow, 0 not, 255 nodata).
    fraction : path, optional
        The estimated shadow fraction (float32, 0–1; what the classes are cut from): the
        input of ``deshadow``.
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    bands : BandChoice
        The bands of the boresight ratio (Eq. 3) the classes are scaled by, nearest 920 nm
        (VNIR) and 1010 nm (SWIR) by default; its ``tolerance_nm`` also bounds the blue, NIR
        and SWIR ranges. The faces always give ``band_mode="wavelength"``.
    dark : DarkLevels
        Dark level (DN of zero signal) of each instrument (``vnir_dark``, ``swir_dark``);
        None = the sensor product's dark reference, else the header's 'dark level', else
        estimated from the data (dark object): :func:`geoboresight.sensor.dark.find_dark_levels`.
        Give 0 for radiance.
    surface : SurfaceModel
        A surface model on the image's grid (``dsm``) and the sun (``sun_zenith``,
        ``sun_azimuth``; ``cell_size`` for a DSM without a geotransform): the cast shadow it
        predicts is the prior, the spectra refine its edges and fraction, and no pixel away
        from it is shadow, except where a caster beyond the model's edge could shade it
        (:func:`geoboresight.shadow.prior.dsm_shadow_fraction`). How far the
        model and the image disagree is reported (best shift, share of predicted shadow that
        is spectrally lit). Default: none (spectral evidence only).
    detection : Detection
        ``core_darkness``: core shadow where the SWIR signal over its sunlit mode is at or
        below this (natural log, default ln 1/6; with a surface model only at the prior's
        edges and near the model's sunward edge);
        ``edge_pixels``: partial shadow is looked for this many pixels around it;
        ``sky_blue``: without a surface model, a pixel that dark whose blue is at least this
        (natural log over the scene's sunlit blue, default −0.3) and whose blue/NIR is a flat
        dark material's, or whose blue is at least ``sky_blue − 0.2`` and whose long SWIR
        (2.0–2.3 µm) is not darker than its SWIR against the sunlit ground, is a sunlit dark
        material.
    calibration : MapCalibration
        The random sample that calibrates the map (``sample_size``, default 200,000;
        ``seed``) and the boresight offset of the SWIR relative to the VNIR (px,
        ``offset_along``, ``offset_across``; both None = measured on a central block).
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` (and ``mask``), the calibration (dark levels and their source, sunlit
        signals, sunlit ratio, class scale, offset), the class boundaries used, pixels per
        class, shadow pixels, without a surface model ``dark_pixels`` (dark enough for core
        shadow) and ``dark_declined_share`` (their share left sunlit: water, sunlit dark
        materials; also in the products' tags), and ``warnings``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2).
    Chavez, P.S. Remote Sens. Environ. 1988, 24, 459–479 (dark-object subtraction).

    Examples
    --------
    The sample scene's shadow classes, mask and shadow fraction:

    >>> import geoboresight as gb
    >>> result = gb.shadow_map_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...     output="out/classes.tif", mask="out/mask.tif", fraction="out/fraction.tif",
    ... )
    >>> result["shadow_share"], result["offset_along_px"]
    (0.1857, 0.87)
    """
    core_darkness = detection.core_darkness
    edge_pixels = detection.edge_pixels
    if int(edge_pixels) != edge_pixels or edge_pixels < 0:
        raise ParameterError(f"parameter 'edge_pixels': {edge_pixels!r} must be a whole number ≥ 0")
    edge_pixels = int(edge_pixels)
    sky_blue = check_limit(detection.sky_blue)
    base_table = class_table(classes)
    dual = io.as_dual(vnir, swir, layout)
    mb = _map_bands(dual, bands, progress)
    warnings: list[str] = []
    strips = {"height": dual.height, "width": dual.width, "block_rows": block_rows}
    with contextlib.ExitStack() as stack:
        v_src = stack.enter_context(io.open_raster(dual.vnir.reads, "VNIR"))
        s_src = (
            v_src if dual.merged else stack.enter_context(io.open_raster(dual.swir.reads, "SWIR"))
        )
        opened = open_surface(surface, dual, block_rows, stack, progress)
        # Pass 1: a random sample of the line for the dark levels and the sunlit modes.
        how = (dark, calibration, base_table, core_darkness)
        cal, levels = _calibrate(vnir, dual, (v_src, s_src), mb, how, strips, warnings, progress)
        read = _map_reader(stack, (v_src, s_src), dual, mb, opened)
        block = dict(calibration=cal, dark_levels=levels, edge_pixels=edge_pixels)
        prior, agreement = None, {}
        if opened is not None:
            prior, agreement = _register(read, dual, mb, opened.prior, surface.register, block)
        tags = _map_tags(dual, cal, core_darkness, edge_pixels, surface, opened, prior)
        halo = shadow_map_halo(cal, edge_pixels) + SKY_HALO
        halo = (halo,) * 2 if prior is None else prior_halo(prior, halo, opened.halo)
        tags["sky_blue"] = str(sky_blue)
        kernel = _map_kernel(mb, cal.table, block, prior, sky_blue)
        paths = (output, mask, fraction)
        counts, n = _write_map(
            stack, read, kernel, dual, tags, cal.table, paths, halo, strips, progress
        )
        n_valid = int(counts[:NODATA_CLASS].sum())
        if n_valid == 0:
            raise no_valid_error(vnir, "VNIR/SWIR image")
    share = n["shadow"] / n_valid
    if share > MOSTLY_SHADOW:
        warnings.append(
            f"{100 * share:.0f} % of the valid pixels are shadow: the sunlit mode may not be "
            "sunlit ground (a mostly shaded or dark scene); check the calibration"
        )
    if prior is not None:
        _surface_summary(agreement, prior, n, n_valid, surface.register, warnings, progress)
    for w in warnings:
        progress.info(f"warning: {w}")
    paths = {"output": output, "mask": mask, "fraction": fraction}
    agreement = {**agreement, **_declined_summary(n, sky_blue, progress)}
    return _map_result(paths, cal, counts, n["shadow"], agreement, warnings)


def _declined_summary(n: dict, sky_blue: float, progress) -> dict:
    """Without a surface model: the pixels dark enough for core shadow and their share left
    sunlit (water, sunlit dark materials), in the result and the log."""
    if not n["dark"]:
        return {}
    share = n["declined"] / n["dark"]
    progress.info(
        f"{100 * share:.1f} % of the {n['dark']} pixels dark enough for core shadow left "
        f"sunlit (water, and dark materials whose blue or long SWIR is sunlit: sky_blue "
        f"{sky_blue:g})"
    )
    return {"dark_pixels": n["dark"], "dark_declined_share": round(share, 4)}


def _map_result(paths, cal, counts, n_shadow, agreement, warnings) -> dict:
    """The operation's result: the outputs, the calibration, the classes' pixels."""
    n_valid = int(counts[:NODATA_CLASS].sum())
    result = {
        "output": paths["output"],
        "valid_pixels": n_valid,
        "shadow_pixels": n_shadow,
        "shadow_share": round(n_shadow / n_valid, 4),
        **cal.as_dict(),
        "classes": _fraction_classes(cal.table),
        "table2_ratio_bounds_on_scene": cal.table.describe(),
        **agreement,
        "warnings": warnings,
    }
    result.update({k: paths[k] for k in ("mask", "fraction") if paths[k]})
    for c in cal.table.classes:
        result[f"class_{c.id}_pixels"] = int(counts[c.id])
    result["no_shadow_pixels"] = int(counts[NO_SHADOW])
    return result


class _MapBands(NamedTuple):
    """The bands the map reads: the ratio's, the blue, NIR and SWIR ranges, and the bands of
    each instrument sampled for its dark level (1-based file bands)."""

    ratio: object
    blue: list
    nir: list
    swir: list
    vnir_dark: list
    swir_dark: list
    long_swir: list  # the long-SWIR bands of the tilt test; empty when the SWIR stops short

    def reads(self) -> tuple[list, list]:
        """(VNIR bands, SWIR bands) a block of :func:`_map_reader` holds, in its order: the
        ratio's bands only for their validity."""
        return (
            self.blue + self.nir + [self.ratio.vnir_band],
            self.swir + self.long_swir + [self.ratio.swir_band],
        )

    def split(self, values):
        """(blue, nir, swir) of a block read by :func:`_map_reader`."""
        at_nir, at_swir = len(self.blue), len(self.blue) + len(self.nir) + 1
        return (
            values[:at_nir],
            values[at_nir : at_swir - 1],
            values[at_swir : at_swir + len(self.swir)],
        )

    def long(self, values):
        """The long-SWIR bands of a block read by :func:`_map_reader` (None without them)."""
        if not self.long_swir:
            return None
        at = len(self.blue) + len(self.nir) + 1 + len(self.swir)
        return values[at : at + len(self.long_swir)]


def _map_bands(dual, bands: BandChoice, progress) -> _MapBands:
    rb = dual.ratio_bands(bands)
    tolerance_nm = bands.tolerance_nm
    blue_b = band_range(dual.vnir, *BLUE_NM, tolerance_nm=tolerance_nm)
    nir_b = band_range(dual.vnir, *NIR_NM, tolerance_nm=tolerance_nm)
    swir_b = band_range(dual.swir, *SWIR_NM, tolerance_nm=tolerance_nm)
    v_dark_b = sorted(
        set(spread_bands(dual.vnir.bands, DARK_BANDS) + blue_b + nir_b + [rb.vnir_band])
    )
    s_dark_b = sorted(set(spread_bands(dual.swir.bands, DARK_BANDS) + swir_b + [rb.swir_band]))
    lo, hi = LONG_SWIR_NM
    long_b = [b for b in dual.swir.bands if lo <= dual.swir.wavelength_of(b) <= hi]
    if len(long_b) < LONG_SWIR_BANDS:
        progress.info(
            f"the SWIR has {len(long_b)} band(s) at {lo:g}–{hi:g} nm (the tilt test takes at "
            f"least {LONG_SWIR_BANDS}): the sunlit dark materials' tilt test is off"
        )
        long_b = []
    progress.info(
        f"signals: blue bands {blue_b[0]}–{blue_b[-1]}, NIR bands {nir_b[0]}–{nir_b[-1]} of "
        f"{dual.vnir.path}, SWIR bands "
        f"{swir_b[0]}–{swir_b[-1]} of {dual.swir.path}; ratio {rb.swir_nm:.1f}/{rb.vnir_nm:.1f} nm"
    )
    return _MapBands(rb, blue_b, nir_b, swir_b, v_dark_b, s_dark_b, long_b)


def _checked_sample(vnir, dual, sources, mb: _MapBands, sample, strips, warnings, progress):
    """The calibration sample of both instruments, saturated pixels and those without signal
    left out (else "no shadow" would be reported): (VNIR values, SWIR values, usable,
    long-SWIR values)."""
    v_src, s_src = sources
    with _bands_reader(dual, sources, mb.vnir_dark, mb.swir_dark + mb.long_swir) as read:
        pixels, ok = io.sample_windows(
            read,
            size=sample.sample_size,
            seed=sample.seed,
            progress=progress.sub(0, 0.3),
            **strips,
        )
    if not ok.any():
        raise no_valid_error(vnir, "VNIR/SWIR image")
    at_long = len(mb.vnir_dark) + len(mb.swir_dark)
    vs, ss, ls = pixels[: len(mb.vnir_dark)], pixels[len(mb.vnir_dark) : at_long], pixels[at_long:]
    checks = {}
    for sensor, values, src in ((dual.vnir, vs, v_src), (dual.swir, ss, s_src)):
        label = f"{sensor.name} {sensor.path}"
        checks[sensor.name] = check_sample(
            values, ok, None, name=label, saturation=saturation_value(src)
        )
        if checks[sensor.name].saturated:
            warnings.append(
                f"{sensor.name}: {checks[sensor.name].saturated} of {int(ok.sum())} sampled "
                "pixels are saturated and were left out of the calibration"
            )
            progress.info(warnings[-1])
    return vs, ss, ok & checks["VNIR"].usable & checks["SWIR"].usable, ls


def _calibrate(vnir, dual, sources, mb, how, strips, warnings, progress):
    """Pass 1: the scene's calibration (:func:`geoboresight.shadow.darkness.calibrate_shadow_map`)
    on a random sample, and the dark levels of the blue, NIR and SWIR bands; ``how``: the
    dark levels given, the sample and offset, the class table, the core darkness."""
    dark, calibration, table, core = how
    v_src, s_src = sources
    vs, ss, ok, ls = _checked_sample(
        vnir, dual, sources, mb, calibration, strips, warnings, progress
    )
    found = dual_dark_levels(
        dual, sources, (mb.vnir_dark, mb.swir_dark), dark, {"vnir": vs, "swir": ss}, ok, progress
    )
    levels = (
        found.for_bands("vnir", mb.vnir_dark, mb.blue),
        found.for_bands("vnir", mb.vnir_dark, mb.nir),
        found.for_bands("swir", mb.swir_dark, mb.swir),
    )
    v_at, s_at = mb.vnir_dark.index, mb.swir_dark.index
    blue_s = signal(vs[[v_at(b) for b in mb.blue]], levels[0])
    nir_s = signal(vs[[v_at(b) for b in mb.nir]], levels[1])
    swir_s = signal(ss[[s_at(b) for b in mb.swir]], levels[2])
    long_s = None
    if mb.long_swir:
        levels = (*levels, _long_dark(dual.swir, s_src, mb.long_swir, dark, ls, ok))
        long_s = signal(ls, levels[3])
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio_s = ss[s_at(mb.ratio.swir_band)] / vs[v_at(mb.ratio.vnir_band)]
    along, across, _ = boresight_offset(
        dual, calibration, progress, over="central", ratio_bands=mb.ratio, sources=(v_src, s_src)
    )
    cal = calibrate_shadow_map(
        blue_s,
        nir_s,
        swir_s,
        ratio_s,
        ok,
        dark=found,
        table=table,
        offset=(along, across),
        core=core,
        long_swir=long_s,
    )
    progress.info(
        f"sunlit ratio {cal.ratio_mode:.3f}: Table 2's ratio bounds on this scene would be × "
        f"{cal.ratio_mode / PAPER_SUNLIT_RATIO:.3f}: {cal.table.describe()}"
    )
    return cal, levels


def _long_dark(sensor, src, bands, given: DarkLevels, sample, valid) -> np.ndarray:
    """The dark level of each long-SWIR band: given, the product's or the header's, else the
    dark object of those bands alone, band by band (a shadow's long SWIR holds a few DN, so
    the one level of the instrument's dimmest band would tilt it)."""
    recorded = recorded_dark_levels({"swir": (sensor, src, bands)}, given)
    found = find_dark_levels(given, recorded, {"swir": sample}, valid)
    if found.source("swir") == ESTIMATED:
        return np.asarray(found.band_levels("swir"), float)  # each band's own dark object
    return found.per_band("swir", bands)


@contextlib.contextmanager
def _bands_reader(dual, sources, vnir_bands: list, swir_bands: list):
    """``read(row0, row1) -> (values, valid)`` of the 1-based ``vnir_bands`` then
    ``swir_bands``, valid where all are: straight from raw ENVI files
    (:func:`geoboresight.io.cube.raw_bands_reader`: a BIL strip's bands in one copy), else
    through GDAL band by band (:func:`geoboresight.io.bands_reader`). The same values and
    validity either way."""
    raw, cube = raw_bands_reader(dual.vnir.reads, dual.swir.reads, vnir_bands, swir_bands)
    if raw is None:
        v_src, s_src = sources
        yield io.bands_reader([(v_src, b) for b in vnir_bands] + [(s_src, b) for b in swir_bands])
        return

    def read(row0: int, row1: int):
        (v, v_ok), (s, s_ok) = raw(row0, row1)
        return np.concatenate([v, s]), v_ok & s_ok

    with cube:
        yield read


def _map_reader(stack, sources, dual, mb: _MapBands, opened):
    """Pass 2's reader of a block (:meth:`_MapBands.reads`: the signal bands, valid in the
    ratio's bands too), and with a surface model its heights and the block's first line."""
    read_image = stack.enter_context(_bands_reader(dual, sources, *mb.reads()))
    if opened is None:
        return read_image
    read_z = io.band_reader(opened.src, 1)

    def read(r0, r1):
        values, valid = read_image(r0, r1)
        z, z_ok = read_z(r0, r1)
        return values, valid, z, z_ok, r0

    return read


def _register(read, dual, mb: _MapBands, prior, register: bool, block: dict):
    """The surface model registered onto the image on the central block of lines (as the
    boresight offset): :func:`geoboresight.shadow.blocks.register_prior`."""
    r0, r1 = central_rows(dual.height)
    values, valid, z, z_ok, _ = read(r0, r1)
    return register_prior(
        *mb.split(values),
        z,
        valid,
        heights_valid=z_ok,
        surface_prior=prior,
        row0=r0,
        register=register,
        **block,
    )


def _map_kernel(mb: _MapBands, table, block: dict, prior, sky_blue: float):
    """The kernel of a strip: (classes, mask, fraction, and with a surface model the
    predicted shadow away from its edges, its part spectrally lit, the unseen pixels and the
    model's holes; without one the pixels dark enough for core shadow and those of them the
    map leaves sunlit: water and sunlit dark materials)."""

    def kernel(values, valid, z=None, z_ok=None, r0=0):
        if z is None:
            f, d = shadow_fraction_block(
                *mb.split(values), valid, sky_blue=sky_blue, long_swir=mb.long(values), **block
            )
            with np.errstate(invalid="ignore"):
                dark = d <= block["calibration"].core
                declined = dark & ~(f >= 0.5)
            c, m = shadow_classes(f, table), shadow_mask(f)
            return c, m, f, None, None, None, None, dark, declined
        b = prior_map_block(
            *mb.split(values),
            z,
            valid,
            heights_valid=z_ok,
            surface_prior=prior,
            row0=r0,
            sky_blue=sky_blue,
            long_swir=mb.long(values),
            **block,
        )
        f = b.fraction
        return (
            shadow_classes(f, table),
            shadow_mask(f),
            f,
            b.deep,
            b.lit,
            b.unseen,
            b.holes,
            None,
            None,
        )

    return kernel


def _fraction_classes(table) -> str:
    return "; ".join(f"{c.id}: {fraction_text(c)}" for c in table.classes)


def _map_tags(dual, cal, core, edge_pixels, surface: SurfaceModel, opened, prior) -> dict:
    """The products' tags: the calibration, the classes and the method."""
    tags = {
        "product": "boresight shadow map: mask and scene-calibrated Table 2 classes "
        "(Brook & Ben-Dor 2011, §3.1)",
        "vnir": dual.vnir.path,
        "swir": dual.swir.path,
        **{k: str(v) for k, v in cal.as_dict().items()},
        "classes": _fraction_classes(cal.table),
        "table2_ratio_bounds_on_scene": cal.table.describe(),
        "table2_ratio_bounds_csv": class_table_csv(cal.table).replace("\n", " | "),
        "method": spectral_method(core, edge_pixels),
    }
    if prior is None:
        return tags
    tags.update(
        dsm=surface.dsm,
        sun_zenith_deg=str(prior.zenith),
        sun_azimuth_deg=str(prior.azimuth),
        sun_position=opened.sun,
        **({"igm": surface.igm} if surface.igm else {}),
        **({"glt": surface.glt} if surface.glt else {}),
        dsm_surface=prior.surface,
        dsm_registration_rows=str(prior.shift[0]),
        dsm_registration_columns=str(prior.shift[1]),
        dsm_height_noise_m=f"{prior.noise:.3f}",
        dsm_edge_tolerance_px=str(prior.tolerance),
        method=prior_method(prior, registered=surface.register, edge_pixels=edge_pixels),
    )
    return tags


def _write_map(stack, read, kernel, dual, tags, table, paths, halo, strips, progress):
    """Pass 2: the map written strip by strip; (pixels per class, counts of shadow pixels and
    of the surface model's agreement)."""
    output, mask, fraction = paths
    dst = stack.enter_context(
        io.create_class_raster(
            output,
            dual.grid,
            tags=tags,
            band_name="shadow class (scene-calibrated Table 2)",
            colormap=table.colormap(),
            category_names=table.names(),
            band_tags={f"CLASS_{k}": v for k, v in table.names().items()},
        )
    )
    mdst = stack.enter_context(mask_raster(mask, dual.grid, tags, "shadow mask")) if mask else None
    fdst = None
    if fraction:
        fdst = stack.enter_context(
            io.create_raster(
                fraction,
                dual.grid,
                tags={**tags, "product": "estimated shadow fraction (0–1)"},
                band_names=["shadow fraction"],
            )
        )
    counts = np.zeros(256, np.int64)
    n = dict.fromkeys(("shadow", "deep", "lit", "unseen", "holes", "dark", "declined"), 0)
    for win, (c, m, f, *agree, dark, declined) in io.map_windows(
        read, kernel, halo=halo, progress=progress.sub(0.3, 1.0), message="shadow map", **strips
    ):
        dst.write(c, 1, window=win)
        if mdst is not None:
            mdst.write(m, 1, window=win)
        if fdst is not None:
            fdst.write(
                np.where(np.isfinite(f), f, io.FLOAT_NODATA).astype("float32"), 1, window=win
            )
        counts += np.bincount(c.ravel(), minlength=256)
        n["shadow"] += int((m == MASK_SHADOW).sum())
        if agree[0] is not None:
            for key, a in zip(("deep", "lit", "unseen", "holes"), agree, strict=True):
                n[key] += int(a.sum())
        if dark is not None:
            n["dark"] += int(dark.sum())
            n["declined"] += int(declined.sum())
    if n["dark"]:
        for d in (dst, mdst, fdst):
            if d is not None:
                d.update_tags(**_declined_tags(n))
    return counts, n


def _declined_tags(n: dict) -> dict:
    """The share of the pixels dark enough for core shadow that the map left sunlit (tags
    named as :func:`geoboresight.io.raster.base_tags` names the others)."""
    return {
        "DARK_PIXELS": str(n["dark"]),
        "DARK_DECLINED_SHARE": f"{n['declined'] / n['dark']:.4f}",
    }


def _surface_summary(agreement, prior, n, n_valid, register, warnings, progress) -> None:
    """The surface model against the image: the result's figures, the log and warnings."""
    lit_share = n["lit"] / n["deep"] if n["deep"] else 0.0
    agreement.update(
        dsm_surface=prior.surface,
        dsm_relief_m=round(prior.relief, 3),
        dsm_predicted_shadow_pixels=n["deep"],
        dsm_predicted_shadow_lit_share=round(lit_share, 4),
        dsm_unseen_share=round(n["unseen"] / n_valid, 4),
        dsm_missing_share=round(n["holes"] / n_valid, 4),
    )
    if n["holes"]:
        warnings.append(
            f"the surface model has no height for {100 * n['holes'] / n_valid:.1f} % of the "
            "valid pixels (beyond its extent or nodata): the spectra alone judge them"
        )
    if register:
        progress.info(
            "predicted shadow registered to the image: moved by "
            f"{agreement['dsm_registration_rows']:+.2f} rows, "
            f"{agreement['dsm_registration_columns']:+.2f} columns (correlation with the "
            f"NIR's darkness {agreement['dsm_registration_r0']} → "
            f"{agreement['dsm_registration_r']}, t = {agreement['dsm_registration_t']})"
        )
    progress.info(
        f"surface model against the image: {100 * lit_share:.1f} % of the predicted shadow "
        "(away from its edges) is spectrally lit; best shift of the predicted shadow "
        f"{agreement['dsm_shift_rows']:+d} rows, {agreement['dsm_shift_columns']:+d} columns "
        f"(IoU with the dark pixels {agreement['dsm_iou_at_shift']} there, "
        f"{agreement['dsm_iou']} unshifted); {100 * n['unseen'] / n_valid:.1f} % of the "
        "pixels could be shaded by casters beyond the surface model's edge (spectral "
        "estimate there)"
    )
    if lit_share > LIT_PREDICTION:
        warnings.append(
            f"{100 * lit_share:.0f} % of the shadow the surface model predicts is "
            "spectrally lit: the model may be of another date, not registered with the "
            "image, or the sun's angles wrong"
        )
    gain = (agreement["dsm_iou_at_shift"] or 0) - (agreement["dsm_iou"] or 0)
    shifted = (agreement["dsm_shift_rows"], agreement["dsm_shift_columns"]) != (0, 0)
    if shifted and gain > SHIFT_IOU_GAIN:
        warnings.append(
            "the predicted shadow matches the image's dark pixels best shifted by "
            f"{agreement['dsm_shift_rows']:+d} rows, {agreement['dsm_shift_columns']:+d} "
            f"columns (IoU {agreement['dsm_iou']} → {agreement['dsm_iou_at_shift']}): the "
            "surface model is probably not registered with the image"
        )
