"""File-level ``info``: what a flight line is, as ``gdalinfo`` / ``rio info`` say it for a
raster (:func:`geoboresight.io.describe.describe_product`)."""

from __future__ import annotations

from .. import io
from ..io.describe import describe_product, format_description
from ..io.dual import BandChoice, DualLayout, DualSensor


def info_file(
    vnir,
    swir=None,
    *,
    output=None,
    layout=DualLayout(),
    bands=BandChoice(),
    progress=None,
) -> dict:
    """Describe a flight line: the sensor product recognised, each image's size, interleave,
    data type, units, wavelengths and bad bands, the dark reference, the two bands the boresight
    ratio would use, the geolocation found and the reader's notes. Reads metadata only.

    Parameters
    ----------
    vnir : path or DualSensor
        A file, folder or zip: a VNIR file, a merged VNIR+SWIR cube or a sensor product
        (Specim raw ENVI, HySpex, EnMAP L1B, PRISMA L1), or a dataset opened with
        :func:`geoboresight.open_dual`.
    swir : path, optional
        The SWIR file of a pair.
    output : path, optional
        The description as JSON.
    layout : DualLayout
        A merged cube's seam and band centres for files without any, as the operations use.
    bands : BandChoice
        The ratio's band choice whose bands are reported (nearest 920 and 1010 nm by default).
    progress : Progress, optional

    Returns
    -------
    dict
        The summary (``product``, ``lines``, ``samples``, ``vnir_bands``, ``swir_bands``, the
        ratio's bands and wavelengths, ``dark_source``), ``files`` (per file: product,
        images, geolocation, notes), ``ratio_error`` when the ratio's bands cannot be found,
        ``summary`` (the description as text, what the command line prints) and ``output``.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (Eq. 3: the bands
    reported are those of the boresight ratio).

    Examples
    --------
    >>> import geoboresight as gb
    >>> info = gb.info_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr")
    >>> info["lines"], info["samples"], info["vnir_bands"], info["swir_bands"]
    (192, 286, 96, 102)
    >>> print(info["summary"].splitlines()[-2])
    Boresight ratio: SWIR band 3 (1009.1 nm) / VNIR band 88 (922.0 nm)
    """
    if isinstance(vnir, DualSensor):
        vnir, swir = vnir.files[0], (vnir.files[1] if len(vnir.files) > 1 else None)
    description = describe_product(vnir, swir, layout, bands)
    progress.info(
        f"{description['product']}: {description['lines']} lines × {description['samples']} samples"
    )
    if output:
        io.write_json(output, description)
    return {
        **({"output": output} if output else {}),
        **description,
        "summary": format_description(description),
    }
