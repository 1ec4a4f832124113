"""Small self-contained HTML pages (statistics tables, reports): no external assets.

Pages are Jinja2 templates in ``geoboresight/templates/`` with autoescaping on: every text and
value put in a page is escaped, only the templates' own markup is HTML. Figures are embedded
as ``data:`` URIs, so a page is one file that opens offline.

- ``page.html``: the document and the project's style (``style.css``);
- ``macros.html``: ``table``, ``image``, ``figure``, ``note``, ``descriptives`` (Table 1 of
  the paper) and ``section`` (of the scene report);
- ``stats.html``: the ``stats`` operation's page; ``report.html``: the scene report.
"""

from __future__ import annotations

import base64
import functools
import math

import jinja2
from markupsafe import Markup, escape


@functools.cache
def environment() -> jinja2.Environment:
    """The templates' environment (autoescaped; ``fmt`` and ``png_data`` filters)."""
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("geoboresight", "templates"),
        autoescape=True,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
        undefined=jinja2.StrictUndefined,
    )
    env.filters["fmt"] = format_value
    env.filters["png_data"] = png_data_uri
    return env


def render(template: str, **context) -> str:
    """Render one of the package's templates (e.g. ``"report.html"``) with ``context``."""
    return environment().get_template(template).render(**context)


def macro(name: str):
    """A macro of ``macros.html`` as a function returning :class:`~markupsafe.Markup`."""
    return getattr(environment().get_template("macros.html").module, name)


def format_value(value, digits: int = 4) -> str:
    """A value as the pages show it (plain text, escaped by the template).

    Floats with ``digits`` decimals and thousands separators, or in E notation when very
    large or small, "–" for NaN; whole numbers with thousands separators; yes/no for flags.
    """
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        if value != 0 and (abs(value) >= 1e7 or abs(value) < 1e-3):
            return f"{value:.{digits - 1}E}"
        return f"{value:,.{digits}f}"
    return f"{value:,}" if isinstance(value, int) else str(value)


def fmt(value, digits: int = 4) -> Markup:
    """:func:`format_value`, escaped for HTML."""
    return escape(format_value(value, digits))


def png_data_uri(path_or_bytes) -> str:
    """A PNG (a file path or its bytes) as a ``data:image/png;base64,...`` URI."""
    data = path_or_bytes
    if isinstance(path_or_bytes, str):
        with open(path_or_bytes, "rb") as f:
            data = f.read()
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii")


def page(title: str, body) -> str:
    """A whole HTML document with the project's style; ``body`` is trusted HTML (a
    :class:`~markupsafe.Markup`, e.g. from :func:`table`; plain strings are taken as HTML)."""
    return render("page.html", title=title, body=Markup(body))


def table(rows, caption: str = "", header=("", "")) -> Markup:
    """A two-column table of (label, value) rows."""
    return macro("table")(list(rows), caption, tuple(header))


def png_img(path_or_bytes, alt: str, width: int | None = None) -> Markup:
    """An <img> with the PNG embedded as base64, so the page is self-contained."""
    return macro("image")(png_data_uri(path_or_bytes), alt, width)


def descriptives_html(d, title: str, source: str, histogram_png: str | None) -> str:
    """The ``stats`` page: Table 1 of the paper (N, mean ± SE, std, variance, skewness and
    kurtosis ± SE), the z tests, 3σ outliers, range and percentiles, and the histogram.

    ``d`` is a :class:`geoboresight.stats.Descriptives` (or its ``to_dict()``), ``title`` the
    band's name, ``source`` where it was read, ``histogram_png`` the Figure 3 PNG or None.
    """
    return render(
        "stats.html",
        title=f"Descriptive statistics — {title}",
        d=d,
        table_title=title,
        source=source,
        histogram=png_data_uri(histogram_png) if histogram_png else None,
    )


__all__ = [
    "descriptives_html",
    "environment",
    "fmt",
    "format_value",
    "macro",
    "page",
    "png_data_uri",
    "png_img",
    "render",
    "table",
]
