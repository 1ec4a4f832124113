"""File-level scene report: one self-contained HTML page running every application of the paper."""

from __future__ import annotations

import os
import shutil

from .. import io
from ..dem.height import FlightGeometry
from ..io.dual import BandChoice, DualLayout
from ..io.write import temp_name


def report_file(
    vnir,
    swir=None,
    *,
    output,
    layout=DualLayout(),
    bands=BandChoice(),
    shadow_truth=None,
    target_truth=None,
    cloud_mask=None,
    geometry=FlightGeometry(),
    svdd=True,
    products=None,
    progress=None,
) -> dict:
    """Write an HTML report of one scene: ratio statistics, shadow, relative DEM, anomalies.

    Runs the operations (``ratio``, ``stats``, ``shadow-map``, ``shadow-classes``, ``shadow-cluster``,
    ``shadow-fraction-fit``, ``relative-dem``, ``view-3d``, ``boresight-indicator``, ``rx``,
    ``svdd``, ``roc``) on the values this operation's spec has checked, and lays out their
    figures and numbers (see :mod:`geoboresight.report.page`). A step that cannot run becomes
    a note in its section.

    Parameters
    ----------
    vnir : path or DualSensor
        VNIR file (ENVI or GeoTIFF), a merged VNIR+SWIR cube or a sensor product when ``swir``
        is None, or a dataset opened with :func:`geoboresight.open_dual` (its files are read
        again by each step, with ``layout``).
    swir : path, optional
        SWIR file on the same pixel grid.
    output : path
        The report: one HTML file with every figure embedded (it opens offline).
    layout : DualLayout
        How to read files that do not say it all (a merged cube's seam, band centres).
    bands : BandChoice
        The ratio's two bands.
    shadow_truth : path, optional
        Ground-truth shadow fraction (0–1) on the VNIR grid, for the Figure 5 fit.
    target_truth : path, optional
        Target mask or abundance on the VNIR grid, for the ROC curves (Figure 12).
    cloud_mask : path, optional
        Cloud mask on the VNIR grid (non-zero = cloud), left out of the relative DEM.
    geometry : FlightGeometry
        Relative DEM: the height-to-disparity factor tan θ / GSD (px per metre), or the
        squint (degrees), flying height (m) and IFOV (mrad); without them the DEM section
        says what is missing.
    svdd : bool
        Include the SVDD detector (slower) among the anomaly scores.
    products : path, optional
        Folder (created) to keep the intermediate rasters and figures in; by default they are
        made in ``<output>.work`` beside the report and deleted.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, and ``products`` when kept.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (Eq. 3, Table 1 and
    Figure 3; §3.1, Table 2, Figures 4 and 5; §3.2, Figure 9; §3.3, Figure 12).
    """
    from .page import build_report  # matplotlib and jinja2: loaded only for a report

    # The primary input must open (and carry wavelengths): a report of notes saying that
    # nothing could run would be a success in name only. Optional inputs given must open too
    # and lie on its grid.
    dual = io.as_dual(vnir, swir, layout)
    # The steps take the opened dataset and these values as they are (one opening, one
    # band choice and one geometry for every step).
    values = {
        "dual": dual,
        "layout": layout,
        "bands": bands,
        "geometry": geometry,
        "shadow_truth": shadow_truth,
        "target_truth": target_truth,
        "cloud_mask": cloud_mask,
        "svdd": svdd,
    }
    for label, path in (
        ("shadow_truth", shadow_truth),
        ("target_truth", target_truth),
        ("cloud_mask", cloud_mask),
    ):
        if path:
            with io.open_raster(path, label) as src:
                dual.grid.require_same(io.Grid.of(src), f"VNIR {dual.vnir.path}", f"{label} {path}")
    if products:
        os.makedirs(products, exist_ok=True)
        work = products
    else:
        # A new folder beside the output (same file system), named by io.write's temporary
        # pattern: never an existing folder of the user's, and swept if the run is killed.
        work = temp_name(os.path.abspath(output) + ".work")
        os.makedirs(work)
    try:
        io.write_text(output, build_report(values, work, progress))
    finally:
        if not products:
            shutil.rmtree(work, ignore_errors=True)
    result = {"output": output}
    if products:
        result["products"] = products
    return result
