"""Direct georeferencing (Brook & Ben-Dor 2011, Eq. 1–2) against an independent exact ray
trace, the navigation readers against files written to their published layouts, and hostile
inputs.

The reference is written apart from the library: rotations as explicit matrices, the local
north-east-down axes by differencing pyproj's ECEF positions, the true trajectory at each
line's time (not the sampled navigation), a march of 0.25 m along each ECEF ray with
pyproj's exact map position and height at every point, heights by SciPy's
``map_coordinates``, and bisection to 1e-7 m.
"""

import os

import numpy as np
import pytest
from pyproj import Transformer
from scipy import ndimage

from geoboresight.errors import InputError, ParameterError
from geoboresight.io.navigation import (
    read_line_times,
    read_navigation,
    read_navigation_csv,
    read_sbet,
    read_sensor_model,
    write_navigation_csv,
    write_sbet,
)
from geoboresight.operations.direct_georef import SensorGeometry, Terrain
from geoboresight.sensor.boresight import Boresight
from geoboresight.sensor.georeference import Surface, ground_points, platform, trace
from geoboresight.sensor.model import SensorModel
from geoboresight.sensor.navigation import Navigation
from geoboresight.simulate.flight import (
    TRUE_BORESIGHT,
    TRUE_LEVER_ARM,
    Flight,
    relief_dem,
    sensor_models,
)

LINES = 160
TO_ECEF = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)


def _rx(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _ry(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _zyx(heading, pitch, roll):
    return _rz(np.radians(heading)) @ _ry(np.radians(pitch)) @ _rx(np.radians(roll))


def _ned_axes(lat, lon, h):
    """North, east, down unit vectors in ECEF by differencing pyproj's positions."""
    d = 1e-6
    p = lambda la, lo, hh: np.array(TO_ECEF.transform(lo, la, hh))  # noqa: E731
    north = p(lat + d, lon, h) - p(lat - d, lon, h)
    east = p(lat, lon + d, h) - p(lat, lon - d, h)
    up = p(lat, lon, h + 1.0) - p(lat, lon, h - 1.0)
    north, east, up = (v / np.linalg.norm(v) for v in (north, east, up))
    return np.stack([north, east, -up], axis=1)


def reference_points(flight, times, model, boresight, lever, dem, pixels):
    """The exact ground point of each (line, pixel) in ``pixels`` (see the module's text)."""
    to_map = Transformer.from_crs("EPSG:4978", dem.crs, always_xy=True)
    a, _, c, _, e, f = dem.transform
    z = dem.heights
    lat, lon, h = flight.geodetic(times)
    roll, pitch, heading = flight.attitude(times)
    origins, dirs = [], []
    for li, pi in pixels:
        r = _ned_axes(lat[li], lon[li], h[li]) @ _zyx(heading[li], pitch[li], roll[li])
        pos = np.array(TO_ECEF.transform(lon[li], lat[li], h[li]))
        look = np.array([np.tan(model.along_rad[pi]), np.tan(model.across_rad[pi]), 1.0])
        look /= np.linalg.norm(look)
        b = _zyx(boresight.heading_deg, boresight.pitch_deg, boresight.roll_deg)
        origins.append(pos + r @ np.array([lever.x, lever.y, lever.z]))
        dirs.append(r @ b @ look)
    origins, dirs = np.array(origins), np.array(dirs)

    def height_diff(t):
        p = origins + t[:, None] * dirs
        x, y, hh = to_map.transform(p[:, 0], p[:, 1], p[:, 2])
        col, row = (np.asarray(x) - c) / a - 0.5, (np.asarray(y) - f) / e - 0.5
        zz = ndimage.map_coordinates(z, [row, col], order=1, mode="nearest")
        return np.asarray(hh) - zz

    # march from well above the highest point (the sensor is ~900 m above the ground)
    t = np.full(len(origins), 600.0)
    prev_t, prev_d = t.copy(), height_diff(t)
    assert np.all(prev_d > 0)
    found = np.zeros(len(origins), bool)
    lo, hi = np.zeros(len(origins)), np.zeros(len(origins))
    step = 0.25
    while not found.all():
        t = prev_t + step
        d = height_diff(t)
        new = (~found) & (d <= 0)
        lo[new], hi[new] = prev_t[new], t[new]
        found |= new
        prev_t = np.where(found, prev_t, t)
        assert np.all(prev_t < 2500)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        below = height_diff(mid) <= 0
        hi = np.where(below, mid, hi)
        lo = np.where(below, lo, mid)
    p = origins + (0.5 * (lo + hi))[:, None] * dirs
    x, y, _ = to_map.transform(p[:, 0], p[:, 1], p[:, 2])
    return np.asarray(x), np.asarray(y)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("flight")
    flight = Flight()
    times = flight.line_times(LINES)
    # records fall between the lines (2.3 ms off): the lines interpolate the navigation
    nav = flight.navigation(times[0] - 1.0023, times[-1] + 1.0)
    sbet = str(folder / "line.out")
    csv = str(folder / "line_nav.csv")
    write_sbet(sbet, nav, wander_deg=flight.wander(nav.time))
    write_navigation_csv(csv, nav)
    dem = relief_dem(flight)
    vnir, swir = sensor_models()
    return dict(flight=flight, times=times, sbet=sbet, csv=csv, dem=dem, vnir=vnir, swir=swir)


def _pixel_sample(n_pixels, seed):
    rng = np.random.default_rng(seed)
    lines = rng.integers(0, LINES, 150)
    pix = rng.integers(0, n_pixels, 150)
    edges = np.array([[0, 0], [LINES - 1, n_pixels - 1], [LINES // 2, 0], [3, n_pixels - 1]])
    return np.concatenate([np.stack([lines, pix], axis=1), edges])


@pytest.mark.parametrize("source", ["sbet", "csv"])
@pytest.mark.parametrize("sensor", ["vnir", "swir"])
def test_igm_matches_an_exact_ecef_trace(scene, source, sensor):
    nav = read_sbet(scene["sbet"]) if source == "sbet" else read_navigation_csv(scene["csv"])
    model, dem, flight = scene[sensor], scene["dem"], scene["flight"]
    b, lever = TRUE_BORESIGHT[sensor], TRUE_LEVER_ARM[sensor]
    x, y, h = ground_points(nav, scene["times"], model, b, lever, dem)
    assert x.shape == (LINES, model.n_pixels) and np.isfinite(x).all()
    pixels = _pixel_sample(model.n_pixels, seed=len(sensor) + len(source))
    rx, ry = reference_points(flight, scene["times"], model, b, lever, dem, pixels)
    err = np.hypot(x[pixels[:, 0], pixels[:, 1]] - rx, y[pixels[:, 0], pixels[:, 1]] - ry)
    # one pixel on the ground: the height above the ground times the pixel's angular size
    ifov = np.abs(np.gradient(model.across_rad))[pixels[:, 1]]
    agl = flight.map_position(scene["times"])[2][pixels[:, 0]] - h[pixels[:, 0], pixels[:, 1]]
    err_px = err / (agl * ifov)
    assert np.median(err_px) <= 0.02, np.median(err_px)
    assert np.quantile(err_px, 0.99) <= 0.05, np.quantile(err_px, 0.99)


def test_numba_march_equals_numpy_reference(scene):
    pytest.importorskip("numba")
    nav = read_sbet(scene["sbet"])
    args = (nav, scene["times"][:40], scene["vnir"], TRUE_BORESIGHT["vnir"],
            TRUE_LEVER_ARM["vnir"], scene["dem"])  # fmt: skip
    a = ground_points(*args, engine="numba")
    b = ground_points(*args, engine="numpy")
    for u, v in zip(a, b, strict=True):
        np.testing.assert_allclose(u, v, rtol=0, atol=1e-6)


def test_conventions_hold():
    """Right wing down (positive roll) turns the body's down axis to the left, so the nadir
    ray lands left of the track; nose up (positive pitch) turns it forward; a boresight roll
    turns the sensor's look as a body roll does."""
    t = np.array([0.0, 1.0])
    base = dict(lat_deg=[31.0, 31.0], lon_deg=[35.0, 35.0], height=[1000.0, 1000.0])

    def nadir(roll=0.0, pitch=0.0, heading=0.0, boresight=None):
        nav = Navigation(t, **base, roll_deg=[roll] * 2, pitch_deg=[pitch] * 2,
                         heading_deg=[heading] * 2)  # fmt: skip
        x, y, _ = ground_points(nav, [0.5], SensorModel([0.0], [0.0]), boresight, None,
                                height=0.0, crs="EPSG:32636")  # fmt: skip
        return x[0, 0], y[0, 0]

    x0, y0 = nadir()
    xr, yr = nadir(roll=5.0)  # heading north: left is west
    assert x0 - xr == pytest.approx(1000 * np.tan(np.radians(5.0)), rel=0.01)
    xp, yp = nadir(pitch=5.0)  # nose up: the nadir ray points forward (north)
    assert yp - y0 == pytest.approx(1000 * np.tan(np.radians(5.0)), rel=0.01)
    xb, yb = nadir(heading=90.0, boresight=Boresight(roll_deg=5.0))  # east: left is north
    assert yb - y0 == pytest.approx(1000 * np.tan(np.radians(5.0)), rel=0.01)
    assert Boresight(1, 2, 3).matrix() == pytest.approx(_zyx(3, 2, 1))


def test_positive_across_angle_looks_right():
    m = SensorModel([-0.1, 0.1], [0.0, 0.0])
    v = m.look_vectors()
    assert v[1, 1] > 0 > v[0, 1]
    ideal = SensorModel.ideal(10, 20.0)
    assert np.all(np.diff(ideal.across_rad) > 0)
    assert ideal.across_rad[-1] < np.radians(10.0)
    assert ideal.binned(2).n_pixels == 5
    assert ideal.for_image(5).n_pixels == 5


def test_time_offset_samples_the_navigation_later():
    t = np.arange(0.0, 10.0, 0.01)
    nav = Navigation(t, 31 + 1e-4 * t, 35 + 0 * t, 1000 + 0 * t, 0 * t, 0 * t, 0 * t)
    a, _ = platform(nav, [5.0], time_offset=0.5)
    b, _ = platform(nav, [5.5])
    np.testing.assert_allclose(a, b, atol=1e-6)


def test_sbet_heading_is_platform_heading_minus_wander(tmp_path):
    # one record by hand, to the published layout (17 little-endian float64)
    rec = np.zeros(17 * 3, "<f8").reshape(3, 17)
    rec[:, 0] = [100.0, 100.005, 100.01]
    rec[:, 1], rec[:, 2], rec[:, 3] = np.radians(31.0), np.radians(35.0), 1234.5
    rec[:, 7], rec[:, 8] = np.radians(1.5), np.radians(-0.5)
    rec[:, 9], rec[:, 10] = np.radians(-170.0), np.radians(25.0)
    path = tmp_path / "a.out"
    rec.tofile(path)
    nav = read_navigation(str(path))
    assert nav.heading_deg[0] == pytest.approx(165.0)
    assert nav.roll_deg[0] == pytest.approx(1.5) and nav.height[0] == 1234.5


def test_specim_nav_and_line_times(tmp_path):
    # NMEA sentences as a Specim .nav holds them (APL src/navfileclasses.cpp reads these)
    text = "\n".join(
        [
            "$GPZDA,101500.00,07,06,2011,00,00*4A",
            "$GPGGA,101500.00,3110.0000,N,03441.0000,E,2,09,1.0,1230.0,M,20.5,M,,*47",
            "$PRDID,0.50,-1.25,64.00*5F",
            "$SPTSMP2,1,0.2500*12",
            "$GPGGA,101500.50,3110.0010,N,03441.0020,E,2,09,1.0,1230.5,M,20.5,M,,*47",
            "$PRDID,0.40,-1.20,64.10*5F",
        ]
    )
    path = tmp_path / "line.nav"
    path.write_text(text)
    from geoboresight.io.navigation import read_specim_nav

    nav, first = read_specim_nav(str(path))
    tuesday = 2 * 86400.0  # 7 June 2011 was a Tuesday
    assert nav.time[0] == pytest.approx(tuesday + 10 * 3600 + 15 * 60)
    assert nav.lat_deg[0] == pytest.approx(31 + 10 / 60)
    assert nav.height[0] == pytest.approx(1250.5)
    assert nav.roll_deg[0] == pytest.approx(-1.25) and nav.pitch_deg[0] == pytest.approx(0.5)
    assert first == pytest.approx(nav.time[0] + 1.0 - 0.25)
    times = tmp_path / "times.txt"
    times.write_text("1.0\n1.02\n1.04\n")
    assert read_line_times(str(times), 3).tolist() == [1.0, 1.02, 1.04]


def test_sensor_model_files(tmp_path):
    # HySpex/NEO text as HyPro writes it (EnSpec/hypro sensor_model.py): pixel vinkelx vinkely
    hy = tmp_path / "vnir.txt"
    hy.write_text("# pixel    vinkelx    vinkely\n0 -0.2 0.001\n1 0.0 0.001\n2 0.2 0.001\n")
    m = read_sensor_model(str(hy))
    assert m.across_rad.tolist() == [-0.2, 0.0, 0.2] and m.along_rad[0] == 0.001
    csv = tmp_path / "swir.csv"
    csv.write_text("pixel,across_track_rad,along_track_rad\n1,0.1,0\n0,-0.1,0.002\n")
    m = read_sensor_model(str(csv))
    assert m.across_rad.tolist() == [-0.1, 0.1] and m.along_rad.tolist() == [0.002, 0.0]
    # APL's view-vector ENVI file (arsf/APL src/viewvectors.cpp): 3 bands, one line
    import rasterio

    vv = tmp_path / "vv.bil"
    with rasterio.open(vv, "w", driver="ENVI", width=4, height=1, count=3, dtype="float64") as d:
        d.write(np.array([[[-0.3, -0.1, 0.1, 0.3]], [[0.01] * 4], [[0.0] * 4]]))
    m = read_sensor_model(str(vv))
    assert m.across_rad.tolist() == [-0.3, -0.1, 0.1, 0.3] and m.along_rad[0] == 0.01


# hostile inputs: one clear line each


def test_navigation_not_covering_the_lines_names_both_ranges(scene):
    nav = read_sbet(scene["sbet"])
    with pytest.raises(InputError, match=r"covers GPS time .* but the line times run"):
        ground_points(nav, scene["times"] + 100.0, scene["vnir"], height=300.0, crs="EPSG:32636")


def test_csv_angles_in_radians_are_refused(tmp_path, scene):
    nav = read_navigation_csv(scene["csv"])
    rad = Navigation(nav.time, nav.lat_deg, nav.lon_deg, nav.height,
                     np.radians(nav.roll_deg), np.radians(nav.pitch_deg),
                     np.radians(nav.heading_deg))  # fmt: skip
    path = tmp_path / "rad.csv"
    write_navigation_csv(str(path), rad)
    with pytest.raises(InputError, match="look like radians"):
        read_navigation_csv(str(path))


def test_line_times_of_another_length_are_refused(tmp_path):
    path = tmp_path / "t.txt"
    path.write_text("1\n2\n3\n")
    with pytest.raises(InputError, match="holds 3 times but the image has 4 lines"):
        read_line_times(str(path), 4)


def test_sensor_model_matching_no_binning_is_refused():
    with pytest.raises(InputError, match="match no binning"):
        SensorModel.ideal(100, 20.0).for_image(33)


def test_truncated_sbet_is_refused(tmp_path):
    path = tmp_path / "bad.out"
    path.write_bytes(b"\1" * 200)
    with pytest.raises(InputError, match="not a whole number of 136-byte"):
        read_sbet(str(path))


def test_constant_height_needs_a_crs():
    t = np.arange(3.0)
    nav = Navigation(t, [31] * 3, [35] * 3, [900] * 3, [0] * 3, [0] * 3, [0] * 3)
    with pytest.raises(ParameterError, match="output CRS"):
        ground_points(nav, [1.0], SensorModel.ideal(4, 10), height=0.0)


def test_trace_is_the_low_level_step(scene):
    nav = read_sbet(scene["sbet"])
    pos, r = platform(nav, scene["times"][:5])
    a = trace(pos, r, scene["swir"].look_vectors(), TRUE_BORESIGHT["swir"],
              TRUE_LEVER_ARM["swir"], scene["dem"])  # fmt: skip
    b = ground_points(nav, scene["times"][:5], scene["swir"], TRUE_BORESIGHT["swir"],
                      TRUE_LEVER_ARM["swir"], scene["dem"])  # fmt: skip
    np.testing.assert_array_equal(a[0], b[0])


# the operation, through the command line and Python


def _write_line(folder, lines, samples, keys=None):
    """A raw uint16 ENVI line (BIL) with the header keys a Specim line carries."""
    import rasterio

    path = str(folder / "line_vnir.bil")
    with rasterio.open(path, "w", driver="ENVI", width=samples, height=lines, count=2,
                       dtype="uint16", interleave="bil") as d:  # fmt: skip
        d.write(np.full((2, lines, samples), 1000, "uint16"))
    if keys:
        with open(str(folder / "line_vnir.hdr"), "a", encoding="utf-8") as f:
            for k, v in keys.items():
                f.write(f"{k} = {v}\n")
    return path


def _write_dem(folder, dem):
    import rasterio
    from rasterio.transform import Affine

    path = str(folder / "dem.tif")
    z = dem.heights
    with rasterio.open(path, "w", driver="GTiff", width=z.shape[1], height=z.shape[0], count=1,
                       dtype="float64", crs=dem.crs, transform=Affine(*dem.transform)) as d:  # fmt: skip
        d.write(z, 1)
    return path


@pytest.fixture(scope="module")
def line_files(scene, tmp_path_factory):
    from geoboresight.io.navigation import write_line_times, write_sensor_model_csv

    folder = tmp_path_factory.mktemp("op")
    lines = 48
    image = _write_line(folder, lines, scene["vnir"].n_pixels)
    times = str(folder / "times.txt")
    write_line_times(times, scene["times"][:lines])
    model = str(folder / "vnir.csv")
    write_sensor_model_csv(model, scene["vnir"])
    return dict(folder=folder, image=image, times=times, model=model, lines=lines,
                dem=_write_dem(folder, scene["dem"]))  # fmt: skip


def test_cli_takes_three_numbers_with_negative_values(scene, line_files):
    from click.testing import CliRunner

    from geoboresight.cli import main as cli

    out = str(line_files["folder"] / "igm.tif")
    b, lever = TRUE_BORESIGHT["vnir"], TRUE_LEVER_ARM["vnir"]
    args = ["direct-georeference", "--input", line_files["image"], "--navigation", scene["sbet"],
            "--line-times", line_files["times"], "--sensor-model", line_files["model"],
            "--boresight", *map(str, b.as_tuple()), "--lever-arm", *map(str, lever.as_tuple()),
            "--dem", line_files["dem"], "-o", out, "-q"]  # fmt: skip
    res = CliRunner().invoke(cli, args)
    assert res.exit_code == 0, res.output
    import rasterio

    with rasterio.open(out) as src:
        igm = src.read()
        assert src.count == 3 and src.dtypes[0] == "float64"
    nav = read_sbet(scene["sbet"])
    x, y, h = ground_points(nav, scene["times"][: line_files["lines"]], scene["vnir"], b, lever,
                            scene["dem"])  # fmt: skip
    np.testing.assert_allclose(igm[0], x, atol=1e-6)
    np.testing.assert_allclose(igm[2], h, atol=1e-6)


def test_envi_igm_in_apl_layout_goes_to_geolocate(scene, line_files):
    import rasterio

    from geoboresight import geolocate_file
    from geoboresight.operations.direct_georef import direct_georeference_file

    out = str(line_files["folder"] / "igm.bil")
    direct_georeference_file(
        line_files["image"], scene["csv"], output=out,
        geometry=SensorGeometry(sensor_model=line_files["model"], line_times=line_files["times"],
                                boresight=TRUE_BORESIGHT["vnir"], lever_arm=(0.35, -0.12, 0.28)),
        terrain=Terrain(dem=line_files["dem"]),
    )  # fmt: skip
    with rasterio.open(out) as src:
        assert src.driver == "ENVI" and src.count == 3 and src.crs is not None
    mapped = str(line_files["folder"] / "mapped.tif")
    res = geolocate_file(line_files["image"], out, output=mapped)
    assert res["valid_pixels"] > 0


def test_dem_that_misses_the_swath_is_named_with_its_share(scene, line_files, tmp_path):
    from geoboresight.operations.direct_georef import direct_georeference_file

    dem = scene["dem"]
    half = Surface(dem.heights[:, : dem.heights.shape[1] // 2], dem.transform, dem.crs)
    path = _write_dem(tmp_path, half)
    with pytest.raises(InputError, match=r"DEM .* misses \d+\.\d% of the pixels"):
        direct_georeference_file(
            line_files["image"], scene["sbet"], output=str(tmp_path / "i.tif"),
            geometry=SensorGeometry(sensor_model=line_files["model"],
                                    line_times=line_files["times"]),
            terrain=Terrain(dem=path),
        )  # fmt: skip
    assert not os.path.exists(tmp_path / "i.tif")


def test_dem_without_crs_or_in_feet_is_refused(scene, line_files, tmp_path):
    import rasterio

    from geoboresight.operations.direct_georef import direct_georeference_file

    path = str(tmp_path / "nocrs.tif")
    with rasterio.open(path, "w", driver="GTiff", width=4, height=4, count=1,
                       dtype="float32") as d:  # fmt: skip
        d.write(np.zeros((1, 4, 4), "float32"))
    kw = dict(output=str(tmp_path / "i.tif"),
              geometry=SensorGeometry(sensor_model=line_files["model"],
                                      line_times=line_files["times"]))  # fmt: skip
    with pytest.raises(InputError, match="carries no CRS"):
        direct_georeference_file(
            line_files["image"], scene["sbet"], terrain=Terrain(dem=path), **kw
        )
    feet = str(tmp_path / "feet.tif")
    from rasterio.transform import from_origin

    with rasterio.open(feet, "w", driver="GTiff", width=4, height=4, count=1, dtype="float32",
                       crs="EPSG:2227", transform=from_origin(0, 0, 1, 1)) as d:  # fmt: skip
        d.write(np.zeros((1, 4, 4), "float32"))
    with pytest.raises(InputError, match="in feet"):
        direct_georeference_file(
            line_files["image"], scene["sbet"], terrain=Terrain(dem=feet), **kw
        )


def test_header_start_time_and_fps_give_the_line_times(tmp_path):
    from geoboresight.io.navigation import header_line_times

    keys = {"gps start time": "UTC 10:15:02.500", "acquisition date": "DATE(dd-mm-yyyy): 07-06-2011",
            "fps": "50"}  # fmt: skip
    t = header_line_times(keys, 3)
    np.testing.assert_allclose(t, 2 * 86400 + 36902.5 + np.arange(3) / 50)


def test_the_demo_goes_from_the_sample_navigation_to_the_map(tmp_path):
    import shlex

    import rasterio
    from click.testing import CliRunner

    from geoboresight.algorithms import execute, registry
    from geoboresight.cli import main
    from geoboresight.demo import SAMPLE, _command_line, _from_navigation, _Scene

    if not (SAMPLE / "flight" / "flight.json").exists():
        pytest.skip("no sample flight")
    s = _Scene(SAMPLE, tmp_path, {})
    todo = _from_navigation(s)
    # the ratio the demo maps is made earlier in the demo: here, from the sample's bands
    execute(registry()["ratio"], {"vnir": s.v, "swir": s.s, "output": s.ratio})
    assert [n for n, _ in todo] == ["direct-georeference"] * 2 + ["geolocate"]
    for name, values in todo:
        execute(registry()[name], values)
    assert (tmp_path / "boresight_ratio_from_navigation_map.tif").exists()
    with (
        rasterio.open(tmp_path / "vnir_igm.tif") as v,
        rasterio.open(tmp_path / "swir_igm.tif") as w,
    ):
        a, b = v.read(), w.read()
    assert np.isfinite(a).all() and a.shape == (3, 192, 286)
    # the two sensors' boresights differ by about a degree: metres apart on the ground
    assert 5.0 < np.median(np.hypot(a[0] - b[0], a[1] - b[1])) < 60.0
    # the printed command pastes as printed (three numbers after --boresight, negative ones too)
    words = shlex.split(_command_line(*todo[0]))
    assert "--boresight" in words
    out = CliRunner().invoke(main, [*words[1:], "-q"])
    assert out.exit_code == 0, out.output


def test_three_numbers_parameter_takes_text_lists_and_values():
    from geoboresight.algorithms.spec import Numbers

    p = Numbers(name="boresight", description="d", names=("ROLL", "PITCH", "HEADING"))
    assert p.coerce("0.4 -0.3 0.5") == (0.4, -0.3, 0.5)
    assert p.coerce("0.4,-0.3,0.5") == (0.4, -0.3, 0.5)
    assert p.coerce([1, 2, 3]) == (1.0, 2.0, 3.0)
    assert p.coerce(Boresight(1, -2, 3)) == (1.0, -2.0, 3.0)
    for bad in ("1 2", [1, 2, 3, 4], "1 x 3", [1, float("nan"), 3], 5.0, [True, 1, 2]):
        with pytest.raises(ParameterError, match="parameter 'boresight'"):
            p.coerce(bad)


def test_view_angles_are_written_beside_the_igm(scene, line_files):
    import rasterio

    from geoboresight.operations.direct_georef import direct_georeference_file

    out = line_files["folder"] / "igm_angles.tif"
    angles = line_files["folder"] / "angles.tif"
    direct_georeference_file(
        line_files["image"], scene["sbet"], output=str(out),
        geometry=SensorGeometry(sensor_model=line_files["model"], line_times=line_files["times"]),
        terrain=Terrain(dem=line_files["dem"]), view_angles_output=str(angles),
    )  # fmt: skip
    with rasterio.open(angles) as src:
        zenith, azimuth = src.read(1), src.read(2)
    # a 30° field of view with up to ~2° of wobble: zenith 0–17°, the edges near 15°
    assert zenith.min() >= 0 and zenith.max() < 18.0
    assert 12.0 < np.median(zenith[:, 0]) < 18.0 and 12.0 < np.median(zenith[:, -1]) < 18.0
    # heading 63°: the left edge looks back up to the sensor from the south-east (azimuth
    # ≈ 153°), the right edge from the north-west (≈ 333°)
    assert (
        abs(np.median(azimuth[:, 0]) - 153.0) < 10 and abs(np.median(azimuth[:, -1]) - 333.0) < 10
    )


def test_geoid_dem_without_its_grid_is_refused(scene, line_files, tmp_path):
    from pyproj import CRS

    from geoboresight.io.terrain import _to_ellipsoid
    from geoboresight.operations.direct_georef import direct_georeference_file

    try:  # with PROJ's EGM96 grid installed the conversion runs: nothing to refuse
        _to_ellipsoid(np.zeros((1, 1)), (1, 0, 661000, 0, -1, 3451000), CRS(scene["dem"].crs),
                      "EPSG:5773", "probe")  # fmt: skip
        pytest.skip("PROJ has the EGM96 grid here")
    except InputError:
        pass
    with pytest.raises(InputError, match="no geoid grid for EGM96"):
        direct_georeference_file(
            line_files["image"], scene["sbet"], output=str(tmp_path / "i.tif"),
            geometry=SensorGeometry(sensor_model=line_files["model"],
                                    line_times=line_files["times"]),
            terrain=Terrain(dem=line_files["dem"], dem_vertical_crs="EPSG:5773"),
        )  # fmt: skip
    assert not os.path.exists(tmp_path / "i.tif")


def test_sensor_model_is_binned_and_trimmed_as_the_header_says(tmp_path):
    from geoboresight.io.navigation import sensor_model_for, write_sensor_model_csv

    full = SensorModel.ideal(40, 20.0)
    path = str(tmp_path / "m.csv")
    write_sensor_model_csv(path, full)
    # Specim's header: binning = {spectral, spatial}; x start in binned pixels (as APL)
    m = sensor_model_for(path, None, 16, {"binning": "{2, 2}", "x start": "4"})
    np.testing.assert_allclose(m.across_rad, full.binned(2).across_rad[4:])
    assert sensor_model_for(path, None, 20, {}).n_pixels == 20  # binning 2 found
    with pytest.raises(InputError, match="match no binning"):
        sensor_model_for(path, None, 17, {})
    with pytest.raises(ParameterError, match="one of them"):
        sensor_model_for(path, 10.0, 17, {})


def test_a_constant_height_needs_no_dem(scene, line_files, tmp_path):
    import rasterio

    from geoboresight.operations.direct_georef import direct_georeference_file

    out = str(tmp_path / "flat.tif")
    direct_georeference_file(
        line_files["image"], scene["sbet"], output=out,
        geometry=SensorGeometry(sensor_model=line_files["model"], line_times=line_files["times"]),
        terrain=Terrain(height=340.0), crs="EPSG:32636",
    )  # fmt: skip
    with rasterio.open(out) as src:
        h = src.read(3)
    np.testing.assert_allclose(h, 340.0, atol=1e-4)
    with pytest.raises(ParameterError, match="output CRS"):
        direct_georeference_file(
            line_files["image"], scene["sbet"], output=str(tmp_path / "x.tif"),
            geometry=SensorGeometry(sensor_model=line_files["model"],
                                    line_times=line_files["times"]),
            terrain=Terrain(height=340.0),
        )  # fmt: skip


def test_hyspex_per_line_navigation_text(tmp_path):
    from geoboresight.io.navigation import read_hyspex_nav

    path = tmp_path / "line_nav.txt"
    path.write_text(
        "# line time lat lon height roll pitch heading\n"
        "0 1000.00 31.1 34.7 1500.0 0.5 -0.2 63.0\n"
        "1 1000.02 31.1001 34.7001 1500.1 0.6 -0.1 63.1\n"
    )
    nav, times = read_hyspex_nav(str(path))
    assert times.tolist() == [1000.0, 1000.02] and nav.heading_deg[1] == pytest.approx(63.1)
    assert read_navigation(str(path)).roll_deg.tolist() == [0.5, 0.6]
    path.write_text("0 1000.0 31.1 34.7 1500.0 0.5 -0.2\n")
    with pytest.raises(InputError, match="has 7 columns"):
        read_hyspex_nav(str(path))


def test_igm_geotiff_is_lossless_float64(tmp_path):
    """The IGM's compression (ZSTD where GDAL has it, else deflate) gives back every bit."""
    import rasterio

    from geoboresight.io.igm import IGM_BANDS, block_writer, fast_compression

    rng = np.random.default_rng(5)
    data = 650000.0 + rng.normal(scale=300.0, size=(3, 300, 70)).cumsum(axis=2)
    data[:, 7, 3] = np.nan
    out = str(tmp_path / "igm.tif")
    with block_writer(out, 70, 300, "EPSG:32636", bands=IGM_BANDS, tags={}) as write:
        write(0, data[:, :256])
        write(256, data[:, 256:])
    with rasterio.open(out) as src:
        back = src.read()
        assert src.compression.name == fast_compression().get("compress", "deflate")
    np.testing.assert_array_equal(np.where(np.isnan(data), -9999.0, data), back)
