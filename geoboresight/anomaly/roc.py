"""ROC curves: probability of detection against probability of false alarm (paper Figure 12).

For a score map and a truth mask, every distinct score is a threshold; Pd is the fraction of
target pixels at or above it, Pfa the fraction of background pixels at or above it. The curve
is ``sklearn.metrics.roc_curve`` (``drop_intermediate=False``: every threshold kept) and its
area ``sklearn.metrics.auc`` (trapezoids). Pd at a fixed Pfa is the best Pd among thresholds
whose Pfa does not exceed it (no interpolation: an achievable operating point).

SciPy's image module, scikit-learn and matplotlib are imported on first use.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: False-alarm rate at which Pd is reported by default.
PFA = 1e-3
#: Default figure title.
TITLE = "ROC: anomaly detectors"


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
    truth: np.ndarray,
    valid: np.ndarray | None = None,
    *,
    threshold: float | None = None,
    guard_px: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """(targets, background) masks from a truth mask or an abundance raster.

    ``valid``: pixels outside it (and non-finite truth values) are neither target nor
    background. ``threshold``: a pixel is a target when its value is ≥ threshold (default:
    > 0). ``guard_px``: pixels within this distance of a target are neither, as is usual for
    sub-pixel targets whose signal spills into neighbours.
    """
    t = np.asarray(truth, dtype=np.float64)
    ok = np.isfinite(t) if valid is None else (valid & np.isfinite(t))
    with np.errstate(invalid="ignore"):
        targets = (t >= threshold) if threshold is not None else (t > 0)
    targets &= ok
    background = ok & ~targets
    if guard_px > 0:
        from scipy import ndimage

        near = ndimage.binary_dilation(targets, iterations=int(guard_px), structure=np.ones((3, 3)))
        background &= ~near
    return targets, background


def roc_curve(scores: np.ndarray, targets: np.ndarray, background: np.ndarray) -> ROC:
    """ROC of one score map (higher = more anomalous); NaN scores are left out.

    Parameters
    ----------
    scores : array
        Detector scores (RX, SVDD, boresight indicator, …), higher = more anomalous.
    targets : bool array
        Target pixels (same shape), e.g. from :func:`truth_mask`.
    background : bool array
        Background pixels (same shape); pixels in neither mask are left out.

    Returns
    -------
    ROC
        ``pfa`` and ``pd`` (probability of false alarm and of detection, one point per distinct
        score, from (0, 0) to (1, 1)), the decreasing score ``thresholds`` (the first, +inf,
        flags nothing), the area under the curve ``auc`` (trapezoids) and the numbers of
        target and background pixels used; :meth:`ROC.pd_at` gives Pd at a fixed Pfa.

    Raises
    ------
    InputError
        When no target or no background pixel has a finite score.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§3.3, Figure 12: ROC
    performance of the global RX, SVDD and boresight band detectors).
    Fawcett, T. An introduction to ROC analysis. Pattern Recognit. Lett. 2006, 27, 861–874.

    Examples
    --------
    >>> import numpy as np
    >>> import geoboresight as gb
    >>> scores = np.array([0.1, 0.4, 0.35, 0.8, 0.9])
    >>> targets = np.array([False, False, False, True, True])
    >>> gb.roc_curve(scores, targets, ~targets).auc  # every target above every background pixel
    1.0
    """
    from sklearn import metrics

    s = np.asarray(scores, dtype=np.float64)
    use = (targets | background) & np.isfinite(s)
    y = targets[use]
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
    pfa, pd, thr = metrics.roc_curve(y, s[use], drop_intermediate=False)
    return ROC(pfa, pd, thr, float(metrics.auc(pfa, pd)), n_pos, n_neg)


def roc_figure(curves: dict[str, ROC], title: str = TITLE, pfa_marker: float = PFA):
    """Pd against Pfa of every detector (linear and logarithmic Pfa), AUC and Pd at
    ``pfa_marker`` in the legend: a matplotlib Figure (object-oriented API, no pyplot)."""
    from ..figures import blank_figure

    fig = blank_figure(10, 4.4, dpi=120, layout=None)
    axes = fig.subplots(1, 2)
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
    # Laid out at matplotlib's default 100 dpi, drawn at 120 dpi (as the figure always was).
    fig.set_dpi(100)
    fig.tight_layout()
    fig.set_dpi(120)
    return fig
