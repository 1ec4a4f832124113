"""Boresight calibration against ground truth by construction.

A small pushbroom line is flown over analytic relief with a jittered attitude; its ground is
traced by a forward model written here from the stated conventions alone (body frame x
forward, y right, z down; R_nb = Rz(heading)·Ry(pitch)·Rx(roll); the boresight R_bs likewise;
look vector [tan along, tan across, 1]; a first hit on the relief found by bisection). Tie
points are the true ground of image positions (plus matching noise); the angles measured from
them must give IGMs within the accuracy the issue sets (RMS 0.3 px, p99 0.6 px) of the IGMs
made with the true angles, for a VNIR and a SWIR geometry, and a 20 ms clock offset must be
found within 2 ms. Tie points that cannot determine the angles are refused with the reason.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from geoboresight.errors import InputError
from geoboresight.georef.transfer import transfer_tie_points
from geoboresight.sensor.calibrate import calibrate_boresight

H = 1000.0  # flying height above the datum (m)
SPEED = 60.0  # m/s
HEADING = 35.0  # degrees, track over the ground
LINE_S = 0.02  # line period (s): 1.2 m along-track
LINES = 160


def relief(x, y):
    """Hills up to about 80 m (real relief for a 1,000 m flight)."""
    return 40.0 + 30.0 * np.sin(x / 90.0) * np.cos(y / 70.0) + 12.0 * np.cos((x + 2 * y) / 40.0)


def attitude(t):
    """Roll, pitch, heading (degrees) at time t: a jittered attitude (a slow sway and a
    faster shake, as a light aircraft in light turbulence)."""
    roll = 0.4 * np.sin(2 * np.pi * 0.3 * t) + 0.06 * np.sin(2 * np.pi * 1.7 * t + 1.0)
    pitch = 1.0 + 0.2 * np.sin(2 * np.pi * 0.4 * t + 0.4) + 0.04 * np.cos(2 * np.pi * 1.9 * t)
    heading = HEADING + 2.0 + 0.2 * np.sin(2 * np.pi * 0.25 * t + 2.0)
    return roll, pitch, heading


class Line:
    """A pushbroom sensor of ``pixels`` pixels of ``ifov`` radians on the aircraft."""

    def __init__(self, pixels: int, ifov: float, lever=(0.3, -0.2, 0.5)):
        self.pixels, self.ifov, self.lever = pixels, ifov, np.asarray(lever, float)

    def ground(self, angles_deg, time_offset, pixel_line):
        pl = np.asarray(pixel_line, float).reshape(-1, 2)
        t = (pl[:, 1] - 0.5) * LINE_S + time_offset
        across = (pl[:, 0] - self.pixels / 2) * self.ifov
        look = np.column_stack([np.zeros(len(pl)), np.tan(across), np.ones(len(pl))])
        r, p, h = attitude(t)
        r_nb = Rotation.from_euler("ZYX", np.column_stack([h, p, r]), degrees=True)
        r_bs = Rotation.from_euler(
            "ZYX", [angles_deg[2], angles_deg[1], angles_deg[0]], degrees=True
        )
        d_ned = r_nb.apply(r_bs.apply(look))
        trk = np.radians(HEADING)
        s = SPEED * t
        pos_ned = np.column_stack([s * np.cos(trk), s * np.sin(trk), np.full(len(t), -H)])
        pos_ned += r_nb.apply(self.lever)
        # NED to a map frame x east, y north, z up; first hit by bisection on the ray length.
        pos = np.column_stack([pos_ned[:, 1], pos_ned[:, 0], -pos_ned[:, 2]])
        d = np.column_stack([d_ned[:, 1], d_ned[:, 0], -d_ned[:, 2]])
        lo, hi = np.zeros(len(pl)), np.full(len(pl), 3 * H)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            q = pos + mid[:, None] * d
            above = q[:, 2] > relief(q[:, 0], q[:, 1])
            lo, hi = np.where(above, mid, lo), np.where(above, hi, mid)
        q = pos + hi[:, None] * d
        return q[:, :2]

    def igm(self, angles_deg, time_offset=0.0):
        jj, ii = np.meshgrid(np.arange(self.pixels) + 0.5, np.arange(LINES) + 0.5)
        return self.ground(angles_deg, time_offset, np.column_stack([jj.ravel(), ii.ravel()]))

    def gsd(self):
        return (H - 40.0) * self.ifov


VNIR = Line(96, 1.0e-3)
SWIR = Line(64, 1.5e-3, lever=(0.3, 0.1, 0.5))
TRUE = {"VNIR": (0.35, -0.45, 0.55), "SWIR": (-0.25, 0.6, 0.3)}


def tie_points(line, angles, n=120, noise_px=0.15, time_offset=0.0, seed=1):
    rng = np.random.default_rng(seed)
    pl = np.column_stack([rng.uniform(2, line.pixels - 2, n), rng.uniform(2, LINES - 2, n)])
    xy = line.ground(angles, time_offset, pl)
    return pl + rng.normal(0, noise_px, pl.shape), xy


def igm_error_px(line, estimated, true, time_est=0.0, time_true=0.0):
    d = line.igm(estimated, time_est) - line.igm(true, time_true)
    err = np.hypot(*d.T) / line.gsd()
    return float(np.sqrt(np.mean(err**2))), float(np.percentile(err, 99))


@pytest.mark.parametrize("name,line", [("VNIR", VNIR), ("SWIR", SWIR)])
def test_angles_give_the_true_igm(name, line):
    true = TRUE[name]
    pl, xy = tie_points(line, true)
    cal = calibrate_boresight(pl, xy, line.ground)
    rms, p99 = igm_error_px(line, cal.angles_deg, true)
    assert rms <= 0.3 and p99 <= 0.6, (name, cal.angles_deg, rms, p99)
    # The standard errors say how far the angles are: within 4 of them.
    assert np.all(np.abs(cal.angles_deg - true) <= 4 * cal.angles_se_deg + 1e-4)
    # Residuals are the matching noise (0.15 px per axis): their RMS length about 0.21 px;
    # a Gaussian tail point or two may fall beyond the rejection limit.
    assert 0.1 < cal.rms_px < 0.35 and (~cal.used).sum() <= 2
    # A residual in pixels is where the image would have to see the tie point: moving the
    # image position by it lands the ray on the tie point's ground.
    moved = line.ground(cal.angles_deg, 0.0, pl - cal.residuals_px)
    assert np.abs(moved - xy).max() < 0.05 * line.gsd()
    assert np.allclose(line.ground(cal.angles_deg, 0.0, pl) - xy, cal.residuals_m)


def test_outliers_are_rejected():
    pl, xy = tie_points(VNIR, TRUE["VNIR"])
    bad = np.arange(0, 120, 12)
    xy = xy.copy()
    xy[bad] += np.random.default_rng(3).normal(0, 8.0, (len(bad), 2)) + 6.0
    cal = calibrate_boresight(pl, xy, VNIR.ground)
    rejected = set(np.flatnonzero(~cal.used))
    assert set(bad) <= rejected and len(rejected) <= len(bad) + 2
    assert all(r.startswith("residual over") for r in cal.rejected[bad])
    rms, p99 = igm_error_px(VNIR, cal.angles_deg, TRUE["VNIR"])
    assert rms <= 0.3 and p99 <= 0.6


def test_clock_offset_is_found():
    true_dt = 0.020
    pl, xy = tie_points(VNIR, TRUE["VNIR"], n=200, time_offset=true_dt)
    held = calibrate_boresight(pl, xy, VNIR.ground)
    cal = calibrate_boresight(pl, xy, VNIR.ground, estimate_time_offset=True)
    assert abs(cal.time_offset_s - true_dt) <= 0.002, cal.time_offset_s
    rms, p99 = igm_error_px(VNIR, cal.angles_deg, TRUE["VNIR"], cal.time_offset_s, true_dt)
    assert rms <= 0.3 and p99 <= 0.6
    # Holding the clock at zero leaves the jitter's misfit in the residuals.
    assert held.rms_px > 1.3 * cal.rms_px


def test_too_few_tie_points_are_refused():
    pl, xy = tie_points(VNIR, TRUE["VNIR"], n=5)
    with pytest.raises(InputError, match="only 5 tie point"):
        calibrate_boresight(pl, xy, VNIR.ground)


def test_tie_points_on_one_line_are_refused():
    pl, xy = tie_points(VNIR, TRUE["VNIR"], n=30, noise_px=0.0)
    pl[:, 1] = 40.5
    with pytest.raises(InputError, match="one image line"):
        calibrate_boresight(pl, xy, VNIR.ground)


def test_clock_and_pitch_without_attitude_change_are_refused(monkeypatch):
    """A line flown straight and level over flat ground cannot tell the clock offset from
    the pitch: both move the ground along the track alike."""
    import sys

    module = sys.modules[__name__]
    monkeypatch.setattr(module, "attitude", lambda t: (0 * t, 0 * t, HEADING + 0 * t))
    monkeypatch.setattr(module, "relief", lambda x, y: 0 * x)
    pl, xy = tie_points(VNIR, TRUE["VNIR"], n=50)
    with pytest.raises(InputError, match="time offset"):
        calibrate_boresight(pl, xy, VNIR.ground, estimate_time_offset=True)


def test_transfer_follows_the_local_offset():
    """Features matched between the VNIR and the SWIR image through the line's offset land
    where the SWIR sees them, though the offset changes along the line (a parallax one
    offset for the line cannot hold)."""
    from scipy import ndimage

    rng = np.random.default_rng(5)
    texture = ndimage.gaussian_filter(rng.normal(size=(260, 200)), 2.0)
    yy, xx = np.mgrid[0:200, 0:150].astype(float)
    # The SWIR sees VNIR feature (r, c) at (r + along, c + across): along grows down the
    # line from 3 to 7 lines.
    vnir = ndimage.map_coordinates(texture, [yy + 30, xx + 20], order=3)
    swir = ndimage.map_coordinates(texture, [yy + 30 - 3.0 - 0.02 * yy, xx + 20 + 2.0], order=3)
    spl, vpl, (along, across) = transfer_tie_points(vnir, swir)
    assert len(spl) > 50 and 3.0 < along < 7.0 and across == pytest.approx(-2.0, abs=0.05)
    # VNIR row r (continuous r + 0.5) is SWIR row y with y - 3 - 0.02 y = r.
    want = np.column_stack([vpl[:, 0] - 2.0, (vpl[:, 1] - 0.5 + 3.0) / 0.98 + 0.5])
    # SIFT places a keypoint to a few tenths of a pixel, unbiased: the solver averages them.
    err = np.hypot(*(spl - want).T)
    assert np.sqrt(np.mean(err**2)) < 0.5 and np.percentile(err, 99) < 1.2
    assert np.all(np.abs(np.mean(spl - want, axis=0)) < 0.1)


# ---------------------------------------------------------------------------------------
# Through the direct georeferencing: a geodetic trajectory (WGS84), a DEM in UTM, pyproj.
UTM = "EPSG:32636"
E0, N0 = 700000.0, 3500000.0
DEM_CELL = 2.0


def geodetic_scene(lines=LINES):
    """A Navigation at 100 Hz over the line (straight track, jittered attitude, 1,000 m
    above the relief), its line times, and a DEM (Surface) of the relief in UTM."""
    from pyproj import Transformer

    from geoboresight.sensor.georeference import Surface
    from geoboresight.sensor.navigation import Navigation

    t = np.arange(-2.0, lines * LINE_S + 2.0, 0.01)
    trk = np.radians(HEADING)
    e = E0 + SPEED * t * np.sin(trk)
    n = N0 + SPEED * t * np.cos(trk)
    lon, lat = Transformer.from_crs(UTM, "EPSG:4326", always_xy=True).transform(e, n)
    roll, pitch, heading = attitude(t)
    nav = Navigation(t + 1000.0, lat, lon, np.full(t.shape, H + 20.0), roll, pitch, heading)
    times = 1000.0 + (np.arange(lines) + 0.5) * LINE_S
    x = np.arange(E0 - 400.0, E0 + 500.0, DEM_CELL)
    y = np.arange(N0 + 500.0, N0 - 400.0, -DEM_CELL)
    xx, yy = np.meshgrid(x + DEM_CELL / 2, y - DEM_CELL / 2)
    dem = Surface(20.0 + relief(xx - E0, yy - N0), (DEM_CELL, 0, x[0], 0, -DEM_CELL, y[0]), UTM)
    return nav, times, dem


@pytest.fixture(scope="module")
def scene():
    return geodetic_scene()


def test_tie_point_ground_is_the_direct_georeferencing(scene):
    """At pixel and line centres, the tie points' forward model gives ground_points' IGM."""
    from geoboresight.sensor.boresight import Boresight, LeverArm
    from geoboresight.sensor.calibrate import tie_point_ground
    from geoboresight.sensor.georeference import ground_points
    from geoboresight.sensor.model import SensorModel

    nav, times, dem = scene
    model = SensorModel.ideal(48, 4.0)
    lever = LeverArm(0.4, -0.3, 0.6)
    angles = (0.3, -0.4, 0.5)
    x, y, _ = ground_points(nav, times, model, Boresight(*angles), lever, dem, time_offset=0.01)
    project = tie_point_ground(nav, times, model, lever, dem)
    rows = np.array([0, 7, 80, 159])
    cols = np.array([0, 13, 30, 47])
    pl = np.column_stack([cols + 0.5, rows + 0.5])
    got = project(angles, 0.01, pl)
    assert np.allclose(got, np.column_stack([x[rows, cols], y[rows, cols]]), atol=1e-6)


SENSORS = {
    # pixels, field of view (deg), lever arm (m), true boresight (deg)
    "VNIR": (96, 5.5, (0.4, -0.3, 0.6), (0.35, -0.45, 0.55)),
    "SWIR": (96, 5.6, (0.4, 0.1, 0.6), (-0.25, 0.6, 0.3)),
}


def _direct(scene, name, true_offset=0.0, n=150, seed=2):
    """The true IGM of a sensor, tie points taken from it (matching noise 0.15 px), and the
    forward model to calibrate with."""
    from geoboresight.sensor.boresight import LeverArm
    from geoboresight.sensor.calibrate import tie_point_ground
    from geoboresight.sensor.model import SensorModel

    nav, times, dem = scene
    pixels, fov, lever, true = SENSORS[name]
    model, lever = SensorModel.ideal(pixels, fov), LeverArm(*lever)
    project = tie_point_ground(nav, times, model, lever, dem)
    rng = np.random.default_rng(seed)
    pl = np.column_stack([rng.uniform(1, pixels - 1, n), rng.uniform(1, LINES - 1, n)])
    xy = project(true, true_offset, pl)
    return model, lever, project, pl + rng.normal(0, 0.15, pl.shape), xy


def _igm_error_px(scene, model, lever, estimated, true, dt_est=0.0, dt_true=0.0):
    from geoboresight.sensor.boresight import Boresight
    from geoboresight.sensor.georeference import ground_points

    nav, times, dem = scene
    xe, ye, _ = ground_points(
        nav, times, model, Boresight(*estimated), lever, dem, time_offset=dt_est
    )
    xt, yt, _ = ground_points(nav, times, model, Boresight(*true), lever, dem, time_offset=dt_true)
    # pixel size on the ground: the mean spacing of neighbouring pixels across and along
    gsd = 0.5 * (
        np.nanmean(np.hypot(np.diff(xt, axis=1), np.diff(yt, axis=1)))
        + np.nanmean(np.hypot(np.diff(xt, axis=0), np.diff(yt, axis=0)))
    )
    err = np.hypot(xe - xt, ye - yt).ravel() / gsd
    return float(np.sqrt(np.mean(err**2))), float(np.percentile(err, 99))


@pytest.mark.parametrize("name", ["VNIR", "SWIR"])
def test_direct_georeferencing_angles(scene, name):
    model, lever, project, pl, xy = _direct(scene, name)
    cal = calibrate_boresight(pl, xy, project)
    true = SENSORS[name][3]
    rms, p99 = _igm_error_px(scene, model, lever, cal.angles_deg, true)
    assert rms <= 0.3 and p99 <= 0.6, (cal.angles_deg, rms, p99)


def test_direct_georeferencing_clock_offset(scene):
    model, lever, project, pl, xy = _direct(scene, "VNIR", true_offset=0.020)
    cal = calibrate_boresight(pl, xy, project, estimate_time_offset=True)
    assert abs(cal.time_offset_s - 0.020) <= 0.002, cal.time_offset_s
    true = SENSORS["VNIR"][3]
    rms, p99 = _igm_error_px(scene, model, lever, cal.angles_deg, true, cal.time_offset_s, 0.020)
    assert rms <= 0.3 and p99 <= 0.6, (cal.angles_deg, rms, p99)


# ---------------------------------------------------------------------------------------
# The operation on files: a VNIR and a SWIR line rendered from one ground texture at their
# true angles, the navigation CSV, line times, a DEM and an orthophoto of the texture.
ORTHO_CELL = 1.0
TEXTURE_CELL = 0.5
X0, Y0 = E0 - 300.0, N0 + 400.0


def _texture_field(seed=0):
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    field = ndimage.gaussian_filter(rng.normal(size=(1400, 1400)), 4.0)
    return field + 0.3 * ndimage.gaussian_filter(rng.normal(size=(1400, 1400)), 3.0)


def _texture(field, x, y):
    from scipy import ndimage

    rows = (Y0 - np.asarray(y)) / TEXTURE_CELL - 0.5
    cols = (np.asarray(x) - X0) / TEXTURE_CELL - 0.5
    return ndimage.map_coordinates(field, [rows, cols], order=1, mode="nearest")


@pytest.fixture(scope="module")
def flight_files(tmp_path_factory, scene):
    """The files an aircraft and a mapping agency give, with the true angles."""
    import rasterio
    from rasterio.transform import from_origin
    from synth import write_envi

    from geoboresight.io.navigation import write_line_times, write_navigation_csv
    from geoboresight.sensor.boresight import Boresight, LeverArm
    from geoboresight.sensor.georeference import ground_points
    from geoboresight.sensor.model import SensorModel

    folder = tmp_path_factory.mktemp("flight")
    nav, times, dem = scene
    field = _texture_field()
    files = {"truth": {}}
    for name, nm in (("VNIR", (650.0, 920.0)), ("SWIR", (1010.0, 1600.0))):
        pixels, fov, lever, true = SENSORS[name]
        x, y, _ = ground_points(
            nav, times, SensorModel.ideal(pixels, fov), Boresight(*true), LeverArm(*lever), dem
        )
        band = (1000.0 * (1.0 + _texture(field, x, y))).astype("float32")
        files[name] = write_envi(folder / f"{name.lower()}.img", np.stack([band, band]), nm)
        files["truth"][name] = (x, y)
    files["navigation"] = str(folder / "nav.csv")
    write_navigation_csv(files["navigation"], nav)
    files["line_times"] = str(folder / "times.txt")
    write_line_times(files["line_times"], times)
    files["dem"] = str(folder / "dem.tif")
    a, _, c, _, e, f = dem.transform
    with rasterio.open(
        files["dem"], "w", driver="GTiff", width=dem.heights.shape[1],
        height=dem.heights.shape[0], count=1, dtype="float32", crs=UTM,
        transform=from_origin(c, f, a, -e),
    ) as dst:  # fmt: skip
        dst.write(dem.heights.astype("float32"), 1)
    xs = X0 + (np.arange(600) + 0.5) * ORTHO_CELL
    ys = Y0 - (np.arange(600) + 0.5) * ORTHO_CELL
    ox, oy = np.meshgrid(xs, ys)
    files["reference"] = str(folder / "ortho.tif")
    with rasterio.open(
        files["reference"], "w", driver="GTiff", width=600, height=600, count=1,
        dtype="float32", crs=UTM, transform=from_origin(X0, Y0, ORTHO_CELL, ORTHO_CELL),
    ) as dst:  # fmt: skip
        dst.write((1000.0 * (1.0 + _texture(field, ox, oy))).astype("float32"), 1)
    return files


def _op_error_px(scene, name, angles, dt=0.0, dt_true=0.0):
    from geoboresight.sensor.boresight import LeverArm
    from geoboresight.sensor.model import SensorModel

    pixels, fov, lever, true = SENSORS[name]
    return _igm_error_px(
        scene, SensorModel.ideal(pixels, fov), LeverArm(*lever), angles, true, dt, dt_true
    )


def test_operation_on_a_reference_for_both_sensors(flight_files, scene, tmp_path):
    import json

    import pyogrio.raw

    import geoboresight as gb

    f = flight_files
    out = gb.boresight_calibrate_file(
        f["VNIR"],
        f["navigation"],
        swir=f["SWIR"],
        ties=gb.TieSources(reference=f["reference"]),
        geometry=gb.SensorGeometry(
            line_times=f["line_times"], fov=SENSORS["VNIR"][1], lever_arm=SENSORS["VNIR"][2]
        ),
        swir_geometry=gb.SensorGeometry(fov=SENSORS["SWIR"][1], lever_arm=SENSORS["SWIR"][2]),
        terrain=gb.Terrain(dem=f["dem"]),
        output=str(tmp_path / "boresight.json"),
        vectors=str(tmp_path / "residuals.gpkg"),
        plot=str(tmp_path / "residuals.png"),
    )
    report = json.loads((tmp_path / "boresight.json").read_text())
    for name in ("VNIR", "SWIR"):
        part = report[name.lower()]
        angles = (part["roll_deg"], part["pitch_deg"], part["heading_deg"])
        rms, p99 = _op_error_px(scene, name, angles)
        assert rms <= 0.3 and p99 <= 0.6, (name, angles, rms, p99)
        assert part["tie_points_used"] >= 30 and part["rms_px"] < 1.0
        assert all(part[k + "_se_deg"] > 0 for k in ("roll", "pitch", "heading"))
        assert {"rms_m", "p90_px", "p90_m", "time_offset_s"} <= set(part)
    assert out["roll_deg"] == report["vnir"]["roll_deg"]
    meta, _, _, columns = pyogrio.raw.read(tmp_path / "residuals.gpkg")
    table = dict(zip(meta["fields"], columns, strict=True))
    used = report["vnir"]["tie_points_used"] + report["swir"]["tie_points_used"]
    assert int(table["used"].sum()) == used and set(table["sensor"]) == {"VNIR", "SWIR"}
    assert "32636" in meta["crs"]
    assert (tmp_path / "residuals.png").stat().st_size > 10_000


def _gcp_file(path, scene, n, true_offset, seed=4):
    """GCPs in WGS 84 longitude and latitude (another CRS than the DEM's UTM) on the VNIR."""
    from pyproj import Transformer

    from geoboresight.sensor.boresight import LeverArm
    from geoboresight.sensor.calibrate import tie_point_ground
    from geoboresight.sensor.model import SensorModel

    nav, times, dem = scene
    pixels, fov, lever, true = SENSORS["VNIR"]
    project = tie_point_ground(nav, times, SensorModel.ideal(pixels, fov), LeverArm(*lever), dem)
    rng = np.random.default_rng(seed)
    pl = np.column_stack([rng.uniform(1, pixels - 1, n), rng.uniform(1, LINES - 1, n)])
    xy = project(true, true_offset, pl)
    lon, lat = Transformer.from_crs(UTM, "EPSG:4326", always_xy=True).transform(*xy.T)
    pl = pl + rng.normal(0, 0.1, pl.shape)  # picked to a tenth of a pixel
    rows = "\n".join(
        f"{p:.4f},{q:.4f},{x:.9f},{y:.9f}" for (p, q), x, y in zip(pl, lon, lat, strict=True)
    )
    path.write_text("# CRS: EPSG:4326\npixel,line,x,y\n" + rows + "\n")
    return str(path)


def test_operation_on_gcps_finds_the_clock_offset(flight_files, scene, tmp_path):
    """GCPs in another CRS, line times 20 ms late against the navigation: the offset the
    report gives is the one direct-georeference takes."""
    import json

    import geoboresight as gb

    f = flight_files
    gcps = _gcp_file(tmp_path / "gcps.csv", scene, 60, 0.020)
    gb.boresight_calibrate_file(
        f["VNIR"],
        f["navigation"],
        ties=gb.TieSources(gcps=gcps),
        geometry=gb.SensorGeometry(
            line_times=f["line_times"], fov=SENSORS["VNIR"][1], lever_arm=SENSORS["VNIR"][2]
        ),
        terrain=gb.Terrain(dem=f["dem"]),
        fit=gb.BoresightFit(estimate_time_offset=True),
        output=str(tmp_path / "boresight.json"),
    )
    part = json.loads((tmp_path / "boresight.json").read_text())["vnir"]
    assert abs(part["time_offset_s"] - 0.020) <= 0.002, part["time_offset_s"]
    angles = (part["roll_deg"], part["pitch_deg"], part["heading_deg"])
    rms, p99 = _op_error_px(scene, "VNIR", angles, part["time_offset_s"], 0.020)
    assert rms <= 0.3 and p99 <= 0.6, (angles, rms, p99)
    assert part["time_offset_se_s"] > 0 and part["tie_points_used"] >= 55


def test_operation_refuses_too_few_gcps(flight_files, scene, tmp_path):
    import geoboresight as gb

    f = flight_files
    gcps = _gcp_file(tmp_path / "gcps.csv", scene, 4, 0.0)
    with pytest.raises(InputError, match=r"only 4 tie point\(s\).*at least 6"):
        gb.boresight_calibrate_file(
            f["VNIR"],
            f["navigation"],
            ties=gb.TieSources(gcps=gcps),
            geometry=gb.SensorGeometry(line_times=f["line_times"], fov=SENSORS["VNIR"][1]),
            terrain=gb.Terrain(dem=f["dem"]),
            output=str(tmp_path / "boresight.json"),
            vectors=str(tmp_path / "residuals.gpkg"),
        )
    assert not (tmp_path / "boresight.json").exists()
    assert not (tmp_path / "residuals.gpkg").exists()


def test_operation_needs_tie_points(flight_files, tmp_path):
    import geoboresight as gb
    from geoboresight.errors import ParameterError

    f = flight_files
    with pytest.raises(ParameterError, match="give tie points"):
        gb.boresight_calibrate_file(
            f["VNIR"],
            f["navigation"],
            geometry=gb.SensorGeometry(fov=5.5),
            terrain=gb.Terrain(dem=f["dem"]),
            output=str(tmp_path / "b.json"),
        )


def test_command_line_and_rio_give_the_same_angles(flight_files, scene, tmp_path):
    """Three numbers after --lever-arm, negative ones as written; rio boresight runs the same
    operation; too few GCPs give one line and exit 1."""
    import json

    from click.testing import CliRunner
    from rasterio.rio.main import main_group

    from geoboresight.cli import main as cli

    f = flight_files
    gcps = _gcp_file(tmp_path / "gcps.csv", scene, 30, 0.0)
    args = ["--vnir", f["VNIR"], "--navigation", f["navigation"], "--gcps", gcps,
            "--line-times", f["line_times"], "--fov", str(SENSORS["VNIR"][1]),
            "--lever-arm", *map(str, SENSORS["VNIR"][2]), "--dem", f["dem"]]  # fmt: skip
    res = CliRunner().invoke(cli, ["boresight-calibrate", *args, "-o", str(tmp_path / "a.json")])
    assert res.exit_code == 0, res.output
    res = CliRunner().invoke(
        main_group, ["boresight", "boresight-calibrate", *args, "-o", str(tmp_path / "b.json")]
    )
    assert res.exit_code == 0, res.output
    a, b = (json.loads((tmp_path / n).read_text())["vnir"] for n in ("a.json", "b.json"))
    assert a["roll_deg"] == b["roll_deg"] and a["pitch_deg"] == b["pitch_deg"]
    rms, p99 = _op_error_px(scene, "VNIR", (a["roll_deg"], a["pitch_deg"], a["heading_deg"]))
    assert rms <= 0.3 and p99 <= 0.6
    few = _gcp_file(tmp_path / "few.csv", scene, 3, 0.0)
    args[args.index(gcps)] = few
    res = CliRunner().invoke(cli, ["boresight-calibrate", *args, "-o", str(tmp_path / "c.json")])
    assert res.exit_code == 1 and "Traceback" not in res.output
    errors = [ln for ln in res.output.splitlines() if ln.startswith("Error")]
    assert len(errors) == 1 and "only 3 tie point(s)" in errors[0]
