"""Automatic georeferencing on the simulator's truth: a raw line with roll/pitch/yaw jitter,
its true IGM (ray hits on the surface model) and an orthophoto of the same scene."""

from __future__ import annotations

import json

import numpy as np
import pytest
import rasterio

import geoboresight as gb
from geoboresight.errors import InputError
from geoboresight.io import Grid, write_raster
from geoboresight.io.orthoscene import true_corners
from geoboresight.simulate.ortho import HEADING_DEG

LINES = 160
GSD = 1.5
#: The rough placement is off by a few metres at each corner (a hand-read map).
CORNER_ERROR_M = np.array([[6.0, -4.0], [-5.0, 3.0], [4.0, 5.0], [-3.0, -6.0]])


_SCENES: dict = {}


def _simulated(jitter, tmp_path_factory):
    """One simulated scene per jitter for the whole module."""
    if jitter not in _SCENES:
        folder = tmp_path_factory.mktemp("ortho") / "scene"
        gb.simulate_ortho_file(output=str(folder), lines=LINES, jitter_deg=jitter, seed=2)
        _SCENES[jitter] = (jitter, folder)
    return _SCENES[jitter]


@pytest.fixture(scope="module", params=[0.0, 0.05, 0.1], ids=lambda j: f"jitter{j}")
def scene(request, tmp_path_factory):
    return _simulated(request.param, tmp_path_factory)


@pytest.fixture(scope="module")
def scene_005(tmp_path_factory):
    return _simulated(0.05, tmp_path_factory)


@pytest.fixture(scope="module")
def scene_01(tmp_path_factory):
    return _simulated(0.1, tmp_path_factory)


def test_the_true_igm_follows_the_flight_geometry_and_the_jitter(scene):
    jitter, folder = scene
    with rasterio.open(folder / "igm.img") as src:
        igm = src.read()
        assert src.crs.to_epsg() == 32636
    e, n, z = igm
    att = np.loadtxt(folder / "attitude.csv", delimiter=",", skiprows=1)[:, 1:]
    roll, pitch = np.radians(att[:, 0]), np.radians(att[:, 1])
    h = np.radians(HEADING_DEG)
    # Roll moves the line across the track by (H − z)·tan(roll), pitch along it by
    # (H − z)·tan(pitch) (the simulator's geometry, independent of any warp). With those
    # removed, the centre pixel's track is a straight line on the heading, one line spacing
    # per line.
    c = 143
    height = 1500.0 - z[:, c]
    across = height * np.tan(roll)
    along = height * np.tan(pitch)
    e0 = e[:, c] - across * np.cos(h) - along * np.sin(h)
    n0 = n[:, c] + across * np.sin(h) - along * np.cos(h)
    t = np.arange(len(e0))
    de, dn = np.polyfit(t, e0, 1)[0], np.polyfit(t, n0, 1)[0]
    assert np.degrees(np.arctan2(de, dn)) == pytest.approx(HEADING_DEG, abs=0.2)
    assert np.hypot(de, dn) == pytest.approx(GSD, rel=0.01)
    straight = np.hypot(
        e0 - np.polyval(np.polyfit(t, e0, 1), t), n0 - np.polyval(np.polyfit(t, n0, 1), t)
    )
    assert straight.max() < 0.1 * GSD
    # Without that correction the line wobbles when there is jitter.
    if jitter:
        assert np.std(across) > 0.5
    # Across the track, one IFOV at 1,500 m minus the relief: about 1.5 m.
    assert np.median(np.hypot(np.diff(e, axis=1), np.diff(n, axis=1))) == pytest.approx(
        GSD, rel=0.05
    )


def _corners(folder, error=CORNER_ERROR_M):
    with rasterio.open(folder / "igm.img") as src:
        igm = src.read()
    return ",".join(f"{v:.3f}" for v in (true_corners(igm) + error).ravel())


def test_auto_georeference_meets_one_pixel_against_the_true_igm_or_refuses(scene, tmp_path):
    jitter, folder = scene
    out, fitted, report = (str(tmp_path / n) for n in ("auto.tif", "fitted_igm.tif", "auto.json"))
    try:
        r = gb.auto_georeference_file(
            str(folder / "raw.hdr"),
            str(folder / "orthophoto.tif"),
            output=out,
            corners=_corners(folder),
            reference_band=4,  # NIR, as the raw band
            igm_output=fitted,
            report=report,
        )
    except InputError as exc:
        assert "automatic tie points" in str(exc)
        assert list(tmp_path.iterdir()) == []
        assert jitter > 0.05, "the moderate cases must be georeferenced"
        return
    with rasterio.open(fitted) as f, rasterio.open(folder / "igm.img") as t:
        got, truth = f.read(), t.read()
    err_px = np.hypot(got[0] - truth[0], got[1] - truth[1]) / GSD
    rmse = float(np.sqrt(np.mean(err_px**2)))
    assert rmse <= 1.0, (jitter, rmse)
    rep = json.loads(open(report).read())
    assert rep["inliers"] == r["inliers"] >= 12 and rep["rmse_px"] <= 1.0
    assert len(rep["points"]) == r["inliers"]
    # The rough placement alone is worse than the result (the model did the work).
    assert rep["placement"]["rmse_px"] > 0 and rmse < 1.0
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 32636


def test_auto_georeference_refuses_without_texture_far_off_or_without_crs(scene_005, tmp_path):
    jitter, folder = scene_005
    raw, ortho = str(folder / "raw.hdr"), str(folder / "orthophoto.tif")
    with rasterio.open(ortho) as src:
        flat = str(tmp_path / "flat.tif")
        write_raster(flat, np.full((1, src.height, src.width), 0.3, "float32"), src, nodata=None)
        bare = str(tmp_path / "bare.tif")
        write_raster(bare, src.read(4)[None], Grid(src.width, src.height), nodata=None)
    before = sorted(p.name for p in tmp_path.iterdir())
    with pytest.raises(
        InputError, match=r"only \d+ inlier\(s\) of \d+ matches .*at least 12 needed"
    ):
        gb.auto_georeference_file(
            raw, flat, output=str(tmp_path / "o.tif"), corners=_corners(folder)
        )
    far = np.full((4, 2), 150.0)  # 100 px off: beyond --max-shift-px
    with pytest.raises(InputError, match="automatic tie points"):
        gb.auto_georeference_file(
            raw,
            ortho,
            output=str(tmp_path / "o.tif"),
            corners=_corners(folder, far),
            reference_band=4,
        )
    with pytest.raises(InputError, match="reference .*bare.tif has no CRS"):
        gb.auto_georeference_file(
            raw, bare, output=str(tmp_path / "o.tif"), corners=_corners(folder)
        )
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_the_true_igm_geolocates_the_raw_line_onto_the_orthophoto(scene_01, tmp_path):
    """geolocate with the true IGM, then reproject-to the orthophoto's grid: the two overlay
    (correlation of the NIR bands at the same map cells)."""
    jitter, folder = scene_01
    geo = str(tmp_path / "raw_map.tif")
    gb.geolocate_file(str(folder / "raw.hdr"), str(folder / "igm.img"), output=geo)
    on = str(tmp_path / "on_ortho.tif")
    gb.reproject_to_file(geo, str(folder / "orthophoto.tif"), output=on)
    with rasterio.open(on) as a, rasterio.open(folder / "orthophoto.tif") as b:
        x = a.read(1, masked=True)
        y = b.read(4)
    ok = ~np.ma.getmaskarray(x)
    assert ok.mean() > 0.3
    r_same = np.corrcoef(x.data[ok], y[ok])[0, 1]
    shifted = np.roll(y, 2, axis=1)  # two orthophoto cells off: the overlay is worse
    r_off = np.corrcoef(x.data[ok], shifted[ok])[0, 1]
    assert r_same > 0.9 and r_same > r_off + 0.05, (r_same, r_off)
