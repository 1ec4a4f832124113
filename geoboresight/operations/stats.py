"""File-level SPSS-style descriptive statistics of one raster band (Table 1, Figure 3)."""

from __future__ import annotations

from .. import io
from ..errors import ParameterError
from ..stats import DEFAULT_PERCENTILES, describe_blocks

#: The percentiles reported by default, as the spec's text parameter spells them.
PERCENTILES = ",".join(f"{q:g}" for q in DEFAULT_PERCENTILES)
BINS = 50


def parse_percentiles(text) -> list[float]:
    """Percentiles from ``"1,5,50"`` (or a sequence of numbers), each in 0–100."""
    if isinstance(text, str):
        try:
            qs = [float(v) for v in text.replace(";", ",").split(",") if v.strip()]
        except ValueError:
            raise ParameterError(
                f"parameter 'percentiles': {text!r} is not a comma-separated list of numbers"
            ) from None
    else:
        qs = [float(v) for v in text]
    bad = [q for q in qs if not 0 <= q <= 100]
    if bad:
        raise ParameterError(f"parameter 'percentiles': {bad} outside 0–100")
    return qs


def stats_file(
    input,
    *,
    output,
    band=1,
    band_nm=None,
    bins=BINS,
    percentiles=PERCENTILES,
    block_rows=io.DEFAULT_BLOCK_ROWS,
    html=None,
    histogram=None,
    progress=None,
) -> dict:
    """Exact descriptive statistics of one band of a raster, as SPSS reports them.

    N, mean and its standard error, standard deviation, variance, skewness and kurtosis
    (bias-corrected G1, G2) with standard errors and z tests, 3σ outliers, percentiles and the
    histogram, merged exactly over blocks of lines.

    Parameters
    ----------
    input : path
        Raster to describe (typically the boresight ratio).
    output : path
        JSON file with every number.
    band : int
        1-based band number.
    band_nm : float, optional
        The band by its centre wavelength (nm) instead: the band nearest it becomes ``band``
        (a sensor product's bands, or a file's wavelength metadata).
    bins : int
        Histogram bins between the minimum and the maximum.
    percentiles : str or sequence of float
        Percentiles (0–100) to report, e.g. ``"1,5,50,95,99"``.
    block_rows : int
        Lines read at a time.
    html : path, optional
        The statistics as an HTML page laid out as Table 1.
    histogram : path, optional
        The histogram as a PNG (Figure 3).
    progress : Progress, optional

    Returns
    -------
    dict
        The output paths and N, mean, std, skewness and its standard error.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (Table 1, Figure 3).

    Examples
    --------
    Table 1's statistics of the sample scene's boresight ratio:

    >>> import geoboresight as gb
    >>> _ = gb.ratio_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr", output="out/ratio.tif"
    ... )
    >>> stats = gb.stats_file("out/ratio.tif", output="out/stats.json", histogram="out/hist.png")
    >>> stats["n"], round(stats["mean"], 3), round(stats["skewness"], 3)
    (54912, 2.434, 0.976)
    >>> round(stats["se_skewness"], 4)  # follows from N alone (SPSS)
    0.0105
    """
    qs = parse_percentiles(percentiles)
    image = io.raster_image(input, "input")
    with io.open_raster(input, "input") as src:
        desc_name = src.descriptions[band - 1] or f"band {band}"
        units = image.units or (src.units[band - 1] if src.units else "") or ""
        read = io.band_reader(src, band)

        blocks = io.windows.value_passes(
            read,
            lambda values, valid: values[valid],
            height=src.height,
            width=src.width,
            block_rows=block_rows,
        )

        d = describe_blocks(
            blocks, bins=bins, percentiles=qs, progress=progress, label=f"{image.path} band {band}"
        )
    result = {"output": output}
    payload = {
        "input": image.path,
        "product": image.kind,
        "band": band,
        "band_description": desc_name,
        "band_wavelength_nm": None
        if image.wavelengths is None
        else round(float(image.wavelengths[band - 1]), 3),
        "units": units,
        **d.to_dict(),
    }
    if histogram:
        from ..figures import histogram_figure  # matplotlib only when asked
        from ..io.write import save_figure

        fig = histogram_figure(
            d.histogram_counts,
            d.histogram_edges,
            f"Distribution of {desc_name}",
            desc_name,
            d.mean,
            d.std,
        )
        save_figure(fig, histogram)
        result["histogram"] = histogram
    if html:
        from ..html import descriptives_html

        io.write_text(
            html, descriptives_html(d, desc_name, f"{image.path}, band {band}", histogram)
        )
        result["html"] = html
    io.write_json(output, payload)
    progress.info(
        f"N={d.n} mean={d.mean:.6g} (SE {d.se_mean:.4g}) std={d.std:.6g} "
        f"skewness={d.skewness:.4g} (SE {d.se_skewness:.3f}, z={d.z_skewness:.3g})"
    )
    result.update(n=d.n, mean=d.mean, std=d.std, skewness=d.skewness, se_skewness=d.se_skewness)
    return result
