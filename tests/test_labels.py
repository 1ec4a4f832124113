"""Every parameter has a dialog label in QGIS's words (a few words, as QGIS core names its
parameters: "Input layer", "Band number", "Output CRS") beside the sentence that explains it
(the help pane, the tooltip, the command line's --help)."""

from __future__ import annotations

import pytest

from geoboresight.algorithms import registry
from geoboresight.engine import describe, field_label


@pytest.mark.parametrize("name", sorted(registry()))
def test_each_parameter_has_a_short_label_and_its_sentence(name):
    alg = registry()[name]
    labels = [field_label(p) for p in alg.params]
    for p, label in zip(alg.params, labels, strict=True):
        assert p.label, (name, p.name, "no label")
        assert len(label) <= 30 and len(label.split()) <= 5, (name, p.name, label)
        assert not label[0].islower() and not label.endswith("."), (name, p.name, label)
        assert p.description, (name, p.name)  # the sentence, for help and tooltip
    assert len(set(labels)) == len(labels), (name, labels)  # two fields, two labels


def test_the_engine_describes_label_and_sentence():
    ratio = next(a for a in describe()["algorithms"] if a["name"] == "ratio")
    fields = {p["name"]: p for p in ratio["params"]}
    assert fields["vnir"]["label"] == "VNIR image"
    assert fields["vnir_nm"]["label"] == "VNIR wavelength (nm)"
    assert fields["vnir_nm"]["description"].startswith("VNIR band: the one nearest")


def test_the_command_line_help_keeps_the_sentence():
    from click.testing import CliRunner

    from geoboresight.cli import main

    out = CliRunner().invoke(main, ["ratio", "--help"], terminal_width=200).output
    assert "VNIR band: the one nearest this wavelength" in " ".join(out.split())
