"""Outputs open styled: continuous rasters with a stretched ramp, classes with their colour table."""

from __future__ import annotations

import numpy as np
import pytest
import rasterio

from geoboresight.io import quiet_georef, write_raster

pytestmark = pytest.mark.qgis


def test_ratio_loads_with_a_ramp(provider, inputs, tmp_path):
    """Loaded into the project by Processing (as the toolbox does), the ratio has a ramp
    stretched over its 2–98 % range, and the .qml sidecar gives the same when opened later."""
    import geoboresight_qgis.styles as styles
    import processing
    from qgis.core import QgsProject, QgsRasterLayer

    out = str(tmp_path / "ratio.tif")
    styles._KEEP.clear()
    QgsProject.instance().clear()
    processing.runAndLoadResults(
        "geoboresight:ratio",
        {"vnir": inputs.scene["vnir"], "swir": inputs.scene["swir"], "output": out},
    )
    layers = list(QgsProject.instance().mapLayers().values())
    assert len(layers) == 1 and layers[0].source() == out
    assert [p.qml for p in styles._KEEP] == [str(tmp_path / "ratio.qml")]  # post-processor set
    renderer = layers[0].renderer()
    assert renderer.type() == "singlebandpseudocolor"

    with quiet_georef(), rasterio.open(out) as src:
        data = src.read(1, masked=True).compressed()
    lo, hi = renderer.classificationMin(), renderer.classificationMax()
    # QGIS's cumulative cut works on a histogram: compare with the true percentiles loosely
    span = data.max() - data.min()
    assert lo == pytest.approx(np.percentile(data, 2), abs=0.02 * span)
    assert hi == pytest.approx(np.percentile(data, 98), abs=0.02 * span)
    assert data.min() < lo < hi < data.max()
    items = renderer.shader().rasterShaderFunction().colorRampItemList()
    assert len(items) >= 2 and items[0].color != items[-1].color

    later = QgsRasterLayer(out, "later", "gdal")  # e.g. dragged into QGIS next week
    assert later.renderer().type() == "singlebandpseudocolor"
    assert later.renderer().classificationMin() == pytest.approx(lo)
    QgsProject.instance().clear()


def test_classes_keep_their_colour_table(provider, tmp_path):
    """A class raster (e.g. the shadow classes) is shown with its own colours, no ramp added."""
    import geoboresight_qgis.styles as styles
    from qgis.core import QgsRasterLayer

    path = str(tmp_path / "classes.tif")
    classes = np.arange(5, dtype="uint8").repeat(8).reshape(5, 8)
    colours = {0: (0, 0, 0, 0), 1: (255, 255, 178, 255), 2: (254, 204, 92, 255)}
    colours.update({3: (253, 141, 60, 255), 4: (227, 26, 28, 255)})
    write_raster(path, classes, nodata=0, dtype="uint8", colormap=colours)
    assert styles.style_output(path, None) is None
    layer = QgsRasterLayer(path, "classes", "gdal")
    assert layer.renderer().type() == "paletted"
    shown = {c.value: c.color.getRgb() for c in layer.renderer().classes()}
    for value in (1, 2, 3, 4):
        assert shown[value] == colours[value]
