"""Geolocation as processing chains write it, and everyday files.

Every fixture is written to a published layout; each docstring names the source of the
layout facts it relies on (see docs/sensors.md and docs/georef.md: "Geolocation written by processing
chains" and "Everyday files"). The truth comes from the simulator's flight geometry
(:func:`geoboresight.simulate.ortho.simulate_ortho`: the map position of every raw pixel).
"""

from __future__ import annotations

import os

import numpy as np
import pytest
import rasterio
from pyproj import CRS as PyCRS
from pyproj import Transformer
from rasterio.transform import from_origin

import geoboresight as gb
from geoboresight.batch import _run_one, read_jobs
from geoboresight.errors import InputError, ParameterError
from geoboresight.io import Grid, write_raster
from geoboresight.io import georef as gio
from geoboresight.io.georef import read_gcps
from geoboresight.io.tables import read_table
from geoboresight.simulate.ortho import CRS as SIM_CRS
from geoboresight.simulate.ortho import simulate_ortho

LINES = 64


def _leftovers(folder):
    return sorted(p.name for p in folder.iterdir())


def _index_raster(path, w, h):
    """Two bands holding each raw pixel's column and line: warped, they say where every map
    cell came from."""
    jj, ii = np.meshgrid(np.arange(w, dtype="float32"), np.arange(h, dtype="float32"))
    write_raster(str(path), np.stack([jj, ii]), Grid(w, h), band_names=["column", "line"])
    return str(path)


def _to_lonlat(e, n):
    tr = Transformer.from_crs(SIM_CRS, "EPSG:4326", always_xy=True)
    return tr.transform(e, n)


def write_apl_igm(path, lon, lat, height, *, projection="Geographic Lat/Lon", extra=""):
    """An IGM as NERC-ARF APL's aplcorr writes it (arsf/APL ``src/geolocation.cpp``: a
    ``BILWriter`` of ``FileWriter::float64`` with 3 bands, lines × samples of the level-1
    data; header lines ``projection = Geographic Lat/Lon``, ``datum ellipsoid = WGS-84``
    (``Ellipsoid::Name()`` of WGS84 in ``src/conversions.cpp``), ``band names = {Longitude,
    Latitude, Height}``, ``x start``/``y start``, ``data ignore value = -9999``
    (``BADDATAVALUE``); ``src/bilwriter.cpp``: ``ENVI``, ``description``, ``lines``,
    ``samples``, ``bands``, ``interleave = bil``, ``data type`` (5: float64), and no ``map
    info`` nor ``byte order`` key, the data in the machine's order)."""
    lines, samples = lon.shape
    cube = np.stack([lon, lat, height]).astype("<f8")  # bands, lines, samples
    with open(path, "wb") as f:
        f.write(np.ascontiguousarray(cube.transpose(1, 0, 2)).tobytes())  # BIL
    hdr = os.path.splitext(str(path))[0] + ".hdr"
    with open(hdr, "w") as f:
        f.write(
            "ENVI\n"
            "description = { DEM-derived geocorrection on Mon Jun  3 10:00:00 2024\n }\n"
            f"lines = {lines}\nsamples = {samples}\nbands = 3\ninterleave = bil\n"
            "data type = 5\n"
            f"projection = {projection}\n"
            "datum ellipsoid = WGS-84\n"
            "band names = {Longitude, Latitude, Height}\n"
            ";These describe which pixels from the original raw image the IGM file positions "
            "relate to.\n"
            "x start = 0\ny start = 0\n"
            "data ignore value = -9999\n" + extra
        )
    return str(path)


@pytest.fixture(scope="module")
def line(tmp_path_factory):
    """A 64-line simulated line: the raw product (an index raster), the true UTM position
    of every raw pixel centre, and the APL-style lon/lat IGM of it (-9999 in a few pixels,
    as aplcorr writes pixels it could not place)."""
    folder = tmp_path_factory.mktemp("apl")
    scene = simulate_ortho("urban", LINES, seed=3)
    e, n, z = scene.igm
    lon, lat = _to_lonlat(e, n)
    lon, lat = np.array(lon), np.array(lat)
    lon[5, :3] = lat[5, :3] = -9999.0
    h, w = e.shape
    return {
        "folder": folder,
        "raw": _index_raster(folder / "raw.tif", w, h),
        "e": e,
        "n": n,
        "igm": write_apl_igm(folder / "line_igm.bil", lon, lat, z),
        "w": w,
        "h": h,
    }


def _sample_nearest(path, x, y):
    """Values of every band at map points (the cell holding each point; NaN on nodata)."""
    with rasterio.open(path) as src:
        data = src.read(masked=True).astype("float64").filled(np.nan)
        t = src.transform  # north-up
    col = np.floor((np.asarray(x, float) - t.c) / t.a).astype(int)
    row = np.floor((np.asarray(y, float) - t.f) / t.e).astype(int)
    inside = (row >= 0) & (row < data.shape[1]) & (col >= 0) & (col < data.shape[2])
    out = np.full((data.shape[0],) + np.shape(x), np.nan)
    out[:, inside] = data[:, row[inside], col[inside]]
    return out


# ------------------------------------------------------------------- geographic IGMs (APL)
def test_apl_lonlat_igm_goes_on_its_utm_zone_in_metres(line, tmp_path):
    """``geolocate --igm line_igm.bil --resolution 1.5``: the CRS comes from APL's header
    lines (GDAL finds none), the grid is the UTM zone of the data (36N for the simulator's
    Negev line), 1.5 m cells, and ≥ 95 % of raw pixels land within one output pixel of their
    true position."""
    with rasterio.open(line["igm"]) as src:
        assert src.crs is None and src.nodata == -9999  # what GDAL sees of APL's header
    out = str(tmp_path / "map.tif")
    r = gb.geolocate_file(line["raw"], line["igm"], output=out, grid=gb.OutputGrid(resolution=1.5))
    assert r["crs"] == "EPSG:32636" and r["resolution"] == 1.5
    assert r["masked_nan"] == 3
    with rasterio.open(out) as ds:
        assert ds.crs.to_epsg() == 32636 and ds.res == (1.5, 1.5)
        assert PyCRS.from_wkt(ds.crs.to_wkt()).axis_info[0].unit_name == "metre"
    got = _sample_nearest(out, line["e"], line["n"])  # (column, line) at each true position
    jj, ii = np.meshgrid(np.arange(line["w"]), np.arange(line["h"]))
    err = np.hypot(got[0] - jj, got[1] - ii)  # raw pixels ≈ 1.5 m = one output pixel
    assert np.mean(err <= 1.0) >= 0.95, np.nanpercentile(err, [50, 95, 99])
    # The default resolution is the median pixel spacing, in metres too.
    r = gb.geolocate_file(line["raw"], line["igm"], output=str(tmp_path / "d.tif"))
    assert r["crs"] == "EPSG:32636" and 1.0 < r["resolution"] < 2.0


def test_no_run_makes_degree_sized_cells(line, tmp_path):
    """The runs that made three 1.5-degree cells are refused or metric, naming the fix."""
    before = _leftovers(tmp_path)
    for kw in ({}, {"igm_crs": "EPSG:4326"}):
        with pytest.raises(ParameterError, match=r"give --resolution \S+ or finer") as exc:
            gb.geolocate_file(
                line["raw"],
                line["igm"],
                output=str(tmp_path / "o.tif"),
                grid=gb.OutputGrid(crs="EPSG:4326", resolution=1.5),
                **kw,
            )
        assert "degree" in str(exc.value) and "\n" not in str(exc.value)
        assert _leftovers(tmp_path) == before
    # Asked in degrees explicitly, at a sensible resolution: cells of about a metre.
    r = gb.geolocate_file(
        line["raw"],
        line["igm"],
        output=str(tmp_path / "g.tif"),
        grid=gb.OutputGrid(crs="EPSG:4326"),
    )
    assert r["crs"] == "EPSG:4326" and r["resolution"] < 1e-4
    r = gb.geolocate_file(
        line["raw"], line["igm"], output=str(tmp_path / "m.tif"), igm_crs="EPSG:4326"
    )
    assert r["crs"] == "EPSG:32636" and r["resolution"] > 0.5


def test_geolocation_arrays_in_degrees_go_on_utm(line, tmp_path):
    """GDAL geolocation arrays (RFC 4: X/Y_DATASET, SRS in the GEOLOCATION domain) holding
    longitude and latitude, as a PRISMA/EMIT-style swath exposes them."""
    lon, lat = _to_lonlat(line["e"], line["n"])
    for name, a in (("lon", lon), ("lat", lat)):
        write_raster(
            str(tmp_path / f"{name}.tif"),
            np.asarray(a)[None],
            Grid(line["w"], line["h"]),
            nodata=None,
            dtype="float64",
        )
    vrt = tmp_path / "swath.vrt"
    vrt.write_text(
        f'<VRTDataset rasterXSize="{line["w"]}" rasterYSize="{line["h"]}">'
        '<Metadata domain="GEOLOCATION">'
        f'<MDI key="X_DATASET">{tmp_path / "lon.tif"}</MDI><MDI key="X_BAND">1</MDI>'
        f'<MDI key="Y_DATASET">{tmp_path / "lat.tif"}</MDI><MDI key="Y_BAND">1</MDI>'
        '<MDI key="PIXEL_OFFSET">0</MDI><MDI key="LINE_OFFSET">0</MDI>'
        '<MDI key="PIXEL_STEP">1</MDI><MDI key="LINE_STEP">1</MDI>'
        '<MDI key="SRS">EPSG:4326</MDI><MDI key="GEOREFERENCING_CONVENTION">PIXEL_CENTER</MDI>'
        "</Metadata>"
        '<VRTRasterBand dataType="Float32" band="1"><SimpleSource>'
        f"<SourceFilename>{line['raw']}</SourceFilename><SourceBand>1</SourceBand>"
        "</SimpleSource></VRTRasterBand></VRTDataset>"
    )
    out = str(tmp_path / "map.tif")
    r = gb.geolocate_file(str(vrt), output=out, grid=gb.OutputGrid(resolution=1.5))
    assert r["crs"] == "EPSG:32636" and r["resolution"] == 1.5
    got = _sample_nearest(out, line["e"], line["n"])[0]
    jj = np.meshgrid(np.arange(line["w"]), np.arange(line["h"]))[0]
    assert np.mean(np.abs(got - jj) <= 1.0) >= 0.95


def test_apltran_headers_are_read_too(line, tmp_path):
    """apltran's output (arsf/APL ``src/transform.cpp``): ``projection = UTM <zone>
    North|South``, ``datum ellipsoid = WGS84`` and ``proj4 projection string = ...``."""
    e, n = line["e"], line["n"]
    z = np.zeros_like(e)
    a = write_apl_igm(tmp_path / "utm.bil", e, n, z, projection="UTM 36 North")
    assert gio.read_coordinates(a).crs.to_epsg() == 32636
    b = write_apl_igm(
        tmp_path / "p4.bil",
        e,
        n,
        z,
        projection="UTM 36 North",
        extra="proj4 projection string = +proj=utm +ellps=WGS84 +zone=36 +datum=WGS84 +units=m\n",
    )
    assert PyCRS.from_wkt(gio.read_coordinates(b).crs.to_wkt()).utm_zone == "36N"
    c = write_apl_igm(tmp_path / "os.bil", e, n, z, projection="osng")
    with pytest.raises(InputError, match=r"'projection = osng'.*give its CRS with --igm-crs"):
        gio.read_coordinates(c)
    assert gio.read_coordinates(c, crs=SIM_CRS).crs.to_epsg() == 32636  # --igm-crs wins


@pytest.mark.parametrize(
    "lonlat,south,expected",
    [((34.7, 31.2), False, 32636), ((-3.2, 50.4), False, 32630), ((151.2, -33.9), True, 32756)],
)
def test_utm_zone_of_the_data(lonlat, south, expected):
    lon, lat = np.full((3, 3), lonlat[0]), np.full((3, 3), lonlat[1])
    assert gio.output_crs(None, gio.parse_crs("EPSG:4326"), lon, lat).to_epsg() == expected
    assert gio.output_crs("EPSG:3857", gio.parse_crs("EPSG:4326"), lon, lat).to_epsg() == 3857
    utm = gio.parse_crs(SIM_CRS)
    assert gio.output_crs(None, utm, lon, lat) is utm  # projected: kept


# -------------------------------------------------------------- coordinates against the CRS
def test_an_igm_whose_values_contradict_its_crs_is_refused(line, tmp_path):
    """UTM metres labelled lon/lat (an APL header over apltran's UTM values; ``--igm-crs
    EPSG:4326`` over a UTM IGM), and degrees labelled UTM: one line naming the input, its
    CRS and what to do; nothing written."""
    e, n = line["e"], line["n"]
    z = np.zeros_like(e)
    wrong = write_apl_igm(tmp_path / "wrong.bil", e, n, z)
    lon, lat = _to_lonlat(e, n)
    degrees = write_apl_igm(tmp_path / "deg.bil", np.asarray(lon), np.asarray(lat), z)
    out = str(tmp_path / "o.tif")
    before = _leftovers(tmp_path)
    with pytest.raises(InputError) as exc:
        gb.geolocate_file(line["raw"], wrong, output=out)
    msg = str(exc.value)
    assert "wrong.bil (CRS EPSG:4326 from its header)" in msg and "\n" not in msg
    assert "cannot be longitude and latitude" in msg and "--igm-crs" in msg
    assert "3450" in msg  # the northing it found, shown
    with pytest.raises(InputError, match=r"from --igm-crs\).*check --igm-crs"):
        gb.geolocate_file(line["raw"], wrong, output=out, igm_crs="EPSG:4326")
    with pytest.raises(InputError, match=r"neighbouring pixels lie [0-9.e-]+ m apart.*degrees"):
        gb.geolocate_file(line["raw"], degrees, output=out, igm_crs=SIM_CRS)
    assert _leftovers(tmp_path) == before


def test_far_off_projected_coordinates_are_refused(line, tmp_path):
    """Eastings of a national grid in feet (EPSG:2263, New York) read as UTM 36N."""
    e, n = line["e"], line["n"]
    x, y = e * 20.0, n * 20.0  # 13 200 km east, 69 000 km north: nowhere in zone 36N
    path = write_apl_igm(tmp_path / "far.bil", x, y, np.zeros_like(x), projection="UTM 36 North")
    with pytest.raises(InputError, match=r"far outside the area where EPSG:32636 is used"):
        gb.geolocate_file(line["raw"], path, output=str(tmp_path / "o.tif"))


def test_gcps_whose_values_contradict_their_crs_are_refused(tmp_path):
    path = tmp_path / "g.csv"
    path.write_text(
        "# CRS: EPSG:4326\npixel,line,x,y\n0,0,660000,3450000\n10,0,660015,3450000\n"
        "0,10,660000,3449985\n"
    )
    with pytest.raises(InputError, match=r"g.csv \(CRS EPSG:4326 from its CRS line\).*--gcp-crs"):
        read_gcps(path)
    assert read_gcps(path, crs=SIM_CRS).crs.to_epsg() == 32636


# ------------------------------------------------------------------------ --igm-crs alone
def test_igm_crs_without_igm_on_a_product_without_geolocation_arrays_is_refused(line, tmp_path):
    before = _leftovers(tmp_path)
    with pytest.raises(InputError) as exc:
        gb.geolocate_file(line["raw"], output=str(tmp_path / "o.tif"), igm_crs=SIM_CRS)
    msg = str(exc.value)
    assert "has no GDAL geolocation arrays" in msg and "it needs --igm" in msg
    assert "\n" not in msg and _leftovers(tmp_path) == before
    with pytest.raises(InputError, match="give its coordinates with --igm .* or --glt"):
        gb.geolocate_file(line["raw"], output=str(tmp_path / "o.tif"))


# ------------------------------------------------------------------------- resolution rules
def test_too_coarse_and_too_large_grids_are_refused_before_any_work(line, tmp_path, monkeypatch):
    out = str(tmp_path / "o.tif")
    before = _leftovers(tmp_path)
    with pytest.raises(ParameterError, match=r"at least 16 along each side.* give --resolution"):
        gb.geolocate_file(line["raw"], line["igm"], output=out, grid=gb.OutputGrid(resolution=40.0))
    # Memory: a machine with 6 MB to spare cannot hold a 0.1 m grid of this line.
    monkeypatch.setattr(gio, "available_memory", lambda: 6_000_000)
    with pytest.raises(ParameterError) as exc:
        gb.geolocate_file(line["raw"], line["igm"], output=out, grid=gb.OutputGrid(resolution=0.1))
    msg = str(exc.value)
    assert "whose warp needs" in msg and "at hand" in msg and "\n" not in msg
    assert _leftovers(tmp_path) == before
    fit = float(msg.split("give --resolution ")[1].split()[0])
    assert 0.1 < fit < 5.0
    r = gb.geolocate_file(
        line["raw"], line["igm"], output=out, grid=gb.OutputGrid(resolution=fit)
    )  # it fits
    assert r["resolution"] == fit


# --------------------------------------------------------------------------------- GLTs
def write_emit_glt(path, sample, line_, transform, *, driver="GTiff", nodata=None):
    """A GLT as EMIT ships it (emit-sds ``emit_utils/reformat.py`` ``single_image_ortho``:
    two bands, ``glt_x`` (sample) then ``glt_y`` (line), one-based, 0 = no data; int32
    (``daac_converter.add_glt``); on an EPSG:4326 grid). Negative indices: ENVI's "GLT and
    bowtie correction" infill (a cell filled from a neighbour; the absolute value is the
    index)."""
    profile = dict(
        driver=driver,
        width=sample.shape[1],
        height=sample.shape[0],
        count=2,
        dtype="int32",
        crs="EPSG:4326",
        transform=transform,
    )
    if nodata is not None:
        profile["nodata"] = nodata
    with rasterio.open(str(path), "w", **profile) as dst:
        dst.write(np.stack([sample, line_]).astype("int32"))
    return str(path)


@pytest.mark.parametrize("driver,nodata", [("GTiff", None), ("ENVI", 0)])
def test_emit_glt_one_based_zero_nodata_round_trip(tmp_path, driver, nodata):
    w, h = 30, 40
    raw = _index_raster(tmp_path / "raw.tif", w, h)
    rng = np.random.default_rng(9)
    rows, cols = rng.integers(0, h, (25, 35)), rng.integers(0, w, (25, 35))
    sample, line_ = cols + 1, rows + 1
    sample[:, :4] = 0  # EMIT's "no data": outside the swath
    line_[-3:] = 0
    sample[10:12] *= -1  # ENVI infill
    line_[12] *= -1
    rows[0, 10] = cols[0, 10] = 0
    sample[0, 10] = line_[0, 10] = 1  # the first raw pixel, one-based
    tr = from_origin(34.70, 31.21, 0.0005, 0.0005)
    glt = write_emit_glt(
        tmp_path / f"glt.{driver}", sample, line_, tr, driver=driver, nodata=nodata
    )
    out = str(tmp_path / "map.tif")
    r = gb.geolocate_file(raw, glt=glt, output=out)
    seen = (sample != 0) & (line_ != 0)
    assert r["valid_pixels"] == int(seen.sum()) and r["crs"] == "EPSG:4326"
    with rasterio.open(out) as ds:
        got = ds.read(masked=True)
        assert ds.transform == tr
    assert np.ma.getmaskarray(got[0])[~seen].all()
    np.testing.assert_array_equal(got[0].data[seen], cols[seen])
    np.testing.assert_array_equal(got[1].data[seen], rows[seen])
    assert got[0][0, 10] == 0 and got[1][0, 10] == 0


def test_a_glt_grid_in_metres_labelled_lonlat_is_refused(tmp_path):
    raw = _index_raster(tmp_path / "raw.tif", 10, 10)
    ones = np.ones((20, 20), "int32")
    glt = write_emit_glt(tmp_path / "g.tif", ones, ones, from_origin(660000, 3450000, 60, 60))
    with pytest.raises(InputError, match=r"GLT .*g.tif: its map grid \(CRS EPSG:4326\)"):
        gb.geolocate_file(raw, glt=glt, output=str(tmp_path / "o.tif"))


# ------------------------------------------------------------------- QGIS .points files
def _gcps(n=8, seed=4):
    rng = np.random.default_rng(seed)
    pl = np.column_stack([rng.uniform(1, 280, n), rng.uniform(1, 60, n)])
    return pl, np.column_stack([660000 + 1.5 * pl[:, 0], 3450000 - 1.5 * pl[:, 1]])


def write_points(
    path, pl, xy, *, crs_wkt=None, header="sourceX,sourceY", enabled=None, residuals=True, sep=","
):
    """A QGIS Georeferencer ``.points`` file. Recent QGIS (``QgsGCPList::saveGcps``,
    src/app/georeferencer/qgsgcplist.cpp): ``#CRS: <WKT>`` then
    ``mapX,mapY,sourceX,sourceY,enable,dX,dY,residual``; earlier releases
    (``QgsGeoreferencerMainWindow::saveGCPs``, the plugin's ``saveGCPs``): the header
    ``mapX,mapY,pixelX,pixelY,...``, with or without ``#CRS:`` first (the release of each
    change not verified); older files without dX/dY/residual and, from the pre-2.0 plugin,
    tab separated (``loadGcps`` splits on tabs when a line has no comma, and reads columns by
    position). The source y of a raster without a geotransform is minus its line."""
    with open(path, "w") as f:
        if crs_wkt:
            f.write(f"#CRS: {crs_wkt}\n")
        cols = ["mapX", "mapY", *header.split(","), "enable"]
        if residuals:
            cols += ["dX", "dY", "residual"]
        f.write(sep.join(cols) + "\n")
        for i, ((p, ln), (a, b)) in enumerate(zip(pl, xy, strict=True)):
            e = 1 if enabled is None else int(enabled[i])
            vals = [a, b, p, -ln, e] + ([0.1, -0.2, 0.22] if residuals else [])
            f.write(sep.join(repr(float(v)) if k != 4 else str(v) for k, v in enumerate(vals)))
            f.write("\n")
    return str(path)


def test_points_files_of_every_qgis_3(tmp_path):
    pl, xy = _gcps()
    enabled = np.ones(len(pl), bool)
    enabled[2] = False
    wkt = PyCRS.from_user_input(SIM_CRS).to_wkt()  # WKT2, as QGIS ≥ 3.26 writes it
    new = read_gcps(write_points(tmp_path / "new.points", pl, xy, crs_wkt=wkt, enabled=enabled))
    np.testing.assert_allclose(new.pixel_line, pl)  # line = -sourceY
    np.testing.assert_allclose(new.xy, xy)
    assert new.crs.to_epsg() == 32636 and new.enabled.tolist() == enabled.tolist()
    old = write_points(tmp_path / "old.points", pl, xy, header="pixelX,pixelY", enabled=enabled)
    assert read_gcps(old).crs is None  # no #CRS line: the CRS comes from --gcp-crs
    got = read_gcps(old, crs=SIM_CRS)
    np.testing.assert_allclose(got.pixel_line, pl)
    assert got.crs.to_epsg() == 32636 and got.enabled.tolist() == enabled.tolist()
    short = read_gcps(
        write_points(tmp_path / "s.points", pl, xy, header="pixelX,pixelY", residuals=False),
        crs=SIM_CRS,
    )
    np.testing.assert_allclose(short.pixel_line, pl)
    tabs = read_gcps(
        write_points(tmp_path / "t.points", pl, xy, header="pixelX,pixelY", sep="\t"),
        crs=SIM_CRS,
    )
    np.testing.assert_allclose(tabs.xy, xy)
    # The user's CRS overrides the file's.
    lonlat = np.column_stack(_to_lonlat(xy[:, 0], xy[:, 1]))
    wgs = PyCRS.from_epsg(4326).to_wkt()
    f = write_points(tmp_path / "ll.points", pl, lonlat, crs_wkt=wgs)
    assert read_gcps(f).crs.to_epsg() == 4326
    with pytest.raises(InputError, match="cannot be longitude and latitude"):
        read_gcps(write_points(tmp_path / "bad.points", pl, xy, crs_wkt=wgs))


def test_georeference_from_qgis_points_in_wgs84_goes_on_utm(tmp_path):
    """A .points file in WGS 84 (#CRS: GEOGCRS...) georeferences onto UTM 36N, in metres;
    the disabled GCP (enable=0) is left out of the fit."""
    w, h = 286, 64
    raw = _index_raster(tmp_path / "raw.tif", w, h)
    pl, xy = _gcps(n=9)
    xy[4] += 500.0  # a blunder, disabled in QGIS
    enabled = np.ones(len(pl), bool)
    enabled[4] = False
    lonlat = np.column_stack(_to_lonlat(xy[:, 0], xy[:, 1]))
    f = write_points(
        tmp_path / "raw.tif.points",
        pl,
        lonlat,
        crs_wkt=PyCRS.from_epsg(4326).to_wkt(),
        enabled=enabled,
    )
    r = gb.georeference_file(
        raw, f, output=str(tmp_path / "map.tif"), grid=gb.OutputGrid(resolution=1.5)
    )
    assert r["crs"] == "EPSG:32636" and r["resolution"] == 1.5 and r["rmse"] < 0.01


# ------------------------------------------------------------ CSVs as spreadsheets save them
def test_gcp_csv_with_bom_semicolons_and_decimal_commas(tmp_path):
    pl, xy = _gcps()
    rows = "".join(
        f"{p:.3f};{ln:.3f};{a:.3f};{b:.3f}\n".replace(".", ",")
        for (p, ln), (a, b) in zip(pl, xy, strict=True)
    )
    path = tmp_path / "g.csv"
    path.write_bytes(("# CRS: EPSG:32636\npixel;line;x;y\n" + rows).encode("utf-8-sig"))
    g = read_gcps(path)
    np.testing.assert_allclose(g.pixel_line, pl, atol=1e-3)
    np.testing.assert_allclose(g.xy, xy, atol=1e-3)
    assert g.crs.to_epsg() == 32636


def test_jobs_csv_saved_by_a_spreadsheet(line, tmp_path):
    """ "CSV UTF-8" (a byte-order mark before the header) and ';'-separated: the parameters
    are named right, and each job runs as the batch's workers run it."""
    outs = [str(tmp_path / f"m{k}.tif") for k in range(2)]
    text = "input;igm;resolution;output\n" + "".join(
        f"{line['raw']};{line['igm']};{r};{o}\n" for r, o in zip(("1.5", "2"), outs, strict=True)
    )
    path = tmp_path / "jobs.csv"
    path.write_bytes(text.encode("utf-8-sig"))
    jobs = read_jobs(str(path))
    assert [sorted(j) for j in jobs] == [["igm", "input", "output", "resolution"]] * 2
    assert jobs[0]["resolution"] == "1.5"  # the spec parses numbers itself
    for job, out in zip(jobs, outs, strict=True):
        result, error = _run_one("geolocate", job, False)
        assert error is None, error
        assert os.path.exists(out) and result["crs"] == "EPSG:32636"
    comma = tmp_path / "c.csv"
    comma.write_bytes(f"input,igm,output\n{line['raw']},{line['igm']},x.tif\n".encode("utf-8-sig"))
    assert read_jobs(str(comma)) == [{"input": line["raw"], "igm": line["igm"], "output": "x.tif"}]


def test_one_table_reader_for_every_delimiter(tmp_path):
    for sep in (",", ";", "\t"):
        p = tmp_path / "t.csv"
        p.write_bytes(f"a{sep}b{sep}c\n1{sep}2{sep}3\n".encode("utf-8-sig"))
        t = read_table(p)
        assert t.header == ["a", "b", "c"] and t.rows == [["1", "2", "3"]] and t.delimiter == sep
    p.write_bytes("a;b\n\xe9;2\n".encode("cp1252"))  # Excel's plain "CSV" on Windows
    assert read_table(p).rows == [["é", "2"]]


@pytest.mark.parametrize("chunked", [False, True])
def test_prisma_geolocation_puts_its_products_on_a_metric_grid(tmp_path, chunked):
    """A PRISMA L1 file's own latitude/longitude arrays (``Latitude_VNIR``/``Longitude_VNIR``,
    the layout facts in tests/products_space.py) place a product of its raw grid:
    ``geolocate --input ratio.tif --igm PRISMA.he5`` gives the data's UTM zone (32N at 9° E),
    cells in metres, and ≥ 95 % of raw pixels within one output pixel of their position."""
    from products_space import write_prisma_l1

    w = write_prisma_l1(tmp_path / "PRS_L1_STD_OFFL.he5", chunked=chunked)
    lat, lon = w.extra["lat"].astype("float64"), w.extra["lon"].astype("float64")
    h, wd = lat.shape
    index = _index_raster(tmp_path / "index.tif", wd, h)  # a product on the cube's raw grid
    out = str(tmp_path / "map.tif")
    r = gb.geolocate_file(index, w.path, output=out, grid=gb.OutputGrid(resolution=30.0))
    assert r["crs"] == "EPSG:32632" and r["resolution"] == 30.0
    e, n = Transformer.from_crs("EPSG:4326", "EPSG:32632", always_xy=True).transform(lon, lat)
    got = _sample_nearest(out, e, n)
    jj, ii = np.meshgrid(np.arange(wd), np.arange(h))
    err = np.hypot(got[0] - jj, got[1] - ii)
    assert np.mean(err <= 1.0) >= 0.95, np.nanpercentile(err, [50, 95, 99])
    with rasterio.open(out) as a:
        assert a.crs.to_epsg() == 32632 and a.res == (30.0, 30.0)
