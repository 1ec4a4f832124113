"""Temporary outputs ('Create temporary layer/file') of each kind, through ``processing.run`` in
real QGIS (the provider starts the engine, the project's .venv/bin/geoboresight).

Every operation against the library's own outputs, results, declared outputs and styles: see
test_qgis_desktop.py (one QGIS desktop run in a fresh profile runs them all).
"""

from __future__ import annotations

import os

import pytest
from qgis_cases import to_qgis, values_for

from geoboresight.algorithms import registry

pytestmark = pytest.mark.qgis


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
