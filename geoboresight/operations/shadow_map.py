"""File-level shadow map (paper §3.1, made physical): VNIR + SWIR in, a shadow mask and the
four shadow-fraction classes out, calibrated to the scene (:mod:`geoboresight.shadow.map`).

Two passes over the flight line: a random sample calibrates the map (dark levels, sunlit
modes, sunlit ratio, the scaled class table) and a central block of lines gives the boresight
offset; then the map is written strip by strip, each strip by the kernel
:func:`geoboresight.shadow.map.shadow_map_block`. The dark levels are found in
:mod:`geoboresight.io.dark`.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass

import numpy as np

from .. import io
from ..errors import InputError, ParameterError
from ..io.bands import BoresightOffset, band_range
from ..io.dark import DarkLevels, dark_level_of
from ..io.dual import BandChoice, DualLayout
from ..io.masks import mask_raster
from ..io.shadow import class_table_csv
from ..io.windows import Sample
from ..shadow import classes as cls
from ..shadow import map as smap
from ._operation import operation
from .shadow import class_table, no_valid_error

#: Pixels drawn at random to calibrate the map.
SAMPLE_SIZE = 200_000


@dataclass(frozen=True)
class MapSample(Sample):
    """The shadow map's calibration sample: :class:`~geoboresight.io.windows.Sample` with
    :data:`SAMPLE_SIZE` pixels by default."""

    sample_size: int = SAMPLE_SIZE


#: Bands per instrument read for the dark level besides the signal bands (evenly spaced).
DARK_BANDS = 16
#: Lines of the central block the boresight offset is measured on.
OFFSET_ROWS = 512


def _spread(bands: tuple[int, ...], n: int) -> list[int]:
    idx = np.unique(np.linspace(0, len(bands) - 1, min(n, len(bands))).round().astype(int))
    return [bands[i] for i in idx]


def _dark_level(sensor, src, bands, given, sample, valid, progress) -> smap.DarkLevel:
    """Given, the product's dark reference or the header's (io.dark), else the dark object."""
    level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is None:
        level = smap.dark_level(sample, valid)
    progress.info(level.describe(sensor.name))
    return level


def _saturation(src) -> float | None:
    """The value a saturated element reads: the integer data type's largest; None for floats."""
    dtype = np.dtype(src.dtypes[0])
    return float(np.iinfo(dtype).max) if dtype.kind in "iu" else None


def _offset(dual, v_src, s_src, rb, given: BoresightOffset, progress):
    if given.offset_along is not None or given.offset_across is not None:
        return float(given.offset_along or 0.0), float(given.offset_across or 0.0), "given"
    from ..dem.offset import estimate_offset

    r0 = max(0, dual.height // 2 - OFFSET_ROWS // 2)
    r1 = min(dual.height, r0 + OFFSET_ROWS)
    vv, vok = io.band_reader(v_src, rb.vnir_band)(r0, r1)
    ss, sok = io.band_reader(s_src, rb.swir_band)(r0, r1)
    try:
        off = estimate_offset(vv, ss, vok & sok)
    except InputError as e:
        progress.info(f"boresight offset not measurable ({e}); the SWIR is used unshifted")
        return 0.0, 0.0, "not measurable: 0"
    return off.along, off.across, f"measured on lines {r0}–{r1}"


@operation(inputs=("vnir", "swir", "classes"), outputs=("output", "mask"))
def shadow_map_file(
    vnir,
    swir=None,
    classes=None,
    *,
    output,
    mask=None,
    layout=DualLayout(),
    bands=BandChoice(),
    dark=DarkLevels(),
    offset=BoresightOffset(),
    core_darkness=smap.CORE_DARKNESS,
    edge_pixels=smap.EDGE_PIXELS,
    sample=MapSample(),
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
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    bands : BandChoice
        The bands of the boresight ratio (Eq. 3) the classes are scaled by, nearest 920 nm
        (VNIR) and 1010 nm (SWIR) by default; its ``tolerance_nm`` also bounds the blue, NIR
        and SWIR ranges. The faces always give ``band_mode="wavelength"``.
    dark : DarkLevels
        Dark level (DN of zero signal) of each instrument (``vnir_dark``, ``swir_dark``);
        None = the sensor product's dark reference, else the header's 'dark level', else
        estimated from the data (dark object): :func:`geoboresight.io.dark.dark_level_of`.
        Give 0 for radiance.
    offset : BoresightOffset
        Boresight offset of the SWIR relative to the VNIR (px, ``offset_along``,
        ``offset_across``); both None = measured on a central block of lines.
    core_darkness : float
        Core shadow: mean natural log of the NIR and SWIR signals over their sunlit modes at
        or below this (default ln 0.2).
    edge_pixels : int
        Partial shadow is looked for this many pixels around the core (0 = core only).
    sample : MapSample
        The random sample that calibrates the map: ``sample_size`` pixels (default 200,000),
        ``seed``.
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` (and ``mask``), the calibration (dark levels and their source, sunlit
        signals, sunlit ratio, class scale, offset), the class boundaries used, pixels per
        class, shadow pixels and ``warnings``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.1, Table 2).
    Chavez, P.S. Remote Sens. Environ. 1988, 24, 459–479 (dark-object subtraction).
    """
    if int(edge_pixels) != edge_pixels or edge_pixels < 0:
        raise ParameterError(f"parameter 'edge_pixels': {edge_pixels!r} must be a whole number ≥ 0")
    edge_pixels = int(edge_pixels)
    base_table = class_table(classes)
    dual = io.as_dual(vnir, swir, layout)
    rb = dual.ratio_bands(bands)
    tolerance_nm = bands.tolerance_nm
    blue_b = band_range(dual.vnir, *smap.BLUE_NM, tolerance_nm=tolerance_nm)
    nir_b = band_range(dual.vnir, *smap.NIR_NM, tolerance_nm=tolerance_nm)
    swir_b = band_range(dual.swir, *smap.SWIR_NM, tolerance_nm=tolerance_nm)
    v_dark_b = sorted(set(_spread(dual.vnir.bands, DARK_BANDS) + blue_b + nir_b + [rb.vnir_band]))
    s_dark_b = sorted(set(_spread(dual.swir.bands, DARK_BANDS) + swir_b + [rb.swir_band]))
    progress.info(
        f"signals: blue bands {blue_b[0]}–{blue_b[-1]}, NIR bands {nir_b[0]}–{nir_b[-1]} of "
        f"{dual.vnir.path}, SWIR bands "
        f"{swir_b[0]}–{swir_b[-1]} of {dual.swir.path}; ratio {rb.swir_nm:.1f}/{rb.vnir_nm:.1f} nm"
    )
    warnings: list[str] = []
    strips = {"height": dual.height, "width": dual.width, "block_rows": block_rows}
    with contextlib.ExitStack() as stack:
        v_src = stack.enter_context(io.open_raster(dual.vnir.reads, "VNIR"))
        s_src = (
            v_src if dual.merged else stack.enter_context(io.open_raster(dual.swir.reads, "SWIR"))
        )
        # Pass 1: a random sample of the line for the dark levels and the sunlit modes.
        sources = [(v_src, b) for b in v_dark_b] + [(s_src, b) for b in s_dark_b]
        pixels, ok = io.sample_windows(
            io.bands_reader(sources),
            size=sample.sample_size,
            seed=sample.seed,
            progress=progress.sub(0, 0.3),
            **strips,
        )
        if not ok.any():
            raise no_valid_error(vnir, "VNIR/SWIR image")
        nv = len(v_dark_b)
        vs, ss = pixels[:nv], pixels[nv:]
        # The physics the map needs, checked before calibrating: unsaturated pixels with
        # signal, and dark levels within the data's range (else "no shadow" would be reported).
        checks = {}
        for sensor, values, src in ((dual.vnir, vs, v_src), (dual.swir, ss, s_src)):
            label = f"{sensor.name} {sensor.path}"
            checks[sensor.name] = smap.check_sample(
                values, ok, None, name=label, saturation=_saturation(src)
            )
            if checks[sensor.name].saturated:
                warnings.append(
                    f"{sensor.name}: {checks[sensor.name].saturated} of {int(ok.sum())} sampled "
                    "pixels are saturated and were left out of the calibration"
                )
                progress.info(warnings[-1])
        ok = ok & checks["VNIR"].usable & checks["SWIR"].usable
        v_dark = _dark_level(dual.vnir, v_src, v_dark_b, dark.vnir_dark, vs, ok, progress)
        s_dark = _dark_level(dual.swir, s_src, s_dark_b, dark.swir_dark, ss, ok, progress)
        for sensor, values, level in ((dual.vnir, vs, v_dark), (dual.swir, ss, s_dark)):
            smap.check_sample(values, ok, level, name=f"{sensor.name} {sensor.path}")
        blue_lv = v_dark.for_bands(v_dark_b, blue_b)
        nir_lv = v_dark.for_bands(v_dark_b, nir_b)
        swir_lv = s_dark.for_bands(s_dark_b, swir_b)
        blue_s = smap.signal(vs[[v_dark_b.index(b) for b in blue_b]], blue_lv)
        nir_s = smap.signal(vs[[v_dark_b.index(b) for b in nir_b]], nir_lv)
        swir_s = smap.signal(ss[[s_dark_b.index(b) for b in swir_b]], swir_lv)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio_s = ss[s_dark_b.index(rb.swir_band)] / vs[v_dark_b.index(rb.vnir_band)]
        along, across, how = _offset(dual, v_src, s_src, rb, offset, progress)
        progress.info(f"boresight offset {along:+.2f} px along, {across:+.2f} px across ({how})")
        cal = smap.calibrate_shadow_map(
            blue_s,
            nir_s,
            swir_s,
            ratio_s,
            ok,
            vnir_dark=v_dark,
            swir_dark=s_dark,
            table=base_table,
            offset=(along, across),
            core=core_darkness,
        )
        progress.info(
            f"sunlit ratio {cal.ratio_mode:.3f}: Table 2's ratio bounds on this scene would be × "
            f"{cal.ratio_mode / smap.PAPER_SUNLIT_RATIO:.3f}: {cal.table.describe()}"
        )
        fraction_classes = "; ".join(f"{c.id}: {cls.fraction_text(c)}" for c in cal.table.classes)
        # Pass 2: the map, strip by strip (shadow.map.shadow_map_block); the halo covers the
        # SWIR shift and the edge search.
        read = io.bands_reader(
            [(v_src, b) for b in blue_b]
            + [(v_src, b) for b in nir_b]
            + [(s_src, b) for b in swir_b]
            + [(v_src, rb.vnir_band), (s_src, rb.swir_band)]  # valid in the ratio's bands too
        )
        at_nir, at_swir = len(blue_b), len(blue_b) + len(nir_b)
        at_end = at_swir + len(swir_b)
        levels = (blue_lv, nir_lv, swir_lv)

        def kernel(values, valid):
            c, m = smap.shadow_map_block(
                values[:at_nir],
                values[at_nir:at_swir],
                values[at_swir:at_end],
                valid,
                calibration=cal,
                dark_levels=levels,
                edge_pixels=edge_pixels,
            )
            return c, m, np.bincount(c.ravel(), minlength=256)

        tags = {
            "product": "boresight shadow map: mask and scene-calibrated Table 2 classes "
            "(Brook & Ben-Dor 2011, §3.1)",
            "vnir": dual.vnir.path,
            "swir": dual.swir.path,
            **{k: str(v) for k, v in cal.as_dict().items()},
            "classes": fraction_classes,
            "table2_ratio_bounds_on_scene": cal.table.describe(),
            "table2_ratio_bounds_csv": class_table_csv(cal.table).replace("\n", " | "),
            "method": "dark-object subtraction; SWIR darkness against its sunlit mode (core ≤ "
            f"{core_darkness:.3f}, natural log) on the SWIR resampled by the boresight offset; "
            "not water (blue/NIR); shadow fraction of the pixels within "
            f"{edge_pixels} px by unmixing between the local sunlit and core-shadow signals; "
            "classes by Table 2's fraction intervals",
        }
        counts = np.zeros(256, np.int64)
        n_shadow = 0
        dst = stack.enter_context(
            io.create_class_raster(
                output,
                dual.grid,
                tags=tags,
                band_name="shadow class (scene-calibrated Table 2)",
                colormap=cal.table.colormap(),
                category_names=cal.table.names(),
                band_tags={f"CLASS_{k}": v for k, v in cal.table.names().items()},
            )
        )
        mdst = None
        if mask:
            mdst = stack.enter_context(mask_raster(mask, dual.grid, tags, "shadow mask"))
        for win, (c, m, n) in io.map_windows(
            read,
            kernel,
            halo=(smap.shadow_map_halo(cal, edge_pixels),) * 2,
            progress=progress.sub(0.3, 1.0),
            message="shadow map",
            **strips,
        ):
            dst.write(c, 1, window=win)
            if mdst is not None:
                mdst.write(m, 1, window=win)
            counts += n
            n_shadow += int((m == cls.MASK_SHADOW).sum())
        n_valid = int(counts[: cls.NODATA_CLASS].sum())
        if n_valid == 0:
            raise no_valid_error(vnir, "VNIR/SWIR image")
    share = n_shadow / n_valid
    if share > 0.6:
        warnings.append(
            f"{100 * share:.0f} % of the valid pixels are shadow: the sunlit mode may not be "
            "sunlit ground (a mostly shaded or dark scene); check the calibration"
        )
    for w in warnings:
        progress.info(f"warning: {w}")
    result = {
        "output": output,
        "valid_pixels": n_valid,
        "shadow_pixels": n_shadow,
        "shadow_share": round(share, 4),
        **cal.as_dict(),
        "classes": fraction_classes,
        "table2_ratio_bounds_on_scene": cal.table.describe(),
        "warnings": warnings,
    }
    if mask:
        result["mask"] = mask
    for c in cal.table.classes:
        result[f"class_{c.id}_pixels"] = int(counts[c.id])
    result["no_shadow_pixels"] = int(counts[cls.NO_SHADOW])
    return result
