"""File-level de-shadowing: a VNIR + SWIR cube and a shadow fraction in, the cube with each
shadowed pixel scaled to its sunlit signal out (:mod:`geoboresight.shadow.deshadow`).

Two passes over the flight line: the pairs of shadowed and sunlit pixels across shadow edges
give each band's illumination ratio (on the VNIR grid, the SWIR resampled by the boresight
offset); then the cube is written strip by strip, each instrument on its own grid (the
fraction shifted onto the SWIR's).
"""

from __future__ import annotations

import contextlib
import math

import numpy as np

from .. import io
from ..dem.coregister import coregister
from ..errors import InputError, ParameterError
from ..io.bands import BoresightOffset
from ..io.dark import DarkLevels, dark_level_of
from ..io.dual import DualLayout
from ..shadow import deshadow as ds
from ..shadow import illumination as ill
from ._operation import operation
from .shadow import check_fraction, check_fraction_nodata, no_valid_error
from .shadow_map import DARK_BANDS, SurfaceModel, _dark_level, _offset, _open_surface, _spread

#: Pixels sampled for the dark level estimate.
DARK_SAMPLE = 100_000
#: Pixels of a flight line whose pairs are looked for (a fixed share of a longer line, so
#: that the pairs held stay bounded: about 1 % of pixels are at a shadow edge).
PAIR_PIXELS = 250_000


def _fraction_grid(f, along, across, ok):
    """The shadow fraction (VNIR grid) moved onto the SWIR's grid."""
    g, g_ok = coregister(np.where(ok, f, 0.0), -along, -across, ok, order=1)
    return np.where(g_ok, g, np.nan)


def _levels(sensor, src, bands, sampled, given, sample, ok, progress) -> np.ndarray:
    """The dark level of each of ``bands``: per band from the product or header when it lists
    them, else the one level (given, or the dark object's, as ``shadow-map``)."""
    level = dark_level_of(sensor, bands, src.tags(ns="ENVI"), src.count, given)
    if level is not None:
        progress.info(level.describe(sensor.name))
        return np.broadcast_to(level.for_bands(bands, bands), (len(bands),)).astype(float)
    level = _dark_level(sensor, src, sampled, given, sample, ok, progress)
    return np.full(len(bands), level.level)


def _sky_view(read_z, dsm, r0, r1, height):
    """(heights, sky-view factor) of lines r0–r1: the factor from the DSM read
    :data:`~geoboresight.shadow.illumination.SKY_RADIUS_M` beyond them (its horizon search)."""
    cell = float(np.sqrt(abs(np.linalg.det(dsm.matrix))))
    halo = math.ceil(ill.SKY_RADIUS_M / cell) + 1
    q0, q1 = max(0, r0 - halo), min(height, r1 + halo)
    z, z_ok = read_z(q0, q1)
    v = ill.sky_view_factor(z, z_ok, transform=dsm.matrix, clearance=dsm.clearance)
    cut = slice(r0 - q0, r1 - q0)
    return np.where(z_ok, z, np.nan)[cut], v[cut]


@operation(
    inputs=("vnir", "swir", "shadow", "surface.dsm", "surface.igm", "surface.glt"),
    outputs=("output", "report"),
)
def deshadow_file(
    vnir,
    swir=None,
    *,
    shadow,
    output,
    report=None,
    surface=SurfaceModel(),
    layout=DualLayout(),
    dark=DarkLevels(),
    offset=BoresightOffset(),
    additive=False,
    adjacency=False,
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """De-shadowed cube: each pixel scaled by its shadow fraction and the scene's
    sunlit-to-shadow illumination ratio of each band.

    ``L_sun = L / (1 − f·(1 − 1/k_b))`` on the signal above the dark level (from
    ``L = (E_dir·(1 − f) + E_diff)·ρ``), ``k_b`` measured on pairs of fully shadowed and
    sunlit pixels across the shadow edges of the scene
    (:func:`geoboresight.shadow.deshadow.illumination_ratio`). The output is in the input's
    units (the dark level added back): pixels out of shadow keep their values.

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
        JSON: the illumination ratio and factor at full shadow of each band, the pairs used.
    surface : SurfaceModel
        A surface model on the image's grid and the sun (as ``shadow-map --dsm``; its
        ``clearance`` is the height noise the horizon search ignores): pairs are kept only
        down-sun or lateral of the shadow and between cells of about the same height (the same
        surface), the median of all of them is the ratio, and each pixel gets the sky in
        proportion to its sky-view factor
        (:func:`geoboresight.shadow.illumination.sky_view_factor`): the ratio is that of open
        ground, each pixel's own follows from its sky view. None: one ratio for every pixel.
    layout : DualLayout
    dark : DarkLevels
        Dark level of each instrument (None = the product's, the header's, else estimated as
        ``shadow-map`` does); 0 for radiance.
    offset : BoresightOffset
        Boresight offset of the SWIR (px); both None = measured.
    additive : bool
        Also estimate each band's additive signal (path radiance, and what is left of a dark
        level that differs from band to band when one level per instrument is subtracted):
        the intercept of the line of the pairs of one surface
        (:func:`geoboresight.shadow.deshadow.same_surface`,
        :func:`geoboresight.shadow.deshadow.additive_signal`; with a surface model each sunlit
        side's slope, cos i, enters it), combined band by band with the dark object (an upper
        bound, :func:`geoboresight.shadow.deshadow.combine_additive`) by their estimated
        errors; the ratio is then measured, and the signal scaled, above it (it is added
        back). Off by default: on the validation scenes it helps model 2 with a surface model
        and harms the simulator, where the pairs of one surface are not found
        (docs/deshadow.md).
    adjacency : bool
        Also light each pixel by its sunlit surroundings (ATCOR-4's terrain-reflected term,
        ``(1 − V)·ρ̄·E_global``: ρ̄·E_global the mean sunlit signal within
        :data:`~geoboresight.shadow.deshadow.ADJACENCY_M` around it), its share fitted per
        band on the pairs with the ratio (:func:`geoboresight.shadow.deshadow.adjacency_ratio`),
        so each pixel gets its own ratio. Needs the surface model (V). Off by default
        (docs/deshadow.md).
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
    """
    dual = io.as_dual(vnir, swir, layout)
    vb, sb = list(dual.vnir.bands), list(dual.swir.bands)
    wl = np.concatenate([dual.vnir.wavelengths, dual.swir.wavelengths]).astype(float)
    nv = len(vb)
    strips = {"height": dual.height, "width": dual.width, "block_rows": block_rows}
    warnings: list[str] = []
    with contextlib.ExitStack() as stack:
        v_src = stack.enter_context(io.open_raster(dual.vnir.reads, "VNIR"))
        s_src = (
            v_src if dual.merged else stack.enter_context(io.open_raster(dual.swir.reads, "SWIR"))
        )
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
        dsm = _open_surface(surface, dual, block_rows, stack, progress)
        if adjacency and dsm is None:
            raise ParameterError(
                "parameter 'adjacency': the light of the surroundings needs a surface model "
                "(--dsm and the sun): a shadow gets it from the part of its sky that the "
                "surroundings hide, 1 − its sky-view factor"
            )
        adj_half = 0
        if adjacency:
            cell = float(np.sqrt(abs(np.linalg.det(dsm.matrix))))
            adj_half = max(1, int(ds.ADJACENCY_M / (2.0 * cell)))
        toward_sun = None
        if dsm is not None:
            toward_sun = ill.sun_step(dsm.zenith, dsm.azimuth, dsm.matrix)[:2]
            read_z = io.band_reader(dsm.src, 1)
        # Dark levels, as shadow-map finds them.
        v_dark_b = _spread(tuple(vb), DARK_BANDS)
        s_dark_b = _spread(tuple(sb), DARK_BANDS)
        pixels, ok = io.sample_windows(
            io.bands_reader([(v_src, b) for b in v_dark_b] + [(s_src, b) for b in s_dark_b]),
            size=DARK_SAMPLE,
            progress=progress.sub(0, 0.1),
            **strips,
        )
        if not ok.any():
            raise no_valid_error(vnir, "VNIR/SWIR image")
        nd = len(v_dark_b)
        levels = np.concatenate(
            [
                _levels(dual.vnir, v_src, vb, v_dark_b, dark.vnir_dark, pixels[:nd], ok, progress),
                _levels(dual.swir, s_src, sb, s_dark_b, dark.swir_dark, pixels[nd:], ok, progress),
            ]
        )
        rb = dual.ratio_bands()
        along, across, how = _offset(dual, v_src, s_src, rb, offset, progress)
        progress.info(f"boresight offset {along:+.2f} px along, {across:+.2f} px across ({how})")
        read_cube = io.bands_reader([(v_src, b) for b in vb] + [(s_src, b) for b in sb])
        read_f = io.band_reader(f_src, 1)

        def read(r0, r1):
            x, x_ok = read_cube(r0, r1)
            f, f_ok = read_f(r0, r1)
            check_fraction(f, f_ok, shadow)
            f = np.where(f_ok, f, np.nan)
            if dsm is None:
                return x, x_ok, f, None, None
            return (x, x_ok, f, *_sky_view(read_z, dsm, r0, r1, dual.height))

        shift_halo = math.ceil(abs(along)) + 2
        keep_per_mille = max(1, min(1000, round(1000 * PAIR_PIXELS / (dual.height * dual.width))))
        lv = levels[:, None, None]

        # Pass 1: pairs across shadow edges, on the VNIR grid (the SWIR resampled onto it),
        # and each instrument's darkest pixels (on its own grid) for the dark object.
        n_dark = ds.DARK_PIXELS

        def darkest(sig, ok, own):
            """The n_dark darkest pixels (by their mean over the bands) of the strip's lines."""
            use = ok & own & np.isfinite(sig).all(axis=0)
            x = sig[:, use].T
            if x.shape[0] > n_dark:
                x = x[np.argpartition(x.mean(axis=1), n_dark - 1)[:n_dark]]
            return x.astype(np.float32)

        def pairs(x, x_ok, f, z, v, block):
            sig = x.astype(np.float64) - lv
            own = np.zeros(f.shape, bool)
            own[block.inner] = True
            dark_v, dark_s = darkest(sig[:nv], x_ok, own), darkest(sig[nv:], x_ok, own)
            for i in range(nv, sig.shape[0]):
                sig[i], _ = coregister(sig[i], along, across, x_ok, order=1)
            # Shadowed pixels of the strip's own lines, a fixed share of them on a long line
            # (chosen by their position, so strips give the pairs of the whole image).
            rr, cc = np.mgrid[block.row0 : block.row0 + f.shape[0], 0 : f.shape[1]]
            picked = (rr * 73856093 ^ cc * 19349663) % 1000 < keep_per_mille
            shaded_ok = own & picked
            ia, ib = ds.pair_indices(
                f,
                x_ok & np.isfinite(sig).all(axis=0),
                own=shaded_ok,
                toward_sun=toward_sun,
                heights=z,
            )
            flat = sig.reshape(sig.shape[0], -1)
            sky = np.ones(f.size) if v is None else v.reshape(-1)
            if z is None:
                cos_i = np.ones(f.size)
            else:
                cos_i = ill.plane_incidence(
                    z,
                    np.isfinite(z),
                    sun_zenith=dsm.zenith,
                    sun_azimuth=dsm.azimuth,
                    transform=dsm.matrix,
                ).reshape(-1)
            if adjacency:
                with np.errstate(invalid="ignore"):
                    lit_px = x_ok & (f <= ds.LIT)
                sur = ds.surround_signal(sig, lit_px, 2 * adj_half + 1).reshape(sig.shape[0], -1)
                sur_a, sur_b = sur[:, ia].T, sur[:, ib].T
            else:
                sur_a = sur_b = np.zeros((ia.size, 0))
            return (
                flat[:, ia].T.astype(np.float32),
                flat[:, ib].T.astype(np.float32),
                np.stack([sky[ia], sky[ib], cos_i[ib]]).astype(np.float32),
                dark_v,
                dark_s,
                sur_a.astype(np.float32),
                sur_b.astype(np.float32),
            )

        def merge(u, w):
            a_, b_, p_ = (
                np.concatenate([p, q], axis=-1 if i == 2 else 0)  # sky views: (3, n)
                for i, (p, q) in enumerate(zip(u[:3], w[:3], strict=True))
            )
            dv_, ds_, sa_, sb_ = (np.concatenate([p, q]) for p, q in zip(u[3:], w[3:], strict=True))
            if dv_.shape[0] > n_dark:
                dv_ = dv_[np.argsort(dv_.mean(axis=1), kind="stable")[:n_dark]]
            if ds_.shape[0] > n_dark:
                ds_ = ds_[np.argsort(ds_.mean(axis=1), kind="stable")[:n_dark]]
            return a_, b_, p_, dv_, ds_, sa_, sb_

        n_sur = len(wl) if adjacency else 0
        a, b, pv, dark_v, dark_s, sur_a, sur_b = io.reduce_windows(
            read,
            pairs,
            merge,
            (
                np.zeros((0, len(wl)), np.float32),
                np.zeros((0, len(wl)), np.float32),
                np.zeros((3, 0), np.float32),
                np.zeros((0, nv), np.float32),
                np.zeros((0, len(wl) - nv), np.float32),
                np.zeros((0, n_sur), np.float32),
                np.zeros((0, n_sur), np.float32),
            ),
            halo=(max(ds.DISTANCES) + 1 + shift_halo + adj_half,) * 2,
            pass_block=True,
            progress=progress.sub(0.1, 0.4),
            message="shadow edges",
            **strips,
        )
        sky = None if dsm is None else (pv[0], pv[1])
        direct = None if dsm is None else pv[2]
        keep = ds.KEEP if dsm is None else ds.KEEP_WITH_SURFACE
        k, n_pairs, spread = ds.illumination_ratio(a, b, sky_view=sky, keep=keep)
        c = np.zeros(len(wl))
        c_err = np.full(len(wl), np.inf)
        c_line, e_line, dark_obj = c, c_err, np.full(len(wl), np.nan)
        if additive:
            # Pairs of one surface (a smooth ratio spectrum) give the additive signal (their
            # line's intercept, with the direct light on the sunlit side's slope); the dark
            # object bounds it and measures it where the line cannot (combine_additive); the
            # ratio is then that of all the pairs' signal above it.
            one = ds.same_surface(a, b, wl)
            sky1 = None if sky is None else (sky[0][one], sky[1][one])
            c_line, e_line = ds.additive_signal(
                a[one], b[one], k, sky_view=sky1, direct=None if direct is None else direct[one]
            )
            dark_obj = np.concatenate(
                [
                    ds.dark_object(dark_v.T.astype(np.float64), min(n_dark, len(dark_v))),
                    ds.dark_object(dark_s.T.astype(np.float64), min(n_dark, len(dark_s))),
                ]
            )
            c, c_err = ds.combine_additive(c_line, e_line, dark_obj, np.median(a, axis=0))
            k, n_pairs, spread = ds.illumination_ratio(
                a - c, b - c, sky_view=sky, direct=direct, keep=keep
            )
            progress.info(
                f"additive signal (the line of {int(one.sum())} pairs of one surface in "
                f"{int(np.isfinite(e_line).sum())} bands, with the dark object): "
                f"{np.min(c):.1f} to {np.max(c):.1f} DN"
            )
        adj_scale = np.zeros(len(wl))
        eta = np.zeros(len(wl))
        if adjacency:
            # The light of the sunlit surroundings (1 − V)·ρ̄·E_global, its share per band
            # fitted on the pairs with the ratio (above the additive signal).
            k, adj_scale, eta = ds.adjacency_ratio(
                a - c,
                b - c,
                (sur_a - c, sur_b - c),
                sky_view=sky,
                direct=direct if additive else None,
            )
            progress.info(
                f"light of the surroundings: share η {np.min(eta):.2f}–{np.max(eta):.2f} "
                f"(median {np.median(eta):.2f}) over the bands"
            )

        # A band whose pairs do not say the sun brightens it (noise, absorption bands) is
        # left as it is: ratio 1.
        unchanged = int((~(np.isfinite(k) & (k >= 1.0))).sum())
        k = np.where(np.isfinite(k) & (k >= 1.0), k, 1.0)
        if unchanged:
            progress.info(f"{unchanged} band(s) left unchanged (no ratio above 1 measured)")
        progress.info(
            f"illumination ratio (sunlit / shadow) from {n_pairs} of {a.shape[0]} pairs "
            f"across shadow edges: {np.nanmin(k):.2f}–{np.nanmax(k):.2f} over the bands "
            f"(spread {spread:.3f} in log)"
        )
        if spread > 0.2:
            warnings.append(
                f"the pairs across shadow edges agree poorly (median RMS log difference "
                f"{spread:.2f}): the ratio may mix materials; check the shadow fraction"
            )

        # Pass 2: the de-shadowed cube, each instrument on its own grid.
        base = lv + c[:, None, None]

        def surroundings(sig, frac, ok, vv, scale):
            """Each pixel's light from its sunlit surroundings, scale·(1 − V)·S̄."""
            if not adjacency:
                return None
            with np.errstate(invalid="ignore"):
                lit_px = ok & (frac <= ds.LIT)
            s_bar = ds.surround_signal(sig, lit_px, 2 * adj_half + 1)
            return scale[:, None, None] * (1.0 - vv)[None] * s_bar

        def kernel(x, x_ok, f, z, v):
            f_ok = np.isfinite(f)
            fs = _fraction_grid(f, along, across, f_ok)
            vs = None if v is None else _fraction_grid(v, along, across, np.isfinite(v))
            bv, bs = base[:nv], base[nv:]
            sv, ss = x[:nv] - bv, x[nv:] - bs
            av = surroundings(sv, f, x_ok, v, adj_scale[:nv])
            as_ = surroundings(ss, fs, x_ok, vs, adj_scale[nv:])
            out_v = ds.deshadow(sv, f, x_ok, ratio=k[:nv], sky_view=v, adjacency=av) + bv
            out_s = ds.deshadow(ss, fs, x_ok, ratio=k[nv:], sky_view=vs, adjacency=as_) + bs
            with np.errstate(invalid="ignore"):
                shaded = x_ok & (f > 0)
            return np.concatenate([out_v, out_s]), shaded

        names = [f"{'VNIR' if i < nv else 'SWIR'} {w:.1f} nm" for i, w in enumerate(wl)]
        tags = {
            "product": "de-shadowed cube: L / (1 − f·(1 − 1/k)) on the signal above the dark "
            "level, k the scene's sunlit-to-shadow illumination ratio",
            "vnir": dual.vnir.path,
            "swir": dual.swir.path,
            "shadow": str(shadow),
            "surface_model": str(surface.dsm) if dsm is not None else "none",
            "sky_view": "each pixel's sky-view factor V from the surface model: factor "
            "(k − 1 + V)/((k − 1)·(1 − f) + V), k the open-ground ratio"
            if dsm is not None
            else "none (V = 1)",
            "wavelength": "{" + ", ".join(f"{w:.2f}" for w in wl) + "}",
            "wavelength_units": "Nanometers",
            "illumination_ratio": ",".join(f"{v:.4f}" for v in k),
            "dark_level_dn": ",".join(f"{v:.2f}" for v in levels),
            "additive_signal_dn": ",".join(f"{v:.2f}" for v in c),
            "adjacency": "(1 − V)·η·k·S̄/S_ref added to V, S̄ the mean sunlit signal within "
            f"{ds.ADJACENCY_M:g} m; η per band in the report"
            if adjacency
            else "none",
            "pairs_used": str(n_pairs),
            "offset_along_px": f"{along:.3f}",
            "offset_across_px": f"{across:.3f}",
        }
        band_tags = [
            {
                "wavelength": f"{w:.2f}",
                "wavelength_units": "Nanometers",
                "illumination_ratio": f"{kk:.4f}",
            }
            for w, kk in zip(wl, k, strict=True)
        ]
        n_corrected = 0
        with io.create_raster(
            output, dual.grid, count=len(wl), tags=tags, band_names=names, band_tags=band_tags
        ) as dst:
            for win, (cube, n) in io.map_windows(
                read,
                kernel,
                halo=(shift_halo + adj_half,) * 2,
                progress=progress.sub(0.4, 1.0),
                message="de-shadowing",
                **strips,
            ):
                dst.write(np.where(np.isfinite(cube), cube, io.FLOAT_NODATA), window=win)
                n_corrected += int(n.sum())
    result = {
        "output": output,
        "pairs": int(a.shape[0]),
        "pairs_used": n_pairs,
        "pair_spread": round(spread, 4),
        "ratio_min": round(float(np.nanmin(k)), 4),
        "ratio_max": round(float(np.nanmax(k)), 4),
        "shadowed_pixels": n_corrected,
        "bands_unchanged": unchanged,
        "offset_along_px": round(along, 3),
        "offset_across_px": round(across, 3),
        "warnings": warnings,
    }
    if report:
        io.write_json(
            report,
            {
                **result,
                "bands": [
                    {
                        "wavelength_nm": round(float(w), 2),
                        "illumination_ratio": float(kk),
                        "dark_level_dn": float(lvl),
                        "additive_signal_dn": float(cc),
                        "additive_signal_error_dn": float(ce) if np.isfinite(ce) else None,
                        "additive_signal_line_dn": float(cl) if np.isfinite(el) else None,
                        "additive_signal_line_error_dn": float(el) if np.isfinite(el) else None,
                        "dark_object_dn": float(do) if np.isfinite(do) else None,
                        "adjacency_share": float(et),
                    }
                    for w, kk, lvl, cc, ce, cl, el, do, et in zip(
                        wl, k, levels, c, c_err, c_line, e_line, dark_obj, eta, strict=True
                    )
                ],
                "formula": "L_sun = L / (1 - f * (1 - 1/k)), L = DN - dark level - additive "
                "signal (both added back)",
            },
        )
        result["report"] = report
    for w in warnings:
        progress.info(f"warning: {w}")
    return result
