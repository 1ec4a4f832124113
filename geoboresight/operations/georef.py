"""File-level georeferencing: put raw-geometry products on a map grid (from an IGM, a GLT or
GDAL geolocation arrays; from GCPs; from automatic tie points to an orthophoto), put a product
onto a reference raster's grid, and simulate a jittered line with its orthophoto and IGM.

Every raster warp goes through GDAL (rasterio's ``reproject``: the geolocation-array warper
for raw products, the affine warper for map products): the models here only produce the map
coordinates of every raw pixel.
"""

from __future__ import annotations

import os

import numpy as np

from ..errors import InputError, ParameterError
from ..georef.geoloc import clean_igm, corner_geoloc, glt_indices
from ..georef.tiepoints import TieMatching, corrected, match_tie_points
from ..georef.transforms import fit_transform
from ..io import georef
from ..io.grid import OutputGrid
from ..io.image import open_raster
from ..io.write import write_json
from ..simulate.ortho import HEADING_DEG, JITTER_DEG, JITTER_LINES, ORTHO_CELL
from ._gcps import check_reference, read_image_gcps
from ._glt import glt_for

REFERENCES = """
    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (section 2: raw AISA-Dual
    lines "geo-rectified by conventional methods"; Figure 10: overlay on a topographic map and
    the national orthophoto)."""


def _docstring(func):
    func.__doc__ = (func.__doc__ or "").rstrip() + "\n" + REFERENCES + "\n"
    return func


def _product_size(path: str) -> tuple[int, int]:
    """Columns and lines of a raw product: a raster, or a sensor product's image."""
    with open_raster(path, "input") as src:
        return src.width, src.height


def _model_geoloc(model, width: int, height: int, src_crs, dst_crs):
    """Pixel-centre coordinates and the (lines + 1, columns + 1) pixel-corner geolocation
    array (:func:`~geoboresight.georef.geoloc.corner_geoloc`) of a model
    ``(pixel, line) -> (x, y)``, in ``dst_crs``."""
    jj, ii = np.meshgrid(np.arange(width, dtype="float64"), np.arange(height, dtype="float64"))
    cx, cy = georef.transform_xy(*model(jj + 0.5, ii + 0.5), src_crs, dst_crs)
    kk, ll = np.meshgrid(
        np.arange(width + 1, dtype="float64"), np.arange(height + 1, dtype="float64")
    )
    gx, gy = georef.transform_xy(*model(kk, ll), src_crs, dst_crs)
    return cx, cy, np.stack([gx, gy])


def _warp_model(input, output, model, src_crs, to: OutputGrid, tags, progress, igm_output):
    width, height = _product_size(input)
    dst_crs = georef.output_crs(
        to.crs, src_crs, *model(np.array([width / 2]), np.array([height / 2]))
    )
    cx, cy, geoloc = _model_geoloc(model, width, height, src_crs, dst_crs)
    ok = np.isfinite(cx) & np.isfinite(cy)
    grid = georef.map_grid(cx, cy, ok, dst_crs, to.resolution)
    done = georef.warp_geoloc(
        input,
        output,
        geoloc,
        grid,
        source_valid=None,
        resampling=to.resampling,
        tags=tags,
        progress=progress,
    )
    if igm_output:
        georef.write_igm(igm_output, cx, cy, dst_crs, tags)
    return grid, done


def _grid_result(grid, done: dict) -> dict:
    return {
        "crs": grid.crs.to_string(),
        "resolution": float(grid.transform.a),
        "width": grid.width,
        "height": grid.height,
        **done,
    }


@_docstring
def geolocate_file(
    input,
    igm=None,
    glt=None,
    *,
    output,
    igm_crs=None,
    grid=OutputGrid(),
    progress=None,
) -> dict:
    """Put a raw-geometry product on a map grid with the per-pixel coordinates a processing
    chain made.

    Parameters
    ----------
    input : path
        Any raw-geometry raster (ratio, classes, DEM, scores, a cube).
    igm : path, optional
        An IGM (ENVI or GeoTIFF; band 1 easting, band 2 northing of every raw pixel's centre,
        as APL, CaliGeoPRO or gref4hsi write it) or a dataset with GDAL geolocation arrays.
        Neither ``igm`` nor ``glt``: the product's own GDAL geolocation arrays.
    glt : path, optional
        A geometry lookup table (AVIRIS, EMIT): one-based sample and line on a map grid.
    output : path
        GeoTIFF on a north-up grid in ``crs``; nodata outside the footprint.
    igm_crs : str, optional
        CRS of the IGM or GLT when its header carries none (or to override it).
    grid : OutputGrid
        The output's CRS (the IGM's by default, its UTM zone when it is in degrees; coordinates transformed with pyproj), cell
        size (0: the median pixel spacing) and resampling (``auto``: nearest for class
        rasters, bilinear otherwise). A GLT fixes the map grid (give no CRS nor cell size)
        and is looked up nearest.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the grid (CRS, resolution, size), the resampling and the pixels masked in
        the IGM (NaN, non-monotonic).

    Examples
    --------
    The sample scene's boresight ratio on the map, with the scene's IGM:

    >>> import geoboresight as gb
    >>> _ = gb.ratio_file(
    ...     "sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr", output="out/ratio.tif"
    ... )
    >>> result = gb.geolocate_file(
    ...     "out/ratio.tif", igm="sample_data/scene/igm.tif", output="out/ratio_map.tif"
    ... )
    >>> result["crs"], result["resolution"], result["width"], result["height"]
    ('EPSG:32636', 1.5, 346, 323)
    """
    if igm and glt:
        raise ParameterError("give either --igm or --glt, not both")
    width, height = _product_size(input)
    if glt:
        table = glt_for(glt, f"input {input}", width=width, height=height, crs=igm_crs)
        rows, cols, ok, _ = glt_indices(
            table.sample, table.line, table.valid, width=width, height=height
        )
        if grid.crs or grid.resolution:
            raise ParameterError(
                "--crs and --resolution do not apply to a GLT (its map grid is fixed): use "
                "reproject-to afterwards"
            )
        done = georef.lookup_glt(
            input,
            output,
            table,
            rows,
            cols,
            ok,
            tags={"GEOREFERENCE": f"GLT {glt}"},
            progress=progress,
        )
        progress.info(f"GLT lookup: {done['valid_pixels']} map cells filled")
        return {"output": output, **_grid_result(table.grid, {**done, "resampling": "nearest"})}
    coords = georef.coordinates_for(input, igm, igm_crs)
    if coords.x.shape != (height, width):
        raise InputError(
            f"IGM {coords.path} is {coords.x.shape[1]} × {coords.x.shape[0]} (columns × lines) but "
            f"input {input} is {width} × {height}: the IGM must belong to this product"
        )
    dst_crs = georef.output_crs(grid.crs, coords.crs, coords.x, coords.y)
    x, y = georef.transform_xy(coords.x, coords.y, coords.crs, dst_crs)
    try:
        clean = clean_igm(x, y)
    except InputError as exc:
        raise InputError(f"IGM {coords.path}: {exc}") from None
    if clean.nan or clean.non_monotonic:
        progress.info(
            f"IGM {coords.path}: {clean.nan} pixel(s) without coordinates (NaN or nodata) and "
            f"{clean.non_monotonic} non-monotonic pixel(s) masked (left as nodata)"
        )
    on = georef.map_grid(clean.x, clean.y, clean.valid, dst_crs, grid.resolution)
    done = georef.warp_geoloc(
        input,
        output,
        corner_geoloc(clean.x, clean.y),
        on,
        source_valid=clean.valid,
        resampling=grid.resampling,
        tags={"GEOREFERENCE": coords.source},
        progress=progress,
    )
    return {
        "output": output,
        **_grid_result(on, done),
        "masked_nan": clean.nan,
        "masked_non_monotonic": clean.non_monotonic,
    }


@_docstring
def georeference_file(
    input,
    gcps,
    *,
    output,
    report=None,
    igm_output=None,
    gcp_crs=None,
    method="polynomial",
    order=1,
    grid=OutputGrid(),
    progress=None,
) -> dict:
    """Georeference a raw-geometry product from ground control points (no navigation data).

    Parameters
    ----------
    input : path
        Any raw-geometry raster.
    gcps : path
        GCPs: a CSV with columns ``pixel,line,x,y`` (pixel coordinates as GDAL's: the
        top-left corner of the image is 0,0; a ``# CRS: EPSG:...`` line gives the CRS) or a
        QGIS Georeferencer ``.points`` file.
    output : path
        GeoTIFF on a north-up grid.
    report : path, optional
        JSON report: the model, RMSE and each GCP's residual (map units and pixels).
    gcp_crs : str, optional
        CRS of the GCPs' map coordinates when the file names none (or to override it).
    method : {"polynomial", "tps"}
        Polynomial of ``order`` (least squares) or thin-plate spline (exact at the GCPs;
        cross-validated residuals).
    order : {1, 2, 3}
        Polynomial order: needs 3, 6 or 10 GCPs.
    grid : OutputGrid
        The output's CRS (the GCPs' by default), cell size (0: the median pixel spacing of
        the model) and resampling (``auto``: nearest for class rasters, bilinear otherwise).
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, ``report``, the RMSE (map units and pixels) and the grid.
    """
    width, height = _product_size(input)
    table = read_image_gcps(gcps, gcp_crs, width, height)
    fit = fit_transform(
        table.pixel_line,
        table.xy,
        table.enabled,
        method=method,
        order=int(order),
        label=f"GCP file {gcps}",
    )
    what = f"{method}" + (f" order {fit.order}" if fit.order else "")
    progress.info(
        f"{what} on {int(table.enabled.sum())} GCPs: RMSE {fit.rmse:.3f} ({fit.rmse_px:.2f} px)"
    )
    warnings = []
    if fit.repeated:
        # An exact copy adds nothing a least-squares fit minds; a spline takes each point once.
        done_with = "left out of the thin-plate spline" if method == "tps" else "kept"
        warnings.append(
            f"GCP file {gcps}: GCP(s) {', '.join(map(str, fit.repeated))} repeat an earlier "
            f"GCP exactly (same image position and map point): {done_with}"
        )
        progress.info(warnings[-1])
    tags = {"GEOREFERENCE": f"GCPs {gcps}: {what}, RMSE {fit.rmse:.4g} ({fit.rmse_px:.3f} px)"}
    on, done = _warp_model(input, output, fit, table.crs, grid, tags, progress, igm_output)
    if report:
        write_json(
            report,
            {
                "input": os.fspath(input),
                "gcps": os.fspath(gcps),
                "crs": table.crs.to_string(),
                **fit.report(),
            },
        )
    return {
        "output": output,
        "report": report,
        "igm_output": igm_output,
        "rmse": fit.rmse,
        "rmse_px": fit.rmse_px,
        **_grid_result(on, done),
        **({"warnings": warnings} if warnings else {}),
    }


def _placement(input, gcps, corners, gcp_crs, ref_crs, width, height):
    """The rough placement, in the reference's CRS: an affine fit to the corners or to the
    GCPs (second order from six GCPs)."""
    if bool(gcps) == bool(corners):
        raise ParameterError("give the rough placement as either --gcps or --corners (one of them)")
    if gcps:
        table = read_image_gcps(gcps, gcp_crs or ref_crs.to_wkt(), width, height)
        pl, xy, ok, src_crs, label = (
            table.pixel_line,
            table.xy,
            table.enabled,
            table.crs,
            f"GCP file {gcps}",
        )
    else:
        pl, xy = georef.corner_gcps(corners, width, height)
        ok, label = None, "parameter 'corners'"
        src_crs = georef.parse_crs(gcp_crs, "parameter 'gcp_crs'") if gcp_crs else ref_crs
    x, y = georef.transform_xy(xy[:, 0], xy[:, 1], src_crs, ref_crs)
    n = len(pl) if ok is None else int(np.sum(ok))
    return fit_transform(pl, np.column_stack([x, y]), ok, order=2 if n >= 6 else 1, label=label)


def _reference_window(reference, reference_band, placement, width, height, margin_px):
    """The reference band around the rough footprint (a large orthophoto is read in part)."""
    with open_raster(reference, "reference") as ref:
        check_reference(ref, reference, reference_band)
        t = np.linspace(0, 1, 33)
        edge_p = np.concatenate([t * width, np.full(33, width), t * width, np.zeros(33)])
        edge_l = np.concatenate([np.zeros(33), t * height, np.full(33, height), t * height])
        ex, ey = placement(edge_p, edge_l)
        cx, cy = placement(
            np.array([width / 2, width / 2 + 1, width / 2]),
            np.array([height / 2, height / 2, height / 2 + 1]),
        )
        pixel = 0.5 * (
            np.hypot(cx[1] - cx[0], cy[1] - cy[0]) + np.hypot(cx[2] - cx[0], cy[2] - cy[0])
        )
        # Room for the placement's error, plus a few reference cells for the interpolation.
        pad = 2 * margin_px * pixel + 4 * max(abs(ref.transform.a), abs(ref.transform.e))
        bounds = (ex.min() - pad, ey.min() - pad, ex.max() + pad, ey.max() + pad)
        win = georef.reference_window(ref, bounds, reference)
        data = ref.read(reference_band, window=win, masked=True)
        return (
            np.ma.getdata(data).astype("float64"),
            ~np.ma.getmaskarray(data),
            tuple(ref.window_transform(win))[:6],
            ref.crs,
        )


@_docstring
def auto_georeference_file(
    input,
    reference,
    gcps=None,
    *,
    output,
    report=None,
    igm_output=None,
    corners=None,
    gcp_crs=None,
    band=1,
    band_nm=None,
    reference_band=1,
    matching=TieMatching(),
    grid=OutputGrid(),
    progress=None,
) -> dict:
    """Georeference a raw-geometry product on a reference orthophoto by automatic tie points.

    A rough placement (a few GCPs or the four corners' coordinates) puts the orthophoto into
    the product's raw geometry; SIFT or ORB features (scikit-image) are matched between one
    product band and one orthophoto band, RANSAC per block of lines keeps the consistent
    ones, and a piecewise model (affine per block of lines, blended, or a thin-plate spline)
    follows the line's attitude wobble (:mod:`geoboresight.georef.tiepoints`). The run is
    refused, writing nothing, when fewer than ``matching.min_inliers`` tie points survive or
    their cross-validated RMSE exceeds ``matching.max_rmse_px``.

    Parameters
    ----------
    input : path
        Raw-geometry raster (a VNIR cube or any product with texture).
    reference : path
        Orthophoto with a CRS and geotransform.
    gcps : path, optional
        Rough placement from GCPs (CSV or QGIS ``.points``); or give ``corners``.
    output : path
        GeoTIFF of every band of ``input`` on a north-up grid.
    igm_output : path, optional
        The fitted model's IGM: a float64 GeoTIFF with the map x and y of every raw pixel's
        centre (raw geometry, the CRS in its header), for ``geolocate --igm`` on the line's
        other products.
    report : path, optional
        JSON report: matches, inliers, each tie point's cross-validated residual, RMSE.
    corners : str, optional
        Rough placement from the corners: ``x,y`` of the top-left, top-right, bottom-right
        and bottom-left image corners (8 numbers, in ``gcp_crs`` or the reference's CRS).
    gcp_crs : str, optional
        CRS of the GCPs or corners (default: the GCP file's, else the reference's).
    band, reference_band : int
        The product band and orthophoto band to match (similar wavelengths, e.g. NIR).
    band_nm : float, optional
        The product band by its centre wavelength (nm) instead: the band nearest it becomes
        ``band``.
    matching : TieMatching
        The feature detector (``sift``, ``orb``), the wobble model (``blocks`` of
        ``model_block_lines`` lines, ``tps``), the largest error of the rough placement
        (``max_shift_px``), the acceptance test (``min_inliers``, ``max_rmse_px``, product
        pixels) and RANSAC's ``seed``.
    grid : OutputGrid
        As :func:`georeference_file` (the reference's CRS by default).
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, ``report``, matches, inliers, RMSE (pixels) and the grid.
    """
    with open_raster(input, "input") as src:
        if not 1 <= band <= src.count:
            raise ParameterError(
                f"parameter 'band': band {band} does not exist in {input}, which has {src.count} band(s)"
            )
        data = src.read(band, masked=True)
        width, height = src.width, src.height
    with open_raster(reference, "reference") as ref:
        ref_crs = ref.crs
    if ref_crs is None:
        raise InputError(
            f"reference {reference} has no CRS: give an orthophoto with its CRS (e.g. a GeoTIFF)"
        )
    placement = _placement(input, gcps, corners, gcp_crs, ref_crs, width, height)
    m = matching
    ref_data, ref_ok, ref_tr, _ = _reference_window(
        reference, reference_band, placement, width, height, m.max_shift_px
    )
    progress.update(0.1, "tie points")
    tie = match_tie_points(
        np.ma.getdata(data).astype("float64"),
        ref_data,
        ~np.ma.getmaskarray(data),
        ref_transform=ref_tr,
        placement=placement,
        ref_valid=ref_ok,
        **m.matcher_options(),
    )
    progress.info(
        f"{tie.matches} matches, {tie.inliers} inliers, cross-validated RMSE {tie.rmse_px:.2f} px"
    )
    if tie.inliers < m.min_inliers:
        raise InputError(
            f"automatic tie points: only {tie.inliers} inlier(s) of {tie.matches} matches between "
            f"band {band} of {input} and band {reference_band} of {reference} (at least "
            f"{m.min_inliers} needed): give a closer rough placement, another band pair, or GCPs"
        )
    if tie.rmse_px > m.max_rmse_px:
        raise InputError(
            f"automatic tie points: cross-validated RMSE {tie.rmse_px:.2f} px on {tie.inliers} "
            f"inliers exceeds --max-rmse-px {m.max_rmse_px:g}: the model does not follow this "
            "line well enough (try --model tps, smaller --model-block-lines, or GCPs)"
        )
    tags = {
        "GEOREFERENCE": f"automatic tie points to {reference}: {tie.inliers} inliers, "
        f"{m.model} model, cross-validated RMSE {tie.rmse_px:.3f} px"
    }
    final = corrected(placement, tie.displacement)
    on, done = _warp_model(input, output, final, ref_crs, grid, tags, progress, igm_output)
    if report:
        write_json(
            report,
            {
                "input": os.fspath(input),
                "reference": os.fspath(reference),
                "crs": ref_crs.to_string(),
                "band": band,
                "reference_band": reference_band,
                "placement": placement.report(),
                **tie.report(),
            },
        )
    return {
        "output": output,
        "report": report,
        "igm_output": igm_output,
        "matches": tie.matches,
        "inliers": tie.inliers,
        "rmse_px": tie.rmse_px,
        **_grid_result(on, done),
    }


@_docstring
def reproject_to_file(input, reference, *, output, resampling="auto", progress=None) -> dict:
    """Put a map product onto the exact grid (CRS, transform, size) of a reference raster
    (an orthophoto or a scanned topographic map); a vector layer (GeoPackage or GeoJSON) is
    reprojected to the reference's CRS with pyproj.

    Parameters
    ----------
    input : path
        A georeferenced raster (e.g. the output of geolocate or georeference), or a
        GeoPackage/GeoJSON vector layer.
    reference : path
        The raster whose grid the output takes; it must have a CRS.
    output : path
        GeoTIFF on the reference's grid (or a .gpkg/.geojson for a vector input).
    resampling : {"auto", "nearest", "bilinear", "cubic"}
        ``auto``: nearest for class rasters, bilinear otherwise.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, the CRS and size of the grid (features for a vector).

    Examples
    --------
    The sample scene's ratio, geolocated, then on the orthophoto's exact grid:

    >>> import geoboresight as gb
    >>> _ = gb.ratio_file("sample_data/scene/vnir.hdr", "sample_data/scene/swir.hdr",
    ...                   output="out/ratio.tif")
    >>> _ = gb.geolocate_file("out/ratio.tif", igm="sample_data/scene/igm.tif",
    ...                       output="out/ratio_map.tif")
    >>> result = gb.reproject_to_file("out/ratio_map.tif", reference="sample_data/scene/ortho.tif",
    ...                               output="out/ratio_on_ortho.tif")
    >>> result["crs"], result["width"], result["height"]
    ('EPSG:32636', 544, 510)
    """
    if os.path.splitext(os.fspath(input))[1].lower() in (".gpkg", ".geojson", ".json"):
        return _reproject_vector(input, reference, output)
    done = georef.reproject_onto(input, reference, output, resampling=resampling, progress=progress)
    return {"output": output, **done}


def _reproject_vector(input, reference, output) -> dict:
    from ..io.vector import write_vector

    geoms, fields, src_crs, layer = georef.read_vector(input)
    if src_crs is None:
        raise InputError(
            f"vector {input} is in raw sensor geometry (no CRS): georeference the raster it came "
            "from and trace it again"
        )
    with open_raster(reference, "reference") as ref:
        dst_crs = ref.crs
    if dst_crs is None:
        raise InputError(f"reference {reference} has no CRS: give a raster with its CRS")
    moved = georef.reproject_geoms(geoms, src_crs, dst_crs)
    write_vector(
        output, moved, {k: np.asarray(v) for k, v in fields.items()}, crs=dst_crs, layer=layer
    )
    return {"output": output, "crs": dst_crs.to_string(), "features": len(moved)}


@_docstring
def simulate_ortho_file(
    *,
    output,
    preset="urban",
    lines=128,
    jitter_deg=JITTER_DEG,
    jitter_lines=JITTER_LINES,
    heading_deg=HEADING_DEG,
    ortho_cell=ORTHO_CELL,
    seed=0,
    progress=None,
) -> dict:
    """Simulate a raw line with roll/pitch/yaw jitter, its true IGM and an orthophoto.

    Parameters
    ----------
    output : path
        Folder to create: ``raw.img/.hdr`` (one NIR band, raw geometry), ``igm.img/.hdr``
        (easting, northing, height of each pixel, with its CRS), ``orthophoto.tif`` (red,
        green, blue, NIR on a north-up grid), ``corners.txt`` (the true corner coordinates,
        for a rough placement), ``attitude.csv`` and ``truth.json``.
    preset : {"urban", "dunes", "glade", "mixed"}
        The scene.
    lines : int
        Lines of the raw band.
    jitter_deg : float
        Standard deviation of roll, pitch and yaw (deg).
    jitter_lines : float
        Correlation length of the jitter (lines).
    heading_deg : float
        Flight heading, clockwise from north.
    ortho_cell : float
        Orthophoto cell size (m).
    seed : int
        Same seed, same scene.
    progress : Progress, optional

    Returns
    -------
    dict
        ``output`` and the files written.
    """
    from ..io.orthoscene import ORTHO_SCENE_FILES, write_ortho_scene
    from ..io.write import check_folder_replaceable
    from ..simulate.ortho import simulate_ortho

    # Before simulating: an existing folder holding the user's own files is never replaced.
    check_folder_replaceable(output, ORTHO_SCENE_FILES)
    progress.update(0.0, "simulate")
    scene = simulate_ortho(
        preset,
        int(lines),
        jitter_deg=float(jitter_deg),
        jitter_lines=float(jitter_lines),
        heading_deg=float(heading_deg),
        ortho_cell=float(ortho_cell),
        seed=int(seed),
    )
    progress.update(0.9, "write")
    # The operation has refused an existing folder unless asked to overwrite it.
    files = write_ortho_scene(scene, output, overwrite=True)
    return {"output": output, "files": files}
