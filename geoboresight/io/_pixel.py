"""The pixel function GDAL calls to read a raw capture as radiance on the fly
(:func:`geoboresight.io.radiance.radiance_image`): one derived VRT band per band,
``(DN − dark) · gain / tint`` with NumPy, over the capture's own bytes and its coefficients.

GDAL runs Python pixel functions only from modules it is told to trust
(``GDAL_VRT_PYTHON_TRUSTED_MODULES``; GDAL's default ``GDAL_VRT_ENABLE_PYTHON =
TRUSTED_MODULES``): :func:`trust` adds this module, and nothing else, to that list. Where the
user has turned Python pixel functions off, the radiance VRT is built from GDAL's own ``sum``
and ``mul`` functions instead (two levels, slower).
"""

from __future__ import annotations

import os

import numpy as np

#: The name GDAL imports this module by.
MODULE = __name__
_TRUSTED = "GDAL_VRT_PYTHON_TRUSTED_MODULES"


def trust() -> None:
    """Add this module to GDAL's trusted pixel-function modules (the user's own kept)."""
    names = [m for m in os.environ.get(_TRUSTED, "").split(",") if m]
    if MODULE not in names:
        os.environ[_TRUSTED] = ",".join([*names, MODULE])


def python_allowed() -> bool:
    """Whether GDAL may run this module's pixel function (the user has not set
    ``GDAL_VRT_ENABLE_PYTHON`` to NO)."""
    return os.environ.get("GDAL_VRT_ENABLE_PYTHON", "TRUSTED_MODULES").upper() not in (
        "NO",
        "FALSE",
        "OFF",
        "0",
    )


def radiance(in_ar, out_ar, *args, **kwargs) -> None:
    """GDAL pixel function: ``out = (DN − dark) · scale`` (sources: DN, dark, gain / tint);
    a saturated DN arrives as NaN (its source's NODATA) and stays NaN."""
    dn, dark, scale = in_ar
    np.subtract(dn, dark, out=out_ar, casting="unsafe")
    out_ar *= scale


__all__ = ["MODULE", "python_allowed", "radiance", "trust"]
