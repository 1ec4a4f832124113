"""Spec: SPSS-style descriptive statistics of one raster band (Table 1, Figure 3)."""

from __future__ import annotations

import json

from .. import io
from ..html import page, png_img, table
from ..stats import DEFAULT_PERCENTILES, Descriptives, describe_blocks
from ._common import BLOCK_ROWS
from .spec import Algorithm, Band, FileOut, Number, RasterIn, Text


def _parse_percentiles(text: str) -> list[float]:
    from ..errors import ParameterError

    try:
        qs = [float(v) for v in text.replace(";", ",").split(",") if v.strip()]
    except ValueError:
        raise ParameterError(
            f"parameter 'percentiles': {text!r} is not a comma-separated list of numbers"
        ) from None
    bad = [q for q in qs if not 0 <= q <= 100]
    if bad:
        raise ParameterError(f"parameter 'percentiles': {bad} outside 0–100")
    return qs


def descriptives_html(d: Descriptives, title: str, source: str, histogram_png: str | None) -> str:
    """Table 1 of the paper (N, mean ± SE, std, variance, skewness ± SE) and the rest."""
    t1 = (
        "<table><caption>Descriptive statistics (as in Table 1)</caption>"
        "<tr><th class='l' rowspan=2></th><th>N</th><th colspan=2>Mean</th><th>Std.</th>"
        "<th>Variance</th><th colspan=2>Skewness</th><th colspan=2>Kurtosis</th></tr>"
        "<tr><th>Statistic</th><th>Statistic</th><th>Std. Error</th><th>Statistic</th>"
        "<th>Statistic</th><th>Statistic</th><th>Std. Error</th><th>Statistic</th><th>Std. Error</th></tr>"
    )
    from ..html import fmt

    cells = [
        d.n,
        d.mean,
        d.se_mean,
        d.std,
        d.variance,
        d.skewness,
        d.se_skewness,
        d.kurtosis,
        d.se_kurtosis,
    ]
    t1 += (
        f"<tr><td class='l'>{title}</td>"
        + "".join(f"<td>{fmt(c)}</td>" for c in cells)
        + "</tr></table>"
    )
    tests = table(
        [
            ("z = skewness / SE", d.z_skewness),
            ("two-sided p (skewness = 0)", d.p_skewness),
            ("z = kurtosis / SE", d.z_kurtosis),
            ("two-sided p (kurtosis = 0)", d.p_kurtosis),
            ("values beyond mean ± 3σ", d.n_outliers_3sd),
            ("fraction beyond mean ± 3σ", d.fraction_outliers_3sd),
            ("minimum", d.minimum),
            ("maximum", d.maximum),
            *[(f"percentile {k[1:]}", v) for k, v in d.percentiles.items()],
        ],
        caption="Tests of normality, outliers and percentiles",
        header=("", "value"),
    )
    img = png_img(histogram_png, "Histogram") if histogram_png else ""
    note = (
        "<p class='note'>Skewness and kurtosis are the bias-corrected G1 and G2 reported by SPSS; "
        "a |z| above 1.96 rejects a symmetric (normal) distribution at 5 %. Source: "
        f"{source}.</p>"
    )
    return page(f"Descriptive statistics — {title}", t1 + tests + note + img)


def _run(values: dict, progress) -> dict:
    path, band = values["input"], values["band"]
    qs = _parse_percentiles(values["percentiles"])

    with io.open_raster(path, "input") as src:
        windows = list(io.row_windows(src.height, src.width, values["block_rows"]))
        desc_name = src.descriptions[band - 1] or f"band {band}"

        def blocks():
            for win in windows:
                v, ok = io.read_masked(src, band, win)
                yield v[ok]

        d = describe_blocks(
            blocks,
            bins=values["bins"],
            percentiles=qs,
            progress=progress,
            label=f"{path} band {band}",
        )
    result = {"output": values["output"]}
    payload = {"input": path, "band": band, "band_description": desc_name, **d.to_dict()}
    png = values.get("histogram")
    if png:
        from ..figures import histogram_figure, save_figure  # matplotlib only when asked

        fig = histogram_figure(
            d.histogram_counts,
            d.histogram_edges,
            f"Distribution of {desc_name}",
            desc_name,
            d.mean,
            d.std,
        )
        save_figure(fig, png)
        result["histogram"] = png
    if values.get("html"):
        with io.atomic_output(values["html"]) as tmp, open(tmp, "w", encoding="utf-8") as f:
            f.write(descriptives_html(d, desc_name, f"{path}, band {band}", png))
        result["html"] = values["html"]
    with io.atomic_output(values["output"]) as tmp, open(tmp, "w", encoding="utf-8") as f:
        json.dump(payload, f, indent=2, allow_nan=True)
    progress.info(
        f"N={d.n} mean={d.mean:.6g} (SE {d.se_mean:.4g}) std={d.std:.6g} "
        f"skewness={d.skewness:.4g} (SE {d.se_skewness:.3f}, z={d.z_skewness:.3g})"
    )
    result.update(n=d.n, mean=d.mean, std=d.std, skewness=d.skewness, se_skewness=d.se_skewness)
    return result


STATS = Algorithm(
    name="stats",
    display_name="Descriptive statistics (SPSS style)",
    group="Boresight ratio and statistics",
    short_help="N, mean and its SE, std, variance, skewness and kurtosis with SEs and z tests, 3σ outliers, histogram.",
    help=(
        "Descriptive statistics of one band as SPSS reports them (Table 1 of Brook & Ben-Dor "
        "2011): N, mean and its standard error, standard deviation, variance, skewness and "
        "kurtosis (bias-corrected G1, G2) with their standard errors and z tests, minimum, "
        "maximum, percentiles, the pixels beyond 3 standard deviations, and the histogram "
        "(Figure 3). Nodata pixels are ignored.\n\n"
        "Exact for flight lines of any length: the raster is read block by block and the "
        "moments merged exactly; percentiles are exact order statistics.\n\n"
        "Outputs: a JSON file (all numbers), optionally an HTML table and a histogram PNG."
    ),
    params=(
        RasterIn(name="input", description="Raster to describe (typically the boresight ratio)"),
        Band(name="band", description="Band number (1 = first)", default=1, raster="input"),
        Number(
            name="bins",
            description="Number of histogram bins",
            default=50,
            minimum=2,
            maximum=10000,
            integer=True,
        ),
        Text(
            name="percentiles",
            description="Percentiles to report, comma-separated (0–100)",
            default=",".join(f"{q:g}" for q in DEFAULT_PERCENTILES),
        ),
        BLOCK_ROWS,
        FileOut(name="output", description="Statistics as JSON", extension="json"),
        FileOut(
            name="html", description="Statistics as an HTML table", extension="html", optional=True
        ),
        FileOut(name="histogram", description="Histogram (PNG)", extension="png", optional=True),
    ),
    run=_run,
)

ALGORITHMS = (STATS,)
