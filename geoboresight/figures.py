"""Figures shared by every application: one place for their style.

Only matplotlib's object-oriented API is used: a :class:`matplotlib.figure.Figure` drawn by its
own Agg canvas. Matplotlib's state-machine interface and backend switch are never used: they
keep global state (the current figure, the backend of the whole process) that QGIS owns and
that Processing's worker threads must not touch, whereas a Figure with its own canvas is a
plain object, safe in any thread and garbage-collected like one (nothing to close).
"""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

#: Resolution of the project's figures (dots per inch).
DPI = 110


def decimated_shape(height: int, width: int, max_side: int) -> tuple[int, tuple[int, int]]:
    """``(step, (rows, cols))``: the smallest integer step that brings the longer side of a
    ``height × width`` raster to at most ``max_side``, and the shape drawn at that step (a
    figure shows a few hundred to a few thousand pixels a side, whatever the flight line)."""
    step = max(1, -(-max(height, width) // int(max_side)))
    return step, (-(-height // step), -(-width // step))


def blank_figure(
    width: float = 6.4, height: float = 4.2, *, dpi: float | None = DPI, layout="constrained"
) -> Figure:
    """A figure without axes, drawn by its own Agg canvas (``fig.subplots(...)``,
    ``fig.add_subplot(projection="3d")`` add them). ``dpi=None`` and ``layout=None`` give
    matplotlib's defaults."""
    kwargs = {"figsize": (width, height), "layout": layout}
    if dpi is not None:
        kwargs["dpi"] = dpi
    fig = Figure(**kwargs)
    FigureCanvasAgg(fig)
    return fig


def new_figure(width: float = 6.4, height: float = 4.2):
    """A figure and one axes with the project's style: ``(fig, ax)``."""
    fig = blank_figure(width, height)
    ax = fig.add_subplot()
    ax.grid(True, alpha=0.3)
    return fig, ax


def histogram_figure(counts, edges, title: str, xlabel: str, mean=None, std=None) -> Figure:
    """Figure 3 of the paper: the distribution of boresight values, with mean and ±3σ."""
    fig, ax = new_figure()
    edges = np.asarray(edges)
    ax.bar(
        edges[:-1],
        counts,
        width=np.diff(edges),
        align="edge",
        color="#4a7ab5",
        edgecolor="white",
        linewidth=0.3,
    )
    if mean is not None and np.isfinite(mean):
        ax.axvline(mean, color="black", lw=1.2, label=f"mean {mean:.4g}")
        if std is not None and np.isfinite(std):
            for s in (-3, 3):
                ax.axvline(mean + s * std, color="#c0392b", lw=1, ls="--")
            ax.plot([], [], color="#c0392b", ls="--", label="mean ± 3σ")
        ax.legend(loc="upper right")
    ax.set_title(title)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("Number of pixels")
    return fig


__all__ = ["DPI", "blank_figure", "histogram_figure", "new_figure"]
