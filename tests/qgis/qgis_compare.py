"""Compare the files two runs wrote (QGIS vs the library): same numbers, not just "exists"."""

from __future__ import annotations

import json
import math
import os

import numpy as np

_RASTER = {".tif", ".tiff", ".img", ".vrt"}
_TEXT = {".html", ".htm", ".csv", ".txt", ".md", ".hdr", ".qml"}
_VECTOR = {".gpkg", ".geojson", ".shp"}


def same_value(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def _swap(obj, a_dir: str, b_dir: str):
    """Replace the first run's folder by the second's in every string (paths written into files)."""
    if isinstance(obj, str):
        return obj.replace(a_dir, b_dir)
    if isinstance(obj, dict):
        return {k: _swap(v, a_dir, b_dir) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_swap(v, a_dir, b_dir) for v in obj]
    return obj


def assert_same_file(a: str, b: str, a_dir: str, b_dir: str) -> None:
    assert os.path.exists(a), f"missing output {a}"
    assert os.path.exists(b), f"missing output {b}"
    if os.path.isdir(a):
        names_a = sorted(n for n in os.listdir(a) if not n.endswith(".aux.xml"))
        names_b = sorted(n for n in os.listdir(b) if not n.endswith(".aux.xml"))
        assert names_a == names_b, (a, names_a, names_b)
        for n in names_a:
            assert_same_file(os.path.join(a, n), os.path.join(b, n), a_dir, b_dir)
        return
    ext = os.path.splitext(a)[1].lower()
    if ext in _RASTER or _is_envi_data(a):
        _same_raster(a, b)
    elif ext == ".json":
        with open(a, encoding="utf-8") as fa, open(b, encoding="utf-8") as fb:
            ja, jb = json.load(fa), json.load(fb)
        assert same_value(_swap(ja, a_dir, b_dir), jb), f"{a} and {b} differ"
    elif ext in _TEXT:
        with open(a, encoding="utf-8") as fa, open(b, encoding="utf-8") as fb:
            ta, tb = fa.read(), fb.read()
        assert ta.replace(a_dir, b_dir) == tb, f"{a} and {b} differ"
    elif ext == ".png":
        import matplotlib.image as mpimg

        pa, pb = mpimg.imread(a), mpimg.imread(b)
        assert pa.shape == pb.shape and np.array_equal(pa, pb), f"{a} and {b} differ"
    elif ext in _VECTOR:
        assert _features(a) == _features(b), f"{a} and {b} differ"
    else:
        with open(a, "rb") as fa, open(b, "rb") as fb:
            assert fa.read() == fb.read(), f"{a} and {b} differ"


def _is_envi_data(path: str) -> bool:
    return os.path.exists(os.path.splitext(path)[0] + ".hdr") and not path.endswith(".hdr")


def _same_raster(a: str, b: str) -> None:
    import rasterio

    from geoboresight.io import quiet_georef

    with quiet_georef(), rasterio.open(a) as ra, rasterio.open(b) as rb:
        assert (ra.count, ra.width, ra.height) == (rb.count, rb.width, rb.height), (a, b)
        assert ra.crs == rb.crs and ra.transform == rb.transform, (a, b)
        assert ra.nodata == rb.nodata or (
            ra.nodata is not None and np.isnan(ra.nodata) and np.isnan(rb.nodata)
        )
        assert ra.dtypes == rb.dtypes
        np.testing.assert_array_equal(ra.read(), rb.read(), err_msg=f"{a} vs {b}")
        if ra.count == 1:
            try:
                assert ra.colormap(1) == rb.colormap(1)
            except ValueError:  # no colour table in either
                pass


def _features(path: str) -> list:
    from osgeo import ogr

    ds = ogr.Open(path)
    assert ds is not None, f"cannot open {path}"
    out = []
    for i in range(ds.GetLayerCount()):
        layer = ds.GetLayerByIndex(i)
        for f in layer:
            geom = f.GetGeometryRef()
            out.append((layer.GetName(), _normalized(geom), tuple(f.items().items())))
    return out


def _normalized(geom):
    """Canonical WKT: the same shape with its rings started and oriented one way (two GEOS
    versions may trace the same polygon from another vertex or the other way round)."""
    if geom is None:
        return None
    import shapely

    return shapely.normalize(shapely.from_wkt(geom.ExportToWkt())).wkt
