"""The provider as QGIS sees it: every spec listed, parameters of QGIS's own types, help."""

from __future__ import annotations

import configparser

import pytest
from qgis_harness import PLUGIN_DIR

from geoboresight.algorithms import registry

pytestmark = pytest.mark.qgis


def test_provider_lists_every_spec(provider):
    from qgis.core import QgsApplication

    reg = QgsApplication.processingRegistry()
    assert reg.providerById("geoboresight") is provider
    listed = {a.name() for a in provider.algorithms()}
    assert listed == set(registry())
    for name, spec in registry().items():
        alg = reg.algorithmById(f"geoboresight:{name}")
        assert alg is not None, name
        assert alg.displayName() == spec.display_name
        assert alg.group() == spec.group
        assert alg.shortDescription() == spec.short_help
        assert spec.short_help in alg.shortHelpString()
        assert [p.name() for p in alg.parameterDefinitions()] == [p.name for p in spec.params]


EXPECTED_TYPE = {
    "raster": "raster",
    "multiraster": "multilayer",
    "file": "file",
    "band": "band",
    "number": "number",
    "wavelength": "number",
    "enum": "enum",
    "bool": "boolean",
    "string": "string",
    "raster_out": "rasterDestination",
    "vector_out": "vectorDestination",
    "file_out": "fileDestination",
    "folder_out": "folderDestination",
}


def test_parameters_map_to_qgis_types(provider):
    from qgis.core import QgsApplication, QgsProcessingParameterDefinition

    reg = QgsApplication.processingRegistry()
    for name, spec in registry().items():
        alg = reg.algorithmById(f"geoboresight:{name}")
        for p in spec.params:
            q = alg.parameterDefinition(p.name)
            where = f"{name}.{p.name}"
            assert q.type() == EXPECTED_TYPE[p.kind], where
            optional = bool(q.flags() & QgsProcessingParameterDefinition.FlagOptional)
            assert optional == (not p.required), where
            advanced = bool(q.flags() & QgsProcessingParameterDefinition.FlagAdvanced)
            assert advanced == p.advanced, where
            assert q.description().startswith(p.description), where
            if p.kind in ("number", "wavelength"):
                if p.minimum is not None:
                    assert q.minimum() == p.minimum, where
                if p.maximum is not None:
                    assert q.maximum() == p.maximum, where
                if p.default is not None:
                    assert q.defaultValue() == p.default, where
                assert (q.dataType() == q.Integer) == bool(p.integer), where
            if p.kind == "wavelength":
                assert "nm" in q.description(), where
            if p.kind == "band":
                assert q.parentLayerParameterName() == p.raster, where
            if p.kind == "enum":
                assert q.options() == list(p.choices), where
                if p.default is not None:
                    assert q.options()[q.defaultValue()] == p.default, where
            if p.kind == "file_out":
                assert f"*.{p.extension}" in q.fileFilter(), where
                if p.extension.startswith("htm"):
                    # QGIS shows HTML outputs in its Results Viewer
                    assert q.toOutputDefinition().type() == "outputHtml", where


def test_groups_follow_the_papers_applications(provider):
    from geoboresight.algorithms import GROUPS

    for alg in provider.algorithms():
        assert alg.group() in GROUPS
        assert alg.groupId() and alg.groupId().islower() and " " not in alg.groupId()


def test_metadata_declares_a_processing_provider():
    meta = configparser.ConfigParser()
    meta.read(PLUGIN_DIR / "metadata.txt", encoding="utf-8")
    general = meta["general"]
    assert general["hasProcessingProvider"] == "yes"
    for key in (
        "name",
        "version",
        "about",
        "tracker",
        "homepage",
        "repository",
        "qgisMinimumVersion",
    ):
        assert general.get(key), key
    import geoboresight

    assert general["version"] == geoboresight.__version__
