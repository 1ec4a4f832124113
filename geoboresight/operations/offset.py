"""File-level boresight offset and co-registration (paper §3.2): measure the VNIR→SWIR shift of
a flight line from the images alone, then remove it by resampling SWIR onto the VNIR grid."""

from __future__ import annotations

import numpy as np

from .. import io
from ..dem.height import FlightGeometry
from ..errors import ParameterError
from ..io.bands import MatchBands, open_matching_pair
from ..io.dual import DualLayout
from ..sensor.coregister import (
    DEFAULT_ORDER,
    ORDERS,
    coregister_halo,
    coregister_stack,
    profile_to_lines,
)
from ..sensor.offset import (
    PROFILE_ROWS,
    offset_angles,
    profile_figure,
)
from ._offset import line_offset

#: The convention of every offset reported.
CONVENTION = "a feature at VNIR (line r, column c) appears at SWIR (r + along, c + across)"


def boresight_offset_file(
    vnir,
    swir=None,
    cloud_mask=None,
    *,
    output,
    plot=None,
    layout=DualLayout(),
    match=MatchBands(),
    geometry=FlightGeometry(),
    profile_rows=PROFILE_ROWS,
    progress=None,
) -> dict:
    """Measure the boresight offset between the VNIR and the SWIR image of a flight line.

    The sub-pixel shift (along-track, across-track) that brings the VNIR band nearest 920 nm
    onto the SWIR band nearest 1010 nm (the bands of the boresight ratio), by Fourier
    cross-correlation; optionally per block of lines, to see drift.

    Parameters
    ----------
    vnir : path
        VNIR file (ENVI or GeoTIFF), or a merged VNIR+SWIR cube when ``swir`` is None.
    swir : path, optional
        SWIR file on the same pixel grid.
    cloud_mask : path, optional
        Cloud mask on the same grid (non-zero = cloud), left out of the matching.
    output : path
        JSON report: the offset (px; mrad, degrees and metres with the IFOV and flying height),
        the bands matched and the profile along the flight line.
    plot : path, optional
        PNG plot of the offset per block of lines (needs ``profile_rows`` > 0).
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    match : MatchBands
        The bands matched: by default the ratio's, nearest 920 and 1010 nm (Eq. 3).
    geometry : FlightGeometry
        Its ``ifov_mrad`` gives the offset as angles, with ``flying_height`` in metres.
    profile_rows : int
        Also measure the offset per block of this many lines (0: the global offset only).
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the offset (``along_px``, ``across_px``, ``match_error``, angles), the bands
        matched and the drift (without the per-block profile, which is in the report).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2; the bands of
    Eq. 3).

    Examples
    --------
    >>> import geoboresight as gb
    >>> result = gb.boresight_offset_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr", output="out/offset.json"
    ... )
    >>> result["along_px"], result["across_px"]
    (0.87, -0.07)
    """
    dual = io.as_dual(vnir, swir, layout)
    with open_matching_pair(dual, match, cloud_mask) as pair:
        info = pair.info()
        progress.info(
            f"matching VNIR band {info['vnir_band']} ({info['vnir_wavelength_nm']} nm) with "
            f"SWIR band {info['swir_band']} ({info['swir_wavelength_nm']} nm)"
        )
        off, prof = line_offset(pair, profile_rows, progress.sub(0.0, 0.95))
    result = {
        "along_px": round(off.along, 4),
        "across_px": round(off.across, 4),
        "match_error": round(off.error, 4),
        **info,
        "convention": CONVENTION,
    }
    if geometry.ifov_mrad:
        ang = offset_angles(off.along, off.across, geometry.ifov_mrad, geometry.flying_height)
        result.update({k: round(val, 6) for k, val in ang.items()})
    progress.info(
        f"boresight offset: {off.along:+.3f} px along-track, {off.across:+.3f} px across-track"
        + (
            f" = {result['along_mrad']:+.3f} / {result['across_mrad']:+.3f} mrad"
            if "along_mrad" in result
            else ""
        )
    )
    if prof is not None:
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
                f"drift along the flight line ({good.sum()} blocks of {profile_rows} lines): "
                f"{result['drift_along_px']:.3f} px along, {result['drift_across_px']:.3f} px across"
            )
        if plot:
            from ..io.write import save_figure

            save_figure(profile_figure(prof), plot)
    io.write_json(output, result)
    progress.update(1.0, "done")
    return {"output": output, **{k: v for k, v in result.items() if k != "profile"}}


def coregister_file(
    vnir,
    swir=None,
    cloud_mask=None,
    *,
    output,
    layout=DualLayout(),
    match=MatchBands(),
    along=None,
    across=None,
    follow_drift=False,
    profile_rows=PROFILE_ROWS,
    order=str(DEFAULT_ORDER),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Resample every SWIR band onto the VNIR pixel grid, removing the boresight offset.

    SWIR pixel ``(r, c)`` then sees the ground of VNIR pixel ``(r, c)``. The offset is measured
    from the images (as :func:`boresight_offset_file`) unless given; with ``follow_drift`` it is
    measured per block of lines and interpolated line by line. The bands are resampled strip by
    strip, each strip read with the lines the shift and the kernel reach.

    Parameters
    ----------
    vnir : path
        VNIR file (ENVI or GeoTIFF), or a merged VNIR+SWIR cube when ``swir`` is None.
    swir : path, optional
        SWIR file on the same pixel grid.
    cloud_mask : path, optional
        Cloud mask on the same grid (non-zero = cloud), left out when measuring the offset.
    output : path
        Float32 GeoTIFF with every SWIR band (descriptions and tags give the wavelengths),
        nodata -9999 where the shifted image has no data, on the VNIR grid.
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    match : MatchBands
        The bands matched to measure the offset (see :func:`boresight_offset_file`).
    along, across : float, optional
        A known offset (px); both or neither (then it is measured).
    follow_drift : bool
        Measure the offset per block of ``profile_rows`` lines and follow it line by line.
    profile_rows : int
        Lines per block for ``follow_drift``.
    order : {"1", "3"}
        Interpolation: linear, or Keys' cubic convolution (the default).
    block_rows : int
        Lines resampled at a time (each strip is read with the lines its shift reaches).
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the number of bands and the mean offset removed (px).

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.2).

    Examples
    --------
    >>> import geoboresight as gb
    >>> result = gb.coregister_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                             output="out/swir_on_vnir.tif")
    >>> result["bands"], result["along_px"], result["across_px"]
    (102, 0.87, -0.07)
    """
    if (along is None) != (across is None):
        raise ParameterError("give both 'along' and 'across', or neither (then they are measured)")
    order = int(order)
    dual = io.as_dual(vnir, swir, layout)
    if along is None:
        with open_matching_pair(dual, match, cloud_mask) as pair:
            off, prof = line_offset(
                pair,
                profile_rows if follow_drift else 0,
                progress.sub(0.0, 0.2),
                given=": give it ('along', 'across')",
            )
        if follow_drift:
            along = profile_to_lines(prof.rows, prof.along, dual.height)
            across = profile_to_lines(prof.rows, prof.across, dual.height)
            progress.info(
                f"offset per block of {profile_rows} lines, interpolated per line: "
                f"along {np.nanmin(prof.along):+.3f}…{np.nanmax(prof.along):+.3f} px"
            )
        else:
            along, across = off.along, off.across
    per_line = np.ndim(along) > 0
    if not per_line:
        progress.info(
            f"resampling SWIR by {along:+.3f} px along-track, {across:+.3f} px across-track"
        )
    cube, index, wavelengths, _ = io.open_sensors([dual.swir], "SWIR")
    tags = {
        "product": "SWIR co-registered onto the VNIR grid (boresight offset removed)",
        "swir_file": dual.swir.path,
        "offset_along_px": f"{float(np.mean(along)):.4f}",
        "offset_across_px": f"{float(np.mean(across)):.4f}",
        "offset_per_line": "yes" if per_line else "no",
        "interpolation": ORDERS[order],
        "wavelength_units": "nm",
    }
    n = len(index)

    def shift(values, valid, *, block):
        lines = slice(block.row0, block.row0 + values.shape[1])
        al, ac = (along[lines], across[lines]) if per_line else (along, across)
        out, ok = coregister_stack(values, al, ac, valid, order=order)
        out[:, ~ok] = io.FLOAT_NODATA
        return out[:, block.inner]

    with (
        cube,
        io.create_raster(
            output,
            dual.grid,
            count=n,
            tags=tags,
            band_names=[f"{w:.2f} nm" for w in wavelengths],
            band_tags=[{"wavelength": f"{w:.3f}", "wavelength_units": "nm"} for w in wavelengths],
        ) as dst,
    ):
        halo = coregister_halo(along, order)  # the lines the shift and the kernel reach
        for win, out in io.map_windows(
            cube.reader(index, None),
            shift,
            height=dual.height,
            width=dual.width,
            block_rows=block_rows,
            halo=halo,
            pass_block=True,
            workers=io.windows.default_workers(),
            progress=progress.sub(0.2, 1.0),
            message="resampling SWIR bands",
        ):
            dst.write(out, window=win)
    return {
        "output": output,
        "bands": n,
        "along_px": round(float(np.mean(along)), 4),
        "across_px": round(float(np.mean(across)), 4),
    }
