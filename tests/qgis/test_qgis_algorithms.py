"""Every algorithm in the registry, run through ``processing.run`` in real QGIS (the provider
starts the engine, the project's .venv/bin/geoboresight), writes the same numbers as the
library run directly with the same values (in the engine's environment), and returns the same results, declared as outputs."""

from __future__ import annotations

import json
import os

import pytest
from qgis_cases import to_qgis, values_for
from qgis_compare import assert_same_file, same_value
from qgis_harness import library_run

from geoboresight.algorithms import registry

pytestmark = pytest.mark.qgis


def assert_styled(path):
    """Opened in QGIS: classes with their colour table, one continuous band with a ramp."""
    from qgis.core import QgsRaster, QgsRasterLayer

    layer = QgsRasterLayer(path, "out", "gdal")
    assert layer.isValid(), path
    if layer.dataProvider().colorInterpretation(1) == QgsRaster.PaletteIndex:
        assert layer.renderer().type() == "paletted", path
    elif layer.bandCount() == 1:
        assert layer.renderer().type() == "singlebandpseudocolor", path


@pytest.mark.parametrize("name", list(registry()))
def test_every_algorithm_matches_the_library(name, provider, inputs, tmp_path):
    import processing
    from qgis.core import QgsProcessingFeedback

    spec = registry()[name]
    q_dir, l_dir = tmp_path / "qgis", tmp_path / "lib"
    q_dir.mkdir()
    l_dir.mkdir()
    q_values = values_for(spec, inputs, str(q_dir))
    l_values = values_for(spec, inputs, str(l_dir))

    messages = []

    class Feedback(QgsProcessingFeedback):
        def pushInfo(self, info):  # noqa: N802
            messages.append(info)
            super().pushInfo(info)

    q_result = processing.run(f"geoboresight:{name}", to_qgis(spec, q_values), feedback=Feedback())
    l_result = library_run(name, l_values)

    for p in spec.outputs:
        if p.name in l_result:
            assert q_result[p.name] == q_values[p.name]
            assert_same_file(q_values[p.name], l_values[p.name], str(q_dir), str(l_dir))
            if p.kind == "raster_out":
                assert_styled(q_values[p.name])
    from qgis.core import QgsApplication

    alg = QgsApplication.processingRegistry().algorithmById(f"geoboresight:{name}")
    declared = {o.name(): o.type() for o in alg.outputDefinitions()}
    for key, value in l_result.items():
        if key in {p.name for p in spec.outputs}:
            continue
        # Scalar results are declared outputs (numbers, strings) a model can chain; only
        # results named after the inputs (ROC's auc_<name>) or like a parameter are not.
        if key not in {p.name for p in spec.params} and not key.startswith(("auc_", "pd_at")):
            assert key in declared, f"{name}: result {key} not declared as an output"
            kind = declared[key]
            if isinstance(value, bool):
                assert kind == "outputBoolean", (key, kind)
            elif isinstance(value, int | float):
                assert kind == "outputNumber", (key, kind)
            else:
                assert kind == "outputString", (key, kind)
        got = q_result.get(key)
        if isinstance(got, str) and isinstance(value, list | tuple | dict):
            got = json.loads(got)  # lists and tables reach QGIS as JSON text
        if isinstance(value, str):
            value = value.replace(str(l_dir), str(q_dir))
        assert same_value(got, list(value) if isinstance(value, tuple) else value), (
            key,
            got,
            value,
        )
        assert any(key in m for m in messages), f"result {key} not shown in the QGIS log"


def _first_with_output(kind):
    for spec in registry().values():
        if any(p.kind == kind for p in spec.outputs):
            return spec.name
    return None


OUTPUT_KINDS = ("raster_out", "vector_out", "file_out", "folder_out")


@pytest.mark.parametrize("kind", OUTPUT_KINDS)
def test_temporary_outputs(kind, provider, inputs):
    """'Create temporary layer/file' (TEMPORARY_OUTPUT) works for each kind of output."""
    import processing

    name = _first_with_output(kind)
    if name is None:
        pytest.skip(f"no algorithm has a {kind} output yet")
    spec = registry()[name]
    params = to_qgis(spec, values_for(spec, inputs, "unused"))
    for p in spec.outputs:
        params[p.name] = "TEMPORARY_OUTPUT"
    result = processing.run(f"geoboresight:{name}", params)
    for p in spec.outputs:
        path = result.get(p.name)
        assert path and os.path.exists(path), (name, p.name, path)
        if p.extension and p.kind != "folder_out":
            assert path.endswith(f".{p.extension}"), (name, p.name, path)
