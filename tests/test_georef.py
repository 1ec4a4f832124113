"""Georeferencing: transforms against GDAL's, GCP files, IGM/GLT geolocation through GDAL's
geolocation-array warper, reproject-to, and every bad input of georeferencing (one line, nothing
left on disk)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin
from scipy import ndimage

import geoboresight as gb
from geoboresight.errors import GeoboresightError, InputError, ParameterError
from geoboresight.georef.geoloc import clean_igm, corner_geoloc, glt_indices
from geoboresight.georef.transforms import MIN_GCPS, fit_transform
from geoboresight.io import Grid, create_class_raster, quiet_georef, write_raster
from geoboresight.io.georef import read_gcps

CRS = "EPSG:32636"
W, H = 60, 90


def _rotation_model(pixel, line, wobble=0.0):
    """A raw line on the map: 30° heading, 1.3 m across, 1.6 m along, and an along-track
    wobble (m) of the whole line across the track (roll) and along it (pitch)."""
    h = np.radians(30.0)
    a = 1.3 * np.asarray(pixel, float) + wobble * 2.0 * np.sin(2 * np.pi * np.asarray(line) / 37.0)
    b = 1.6 * np.asarray(line, float) + wobble * 1.0 * np.cos(2 * np.pi * np.asarray(line) / 23.0)
    x = 660000.0 + a * np.cos(h) + b * np.sin(h)
    y = 3450000.0 - a * np.sin(h) + b * np.cos(h)
    return x, y


def _index_raster(path, w=W, h=H, dtype="float32"):
    """Two bands holding each raw pixel's column and line: warped, they say where every map
    cell came from."""
    jj, ii = np.meshgrid(np.arange(w, dtype=dtype), np.arange(h, dtype=dtype))
    write_raster(str(path), np.stack([jj, ii]), Grid(w, h), band_names=["column", "line"])
    return str(path)


def _igm(path, x, y, crs=CRS, nodata=None):
    profile = dict(driver="ENVI", width=x.shape[1], height=x.shape[0], count=2, dtype="float64")
    if crs:
        profile["crs"] = crs
    if nodata is not None:
        profile["nodata"] = nodata
    with quiet_georef(), rasterio.open(str(path), "w", **profile) as dst:
        dst.write(np.stack([x, y]))
    return str(path)


def _centres(model, w=W, h=H):
    jj, ii = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5)
    return model(jj, ii)


def _sample(path, x, y, order=1):
    """Values of every band of a map raster at map points (bilinear, NaN off the valid data)."""
    with rasterio.open(path) as src:
        data = src.read(masked=True)
        a, b, c, d, e, f = tuple(src.transform)[:6]
    x, y = np.asarray(x, float), np.asarray(y, float)
    det = a * e - b * d
    col = ((x - c) * e - (y - f) * b) / det
    row = ((y - f) * a - (x - c) * d) / det
    out = []
    mask = np.ma.getmaskarray(data[0]).astype(float)
    # Bilinear where the four cells around the point are valid; at the footprint's edge, the
    # cell holding the point; NaN outside.
    edge = ndimage.map_coordinates(mask, [row - 0.5, col - 0.5], order=1, cval=1.0) > 0
    off = ndimage.map_coordinates(mask, [row - 0.5, col - 0.5], order=0, cval=1.0) > 0
    for band in data:
        filled = band.filled(0).astype(float)
        v = ndimage.map_coordinates(filled, [row - 0.5, col - 0.5], order=order)
        near = ndimage.map_coordinates(filled, [row - 0.5, col - 0.5], order=0)
        out.append(np.where(off, np.nan, np.where(edge, near, v)))
    return np.stack(out)


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir())


# ------------------------------------------------------------------ transforms: GDAL's oracle
@pytest.mark.skipif(shutil.which("gdaltransform") is None, reason="GDAL command-line tools")
@pytest.mark.parametrize(
    "method,order", [("polynomial", 1), ("polynomial", 2), ("polynomial", 3), ("tps", 1)]
)
def test_transforms_agree_with_gdaltransform(method, order):
    rng = np.random.default_rng(1)
    pl = np.column_stack([rng.uniform(0, 286, 15), rng.uniform(0, 600, 15)])
    x, y = _rotation_model(pl[:, 0], pl[:, 1], wobble=3.0)
    xy = np.column_stack([x + 1e-3 * pl[:, 1] ** 2, y]) + rng.normal(0, 0.8, (15, 2))
    fit = fit_transform(pl, xy, method=method, order=order)
    test = np.array([[3.0, 5.0], [140.0, 300.0], [280.0, 590.0], [50.0, 420.5]])
    args = ["gdaltransform"] + (["-tps"] if method == "tps" else ["-order", str(order)])
    for (p, ln), (a, b) in zip(pl, xy, strict=True):
        args += ["-gcp", *(repr(float(v)) for v in (p, ln, a, b))]
    out = subprocess.run(
        args,
        input="\n".join(f"{p} {ln}" for p, ln in test),
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    gdal = np.array([[float(v) for v in s.split()[:2]] for s in out.strip().splitlines()])
    ours = np.column_stack(fit(test[:, 0], test[:, 1]))
    np.testing.assert_allclose(ours, gdal, atol=1e-5)
    if method == "polynomial":  # least-squares residuals: data minus model, at the GCPs
        np.testing.assert_allclose(fit.residuals, xy - np.column_stack(fit(*pl.T)), atol=1e-9)
        assert fit.rmse == pytest.approx(np.sqrt(np.mean(np.sum(fit.residuals**2, axis=1))))


def test_an_exact_model_is_recovered_and_tps_residuals_are_cross_validated():
    rng = np.random.default_rng(2)
    pl = np.column_stack([rng.uniform(0, W, 12), rng.uniform(0, H, 12)])
    xy = np.column_stack(_rotation_model(*pl.T))
    fit = fit_transform(pl, xy, order=1)
    assert fit.rmse < 1e-6
    np.testing.assert_allclose(
        np.column_stack(fit(10.0, 20.0)).ravel(), _rotation_model(10.0, 20.0), atol=1e-6
    )
    assert fit.rmse_px < 1e-6
    wob = np.column_stack(_rotation_model(*pl.T, wobble=2.0))
    tps = fit_transform(pl, wob, method="tps")
    np.testing.assert_allclose(np.column_stack(tps(*pl.T)), wob, atol=1e-6)  # exact at GCPs...
    assert tps.rmse > 0.05  # ...but its reported residuals are each GCP predicted without it


@pytest.mark.parametrize("order", [1, 2, 3])
def test_too_few_gcps_say_how_many(order):
    n = MIN_GCPS[order] - 1
    pl = np.column_stack([np.linspace(0, 50, n), np.linspace(0, 80, n) ** 1.5 / 10])
    with pytest.raises(
        ParameterError,
        match=rf"{n} GCP\(s\) given but a polynomial of order {order} needs at least {MIN_GCPS[order]}",
    ):
        fit_transform(pl, pl * 2, order=order)


def test_collinear_gcps_are_refused():
    pl = np.column_stack([np.linspace(0, 50, 8), np.linspace(0, 80, 8)])
    with pytest.raises(ParameterError, match="lie on one line"):
        fit_transform(pl, pl * 2 + 5, order=1)
    # Not on one line, but on a conic: degenerate for a second-order polynomial.
    t = np.linspace(0, 2 * np.pi, 9)[:-1]
    circle = np.column_stack([30 + 20 * np.cos(t), 40 + 20 * np.sin(t)])
    with pytest.raises(ParameterError, match="collinear \\(or too clustered\\).*order 2"):
        fit_transform(circle, circle * 2, order=2)


# ------------------------------------------------------------------------------ GCP files
def _gcp_rows(n=9, seed=3, noise=0.5):
    rng = np.random.default_rng(seed)
    pl = np.column_stack([rng.uniform(2, W - 2, n), rng.uniform(2, H - 2, n)])
    pl[:4] = [[0.5, 0.5], [W - 0.5, 0.5], [W - 0.5, H - 0.5], [0.5, H - 0.5]]  # the corners
    x, y = _rotation_model(*pl.T)
    return pl, np.column_stack([x, y]) + rng.normal(0, noise, (n, 2))


def _write_csv(path, pl, xy, crs=CRS):
    with open(path, "w") as f:
        if crs:
            f.write(f"# CRS: {crs}\n")
        f.write("pixel,line,x,y\n")
        for (p, ln), (a, b) in zip(pl, xy, strict=True):
            f.write(f"{p},{ln},{a},{b}\n")
    return str(path)


def _write_points(path, pl, xy, enabled=None, crs=CRS):
    from pyproj import CRS as PyCRS

    with open(path, "w") as f:
        f.write(f"#CRS: {PyCRS.from_user_input(crs).to_wkt()}\n")
        f.write("mapX,mapY,pixelX,pixelY,enable,dX,dY,residual\n")
        for i, ((p, ln), (a, b)) in enumerate(zip(pl, xy, strict=True)):
            e = 1 if enabled is None else int(enabled[i])
            f.write(f"{a},{b},{p},{-ln},{e},0,0,0\n")
    return str(path)


def test_qgis_points_file_reads_as_the_csv(tmp_path):
    pl, xy = _gcp_rows()
    enabled = np.ones(len(pl), bool)
    enabled[5] = False
    a = read_gcps(_write_csv(tmp_path / "g.csv", pl, xy))
    b = read_gcps(_write_points(tmp_path / "g.points", pl, xy, enabled))
    np.testing.assert_allclose(a.pixel_line, b.pixel_line)  # QGIS's negative lines, turned
    np.testing.assert_allclose(a.xy, b.xy)
    assert a.crs == b.crs and a.crs.to_epsg() == 32636
    assert b.enabled.tolist() == enabled.tolist()


# ----------------------------------------------------------------------------- georeference
def test_georeferenced_gcps_corners_and_interior_land_within_the_reported_residuals(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    pl, xy = _gcp_rows(n=12)
    gcps = _write_csv(tmp_path / "g.csv", pl, xy)
    out = tmp_path / "geo.tif"
    r = gb.georeference_file(
        src,
        gcps,
        output=str(out),
        report=str(tmp_path / "r.json"),
        order=2,
        grid=gb.OutputGrid(resolution=0.5),
    )
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["gcps"] == 12 and rep["order"] == 2 and rep["rmse"] == pytest.approx(r["rmse"])
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 32636 and ds.res == (0.5, 0.5)
        assert ds.tags()["RESAMPLING"] == "bilinear"
    # Each GCP's map point shows the raw position the model sends there: the map distance
    # between that raw position and the GCP's is the GCP's reported residual (1 cell of slack).
    got = _sample(str(out), xy[:, 0], xy[:, 1])  # (column, line) found at the GCPs' map points
    found = np.column_stack(r_model := _model_of(rep, got.T + 0.5))
    gap = np.hypot(*(found - xy).T)
    for point, g in zip(rep["points"], gap, strict=True):
        assert g <= point["residual"] + 0.5, (point, g)
    # The image corners land where the fitted model puts them (within a cell).
    with rasterio.open(out) as ds:
        valid = ds.read_masks(1) > 0
        rows, cols = np.nonzero(valid)
        xs, ys = ds.xy(rows, cols)
    fit = fit_transform(pl, xy, order=2)
    cx, cy = fit(np.array([0, W, W, 0.0]), np.array([0, 0, H, H.__float__()]))
    assert abs(min(xs) - cx.min()) < 1.0 and abs(max(xs) - cx.max()) < 1.0
    assert abs(min(ys) - cy.min()) < 1.0 and abs(max(ys) - cy.max()) < 1.0
    del r_model


def _model_of(report, pixel_line):
    """The map position of raw positions under the report's polynomial (refitted from its
    points, which hold the GCPs)."""
    pts = report["points"]
    pl = np.array([[p["pixel"], p["line"]] for p in pts])
    xy = np.array([[p["x"], p["y"]] for p in pts])
    fit = fit_transform(pl, xy, order=report["order"])
    return fit(pixel_line[:, 0], pixel_line[:, 1])


def test_classes_survive_nearest_resampling_exactly(tmp_path):
    rng = np.random.default_rng(4)
    classes = ndimage.zoom(rng.integers(0, 5, (9, 6)), 10, order=0).astype("uint8")[:H, :W]
    path = str(tmp_path / "classes.tif")
    with create_class_raster(
        path,
        Grid(W, H),
        tags={"product": "classes"},
        band_name="class",
        colormap={k: (40 * k, 255 - 40 * k, 0, 255) for k in range(5)},
        category_names={k: f"class {k}" for k in range(5)},
    ) as dst:
        dst.write(classes, 1)
    idx = _index_raster(tmp_path / "idx.tif")
    pl, xy = _gcp_rows(n=10)
    gcps = _write_csv(tmp_path / "g.csv", pl, xy)
    out, where = str(tmp_path / "c_map.tif"), str(tmp_path / "i_map.tif")
    r = gb.georeference_file(path, gcps, output=out, order=1, grid=gb.OutputGrid(resolution=0.7))
    gb.georeference_file(
        idx, gcps, output=where, order=1, grid=gb.OutputGrid(resolution=0.7, resampling="nearest")
    )
    assert r["resampling"] == "nearest"  # chosen from the colour table
    with rasterio.open(out) as c, rasterio.open(where) as i:
        got = c.read(1, masked=True)
        col, line = i.read(1), i.read(2)
        assert c.colormap(1)[3][:3] == (120, 135, 0)
        assert c.nodata == 255
    ok = ~np.ma.getmaskarray(got)
    assert ok.sum() > 0.5 * W * H
    # Every map cell holds exactly the class of the raw pixel it came from.
    src = classes[line[ok].astype(int), col[ok].astype(int)]
    np.testing.assert_array_equal(got.data[ok], src)
    assert set(np.unique(got.data[ok])) <= set(range(5))


def test_gcp_files_that_cannot_georeference_give_one_line_and_leave_nothing(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    pl, xy = _gcp_rows(n=6)
    cases = {
        "too_few.csv": (
            pl[:5],
            xy[:5],
            {"order": 2},
            r"5 GCP\(s\) given but a polynomial of order 2 needs at least 6",
        ),
        "outside.csv": (
            pl + np.array([[0, 0]] * 5 + [[W + 10, 0]]),
            xy,
            {},
            r"GCP\(s\) 6 lie outside the input \(60 × 90",
        ),
        "line.csv": (
            np.column_stack([np.arange(6) * 5.0, np.arange(6) * 7.0]),
            xy,
            {},
            "lie on one line",
        ),
        "nocrs.csv": (pl, xy, {"crs_none": True}, "names no CRS"),
    }
    before = _leftovers(tmp_path)
    for name, (p, q, kw, message) in cases.items():
        gcps = _write_csv(tmp_path / name, p, q, crs=None if kw.pop("crs_none", False) else CRS)
        before = _leftovers(tmp_path)
        with pytest.raises(GeoboresightError, match=message) as exc:
            gb.georeference_file(
                src, gcps, output=str(tmp_path / "o.tif"), report=str(tmp_path / "o.json"), **kw
            )
        assert "\n" not in str(exc.value)
        assert _leftovers(tmp_path) == before
    with pytest.raises(ParameterError, match="parameter 'crs': unknown CRS 'EPSG:99999999'"):
        gb.georeference_file(
            src,
            _write_csv(tmp_path / "ok.csv", pl, xy),
            output=str(tmp_path / "o.tif"),
            grid=gb.OutputGrid(crs="EPSG:99999999"),
        )
    assert not (tmp_path / "o.tif").exists()


# -------------------------------------------------------------------------------- geolocate
def test_igm_round_trip_puts_raw_pixels_within_one_pixel_of_their_igm_position(tmp_path):
    """Synthetic IGM: rotation, scale and an along-track wobble; the warp is GDAL's."""
    src = _index_raster(tmp_path / "idx.tif")
    x, y = _centres(lambda p, ln: _rotation_model(p, ln, wobble=3.0))
    igm = _igm(tmp_path / "igm.img", x, y)
    out = str(tmp_path / "map.tif")
    r = gb.geolocate_file(src, igm, output=out, grid=gb.OutputGrid(resolution=0.5))
    assert r["masked_nan"] == 0 and r["masked_non_monotonic"] == 0
    got = _sample(out, x, y)  # (column, line) found at every raw pixel's IGM position
    jj, ii = np.meshgrid(np.arange(W), np.arange(H))
    err = np.hypot(got[0] - jj, got[1] - ii)
    assert np.mean(err < 1.0) >= 0.95, np.nanpercentile(err, [50, 95])
    # No gaps inside the footprint, nodata outside it.
    with rasterio.open(out) as ds:
        valid = ds.read_masks(1) > 0
        inside = _footprint_mask(ds, x, y)
    assert valid[ndimage.binary_erosion(inside, iterations=2)].all()
    assert not valid[~ndimage.binary_dilation(inside, iterations=3)].any()


def _footprint_mask(ds, x, y):
    """Map cells inside the polygon through the outer pixel centres (rasterio.features)."""
    from rasterio.features import rasterize
    from shapely.geometry import Polygon

    ring = np.concatenate(
        [
            np.column_stack([x[0], y[0]]),
            np.column_stack([x[:, -1], y[:, -1]]),
            np.column_stack([x[-1, ::-1], y[-1, ::-1]]),
            np.column_stack([x[::-1, 0], y[::-1, 0]]),
        ]
    )
    return rasterize([(Polygon(ring), 1)], out_shape=ds.shape, transform=ds.transform).astype(bool)


def test_geolocate_a_cube_keeps_wavelengths_in_band_tags_and_the_imagery_domain(tmp_path):
    from tests.synth import write_envi

    cube = np.random.default_rng(5).uniform(0, 1, (3, H, W)).astype("float32")
    path = write_envi(tmp_path / "cube.img", cube, [450.0, 650.0, 860.0])
    x, y = _centres(_rotation_model)
    out = str(tmp_path / "cube_map.tif")
    gb.geolocate_file(path, _igm(tmp_path / "igm.img", x, y), output=out)
    with rasterio.open(out) as ds:
        assert ds.count == 3
        assert ds.tags(3)["wavelength"] == "860.0000"
        assert ds.tags(3, ns="IMAGERY")["CENTRAL_WAVELENGTH_UM"] == "0.860000"
    assert gb.open_cube([out]).wavelengths.tolist() == [450.0, 650.0, 860.0]


def test_igm_nans_and_fold_overs_are_masked_and_counted(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    x, y = _centres(_rotation_model)
    x[10:12, 20:25] = np.nan
    x[40, 30], y[40, 30] = x[40, 30] + 9.0, y[40, 30] + 9.0  # a spike
    x[60, [7, 8]], y[60, [7, 8]] = x[60, [8, 7]], y[60, [8, 7]]  # two pixels swapped
    clean = clean_igm(x, y)
    assert (clean.nan, clean.non_monotonic) == (10, 3)
    assert not clean.valid[40, 30] and not clean.valid[60, 7] and not clean.valid[60, 8]
    logged = []
    out = str(tmp_path / "map.tif")
    r = gb.geolocate_file(
        src, _igm(tmp_path / "igm.img", x, y), output=out, progress=gb.Progress(log=logged.append)
    )
    assert (r["masked_nan"], r["masked_non_monotonic"]) == (10, 3)
    assert any("10 pixel(s) without coordinates" in m and "3 non-monotonic" in m for m in logged)
    # The masked raw pixels are not drawn: no map cell takes their values.
    xt, yt = _centres(_rotation_model)
    got = _sample(out, xt[40:41, 30], yt[40:41, 30], order=0)[:, 0]
    assert np.isnan(got).all() or not (abs(got[0] - 30) < 0.5 and abs(got[1] - 40) < 0.5)


def test_an_igm_of_another_size_or_without_crs_is_refused_and_nothing_left(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    x, y = _centres(_rotation_model, w=W, h=H + 5)
    igm = _igm(tmp_path / "igm.img", x, y)
    before = _leftovers(tmp_path)
    with pytest.raises(
        InputError, match=r"IGM .*igm.img is 60 × 95 .* but input .*idx.tif is 60 × 90"
    ):
        gb.geolocate_file(src, igm, output=str(tmp_path / "o.tif"))
    x, y = _centres(_rotation_model)
    bare = _igm(tmp_path / "bare.img", x, y, crs=None)
    before = _leftovers(tmp_path)
    with pytest.raises(InputError, match="carries no CRS in its header: give it with --igm-crs"):
        gb.geolocate_file(src, bare, output=str(tmp_path / "o.tif"))
    with pytest.raises(ParameterError, match="parameter 'igm_crs': unknown CRS 'UTM 36'"):
        gb.geolocate_file(src, bare, output=str(tmp_path / "o.tif"), igm_crs="UTM 36")
    assert _leftovers(tmp_path) == before
    r = gb.geolocate_file(
        src, bare, output=str(tmp_path / "o.tif"), igm_crs=CRS, grid=gb.OutputGrid(crs="EPSG:4326")
    )
    assert r["crs"] == "EPSG:4326" and r["resolution"] < 1e-3  # degrees


def test_gdal_geolocation_arrays_carried_by_a_vrt(tmp_path):
    """A product whose GEOLOCATION metadata names X/Y arrays (GDAL RFC 4), subsampled ×2."""
    src = _index_raster(tmp_path / "idx.tif")
    jj, ii = np.meshgrid(np.arange(0, W, 2) + 0.5, np.arange(0, H, 2) + 0.5)
    gx, gy = _rotation_model(jj, ii)
    for name, a in (("lon", gx), ("lat", gy)):
        write_raster(
            str(tmp_path / f"{name}.tif"),
            a[None],
            Grid(a.shape[1], a.shape[0]),
            nodata=None,
            dtype="float64",
        )
    vrt = tmp_path / "geo.vrt"
    with rasterio.open(src) as s:
        vrt.write_text(
            f'<VRTDataset rasterXSize="{W}" rasterYSize="{H}">'
            '<Metadata domain="GEOLOCATION">'
            f'<MDI key="X_DATASET">{tmp_path / "lon.tif"}</MDI><MDI key="X_BAND">1</MDI>'
            f'<MDI key="Y_DATASET">{tmp_path / "lat.tif"}</MDI><MDI key="Y_BAND">1</MDI>'
            '<MDI key="PIXEL_OFFSET">0</MDI><MDI key="LINE_OFFSET">0</MDI>'
            '<MDI key="PIXEL_STEP">2</MDI><MDI key="LINE_STEP">2</MDI>'
            f'<MDI key="SRS">{CRS}</MDI><MDI key="GEOREFERENCING_CONVENTION">PIXEL_CENTER</MDI>'
            "</Metadata>"
            '<VRTRasterBand dataType="Float32" band="1"><SimpleSource>'
            f"<SourceFilename>{src}</SourceFilename><SourceBand>1</SourceBand>"
            f"</SimpleSource></VRTRasterBand></VRTDataset>"
        )
        assert s.count == 2
    out = str(tmp_path / "map.tif")
    gb.geolocate_file(
        str(vrt), output=out, grid=gb.OutputGrid(resolution=0.5)
    )  # the product's own arrays
    x, y = _centres(_rotation_model)
    got = _sample(out, x, y)[0]
    jcol = np.meshgrid(np.arange(W), np.arange(H))[0]
    assert np.nanmean(np.abs(got - jcol) < 1.0) >= 0.95


# ----------------------------------------------------------------------------------- GLT
def _glt_case(tmp_path, shift=0):
    """A GLT on a 1 m grid sending each map cell to a known raw pixel (one-based)."""
    rng = np.random.default_rng(6)
    rows = rng.integers(0, H, (40, 50))
    cols = rng.integers(0, W, (40, 50))
    sample, line = cols + 1, rows + 1
    sample[:5] = 0  # no pixel seen
    line[5:8] = -line[5:8]  # AVIRIS-NG: filled from a neighbour
    sample[-1, -1] += shift
    path = str(tmp_path / "glt.tif")
    write_raster(
        path,
        np.stack([sample, line]).astype("int32"),
        crs=CRS,
        transform=from_origin(660000, 3450000, 1, 1),
        nodata=None,
        dtype="int32",
    )
    return path, rows, cols


def test_glt_lookup_is_exact(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    glt, rows, cols = _glt_case(tmp_path)
    out = str(tmp_path / "map.tif")
    r = gb.geolocate_file(src, glt=glt, output=out)
    with rasterio.open(out) as ds:
        got = ds.read(masked=True)
        assert ds.transform == from_origin(660000, 3450000, 1, 1)
    assert np.ma.getmaskarray(got[0])[:5].all()
    np.testing.assert_array_equal(got[0][5:], cols[5:])
    np.testing.assert_array_equal(got[1][5:], rows[5:])
    assert r["valid_pixels"] == 35 * 50
    assert glt_indices(np.array([[1, W + 1]]), np.array([[1, 1]]), width=W, height=H)[3] == 1


def test_a_glt_pointing_outside_the_product_is_refused(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    glt, *_ = _glt_case(tmp_path, shift=W)
    before = _leftovers(tmp_path)
    with pytest.raises(
        InputError, match=r"GLT .*glt.tif: 1 cell\(s\) point outside input .*60 × 90"
    ):
        gb.geolocate_file(src, glt=glt, output=str(tmp_path / "o.tif"))
    assert _leftovers(tmp_path) == before


def test_corner_geoloc_is_the_top_left_corner_gdal_expects():
    x, y = _centres(_rotation_model)
    g = corner_geoloc(x, y)
    assert g.shape == (2, H + 1, W + 1)
    cx, cy = _rotation_model(np.array([0.0, 7.0, W]), np.array([0.0, 11.0, H]))
    np.testing.assert_allclose(g[0][[0, 11, H], [0, 7, W]], cx, atol=1e-6)
    np.testing.assert_allclose(g[1][[0, 11, H], [0, 7, W]], cy, atol=1e-6)


# ---------------------------------------------------------------------------- reproject-to
def test_reproject_to_takes_the_reference_grid_exactly(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    x, y = _centres(_rotation_model)
    geo = str(tmp_path / "geo.tif")
    gb.geolocate_file(
        src, _igm(tmp_path / "igm.img", x, y), output=geo, grid=gb.OutputGrid(resolution=0.5)
    )
    ref = str(tmp_path / "ortho.tif")
    write_raster(
        ref,
        np.zeros((1, 150, 170), "uint8"),
        crs=CRS,
        transform=from_origin(659990.0, 3450130.0, 0.8, 0.8),
        nodata=None,
    )
    out = str(tmp_path / "on_ref.tif")
    r = gb.reproject_to_file(geo, ref, output=out)
    with rasterio.open(out) as o, rasterio.open(ref) as f:
        assert (o.crs, o.transform, o.shape) == (f.crs, f.transform, f.shape)
    assert r["resampling"] == "bilinear"
    # The same map points give the same raw positions on both grids.
    px, py = _rotation_model(np.array([10.5, 30.5]), np.array([20.5, 70.5]))
    np.testing.assert_allclose(_sample(out, px, py), _sample(geo, px, py), atol=0.35)


def test_reproject_to_refuses_raw_products_and_references_without_crs(tmp_path):
    src = _index_raster(tmp_path / "idx.tif")
    ref = str(tmp_path / "plain.tif")
    write_raster(ref, np.zeros((1, 10, 10), "uint8"), Grid(10, 10), nodata=None)
    before = _leftovers(tmp_path)
    with pytest.raises(InputError, match="reference .*plain.tif has no CRS"):
        gb.reproject_to_file(src, ref, output=str(tmp_path / "o.tif"))
    good = str(tmp_path / "ref.tif")
    write_raster(
        good,
        np.zeros((1, 10, 10), "uint8"),
        crs=CRS,
        transform=from_origin(0, 10, 1, 1),
        nodata=None,
    )
    before = _leftovers(tmp_path)
    with pytest.raises(InputError, match="raw sensor geometry .*geolocate .*georeference"):
        gb.reproject_to_file(src, good, output=str(tmp_path / "o.tif"))
    assert _leftovers(tmp_path) == before


def test_reproject_to_moves_vectors_with_pyproj(tmp_path):
    from pyproj import Transformer
    from shapely.geometry import Point, box

    from geoboresight.io.georef import read_vector
    from geoboresight.io.vector import write_vector

    crs = rasterio.CRS.from_string(CRS)
    vec = str(tmp_path / "shadow.gpkg")
    write_vector(
        vec,
        [box(660000, 3450000, 660010, 3450020), Point(660100, 3450100)],
        {"cls": np.array([1, 2])},
        crs=crs,
        layer="shadow",
    )
    ref = str(tmp_path / "ref.tif")
    write_raster(
        ref,
        np.zeros((1, 5, 5), "uint8"),
        crs="EPSG:4326",
        transform=from_origin(34, 32, 0.1, 0.1),
        nodata=None,
    )
    out = str(tmp_path / "shadow_4326.geojson")
    r = gb.reproject_to_file(vec, ref, output=out)
    geoms, fields, got_crs, _ = read_vector(out)
    assert r["features"] == 2 and got_crs.to_epsg() == 4326 and list(fields["cls"]) == [1, 2]
    lon, lat = Transformer.from_crs(CRS, "EPSG:4326", always_xy=True).transform(660100, 3450100)
    assert geoms[1].x == pytest.approx(lon, abs=1e-9) and geoms[1].y == pytest.approx(lat, abs=1e-9)


def test_shadow_polygons_of_a_geolocated_product_are_in_map_coordinates(tmp_path):
    """Vector products carry the raster's CRS: after geolocation they are on the map."""
    from geoboresight.io.georef import read_vector

    classes = np.zeros((H, W), "uint8")
    classes[20:40, 10:30] = 1
    path = str(tmp_path / "classes.tif")
    with create_class_raster(
        path,
        Grid(W, H),
        tags={},
        band_name="class",
        colormap={0: (0, 0, 0, 255), 1: (255, 0, 0, 255)},
        category_names={0: "lit", 1: "shadow"},
    ) as dst:
        dst.write(classes, 1)
    x, y = _centres(_rotation_model)
    geo = str(tmp_path / "classes_map.tif")
    gb.geolocate_file(path, _igm(tmp_path / "igm.img", x, y), output=geo)
    gb.shadow_polygons_file(geo, output=str(tmp_path / "poly.gpkg"))
    geoms, _, crs, _ = read_vector(str(tmp_path / "poly.gpkg"))
    assert crs.to_epsg() == 32636
    assert all(659000 < g.centroid.x < 661000 and 3449000 < g.centroid.y < 3451000 for g in geoms)


def test_faces_share_the_specs(tmp_path):
    from geoboresight.algorithms import registry

    algs = registry()
    for name in (
        "geolocate",
        "georeference",
        "auto-georeference",
        "reproject-to",
        "simulate-ortho",
    ):
        assert name in algs
        assert getattr(gb, algs[name].run.__name__) is algs[name].operation
    assert os.path.isdir(os.path.dirname(gb.__file__))
