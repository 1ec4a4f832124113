"""File-level de-shadowing: a VNIR + SWIR cube and a shadow fraction in, the cube with each
shadowed pixel scaled to its sunlit signal out (:mod:`geoboresight.shadow.deshadow`).

Two passes over the flight line: the pairs of shadowed and sunlit pixels across shadow edges
give each band's illumination ratio (on the VNIR grid, the SWIR resampled by the boresight
offset); then the cube is written strip by strip, each instrument on its own grid (the
fraction shifted onto the SWIR's). The steps are kernels of
:mod:`geoboresight.shadow.deshadow_steps` (:func:`~geoboresight.shadow.deshadow_steps.edge_pairs`,
:func:`~geoboresight.shadow.deshadow_steps.fit_illumination`,
:func:`~geoboresight.shadow.deshadow_steps.deshadow_block`).
"""

from __future__ import annotations

import contextlib
import math
from dataclasses import dataclass

import numpy as np

from .. import io
from ..errors import InputError, ParameterError
from ..io.bands import BoresightOffset
from ..io.checks import check_fraction, check_fraction_nodata, no_valid_error
from ..io.dual import DualLayout
from ..sensor.dark import DarkLevels
from ..shadow.deshadow import ADJACENCY_M, DISTANCES, MIN_SHADOW_SNR, POOR_SPREAD
from ..shadow.deshadow_steps import (
    NOISE_PIXELS,
    EdgePairs,
    deshadow_block,
    edge_pairs,
    fit_illumination,
    merge_edge_pairs,
    pair_share,
    picked_pixels,
)
from ..shadow.region import TILE as REGION_TILE
from ..shadow.skyview import SKY_RADIUS_M, sky_view_factor
from ._dark import DARK_BANDS, dual_dark_levels, spread_bands
from ._offset import boresight_offset
from ._surface import SurfaceModel, open_surface

#: Pixels sampled for the dark level estimate.
DARK_SAMPLE = 100_000


@dataclass(frozen=True)
class LightModel:
    """What de-shadowing models of the light beyond one ratio per band, all off by default
    (docs/deshadow.md).

    ``additive``: also estimate each band's additive signal (path radiance, and
    what is left of a dark level that differs from band to band when one level per
    instrument is subtracted): the intercept of the line of the pairs of one surface
    (:func:`geoboresight.shadow.deshadow.same_surface`,
    :func:`geoboresight.shadow.deshadow.additive_signal`; with a surface model each sunlit
    side's slope, cos i, enters it), combined band by band with the dark object (an upper
    bound, :func:`geoboresight.shadow.deshadow.combine_additive`) by their estimated
    errors; the ratio is then measured, and the signal scaled, above it (it is added
    back). It helps only where pairs of one surface are found.
    ``adjacency``: also light each pixel by its sunlit surroundings (ATCOR-4's
    ``(1 − V)·ρ̄·E_global``, within :data:`~geoboresight.shadow.deshadow.ADJACENCY_M`),
    its share fitted per band (:func:`geoboresight.shadow.deshadow.adjacency_ratio`): each
    pixel gets its own ratio. Needs the surface model (V).
    ``regions``: each neighbourhood of shadows (96 px) gets its own ratio, the
    scene's ``k − 1`` scaled by what the pairs across its own shadows' edges say
    (:mod:`geoboresight.shadow.region`: a shadow that sees less sky, or gets more light
    from its surroundings, than the scene's average), the scene's ratio where it has too
    few pairs; not with ``adjacency``, which gives each pixel its own already. It helps
    the simulator's scenes, not model 2's.

    Examples
    --------
    >>> import geoboresight as gb
    >>> gb.LightModel(regions=True)
    LightModel(additive=False, adjacency=False, regions=True)
    """

    additive: bool = False
    adjacency: bool = False
    regions: bool = False


def _sky_view(read_z, prior, r0, r1, height):
    """(heights, sky-view factor) of lines r0–r1: the factor from the DSM read
    :data:`~geoboresight.shadow.skyview.SKY_RADIUS_M` beyond them (its horizon search)."""
    halo = math.ceil(SKY_RADIUS_M / _cell(prior)) + 1
    q0, q1 = max(0, r0 - halo), min(height, r1 + halo)
    z, z_ok = read_z(q0, q1)
    v = sky_view_factor(z, z_ok, transform=prior.matrix, clearance=prior.clearance)
    cut = slice(r0 - q0, r1 - q0)
    return np.where(z_ok, z, np.nan)[cut], v[cut]


def _cell(prior) -> float:
    """The grid's cell size (m): the square root of its cell's area."""
    return float(np.sqrt(abs(np.linalg.det(prior.matrix))))


def deshadow_file(
    vnir,
    swir=None,
    *,
    shadow,
    output,
    report=None,
    unresolved=None,
    surface=SurfaceModel(),
    layout=DualLayout(),
    dark=DarkLevels(),
    offset=BoresightOffset(),
    light=LightModel(),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """De-shadowed cube: each pixel scaled by its shadow fraction and the scene's
    sunlit-to-shadow illumination ratio of each band.

    ``L_sun = L / (1 − f·(1 − 1/k_b))`` on the signal above the dark level (from
    ``L = (E_dir·(1 − f) + E_diff)·ρ``), ``k_b`` measured on pairs of fully shadowed and
    sunlit pixels across the scene's shadow edges
    (:func:`geoboresight.shadow.deshadow.illumination_ratio`). The output is in the input's
    units: pixels out of shadow keep their values.

    Parameters
    ----------
    vnir : path
        VNIR file, a merged VNIR+SWIR cube when ``swir`` is None, or a sensor product.
    swir : path, optional
        SWIR file on the same pixel grid.
    shadow : path
        Shadow fraction (0–1) on the image's grid: ``shadow-map``'s ``fraction`` or
        ``sun-shadow``'s output.
    output : path
        Float32 GeoTIFF, VNIR bands then SWIR bands, wavelengths in the band descriptions and
        tags.
    report : path, optional
        JSON: the illumination ratio and factor at full shadow of each band, its signal and
        noise in full shadow and whether they resolve it, the pairs used.
    unresolved : path, optional
        Byte mask on the image's grid: 1 where a shadowed pixel (fraction above 0) holds bands
        left as measured because the noise does not resolve their signal in shadow, 0
        elsewhere, 255 nodata. A band is resolved when its median signal in full shadow is at
        least :data:`~geoboresight.shadow.deshadow.MIN_SHADOW_SNR` × its noise there
        (neighbouring shadowed pixels' differences,
        :func:`geoboresight.shadow.deshadow.shadow_noise`); the others keep ratio 1 and are
        named in the band tags (``resolved_in_shadow``) and the report.
    surface : SurfaceModel
        A surface model on the image's grid and the sun (as ``shadow-map --dsm``): pairs are
        kept only down-sun or lateral of the shadow and between cells of about the same
        height, their median is open ground's ratio, and each pixel's own follows from its
        sky-view factor (:func:`geoboresight.shadow.skyview.sky_view_factor`). None: one
        ratio for every pixel.
    layout : DualLayout
    dark : DarkLevels
        Dark level of each instrument (None = the product's, the header's, else estimated as
        ``shadow-map`` does); 0 for radiance.
    offset : BoresightOffset
        Boresight offset of the SWIR (px); both None = measured.
    light : LightModel
        The additive signal, the light of the sunlit surroundings, each neighbourhood's own
        ratio: all off by default (:class:`LightModel`).
    block_rows : int
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` (``report``), the pairs used, their spread, the ratio's range over the
        bands, shadowed pixels corrected, warnings.

    References
    ----------
    Richter, R.; Müller, A. Int. J. Remote Sens. 2005, 26, 3137–3148 (de-shadowing).
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484.

    Examples
    --------
    >>> v, s = "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr"
    >>> _ = gb.shadow_map_file(v, s, output="out/classes.tif", fraction="out/fraction.tif")
    >>> gb.deshadow_file(v, s, shadow="out/fraction.tif", output="out/deshadowed.tif")["pairs_used"]
    181
    """
    additive, adjacency = light.additive, light.adjacency
    dual = io.as_dual(vnir, swir, layout)
    wl = np.concatenate([dual.vnir.wavelengths, dual.swir.wavelengths]).astype(float)
    strips = {"height": dual.height, "width": dual.width, "block_rows": block_rows}
    warnings: list[str] = []
    with contextlib.ExitStack() as stack:
        v_src = stack.enter_context(io.open_raster(dual.vnir.reads, "VNIR"))
        s_src = (
            v_src if dual.merged else stack.enter_context(io.open_raster(dual.swir.reads, "SWIR"))
        )
        f_src = _open_fraction(shadow, dual, stack)
        opened = open_surface(surface, dual, block_rows, stack, progress)
        prior = None if opened is None else opened.prior
        if adjacency and prior is None:
            raise ParameterError(
                "parameter 'adjacency': the light of the surroundings needs a surface model "
                "(--dsm and the sun): a shadow gets it from the part of its sky that the "
                "surroundings hide, 1 − its sky-view factor"
            )
        adj_half = max(1, int(ADJACENCY_M / (2.0 * _cell(prior)))) if adjacency else 0
        levels = _dark_levels(vnir, dual, (v_src, s_src), dark, strips, progress)
        along, across, _ = boresight_offset(
            dual, offset, progress, over="central", sources=(v_src, s_src)
        )
        read = _cube_reader(dual, (v_src, s_src), f_src, shadow, opened)
        # Pass 1: pairs across shadow edges, and each instrument's darkest pixels.
        edges = _gather_pairs(
            read, dual, levels, prior, (along, across), adj_half, strips, progress
        )
        fit = fit_illumination(
            edges,
            wl,
            surface=prior is not None,
            additive=additive,
            adjacency=adjacency,
            shape=(dual.height, dual.width),
            regions=light.regions,
        )
        _log_fit(fit, edges, (additive, adjacency, prior is not None), warnings, progress)
        # Pass 2: the de-shadowed cube, each instrument on its own grid.
        tags = _cube_tags(dual, shadow, surface, prior, wl, fit, levels, adjacency, along, across)
        n_corrected = _write_cube(
            read, (output, unresolved), dual, tags, fit, levels, (along, across), adj_half,
            strips, progress
        )  # fmt: skip
    result = _result(output, edges, fit, n_corrected, (along, across), warnings)
    if report:
        io.write_json(report, _report(result, wl, fit, levels))
        result["report"] = report
    if unresolved:
        result["unresolved"] = unresolved
    for w in warnings:
        progress.info(f"warning: {w}")
    return result


def _result(output, edges, fit, n_corrected, offset, warnings) -> dict:
    """The operation's result: the output, the pairs, the ratio's range, the bands left."""
    k = fit.ratio
    return {
        "output": output,
        "pairs": int(edges.shaded.shape[0]),  # the candidates the fit chose from
        "pairs_used": fit.pairs_used,
        "pair_spread": round(fit.spread, 4),
        "ratio_min": round(float(np.nanmin(k)), 4),
        "ratio_max": round(float(np.nanmax(k)), 4),
        "shadowed_pixels": n_corrected,
        "bands_unchanged": fit.unchanged,
        "bands_unresolved": fit.unresolved,
        "regions": fit.regions,
        "offset_along_px": round(offset[0], 3),
        "offset_across_px": round(offset[1], 3),
        "warnings": warnings,
    }


def _gather_pairs(read, dual, levels, prior, offset, adj_half, strips, progress):
    """Pass 1: the pairs across the shadow edges of the whole line, on the VNIR grid (the SWIR
    resampled onto it), and each instrument's darkest pixels on its own grid
    (:func:`geoboresight.shadow.deshadow_steps.edge_pairs`)."""
    nv = len(dual.vnir.bands)
    lv = levels[:, None, None]
    share = pair_share((dual.height, dual.width))
    quiet_share = pair_share((dual.height, dual.width), NOISE_PIXELS)
    adj_size = 2 * adj_half + 1 if adj_half else 0

    def pairs(x, x_ok, f, z, v, block):
        own = np.zeros(f.shape, bool)
        own[block.inner] = True
        return edge_pairs(
            x.astype(np.float64) - lv,
            f,
            z,
            v,
            x_ok,
            own=own,
            picked=picked_pixels(block.row0, f.shape, share),
            n_vnir=nv,
            offset=offset,
            surface_prior=prior,
            adjacency_size=adj_size,
            quiet=picked_pixels(block.row0, f.shape, quiet_share),
            row0=block.row0,
        )

    shift_halo = math.ceil(abs(offset[0])) + 2
    return io.reduce_windows(
        read,
        pairs,
        merge_edge_pairs,
        EdgePairs.empty(len(levels), nv, bool(adj_half)),
        halo=(max(DISTANCES) + 1 + shift_halo + adj_half,) * 2,
        pass_block=True,
        progress=progress.sub(0.1, 0.4),
        message="shadow edges",
        **strips,
    )


def _write_cube(read, outputs, dual, tags, fit, levels, offset, adj_half, strips, progress):
    """Pass 2: the de-shadowed cube written strip by strip
    (:func:`geoboresight.shadow.deshadow_steps.deshadow_block`), and the mask of shadowed
    pixels with bands left as measured when ``outputs`` names one; the shadowed pixels
    corrected."""
    output, unresolved = outputs
    nv = len(dual.vnir.bands)
    wl = np.concatenate([dual.vnir.wavelengths, dual.swir.wavelengths]).astype(float)
    base = levels[:, None, None] + fit.additive[:, None, None]
    adj_size = 2 * adj_half + 1 if adj_half else 0

    def kernel(x, x_ok, f, z, v, block):
        cube, n = deshadow_block(
            x, f, v, x_ok, base=base, fit=fit, n_vnir=nv, offset=offset,
            adjacency_size=adj_size, row0=block.row0,
        )  # fmt: skip
        return cube[:, block.inner], n[block.inner]

    names = [f"{'VNIR' if i < nv else 'SWIR'} {w:.1f} nm" for i, w in enumerate(wl)]
    band_tags = [
        {
            "wavelength": f"{w:.2f}",
            "wavelength_units": "Nanometers",
            "illumination_ratio": f"{k:.4f}",
            "resolved_in_shadow": "yes" if ok else "no",
            "shadow_snr": f"{snr:.2f}" if np.isfinite(snr) else "unknown",
        }
        for w, k, ok, snr in zip(wl, fit.ratio, _resolved(fit), _snr(fit), strict=True)
    ]
    flagged = fit.unresolved > 0
    n_corrected = 0
    with contextlib.ExitStack() as stack:
        out = stack.enter_context(
            io.create_raster(
                output, dual.grid, count=len(wl), tags=tags, band_names=names, band_tags=band_tags
            )
        )
        mask = None
        if unresolved:
            mask = stack.enter_context(
                io.create_raster(
                    unresolved,
                    dual.grid,
                    dtype="uint8",
                    nodata=255,
                    tags=_mask_tags(wl, fit),
                    band_names=["shadowed pixel with bands left as measured"],
                )
            )
        for win, (cube, n) in io.map_windows(
            read,
            kernel,
            halo=(math.ceil(abs(offset[0])) + 2 + adj_half,) * 2,
            progress=progress.sub(0.4, 1.0),
            message="de-shadowing",
            pass_block=True,
            **strips,
        ):
            out.write(np.where(np.isfinite(cube), cube, io.FLOAT_NODATA), window=win)
            if mask is not None:
                m = np.where(np.isfinite(cube[0]), (n & flagged).astype(np.uint8), 255)
                mask.write(m.astype(np.uint8)[None], window=win)
            n_corrected += int(n.sum())
    return n_corrected


def _resolved(fit) -> np.ndarray:
    """Whether each band is de-shadowed (all of them when the noise was not measured)."""
    return np.ones(fit.ratio.size, bool) if fit.resolved is None else fit.resolved


def _snr(fit) -> np.ndarray:
    """Each band's signal-to-noise ratio in full shadow (NaN unknown)."""
    if fit.shadow_noise is None:
        return np.full(fit.ratio.size, np.nan)
    with np.errstate(invalid="ignore", divide="ignore"):
        return fit.shadow_signal / fit.shadow_noise


def _mask_tags(wl, fit) -> dict:
    """The tags of the mask of shadowed pixels with bands left as measured."""
    low = ~_resolved(fit)
    return {
        "product": "1: shadowed pixel (fraction above 0) whose bands named in "
        "unresolved_wavelength are left as measured (signal in full shadow below "
        f"{MIN_SHADOW_SNR:g} × its noise); 0: every band de-shadowed or not shadowed; 255 nodata",
        "unresolved_wavelength": "{" + ", ".join(f"{w:.2f}" for w in wl[low]) + "}",
        "wavelength_units": "Nanometers",
    }


def _open_fraction(shadow, dual, stack):
    """The shadow fraction raster, checked against the image's grid and its nodata."""
    f_src = stack.enter_context(io.open_raster(shadow, "shadow fraction"))
    if (f_src.height, f_src.width) != (dual.height, dual.width):
        raise InputError(
            f"shadow fraction {shadow} has {f_src.height} × {f_src.width} pixels but the "
            f"image {dual.height} × {dual.width}: give the fraction of this image "
            "(shadow-map --fraction, or sun-shadow on its grid)"
        )
    dual.grid.require_same(
        io.Grid.of(f_src), f"image {dual.vnir.path}", f"shadow fraction {shadow}"
    )
    check_fraction_nodata(f_src, shadow)
    return f_src


def _dark_levels(vnir, dual, sources, dark: DarkLevels, strips, progress) -> np.ndarray:
    """The dark level of every band, VNIR then SWIR, as ``shadow-map`` finds them."""
    v_src, s_src = sources
    vb, sb = list(dual.vnir.bands), list(dual.swir.bands)
    v_dark_b = spread_bands(tuple(vb), DARK_BANDS)
    s_dark_b = spread_bands(tuple(sb), DARK_BANDS)
    pixels, ok = io.sample_windows(
        io.bands_reader([(v_src, b) for b in v_dark_b] + [(s_src, b) for b in s_dark_b]),
        size=DARK_SAMPLE,
        progress=progress.sub(0, 0.1),
        **strips,
    )
    if not ok.any():
        raise no_valid_error(vnir, "VNIR/SWIR image")
    nd = len(v_dark_b)
    samples = {"vnir": pixels[:nd], "swir": pixels[nd:]}
    found = dual_dark_levels(dual, sources, (vb, sb), dark, samples, ok, progress)
    return np.concatenate([found.per_band("vnir", vb), found.per_band("swir", sb)])


def _cube_reader(dual, sources, f_src, shadow, opened):
    """A block's (cube, valid, fraction, heights, sky view): the last two None without a
    surface model."""
    v_src, s_src = sources
    read_cube = io.bands_reader(
        [(v_src, b) for b in dual.vnir.bands] + [(s_src, b) for b in dual.swir.bands]
    )
    read_f = io.band_reader(f_src, 1)
    read_z = None if opened is None else io.band_reader(opened.src, 1)

    def read(r0, r1):
        x, x_ok = read_cube(r0, r1)
        f, f_ok = read_f(r0, r1)
        check_fraction(f, f_ok, shadow)
        f = np.where(f_ok, f, np.nan)
        if opened is None:
            return x, x_ok, f, None, None
        return (x, x_ok, f, *_sky_view(read_z, opened.prior, r0, r1, dual.height))

    return read


def _log_fit(fit, edges, options, warnings, progress) -> None:
    """The log of the illumination fit, and its warning."""
    additive, adjacency, surface = options
    c, eta, k = fit.additive, fit.adjacency_share, fit.ratio
    if additive:
        progress.info(
            f"additive signal (the line of {fit.one_surface} pairs of one surface in "
            f"{int(np.isfinite(fit.line_error).sum())} bands, with the dark object): "
            f"{np.min(c):.1f} to {np.max(c):.1f} DN"
        )
    if adjacency:
        progress.info(
            f"light of the surroundings: share η {np.min(eta):.2f}–{np.max(eta):.2f} "
            f"(median {np.median(eta):.2f}) over the bands"
        )
    if fit.unchanged:
        progress.info(f"{fit.unchanged} band(s) left unchanged (no ratio above 1 measured)")
    if fit.unresolved:
        progress.info(
            f"{fit.unresolved} band(s) left as measured: their signal in full shadow is below "
            f"{MIN_SHADOW_SNR:g} × its noise there"
        )
    progress.info(
        f"illumination ratio (sunlit / shadow) from {fit.pairs_used} of "
        f"{edges.shaded.shape[0]} pairs across shadow edges: {np.nanmin(k):.2f}–"
        f"{np.nanmax(k):.2f} over the bands (spread {fit.spread:.3f} in log)"
    )
    if fit.regions:
        progress.info(
            f"{fit.regions} neighbourhood(s) of {REGION_TILE} px with their own ratio (scale of "
            f"k − 1 {np.nanmin(fit.region_scale):.2f}–{np.nanmax(fit.region_scale):.2f}), the "
            "scene's elsewhere"
        )
    if fit.edge_pairs:
        warnings.append(
            "the shadows are too narrow to hold a pixel inside them: the illumination ratio is "
            "measured on their edge pixels, which mix in sunlit light (it may be too low)"
        )
    if fit.spread > POOR_SPREAD:
        warnings.append(
            f"the pairs across shadow edges agree poorly (median RMS log difference "
            f"{fit.spread:.2f}): the ratio may mix materials; check the shadow fraction"
            + (
                ""
                if surface
                else "; a surface model (--dsm and the sun) leaves out the pairs across a "
                "height step (a sunlit roof beside its own shadow on the ground)"
            )
        )


def _cube_tags(dual, shadow, surface, prior, wl, fit, levels, adjacency, along, across):
    """The de-shadowed cube's tags."""
    return {
        "product": "de-shadowed cube: L / (1 − f·(1 − 1/k)) on the signal above the dark "
        "level, k the scene's sunlit-to-shadow illumination ratio",
        "vnir": dual.vnir.path,
        "swir": dual.swir.path,
        "shadow": str(shadow),
        "surface_model": str(surface.dsm) if prior is not None else "none",
        "sky_view": "each pixel's sky-view factor V from the surface model: factor "
        "(k − 1 + V)/((k − 1)·(1 − f) + V), k the open-ground ratio"
        if prior is not None
        else "none (V = 1)",
        "wavelength": "{" + ", ".join(f"{w:.2f}" for w in wl) + "}",
        "wavelength_units": "Nanometers",
        "illumination_ratio": ",".join(f"{v:.4f}" for v in fit.ratio),
        "region_ratio": f"the scene's k − 1 scaled per {REGION_TILE} px tile by its "
        f"neighbourhood's shadow edges in {fit.regions} tile(s)"
        if fit.region_scale is not None
        else "none (one ratio for the scene)",
        "dark_level_dn": ",".join(f"{v:.2f}" for v in levels),
        "additive_signal_dn": ",".join(f"{v:.2f}" for v in fit.additive),
        "adjacency": "(1 − V)·η·k·S̄/S_ref added to V, S̄ the mean sunlit signal within "
        f"{ADJACENCY_M:g} m; η per band in the report"
        if adjacency
        else "none",
        "pairs_used": str(fit.pairs_used),
        "unresolved_wavelength": "{" + ", ".join(f"{w:.2f}" for w in wl[~_resolved(fit)]) + "}",
        "min_shadow_snr": f"{MIN_SHADOW_SNR:g}",
        "offset_along_px": f"{along:.3f}",
        "offset_across_px": f"{across:.3f}",
    }


def _report(result, wl, fit, levels) -> dict:
    """The JSON report: the result and each band's ratio, levels and additive signal."""
    fin = lambda v, ok: float(v) if ok else None  # noqa: E731
    return {
        **result,
        "bands": [
            {
                "wavelength_nm": round(float(w), 2),
                "illumination_ratio": float(kk),
                "dark_level_dn": float(lvl),
                "additive_signal_dn": float(cc),
                "additive_signal_error_dn": fin(ce, np.isfinite(ce)),
                "additive_signal_line_dn": fin(cl, np.isfinite(el)),
                "additive_signal_line_error_dn": fin(el, np.isfinite(el)),
                "dark_object_dn": fin(do, np.isfinite(do)),
                "adjacency_share": float(et),
                "shadow_signal_dn": fin(ss, np.isfinite(ss)),
                "shadow_noise_dn": fin(sn, np.isfinite(sn)),
                "resolved_in_shadow": bool(ok),
                "corrected": bool(ok and kk > 1.0),
            }
            for w, kk, lvl, cc, ce, cl, el, do, et, ss, sn, ok in zip(
                wl,
                fit.ratio,
                levels,
                fit.additive,
                fit.additive_error,
                fit.line,
                fit.line_error,
                fit.dark_object,
                fit.adjacency_share,
                _or_nan(fit.shadow_signal, wl.size),
                _or_nan(fit.shadow_noise, wl.size),
                _resolved(fit),
                strict=True,
            )
        ],
        "corrected_nm": _ranges(wl, _resolved(fit) & (fit.ratio > 1.0)),
        "left_as_measured_nm": _ranges(wl, ~(_resolved(fit) & (fit.ratio > 1.0))),
        "formula": "L_sun = L / (1 - f * (1 - 1/k)), L = DN - dark level - additive "
        "signal (both added back)",
    }


def _or_nan(x, n: int) -> np.ndarray:
    return np.full(n, np.nan) if x is None else x


def _ranges(wl, on) -> list[list[float]]:
    """The runs of consecutive bands where ``on`` as [first, last] wavelengths (nm)."""
    out, start = [], None
    for i, flag in enumerate([*on, False]):
        if flag and start is None:
            start = i
        elif not flag and start is not None:
            out.append([round(float(wl[start]), 2), round(float(wl[i - 1]), 2)])
            start = None
    return out
