"""What the operations that fit a geometry to ground control share (``georeference``,
``auto-georeference``, ``boresight-calibrate``): GCPs for an image (their CRS from the file or
the user, every enabled one inside the image) and the check of a reference orthophoto."""

from __future__ import annotations

import numpy as np

from ..errors import InputError, ParameterError
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


def check_reference(ref, reference, reference_band: int) -> None:
    """Refuse a reference orthophoto (``ref``, open; ``reference``, its name) without a CRS or
    geotransform, or without band ``reference_band``."""
    if ref.crs is None or ref.transform.is_identity:
        raise InputError(
            f"reference {reference} has no CRS or geotransform: give an orthophoto with its "
            "CRS (e.g. a GeoTIFF)"
        )
    if not 1 <= reference_band <= ref.count:
        raise ParameterError(
            f"parameter 'reference_band': band {reference_band} does not exist in "
            f"{reference}, which has {ref.count} band(s)"
        )


__all__ = ["check_reference", "read_image_gcps"]
