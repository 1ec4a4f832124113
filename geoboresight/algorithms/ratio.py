"""Spec: the boresight band ratio raster (Eq. 3), streamed over block windows."""

from __future__ import annotations

import numpy as np

from .. import io
from ..ratio import boresight_ratio
from ._common import BAND_PARAMS, BLOCK_ROWS, DUAL_PARAMS, open_dual_from, ratio_bands_from
from .spec import Algorithm, RasterOut


def _run(values: dict, progress) -> dict:
    dual = open_dual_from(values)
    num_band, den_band = ratio_bands_from(dual, values)
    num_wl, den_wl = dual.swir.wavelength_of(num_band), dual.vnir.wavelength_of(den_band)
    progress.info(
        f"boresight ratio: SWIR band {num_band} ({num_wl:.1f} nm) / VNIR band {den_band} "
        f"({den_wl:.1f} nm); {'merged cube' if dual.merged else 'two files'}; "
        f"{'georeferenced' if dual.transform is not None else 'raw sensor geometry'}"
    )
    tags = {
        "product": "boresight band ratio (Brook & Ben-Dor 2011, Eq. 3)",
        "numerator_file": dual.swir.path,
        "numerator_band": num_band,
        "numerator_wavelength_nm": f"{num_wl:.3f}",
        "denominator_file": dual.vnir.path,
        "denominator_band": den_band,
        "denominator_wavelength_nm": f"{den_wl:.3f}",
    }
    n_valid = 0
    total = 0
    with (
        io.open_raster(dual.swir.path, "SWIR") as s_src,
        io.open_raster(dual.vnir.path, "VNIR") as v_src,
        io.create_raster(
            values["output"],
            dual.grid,
            tags=tags,
            band_names=[f"boresight ratio {num_wl:.0f}/{den_wl:.0f} nm"],
        ) as dst,
    ):
        windows = list(io.row_windows(dual.height, dual.width, values["block_rows"]))
        for i, win in enumerate(windows):
            num, ok_n = io.read_masked(s_src, num_band, win)
            den, ok_d = io.read_masked(v_src, den_band, win)
            ratio, ok = boresight_ratio(num, den, ok_n & ok_d)
            dst.write(np.where(ok, ratio, io.FLOAT_NODATA).astype("float32"), 1, window=win)
            n_valid += int(ok.sum())
            total += ok.size
            progress.update((i + 1) / len(windows), "ratio")
    progress.info(f"{n_valid} of {total} pixels valid")
    return {
        "output": values["output"],
        "numerator_band": num_band,
        "numerator_wavelength_nm": round(num_wl, 3),
        "denominator_band": den_band,
        "denominator_wavelength_nm": round(den_wl, 3),
        "valid_pixels": n_valid,
    }


RATIO = Algorithm(
    name="ratio",
    display_name="Boresight band ratio",
    group="Boresight ratio and statistics",
    short_help="b(1010 nm) / b(920 nm): the first SWIR band over the last VNIR band (Eq. 3).",
    help=(
        "Computes the boresight band ratio of Brook & Ben-Dor (2011, Eq. 3): the SWIR band "
        "nearest 1010 nm divided by the VNIR band nearest 920 nm. The two optics of a dual "
        "pushbroom sensor (e.g. AISA-Dual) see slightly different ground, so the ratio is high in "
        "core shadow and at sub-pixel anomalies.\n\n"
        "Input: two files (VNIR and SWIR on the same pixel grid) or one merged cube, split at the "
        "seam wavelength. Wavelengths are read from the ENVI header or the band metadata; give "
        "them by hand for files without any. Works in raw sensor geometry (no CRS is invented) "
        "as well as on georeferenced data (CRS and transform are carried to the output).\n\n"
        "Output: a float32 GeoTIFF, nodata -9999 where either band is nodata or the denominator "
        "is zero or negative, with tags recording the bands and wavelengths used."
    ),
    params=(
        *DUAL_PARAMS,
        *BAND_PARAMS,
        BLOCK_ROWS,
        RasterOut(name="output", description="Boresight ratio raster (GeoTIFF)"),
    ),
    run=_run,
)

ALGORITHMS = (RATIO,)
