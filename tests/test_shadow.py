"""Shadow application (§3.1): Table 2 classes, class tables, the shadow cluster, the fraction
model, the dark-pixel baseline and polygons — against the paper's table, SciPy/scikit-learn and
synthetic truth; bad input leaves no output."""

from __future__ import annotations

import json
import shutil
import subprocess

import numpy as np
import pytest
import rasterio
from scipy.stats import linregress
from sklearn.metrics import r2_score

from geoboresight import io, shadow_classes_file
from geoboresight.algorithms import ratio as ratio_specs
from geoboresight.algorithms import shadow as shadow_specs
from geoboresight.algorithms import shadow_truth as truth_specs
from geoboresight.errors import InputError, OutputError, ParameterError
from geoboresight.operations._shadow_tables import (
    class_polygons,
    class_shapes,
    class_table_csv,
    read_class_table,
    write_class_table,
)
from geoboresight.shadow.classes import (
    NODATA_CLASS,
    TABLE2,
    ShadowClass,
    default_table,
    validate_classes,
)
from geoboresight.shadow.cluster import fit_shadow_cluster, shadow_mask
from geoboresight.shadow.darkpixel import fit_dark_pixel
from geoboresight.shadow.fraction import FractionAccumulator, FractionModel, fit_fraction_model
from geoboresight.shadow.polygons import shadow_pixels, shadow_polygons
from tests.synth import TRANSFORM, UTM, write_envi, write_gtiff

# The specs of this domain (and the ratio), imported directly: the same objects registry() lists.
ALG = {
    a.name: a for a in (*shadow_specs.ALGORITHMS, *truth_specs.ALGORITHMS, *ratio_specs.ALGORITHMS)
}
BLOCKS = (1, 7, 16, 1000)


def by_windows(func, *arrays, block_rows, halo=(0, 0)):
    """``func`` run strip by strip through io.map_windows on in-memory arrays (rows on axis -2),
    the strips' results stacked back along the rows."""
    height, width = arrays[0].shape[-2:]

    def read(r0, r1):
        return tuple(a[..., r0:r1, :] for a in arrays)

    parts = [
        r
        for _, r in io.map_windows(
            read, func, height=height, width=width, block_rows=block_rows, halo=halo
        )
    ]
    if isinstance(parts[0], tuple):
        return tuple(np.concatenate(p, axis=-2) for p in zip(*parts, strict=True))
    return np.concatenate(parts, axis=-2)


def write_ratio(path, ratio, nodata=-9999.0, crs=UTM, transform=TRANSFORM):
    data = np.where(np.isfinite(ratio), ratio, nodata).astype("float32")[None]
    return write_gtiff(path, data, nodata=nodata, crs=crs, transform=transform)


# ------------------------------------------------------------------------------ Table 2


def test_table2_is_the_papers_table():
    t = default_table()
    got = [(c.id, c.min, c.max, c.fraction_min, c.fraction_max) for c in t.classes]
    # The paper's class 1 is 3.4–4; the deepest shadow has the highest ratio, so above 4 is
    # class 1 too (open-ended), not "no shadow".
    assert got == [
        (1, 3.4, float("inf"), 0.8, 1.0),
        (2, 2.5, 3.4, 0.5, 0.8),
        (3, 2.1, 2.5, 0.2, 0.5),
        (4, 1.9, 2.1, 0.1, 0.2),
    ]
    # Figure 6–7 colours: maroon, magenta, cyan, yellow.
    assert [c.hex for c in t.classes] == ["#800000", "#ff00ff", "#00ffff", "#ffff00"]


def test_classify_boundaries_and_nodata():
    r = np.array([3.5, 3.4, 4.0, 4.01, 3.39, 2.5, 2.2, 2.1, 2.0, 1.9, 1.89, np.nan, 3.0])
    valid = np.ones(r.shape, bool)
    valid[-1] = False
    c = default_table().classify(r, valid)
    assert c.dtype == np.uint8
    assert c.tolist() == [1, 1, 1, 1, 2, 2, 3, 3, 4, 4, 0, NODATA_CLASS, NODATA_CLASS]
    m = default_table().mask(c, 0.5)
    assert m.tolist() == [1, 1, 1, 1, 1, 1, 0, 0, 0, 0, 0, 255, 255]


def test_class_table_csv_roundtrip_and_json(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text(class_table_csv(default_table()))
    assert read_class_table(p).classes == TABLE2
    write_class_table(tmp_path / "w.csv", default_table())
    assert (tmp_path / "w.csv").read_text() == p.read_text()
    j = tmp_path / "t.json"
    j.write_text(
        json.dumps(
            [
                {
                    "class": 1,
                    "min": 5,
                    "max": "inf",
                    "fraction_min": 0.5,
                    "fraction_max": 1,
                    "name": "core",
                    "colour": "#102030",
                },
                {"class": 2, "min": 3, "max": 5, "name": "edge", "colour": "1,2,3"},
            ]
        )
    )
    t = read_class_table(j)
    assert t.classes[0].colour == (16, 32, 48) and t.classes[1].colour == (1, 2, 3)
    assert t.classify(np.array([1e6, 4.0, 2.9])).tolist() == [1, 2, 0]


@pytest.mark.parametrize(
    "rows,match",
    [
        ("1,3.4,4,0.8,1,a,#800000\n2,2.5,3.5,0.5,0.8,b,#ff00ff\n", "overlaps"),
        ("1,4,3.4,0.8,1,a,#800000\n", "unordered"),
        (
            "1,3.4,4,0.8,1,a,#800000\n2,1.9,2.1,0.1,0.2,b,#ffff00\n3,2.5,3.4,0.5,0.8,c,#ff00ff\n",
            "ratio order",
        ),
        ("1,3.4,4,80,100,a,#800000\n", "0–1"),
        ("1,3.4,4,0.8,1,a,#800000\n1,2.5,3.4,0.5,0.8,b,#ff00ff\n", "repeat"),
        ("1,3.4,4,0.8,1,a,maroon\n", "colour"),
    ],
)
def test_bad_class_tables_are_refused_and_leave_no_output(tmp_path, rows, match):
    p = tmp_path / "bad.csv"
    p.write_text("class,min,max,fraction_min,fraction_max,name,colour\n" + rows)
    with pytest.raises(ParameterError, match=match):
        read_class_table(p)
    ratio = write_ratio(tmp_path / "r.tif", np.full((20, 20), 3.0))
    out = tmp_path / "c.tif"
    with pytest.raises(ParameterError):
        ALG["shadow-classes"](
            ratio=ratio, classes=str(p), output=str(out), mask=str(tmp_path / "m.tif")
        )
    assert sorted(x.name for x in tmp_path.iterdir()) == ["bad.csv", "r.tif"]


def test_validate_rejects_touching_is_fine():
    t = validate_classes(
        [
            ShadowClass(1, 2.0, 3.0, 0.5, 1.0, "a", (1, 1, 1)),
            ShadowClass(2, 1.0, 2.0, 0.0, 0.5, "b", (2, 2, 2)),
        ]
    )
    assert t.classify(np.array([2.0, 1.99, 3.0])).tolist() == [1, 2, 1]


def test_shadow_classes_spec_writes_a_styled_byte_raster(tmp_path):
    rng = np.random.default_rng(0)
    ratio = rng.uniform(1.5, 4.2, (70, 50))
    ratio[:5] = np.nan  # nodata lines
    src = write_ratio(tmp_path / "r.tif", ratio)
    out, mask = tmp_path / "classes.tif", tmp_path / "mask.tif"
    res = ALG["shadow-classes"](ratio=src, output=str(out), mask=str(mask), block_rows=16)
    want = default_table().classify(ratio)
    with rasterio.open(out) as ds:
        got = ds.read(1)
        assert ds.dtypes[0] == "uint8" and ds.nodata == 255
        assert ds.crs.to_string() == UTM and ds.transform == TRANSFORM
        cmap = ds.colormap(1)
        assert cmap[1][:3] == (128, 0, 0) and cmap[2][:3] == (255, 0, 255)
        assert cmap[3][:3] == (0, 255, 255) and cmap[4][:3] == (255, 255, 0)
        assert ds.tags(1)["CLASS_1"] == "80-100 % shadow"
    np.testing.assert_array_equal(got, want)
    assert (got[:5] == 255).all()
    with rasterio.open(mask) as ds:
        np.testing.assert_array_equal(ds.read(1), default_table().mask(want, 0.5))
    assert res["class_1_pixels"] == int((want == 1).sum())
    # GDAL itself reads the class names (what QGIS shows in the legend).
    if shutil.which("gdalinfo"):
        info = subprocess.run(["gdalinfo", str(out)], capture_output=True, text=True).stdout
        assert "Categories:" in info and "80-100 % shadow" in info and "no shadow" in info


@pytest.mark.parametrize("block_rows", BLOCKS)
def test_classes_by_windows_equal_one_call(block_rows):
    rng = np.random.default_rng(5)
    ratio = rng.uniform(1.5, 4.2, (53, 31))
    valid = rng.random(ratio.shape) > 0.1
    table = default_table()

    def kernel(r, ok):
        c = table.classify(r, ok)
        return c, table.mask(c, 0.5)

    c, m = by_windows(kernel, ratio, valid, block_rows=block_rows)
    whole = table.classify(ratio, valid)
    np.testing.assert_array_equal(c, whole)
    np.testing.assert_array_equal(m, table.mask(whole, 0.5))


def test_classes_operation_is_a_plain_function(tmp_path):
    """A rasterio script calls the operation itself; the spec runs the very same function."""
    rng = np.random.default_rng(6)
    ratio = rng.uniform(1.5, 4.2, (40, 30))
    src = write_ratio(tmp_path / "r.tif", ratio)
    assert ALG["shadow-classes"].operation is shadow_classes_file
    res = shadow_classes_file(src, output=str(tmp_path / "a.tif"), block_rows=9)
    assert res == ALG["shadow-classes"](ratio=src, output=str(tmp_path / "b.tif")) | {
        "output": str(tmp_path / "a.tif")
    }
    with rasterio.open(tmp_path / "a.tif") as a, rasterio.open(tmp_path / "b.tif") as b:
        np.testing.assert_array_equal(a.read(1), b.read(1))
    with pytest.raises(OutputError, match="exists"):
        shadow_classes_file(src, output=str(tmp_path / "a.tif"))


def test_all_nodata_ratio_is_refused_without_output(tmp_path):
    src = write_ratio(tmp_path / "r.tif", np.full((30, 30), np.nan))
    for name, extra in (
        ("shadow-classes", {"mask": str(tmp_path / "m.tif")}),
        ("shadow-fraction-apply", {}),
    ):
        out = tmp_path / f"{name}.tif"
        with pytest.raises(InputError, match="no valid pixel"):
            ALG[name](ratio=src, output=str(out), **extra)
        assert sorted(x.name for x in tmp_path.iterdir()) == ["r.tif"]


# ------------------------------------------------------------------------------ the cluster


def two_population_scene(n_rows=80, n_cols=60, seed=0):
    """Sunlit pixels (ratio ≈ 2, bright NIR) and an isolated shadow cluster (ratio ≈ 4, dark)."""
    rng = np.random.default_rng(seed)
    shadow = np.zeros((n_rows, n_cols), bool)
    shadow[20:45, 10:30] = True
    shadow[60:75, 40:55] = True
    ratio = np.where(
        shadow,
        rng.lognormal(np.log(4.0), 0.06, shadow.shape),
        rng.lognormal(np.log(2.0), 0.12, shadow.shape),
    )
    nir = np.where(
        shadow,
        rng.lognormal(np.log(200), 0.05, shadow.shape),
        rng.lognormal(np.log(550), 0.15, shadow.shape),
    )
    return ratio, nir, shadow


def test_cluster_recovers_the_isolated_shadow_population():
    ratio, nir, shadow = two_population_scene()
    cl = fit_shadow_cluster(ratio, nir)
    p = cl.probability(ratio, nir)
    pred = p >= 0.5
    assert (pred == shadow).mean() >= 0.995
    assert cl.isolation > 2.0  # well separated (Bhattacharyya distance)
    assert cl.shadow_share == pytest.approx(shadow.mean(), abs=0.01)
    # The outline passes around the shadow population's centre.
    ex, ey = cl.ellipse(2.0)
    assert ex.min() < 4.0 < ex.max() and ey.min() < 200 < ey.max()


@pytest.mark.parametrize("block_rows", BLOCKS)
def test_cluster_probability_by_windows_equals_one_call(block_rows):
    ratio, nir, _ = two_population_scene()
    valid = np.ones(ratio.shape, bool)
    valid[3:9, 4:20] = False
    cl = fit_shadow_cluster(ratio, nir)

    def kernel(r, v, ok):
        p = cl.probability(r, v, ok)
        return p, shadow_mask(p)

    p, m = by_windows(kernel, ratio, nir, valid, block_rows=block_rows)
    whole = cl.probability(ratio, nir, valid)
    np.testing.assert_allclose(p, whole, rtol=1e-6, atol=1e-7, equal_nan=True)
    np.testing.assert_array_equal(m, shadow_mask(whole))
    assert (m[~valid] == 255).all()


def test_cluster_spec_end_to_end(tmp_path):
    ratio, nir, shadow = two_population_scene()
    ratio[0, :] = np.nan
    src = write_ratio(tmp_path / "r.tif", ratio)
    wl = np.array([800.0, 900.0, 941.0, 970.0])
    cube = np.stack([nir * 1.2, nir * 1.1, nir, nir * 0.9]).astype("float32")
    vnir = write_envi(tmp_path / "vnir.img", cube, wl, crs=UTM, transform=TRANSFORM)
    res = ALG["shadow-cluster"](
        ratio=src,
        vnir=vnir,
        output=str(tmp_path / "m.tif"),
        probability_output=str(tmp_path / "p.tif"),
        plot=str(tmp_path / "scatter.png"),
        block_rows=13,
    )
    assert res["nir_band"] == 3
    with rasterio.open(tmp_path / "m.tif") as ds:
        m = ds.read(1)
        assert ds.crs.to_string() == UTM
    assert (m[0] == 255).all()
    assert (m[1:] == shadow[1:]).mean() >= 0.995
    assert (tmp_path / "scatter.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ------------------------------------------------------------------------- fraction model


def test_fraction_fit_recovers_the_papers_line_and_r2():
    rng = np.random.default_rng(1)
    f = rng.uniform(0, 1, 5000)
    r = -0.74 * f + 1.31 + rng.normal(0, 0.07, f.size)
    m = fit_fraction_model(r, f)
    ref = linregress(f, r)
    assert m.slope == pytest.approx(-0.74, abs=0.01) and m.intercept == pytest.approx(
        1.31, abs=0.01
    )
    assert m.r2 == pytest.approx(r2_score(r, m.ratio(f)), rel=1e-9)
    assert m.r2 == pytest.approx(ref.rvalue**2, rel=1e-12)
    # Streaming over blocks gives the same line as all pixels at once.
    acc = FractionAccumulator()
    for chunk in np.array_split(np.arange(f.size), 7):
        acc.add(r[chunk] + 1000.0, f[chunk])  # a large offset must not cost precision
    s = acc.model()
    assert s.slope == pytest.approx(ref.slope, rel=1e-9)
    assert s.intercept == pytest.approx(ref.intercept + 1000.0, rel=1e-12)
    assert s.r2 == pytest.approx(ref.rvalue**2, rel=1e-9)
    assert s.stderr == pytest.approx(ref.stderr, rel=1e-6)
    # Inverse: the model's own ratios map back to their fractions.
    np.testing.assert_allclose(m.fraction(m.ratio(f)), f, atol=1e-6)


@pytest.mark.parametrize("block_rows", BLOCKS)
def test_fraction_fit_by_windows_equals_one_fit(block_rows):
    rng = np.random.default_rng(7)
    f = rng.uniform(0, 1, (45, 28))
    r = -0.74 * f + 1.31 + rng.normal(0, 0.07, f.shape)
    sel = rng.random(f.shape) > 0.3

    def read(r0, r1):
        return r[r0:r1], f[r0:r1], sel[r0:r1]

    acc = io.reduce_windows(
        read,
        lambda *block: block,
        lambda total, block: total.add(*block),
        FractionAccumulator(),
        height=f.shape[0],
        width=f.shape[1],
        block_rows=block_rows,
    )
    got, want = acc.model(), fit_fraction_model(r, f, sel)
    assert got.n == want.n == int(sel.sum())
    assert got.slope == pytest.approx(want.slope, rel=1e-9)
    assert got.intercept == pytest.approx(want.intercept, rel=1e-9)
    assert got.r2 == pytest.approx(want.r2, rel=1e-9)


@pytest.mark.parametrize("block_rows", BLOCKS)
@pytest.mark.parametrize("clip", [True, False])
def test_fraction_apply_by_windows_equals_one_call(block_rows, clip):
    rng = np.random.default_rng(8)
    ratio = rng.uniform(0.3, 1.5, (37, 22))
    valid = rng.random(ratio.shape) > 0.05
    model = FractionModel(-0.74, 1.31)
    got = by_windows(
        lambda r, ok: model.fraction(r, ok, clip=clip), ratio, valid, block_rows=block_rows
    )
    np.testing.assert_array_equal(got, model.fraction(ratio, valid, clip=clip))


def test_fraction_errors():
    with pytest.raises(InputError, match="vary"):
        fit_fraction_model(np.array([1.0, 2, 3, 4]), np.ones(4))
    with pytest.raises(InputError, match="too few"):
        fit_fraction_model(np.array([1.0, 2]), np.array([0.1, 0.2]))
    with pytest.raises(ParameterError, match="slope"):
        FractionModel(0.0, 1.0)


def test_fraction_fit_and_apply_specs(tmp_path):
    rng = np.random.default_rng(2)
    f = rng.uniform(0, 1, (60, 40)).astype("float32")
    r = (0.9 * f + 2.5 + rng.normal(0, 0.02, f.shape)).astype("float32")
    mask = (f > 0.3).astype("uint8")
    src = write_ratio(tmp_path / "r.tif", r)
    truth = write_gtiff(tmp_path / "f.tif", f[None], crs=UTM, transform=TRANSFORM)
    mpath = write_gtiff(tmp_path / "m.tif", mask[None], crs=UTM, transform=TRANSFORM)
    res = ALG["shadow-fraction-fit"](
        ratio=src,
        truth=truth,
        mask=mpath,
        block_rows=9,
        report=str(tmp_path / "fit.json"),
        plot=str(tmp_path / "fit.png"),
    )
    ref = linregress(f[mask == 1], r[mask == 1])
    assert res["slope"] == pytest.approx(ref.slope, rel=1e-6)
    assert res["r2"] == pytest.approx(ref.rvalue**2, rel=1e-6)
    assert res["n"] == int(mask.sum())
    assert (tmp_path / "fit.png").stat().st_size > 1000
    ALG["shadow-fraction-apply"](
        ratio=src, model=str(tmp_path / "fit.json"), output=str(tmp_path / "fa.tif")
    )
    with rasterio.open(tmp_path / "fa.tif") as ds:
        got = ds.read(1)
    want = np.clip((r - ref.intercept) / ref.slope, 0, 1)
    np.testing.assert_allclose(got, want, atol=1e-5)
    assert np.abs(got - f).mean() < 0.03


# ----------------------------------------------------------------------- dark-pixel baseline


def test_dark_pixel_matched_filter_properties_and_its_dark_material_failure():
    rng = np.random.default_rng(3)
    n = 20000
    kind = rng.choice(3, n, p=[0.7, 0.15, 0.15])  # 0 sunlit bright, 1 shadow, 2 sunlit asphalt
    base = np.array([[300, 400, 450, 700], [60, 50, 40, 45], [70, 70, 72, 75]], float)
    x = (base[kind] * rng.lognormal(0, 0.05, (n, 4))).T
    model = fit_dark_pixel(x, nir_index=3, dark_percentile=20)
    phi = model.shadow_function(x[:, :, None])[:, 0]
    # Φ = 0 at the scene mean, 1 at the candidates' mean (the matched filter's definition).
    assert float(model.filter @ (model.mean - model.mean)) == 0.0
    assert float(model.filter @ (model.dark_mean - model.mean)) == pytest.approx(1.0)
    m = phi >= 0.5
    assert m[kind == 1].mean() > 0.95  # finds the shadow ...
    assert m[kind == 2].mean() > 0.5  # ... and calls dark asphalt shadow: the paper's point
    assert m[kind == 0].mean() < 0.01


@pytest.mark.parametrize("block_rows", BLOCKS)
def test_dark_pixel_by_windows_equals_one_call(block_rows):
    rng = np.random.default_rng(9)
    cube = rng.lognormal(np.log(500), 0.1, (4, 41, 27))
    cube[:, 10:25, 5:20] *= 0.15
    valid = rng.random(cube.shape[1:]) > 0.05
    model = fit_dark_pixel(cube, valid, nir_index=3)

    def kernel(x, ok):
        return model.mask(x, ok), model.shadow_function(x, ok)

    m, phi = by_windows(kernel, cube, valid, block_rows=block_rows)
    np.testing.assert_array_equal(m, model.mask(cube, valid))
    np.testing.assert_allclose(phi, model.shadow_function(cube, valid), rtol=1e-6, equal_nan=True)


def test_dark_pixel_spec(tmp_path):
    rng = np.random.default_rng(4)
    cube = rng.lognormal(np.log(500), 0.1, (4, 50, 40)).astype("float32")
    cube[:, 10:25, 5:20] *= 0.15
    wl = [480.0, 550.0, 660.0, 850.0]
    img = write_envi(tmp_path / "v.img", cube, wl, crs=UTM, transform=TRANSFORM)
    res = ALG["dark-pixel-shadow"](
        vnir=img, output=str(tmp_path / "d.tif"), shadow_function=str(tmp_path / "phi.tif")
    )
    with rasterio.open(tmp_path / "d.tif") as ds:
        m = ds.read(1)
    truth = np.zeros((50, 40), bool)
    truth[10:25, 5:20] = True
    assert (m.astype(bool) == truth).mean() > 0.99
    assert res["shadow_pixels"] == int(m.sum())
    # The former parameter name is still accepted (a hidden alias) and gives the same mask.
    ALG["dark-pixel-shadow"](image=img, output=str(tmp_path / "d2.tif"))
    with rasterio.open(tmp_path / "d2.tif") as ds:
        np.testing.assert_array_equal(ds.read(1), m)


# ------------------------------------------------------------------------------- polygons


def test_polygons_areas_and_crs(tmp_path):
    pyogrio = pytest.importorskip("pyogrio")
    c = np.zeros((30, 40), np.uint8)
    c[2:6, 3:8] = 1  # 20 px
    c[10:20, 10:12] = 2  # 20 px
    c[10:20, 12:15] = 1  # 30 px, touching class 2
    c[25:, :] = 255
    polys = class_polygons(c, default_table(), TRANSFORM)
    # The same in two steps: io traces the patches, the kernel makes them shadow polygons.
    shapes, pixel_area = class_shapes(c, TRANSFORM, mask=shadow_pixels(c))
    assert pixel_area == pytest.approx(1.5 * 1.5)
    assert shadow_polygons(shapes, default_table(), pixel_area=pixel_area) == polys
    by = sorted((p.class_id, p.pixels) for p in polys)
    assert by == [(1, 20), (1, 30), (2, 20)]
    assert all(p.area == pytest.approx(p.pixels * 1.5 * 1.5) for p in polys)
    path = write_gtiff(tmp_path / "c.tif", c[None], nodata=255, crs=UTM, transform=TRANSFORM)
    for ext in ("gpkg", "geojson"):
        out = tmp_path / f"p.{ext}"
        res = ALG["shadow-polygons"](classes_raster=path, output=str(out))
        assert res["polygons"] == 3
        meta, _, geoms, fields = pyogrio.raw.read(out)
        assert sorted(fields[0].tolist()) == [1, 1, 2]
        assert sorted(fields[4].tolist()) == pytest.approx([45.0, 45.0, 67.5])
        assert "32636" in (meta["crs"] or "")


def test_polygons_in_raw_geometry_say_so(tmp_path):
    pyogrio = pytest.importorskip("pyogrio")
    c = np.zeros((10, 10), np.uint8)
    c[1:3, 1:4] = 3
    path = write_gtiff(tmp_path / "c.tif", c[None], nodata=255)
    out = tmp_path / "p.gpkg"
    ALG["shadow-polygons"](classes_raster=path, output=str(out))
    info = pyogrio.read_info(out)
    # No CRS invented: GeoPackage's own "undefined Cartesian SRS" (srs_id -1), or none.
    assert info["crs"] is None or "Undefined Cartesian" in info["crs"]
    assert "Raw sensor geometry" in info["layer_metadata"]["DESCRIPTION"]
    _, _, _, fields = pyogrio.raw.read(out)
    assert fields[4].tolist() == [6.0]  # area in pixels


# --------------------------------------------------------------- simulated scene, known truth


def test_on_a_simulated_urban_scene_boresight_avoids_dark_materials(tmp_path):
    from geoboresight.io.scene import write_scene
    from geoboresight.simulate import simulate_scene

    scene = simulate_scene("urban", lines=96, seed=3, sun_zenith=30.8)
    folder = tmp_path / "scene"
    write_scene(scene, folder)
    j = lambda n: str(folder / n)  # noqa: E731
    ALG["ratio"](vnir=j("vnir.hdr"), swir=j("swir.hdr"), output=j("ratio.tif"))
    ALG["shadow-cluster"](ratio=j("ratio.tif"), vnir=j("vnir.hdr"), output=j("cl.tif"))
    ALG["dark-pixel-shadow"](vnir=j("vnir.hdr"), output=j("dark.tif"))
    with rasterio.open(j("cl.tif")) as a, rasterio.open(j("dark.tif")) as b:
        bore, dark = a.read(1) == 1, b.read(1) == 1
    f = scene.shadow_fraction
    truth = f >= 0.5
    precision = (bore & truth).sum() / bore.sum()
    recall = (bore & truth).sum() / truth.sum()
    assert precision > 0.9 and recall > 0.6
    ids = [
        k for k, v in scene.material_names.items() if v in ("asphalt", "roof_shingle", "roof_tile")
    ]
    sunlit_dark = np.isin(scene.material, ids) & (f < 0.1)
    assert sunlit_dark.sum() > 500
    # The paper's argument: dark targets are not shadow to the boresight ratio's cluster,
    # but are to a statistical dark-pixel detector.
    assert bore[sunlit_dark].mean() < 0.5 * dark[sunlit_dark].mean()
