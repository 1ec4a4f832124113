"""The validation report (validation/REPORT.md, written by ``make validate``) is in step with
the validation package: every section is there, in order, and says the command that made it,
which is the section's own command; the package is importable as ``validation`` (no path
edits) and each of its parts parses the arguments its sections give it."""

from __future__ import annotations

import re

import pytest

from validation import __main__ as runner

TEXT = runner.REPORT.read_text(encoding="utf-8")


def test_the_report_has_every_section_in_order():
    parts = runner._sections_of(TEXT)
    assert list(parts) == [s.name for s in runner.SECTIONS]
    positions = [TEXT.index(parts[s.name]) for s in runner.SECTIONS]
    assert positions == sorted(positions)
    assert "## Protocol" in TEXT.split(parts[runner.SECTIONS[0].name])[0]


@pytest.mark.parametrize("section", runner.SECTIONS, ids=lambda s: s.name)
def test_each_section_says_the_command_that_made_it(section):
    part = runner._sections_of(TEXT)[section.name]
    made = re.search(r"Made by `([^`]+)` on commit (\S+), [^,]+, in (\d+) s\.", part)
    if made is None:
        assert f"python -m validation --section {section.name}" in part, part[:300]
        return
    assert made.group(1) == " ".join(["python -m validation", section.module, *section.args])
    assert "|---|" in part  # a table follows


@pytest.mark.parametrize("section", runner.SECTIONS, ids=lambda s: s.name)
def test_each_part_parses_its_sections_arguments(section, monkeypatch):
    module = pytest.importorskip(f"validation.{section.module}")
    for args in (section.args, section.quick or ()):
        with pytest.raises(SystemExit) as e:  # --help after the arguments: parsed, not run
            module.report([*args, "--help"])
        assert e.value.code == 0
