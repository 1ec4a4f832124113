"""Figures of the shadow application: Figure 4 (scatter with the shadow cluster outlined) and
Figure 5(B) (shadow fraction vs boresight ratio with the fitted line).

Drawn with matplotlib's object-oriented API only, on :func:`geoboresight.figures.new_figure`
(a Figure with its own Agg canvas; no pyplot); saved by :func:`geoboresight.io.write.save_figure`.
"""

from __future__ import annotations

import numpy as np

from ..figures import new_figure
from .cluster import ShadowCluster
from .fraction import FractionModel


def cluster_figure(ratio, nir, is_shadow, cluster: ShadowCluster, nir_nm: float, title: str = ""):
    """Figure 4: boresight ratio vs the 941 nm band, shadow pixels in red, the cluster's 2σ
    ellipse outlined."""
    fig, ax = new_figure(6.4, 4.8)
    ratio, nir = np.asarray(ratio), np.asarray(nir)
    s = np.asarray(is_shadow, bool)
    ax.scatter(ratio[~s], nir[~s], s=2, c="#4a7ab5", alpha=0.35, lw=0, label="other pixels")
    ax.scatter(ratio[s], nir[s], s=2, c="#c0392b", alpha=0.5, lw=0, label="shadow cluster")
    ex, ey = cluster.ellipse(2.0)
    ax.plot(ex, ey, color="#c0392b", lw=1.6, label="shadow component (2σ)")
    from matplotlib.ticker import ScalarFormatter

    ax.set_xscale("log")
    ax.set_yscale("log")
    for axis in (ax.xaxis, ax.yaxis):
        axis.set_major_formatter(ScalarFormatter())
        axis.set_minor_formatter(ScalarFormatter())
    ax.set_xlabel("Boresight band ratio value")
    ax.set_ylabel(f"VNIR band ({nir_nm:.0f} nm)")
    ax.set_title(
        title
        or f"Shadow cluster ({cluster.n_components}-component mixture): "
        f"{100 * cluster.shadow_share:.1f} % of pixels"
    )
    ax.legend(loc="best", markerscale=4, fontsize=8)
    return fig


def regression_figure(fraction, ratio, model: FractionModel, paper: FractionModel | None = None):
    """Figure 5(B): boresight ratio of detected shadow pixels vs ground-truth shadow fraction."""
    fig, ax = new_figure()
    ax.scatter(fraction, ratio, s=3, c="#4a7ab5", alpha=0.4, lw=0, label="pixels fitted")
    x = np.linspace(0, 1, 50)
    ax.plot(
        x,
        model.ratio(x),
        color="#c0392b",
        lw=1.6,
        label=f"y = {model.slope:.3g}x + {model.intercept:.3g}; R² = {model.r2:.3f}",
    )
    if paper is not None:
        ax.plot(
            x,
            paper.ratio(x),
            color="grey",
            ls="--",
            lw=1,
            label=f"paper: y = {paper.slope:g}x + {paper.intercept:g}",
        )
    ax.set_xlim(0, 1)
    ax.set_xlabel("Shadow fraction (ground truth)")
    ax.set_ylabel("Boresight band ratio value")
    ax.set_title(f"Shadow-fraction model (Figure 5B), n = {model.n}")
    ax.legend(loc="best", fontsize=8)
    return fig
