"""File-level radiance: a raw Specim capture or a HySpex file through its vendor's
calibration, streamed strip by strip into a float32 cube."""

from __future__ import annotations

import os

from .. import io
from ..io.bil import create_bil, is_bil
from ..io.radiance import radiance_plan
from ..sensor.calibration import Calibration, radiance


def radiance_file(
    input,
    calibration: str | os.PathLike | Calibration | None = None,
    *,
    output,
    smear="auto",
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the radiance of a raw capture, L = (DN − dark) · gain / tint[ms], to a GeoTIFF.

    Parameters
    ----------
    input : path
        A raw Specim capture (AISA Eagle, Hawk, Dual; AisaFENIX: ENVI with its Specim header
        and dark frames or a DARKREF file) or a HySpex ``.hyspex`` file.
    calibration : path or Calibration, optional
        The Specim calibration (the ``.cal``/``.dat`` of the calibration pack, or its
        ``.hdr``, or :func:`geoboresight.read_calibration`'s value); a ``.bad`` file of the same name masks bad detector cells. A HySpex file
        carries its own calibration: leave it empty.
    output : path
        Float32 radiance in µW cm⁻² sr⁻¹ nm⁻¹, one band per band of the capture (its image
        lines only), nodata -9999 where a pixel is saturated, a bad cell or the frame counter;
        wavelengths and FWHM as band metadata, every choice and source in the tags. A GeoTIFF
        (``.tif``, compressed, with overviews) or an ENVI BIL cube (``.img``, ``.bil``,
        ``.dat``: uncompressed, written as fast as the disk takes it).
    smear : {"auto", "on", "off"}
        The Eagle's frame-transfer smear correction: "auto" applies it to an Eagle.
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, ``bands``, ``lines``, ``valid_fraction`` and ``units``.

    References
    ----------
    NERC-ARF APL ``aplcal`` (``src/calibration.cpp``); EnSpec HyPro ``hypro/Radiometry.py``;
    Brook, A.; Ben-Dor, E. Remote Sens. 2011, 3, 484–502, https://doi.org/10.3390/rs3030484.
    """
    plan = radiance_plan(input, calibration, smear)
    cube = plan.cube
    progress.info(
        f"radiance of {plan.kind} {plan.path}: {cube.bands} bands × {plan.lines} lines; "
        f"{plan.tags.get('integration_time', 'tint in the calibration')}; "
        f"dark: {plan.tags['dark']}"
    )
    grid = io.Grid(cube.samples, plan.lines, None, None)
    wl = plan.wavelengths
    band_tags = []
    for i, w in enumerate(wl):
        bt = {
            "wavelength": f"{w:.3f}",
            "wavelength_units": "Nanometers",
            "units": plan.tags["units"],
        }
        if plan.fwhm is not None:
            bt["fwhm"] = f"{plan.fwhm[i]:.3f}"
        band_tags.append(bt)
    tags = {**plan.tags, "input": plan.path}
    tags["wavelength"] = "{" + ", ".join(f"{w:.3f}" for w in wl) + "}"
    if plan.fwhm is not None:
        tags["fwhm"] = "{" + ", ".join(f"{f:.3f}" for f in plan.fwhm) + "}"

    def kernel(dn):
        rad, ok = radiance(
            dn,
            plan.dark,
            plan.gain,
            plan.tint,
            saturation=plan.saturation,
            bad=plan.bad,
            smear=plan.smear,
        )
        rad[~ok] = io.FLOAT_NODATA
        return rad, int(ok.sum())

    n_ok = 0
    names = [f"{w:.2f} nm" for w in wl]
    if is_bil(output):
        # ENVI BIL: the strips as the kernel gives them, appended uncompressed.
        writer = create_bil(
            output,
            grid,
            count=cube.bands,
            wavelengths=wl,
            fwhm=plan.fwhm,
            tags=tags,
            band_names=names,
        )
        order = (0, 1, 2)
    else:
        writer = io.create_raster(
            output, grid, count=cube.bands, tags=tags, band_names=names, band_tags=band_tags
        )
        order = (1, 0, 2)  # GeoTIFF: bands first
    with writer as dst:
        for win, (block, n) in io.map_windows(
            plan.dn,
            kernel,
            height=plan.lines,
            width=cube.samples,
            block_rows=block_rows,
            progress=progress,
            message="radiance",
        ):
            dst.write(block.transpose(order), window=win)
            n_ok += n
    total = cube.bands * plan.lines * cube.samples
    progress.info(f"{n_ok} of {total} values are radiance ({n_ok / total:.4%})")
    return {
        "output": output,
        "bands": cube.bands,
        "lines": plan.lines,
        "valid_fraction": round(n_ok / total, 6),
        "units": plan.tags["units"],
    }
