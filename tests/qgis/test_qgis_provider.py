"""The provider as QGIS sees it: every spec listed (from the engine's operation list), parameters
of QGIS's own types, help, declared results, an icon per group, the setup tool, and the enums
of both QGIS generations through plugin/compat.py."""

from __future__ import annotations

import configparser

import pytest
from qgis_harness import PLUGIN_DIR

from geoboresight.algorithms import registry
from geoboresight.engine import field_label

pytestmark = pytest.mark.qgis


def test_provider_lists_every_spec(provider):
    from qgis.core import QgsApplication

    reg = QgsApplication.processingRegistry()
    assert reg.providerById("geoboresight") is provider
    listed = {a.name() for a in provider.algorithms()}
    assert listed == set(registry()) | {"setup-engine"}
    assert provider.engine is not None and provider.problem == ""  # the engine's own list
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
    "numbers": "string",  # "X Y Z" in one text field
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
            assert q.description() == field_label(p), where  # a few words
            assert q.help() == p.description, where  # the sentence: the tooltip
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
        if alg.name() == "setup-engine":
            assert alg.group() == "Engine"
            continue
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
    # QGIS 4 readiness (plugins.qgis.org reads it from qgisMaximumVersion)
    assert int(general["qgisMaximumVersion"].split(".")[0]) >= 4


def test_an_icon_per_group(provider):
    from qgis_harness import PLUGIN_DIR

    from geoboresight.algorithms import GROUPS
    from geoboresight.engine import group_id

    icons = {}
    for alg in provider.algorithms():
        path = PLUGIN_DIR / "icons" / f"{alg.groupId()}.svg"
        assert path.exists(), path
        assert not alg.icon().isNull()
        icons.setdefault(alg.groupId(), path.read_text())
    assert len(set(icons.values())) == len(icons)  # each group its own icon
    assert set(icons) >= {group_id(g) for g in GROUPS} | {"engine"}


def test_scalar_results_are_declared_outputs(provider):
    """Numbers and strings a model can chain (e.g. the ratio's band numbers)."""
    from qgis.core import QgsApplication

    alg = QgsApplication.processingRegistry().algorithmById("geoboresight:ratio")
    types = {o.name(): o.type() for o in alg.outputDefinitions()}
    assert types["output"] == "outputRaster"
    for name in ("swir_band", "vnir_band", "valid_pixels", "swir_wavelength_nm"):
        assert types[name] == "outputNumber", name
    dem = QgsApplication.processingRegistry().algorithmById("geoboresight:relative-dem")
    types = {o.name(): o.type() for o in dem.outputDefinitions()}
    assert types["message"] == "outputString" and types["meaningful"] == "outputBoolean"
    for name in ("variance", "disparity"):  # every file the operation writes is declared
        assert types[name] == "outputRaster", name
    assert types["report"] == "outputFile"


def test_help_lists_ranges_and_results(provider):
    from qgis.core import QgsApplication

    text = QgsApplication.processingRegistry().algorithmById("geoboresight:ratio").shortHelpString()
    spec = registry()["ratio"].param("swir_nm")
    assert f"range {spec.minimum:g}–{spec.maximum:g} nm" in text
    assert "<h3>Results</h3>" in text and "valid_pixels" in text


def test_compat_picks_scoped_enums_when_present():
    """QGIS >= 3.36 / 4: Qgis.<Enum>.<Member>; 3.22: the old unscoped names. Both branches,
    with stand-ins (only 3.22 is installable here)."""
    from types import SimpleNamespace

    import geoboresight_qgis.compat as compat

    new = SimpleNamespace(ProcessingSourceType=SimpleNamespace(Raster="scoped-raster"))
    old = SimpleNamespace(TypeRaster="old-raster")
    assert compat.pick(new, "ProcessingSourceType.Raster", old, "TypeRaster") == "scoped-raster"
    assert compat.pick(SimpleNamespace(), "ProcessingSourceType.Raster", old, "TypeRaster") == (
        "old-raster"
    )
    with pytest.raises(AttributeError, match="neither"):
        compat.pick(SimpleNamespace(), "X.Y", SimpleNamespace(), "Z")
    # on this QGIS (3.22) the values are the old names'
    from qgis.core import QgsProcessing, QgsProcessingParameterDefinition

    assert compat.TYPE_RASTER == QgsProcessing.TypeRaster
    assert compat.FLAG_ADVANCED == QgsProcessingParameterDefinition.FlagAdvanced


def test_no_old_enum_names_outside_compat():
    """QGIS 4 drops the unscoped names: only compat.py may spell them."""
    import re

    from qgis_harness import PLUGIN_DIR

    old = re.compile(
        r"QgsProcessing\.Type\w+|QgsProcessingParameterDefinition\.Flag\w+|"
        r"QgsProcessingParameterNumber\.(Integer|Double)|QgsRaster\.PaletteIndex|"
        r"QgsColorRampShader\.(Interpolated|Continuous)|Qgis\.(Info|Warning|Critical|Success)\b"
    )
    for path in PLUGIN_DIR.rglob("*.py"):
        if path.name == "compat.py":
            continue
        found = old.findall(path.read_text())
        assert not found, (path.name, found)
