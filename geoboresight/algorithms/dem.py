"""Specs: boresight offset, co-registration, disparity, relative DEM and 3-D view (paper §3.2).

Thin wiring of files to the kernels in :mod:`geoboresight.dem`.
"""

from __future__ import annotations

import json
import math

import numpy as np

from .. import io
from ..dem.coregister import coregister, profile_to_lines
from ..dem.disparity import disparity_map
from ..dem.height import HeightFactor, height_factor
from ..dem.kriging import MODELS
from ..dem.offset import estimate_offset, offset_angles, offset_profile
from ..dem.relative import relative_dem
from ..errors import InputError, ParameterError
from ._common import DUAL_PARAMS, TOLERANCE, open_dual_from
from .spec import (
    Algorithm,
    Enum,
    FileOut,
    Flag,
    Number,
    RasterIn,
    RasterOut,
    Wavelength,
)

GROUP = "Relative DEM"


def band_params(vnir_nm=920.0, swir_nm=1010.0, vnir_to_nm=None, swir_to_nm=None) -> tuple:
    """The bands matched between VNIR and SWIR: one band each, or band ranges averaged."""
    return (
        Wavelength(
            name="vnir_nm",
            description="VNIR band to match, nearest this wavelength (nm; the ratio's 920 nm)",
            default=vnir_nm,
        ),
        Wavelength(
            name="swir_nm",
            description="SWIR band to match, nearest this wavelength (nm; the ratio's 1010 nm)",
            default=swir_nm,
        ),
        Wavelength(
            name="vnir_to_nm",
            description=(
                "Average the VNIR bands from 'vnir_nm' up to this wavelength (nm) into the "
                "matching image (more signal, e.g. 900 to 970 nm); empty or equal to "
                "'vnir_nm' = one band"
            ),
            default=vnir_to_nm,
            optional=True,
            advanced=True,
        ),
        Wavelength(
            name="swir_to_nm",
            description=(
                "Average the SWIR bands from 'swir_nm' up to this wavelength (nm) into the "
                "matching image (the 1,010 nm band is weak; e.g. 980 to 1,100 nm); empty or "
                "equal to 'swir_nm' = one band"
            ),
            default=swir_to_nm,
            optional=True,
            advanced=True,
        ),
        TOLERANCE,
    )


#: Offset and co-registration: the ratio's own two bands (Eq. 3), as the issue asks.
BAND_PARAMS = band_params()
#: Dense matching: band means (900–970 nm against 980–1,100 nm). The single 1,010 nm band has
#: about 4 % of the SWIR response and is noisy; averaging gave r 0.93 / RMSE 2.4–2.6 m on the
#: textured dunes scene where single bands gave r 0.83 / RMSE 7.0 m (docs/dem.md).
MATCH_BAND_PARAMS = band_params(900.0, 980.0, 970.0, 1100.0)

CLOUD = RasterIn(
    name="cloud_mask",
    description="Cloud mask on the same grid (non-zero = cloud): masked in matching and in the DEM",
    optional=True,
)

GEOMETRY = (
    Number(
        name="flying_height",
        description="Flying height above the ground (m): with the IFOV gives the pixel size",
        optional=True,
        minimum=0.0,
        unit="m",
    ),
    Number(
        name="ifov_mrad",
        description="Instantaneous field of view of one pixel (mrad; AISA-Dual ≈ 1)",
        optional=True,
        minimum=0.0,
        unit="mrad",
    ),
)

MATCH_PARAMS = (
    Number(
        name="window",
        description="Matching window (odd number of pixels): larger matches more pixels but blurs relief",
        default=15,
        minimum=3,
        maximum=101,
        integer=True,
    ),
    Number(
        name="search_along",
        description="Search ± this many pixels along-track (paper: 3)",
        default=3,
        minimum=1,
        maximum=50,
        integer=True,
    ),
    Number(
        name="search_across",
        description="Search ± this many pixels across-track (paper: 1)",
        default=1,
        minimum=0,
        maximum=50,
        integer=True,
    ),
    Number(
        name="min_peak",
        description="Reliable only where the correlation peak is at least this (0–1)",
        default=0.6,
        minimum=-1.0,
        maximum=1.0,
        advanced=True,
    ),
    Number(
        name="min_sharpness",
        description="Reliable only where the correlation peak is at least this sharp (curvature)",
        default=0.005,
        minimum=0.0,
        advanced=True,
    ),
    Number(
        name="refine",
        description="Sub-pixel refinement passes (warp and re-match: removes peak-locking bias)",
        default=1,
        minimum=0,
        maximum=5,
        integer=True,
        advanced=True,
    ),
)


def _read_pair(values: dict):
    """(dual, vnir band array, swir band array, valid mask, band info) for a spec's values."""
    dual = open_dual_from(values)
    tol = values["tolerance_nm"]
    vbs = _band_range(dual.vnir, values["vnir_nm"], values.get("vnir_to_nm"), tol, "vnir_to_nm")
    sbs = _band_range(dual.swir, values["swir_nm"], values.get("swir_to_nm"), tol, "swir_to_nm")
    vb, sb = vbs[0], sbs[0]
    v, ok_v = _read_mean(dual.vnir.path, "VNIR", vbs)
    s, ok_s = _read_mean(dual.swir.path, "SWIR", sbs)
    valid = ok_v & ok_s
    if values.get("cloud_mask"):
        with io.open_raster(values["cloud_mask"], "cloud mask") as src:
            if (src.height, src.width) != v.shape:
                raise InputError(
                    f"cloud mask {values['cloud_mask']} is {src.width} × {src.height} pixels "
                    f"but the images are {v.shape[1]} × {v.shape[0]}: mismatched grids; give a "
                    "mask on the image grid"
                )
            cloud, ok_c = io.read_masked(src, 1)
        valid &= ~((cloud != 0) & ok_c)
    info = {
        "vnir_band": vb,
        "vnir_wavelength_nm": round(dual.vnir.wavelength_of(vb), 3),
        "swir_band": sb,
        "swir_wavelength_nm": round(dual.swir.wavelength_of(sb), 3),
    }
    if len(vbs) > 1 or len(sbs) > 1:
        info["vnir_bands_averaged"] = vbs
        info["swir_bands_averaged"] = sbs
    return dual, v, s, valid, info


def _band_range(sensor, from_nm: float, to_nm, tolerance_nm: float, name: str) -> list[int]:
    """File bands whose centres lie in [from_nm, to_nm]; the band nearest ``from_nm`` when no
    range is given (or the range holds no band centre)."""
    if to_nm is not None:
        lo, hi = float(from_nm), float(to_nm)
        if hi < lo:
            raise ParameterError(
                f"parameter '{name}': {hi:g} nm is below the start of the range ({lo:g} nm); "
                "give the upper end of the wavelength range to average"
            )
        inside = [b for b in sensor.bands if lo <= sensor.wavelength_of(b) <= hi]
        if inside:
            return sorted(inside, key=sensor.wavelength_of)
    return [sensor.band_for(from_nm, tolerance_nm)]


def _read_mean(path, label: str, bands: list[int]):
    """Mean of ``bands`` (float64) and where all of them are valid."""
    total, valid = None, None
    with io.open_raster(path, label) as src:
        for b in bands:
            x, ok = io.read_masked(src, b)
            total = x.astype(np.float64) if total is None else total + x
            valid = ok if valid is None else valid & ok
    return total / len(bands), valid


def _write_json(path: str, data: dict) -> None:
    with io.atomic_output(path) as tmp, open(tmp, "w", encoding="utf-8") as f:
        json.dump(data, f, indent=2, default=float)


def _gsd(values: dict) -> float | None:
    h, ifov = values.get("flying_height"), values.get("ifov_mrad")
    if h is None or ifov is None:
        return None
    if h <= 0 or ifov <= 0:
        raise ParameterError("parameters 'flying_height' and 'ifov_mrad' must both be > 0")
    return h * ifov * 1e-3


# --------------------------------------------------------------------------------- offset
def _run_offset(values: dict, progress) -> dict:
    dual, v, s, valid, info = _read_pair(values)
    progress.info(
        f"matching VNIR band {info['vnir_band']} ({info['vnir_wavelength_nm']} nm) with SWIR "
        f"band {info['swir_band']} ({info['swir_wavelength_nm']} nm)"
    )
    off = estimate_offset(v, s, valid)
    result = {
        "along_px": round(off.along, 4),
        "across_px": round(off.across, 4),
        "match_error": round(off.error, 4),
        **info,
        "convention": "a feature at VNIR (line r, column c) appears at SWIR (r + along, c + across)",
    }
    if values.get("ifov_mrad"):
        ang = offset_angles(off.along, off.across, values["ifov_mrad"], values.get("flying_height"))
        result.update({k: round(val, 6) for k, val in ang.items()})
    progress.info(
        f"boresight offset: {off.along:+.3f} px along-track, {off.across:+.3f} px across-track"
        + (
            f" = {result['along_mrad']:+.3f} / {result['across_mrad']:+.3f} mrad"
            if "along_mrad" in result
            else ""
        )
    )
    progress.update(0.3, "global offset")
    if values["profile_rows"]:
        prof = offset_profile(v, s, valid, block_rows=values["profile_rows"])
        result["profile"] = [
            {
                "line": float(r),
                "along_px": float(a),
                "across_px": float(c),
                "valid_fraction": float(f),
            }
            for r, a, c, f in zip(
                prof.rows, prof.along, prof.across, prof.valid_fraction, strict=True
            )
        ]
        good = np.isfinite(prof.along)
        if good.sum() >= 2:
            result["drift_along_px"] = round(float(np.ptp(prof.along[good])), 4)
            result["drift_across_px"] = round(float(np.ptp(prof.across[good])), 4)
            progress.info(
                f"drift along the flight line ({good.sum()} blocks of {values['profile_rows']} "
                f"lines): {result['drift_along_px']:.3f} px along, {result['drift_across_px']:.3f} px across"
            )
        if values.get("plot"):
            _plot_profile(values["plot"], prof)
    _write_json(values["output"], result)
    progress.update(1.0, "done")
    return {"output": values["output"], **{k: v for k, v in result.items() if k != "profile"}}


def _plot_profile(path, prof):
    from ..figures import new_figure, save_figure

    fig, ax = new_figure()
    ax.plot(prof.rows, prof.along, "o-", label="along-track")
    ax.plot(prof.rows, prof.across, "s-", label="across-track")
    ax.set_xlabel("Line (along the flight)")
    ax.set_ylabel("SWIR − VNIR offset (pixels)")
    ax.set_title("Boresight offset per block of lines")
    ax.legend()
    save_figure(fig, path)


OFFSET = Algorithm(
    name="boresight-offset",
    display_name="Boresight offset (image-based)",
    group=GROUP,
    short_help="Sub-pixel VNIR→SWIR shift from the images alone, in pixels and angles, per block for drift.",
    help=(
        "Measures the boresight offset between the VNIR and the SWIR image: the sub-pixel shift "
        "(along-track, across-track) that brings the VNIR band nearest 920 nm onto the SWIR band "
        "nearest 1010 nm (the two bands of the boresight ratio). It uses Fourier "
        "cross-correlation with upsampled-DFT refinement (scikit-image) and needs no GPS/INS.\n\n"
        "Convention: a ground feature at VNIR line r, column c appears at SWIR line r + along, "
        "column c + across. Over relief the shift also contains parallax, so the global value is "
        "the offset of the average ground.\n\n"
        "With the IFOV (and the flying height) the offset is also given as angles between the two "
        "lines of sight (and metres on the ground). With 'profile rows' > 0 the offset is also "
        "measured per block of lines, so drift along the flight line can be seen (JSON and an "
        "optional PNG plot).\n\n"
        "Output: a JSON report."
    ),
    params=(
        *DUAL_PARAMS,
        *BAND_PARAMS,
        CLOUD,
        *GEOMETRY,
        Number(
            name="profile_rows",
            description="Also measure the offset per block of this many lines (0 = global only)",
            default=256,
            minimum=0,
            integer=True,
        ),
        FileOut(name="output", description="Offset report (JSON)", extension="json"),
        FileOut(
            name="plot",
            description="Plot of the offset along the flight line (PNG)",
            extension="png",
            optional=True,
        ),
    ),
    run=_run_offset,
)


# --------------------------------------------------------------------------------- coregister
def _run_coregister(values: dict, progress) -> dict:
    dual, v, s, valid, info = _read_pair(values)
    along, across = values.get("along"), values.get("across")
    if (along is None) != (across is None):
        raise ParameterError("give both 'along' and 'across', or neither (then they are measured)")
    if along is None:
        if values["follow_drift"]:
            prof = offset_profile(v, s, valid, block_rows=values["profile_rows"])
            along = profile_to_lines(prof.rows, prof.along, dual.height)
            across = profile_to_lines(prof.rows, prof.across, dual.height)
            progress.info(
                f"offset per block of {values['profile_rows']} lines, interpolated per line: "
                f"along {np.nanmin(prof.along):+.3f}…{np.nanmax(prof.along):+.3f} px"
            )
        else:
            off = estimate_offset(v, s, valid)
            along, across = off.along, off.across
    if np.ndim(along) == 0:
        progress.info(
            f"resampling SWIR by {along:+.3f} px along-track, {across:+.3f} px across-track"
        )
    swir = dual.swir
    names = [f"{w:.2f} nm" for w in swir.wavelengths]
    tags = {
        "product": "SWIR co-registered onto the VNIR grid (boresight offset removed)",
        "swir_file": swir.path,
        "offset_along_px": f"{float(np.mean(along)):.4f}",
        "offset_across_px": f"{float(np.mean(across)):.4f}",
        "offset_per_line": "yes" if np.ndim(along) else "no",
        "spline_order": values["order"],
        "wavelength_units": "nm",
    }
    with (
        io.open_raster(swir.path, "SWIR") as src,
        io.create_raster(
            values["output"], dual.grid, count=len(swir.bands), tags=tags, band_names=names
        ) as dst,
    ):
        for i, band in enumerate(swir.bands, start=1):
            data, ok = io.read_masked(src, band)
            out, ok2 = coregister(data, along, across, ok, order=values["order"])
            dst.write(np.where(ok2, out, io.FLOAT_NODATA).astype("float32"), i)
            dst.update_tags(i, wavelength=f"{swir.wavelengths[i - 1]:.3f}", wavelength_units="nm")
            progress.update(i / len(swir.bands), "resampling SWIR bands")
    return {
        "output": values["output"],
        "bands": len(swir.bands),
        "along_px": round(float(np.mean(along)), 4),
        "across_px": round(float(np.mean(across)), 4),
    }


COREGISTER = Algorithm(
    name="coregister",
    display_name="Co-register SWIR onto VNIR",
    group=GROUP,
    short_help="Resample every SWIR band onto the VNIR pixel grid, removing the boresight offset.",
    help=(
        "Corrects the boresight effect after it has been used: every SWIR band is resampled "
        "(cubic spline by default) so that SWIR pixel (r, c) sees the ground of VNIR pixel "
        "(r, c). The offset is measured from the images (as 'Boresight offset') unless given; "
        "with 'follow drift' it is measured per block of lines and interpolated line by line.\n\n"
        "Output: a float32 GeoTIFF with all SWIR bands (band descriptions and tags carry the "
        "wavelengths in nm), nodata -9999 where the shifted image has no data, on the VNIR grid "
        "(CRS and transform carried over; raw sensor geometry stays raw)."
    ),
    params=(
        *DUAL_PARAMS,
        *BAND_PARAMS,
        CLOUD,
        Number(
            name="along",
            description="Known along-track offset (px); empty = measure it",
            optional=True,
        ),
        Number(
            name="across",
            description="Known across-track offset (px); empty = measure it",
            optional=True,
        ),
        Flag(
            name="follow_drift", description="Measure the offset per block of lines and follow it"
        ),
        Number(
            name="profile_rows",
            description="Block of lines for 'follow drift'",
            default=256,
            minimum=16,
            integer=True,
            advanced=True,
        ),
        Enum(
            name="order",
            description="Interpolation (spline order)",
            choices=("1", "3"),
            default="3",
        ),
        RasterOut(name="output", description="Co-registered SWIR (GeoTIFF)"),
    ),
    run=lambda values, progress: _run_coregister(
        {**values, "order": int(values["order"])}, progress
    ),
)


# --------------------------------------------------------------------------------- disparity
def _run_disparity(values: dict, progress) -> dict:
    dual, v, s, valid, info = _read_pair(values)
    off = estimate_offset(v, s, valid)
    progress.info(f"search centred on the global offset {off.along:+.3f}, {off.across:+.3f} px")
    d = disparity_map(
        v,
        s,
        valid,
        window=values["window"],
        search_along=values["search_along"],
        search_across=values["search_across"],
        center=(off.along, off.across),
        refine=values["refine"],
        min_peak=values["min_peak"],
        min_sharpness=values["min_sharpness"],
        progress=progress.sub(0, 0.9),
    )
    n_rel = int(d.reliable.sum())
    progress.info(f"{n_rel} reliable pixels of {int(valid.sum())} valid")
    if n_rel == 0:
        raise InputError(
            f"no reliable matches with a {values['window']} px window: use a larger window "
            "(--window 21) or lower --min-peak"
        )
    keep = np.isfinite(d.along) & valid
    bands = [
        np.where(keep, d.along, io.FLOAT_NODATA),
        np.where(keep, d.across, io.FLOAT_NODATA),
        np.where(keep, d.peak, io.FLOAT_NODATA),
        np.where(keep, d.sharpness, io.FLOAT_NODATA),
        np.where(valid, d.reliable.astype("float32"), io.FLOAT_NODATA),
    ]
    tags = {
        "product": "VNIR/SWIR disparity (SWIR minus VNIR position, px)",
        **info,
        "window_px": values["window"],
        "search_along_px": values["search_along"],
        "search_across_px": values["search_across"],
        "min_peak": values["min_peak"],
        "min_sharpness": values["min_sharpness"],
        "offset_along_px": f"{off.along:.4f}",
        "offset_across_px": f"{off.across:.4f}",
    }
    io.write_raster(
        values["output"],
        np.stack(bands).astype("float32"),
        like=dual.grid,
        tags=tags,
        band_names=[
            "disparity along-track (px)",
            "disparity across-track (px)",
            "correlation peak",
            "peak sharpness",
            "reliable (1/0)",
        ],
    )
    return {
        "output": values["output"],
        "reliable_pixels": n_rel,
        "offset_along_px": round(off.along, 4),
        "offset_across_px": round(off.across, 4),
    }


DISPARITY = Algorithm(
    name="disparity",
    display_name="Disparity map (VNIR/SWIR matching)",
    group=GROUP,
    short_help="Dense sub-pixel VNIR/SWIR disparity with per-pixel reliability.",
    help=(
        "Matches the VNIR band nearest 920 nm with the SWIR band nearest 1010 nm pixel by pixel: "
        "normalised cross-correlation in a window, searching ± 3 pixels along-track and ± 1 "
        "across-track (the paper's matching accuracy) around the global boresight offset, "
        "refined to sub-pixel by parabola fits.\n\n"
        "Output: a 5-band float32 GeoTIFF: disparity along-track and across-track (px, SWIR "
        "minus VNIR position), correlation peak (0–1), peak sharpness, and reliable (1/0). Clouds "
        "(optional mask) and nodata are masked (-9999)."
    ),
    params=(
        *DUAL_PARAMS,
        *MATCH_BAND_PARAMS,
        CLOUD,
        *MATCH_PARAMS,
        RasterOut(name="output", description="Disparity and reliability bands (GeoTIFF)"),
    ),
    run=_run_disparity,
)


# --------------------------------------------------------------------------------- relative DEM
def _factor(values: dict) -> HeightFactor:
    sign = -1.0 if values["invert_parallax"] else 1.0
    axis = values["parallax_axis"]
    k = values.get("height_factor")
    if k is None:
        theta = values.get("squint_deg")
        if theta is None or values.get("flying_height") is None or values.get("ifov_mrad") is None:
            raise ParameterError(
                "give the height-to-disparity factor ('height_factor', px per metre), or the "
                "flying height, the IFOV and the squint angle between the two lines of sight"
            )
        if not theta > 0:
            raise ParameterError(
                f"parameter 'squint_deg': must be > 0, got {theta}; a zero squint makes no "
                "parallax (use 'invert_parallax' for the direction)"
            )
        f = height_factor(values["flying_height"], values["ifov_mrad"], theta)
        k = f.along
    if not (isinstance(k, int | float) and math.isfinite(k) and k > 0):
        raise ParameterError(
            f"parameter 'height_factor': must be > 0 px per metre, got {k}; it is the size of the "
            "parallax (use 'invert_parallax' for its direction)"
        )
    return HeightFactor(sign * k, 0.0) if axis == "along" else HeightFactor(0.0, sign * k)


def _run_dem(values: dict, progress) -> dict:
    factor = _factor(values)
    gsd = _gsd(values)
    dual, v, s, valid, info = _read_pair(values)
    progress.info(
        f"height-to-disparity factor {factor.magnitude:.5f} px/m ({values['parallax_axis']}-track)"
    )
    r = relative_dem(
        v,
        s,
        factor,
        valid,
        window=values["window"],
        search_along=values["search_along"],
        search_across=values["search_across"],
        min_peak=values["min_peak"],
        min_sharpness=values["min_sharpness"],
        refine=values["refine"],
        point_spacing=values["point_spacing"],
        variogram_model=values["variogram"],
        n_closest_points=values["n_closest_points"],
        require_meaningful=not values["force"],
        progress=progress,
    )
    p = r.precision
    tags = {
        "product": "relative DEM (Brook & Ben-Dor 2011, 3.2): 0 m = lowest reliable region",
        **info,
        "sigma_d_px": f"{p.sigma_d_px:.4f}",
        "sigma_h_m": f"{p.sigma_h_m:.4f}",
        "relief_above_noise_m": f"{p.relief_m:.3f}",
        "relief_to_noise": f"{p.snr:.3f}",
        "meaningful": "yes" if p.meaningful else "NO: sigma_h exceeds the relief",
        "height_factor_px_per_m": f"{factor.magnitude:.6f}",
        "parallax_axis": values["parallax_axis"],
        "offset_along_px": f"{r.offset.along:.4f}",
        "offset_across_px": f"{r.offset.across:.4f}",
        "window_px": values["window"],
        "search_along_px": values["search_along"],
        "search_across_px": values["search_across"],
        "min_peak": values["min_peak"],
        "point_spacing_px": values["point_spacing"],
        "control_points": r.points[0].size,
        "variogram": f"{r.variogram.model}: {r.variogram.describe()}",
        "n_closest_points": values["n_closest_points"],
        "units": "metres",
    }
    if gsd is not None:
        tags["gsd_m"] = f"{gsd:.4f}"
    io.write_raster(
        values["output"],
        np.where(np.isfinite(r.dem), r.dem, io.FLOAT_NODATA).astype("float32"),
        like=dual.grid,
        tags=tags,
        band_names=["relative height (m)"],
    )
    if values.get("variance"):
        io.write_raster(
            values["variance"],
            np.where(np.isfinite(r.variance), r.variance, io.FLOAT_NODATA).astype("float32"),
            like=dual.grid,
            tags={**tags, "product": "kriging variance of the relative DEM (m²)"},
            band_names=["kriging variance (m²)"],
        )
    if values.get("disparity"):
        d = r.disparity
        keep = np.isfinite(d.along) & valid
        io.write_raster(
            values["disparity"],
            np.stack(
                [
                    np.where(keep, b, io.FLOAT_NODATA)
                    for b in (d.along, d.across, d.peak, d.sharpness)
                ]
                + [np.where(valid, d.reliable.astype("float32"), io.FLOAT_NODATA)]
            ).astype("float32"),
            like=dual.grid,
            tags={**tags, "product": "VNIR/SWIR disparity (px) and reliability"},
            band_names=[
                "disparity along-track (px)",
                "disparity across-track (px)",
                "correlation peak",
                "peak sharpness",
                "reliable (1/0)",
            ],
        )
    result = {
        "output": values["output"],
        "sigma_d_px": round(p.sigma_d_px, 4),
        "sigma_h_m": round(p.sigma_h_m, 3),
        "relief_above_noise_m": round(p.relief_m, 2),
        "relief_to_noise": round(p.snr, 3),
        "meaningful": bool(p.meaningful),
        "message": p.message(),
        "height_factor_px_per_m": factor.magnitude,
        "offset_along_px": round(r.offset.along, 4),
        "offset_across_px": round(r.offset.across, 4),
        "reliable_pixels": int(r.disparity.reliable.sum()),
        "control_points": int(r.points[0].size),
        "variogram": {"model": r.variogram.model, "parameters": list(r.variogram.parameters)},
        "cross_validation": r.cross_validation,
        "dem_range_m": [float(np.nanmin(r.dem)), float(np.nanmax(r.dem))],
        **info,
    }
    if values.get("report"):
        _write_json(values["report"], result)
    return result


DEM = Algorithm(
    name="relative-dem",
    display_name="Relative DEM (kriging)",
    group=GROUP,
    short_help="Relative heights from VNIR/SWIR parallax, kriged onto the grid; reports σ_h.",
    help=(
        "Builds the relative DEM of Brook & Ben-Dor (2011, 3.2). The VNIR and SWIR images are "
        "matched pixel by pixel (as 'Disparity map'); relief shifts a feature by h·tan θ / GSD "
        "pixels, θ being the squint between the two lines of sight, so the disparity divided by "
        "the height-to-disparity factor k = tan θ / GSD (px per metre) is a height. Give k, or "
        "the flying height, IFOV and squint angle to derive it. The lowest reliable region is "
        "0 m; every other height is relative to it (not above sea level).\n\n"
        "Reliable heights are thinned to control points (the median of each cell of 'point "
        "spacing' pixels) and interpolated onto every pixel by ordinary kriging (PyKrige) with a "
        "fitted variogram and a local neighbourhood, so a full flight line fits in memory. "
        "Clouds (optional mask) and nodata are masked.\n\n"
        "Precision: the matching precision σ_d is estimated from the data and the height "
        "precision σ_h = σ_d·GSD/tan θ is reported (log, tags, report). With the small squint of "
        "a real instrument σ_h is usually larger than the relief: then the tool stops and says "
        "that no meaningful DEM can be made, rather than output noise that looks like terrain "
        "('force' writes it anyway, tagged as not meaningful).\n\n"
        "Outputs: the DEM (float32 GeoTIFF, metres, nodata -9999, same georeference as the "
        "input: in raw sensor geometry it stays raw; georeferenced, it opens in QGIS's 3D view), "
        "optionally the kriging variance, the disparity with its reliability bands and a JSON "
        "report with the cross-validation of the kriging."
    ),
    params=(
        *DUAL_PARAMS,
        *MATCH_BAND_PARAMS,
        CLOUD,
        Number(
            name="height_factor",
            description="Height-to-disparity factor k = tan θ / GSD (px per metre of height)",
            optional=True,
            unit="px/m",
        ),
        Number(
            name="squint_deg",
            description="Angle between the VNIR and SWIR lines of sight (degrees), if k is not given",
            optional=True,
            unit="°",
        ),
        *GEOMETRY,
        Enum(
            name="parallax_axis",
            description="Direction of the parallax (the squint plane)",
            choices=("along", "across"),
            default="along",
        ),
        Flag(
            name="invert_parallax",
            description="Elevated features appear at lower line (column) numbers in the SWIR image",
        ),
        *MATCH_PARAMS,
        Number(
            name="point_spacing",
            description="One control point per cell of this many pixels (median)",
            default=5,
            minimum=1,
            maximum=100,
            integer=True,
        ),
        Enum(
            name="variogram",
            description="Variogram model fitted for kriging",
            choices=MODELS,
            default="spherical",
        ),
        Number(
            name="n_closest_points",
            description="Control points in each local kriging neighbourhood",
            default=32,
            minimum=3,
            maximum=500,
            integer=True,
            advanced=True,
        ),
        Flag(
            name="force",
            description="Write the DEM even where σ_h exceeds the relief (tagged as not meaningful)",
        ),
        RasterOut(name="output", description="Relative DEM (GeoTIFF, m)"),
        RasterOut(name="variance", description="Kriging variance (GeoTIFF, m²)", optional=True),
        RasterOut(
            name="disparity", description="Disparity and reliability bands (GeoTIFF)", optional=True
        ),
        FileOut(
            name="report",
            description="Report: σ_d, σ_h, offset, variogram, cross-validation (JSON)",
            extension="json",
            optional=True,
        ),
    ),
    run=_run_dem,
)


# --------------------------------------------------------------------------------- 3-D view
def _run_view(values: dict, progress) -> dict:
    from ..dem.view3d import drape_figure, stretch_rgb
    from ..figures import save_figure

    with io.open_raster(values["dem"], "DEM") as src:
        dem, ok = io.read_masked(src, 1)
        georef = io.is_georeferenced(src)
        res = (abs(src.transform.e), abs(src.transform.a)) if georef else None
        gsd_tag = src.tags().get("GSD_M")
    dual = open_dual_from(values)
    if (dual.height, dual.width) != dem.shape:
        raise InputError(
            f"DEM {values['dem']} is {dem.shape[1]} × {dem.shape[0]} pixels but the image is "
            f"{dual.width} × {dual.height}: mismatched grids"
        )
    channels = []
    for nm in (values["red_nm"], values["green_nm"], values["blue_nm"]):
        band = dual.vnir.band_for(nm, values["tolerance_nm"])
        with io.open_raster(dual.vnir.path, "image") as src:
            b, okb = io.read_masked(src, band)
        channels.append(np.where(okb, b, np.nan))
    if res is not None:
        size, unit = res, "m"
    elif gsd_tag:
        size, unit = (float(gsd_tag), float(gsd_tag)), "m"
    else:
        size, unit = (1.0, 1.0), "px"
    fig = drape_figure(
        np.where(ok, dem, np.nan),
        stretch_rgb(*channels),
        exaggeration=values["exaggeration"],
        pixel_size=size,
        unit=unit,
        elevation=values["elevation"],
        azimuth=values["azimuth"],
    )
    save_figure(fig, values["output"])
    return {"output": values["output"]}


VIEW = Algorithm(
    name="view-3d",
    display_name="3-D view (image draped on the DEM)",
    group=GROUP,
    short_help="PNG of an RGB of the image draped on the relative DEM with vertical exaggeration (Figure 9E).",
    help=(
        "Renders the image (an RGB of three VNIR wavelengths, 2–98 % stretch) draped on the "
        "relative DEM, with vertical exaggeration, as Figure 9E of the paper. Pixels without a "
        "height (clouds, nodata) are drawn black. Axes are in metres when the DEM is "
        "georeferenced or records its pixel size, in pixels otherwise.\n\n"
        "For an interactive view, open the DEM GeoTIFF in QGIS's 3D map view with the image "
        "as texture (georeferenced data only)."
    ),
    params=(
        RasterIn(name="dem", description="Relative DEM (from 'Relative DEM')"),
        *DUAL_PARAMS,
        Wavelength(name="red_nm", description="Red channel wavelength (nm)", default=640.0),
        Wavelength(name="green_nm", description="Green channel wavelength (nm)", default=550.0),
        Wavelength(name="blue_nm", description="Blue channel wavelength (nm)", default=460.0),
        Number(
            name="tolerance_nm",
            description="Largest distance to a band centre (nm)",
            default=10.0,
            minimum=0.0,
            unit="nm",
            advanced=True,
        ),
        Number(
            name="exaggeration",
            description="Vertical exaggeration",
            default=3.0,
            minimum=0.01,
            maximum=1000.0,
        ),
        Number(
            name="elevation",
            description="Viewing elevation (degrees)",
            default=35.0,
            minimum=0.0,
            maximum=90.0,
            advanced=True,
        ),
        Number(
            name="azimuth",
            description="Viewing azimuth (degrees)",
            default=-60.0,
            minimum=-360.0,
            maximum=360.0,
            advanced=True,
        ),
        FileOut(name="output", description="3-D view (PNG)", extension="png"),
    ),
    run=_run_view,
)

ALGORITHMS = (OFFSET, COREGISTER, DISPARITY, DEM, VIEW)
