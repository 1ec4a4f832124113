"""``shadow-map --dsm`` with a DSM on a map grid read through the line's IGM, and the sun's
position from the acquisition time.

Independent truth: NREL's published SPA example (Reda & Andreas 2004, Table A5.1), the
transverse Mercator meridian convergence γ ≈ Δλ·sin φ, and the second scene model
(``validation/scene_model2.py``), whose DSM and shadows are on the raw grid: here its DSM is
put on a north-up map grid under a flight line heading 30° east of north, and the shadow map
made through the IGM is compared with the model's own shadow.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
import rasterio
from rasterio.crs import CRS
from rasterio.transform import from_origin
from synth import write_gtiff  # noqa: E402

from geoboresight import SurfaceModel, shadow_map_file
from geoboresight.errors import InputError, ParameterError
from geoboresight.io.georef import true_north_bearing, write_igm
from geoboresight.io.sample import raw_grid_matrix, sample_bilinear
from geoboresight.shadow.solar import parse_time, sun_position
from validation.scene_model2 import simulate2, write_scene2

UTM36N = CRS.from_epsg(32636)
HEADING = 30.0  # the raw grid's up (flight direction), clockwise from north
ORIGIN = (700_000.0, 3_500_000.0)  # east of zone 36's central meridian (33°E)


def test_sun_position_is_nrel_spa_published_example():
    # Reda & Andreas (2004), Table A5.1: 17 October 2003, 12:30:30 local (UTC−7), Golden,
    # Colorado; topocentric zenith 50.11162°, azimuth 194.34024° (±0.0003° claimed).
    zen, az = sun_position(
        "2003-10-17T12:30:30-07:00",
        -105.1786,
        39.742476,
        1830.14,
        pressure=820,
        temperature=11,
        delta_t=67,
    )
    assert zen == pytest.approx(50.11162, abs=1e-3)
    assert az == pytest.approx(194.34024, abs=1e-3)
    # Without an offset the time is UTC: the same instant as 19:30:30Z.
    assert sun_position(
        "2003-10-17T19:30:30",
        -105.1786,
        39.742476,
        1830.14,
        pressure=820,
        temperature=11,
        delta_t=67,
    ) == (zen, az)


@pytest.mark.parametrize(
    "text, match",
    [("yesterday", "not an ISO 8601"), ("2009-06-20", "no time of day"), ("", "ISO 8601")],
)
def test_bad_times_name_the_parameter(text, match):
    with pytest.raises(ParameterError, match=match) as e:
        parse_time(text)
    assert "acquisition_time" in str(e.value)


def test_true_north_bearing_is_the_meridian_convergence():
    # On the central meridian grid north is true north; 2° east of it at 45°N, true north
    # leans west of grid north by γ ≈ Δλ·sin φ = 1.414° (first order of the TM series).
    assert true_north_bearing(33.0, 45.0, UTM36N) == pytest.approx(0.0, abs=1e-6)
    assert true_north_bearing(35.0, 45.0, UTM36N) == pytest.approx(
        -2.0 * math.sin(math.radians(45.0)), abs=0.01
    )
    assert true_north_bearing(35.0, 45.0, CRS.from_epsg(4326)) == 0.0


def _unit(bearing):
    b = math.radians(bearing)
    return np.array([math.sin(b), math.cos(b)])  # (east, north)


def _igm(rows, cols, gsd):
    """Each raw pixel centre on the map: columns to the right of the flight direction."""
    r, c = np.mgrid[0:rows, 0:cols] + 0.5
    right, down = _unit(HEADING + 90.0), _unit(HEADING + 180.0)
    x = ORIGIN[0] + gsd * (c * right[0] + r * down[0])
    y = ORIGIN[1] + gsd * (c * right[1] + r * down[1])
    return x, y


def _map_dsm(z, x, y, gsd, cell=0.25):
    """The raw-grid DSM ``z`` drawn on a north-up map grid of ``cell`` m: each map cell
    takes the height of the raw pixel it falls in (blocks stay blocks)."""
    x0, x1 = x.min() - 3 * gsd, x.max() + 3 * gsd
    y0, y1 = y.min() - 3 * gsd, y.max() + 3 * gsd
    w, h = int((x1 - x0) / cell), int((y1 - y0) / cell)
    transform = from_origin(x0, y1, cell, cell)
    cx = x0 + (np.arange(w) + 0.5) * cell
    cy = y1 - (np.arange(h) + 0.5) * cell
    ex, ny = np.meshgrid(cx - ORIGIN[0], cy - ORIGIN[1])
    right, down = _unit(HEADING + 90.0), _unit(HEADING + 180.0)
    col = (ex * right[0] + ny * right[1]) / gsd
    row = (ex * down[0] + ny * down[1]) / gsd
    ri, ci = np.floor(row).astype(int), np.floor(col).astype(int)
    inside = (ri >= 0) & (ri < z.shape[0]) & (ci >= 0) & (ci < z.shape[1])
    out = np.full((h, w), -9999.0, np.float32)
    out[inside] = z[ri[inside], ci[inside]]
    return out, transform


@pytest.fixture(scope="module")
def mapped(tmp_path_factory):
    root = tmp_path_factory.mktemp("dsm_map")
    folder = str(root / "scene")
    sc = simulate2(rows=72, cols=96, seed=0, sun_zenith=35.0, buildings=8, trees=6)
    write_scene2(sc, folder)
    gsd = float(sc.truth["gsd_m"])
    with rasterio.open(os.path.join(folder, "truth_dsm.tif")) as src:
        z = src.read(1).astype(np.float64)
    x, y = _igm(*z.shape, gsd)
    igm = str(root / "igm.tif")
    write_igm(igm, x, y, UTM36N, {})
    dsm, transform = _map_dsm(z, x, y, gsd)
    dsm_path = write_gtiff(
        str(root / "dsm_map.tif"), dsm[None], nodata=-9999.0, crs=UTM36N, transform=transform
    )
    return sc, folder, igm, dsm_path, z, (x, y)


def test_the_igm_gives_the_raw_grid_geometry(mapped):
    sc, folder, igm, dsm_path, z, (x, y) = mapped
    from geoboresight.io.georef import read_coordinates

    m, crs, rms = raw_grid_matrix(read_coordinates(igm))
    gsd = float(sc.truth["gsd_m"])
    right, down = _unit(HEADING + 90.0), _unit(HEADING + 180.0)
    assert np.allclose(m, gsd * np.column_stack([right, down]), atol=1e-9)
    assert rms < 1e-6 and crs == UTM36N
    # The DSM read back at the raw pixel centres is the model's DSM (blocks: exact inside
    # them; a bilinear mix only within half a map cell of a wall).
    with rasterio.open(dsm_path) as src:
        back = sample_bilinear(src, x, y)
    assert np.mean(np.abs(back - z) < 1e-6) > 0.97


def _f1(pred, truth):
    tp = (pred & truth).sum()
    return 2 * tp / (2 * tp + (pred & ~truth).sum() + (~pred & truth).sum())


def test_shadow_map_through_the_igm_finds_the_models_shadow(mapped, tmp_path):
    sc, folder, igm, dsm_path, z, _ = mapped
    sun = sc.truth["sun"]
    v, s = os.path.join(folder, "vnir.hdr"), os.path.join(folder, "swir.hdr")
    raw = tmp_path / "raw.tif"
    shadow_map_file(
        v,
        s,
        output=str(tmp_path / "c_raw.tif"),
        fraction=str(raw),
        surface=SurfaceModel(
            os.path.join(folder, "truth_dsm.tif"),
            sun["zenith_deg"],
            sun["azimuth_deg"],
            sc.truth["gsd_m"],
        ),
    )
    via = tmp_path / "via.tif"
    r = shadow_map_file(
        v,
        s,
        output=str(tmp_path / "c_map.tif"),
        fraction=str(via),
        # On the map the sun's azimuth is from north: the raw grid's + the heading.
        surface=SurfaceModel(
            dsm_path,
            sun["zenith_deg"],
            (sun["azimuth_deg"] + HEADING) % 360.0,
            igm=igm,
        ),
    )
    with rasterio.open(raw) as a, rasterio.open(via) as b:
        f_raw, f_via = a.read(1), b.read(1)
        assert b.crs is None and b.shape == (z.shape)  # the image's grid, not the map's
    truth = sc.shadow_fraction >= 0.5
    assert _f1(f_via >= 0.5, truth) > 0.8
    assert np.mean((f_via >= 0.5) == (f_raw >= 0.5)) > 0.97
    assert (r["dsm_shift_rows"], r["dsm_shift_columns"]) == (0, 0)


def test_acquisition_time_gives_the_sun_at_the_scene(mapped, tmp_path):
    sc, folder, igm, dsm_path, z, (x, y) = mapped
    from pyproj import Transformer

    when = "2010-06-21T09:00:00Z"
    out = tmp_path / "c.tif"
    shadow_map_file(
        os.path.join(folder, "vnir.hdr"),
        os.path.join(folder, "swir.hdr"),
        output=str(out),
        surface=SurfaceModel(dsm_path, igm=igm, acquisition_time=when),
    )
    lon, lat = Transformer.from_crs(32636, 4326, always_xy=True).transform(
        np.median(x), np.median(y)
    )
    zen, az = sun_position(when, lon, lat)
    with rasterio.open(out) as src:
        tags = src.tags()
    assert float(tags["SUN_ZENITH_DEG"]) == pytest.approx(zen, abs=1e-6)
    # Cast on UTM's grid: the true azimuth turned by the meridian convergence there.
    grid_az = (az + true_north_bearing(lon, lat, UTM36N)) % 360
    assert float(tags["SUN_AZIMUTH_DEG"]) == pytest.approx(grid_az, abs=1e-6)
    assert abs(grid_az - az) > 0.5  # 36°E at 31.6°N: the convergence is not negligible
    assert "NREL SPA" in tags["SUN_POSITION"] and tags["IGM"] == igm


def test_bad_map_grid_inputs_give_one_clear_line(mapped, tmp_path):
    sc, folder, igm, dsm_path, z, (x, y) = mapped
    v, s = os.path.join(folder, "vnir.hdr"), os.path.join(folder, "swir.hdr")
    out = str(tmp_path / "x.tif")
    cases = [
        (SurfaceModel(dsm_path, 30.0, 150.0), InputError, "give a DSM on the image's grid, or"),
        (
            SurfaceModel(dsm_path, 30.0, 150.0, acquisition_time="2010-06-21T09:00Z", igm=igm),
            ParameterError,
            "give the sun's position once",
        ),
        (SurfaceModel(None, igm=igm), ParameterError, "'igm' only used with a surface model"),
        (
            SurfaceModel(
                os.path.join(folder, "truth_dsm.tif"),
                cell_size=1.5,
                acquisition_time="2010-06-21T09:00Z",
            ),
            ParameterError,
            "needs the scene's position",
        ),
    ]
    far = str(tmp_path / "igm_far.tif")
    write_igm(far, x - 50_000.0, y, UTM36N, {})
    cases.append((SurfaceModel(dsm_path, 30.0, 150.0, igm=far), InputError, "does not cover"))
    small = str(tmp_path / "igm_small.tif")
    write_igm(small, x[:10], y[:10], UTM36N, {})
    cases.append((SurfaceModel(dsm_path, 30.0, 150.0, igm=small), InputError, "10 × 96 pixels"))
    for surface, error, match in cases:
        with pytest.raises(error, match=match) as e:
            shadow_map_file(v, s, output=out, surface=surface)
        assert "\n" not in str(e.value)
    assert not os.path.exists(out)


def test_sun_shadow_takes_the_acquisition_time(tmp_path):
    from geoboresight import sun_shadow_file

    z = np.zeros((40, 40), np.float32)
    z[15:25, 15:25] = 10.0
    dsm = str(tmp_path / "dsm.tif")
    write_gtiff(dsm, z[None], crs=UTM36N, transform=from_origin(*ORIGIN, 1.0, 1.0))
    when = "2010-06-21T07:00:00+02:00"
    r = sun_shadow_file(dsm, output=str(tmp_path / "t.tif"), acquisition_time=when)
    from pyproj import Transformer

    lon, lat = Transformer.from_crs(32636, 4326, always_xy=True).transform(
        ORIGIN[0] + 20.0, ORIGIN[1] - 20.0
    )
    zen, az = sun_position(when, lon, lat)
    az = (az + true_north_bearing(lon, lat, UTM36N)) % 360
    given = sun_shadow_file(dsm, output=str(tmp_path / "g.tif"), sun_zenith=zen, sun_azimuth=az)
    with rasterio.open(tmp_path / "t.tif") as a, rasterio.open(tmp_path / "g.tif") as b:
        assert np.array_equal(a.read(), b.read())
        assert float(a.tags()["SUN_ZENITH_DEG"]) == pytest.approx(zen, abs=1e-9)
    assert r["shadow_pixels"] == given["shadow_pixels"] > 0
    for kwargs, match in (
        ({}, "needs the sun's position"),
        ({"sun_zenith": 30.0, "acquisition_time": when}, "give the sun's position once"),
        # 01:00 UTC at 35°E in June is before sunrise: the time is named, not 'sun_zenith'.
        ({"acquisition_time": "2010-06-21T03:00:00+02:00"}, "acquisition_time.*below the horizon"),
    ):
        with pytest.raises(ParameterError, match=match):
            sun_shadow_file(dsm, output=str(tmp_path / "x.tif"), **kwargs)
    raw = str(tmp_path / "raw.tif")
    write_gtiff(raw, z[None])
    with pytest.raises(ParameterError, match="needs the scene's position"):
        sun_shadow_file(raw, output=str(tmp_path / "x.tif"), cell_size=1.0, acquisition_time=when)
    assert not os.path.exists(tmp_path / "x.tif")


def test_deshadow_through_the_igm_equals_the_raw_grid_dsm(mapped, tmp_path):
    # The same surface model, once on the image's grid and once on a rotated map grid read
    # through the IGM: the same pairs, sky-view factors and so the same de-shadowed pixels,
    # but at walls, where the map grid's blocks are read back bilinearly. The IGM moved by
    # four pixels (the sky-view factors misplaced) and no DSM at all show the check can fail.
    from geoboresight import deshadow_file

    sc, folder, igm, dsm_path, z, (x, y) = mapped
    sun = sc.truth["sun"]
    gsd = float(sc.truth["gsd_m"])
    moved = str(tmp_path / "igm_moved.tif")
    write_igm(moved, x + 4 * gsd, y, UTM36N, {})
    on_map = (sun["zenith_deg"], (sun["azimuth_deg"] + HEADING) % 360.0)
    surfaces = {
        "raw": SurfaceModel(
            os.path.join(folder, "truth_dsm.tif"), sun["zenith_deg"], sun["azimuth_deg"], gsd
        ),
        "igm": SurfaceModel(dsm_path, *on_map, igm=igm),
        "moved": SurfaceModel(dsm_path, *on_map, igm=moved),
        "none": SurfaceModel(),
    }
    v, s = os.path.join(folder, "vnir.hdr"), os.path.join(folder, "swir.hdr")
    cubes = {}
    for name, surface in surfaces.items():
        out = tmp_path / f"out_{name}.tif"
        shadow = os.path.join(folder, "truth_shadow_fraction.tif")
        deshadow_file(v, s, shadow=shadow, output=str(out), surface=surface)
        with rasterio.open(out) as src:
            cubes[name] = src.read()
    a = cubes["raw"]
    shaded = (sc.shadow_fraction >= 0.9)[None]

    def rel(b):
        ok = np.isfinite(a) & np.isfinite(b) & (np.abs(a) > 1) & shaded
        return np.abs(b[ok] - a[ok]) / np.abs(a[ok])

    assert np.median(rel(cubes["igm"])) < 0.02  # measured 0.006
    assert np.mean(rel(cubes["igm"]) < 0.05) > 0.8  # measured 0.90
    assert np.median(rel(cubes["moved"])) > 0.03  # measured 0.046
    assert np.median(rel(cubes["none"])) > 0.05  # measured 0.12


def _glt(x, y, gsd, cell):
    """A GLT on a north-up map grid of ``cell`` m (EMIT's layout: band 1 sample, band 2 line,
    one-based, 0 = nothing seen): each cell shows the raw pixel its centre falls in."""
    x0, y1 = x.min() - gsd, y.max() + gsd
    w, h = int((x.max() + gsd - x0) / cell), int((y1 - (y.min() - gsd)) / cell)
    ex, ny = np.meshgrid(
        x0 + (np.arange(w) + 0.5) * cell - ORIGIN[0], y1 - (np.arange(h) + 0.5) * cell - ORIGIN[1]
    )
    right, down = _unit(HEADING + 90.0), _unit(HEADING + 180.0)
    col = np.floor((ex * right[0] + ny * right[1]) / gsd).astype(int)
    row = np.floor((ex * down[0] + ny * down[1]) / gsd).astype(int)
    inside = (row >= 0) & (row < x.shape[0]) & (col >= 0) & (col < x.shape[1])
    glt = np.zeros((2, h, w), np.int32)
    glt[0][inside], glt[1][inside] = col[inside] + 1, row[inside] + 1
    return glt, from_origin(x0, y1, cell, cell)


def test_a_glt_places_the_raw_pixels_and_the_dsm(mapped, tmp_path):
    from geoboresight.georef.geoloc import glt_coordinates

    sc, folder, igm, dsm_path, z, (x, y) = mapped
    gsd = float(sc.truth["gsd_m"])
    glt, transform = _glt(x, y, gsd, cell=gsd)
    # Raw pixels at the mean of the cells showing them: within half a cell's diagonal of
    # their centres; the pixels no cell shows (the rotation drops some) from the affine fit.
    gx, gy = glt_coordinates(glt[0], glt[1], None, transform, width=x.shape[1], height=x.shape[0])
    err = np.hypot(gx - x, gy - y)
    assert np.isfinite(err).all() and err.max() < gsd * np.sqrt(2) / 2
    path = write_gtiff(str(tmp_path / "glt.tif"), glt, crs=UTM36N, transform=transform)
    sun = sc.truth["sun"]
    v, s = os.path.join(folder, "vnir.hdr"), os.path.join(folder, "swir.hdr")
    on_map = (sun["zenith_deg"], (sun["azimuth_deg"] + HEADING) % 360.0)
    fractions = {}
    for name, geo in (("igm", {"igm": igm}), ("glt", {"glt": path})):
        out = tmp_path / f"f_{name}.tif"
        shadow_map_file(
            v,
            s,
            output=str(tmp_path / f"c_{name}.tif"),
            fraction=str(out),
            surface=SurfaceModel(dsm_path, *on_map, **geo),
        )
        with rasterio.open(out) as src:
            fractions[name] = src.read(1) >= 0.5
    assert np.mean(fractions["glt"] == fractions["igm"]) > 0.97
    truth = sc.shadow_fraction >= 0.5
    assert _f1(fractions["glt"], truth) > 0.8
    with pytest.raises(ParameterError, match="its IGM or its GLT"):
        shadow_map_file(
            v,
            s,
            output=str(tmp_path / "x.tif"),
            surface=SurfaceModel(dsm_path, *on_map, igm=igm, glt=path),
        )


@pytest.mark.parametrize("lat", [0.0, 31.6, 60.0])
def test_sun_shadow_on_a_geographic_dsm_is_cast_in_metres(tmp_path, lat):
    # A DSM in longitude/latitude (SRTM, Copernicus DEM): its cells are degrees, its heights
    # metres. A 10 m block under a sun 45° from the zenith in the south shades 10 m north of
    # it: 10 m over the metres per 1e-5° of latitude (the textbook series for the WGS 84
    # meridian arc, independent of the code's ellipsoid computation).
    from geoboresight import sun_shadow_file

    z = np.zeros((100, 100), np.float32)
    z[60:80, 40:60] = 10.0
    dsm = str(tmp_path / "dsm.tif")
    write_gtiff(
        dsm, z[None], crs=CRS.from_epsg(4326), transform=from_origin(35.0, lat + 5e-4, 1e-5, 1e-5)
    )
    sun_shadow_file(dsm, output=str(tmp_path / "s.tif"), sun_zenith=45.0, sun_azimuth=180.0)
    with rasterio.open(tmp_path / "s.tif") as src:
        shaded = src.read(1)[:60, 45] > 0.5
    phi = math.radians(lat)
    m_per_deg = 111_132.92 - 559.82 * math.cos(2 * phi) + 1.175 * math.cos(4 * phi)
    assert abs(shaded.sum() - 10.0 / (m_per_deg * 1e-5)) <= 1.0
    assert shaded[-int(shaded.sum()) :].all()  # the rows next to the block, none beyond


def test_a_dsm_in_feet_is_refused(tmp_path):
    from geoboresight import sun_shadow_file

    dsm = str(tmp_path / "ft.tif")
    t = from_origin(980_000.0, 200_000.0, 3.0, 3.0)
    write_gtiff(dsm, np.zeros((1, 20, 20), np.float32), crs=CRS.from_epsg(2263), transform=t)
    with pytest.raises(InputError, match="ft.tif.*US survey feet.*metres"):
        sun_shadow_file(dsm, output=str(tmp_path / "x.tif"), sun_zenith=30.0, sun_azimuth=90.0)
    assert not os.path.exists(tmp_path / "x.tif")


def test_pixels_without_a_surface_model_height_are_judged_by_the_spectra(tmp_path):
    """A surface model covering part of the line (or with nodata holes) left every pixel it
    does not cover 'no shadow': the prior's 'nothing away from the predicted shadow' dropped
    them all. There the map is now the spectral map's, exactly (independent run without a
    surface model: its calibration does not depend on the surface model), with its test of
    sunlit dark materials (blue and the long SWIR's tilt)."""
    folder = str(tmp_path / "scene")
    sc = simulate2(rows=96, cols=128, seed=1, sun_zenith=45.0, buildings=12, trees=4)
    write_scene2(sc, folder)
    sun = sc.truth["sun"]
    v, s = os.path.join(folder, "vnir.hdr"), os.path.join(folder, "swir.hdr")
    with rasterio.open(os.path.join(folder, "truth_dsm.tif")) as src:
        z = src.read(1).astype("float32")
    half = z.shape[1] // 2
    z[:, :half] = np.nan  # the surface model covers the right half of the line only
    part = write_gtiff(str(tmp_path / "part.tif"), z[None], nodata=float("nan"))
    spectral, with_part = tmp_path / "f0.tif", tmp_path / "f1.tif"
    shadow_map_file(v, s, output=str(tmp_path / "c0.tif"), fraction=str(spectral))
    r = shadow_map_file(
        v,
        s,
        output=str(tmp_path / "c1.tif"),
        fraction=str(with_part),
        surface=SurfaceModel(part, sun["zenith_deg"], sun["azimuth_deg"], sc.truth["gsd_m"]),
    )
    with rasterio.open(spectral) as a, rasterio.open(with_part) as b:
        f0, f1 = a.read(1)[:, :half], b.read(1)[:, :half]
    truth = sc.shadow_fraction[:, :half] >= 0.5
    assert truth.sum() > 300  # the uncovered half has shadow to find
    np.testing.assert_array_equal(f1, f0)
    assert _f1(f1 >= 0.5, truth) > 0.5
    assert r["dsm_missing_share"] == pytest.approx(0.5, abs=0.02)
    assert any("no height" in w for w in r["warnings"])


def test_a_time_without_offset_is_said_to_be_read_as_utc(tmp_path):
    # A local time typed without its offset gives another sun without any error: the result
    # says how it was read, and says nothing when the offset is stated.
    from geoboresight import sun_shadow_file

    z = np.zeros((20, 20), np.float32)
    dsm = str(tmp_path / "dsm.tif")
    write_gtiff(dsm, z[None], crs=UTM36N, transform=from_origin(*ORIGIN, 1.0, 1.0))
    naive = sun_shadow_file(
        dsm, output=str(tmp_path / "a.tif"), acquisition_time="2010-06-21T07:00"
    )
    aware = sun_shadow_file(
        dsm, output=str(tmp_path / "b.tif"), acquisition_time="2010-06-21T07:00+00:00"
    )
    with rasterio.open(tmp_path / "a.tif") as a, rasterio.open(tmp_path / "b.tif") as b:
        assert "read as UTC" in a.tags()["SUN_POSITION"]
        assert "read as UTC" not in b.tags()["SUN_POSITION"]
        assert a.tags()["SUN_ZENITH_DEG"] == b.tags()["SUN_ZENITH_DEG"]
    assert naive["shadow_pixels"] == aware["shadow_pixels"]
