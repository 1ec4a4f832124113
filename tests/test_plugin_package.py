"""The QGIS plugin zip (`make plugin-zip`) against the upload rules of plugins.qgis.org, checked
offline: the checks of its validator (qgis/QGIS-Django, plugins/validator.py) except the
online reachability of the URLs. Plus: the version in one place, the operation list shipped,
and no import of the library (or its wheels) anywhere in the plugin."""

from __future__ import annotations

import ast
import configparser
import io
import json
import re
import subprocess
import sys
import zipfile
from pathlib import Path
from urllib.parse import urlparse

import pytest

import geoboresight
from geoboresight.algorithms import registry

REPO = Path(__file__).resolve().parents[1]
REQUIRED = (
    "name",
    "description",
    "version",
    "qgisMinimumVersion",
    "author",
    "email",
    "about",
    "tracker",
    "repository",
)


@pytest.fixture(scope="module")
def plugin_zip(tmp_path_factory):
    path = tmp_path_factory.mktemp("zip") / "geoboresight-plugin.zip"
    subprocess.run(
        ["make", "-s", "-C", str(REPO), "plugin-zip", f"PLUGIN_ZIP={path}"],
        check=True,
        capture_output=True,
        timeout=600,
    )
    return path


def test_zip_passes_the_repository_rules(plugin_zip):
    assert plugin_zip.stat().st_size <= 25_000_000
    with zipfile.ZipFile(plugin_zip) as z:
        names = z.namelist()
        assert z.testzip() is None
        for n in names:
            assert ".." not in n and not n.startswith("/") and ".pyc" not in n, n
            assert not {"__MACOSX", ".git", "__pycache__"} & set(n.split("/")), n
        top = {n.split("/")[0] for n in names}
        assert len(top) == 1
        package = top.pop()
        assert re.match(r"^[A-Za-z][A-Za-z0-9-_]+$", package)
        assert f"{package}/__init__.py" in names and f"{package}/metadata.txt" in names
        assert f"{package}/LICENSE" in names
        assert "MIT License" in z.read(f"{package}/LICENSE").decode()
        meta = configparser.ConfigParser()
        meta.optionxform = str
        meta.read_file(io.StringIO(z.read(f"{package}/metadata.txt").decode("utf-8")))
        general = dict(meta.items("general"))
        assert f"{package}/{general['icon']}" in names
        ops = json.loads(z.read(f"{package}/operations.json"))
        # the engine's wheel, for a one-click setup; no tests, no sample data
        wheels = [n for n in names if n.startswith(f"{package}/wheels/")]
        assert wheels == [
            f"{package}/wheels/",
            f"{package}/wheels/geoboresight-{geoboresight.__version__}-py3-none-any.whl",
        ] or wheels == [
            f"{package}/wheels/geoboresight-{geoboresight.__version__}-py3-none-any.whl"
        ]
        wheel = z.read(wheels[-1])
        assert not [n for n in names if "/tests/" in n or "sample_data" in n or n.endswith(".img")]
    with zipfile.ZipFile(io.BytesIO(wheel)) as w:
        inside = w.namelist()
        assert "geoboresight/cli.py" in inside and "geoboresight/engine.py" in inside
        assert not [n for n in inside if n.startswith(("tests/", "sample_data/"))]
    assert plugin_zip.stat().st_size < 2_000_000  # small: the dependencies come from pip
    for key in REQUIRED:
        assert general.get(key, "").strip(), key
    for key in ("tracker", "repository", "homepage"):
        url = urlparse(general[key])
        assert url.scheme == "https" and url.netloc, (key, general[key])
    assert "/" not in general["author"]
    assert re.match(r"^[^@\s]+@[^@\s]+\.[^@\s]+$", general["email"])
    assert general["hasProcessingProvider"] == "yes"
    assert int(general["qgisMaximumVersion"].split(".")[0]) >= 4  # QGIS 4 ready
    # one version everywhere: the library's
    assert general["version"] == geoboresight.__version__ == ops["version"]
    assert [a["name"] for a in ops["algorithms"]] == list(registry())


def test_wheel_version_comes_from_the_library():
    """pyproject.toml reads the version from geoboresight/__init__.py (no second copy)."""
    text = (REPO / "pyproject.toml").read_text()
    assert 'dynamic = ["version"]' in text and 'attr = "geoboresight._version.__version__"' in text
    assert not re.search(r'^version\s*=\s*"', text, re.M)
    from importlib.metadata import version

    assert version("geoboresight") == geoboresight.__version__


def test_plugin_imports_only_pyqgis_and_the_standard_library():
    """QGIS's Python must never load the library, numpy-based code of ours, rasterio, shapely,
    pyproj or scikit-learn: the plugin talks to the engine process instead."""
    allowed = set(sys.stdlib_module_names) | {"qgis", "processing", "osgeo"}
    for path in (REPO / "plugin").rglob("*.py"):
        tree = ast.parse(path.read_text(), str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                tops = [a.name.split(".")[0] for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                tops = [(node.module or "").split(".")[0]]
            else:
                continue
            for top in tops:
                assert top in allowed, (path.name, top)


def _plugin_formats():
    """plugin/formats.py on its own (standard library only: no QGIS needed)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("plugin_formats", REPO / "plugin" / "formats.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_raster_inputs_offer_the_sensor_products_beside_gdal(tmp_path):
    from geoboresight.engine import describe

    formats = _plugin_formats()
    ratio = next(a for a in describe()["algorithms"] if a["name"] == "ratio")
    vnir = next(p for p in ratio["params"] if p["name"] == "vnir")
    gdal = "All supported files (*.tif *.TIF *.vrt);;GeoTIFF (*.tif *.TIF);;All files (*)"
    text = formats.product_filter(vnir["formats"], gdal)
    entries = text.split(";;")
    first = entries[0]
    for pattern in ("*.hdr", "*.raw", "*.img", "*.bil", "*.dat", "*.hyspex", "*METADATA.XML"):
        assert pattern in first, pattern
    assert "*.zip" in first and "*.he5" in first and "*.h5" in first and "*.tif" in first
    assert "GeoTIFF (*.tif *.TIF)" in entries and entries[-1] == formats.ALL_FILES
    assert entries.count(formats.ALL_FILES) == 1
    # Paths handed to the engine as they are: existing product files and folders only.
    (tmp_path / "ENMAP01-X-METADATA.XML").write_text("<x/>")
    (tmp_path / "line.he5").write_bytes(b"")
    (tmp_path / "a.tif").write_bytes(b"")
    assert formats.is_product_path(str(tmp_path / "ENMAP01-X-METADATA.XML"), vnir["formats"])
    assert formats.is_product_path(str(tmp_path / "line.he5"), vnir["formats"])
    assert formats.is_product_path(str(tmp_path), vnir["formats"])  # an EnMAP folder
    assert not formats.is_product_path(str(tmp_path / "a.tif"), vnir["formats"])
    assert not formats.is_product_path(str(tmp_path / "missing.he5"), vnir["formats"])
    assert not formats.is_product_path(str(tmp_path / "line.he5"), [])  # no formats declared
