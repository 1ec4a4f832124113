"""File-level disparity map, relative DEM and 3-D view (paper §3.2, Figure 9)."""

from __future__ import annotations

import contextlib
import dataclasses
from dataclasses import replace

import numpy as np

from .. import io
from ..dem.disparity import Matching, disparity_halo, disparity_map
from ..dem.height import FlightGeometry
from ..dem.kriging import LocalKriging
from ..dem.relative import (
    Kriging,
    fit_points,
    line_statistics,
    match_halo,
    match_strip,
    strip_rows,
    validate_kriging,
)
from ..dem.view3d import (
    AZIMUTH,
    BLUE_NM,
    ELEVATION,
    EXAGGERATION,
    GREEN_NM,
    MAX_FACETS,
    RED_NM,
    drape_figure,
    stretch_rgb,
)
from ..errors import InputError
from ..io.bands import DENSE_MATCH, open_matching_pair
from ..io.dual import TOLERANCE_NM, DualLayout
from ..io.grid import require_on_grid
from ._offset import line_offset

#: Worker threads matching strips of a flight line (the filters and warps release the GIL).
MATCH_WORKERS = 2

#: The bands of a disparity raster.
DISPARITY_BANDS = [
    "disparity along-track (px)",
    "disparity across-track (px)",
    "correlation peak",
    "peak sharpness",
    "reliable (1/0)",
]


def _disparity_stack(d, valid) -> np.ndarray:
    """The five float32 bands of a disparity raster, nodata outside the matched pixels."""
    keep = np.isfinite(d.along) & valid
    return np.stack(
        [np.where(keep, b, io.FLOAT_NODATA) for b in (d.along, d.across, d.peak, d.sharpness)]
        + [np.where(valid, d.reliable.astype("float32"), io.FLOAT_NODATA)]
    ).astype("float32")


#: Free memory (bytes) glibc's arenas may hold between strips before it is given back.
#: Given back after every strip, it was page-faulted in again by the next strip's
#: temporaries: 2.9 s of system time on a 20,000-line line against 1.7 s with this bound,
#: and the peak stays flat with the line's length (0.37 GB on 5,000 and 20,000 lines).
RETAIN_FREE = 128 << 20


def release_memory(retain: int = RETAIN_FREE) -> None:
    """Give the memory freed by strips back to the system (glibc's ``malloc_trim``; nothing
    elsewhere) once glibc's arenas hold more than ``retain`` bytes of it (``mallinfo2``;
    every time where glibc is older than 2.33). Worker threads allocate and free dozens of
    strip-sized temporaries; glibc keeps them in per-thread arenas, which otherwise grow with
    the line (measured: 0.30 GB peak on 5,000 lines, 0.81 GB on 80,000)."""
    global _LIBC
    if _LIBC is None:
        _LIBC = _glibc()
    if not _LIBC:
        return
    trim, free_bytes = _LIBC
    if free_bytes is None or free_bytes() > retain:
        trim(0)


def _glibc():
    """``(malloc_trim, free bytes in the arenas or None)`` of glibc; False without glibc."""
    import ctypes
    import ctypes.util

    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        trim = libc.malloc_trim
    except (OSError, AttributeError):
        return False
    try:
        info = libc.mallinfo2
    except AttributeError:  # glibc < 2.33
        return trim, None

    class MallInfo2(ctypes.Structure):
        _fields_ = [
            (name, ctypes.c_size_t)
            for name in ("arena", "ordblks", "smblks", "hblks", "hblkhd", "usmblks", "fsmblks")
            + ("uordblks", "fordblks", "keepcost")
        ]

    info.restype = MallInfo2
    return trim, lambda: info().fordblks


_LIBC = None


def _raster_or_none(path, grid, **options):
    """:func:`~geoboresight.io.create_raster` for an optional output (None: nothing)."""
    return io.create_raster(path, grid, **options) if path else contextlib.nullcontext()


def _own_lines(d, valid, inner: slice):
    """A strip's own lines of a disparity computed on the strip and its halo."""
    return (
        replace(
            d,
            along=d.along[inner],
            across=d.across[inner],
            peak=d.peak[inner],
            sharpness=d.sharpness[inner],
            reliable=d.reliable[inner],
        ),
        valid[inner],
    )


def disparity_file(
    vnir,
    swir=None,
    cloud_mask=None,
    *,
    output,
    layout=DualLayout(),
    match=DENSE_MATCH,
    matching=Matching(),
    progress=None,
) -> dict:
    """Dense sub-pixel VNIR/SWIR disparity of a flight line, with per-pixel reliability.

    Normalised cross-correlation in a window, searching ± ``search_along`` lines and
    ± ``search_across`` columns around the global boresight offset, refined to sub-pixel.

    Parameters
    ----------
    vnir : path
        VNIR file (ENVI or GeoTIFF), or a merged VNIR+SWIR cube when ``swir`` is None.
    swir : path, optional
        SWIR file on the same pixel grid.
    cloud_mask : path, optional
        Cloud mask on the same grid (non-zero = cloud): masked in the matching.
    output : path
        5-band float32 GeoTIFF: disparity along-track and across-track (px, SWIR minus VNIR
        position), correlation peak, peak sharpness and reliable (1/0); nodata -9999.
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    match : MatchBands
        The matching images: by default the means of the bands 900–970 nm and 980–1,100 nm
        (:data:`~geoboresight.io.bands.DENSE_MATCH`).
    matching : Matching
        The matching window, the search range (± px) around the global offset, the
        reliability thresholds on the correlation peak and its curvature, and the sub-pixel
        refinement passes.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the number of reliable pixels and the global offset (px).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2, image matching
    within ± 3 pixels along-track and ± 1 across-track).

    Examples
    --------
    >>> import geoboresight as gb
    >>> result = gb.disparity_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                            output="out/disparity.tif")
    >>> result["reliable_pixels"], result["offset_along_px"]
    (49531, 0.87)
    """
    dual = io.as_dual(vnir, swir, layout)
    with open_matching_pair(dual, match, cloud_mask) as pair:
        off, _ = line_offset(pair, progress=progress.sub(0.0, 0.1))
        progress.info(f"search centred on the global offset {off.along:+.3f}, {off.across:+.3f} px")
        tags = {
            "product": "VNIR/SWIR disparity (SWIR minus VNIR position, px)",
            **pair.info(),
            "window_px": matching.window,
            "search_along_px": matching.search_along,
            "search_across_px": matching.search_across,
            "min_peak": matching.min_peak,
            "min_sharpness": matching.min_sharpness,
            "offset_along_px": f"{off.along:.4f}",
            "offset_across_px": f"{off.across:.4f}",
        }
        halo = disparity_halo(
            matching.window,
            search_along=matching.search_along,
            refine=matching.refine,
            center_along=off.along,
        )

        def match_block(v, s, ok, *, block):
            ok = ok & np.isfinite(v) & np.isfinite(s)
            d = disparity_map(
                v,
                s,
                ok,
                **dataclasses.asdict(matching),
                center=(off.along, off.across),
                block_rows=v.shape[0],  # one block: the strip's halo is the block's
                open_ends=(block.row0 > 0, block.row0 + v.shape[0] < block.height),
            )
            return _own_lines(d, ok, block.inner)

        n_rel = n_ok = 0
        with io.create_raster(
            output, dual.grid, count=len(DISPARITY_BANDS), tags=tags, band_names=DISPARITY_BANDS
        ) as dst:
            for win, (d, ok) in io.map_windows(
                pair.read,
                match_block,
                height=pair.height,
                width=pair.width,
                block_rows=strip_rows(1),
                halo=(halo, halo),
                pass_block=True,
                workers=MATCH_WORKERS,
                progress=progress.sub(0.1, 0.95),
                message="matching VNIR and SWIR",
            ):
                dst.write(_disparity_stack(d, ok), window=win)
                n_rel += int(d.reliable.sum())
                n_ok += int(ok.sum())
    progress.info(f"{n_rel} reliable pixels of {n_ok} valid")
    if n_rel == 0:
        raise InputError(
            f"no reliable matches with a {matching.window} px matching.window: use a larger matching.window "
            "(--matching.window 21) or lower --min-peak"
        )
    return {
        "output": output,
        "reliable_pixels": n_rel,
        "offset_along_px": round(off.along, 4),
        "offset_across_px": round(off.across, 4),
    }


def relative_dem_file(
    vnir,
    swir=None,
    cloud_mask=None,
    *,
    output,
    variance=None,
    disparity=None,
    report=None,
    layout=DualLayout(),
    match=DENSE_MATCH,
    geometry=FlightGeometry(),
    matching=Matching(),
    kriging=Kriging(),
    force=False,
    progress=None,
) -> dict:
    """The relative DEM of a flight line from the VNIR/SWIR parallax, kriged onto its grid.

    The two images are matched pixel by pixel (:func:`disparity_file`); the disparity divided by
    the height-to-disparity factor ``k = tan θ / GSD`` is a height, the lowest reliable region
    being 0 m. Reliable heights are thinned to control points and interpolated by ordinary
    kriging. The height precision ``σ_h = σ_d / k`` is reported, and the run stops when the
    relief does not stand out of it (unless ``force``).

    Parameters
    ----------
    vnir : path
        VNIR file (ENVI or GeoTIFF), or a merged VNIR+SWIR cube when ``swir`` is None.
    swir : path, optional
        SWIR file on the same pixel grid.
    cloud_mask : path, optional
        Cloud mask on the same grid (non-zero = cloud): masked in the matching and the DEM.
    output : path
        The DEM: float32 GeoTIFF in metres, nodata -9999, on the input's grid, with tags giving
        σ_d, σ_h, the factor, the offset and the variogram.
    variance, disparity : path, optional
        The kriging variance (m²); the disparity and reliability bands (as
        :func:`disparity_file`).
    report : path, optional
        JSON report: σ_d, σ_h, offset, variogram, cross-validation of the kriging.
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    match : MatchBands
        The matching images (see :func:`disparity_file`).
    geometry : FlightGeometry
        ``k`` in px per metre of height, or the squint (degrees), flying height (m) and IFOV
        (mrad) that give it; the parallax's axis and direction. With flying height and IFOV
        the ground sample distance is recorded.
    matching : Matching
        The matching (see :func:`disparity_file`).
    kriging : Kriging
        One control point per ``point_spacing`` pixels (median), the variogram model, and
        the control points in each local kriging neighbourhood.
    force : bool
        Write the DEM even where σ_h exceeds the relief (tagged as not meaningful).
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, σ_d, σ_h, the relief (standard deviation of the heights above the
        noise) and relief/σ_h, the χ² test of "relief ≤ noise" (statistic, degrees of freedom,
        p-value), whether the DEM is meaningful (p < 0.05), the
        factor, offset, variogram, cross-validation, the DEM's range and the bands matched.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2, the relative DEM
    by kriging; Figure 9).

    Examples
    --------
    >>> geometry = gb.FlightGeometry(squint_deg=3, flying_height=1500, ifov_mrad=1)  # the sample's
    >>> gb.relative_dem_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                      output="out/dem.tif", geometry=geometry)["sigma_h_m"]
    2.431
    """
    factor = geometry.factor()
    gsd = geometry.gsd
    dual = io.as_dual(vnir, swir, layout)
    progress.info(
        f"height-to-disparity factor {factor.magnitude:.5f} px/m ({geometry.parallax_axis}-track)"
    )
    rows = strip_rows(kriging.point_spacing)
    with open_matching_pair(dual, match, cloud_mask) as pair:
        info = pair.info()
        off, _ = line_offset(pair, progress=progress.sub(0.0, 0.1))
        progress.info(
            f"boresight offset: {off.along:+.3f} px along-track, {off.across:+.3f} px "
            "across-track (search centre)"
        )
        disparity_tags: dict = {}  # written when the raster closes, once the line is known
        with _raster_or_none(
            disparity,
            dual.grid,
            count=len(DISPARITY_BANDS),
            tags=disparity_tags,
            band_names=DISPARITY_BANDS,
        ) as ddst:
            line, valid_strips = _match_line(
                pair,
                off,
                factor,
                {**dataclasses.asdict(matching), "point_spacing": kriging.point_spacing},
                rows,
                ddst,
                progress.sub(0.1, 0.75),
            )
            p = line.precision
            progress.info(p.message())
            if not p.meaningful and not force:
                raise InputError(p.message())
            x, y, z = line.points
            vg = fit_points(x, y, z, kriging.variogram, progress, p.sigma_h_m)
            tags = _dem_tags(info, p, factor, geometry, off, matching, kriging, x.size, vg, gsd)
            disparity_tags.update(tags, product="VNIR/SWIR disparity (px) and reliability")
    kriging = LocalKriging(x, y, z, vg, kriging.n_closest_points)
    dem_range = _write_kriged(
        kriging, valid_strips, rows, dual.grid, output, variance, tags, progress.sub(0.75, 0.95)
    )
    cv = validate_kriging(x, y, z, vg, kriging.n_closest_points, progress, kriging)
    result = {
        "output": output,
        "sigma_d_px": round(p.sigma_d_px, 4),
        "sigma_h_m": round(p.sigma_h_m, 3),
        "relief_std_m": round(p.relief_m, 3),
        "relief_noise_m": round(p.noise_m, 3),
        "relief_to_noise": round(p.snr, 3),
        "relief_block_px": [p.block * p.window[0], p.block * p.window[1]],
        "relief_chi2": round(p.statistic, 3),
        "relief_dof": p.dof,
        "relief_p_value": p.p_value,
        "meaningful": bool(p.meaningful),
        "message": p.message(),
        "height_factor_px_per_m": factor.magnitude,
        "offset_along_px": round(off.along, 4),
        "offset_across_px": round(off.across, 4),
        "reliable_pixels": int(line.reliable),
        "control_points": int(x.size),
        "variogram": {"model": vg.model, "parameters": list(vg.parameters)},
        "cross_validation": cv,
        "dem_range_m": dem_range,
        **info,
    }
    if report:
        io.write_json(report, result)
    progress.update(1.0, "relative DEM written")
    return result


def _dem_tags(info, p, factor, geometry, off, matching, kriging, n_points, vg, gsd) -> dict:
    """The relative DEM's tags: the line's precision and relief test, the geometry, the
    matching and the kriging."""
    tags = {
        "product": "relative DEM (Brook & Ben-Dor 2011, 3.2): 0 m = lowest reliable region",
        **info,
        "sigma_d_px": f"{p.sigma_d_px:.4f}",
        "sigma_h_m": f"{p.sigma_h_m:.4f}",
        "relief_std_m": f"{p.relief_m:.3f}",
        "relief_noise_m": f"{p.noise_m:.3f}",
        "relief_to_noise": f"{p.snr:.3f}",
        "relief_test": p.test(),
        "meaningful": "yes" if p.meaningful else "NO: the relief does not stand out of sigma_h",
        "height_factor_px_per_m": f"{factor.magnitude:.6f}",
        "parallax_axis": geometry.parallax_axis,
        "offset_along_px": f"{off.along:.4f}",
        "offset_across_px": f"{off.across:.4f}",
        "window_px": matching.window,
        "search_along_px": matching.search_along,
        "search_across_px": matching.search_across,
        "min_peak": matching.min_peak,
        "point_spacing_px": kriging.point_spacing,
        "control_points": n_points,
        "variogram": f"{vg.model}: {vg.describe()}",
        "n_closest_points": kriging.n_closest_points,
        "units": "metres",
    }
    if gsd is not None:
        tags["gsd_m"] = f"{gsd:.4f}"
    return tags


def _match_line(pair, offset, factor, options: dict, rows: int, dst, progress):
    """Match a flight line strip by strip (:func:`~geoboresight.dem.relative.match_strip`
    through :func:`~geoboresight.io.map_windows`, each strip with its halo), writing the
    disparity to ``dst`` (optional), and merge the strips
    (:func:`~geoboresight.dem.relative.line_statistics`). Returns the line's statistics and
    each strip's valid pixels, bit-packed (the DEM covers them)."""
    height, width = pair.height, pair.width
    halo = match_halo(
        options["window"],
        search_along=options["search_along"],
        refine=options["refine"],
        center_along=offset.along,
    )

    def match(v, s, ok, *, block):
        return match_strip(
            v,
            s,
            ok,
            factor=factor,
            center=(offset.along, offset.across),
            rows=block.inner,
            first_line=block.row0,
            line_shape=(height, width),
            **options,
        )

    strips, valid = [], []
    for win, part in io.map_windows(
        pair.read,
        match,
        height=height,
        width=width,
        block_rows=rows,
        halo=(halo, halo),
        pass_block=True,
        workers=MATCH_WORKERS,
        progress=progress,
        message="matching VNIR and SWIR",
    ):
        if dst is not None:
            dst.write(_disparity_stack(part.disparity, part.valid), window=win)
        valid.append(np.packbits(part.valid))
        # Keep the small parts only, copied here: left in the worker thread's memory arena
        # they would pin pages of it that the strip's temporaries freed.
        strips.append(
            replace(
                part,
                disparity=None,
                valid=None,
                points=tuple(np.array(a) for a in part.points),
                heights=part.heights.copy(),
                seconds=part.seconds.copy(),
            )
        )
        del part
        release_memory()
    line = line_statistics(
        strips,
        factor=factor,
        window=options["window"],
        min_peak=options["min_peak"],
        progress=progress,
    )
    return line, valid


def _write_kriged(kriging, valid_strips, rows, grid, output, variance, tags, progress):
    """Krige the DEM and its variance strip by strip onto the valid pixels and write them;
    returns the DEM's [min, max] (m)."""
    height, width = grid.shape

    def read(row0: int, row1: int):
        bits = valid_strips[row0 // rows]
        return np.unpackbits(bits, count=(row1 - row0) * width).reshape(-1, width).astype(bool)

    def krige(ok, *, block):
        return kriging.grid_rows(*block.rows, width, ok)

    lo, hi = np.inf, -np.inf
    with (
        io.create_raster(output, grid, tags=tags, band_names=["relative height (m)"]) as dst,
        _raster_or_none(
            variance,
            grid,
            tags={**tags, "product": "kriging variance of the relative DEM (m²)"},
            band_names=["kriging variance (m²)"],
        ) as vdst,
    ):
        for win, (dem, var) in io.map_windows(
            read,
            krige,
            height=height,
            width=width,
            block_rows=rows,
            pass_block=True,
            # Each strip's systems are solved by LAPACK without Python's lock: two strips
            # at once (the node rows two strips share are cached under a lock).
            workers=io.windows.default_workers(),
            progress=progress,
            message="kriging",
        ):
            dem = dem.astype("float32")
            ok = np.isfinite(dem)
            if ok.any():
                lo, hi = min(lo, float(dem[ok].min())), max(hi, float(dem[ok].max()))
            dst.write(np.where(ok, dem, io.FLOAT_NODATA)[None], window=win)
            if vdst is not None:
                var = var.astype("float32")
                vdst.write(np.where(np.isfinite(var), var, io.FLOAT_NODATA)[None], window=win)
    return [float(lo), float(hi)] if lo <= hi else [float("nan"), float("nan")]


def view_3d_file(
    dem,
    vnir,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    red_nm=RED_NM,
    green_nm=GREEN_NM,
    blue_nm=BLUE_NM,
    tolerance_nm=TOLERANCE_NM,
    exaggeration=EXAGGERATION,
    elevation=ELEVATION,
    azimuth=AZIMUTH,
    progress=None,
) -> dict:
    """A PNG of an RGB of the image draped on the relative DEM (Figure 9E).

    Three VNIR bands with a 2–98 % stretch, drawn on the DEM with vertical exaggeration; pixels
    without a height are black. Axes are in metres when the DEM is georeferenced or records its
    pixel size (tag ``GSD_M``), in pixels otherwise.

    Parameters
    ----------
    dem : path
        The relative DEM (:func:`relative_dem_file`), on the image's grid.
    vnir : path
        VNIR file (ENVI or GeoTIFF), or a merged VNIR+SWIR cube when ``swir`` is None.
    swir : path, optional
        SWIR file on the same pixel grid.
    output : path
        The PNG.
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    red_nm, green_nm, blue_nm : float
        The VNIR bands of the RGB, nearest these wavelengths.
    tolerance_nm : float
        Largest distance between a requested wavelength and a band centre.
    exaggeration : float
        Vertical exaggeration.
    elevation, azimuth : float
        Viewing angles (degrees).
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2, Figure 9E).
    """
    from ..figures import decimated_shape
    from ..io.write import save_figure

    dual = io.as_dual(vnir, swir, layout)
    # The view draws at most MAX_FACETS facets per side: the DEM and the RGB are read at that
    # step (decimated reads), not whole, so a flight line of any length costs the same.
    _, shape = decimated_shape(*dual.grid.shape, MAX_FACETS)
    with io.open_raster(dem, "DEM") as src:
        require_on_grid(src, dual.grid, f"DEM {dem}")
        height, ok = io.read_masked(src, 1, out_shape=shape)
        georef = io.is_georeferenced(src)
        res = (abs(src.transform.e), abs(src.transform.a)) if georef else None
        gsd_tag = src.tags().get("GSD_M")
    bands = [dual.vnir.band_for(nm, tolerance_nm) for nm in (red_nm, green_nm, blue_nm)]
    with io.open_raster(dual.vnir.reads, "image") as src:
        rgb, rgb_ok = zip(*(io.read_masked(src, b, out_shape=shape) for b in bands), strict=True)
    progress.update(0.3, "read")
    if res is not None:
        size, unit = res, "m"
    elif gsd_tag:
        size, unit = (float(gsd_tag), float(gsd_tag)), "m"
    else:
        size, unit = (1.0, 1.0), "px"
    # A decimated pixel covers height/rows × width/cols pixels of the grid.
    size = (size[0] * dual.grid.height / shape[0], size[1] * dual.grid.width / shape[1])
    fig = drape_figure(
        np.where(ok, height, np.nan),
        stretch_rgb(*np.where(rgb_ok, rgb, np.nan)),
        exaggeration=exaggeration,
        pixel_size=size,
        unit=unit,
        elevation=elevation,
        azimuth=azimuth,
    )
    save_figure(fig, output)
    progress.update(1.0, "3-D view written")
    return {"output": output}
