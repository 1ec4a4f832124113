"""The sample scene on a map: its IGM and orthophoto (``simulate --navigation``) put the raw
products where the orthophoto shows the ground."""

from __future__ import annotations

import os

import numpy as np
import pytest
import rasterio
from scipy import ndimage

import geoboresight as gb
from geoboresight.simulate.ortho import _to_map
from geoboresight.simulate.scene import _sun, flight_geometry, preset_surface, scene_extent

SAMPLE = os.path.join(os.path.dirname(__file__), "..", "sample_data", "scene")
pytestmark = pytest.mark.skipif(
    not os.path.exists(os.path.join(SAMPLE, "igm.tif")), reason="no sample navigation"
)


def _sample_buildings():
    """The sample's buildings (track frame), rebuilt from its recipe: the surface is the first
    draw of the scene's generator (sample_data/README.md: mixed, 192 lines, seed 4)."""
    geo = flight_geometry("large-squint")
    extent, core = scene_extent(geo, 192, _sun("mixed", None, None))
    return preset_surface("mixed", np.random.default_rng(4), extent, core, seed=4).buildings


def test_navigation_files_describe_the_sample(tmp_path):
    with rasterio.open(os.path.join(SAMPLE, "igm.tif")) as igm:
        assert igm.count == 2 and (igm.height, igm.width) == (192, 286)
        assert igm.crs.to_epsg() == 32636
    with rasterio.open(os.path.join(SAMPLE, "ortho.tif")) as o:
        assert o.count == 3 and o.dtypes[0] == "uint8"
        assert 0.05 < (o.dataset_mask() == 0).mean() < 0.2  # the corners beyond the ground
        assert o.crs.to_epsg() == 32636 and o.res == (1.0, 1.0)
    assert os.path.getsize(os.path.join(SAMPLE, "ortho.tif")) < 300_000


def test_geolocated_product_lands_on_the_orthophoto(tmp_path):
    out = str(tmp_path / "dsm_map.tif")
    g = gb.geolocate_file(
        os.path.join(SAMPLE, "truth_dsm.tif"), os.path.join(SAMPLE, "igm.tif"), output=out
    )
    assert g["crs"] == "EPSG:32636" and g["resolution"] == pytest.approx(1.5)
    assert g["masked_nan"] == 0 and g["masked_non_monotonic"] == 0
    with rasterio.open(out) as d, rasterio.open(os.path.join(SAMPLE, "ortho.tif")) as o:
        assert d.crs == o.crs and d.nodata is not None
        assert d.transform.a == pytest.approx(1.5) and d.transform.e == pytest.approx(-1.5)
        # Inside the orthophoto's extent, and the valid pixels on valid orthophoto cells.
        b, ob = d.bounds, o.bounds
        assert ob.left <= b.left and b.right <= ob.right
        assert ob.bottom <= b.bottom and b.top <= ob.top
        z = d.read(1, masked=True)
        rows, cols = np.nonzero(~np.ma.getmaskarray(z))
        xs, ys = d.transform * (cols + 0.5, rows + 0.5)
        orow, ocol = (
            np.floor(v).astype(int) for v in rasterio.transform.rowcol(o.transform, xs, ys)
        )
        assert (o.dataset_mask()[orow, ocol] > 0).all()
        transform = d.transform
    # A known feature: the tallest buildings' roofs land within a pixel of their place.
    checked = 0
    for x0, x1, y0, y1, h, _ in _sample_buildings():
        e, n = _to_map((x0 + x1) / 2, (y0 + y1) / 2, 35.0, (660000.0, 3450000.0))
        c, r = (int(v) for v in ~transform * (e, n))
        if h < 8 or not (15 <= r < z.shape[0] - 15 and 15 <= c < z.shape[1] - 15):
            continue
        if np.ma.getmaskarray(z)[r, c]:
            continue
        win = z[r - 15 : r + 16, c - 15 : c + 16]
        labels, _ = ndimage.label(win.filled(0) > np.ma.median(win) + h / 2)
        assert labels[15, 15], "no roof at the building's true position"
        yy, xx = np.nonzero(labels == labels[15, 15])
        ec, nc = transform * (c - 15 + xx.mean() + 0.5, r - 15 + yy.mean() + 0.5)
        assert np.hypot(ec - e, nc - n) < 1.5 * 1.5, (h, ec - e, nc - n)
        checked += 1
    assert checked >= 2
