"""File-level boresight calibration: tie points from a reference orthophoto (the matcher of
``auto-georeference``) and/or GCPs, each sensor's boresight angles (and the clock offset)
measured on them through the direct georeferencing, a JSON report, residual vectors and a
residual plot."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..errors import InputError, ParameterError
from ..georef.tiepoints import TieMatching, match_tie_points
from ..georef.transfer import transfer_tie_points
from ..io import georef as gio
from ..io import navigation as nio
from ..io.bands import MatchBands
from ..io.envi import envi_header
from ..io.image import open_raster
from ..io.navigation import line_times_for, sensor_model_for
from ..io.terrain import dem_overview, read_surface
from ..io.write import save_figure, write_json
from ..sensor.boresight import Boresight, LeverArm
from ..sensor.calibrate import (
    calibrate_boresight,
    residual_figure,
    tie_point_ground,
)
from ..sensor.georeference import platform, trace
from ._gcps import check_reference, read_image_gcps
from ._geometry import SensorGeometry, Terrain

#: How each tie point's residual vector is drawn: from the tie point's ground to where the
#: calibrated model puts its image position.
CONVENTION = (
    "residual = model minus tie point: image (pixel, line) and ground (x, y, metres); "
    "time_offset_s is added to the line times, as direct-georeference --time-offset takes it"
)


@dataclass(frozen=True)
class TieSources:
    """Where the tie points come from: a ``reference`` orthophoto with its CRS (automatic
    tie points between its ``reference_band`` and the VNIR's ``band``, or the band nearest
    ``band_nm``) and/or ``gcps`` on the VNIR image (CSV ``pixel,line,x,y`` or QGIS
    ``.points``; ``gcp_crs`` when their file names no CRS)."""

    reference: str | os.PathLike | None = None
    gcps: str | os.PathLike | None = None
    gcp_crs: str | None = None
    band: int = 1
    band_nm: float | None = None
    reference_band: int = 1


@dataclass(frozen=True)
class BoresightFit:
    """The least squares of the angles: its robust ``loss`` (SciPy's: ``soft_l1``,
    ``huber``, ``linear``, ``cauchy``), and whether the clock offset is estimated too."""

    estimate_time_offset: bool = False
    loss: str = "soft_l1"


def metric_crs(crs, x, y):
    """``crs`` when it is projected, else the UTM zone of the points (metre residuals)."""
    if crs is not None and not crs.is_geographic:
        return crs
    return gio.utm_crs(x, y, crs)


def gcp_ties(gcps, gcp_crs, crs, width: int, height: int):
    """GCPs as tie points: image positions, ground in ``crs`` (transformed from the GCPs'
    CRS), enabled flags. A GCP outside the image is refused, naming it."""
    table = read_image_gcps(gcps, gcp_crs, width, height)
    x, y = gio.transform_xy(table.xy[:, 0], table.xy[:, 1], table.crs, crs)
    return table.pixel_line, np.column_stack([x, y]), table.enabled


def _reference_band(reference, reference_band, footprint_xy, pad):
    """The reference band around a footprint (its CRS's x, y), its validity and transform."""
    with open_raster(reference, "reference") as ref:
        check_reference(ref, reference, reference_band)
        x, y = footprint_xy
        pad = pad + 4 * max(abs(ref.transform.a), abs(ref.transform.e))
        bounds = (np.nanmin(x) - pad, np.nanmin(y) - pad, np.nanmax(x) + pad, np.nanmax(y) + pad)
        win = gio.reference_window(ref, bounds, reference)
        data = ref.read(reference_band, window=win, masked=True)
        return (
            np.ma.getdata(data).astype("float64"),
            ~np.ma.getmaskarray(data),
            tuple(ref.window_transform(win))[:6],
        )


def reference_ties(image, valid, reference, reference_band, placement, matching: TieMatching):
    """Automatic tie points between ``image`` (one band, raw geometry) and a reference band.

    ``placement(pixel, line) -> (x, y)`` in the reference's CRS is the forward model with the
    starting angles: the matcher places the reference into the image's geometry through it,
    and a tie point's ground is the placement at the image position its feature matched.
    Returns the image positions, their ground (reference CRS) and the matcher's
    :class:`~geoboresight.georef.tiepoints.TiePoints`.
    """
    lines, cols = image.shape
    t = np.linspace(0, 1, 17)
    edge_p = np.concatenate([t * cols, np.full(17, cols), t * cols, np.zeros(17)])
    edge_l = np.concatenate([np.zeros(17), t * lines, np.full(17, lines), t * lines])
    ex, ey = placement(edge_p, edge_l)
    if not (np.isfinite(ex).any() and np.isfinite(ey).any()):
        raise InputError(
            "the image's edges miss the DEM with the starting angles: give a DEM that covers "
            "the line (or a constant height)"
        )
    cx, cy = placement(np.array([cols / 2, cols / 2 + 1]), np.array([lines / 2] * 2))
    pixel = float(np.hypot(cx[1] - cx[0], cy[1] - cy[0]))
    ref, ref_ok, ref_tr = _reference_band(
        reference, reference_band, (ex, ey), 2 * matching.max_shift_px * pixel
    )
    tie = match_tie_points(
        image,
        ref,
        valid,
        ref_transform=ref_tr,
        placement=placement,
        ref_valid=ref_ok,
        **matching.matcher_options(),
    )
    pl = tie.pixel_line[tie.inlier]
    gx, gy = placement(tie.placed[tie.inlier, 0], tie.placed[tie.inlier, 1])
    return pl, np.column_stack([gx, gy]), tie


def residual_rows(name: str, cal, pl, xy, source) -> list[dict]:
    """One JSON row per tie point of a sensor: image position, ground, residuals, verdict."""
    rows = []
    for i in range(len(pl)):
        rows.append(
            {
                "sensor": name,
                "source": str(source[i]),
                "pixel": float(pl[i, 0]),
                "line": float(pl[i, 1]),
                "x": float(xy[i, 0]),
                "y": float(xy[i, 1]),
                "residual_pixel": _num(cal.residuals_px[i, 0]),
                "residual_line": _num(cal.residuals_px[i, 1]),
                "residual_x_m": _num(cal.residuals_m[i, 0]),
                "residual_y_m": _num(cal.residuals_m[i, 1]),
                "used": bool(cal.used[i]),
                "rejected": str(cal.rejected[i]),
            }
        )
    return rows


def _num(v) -> float | None:
    return float(v) if np.isfinite(v) else None


def write_residual_vectors(path, crs, rows: list[dict]) -> None:
    """Residual vectors as lines from each tie point's ground to the model's, to a
    GeoPackage (or GeoJSON) in ``crs``."""
    from shapely.geometry import LineString

    from ..io.vector import write_vector

    geoms, keep = [], []
    for r in rows:
        dx, dy = r["residual_x_m"], r["residual_y_m"]
        if dx is None or dy is None:
            continue
        geoms.append(LineString([(r["x"], r["y"]), (r["x"] + dx, r["y"] + dy)]))
        keep.append(r)
    fields = {
        "sensor": np.array([r["sensor"] for r in keep], dtype=object),
        "source": np.array([r["source"] for r in keep], dtype=object),
        "pixel": np.array([r["pixel"] for r in keep], "float64"),
        "line": np.array([r["line"] for r in keep], "float64"),
        "residual_px": np.array(
            [np.hypot(r["residual_pixel"], r["residual_line"]) for r in keep], "float64"
        ),
        "residual_m": np.array(
            [np.hypot(r["residual_x_m"], r["residual_y_m"]) for r in keep], "float64"
        ),
        "used": np.array([int(r["used"]) for r in keep], "int32"),
        "rejected": np.array([r["rejected"] for r in keep], dtype=object),
    }
    write_vector(
        path,
        geoms,
        fields,
        crs=crs,
        layer="residuals",
        description="Boresight calibration residuals: tie point ground to the model's ground",
    )


def swir_ties(dual, match, vnir_ground, matching: TieMatching):
    """SWIR tie points: features matched between the VNIR and SWIR images through the
    VNIR/SWIR offset (:func:`~geoboresight.georef.transfer.transfer_tie_points`), each on
    the ground the calibrated VNIR gives its VNIR position (``vnir_ground``)."""
    from ..io.bands import read_matching_pair

    pair = read_matching_pair(dual, match)
    spl, vpl, whole = transfer_tie_points(
        pair.vnir, pair.swir, pair.valid, detector=matching.detector, seed=int(matching.seed)
    )
    if len(spl) == 0:
        raise InputError(
            "no feature matched between the VNIR and the SWIR image: the SWIR's angles "
            "cannot be tied to the VNIR's (check that the two images are of one line)"
        )
    xy = vnir_ground(vpl)
    keep = np.isfinite(xy).all(axis=1)
    source = np.array(["VNIR feature"] * int(keep.sum()), dtype=object)
    return spl[keep], xy[keep], source, whole


def report_of(inputs: dict, crs, sensors: dict) -> dict:
    """The JSON report: each sensor's angles, standard errors, clock offset, residual
    statistics and tie points."""
    out = {**inputs, "crs": crs.to_string(), "convention": CONVENTION}
    for name, (cal, pl, xy, source) in sensors.items():
        out[name.lower()] = {
            **cal.report(),
            "tie_points": residual_rows(name, cal, pl, xy, source),
        }
    return out


def _three(kind, value, name):
    return kind() if value is None else kind(*(float(v) for v in value))


class _Sensor:
    """One sensor's geometry for the forward model: sensor model, line times, lever arm,
    starting boresight."""

    def __init__(self, path, nav, navigation, geometry: SensorGeometry, times=None):
        with open_raster(path, "input") as src:
            self.width, self.lines = src.width, src.height
        keys = envi_header(os.fspath(path)) or {}
        self.model = sensor_model_for(geometry.sensor_model, geometry.fov, self.width, keys)
        self.times = (
            times
            if times is not None
            else line_times_for(geometry.line_times, keys, self.lines, navigation, f"image {path}")
        )
        self.lever = _three(LeverArm, geometry.lever_arm, "lever_arm")
        self.start = _three(Boresight, geometry.boresight, "boresight")
        self.nav = nav


def _dem_window(sensor: _Sensor, dem, vertical_crs, time_offset):
    """The DEM around the swath the starting angles give (padded for the angles' error)."""
    low, high, _, crs = dem_overview(dem)
    n = sensor.lines
    pos, r = platform(sensor.nav, sensor.times[:: max(1, n // 64)], time_offset=time_offset)
    look = sensor.model.look_vectors()[:: max(1, sensor.model.n_pixels // 64)]
    xs, ys = [], []
    for h in (low, high):
        x, y, _ = trace(pos, r, look, sensor.start, sensor.lever, None, height=h, crs=crs)
        xs.append(x)
        ys.append(y)
    x, y = np.concatenate(xs), np.concatenate(ys)
    # A few degrees of boresight error move the swath by a twentieth of the height above it.
    pad = 0.1 * max(np.nanmax(x) - np.nanmin(x), np.nanmax(y) - np.nanmin(y)) + 50.0
    bounds = (np.nanmin(x) - pad, np.nanmin(y) - pad, np.nanmax(x) + pad, np.nanmax(y) + pad)
    return read_surface(dem, bounds=bounds, vertical_crs=vertical_crs)


def _placement(project, angles, time_offset):
    """``project`` at fixed angles as the matcher's ``placement(pixel, line) -> (x, y)``."""

    def placement(pixel, line):
        p, q = np.broadcast_arrays(np.asarray(pixel, "float64"), np.asarray(line, "float64"))
        g = project(angles, time_offset, np.column_stack([p.ravel(), q.ravel()]))
        return g[:, 0].reshape(p.shape), g[:, 1].reshape(p.shape)

    return placement


def _ground_crs(reference, gcps, gcp_crs):
    """The CRS the tie points' ground is solved in: the reference's, else the GCPs', else the
    DEM's; a geographic one is replaced by its UTM zone (residuals in metres)."""
    crs = None
    if reference:
        with open_raster(reference, "reference") as ref:
            crs = ref.crs
        if crs is None:
            raise InputError(
                f"reference {reference} has no CRS: give an orthophoto with its CRS (e.g. a "
                "GeoTIFF)"
            )
    elif gcps:
        crs = gio.read_gcps(gcps, crs=gcp_crs).crs
        if crs is None:
            raise InputError(
                f"GCP file {gcps} names no CRS: add a '# CRS: EPSG:...' line or give --gcp-crs"
            )
    return crs


def _vnir_ties(sensor, project_ref, ref_crs, crs, image, valid, args):
    """The VNIR's tie points (image positions, ground in ``crs``, source labels)."""
    ties, matching, time_offset, progress = args
    reference, gcps, gcp_crs = ties.reference, ties.gcps, ties.gcp_crs
    pls, xys, sources, info = [], [], [], {}
    if reference:
        progress.update(0.1, "automatic tie points")
        placement = _placement(project_ref, sensor.start.as_tuple(), time_offset)
        pl, xy, tie = reference_ties(
            image, valid, reference, ties.reference_band, placement, matching
        )
        x, y = gio.transform_xy(xy[:, 0], xy[:, 1], ref_crs, crs)
        pls.append(pl)
        xys.append(np.column_stack([x, y]))
        sources += ["reference"] * len(pl)
        info = {"matches": tie.matches, "inliers": tie.inliers}
        progress.info(f"{tie.matches} matches to {reference}, {tie.inliers} RANSAC inliers")
    if gcps:
        pl, xy, enabled = gcp_ties(gcps, gcp_crs, crs, sensor.width, sensor.lines)
        pls.append(pl[enabled])
        xys.append(xy[enabled])
        sources += [f"GCP {i + 1}" for i in np.flatnonzero(enabled)]
    return np.concatenate(pls), np.concatenate(xys), np.array(sources, dtype=object), info


def _solve(name, sensor, surface, height, crs, pl, xy, *, time_offset, estimate, loss):
    project = tie_point_ground(
        sensor.nav, sensor.times, sensor.model, sensor.lever, surface, height=height, crs=crs
    )
    return calibrate_boresight(
        pl,
        xy,
        project,
        initial_deg=sensor.start.as_tuple(),
        time_offset=time_offset,
        estimate_time_offset=estimate,
        loss=loss,
        what=f"boresight-calibrate ({name})",
    )


def _swir_sensor(swir, nav, navigation, vnir: _Sensor, geometry: SensorGeometry) -> _Sensor:
    """The SWIR's geometry; its line times are its own (a file or its header), else the
    VNIR's (a dual sensor's two images on one pixel grid are taken line by line together)."""
    try:
        s = _Sensor(swir, nav, navigation, geometry)
    except InputError:
        if geometry.line_times:
            raise
        s = _Sensor(swir, nav, navigation, geometry, times=vnir.times)
    if (s.width, s.lines) != (vnir.width, vnir.lines):
        raise InputError(
            f"SWIR {swir} is {s.width} × {s.lines} but the VNIR is {vnir.width} × {vnir.lines} "
            "(columns × lines): the VNIR's tie points are carried into a SWIR image on the "
            "VNIR's pixel grid; calibrate the SWIR alone with its own GCPs otherwise"
        )
    nav.check_covers(s.times, "the SWIR line times")
    return s


def _dual(vnir, swir):
    from ..io.dual import as_dual

    return as_dual(vnir, swir)


def _band(path, band, label):
    with open_raster(path, label) as src:
        if not 1 <= band <= src.count:
            raise ParameterError(
                f"parameter 'band': band {band} does not exist in {path}, which has "
                f"{src.count} band(s)"
            )
        data = src.read(band, masked=True)
    return np.ma.getdata(data).astype("float64"), ~np.ma.getmaskarray(data)


def _check_choices(ties: TieSources) -> None:
    if not ties.reference and not ties.gcps:
        raise ParameterError(
            "give tie points: a reference orthophoto, GCPs, or both",
            params=("reference", "gcps"),
        )


def boresight_calibrate_file(
    vnir,
    navigation,
    swir=None,
    *,
    ties: TieSources = TieSources(),
    output,
    vectors=None,
    plot=None,
    geometry: SensorGeometry = SensorGeometry(),
    swir_geometry: SensorGeometry = SensorGeometry(),
    time_offset=0.0,
    terrain: Terrain = Terrain(),
    fit: BoresightFit = BoresightFit(),
    matching=TieMatching(),
    progress=None,
) -> dict:
    """Measure a sensor's boresight angles (and the clock offset) on tie points.

    Tie points come from a reference orthophoto (the matcher of ``auto-georeference``, run
    between one image band and the orthophoto placed into the image's geometry through the
    forward model with the starting angles) and/or GCPs; the angles are found by robust least
    squares through the direct georeferencing
    (:func:`~geoboresight.sensor.calibrate.calibrate_boresight`). With ``swir``, the VNIR's
    tie points are carried into the SWIR image through the locally measured VNIR/SWIR offset
    and the SWIR's angles measured on them.

    Parameters
    ----------
    vnir : path
        The VNIR image (raw geometry; its header's binning, ``x start`` and times).
    navigation : path
        SBET, navigation CSV, Specim ``.nav`` or HySpex navigation text.
    swir : path, optional
        The SWIR image on the VNIR's pixel grid: its angles too.
    ties : TieSources
        A reference orthophoto with its CRS (automatic tie points; its band and the VNIR's
        band, or the band nearest ``band_nm``, matched) and/or GCPs on the VNIR image (CSV
        ``pixel,line,x,y`` or QGIS ``.points``, any CRS; ``gcp_crs`` when their file names
        none).
    output : path
        JSON report: each sensor's angles with standard errors, the clock offset, the tie
        points used and rejected, residual RMS and p90 in pixels and metres.
    vectors : path, optional
        Residual vectors (GeoPackage or GeoJSON).
    plot : path, optional
        Residual plot (PNG).
    geometry : SensorGeometry
        The VNIR's geometry, as ``direct-georeference`` takes it; its ``boresight``, the
        starting angles (roll, pitch, heading, degrees).
    swir_geometry : SensorGeometry
        The SWIR's (its line times default to its header's, else the VNIR's).
    time_offset : float
        Seconds added to the line times (held, or the start when estimated).
    terrain : Terrain
        The DEM (or a constant ellipsoidal height), as ``direct-georeference`` takes it.
    fit : BoresightFit
        The robust loss of the least squares, and whether the clock offset is estimated
        too (one for the line, shared by both sensors' runs).
    matching : TieMatching
        The matcher's detector, RANSAC model, block lines, largest shift and seed (as
        ``auto-georeference``); its acceptance test (``min_inliers``, ``max_rmse_px``) does
        not apply: the tie points are judged by the solver (too few, rejected residuals).
    progress : Progress, optional

    Returns
    -------
    dict
        ``output``, each sensor's angles, clock offset, residual RMS (pixels, metres) and
        tie points used.

    References
    ----------
    Brook, A.; Ben-Dor, E. Advantages of the boresight effect in hyperspectral data analysis.
    Remote Sens. 2011, 3, 484–502. https://doi.org/10.3390/rs3030484 (§2, Eq. 1–2).
    """
    _check_choices(ties)
    terrain.check()
    reference, height = ties.reference, terrain.height
    nav = nio.read_navigation(navigation)
    v = _Sensor(vnir, nav, navigation, geometry)
    nav.check_covers(v.times + time_offset, "the VNIR line times (with the time offset)")
    if swir is not None:
        s = _swir_sensor(swir, nav, navigation, v, swir_geometry)
    ref_crs = _ground_crs(reference, ties.gcps, ties.gcp_crs)
    surface = (
        _dem_window(v, terrain.dem, terrain.dem_vertical_crs, time_offset)
        if terrain.dem is not None
        else None
    )
    if ref_crs is None:
        ref_crs = surface.crs
    project_ref = tie_point_ground(
        nav, v.times, v.model, v.lever, surface, height=height, crs=ref_crs
    )
    centre = _placement(project_ref, v.start.as_tuple(), time_offset)(
        np.array([v.width / 2]), np.array([v.lines / 2])
    )
    crs = metric_crs(gio.parse_crs(str(ref_crs.to_wkt())), *centre)
    image, valid = _band(vnir, ties.band, "VNIR") if reference else (None, None)
    pl, xy, source, info = _vnir_ties(
        v, project_ref, ref_crs, crs, image, valid, (ties, matching, time_offset, progress)
    )
    progress.update(0.5, "solving the VNIR's angles")
    solve = {"time_offset": time_offset, "estimate": fit.estimate_time_offset, "loss": fit.loss}
    sensors = {"VNIR": (_solve("VNIR", v, surface, height, crs, pl, xy, **solve), pl, xy, source)}
    if swir is not None:
        progress.update(0.7, "matching the VNIR and the SWIR")
        geo = (nav, surface, height, crs)
        sensors["SWIR"] = _calibrate_swir(
            vnir, swir, v, s, geo, sensors["VNIR"][0], solve, matching, progress
        )
    data = report_of(
        {"vnir": os.fspath(vnir), "navigation": os.fspath(navigation), **info}, crs, sensors
    )
    write_json(output, data)
    if vectors:
        rows = [row for name in sensors for row in data[name.lower()]["tie_points"]]
        write_residual_vectors(vectors, crs, rows)
    if plot:
        cals = {name: part[0] for name, part in sensors.items()}
        save_figure(residual_figure(cals, {name: part[1] for name, part in sensors.items()}), plot)
    progress.update(1.0, "done")
    return {"output": os.fspath(output), "vectors": vectors, "plot": plot, **_results(sensors)}


def _calibrate_swir(vnir, swir, v: _Sensor, s: _Sensor, geo, vcal, solve, matching, progress):
    """The SWIR's tie points (features matched to the VNIR, on the calibrated VNIR's
    ground) and its angles; the clock offset is the VNIR's (one clock for the line)."""
    nav, surface, height, crs = geo
    project_v = tie_point_ground(nav, v.times, v.model, v.lever, surface, height=height, crs=crs)

    def vnir_ground(q):
        return project_v(vcal.angles_deg, vcal.time_offset_s, q)

    spl, sxy, source, whole = swir_ties(_dual(vnir, swir), MatchBands(), vnir_ground, matching)
    progress.info(
        f"{len(spl)} features matched between the VNIR and the SWIR (line offset "
        f"{whole[0]:+.2f} px along, {whole[1]:+.2f} px across)"
    )
    progress.update(0.8, "solving the SWIR's angles")
    held = {**solve, "time_offset": vcal.time_offset_s, "estimate": False}
    return _solve("SWIR", s, surface, height, crs, spl, sxy, **held), spl, sxy, source


def _results(sensors) -> dict:
    """The scalar results: the VNIR's angles and residuals (``swir_``-prefixed, the SWIR's)."""
    out = {}
    for name, (cal, *_) in sensors.items():
        prefix = "" if name == "VNIR" else "swir_"
        rep = cal.report()
        for key in ("roll_deg", "pitch_deg", "heading_deg", "time_offset_s", "rms_px", "rms_m"):
            if not (prefix and key == "time_offset_s"):  # one clock: the VNIR's
                out[prefix + key] = rep[key]
        out[prefix + "tie_points_used"] = rep["tie_points_used"]
    return out
