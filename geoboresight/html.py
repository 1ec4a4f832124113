"""Small self-contained HTML pages (statistics tables, reports): no external assets."""

from __future__ import annotations

import base64
import html
import math

_STYLE = """
body{font-family:system-ui,sans-serif;margin:2em;color:#222}
table{border-collapse:collapse;margin:1em 0}
th,td{border:1px solid #bbb;padding:4px 10px;text-align:right}
th{background:#eef2f7}
td.l,th.l{text-align:left}
caption{font-weight:bold;text-align:left;margin-bottom:4px}
.note{color:#555;font-size:90%}
"""


def page(title: str, body: str) -> str:
    """A whole HTML document with the project's style."""
    return (
        "<!DOCTYPE html><html><head><meta charset='utf-8'>"
        f"<title>{html.escape(title)}</title><style>{_STYLE}</style></head>"
        f"<body><h1>{html.escape(title)}</h1>{body}</body></html>"
    )


def fmt(value, digits: int = 4) -> str:
    if isinstance(value, float):
        if math.isnan(value):
            return "–"
        if value != 0 and (abs(value) >= 1e7 or abs(value) < 1e-3):
            return f"{value:.{digits - 1}E}"
        return f"{value:,.{digits}f}"
    return html.escape(f"{value:,}" if isinstance(value, int) else str(value))


def table(rows: list[tuple[str, object]], caption: str = "", header=("", "")) -> str:
    """A two-column table of (label, value)."""
    cap = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    head = f"<tr><th class='l'>{html.escape(header[0])}</th><th>{html.escape(header[1])}</th></tr>"
    body = "".join(
        f"<tr><td class='l'>{html.escape(k)}</td><td>{fmt(v)}</td></tr>" for k, v in rows
    )
    return f"<table>{cap}{head}{body}</table>"


def png_img(path_or_bytes, alt: str, width: int | None = None) -> str:
    """An <img> with the PNG embedded as base64, so the page is self-contained."""
    data = path_or_bytes
    if isinstance(path_or_bytes, str):
        with open(path_or_bytes, "rb") as f:
            data = f.read()
    b64 = base64.b64encode(data).decode("ascii")
    w = f" width='{width}'" if width else ""
    return f"<img alt='{html.escape(alt)}' src='data:image/png;base64,{b64}'{w}>"
