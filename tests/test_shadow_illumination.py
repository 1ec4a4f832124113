"""Ground-truth shadow simulation (§3.1) against geometry and against GDAL and GRASS.

The analytical truth: a box of height h casts a shadow of length h·tan(zenith) on flat ground.
The independent tools: ``gdaldem hillshade`` (illumination) and GRASS ``r.sunmask`` (cast
shadows). They run when installed and are skipped otherwise, except with
GEOBORESIGHT_REQUIRE_TOOLS=1 (CI), where a missing tool fails the test.
"""

from __future__ import annotations

import math
import os
import shutil
import subprocess

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from geoboresight import io, sun_shadow_file
from geoboresight.algorithms.shadow_truth import SUN_SHADOW
from geoboresight.errors import ParameterError
from geoboresight.shadow.illumination import (
    along_ray,
    cast_shadow,
    grid_matrix,
    halo_rows,
    height_range,
    shadow_fraction,
    unseen_casters,
)
from geoboresight.shadow.incidence import hillshade

CRS = "EPSG:32636"


def need(tool: str) -> str:
    path = shutil.which(tool)
    if path is None:
        if os.environ.get("GEOBORESIGHT_REQUIRE_TOOLS", "") not in ("", "0"):
            pytest.fail(f"{tool} is required (GEOBORESIGHT_REQUIRE_TOOLS=1) but not installed")
        pytest.skip(f"{tool} not installed")
    return path


def scene_dsm() -> np.ndarray:
    """Two buildings on a Gaussian hill: both cast shadows and sloped ground."""
    yy, xx = np.mgrid[0:72, 0:90]
    z = 8.0 * np.exp(-((yy - 50) ** 2 + (xx - 25) ** 2) / (2 * 10.0**2))
    z[15:25, 50:62] += 12.0
    z[42:48, 65:78] += 6.0
    return z.astype("float32")


def write_dsm(path, z, cell=1.5, crs=CRS):
    tr = from_origin(500000.0, 3500000.0, cell, cell)
    kw = dict(driver="GTiff", width=z.shape[1], height=z.shape[0], count=1, dtype="float32")
    if crs:
        kw.update(crs=crs, transform=tr)
    with rasterio.open(path, "w", **kw) as dst:
        dst.write(z, 1)
    return tr


@pytest.mark.parametrize("zenith", [20.0, 30.8, 45.0, 60.0, 72.0])
@pytest.mark.parametrize("azimuth", [0.0, 90.0, 180.0, 270.0])
def test_box_shadow_length_is_h_tan_zenith(zenith, azimuth):
    h, cell = 10.0, 1.0
    z = np.zeros((120, 120))
    z[55:65, 55:65] = h
    length = h * math.tan(math.radians(zenith))
    s = cast_shadow(z, sun_zenith=zenith, sun_azimuth=azimuth, cell_size=cell)
    # Shadow on the side away from the sun, along the box's centre line (row 0 = north).
    away = {0.0: s[65:, 60], 180.0: s[:55, 60][::-1], 90.0: s[60, :55][::-1], 270.0: s[60, 65:]}
    line = away[azimuth]
    n = int(np.argmin(line)) if not line.all() else line.size
    assert line[:n].all() and not line[n:].any()  # one contiguous shadow from the wall
    assert abs(n * cell - length) <= cell  # r.sunmask's whole-cell march: within one cell
    # Sub-cell accuracy from the supersampled fraction: the summed fraction is the length.
    f = shadow_fraction(z, sun_zenith=zenith, sun_azimuth=azimuth, cell_size=cell, supersample=8)
    fline = {0.0: f[65:, 60], 180.0: f[:55, 60], 90.0: f[60, :55], 270.0: f[60, 65:]}[azimuth]
    assert abs(fline.sum() * cell - length) <= 0.25 * cell
    # Nothing on the sunward side, nothing on the roof.
    sun = {0.0: s[:55, 60], 180.0: s[65:, 60], 90.0: s[60, 65:], 270.0: s[60, :55]}[azimuth]
    assert not sun.any() and not s[55:65, 55:65].any()


def test_oblique_sun_shadow_direction_and_length():
    z = np.zeros((100, 100))
    z[40:50, 40:50] = 10.0
    s = cast_shadow(z, sun_zenith=45.0, sun_azimuth=135.0, cell_size=1.0)  # sun in the south-east
    rows, cols = np.nonzero(s)
    # Shadow falls to the north-west: above (smaller rows) and left (smaller cols) of the box.
    assert rows.min() < 40 and cols.min() < 40 and rows.max() < 50 and cols.max() < 50
    # Its reach along the diagonal is 10·tan 45° = 10 m → ≈ 7.07 cells in each axis.
    assert 40 - rows.min() == pytest.approx(10 / math.sqrt(2), abs=1.5)


def test_flat_ground_and_overhead_sun_have_no_shadow():
    z = np.full((30, 30), 5.0)
    assert not cast_shadow(z, sun_zenith=80.0, sun_azimuth=10.0, cell_size=1.0).any()
    z[10:15, 10:15] = 20
    assert not cast_shadow(z, sun_zenith=0.0, sun_azimuth=0.0, cell_size=1.0).any()
    cos_i = hillshade(np.full((10, 10), 3.0), sun_zenith=30.0, sun_azimuth=100.0, cell_size=2.0)
    np.testing.assert_allclose(cos_i, math.cos(math.radians(30.0)), rtol=1e-6)


def test_hillshade_of_a_plane_matches_the_incidence_formula():
    # A plane dipping 20° towards the east: cos i = cos Z cos S + sin Z sin S cos(A − aspect).
    slope, aspect = math.radians(20.0), math.radians(90.0)
    yy, xx = np.mgrid[0:20, 0:20] * 2.0
    z = -np.tan(slope) * xx
    for zen, az in ((30.0, 90.0), (60.0, 270.0), (45.0, 180.0)):
        zr, ar = math.radians(zen), math.radians(az)
        want = math.cos(zr) * math.cos(slope) + math.sin(zr) * math.sin(slope) * math.cos(
            ar - aspect
        )
        got = hillshade(z, sun_zenith=zen, sun_azimuth=az, cell_size=2.0)
        np.testing.assert_allclose(got[1:-1, 1:-1], want, atol=1e-6)


@pytest.mark.parametrize("zenith,azimuth", [(30.8, 161.0), (60.0, 205.8), (45.0, 300.0)])
def test_hillshade_agrees_with_gdaldem(tmp_path, zenith, azimuth):
    gdaldem = need("gdaldem")
    z = scene_dsm()
    tr = write_dsm(tmp_path / "dsm.tif", z)
    out = tmp_path / "hs.tif"
    subprocess.run(
        [
            gdaldem,
            "hillshade",
            "-q",
            "-az",
            str(azimuth),
            "-alt",
            str(90 - zenith),
            str(tmp_path / "dsm.tif"),
            str(out),
        ],
        check=True,
    )
    with rasterio.open(out) as src:
        gdal = src.read(1).astype(float)
    mine = 1.0 + 254.0 * np.clip(
        hillshade(z, sun_zenith=zenith, sun_azimuth=azimuth, transform=tr), 0, None
    )
    # gdaldem leaves the one-cell border as nodata; inside, it rounds to whole bytes.
    diff = np.abs(gdal - mine)[1:-1, 1:-1]
    assert diff.max() <= 0.51
    assert np.ptp(gdal[1:-1, 1:-1]) > 100  # the scene really has varied illumination


def run_sunmask(tmp_path, dsm_path, zenith, azimuth) -> np.ndarray:
    grass = need("grass")
    script = tmp_path / "sunmask.sh"
    out = tmp_path / "sunmask.tif"
    script.write_text(
        "set -e\n"
        f"r.in.gdal input={dsm_path} output=dsm --quiet\n"
        "g.region raster=dsm\n"
        # -z: also process cells at height 0 (r.sunmask skips them otherwise)
        f"r.sunmask -z elevation=dsm output=sh altitude={90 - zenith} azimuth={azimuth} --quiet\n"
        f"r.out.gdal input=sh output={out} format=GTiff type=Byte --quiet\n"
    )
    env = {**os.environ, "GRASS_MESSAGE_FORMAT": "plain"}
    proc = subprocess.run(
        [grass, "--tmp-location", str(dsm_path), "--exec", "bash", str(script)],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    with rasterio.open(out) as src:
        return src.read(1) == 1


@pytest.mark.parametrize(
    "zenith,azimuth", [(30.8, 161.0), (60.0, 205.8), (45.0, 180.0), (70.0, 90.0), (50.0, 315.0)]
)
def test_cast_shadow_agrees_with_grass_r_sunmask(tmp_path, zenith, azimuth):
    z = scene_dsm()
    tr = write_dsm(tmp_path / "dsm.tif", z)
    grass = run_sunmask(tmp_path, tmp_path / "dsm.tif", zenith, azimuth)
    mine = cast_shadow(z, sun_zenith=zenith, sun_azimuth=azimuth, transform=tr)
    assert grass.sum() > 50  # a real shadow to compare
    # Same method (whole-cell march, flat-topped cells): identical up to rare rounding ties.
    assert (mine == grass).mean() >= 0.999
    assert (mine & grass).sum() / (mine | grass).sum() >= 0.98


def test_sun_shadow_spec_streams_and_matches_kernel(tmp_path):
    z = scene_dsm()
    tr = write_dsm(tmp_path / "dsm.tif", z)
    alg = SUN_SHADOW
    res = alg(
        dsm=str(tmp_path / "dsm.tif"),
        sun_zenith=60,
        sun_azimuth=205.8,
        block_rows=7,
        output=str(tmp_path / "f.tif"),
        mask=str(tmp_path / "m.tif"),
        hillshade=str(tmp_path / "h.tif"),
    )
    want = shadow_fraction(z, sun_zenith=60, sun_azimuth=205.8, transform=tr)
    with rasterio.open(tmp_path / "f.tif") as src:
        assert src.crs.to_epsg() == 32636 and src.transform == tr
        np.testing.assert_array_equal(src.read(1), want)
    with rasterio.open(tmp_path / "m.tif") as src:
        m = src.read(1)
        assert src.colormap(1)[1][:3] == (128, 0, 0)
        np.testing.assert_array_equal(m, (want >= 0.5).astype(np.uint8))
    with rasterio.open(tmp_path / "h.tif") as src:
        np.testing.assert_allclose(
            src.read(1), hillshade(z, sun_zenith=60, sun_azimuth=205.8, transform=tr), atol=1e-6
        )
    assert res["shadow_pixels"] == int((want >= 0.5).sum())


def test_dsm_without_geotransform_needs_cell_size(tmp_path):
    z = scene_dsm()
    write_dsm(tmp_path / "raw.tif", z, crs=None)
    alg = SUN_SHADOW
    out = tmp_path / "f.tif"
    with pytest.raises(ParameterError, match="cell-size"):
        alg(dsm=str(tmp_path / "raw.tif"), sun_zenith=45, sun_azimuth=180, output=str(out))
    assert not out.exists() and not list(tmp_path.glob(".f*"))
    alg(
        dsm=str(tmp_path / "raw.tif"),
        sun_zenith=45,
        sun_azimuth=180,
        cell_size=1.5,
        output=str(out),
    )
    with rasterio.open(out) as src:
        assert src.crs is None  # raw stays raw
        np.testing.assert_array_equal(
            src.read(1), shadow_fraction(z, sun_zenith=45, sun_azimuth=180, cell_size=1.5)
        )


@pytest.mark.parametrize("zenith", [-1.0, 90.5, 120.0])
def test_sun_zenith_outside_0_90_is_refused(tmp_path, zenith):
    write_dsm(tmp_path / "dsm.tif", scene_dsm())
    out = tmp_path / "f.tif"
    with pytest.raises(ParameterError, match="sun_zenith"):
        SUN_SHADOW(
            dsm=str(tmp_path / "dsm.tif"), sun_zenith=zenith, sun_azimuth=180, output=str(out)
        )
    with pytest.raises(ParameterError, match="sun_zenith"):
        cast_shadow(scene_dsm(), sun_zenith=zenith, sun_azimuth=180, cell_size=1.0)
    assert not out.exists()


# ------------------------------------------------- strips with a halo equal the whole surface


def strips(func, z, valid, *, block_rows, halo):
    """``func(z, valid)`` run strip by strip through io.map_windows with a halo, in memory."""

    def read(r0, r1):
        return z[r0:r1], valid[r0:r1]

    parts = io.map_windows(
        read, func, height=z.shape[0], width=z.shape[1], block_rows=block_rows, halo=halo
    )
    return np.concatenate([r for _, r in parts], axis=0)


@pytest.mark.parametrize("block_rows", [1, 5, 16, 500])
@pytest.mark.parametrize(
    "zenith,azimuth,surface",
    [
        (60.0, 205.8, "nearest"),  # sun in the south-west: shadows reach north, halo below
        (55.0, 20.0, "nearest"),  # sun in the north: shadows reach south, halo above
        (70.0, 90.0, "bilinear"),  # sun in the east: no rows to cross
        (0.0, 0.0, "nearest"),  # sun overhead
    ],
)
def test_shadow_fraction_by_strips_with_the_halo_equals_the_whole_dsm(
    block_rows, zenith, azimuth, surface
):
    z = scene_dsm().astype(np.float64)
    valid = np.ones(z.shape, bool)
    if surface == "nearest":
        valid[30:33, 5:40] = False  # a nodata patch: it casts no shadow, in a strip or not
    tr = from_origin(500000.0, 3500000.0, 1.5, 1.5)
    lo, hi, n = height_range(z, valid)
    assert n == valid.sum()
    relief = hi - lo
    halo = halo_rows(relief, zenith, azimuth, grid_matrix(tr), z.shape)
    sun = {"sun_zenith": zenith, "sun_azimuth": azimuth, "transform": tr}
    opts = {**sun, "relief": relief, "interpolation": surface, "supersample": 3}
    whole = shadow_fraction(z, valid, **opts)
    got = strips(
        lambda zz, ok: shadow_fraction(zz, ok, **opts), z, valid, block_rows=block_rows, halo=halo
    )
    np.testing.assert_array_equal(got, whole)
    if zenith > 0:
        assert np.nansum(whole) > 20  # a real shadow crosses the strips
    # Horn's 3 × 3 gradient needs one line either side.
    full = np.ones(z.shape, bool)
    hs = strips(
        lambda zz, ok: hillshade(zz, ok, **sun), z, full, block_rows=block_rows, halo=(1, 1)
    )
    np.testing.assert_allclose(hs, hillshade(z, full, **sun), rtol=0, atol=1e-6)


def test_sun_shadow_operation_with_nodata_equals_the_kernel(tmp_path):
    """The operation as a rasterio script calls it: nodata cells stay nodata and cast no shadow."""
    z = scene_dsm()
    z[10:14, 55:60] = -9999.0
    tr = from_origin(500000.0, 3500000.0, 1.5, 1.5)
    path = tmp_path / "dsm.tif"
    with rasterio.open(
        path,
        "w",
        driver="GTiff",
        width=z.shape[1],
        height=z.shape[0],
        count=1,
        dtype="float32",
        crs=CRS,
        transform=tr,
        nodata=-9999.0,
    ) as dst:
        dst.write(z, 1)
    assert SUN_SHADOW.operation is sun_shadow_file
    res = sun_shadow_file(
        str(path),
        output=str(tmp_path / "f.tif"),
        sun_zenith=50.0,
        sun_azimuth=160.0,
        block_rows=6,
    )
    valid = z != -9999.0
    want = shadow_fraction(z, valid, sun_zenith=50.0, sun_azimuth=160.0, transform=tr)
    with rasterio.open(tmp_path / "f.tif") as src:
        got = src.read(1)
    np.testing.assert_array_equal(got[valid], want[valid])
    assert (got[~valid] == io.FLOAT_NODATA).all()
    assert res["valid_pixels"] == int(valid.sum())
    assert res["relief_m"] == pytest.approx(float(z[valid].max() - z[valid].min()), abs=1e-3)


def test_unseen_casters_hold_every_shadow_cast_from_beyond_the_grid():
    """Casters outside a cropped surface model (no higher than its highest surface) shade
    only cells ``unseen_casters`` marks; the mark depends only on each cell's position."""
    rng = np.random.default_rng(3)
    big = np.zeros((90, 90))
    for _ in range(40):  # boxes 2–8 m high everywhere, inside and outside the crop
        r, c = rng.integers(0, 85, 2)
        big[r : r + rng.integers(2, 6), c : c + rng.integers(2, 6)] = rng.uniform(2, 8)
    big[40:44, 40:44] = 8.0  # the crop's highest surface is the highest of all
    crop = (slice(25, 65), slice(25, 65))
    for zen, az in ((35.0, 150.0), (60.0, 300.0), (50.0, 90.0)):
        sun = dict(sun_zenith=zen, sun_azimuth=az, cell_size=1.0)
        whole = cast_shadow(big, **sun)[crop]
        inside = cast_shadow(big[crop], **sun)
        from_beyond = whole & ~inside
        assert from_beyond.sum() > 5  # the case the function is for
        u = unseen_casters(big[crop], top=8.0, **sun)
        assert (u[from_beyond]).all()
        assert u.mean() < 0.5  # and not everything
        # Strips give what the whole grid gives.
        parts = [
            unseen_casters(big[crop][r0 : r0 + 13], top=8.0, row0=r0, height=40, **sun)
            for r0 in range(0, 40, 13)
        ]
        assert np.array_equal(np.vstack(parts), u)
    flat = unseen_casters(np.zeros((5, 5)), sun_zenith=0.0, sun_azimuth=0.0, top=1.0, cell_size=1.0)
    assert not flat.any()


def test_along_ray_follows_the_sun_to_the_edge():
    m = np.ones((10, 12), bool)
    m[4, 6] = False  # one lit cell
    # Towards the sun: one row down and half a column right per step (nearest cell, halves
    # rounded up): the cells whose ray passes through (4, 6) are above it, drifting left.
    out = along_ray(m, (1.0, 0.5, 20))
    expected = {(4, 6)} | {(r, 6 - math.floor(0.5 * (4 - r) + 0.5)) for r in range(4)}
    assert {tuple(x) for x in np.argwhere(~out)} == expected
    assert along_ray(m, (1.0, 0.5, 1))[0, 4]  # one step does not reach it from row 0
