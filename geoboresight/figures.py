"""Figures (PNG) shared by every application: one place for the backend, style and atomic save."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")  # headless: CLI, QGIS and CI have no display

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from .io.write import atomic_output  # noqa: E402


def new_figure(width: float = 6.4, height: float = 4.2):
    """A figure and axes with the project's style."""
    fig, ax = plt.subplots(figsize=(width, height), dpi=110, layout="constrained")
    ax.grid(True, alpha=0.3)
    return fig, ax


def save_figure(fig, path: str, overwrite: bool = True) -> str:
    """Save ``fig`` as PNG atomically (temp file then rename) and close it."""
    try:
        with atomic_output(path, overwrite=overwrite) as tmp:
            fig.savefig(tmp, format="png")
    finally:
        plt.close(fig)
    return path


def histogram_figure(counts, edges, title: str, xlabel: str, mean=None, std=None):
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
