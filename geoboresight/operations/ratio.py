"""File-level boresight ratio (Eq. 3): a whole flight line, streamed block by block."""

from __future__ import annotations

import numpy as np

from .. import io
from ..io.dual import BandChoice, DualLayout
from ..ratio import boresight_ratio


def ratio_file(
    vnir,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    bands=BandChoice(),
    block_rows=io.DEFAULT_BLOCK_ROWS,
    progress=None,
) -> dict:
    """Write the boresight band ratio b(1010 nm) / b(920 nm) of a flight line to a GeoTIFF.

    Parameters
    ----------
    vnir : path or DualSensor
        VNIR file (ENVI or GeoTIFF), a merged VNIR+SWIR cube or a sensor product when ``swir``
        is None, or a dataset opened with :func:`geoboresight.open_dual`.
    swir : path, optional
        SWIR file on the same pixel grid.
    output : path
        The float32 ratio GeoTIFF (nodata -9999), on the input's grid: raw sensor geometry stays
        raw, a CRS and geotransform are carried over.
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    bands : BandChoice
        The two bands: nearest 920 nm (VNIR, denominator) and 1010 nm (SWIR, numerator) by
        default, or the last VNIR and first SWIR band.
    block_rows : int
        Lines read at a time.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the bands and wavelengths used and the number of valid pixels.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (Eq. 3).

    Examples
    --------
    On the bundled sample scene, from the repository's top folder (outputs into ``out/``):

    >>> import geoboresight as gb
    >>> result = gb.ratio_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr", output="out/ratio.tif"
    ... )
    >>> result["swir_wavelength_nm"], result["vnir_wavelength_nm"], result["valid_pixels"]
    (1009.109, 922.0, 54912)

    The first SWIR band over the last VNIR band instead of the bands nearest 1010 and 920 nm:

    >>> edges = gb.BandChoice(band_mode="edges")
    >>> result = gb.ratio_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...     output="out/ratio_edges.tif", bands=edges,
    ... )
    >>> result["swir_wavelength_nm"], result["vnir_wavelength_nm"]
    (980.0, 970.0)
    """
    dual = io.as_dual(vnir, swir, layout)
    bands = dual.ratio_bands(bands)
    progress.info(
        f"boresight ratio: SWIR band {bands.swir_band} ({bands.swir_nm:.1f} nm) / VNIR band "
        f"{bands.vnir_band} ({bands.vnir_nm:.1f} nm); "
        f"{_layout(dual)}; "
        f"{'georeferenced' if dual.grid.georeferenced else 'raw sensor geometry'}"
    )
    tags = {
        "product": "boresight band ratio (Brook & Ben-Dor 2011, Eq. 3)",
        "numerator_file": dual.swir.path,
        "numerator_band": bands.swir_band,
        "numerator_wavelength_nm": f"{bands.swir_nm:.3f}",
        "denominator_file": dual.vnir.path,
        "denominator_band": bands.vnir_band,
        "denominator_wavelength_nm": f"{bands.vnir_nm:.3f}",
        "numerator_units": dual.swir.units,
        "denominator_units": dual.vnir.units,
    }
    n_valid = 0
    with (
        io.open_raster(dual.swir.reads, "SWIR") as s_src,
        io.open_raster(dual.vnir.reads, "VNIR") as v_src,
        io.create_raster(
            output,
            dual.grid,
            tags=tags,
            band_names=[f"boresight ratio {bands.swir_nm:.0f}/{bands.vnir_nm:.0f} nm"],
        ) as dst,
    ):
        read = io.bands_reader([(s_src, bands.swir_band), (v_src, bands.vnir_band)])

        def kernel(pair, valid):
            ratio, ok = boresight_ratio(pair[0], pair[1], valid)
            return np.where(ok, ratio, io.FLOAT_NODATA).astype("float32"), int(ok.sum())

        for win, (ratio, n) in io.map_windows(
            read,
            kernel,
            height=dual.height,
            width=dual.width,
            block_rows=block_rows,
            progress=progress,
            message="ratio",
        ):
            dst.write(ratio, 1, window=win)
            n_valid += n
    progress.info(f"{n_valid} of {dual.width * dual.height} pixels valid")
    return {
        "output": output,
        "swir_band": bands.swir_band,
        "swir_wavelength_nm": round(bands.swir_nm, 3),
        "vnir_band": bands.vnir_band,
        "vnir_wavelength_nm": round(bands.vnir_nm, 3),
        "valid_pixels": n_valid,
    }


def _layout(dual) -> str:
    """How the line was given, for the log: the product recognised, a merged cube or two files."""
    product = getattr(dual.product, "kind", None)
    if product:
        return f"{product} product" + (" (two files)" if len(dual.files) > 1 else "")
    return "merged cube" if dual.merged else "two files"
