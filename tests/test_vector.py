"""Vector outputs (GeoPackage, GeoJSON) written through pyogrio: read back with pyogrio, the
layer name, fields, CRS, geometry type and count are the ones asked for, and a failed write
leaves the old file and no temporary one."""

from __future__ import annotations

import numpy as np
import pyogrio
import pytest
import shapely
from rasterio.crs import CRS

from geoboresight.errors import InputError, OutputError
from geoboresight.io.georef import read_vector
from geoboresight.io.raster import RAW_LOCAL_WKT
from geoboresight.io.vector import count_features, write_vector

POLYS = [shapely.box(0, 0, 3, 2), shapely.MultiPolygon([shapely.box(5, 5, 6, 7)])]
FIELDS = {
    "class_id": np.array([1, 3], np.uint8),
    "area_m2": np.array([6.0, np.nan]),
    "label": np.array(["core shadow", "penumbra"]),
    "flagged": np.array([True, False]),
}


@pytest.mark.parametrize("ext", ["gpkg", "geojson"])
@pytest.mark.parametrize("crs", [None, CRS.from_epsg(32636), CRS.from_wkt(RAW_LOCAL_WKT)])
def test_polygons_read_back_with_pyogrio(tmp_path, ext, crs):
    path = tmp_path / f"shadow.{ext}"
    out = write_vector(
        str(path), POLYS, FIELDS, crs=crs, layer="shadow_polygons", description="test layer"
    )
    assert out == str(path)
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left
    assert pyogrio.list_layers(path).tolist() == [["shadow_polygons", "MultiPolygon"]]
    info = pyogrio.read_info(path, layer="shadow_polygons")
    assert info["features"] == 2 and info["geometry_type"] == "MultiPolygon"
    assert list(info["fields"]) == list(FIELDS)
    assert info["dtypes"][1] == "float64" and info["dtypes"][2] == "object"
    assert info["layer_metadata"]["DESCRIPTION"] == "test layer"
    if crs is None:
        assert info["crs"] is None if ext == "gpkg" else info["crs"] == "EPSG:4326"
    elif crs.to_epsg():
        assert info["crs"] == "EPSG:32636"
    else:
        assert CRS.from_user_input(info["crs"]).to_wkt() == crs.to_wkt()
    meta, _, wkb, columns = pyogrio.raw.read(path)
    geoms = shapely.from_wkb(wkb)
    assert [g.geom_type for g in geoms] == ["MultiPolygon", "MultiPolygon"]
    assert [g.area for g in geoms] == [6.0, 2.0]
    assert columns[0].tolist() == [1, 3]
    assert columns[1][0] == 6.0 and np.isnan(columns[1][1])  # NaN written as null
    assert columns[2].tolist() == ["core shadow", "penumbra"]
    assert [bool(v) for v in columns[3]] == [True, False]
    assert count_features(str(path), "shadow_polygons") == 2
    if ext == "gpkg":
        _, fields, got, layer = read_vector(str(path))
        assert layer == "shadow_polygons" and list(fields) == list(FIELDS)
        assert got == crs


def test_points_and_a_mix_keep_their_geometry_type(tmp_path):
    pts = [shapely.Point(1, 2), shapely.Point(3, 4), shapely.Point(5, 6)]
    write_vector(str(tmp_path / "p.gpkg"), pts, {"score": np.arange(3.0)}, layer="anomalies")
    info = pyogrio.read_info(tmp_path / "p.gpkg")
    assert (info["geometry_type"], info["features"]) == ("Point", 3)
    mix = [shapely.box(0, 0, 1, 1), shapely.Point(3, 4)]
    write_vector(str(tmp_path / "m.gpkg"), mix, {"n": np.array([1, 2])}, layer="mix")
    geoms = shapely.from_wkb(pyogrio.raw.read(tmp_path / "m.gpkg")[2])
    assert [g.geom_type for g in geoms] == ["Polygon", "Point"]


def test_an_empty_layer_is_a_valid_layer(tmp_path):
    write_vector(str(tmp_path / "e.gpkg"), [], {"n": np.array([], int)}, layer="none")
    info = pyogrio.read_info(tmp_path / "e.gpkg")
    assert (info["features"], info["geometry_type"], list(info["fields"])) == (
        0,
        "MultiPolygon",
        ["n"],
    )


def test_a_failed_write_keeps_the_old_file(tmp_path):
    path = tmp_path / "shadow.gpkg"
    write_vector(str(path), POLYS, FIELDS, layer="shadow")
    before = path.read_bytes()
    with pytest.raises(ValueError, match="field area_m2 has 1 values"):
        write_vector(str(path), POLYS, {**FIELDS, "area_m2": [1.0]}, layer="shadow")
    with pytest.raises(OutputError, match=r"shadow\.gpkg could not be written \(.*layer name"):
        write_vector(str(path), [shapely.Point(0, 0)], {"x": [1]}, layer="")
    assert path.read_bytes() == before
    assert [p.name for p in tmp_path.iterdir()] == ["shadow.gpkg"]


def test_count_features_of_a_missing_layer_is_an_input_error(tmp_path):
    path = tmp_path / "a.gpkg"
    write_vector(str(path), POLYS, FIELDS, layer="shadow")
    with pytest.raises(InputError, match="layer anomalies"):
        count_features(str(path), "anomalies")
