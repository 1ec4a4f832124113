"""Sub-pixel anomaly detection and unmixing (Brook & Ben-Dor 2011, §3.3).

Kernels on arrays: global/local RX (:mod:`.rx`), RBF SVDD (:mod:`.svdd`), the boresight-ratio
indicator (:mod:`.indicator`), linear unmixing with endmember libraries (:mod:`.unmix`), ROC
curves (:mod:`.roc`) and score maps to vector features (:mod:`.polygons`). The functions
``rx.rx`` and ``unmix.unmix`` live in their modules (not re-exported: same names).
"""

from .indicator import boresight_indicator, robust_zscore
from .roc import ROC, roc_curve, truth_mask
from .rx import CovarianceAccumulator, GaussianStats, RXDetector, local_rx
from .svdd import SVDDModel, fit_svdd
from .unmix import read_library, resample

__all__ = [
    "ROC",
    "CovarianceAccumulator",
    "GaussianStats",
    "RXDetector",
    "SVDDModel",
    "boresight_indicator",
    "fit_svdd",
    "local_rx",
    "read_library",
    "resample",
    "robust_zscore",
    "roc_curve",
    "truth_mask",
]
