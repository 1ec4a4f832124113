"""Sensor products through real QGIS: the VNIR/SWIR inputs' file dialog offers the products
beside GDAL's rasters, a product path QGIS cannot open as a layer (an EnMAP L1B folder, zip or
METADATA.XML) is accepted and handed to the engine as it is, and the ratio it computes equals
the library's."""

from __future__ import annotations

import numpy as np
import pytest
import rasterio

from geoboresight.io import quiet_georef

pytestmark = pytest.mark.qgis


@pytest.fixture(scope="module")
def enmap(tmp_path_factory):
    from products_space import write_enmap_l1b

    folder = tmp_path_factory.mktemp("enmap_qgis")
    product = write_enmap_l1b(folder / "folder")
    zipped = write_enmap_l1b(folder / "zip", zip=True)
    xml = next(str(p) for p in (folder / "folder").iterdir() if p.name.endswith("METADATA.XML"))
    return {"folder": product.path, "zip": zipped.path, "xml": xml}


def test_vnir_and_swir_offer_the_products_in_the_file_dialog(provider):
    from qgis.core import QgsApplication

    alg = QgsApplication.processingRegistry().algorithmById("geoboresight:ratio")
    for name in ("vnir", "swir"):
        param = alg.parameterDefinition(name)
        for p in (param, param.clone()):  # QGIS's widgets work on a clone
            text = p.createFileFilter()
            for pattern in ("*.hdr", "*.raw", "*.hyspex", "*METADATA.XML", "*.zip", "*.he5"):
                assert pattern in text, (name, pattern)
            assert "*.tif" in text  # GDAL's rasters still offered
    # An input that takes any raster reads a product as its image: offered too.
    stats = QgsApplication.processingRegistry().algorithmById("geoboresight:stats")
    assert "*.hyspex" in stats.parameterDefinition("input").createFileFilter()
    # Inputs where no product belongs keep QGIS's own raster parameter.
    view = QgsApplication.processingRegistry().algorithmById("geoboresight:view-3d")
    assert "*.hyspex" not in view.parameterDefinition("dem").createFileFilter()


def test_stats_on_a_specim_capture_through_qgis_counts_its_image_lines(provider, tmp_path):
    """A Specim capture with dark frames given to 'stats' in QGIS: N is the image's pixels,
    as the library and every other face count them."""
    import processing
    from hostile import COLS, ROWS, make_products

    p = make_products(tmp_path / "p")["specim"]
    out = str(tmp_path / "s.json")
    result = processing.run("geoboresight:stats", {"input": p.path, "band": 2, "output": out})
    assert result["n"] == ROWS * COLS


@pytest.mark.parametrize("form", ["folder", "zip", "xml"])
def test_ratio_on_an_enmap_product_through_qgis_equals_the_library(provider, enmap, form, tmp_path):
    import processing

    from geoboresight.algorithms import registry

    out = str(tmp_path / "ratio.tif")
    result = processing.run("geoboresight:ratio", {"vnir": enmap[form], "output": out})
    ref = str(tmp_path / "ref.tif")
    lib = registry()["ratio"](vnir=enmap[form], output=ref)
    assert result["output"] == out
    assert result["swir_band"] == lib["swir_band"] and result["vnir_band"] == lib["vnir_band"]
    with quiet_georef(), rasterio.open(out) as a, rasterio.open(ref) as b:
        np.testing.assert_array_equal(a.read(), b.read())


def test_info_on_an_enmap_zip_through_qgis(provider, enmap, tmp_path):
    import processing

    out = str(tmp_path / "info.json")
    result = processing.run("geoboresight:info", {"vnir": enmap["zip"], "output": out})
    assert result["product"] == "EnMAP L1B" and result["output"] == out
    assert result["summary"].startswith("Product: EnMAP L1B")


def test_a_missing_product_path_is_refused_before_the_engine(provider, tmp_path):
    import processing
    from qgis.core import QgsProcessingException

    with pytest.raises(QgsProcessingException):
        processing.run(
            "geoboresight:ratio",
            {"vnir": str(tmp_path / "nowhere.he5"), "output": str(tmp_path / "r.tif")},
        )


def test_radiance_and_the_ratio_on_the_fly_through_qgis_equal_the_library(provider, tmp_path):
    """A raw capture and its calibration file (simulate --capture) in QGIS: 'radiance' takes
    the calibration as a file input, 'ratio' reads the capture as radiance with the VNIR
    calibration, and both equal the library's."""
    import processing

    import geoboresight as gb

    scene = tmp_path / "scene"
    gb.simulate_file(output=str(scene), lines=16, seed=3, capture=True)
    cap, cal = str(scene / "capture.hdr"), str(scene / "capture_cal.cal")
    q_rad, q_ratio = str(tmp_path / "q_rad.tif"), str(tmp_path / "q_ratio.tif")
    processing.run("geoboresight:radiance", {"input": cap, "calibration": cal, "output": q_rad})
    processing.run("geoboresight:ratio", {"vnir": cap, "vnir_calibration": cal, "output": q_ratio})
    l_rad, l_ratio = str(tmp_path / "l_rad.tif"), str(tmp_path / "l_ratio.tif")
    gb.radiance_file(cap, cal, output=l_rad)
    gb.ratio_file(cap, output=l_ratio, layout=gb.DualLayout(vnir_calibration=cal))
    for a, b in ((q_rad, l_rad), (q_ratio, l_ratio)):
        with quiet_georef(), rasterio.open(a) as qa, rasterio.open(b) as lb:
            np.testing.assert_array_equal(qa.read(), lb.read())
