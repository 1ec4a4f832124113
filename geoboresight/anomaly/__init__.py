"""Sub-pixel anomaly detection and unmixing (Brook & Ben-Dor 2011, §3.3).

Kernels on arrays: global/local RX (:mod:`.rx`), RBF SVDD (:mod:`.svdd`), the boresight-ratio
indicator (:mod:`.indicator`), linear unmixing with endmember libraries (:mod:`.unmix`), ROC
curves (:mod:`.roc`) and groups of flagged pixels (:mod:`.polygons`). Files (endmember
libraries, vector layers, ROC tables) are read and written by :mod:`geoboresight.io`. The functions
``rx.rx`` and ``unmix.unmix`` live in their modules (not re-exported: same names).

Names are imported on first use (PEP 562), so running RX does not load SciPy's image module
or scikit-learn.
"""

from importlib import import_module

_WHERE = {
    "ROC": "roc",
    "roc_curve": "roc",
    "roc_figure": "roc",
    "truth_mask": "roc",
    "CovarianceAccumulator": "rx",
    "GaussianStats": "rx",
    "RXDetector": "rx",
    "local_rx": "rx",
    "SVDDModel": "svdd",
    "fit_svdd": "svdd",
    "boresight_indicator": "indicator",
    "indicator_score": "indicator",
    "local_residual": "indicator",
    "robust_location": "indicator",
    "robust_zscore": "indicator",
    "label_anomalies": "polygons",
    "resample": "unmix",
    "select_endmembers": "unmix",
    "unmix_cube": "unmix",
}

__all__ = sorted(_WHERE)


def __getattr__(name):
    if name in _WHERE:
        return getattr(import_module(f".{_WHERE[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
