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


def test_background_class_is_transparent_and_each_class_has_one_name(provider, tmp_path):
    """The shadow classes lie over a map: class 0 ("no shadow") is transparent, not white;
    a label that repeats its own name in parentheses is said once."""
    import geoboresight_qgis.styles as styles
    from qgis.core import QgsRasterLayer

    path = str(tmp_path / "shadow.tif")
    colours = {0: (255, 255, 255, 255), 1: (128, 0, 0, 255), 2: (255, 0, 255, 255)}
    classes = np.array([[0, 1, 2, 0]] * 4, dtype="uint8")
    write_raster(path, classes, nodata=255, dtype="uint8", colormap=colours)
    names = "".join(
        f"<Category>{n}</Category>" for n in ("no shadow", "80-100 % shadow", "50-80 % shadow")
    )
    with open(path + ".aux.xml", "w") as f:  # category names, as the library writes them
        f.write(
            '<PAMDataset><PAMRasterBand band="1"><CategoryNames>'
            f"{names}</CategoryNames></PAMRasterBand></PAMDataset>"
        )
    assert styles.style_output(path, None) is not None
    layer = QgsRasterLayer(path, "classes", "gdal")
    shown = {c.value: (c.label, c.color.alpha()) for c in layer.renderer().classes()}
    assert shown == {0: ("no shadow", 0), 1: ("80-100 % shadow", 255), 2: ("50-80 % shadow", 255)}
    assert styles.class_label("80–100 % shadow (80-100 % shadow)") == "80–100 % shadow"
    assert styles.class_label("water (deep)") == "water (deep)"
    assert styles.is_background(0, "background") and not styles.is_background(3, "no shadow")
    assert not styles.is_background(0, "urban")


def test_layer_names_as_qgis_core_gives_them(provider, inputs, tmp_path):
    """A named output keeps its file name (two batch outputs, two names; also under /tmp,
    which QGIS counts as temporary), a temporary output the output's display name, and a
    folder output (simulate) adds its rasters as layers."""
    import processing
    from qgis.core import QgsProject

    QgsProject.instance().clear()
    for nm in (920, 900):
        processing.runAndLoadResults(
            "geoboresight:ratio",
            {
                "vnir": inputs.scene["vnir"],
                "swir": inputs.scene["swir"],
                "vnir_nm": nm,
                "output": str(tmp_path / f"batch_ratio_{nm}.tif"),
            },
        )
    processing.runAndLoadResults(
        "geoboresight:ratio",
        {"vnir": inputs.scene["vnir"], "swir": inputs.scene["swir"], "output": "TEMPORARY_OUTPUT"},
    )
    names = sorted(lay.name() for lay in QgsProject.instance().mapLayers().values())
    assert names == ["Boresight ratio", "batch_ratio_900", "batch_ratio_920"]
    QgsProject.instance().clear()
    processing.runAndLoadResults(
        "geoboresight:simulate-ortho",
        {"preset": 0, "lines": 16, "seed": 1, "output": str(tmp_path / "ortho")},
    )
    names = sorted(lay.name() for lay in QgsProject.instance().mapLayers().values())
    assert names == ["igm", "orthophoto", "raw"], names
    assert not list((tmp_path / "ortho").glob("*.qml"))  # the folder stays as the library wrote it
    QgsProject.instance().clear()
