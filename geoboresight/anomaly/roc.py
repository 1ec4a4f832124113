"""ROC curves: probability of detection against probability of false alarm (paper Figure 12).

For a score map and a truth mask, every distinct score is a threshold; Pd is the fraction of
target pixels at or above it, Pfa the fraction of background pixels at or above it. The curve
and its area (AUC, trapezoids) are computed exactly as ``sklearn.metrics.roc_curve``
(``drop_intermediate=False``) and ``roc_auc_score``. Pd at a fixed Pfa is the best Pd among
thresholds whose Pfa does not exceed it (no interpolation: an achievable operating point).
"""

from __future__ import annotations

import csv
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..errors import InputError


@dataclass(frozen=True)
class ROC:
    pfa: np.ndarray
    pd: np.ndarray
    thresholds: np.ndarray
    auc: float
    n_targets: int
    n_background: int

    def pd_at(self, pfa: float) -> float:
        """Best Pd with Pfa ≤ ``pfa``."""
        ok = self.pfa <= pfa + 1e-15
        return float(self.pd[ok].max()) if ok.any() else 0.0

    def thinned(self, max_points: int = 2000):
        """Indexes of at most ~``max_points`` curve points (log-spaced in Pfa, ends kept)."""
        n = self.pfa.size
        if n <= max_points:
            return np.arange(n)
        targets = np.concatenate([[0.0], np.logspace(-7, 0, max_points - 2)])
        idx = np.searchsorted(self.pfa, targets, side="right") - 1
        return np.unique(np.clip(np.concatenate([[0, n - 1], idx]), 0, n - 1))


def truth_mask(
    truth: np.ndarray, threshold: float | None = None, guard_px: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """(targets, background) masks from a truth mask or an abundance raster.

    ``threshold``: a pixel is a target when its value is ≥ threshold (default: > 0).
    ``guard_px``: pixels within this distance of a target are neither (excluded from both),
    as is usual for sub-pixel targets whose signal spills into neighbours.
    """
    t = np.asarray(truth, dtype=np.float64)
    ok = np.isfinite(t)
    with np.errstate(invalid="ignore"):
        targets = (t >= threshold) if threshold is not None else (t > 0)
    targets &= ok
    background = ok & ~targets
    if guard_px > 0:
        near = ndimage.binary_dilation(targets, iterations=int(guard_px), structure=np.ones((3, 3)))
        background &= ~near
    return targets, background


def roc_curve(scores: np.ndarray, targets: np.ndarray, background: np.ndarray) -> ROC:
    """ROC of one score map (higher = more anomalous); NaN scores are left out."""
    s = np.asarray(scores, dtype=np.float64)
    use = (targets | background) & np.isfinite(s)
    y = targets[use]
    v = s[use]
    n_pos = int(y.sum())
    n_neg = int(y.size - n_pos)
    if n_pos == 0:
        raise InputError(
            "the truth has no target pixels inside the valid area (an all-zero mask, or a "
            "threshold above every abundance): ROC needs targets; check the truth raster and "
            "its threshold"
        )
    if n_neg == 0:
        raise InputError("the truth marks every valid pixel as a target: ROC needs background")
    order = np.argsort(v, kind="mergesort")[::-1]
    v = v[order]
    y = y[order]
    distinct = np.flatnonzero(np.diff(v)) if v.size > 1 else np.array([], int)
    ends = np.r_[distinct, y.size - 1]
    tps = np.cumsum(y)[ends]
    fps = (ends + 1) - tps
    pd = np.r_[0.0, tps / n_pos]
    pfa = np.r_[0.0, fps / n_neg]
    thr = np.r_[np.inf, v[ends]]
    auc = float(np.sum(np.diff(pfa) * (pd[1:] + pd[:-1]) / 2.0))
    return ROC(pfa, pd, thr, auc, n_pos, n_neg)


def write_curves_csv(path: str, curves: dict[str, ROC], max_points: int = 2000) -> None:
    """Long-format CSV: detector, pfa, pd, threshold (thinned to ~max_points per detector)."""
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["detector", "pfa", "pd", "threshold"])
        for name, c in curves.items():
            for i in c.thinned(max_points):
                w.writerow([name, f"{c.pfa[i]:.8g}", f"{c.pd[i]:.8g}", f"{c.thresholds[i]:.8g}"])


def plot_roc(
    path: str, curves: dict[str, ROC], title: str = "ROC", pfa_marker: float = 1e-3
) -> None:
    """One PNG with all detectors' Pd vs Pfa (log Pfa axis), AUC and Pd@Pfa in the legend."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.4))
    for name, c in curves.items():
        i = c.thinned(4000)
        label = f"{name} (AUC {c.auc:.3f}, Pd {c.pd_at(pfa_marker):.2f} @ Pfa {pfa_marker:g})"
        for ax in axes:
            ax.plot(c.pfa[i], c.pd[i], drawstyle="steps-post", label=label)
    lo = min(max(1.0 / max(c.n_background, 1), 1e-7) for c in curves.values())
    axes[0].set_xlim(0, 1)
    axes[1].set_xscale("log")
    axes[1].set_xlim(lo, 1)
    axes[1].axvline(pfa_marker, color="0.6", lw=0.8, ls="--")
    for ax, sub in zip(axes, ("linear Pfa", "log Pfa"), strict=True):
        ax.set_ylim(0, 1.02)
        ax.set_xlabel("Probability of false alarm (Pfa)")
        ax.set_ylabel("Probability of detection (Pd)")
        ax.set_title(sub, fontsize=9)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower right")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
