"""Map-ready products in real QGIS, with QGIS core APIs on files (no provider): a geolocated
product overlays a reference orthophoto in one project, and a raw-geometry product written with its
ground sample distance opens in metres, not on degrees, without claiming an Earth position.

The library runs in this process only to make the files (simulate-ortho, geolocate, ratio);
QGIS reads them.
"""

from __future__ import annotations

import os

import numpy as np
import pytest

pytestmark = pytest.mark.qgis


@pytest.fixture(scope="module")
def ortho_scene(tmp_path_factory):
    from geoboresight import geolocate_file, simulate_ortho_file

    folder = tmp_path_factory.mktemp("overlay")
    sim = str(folder / "sim")
    simulate_ortho_file(output=sim, lines=96, seed=3)
    product = str(folder / "raw_map.tif")
    geolocate_file(os.path.join(sim, "raw.img"), os.path.join(sim, "igm.img"), output=product)
    return sim, product


def _sample(layer, x, y, band=1):
    from qgis.core import QgsPointXY

    value, ok = layer.dataProvider().sample(QgsPointXY(float(x), float(y)), band)
    return value if ok else np.nan


def test_geolocated_product_overlays_the_orthophoto_in_one_project(qgis_app, ortho_scene):
    import rasterio
    from qgis.core import QgsProject, QgsRasterLayer

    sim, product = ortho_scene
    project = QgsProject.instance()
    project.clear()
    ortho = QgsRasterLayer(os.path.join(sim, "orthophoto.tif"), "orthophoto")
    placed = QgsRasterLayer(product, "geolocated NIR")
    assert ortho.isValid() and placed.isValid()
    project.addMapLayers([ortho, placed])
    # Both in the same projected CRS (UTM 36N), metres: QGIS puts them on one map.
    assert placed.crs() == ortho.crs() and not placed.crs().isGeographic()
    assert ortho.extent().intersects(placed.extent())

    # Map points from the independent truth: the true IGM's position of raw pixels (the
    # simulator's ray hits, not the geolocated file), away from the footprint's edges.
    with (
        rasterio.open(os.path.join(sim, "igm.img")) as igm,
        rasterio.open(os.path.join(sim, "raw.img")) as raw,
    ):
        east, north = igm.read(1), igm.read(2)
        nir = raw.read(1).astype("float64")
    rng = np.random.default_rng(0)
    rows = rng.integers(8, nir.shape[0] - 8, 300)
    cols = rng.integers(8, nir.shape[1] - 8, 300)
    pts = list(zip(east[rows, cols], north[rows, cols], strict=True))

    got = np.array([_sample(placed, x, y) for x, y in pts])
    ref = np.array([_sample(ortho, x, y, band=4) for x, y in pts])  # the orthophoto's NIR
    ok = np.isfinite(got) & np.isfinite(ref)
    assert ok.mean() > 0.95
    # QGIS finds, at each map point, the raw pixel the IGM puts there (resampling blurs it
    # with its neighbours only)...
    spread = np.abs(nir[rows, cols] - got)[ok]
    assert np.median(spread) < 0.1 * np.std(nir)
    # ... and the orthophoto's NIR at the same points agrees: another camera, so another
    # gain and noise, but strongly correlated only when the two layers overlay.
    r_here = np.corrcoef(got[ok], ref[ok])[0, 1]
    shifted = np.array([_sample(ortho, x + 6.0, y + 6.0, band=4) for x, y in pts])
    ok2 = ok & np.isfinite(shifted)
    r_shift = np.corrcoef(got[ok2], shifted[ok2])[0, 1]
    assert r_here > 0.8, r_here
    assert r_here > r_shift + 0.2, (r_here, r_shift)


def test_raw_geometry_with_its_gsd_opens_in_metres_not_degrees(qgis_app, tmp_path):
    import rasterio
    from qgis.core import (
        QgsDistanceArea,
        QgsPointXY,
        QgsProject,
        QgsRasterLayer,
        QgsUnitTypes,
    )
    from synth_qgis import raw_pair

    from geoboresight.algorithms import registry

    vnir, swir, vn, sw = raw_pair(tmp_path)
    out = str(tmp_path / "ratio_local.tif")
    registry()["ratio"](vnir=vnir, swir=swir, output=out, raw_gsd=1.5)
    bare = str(tmp_path / "ratio_raw.tif")
    registry()["ratio"](vnir=vnir, swir=swir, output=bare)
    with rasterio.open(out) as src:
        values = src.read(1, masked=True)
        height, width = src.shape

    layer = QgsRasterLayer(out, "ratio (raw geometry, 1.5 m)")
    assert layer.isValid()
    crs = layer.crs()
    # A valid CRS in metres, not geographic (QGIS's 3D view refuses geographic CRSs), with no
    # EPSG code and no ellipsoid: no Earth position is claimed.
    assert crs.isValid() and not crs.isGeographic()
    assert crs.mapUnits() == QgsUnitTypes.DistanceMeters
    assert crs.authid() == "" and "raw sensor geometry" in crs.description()
    assert crs.toProj() == "" or "+proj=longlat" not in crs.toProj()
    # Extent and distances in metres from the GSD.
    ext = layer.extent()
    assert ext.width() == pytest.approx(width * 1.5) and ext.height() == pytest.approx(height * 1.5)
    project = QgsProject.instance()
    project.clear()
    project.addMapLayer(layer)
    project.setCrs(crs)
    assert project.crs().mapUnits() == QgsUnitTypes.DistanceMeters
    d = QgsDistanceArea()
    d.setSourceCrs(crs, project.transformContext())
    metres = d.measureLine(QgsPointXY(0.75, -0.75), QgsPointXY(0.75 + 10 * 1.5, -0.75))
    assert metres == pytest.approx(15.0)
    # Pixel (line r, column c) sits at x = (c + ½)·GSD, y = −(r + ½)·GSD.
    for r, c in [(0, 0), (5, 7), (height - 1, width - 1)]:
        if values.mask[r, c]:
            continue
        got = _sample(layer, (c + 0.5) * 1.5, -(r + 0.5) * 1.5)
        assert got == pytest.approx(float(values[r, c]), rel=1e-6)

    # Without the GSD the product stays raw: QGIS finds no CRS (a user sees it on degrees;
    # the library does not invent one).
    plain = QgsRasterLayer(bare, "ratio raw")
    assert plain.isValid() and not plain.crs().isValid()
