"""GCPs for an image: read (their CRS from the file or the user), every enabled one inside the
image, for the operations that fit a geometry to them (``georeference``, ``auto-georeference``,
``boresight-calibrate``)."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..georef.transforms import outside_image
from ..io.georef import read_gcps


def read_image_gcps(gcps: str, gcp_crs, width: int, height: int):
    """The GCP table of ``gcps`` (:func:`geoboresight.io.georef.read_gcps`) for an image of
    ``width`` × ``height``: refused when it names no CRS, or when an enabled GCP lies outside
    the image (naming it)."""
    table = read_gcps(gcps, crs=gcp_crs)
    if table.crs is None:
        raise InputError(
            f"GCP file {gcps} names no CRS: add a '# CRS: EPSG:...' line or give --gcp-crs"
        )
    out = outside_image(table.pixel_line, width, height) & table.enabled
    if out.any():
        raise InputError(
            f"GCP file {gcps}: GCP(s) {', '.join(str(i + 1) for i in np.flatnonzero(out))} lie "
            f"outside the input ({width} × {height} pixels × lines): check their pixel and line"
        )
    return table


__all__ = ["read_image_gcps"]
