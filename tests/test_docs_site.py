"""The documentation site's generated parts (docs/hooks/site.py, run by `make docs`), the
changelog and the plugin repository's plugins.xml, checked without building anything."""

from __future__ import annotations

import importlib
import importlib.util
import logging
import pathlib
import re
import xml.etree.ElementTree as ET
import zipfile

import geoboresight as gb

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _load(name: str, path: pathlib.Path):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


site = _load("docs_site_hooks", ROOT / "docs" / "hooks" / "site.py")
plugin_repo = _load("plugin_repo", ROOT / "tools" / "plugin_repo.py")


def test_every_public_name_has_a_docstring():
    assert site.missing_docstrings() == []


def test_a_dataclass_without_a_docstring_of_its_own_is_found(monkeypatch):
    import dataclasses

    @dataclasses.dataclass(frozen=True)
    class Bare:
        x: int = 0

    monkeypatch.setattr(gb, "__all__", [*gb.__all__, "Bare"])
    monkeypatch.setattr(gb, "Bare", Bare, raising=False)
    assert site.missing_docstrings() == ["Bare"]


def test_the_api_reference_lists_every_public_name_once():
    pages = site.reference_pages()
    entries = re.findall(r"^::: (\S+)$", "\n".join(pages.values()), flags=re.M)
    names = [e.rsplit(".", 1)[1] for e in entries]
    assert sorted(names) == sorted(gb.__all__)
    for entry in entries:  # documented where it is defined
        module, name = entry.rsplit(".", 1)
        obj = getattr(gb, name)  # an operation: the function its spec wraps
        obj = obj.__wrapped__ if name in gb.OPERATIONS else obj
        assert getattr(importlib.import_module(module), name) is obj
    assert {table for _, _, table, _ in site.REFERENCE} == {"OPERATIONS", "KERNELS", "VALUES", "IO"}


def test_links_leaving_docs_point_at_the_repository_and_a_missing_file_warns(caplog):
    url = "https://github.com/o/r"
    text = "[a](../geoboresight/io/dual.py#L3) [b](qgis.md) [c](../no/such.py)\n```\n[d](../x)\n```"
    with caplog.at_level(logging.WARNING):
        out = site.rewrite_links(text, "api.md", url)
    assert "[a](https://github.com/o/r/blob/main/geoboresight/io/dual.py#L3)" in out
    assert "[b](qgis.md)" in out and "[c](../no/such.py)" in out and "[d](../x)" in out
    assert [r.getMessage() for r in caplog.records] == [
        "api.md: link to ../no/such.py, which does not exist"
    ]


def test_the_home_page_is_the_readme_with_links_from_docs():
    home = site.home_page()
    assert home.startswith("# geoboresight")
    assert "](docs/" not in home and "](qgis.md)" in home
    # a user reads how to install first; the fresh clone's two commands stay in the README
    assert "make test" not in home and "](install.md)" in home
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    top = readme[: readme.index("\n## ", readme.index("## Two commands") + 3)]
    assert re.findall(r"^make (\w+)", top, flags=re.M) == ["demo", "test"]


def test_the_install_page_says_how_to_install_and_shows_five_commands():
    text = (ROOT / "docs" / "install.md").read_text(encoding="utf-8")
    assert "pip install geoboresight" in text and "make plugin-zip" in text
    assert "geoboresight simulate" in text
    shown = re.findall(r"^\$ geoboresight (\S+)", text, flags=re.M)
    assert len([c for c in shown if c != "simulate"]) == 5


def test_the_gallery_shows_the_papers_figures_with_their_commands():
    page = site.gallery_page()
    figures = re.findall(r"^## (Figure \d+):", page, flags=re.M)
    assert figures == [f"Figure {n}" for n in (2, 3, 4, 5, 9, 11, 12)]
    assert page.count("```bash\ngeoboresight ") >= len(figures)
    for name in re.findall(r"\]\(gallery/(\S+)\)", page):
        assert f"out/{name}" in page  # the picture is one a step writes


def test_the_changelog_begins_with_this_version():
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "keepachangelog.com" in text
    versions = re.findall(r"^## \[([^\]]+)\] - (\d{4}-\d{2}-\d{2})$", text, flags=re.M)
    assert versions and versions[0][0] == gb.__version__
    assert re.search(rf"^\[{re.escape(gb.__version__)}\]: https://", text, flags=re.M)


def test_the_changelogs_newest_section_speaks_to_users():
    """One line per change a user sees; the timings stay in benchmarks/RESULTS.md."""
    text = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    sections = re.split(r"^## ", text, flags=re.M)
    newest = sections[1]
    timings = re.findall(r"\d\s?(?:s|ms|min)\b|→|\d\s?×", newest)
    assert not timings, timings
    if newest.startswith("[Unreleased]"):
        link = rf"^\[Unreleased\]: https://\S+/compare/v{re.escape(gb.__version__)}\.\.\.HEAD$"
        assert re.search(link, text, flags=re.M)


def test_plugins_xml_is_written_from_the_zips_metadata(tmp_path):
    zip_path = tmp_path / "plugin.zip"
    with zipfile.ZipFile(zip_path, "w") as z:
        for name in ("metadata.txt", "icon.svg", "__init__.py"):
            z.write(ROOT / "plugin" / name, f"geoboresight_qgis/{name}")
    xml = plugin_repo.write_repository(zip_path, tmp_path / "repo", "https://example.org/q/")
    node = ET.parse(xml).getroot().find("pyqgis_plugin")
    meta = plugin_repo.plugin_metadata(zip_path)[1]
    assert node.get("name") == "geoboresight" and node.get("version") == meta["version"]
    assert node.findtext("qgis_minimum_version") == meta["qgisMinimumVersion"]
    assert node.findtext("qgis_maximum_version") == meta["qgisMaximumVersion"]
    # QGIS names the installed plugin after file_name up to its first dot: the zip's folder.
    assert node.findtext("file_name") == f"geoboresight_qgis.{meta['version']}.zip"
    assert node.findtext("download_url") == (
        f"https://example.org/q/geoboresight_qgis.{meta['version']}.zip"
    )
    assert (tmp_path / "repo" / node.findtext("file_name")).read_bytes() == zip_path.read_bytes()
    assert node.findtext("experimental") == meta["experimental"]


def test_the_gallery_shows_each_command_as_a_shell_runs_it():
    import shlex

    gallery = site._gallery_module()
    for figure in gallery.FIGURES:
        for kind, text in figure["steps"]:
            if kind == "sh":
                shown = site._wrapped(text)
                assert all(len(line) <= 100 for line in shown.splitlines()), shown
                assert shlex.split(shown.replace("\\\n", "")) == shlex.split(text)


# --------------------------------------------------------------------------- command reference
commands = _load("docs_commands", ROOT / "docs" / "hooks" / "commands.py")


def _sections(page: str) -> dict[str, str]:
    """``{operation: its section's text}`` of one page of the command reference."""
    parts = re.split(r"^## (\S+)\n", page, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


def test_the_command_reference_has_every_operation_and_every_option():
    from geoboresight.algorithms import registry
    from geoboresight.cli import make_command
    from geoboresight.engine import field_label

    pages = commands.pages()
    for alg in registry().values():
        sections = _sections(pages[commands.page_of(alg.group)])
        assert alg.name in sections, f"{alg.name} is missing from the command reference"
        text = sections[alg.name]
        command = make_command(alg)
        visible = [o for o in command.params if isinstance(o, type(command.params[-1]))]
        rows = {}
        for line in text.splitlines():
            cells = [c.strip() for c in re.split(r"(?<!\\)\|", line)[1:-1]]
            for flag in re.findall(r"`(--[a-z0-9-]+)", cells[0] if cells else ""):
                rows.setdefault(flag, []).append(cells)
        for p in alg.params:
            found = rows.get(f"--{p.name.replace('_', '-')}", [])
            assert len(found) == 1, f"{alg.name}: option {p.name} is not in the reference"
            cells = found[0]
            assert cells[1] == field_label(p).replace("|", "\\|"), (alg.name, p.name)
            if not p.is_output and not p.required and p.default not in (None, ""):
                assert cells[3] == f"`{commands.value_text(p.default)}`", (alg.name, p.name)
        # every option the command line shows (but the shared ones) has its row
        shared = {"overwrite", "cog", "co", "raw_gsd", "quiet", "as_json", "debug"}
        for option in visible:
            if not option.hidden and option.name not in shared:
                assert f"`{option.opts[-1]}" in text, (alg.name, option.opts)
        if alg.example:
            assert f"```bash\n{alg.example_command()}\n```" in text


def test_a_default_is_shown_as_its_value():
    class P:
        required, default = False, 0.5

    assert commands.default_text(P()) == "`0.5`"
    P.default = 1010.0
    assert commands.default_text(P()) == "`1010`"
    P.default = False
    assert commands.default_text(P()) == "`off`"
    P.required = True
    assert commands.default_text(P()) == "required"


def test_the_command_reference_is_in_the_sites_navigation():
    from geoboresight.algorithms import GROUPS, registry

    nav = [{"Home": "index.md"}, {"Command reference": "commands/index.md"}]
    out = site.expand_nav(nav, commands.nav(), "commands/index.md")
    section = out[1]["Command reference"]
    assert section[0] == "commands/index.md"
    used = [g for g in GROUPS if any(a.group == g for a in registry().values())]
    assert [next(iter(e)) for e in section[1:]] == used
    assert set(commands.pages()) == {"commands/index.md", *(commands.page_of(g) for g in used)}


# --------------------------------------------------------------------------- troubleshooting
def test_the_pages_of_messages_are_in_step_with_the_code_and_ordered_by_task():
    from geoboresight import errors

    pages = errors.catalogue_pages()
    on_disk = {
        f"{errors.CATALOGUE_FOLDER}/{p.name}": p.read_text(encoding="utf-8")
        for p in (ROOT / "docs" / errors.CATALOGUE_FOLDER).glob("*.md")
    }
    assert on_disk == pages, (
        "the pages of messages are out of date: run "
        "python -m geoboresight.errors --update docs/troubleshooting.md"
    )
    listed = sum(len(re.findall(r"^- \*\*", text, flags=re.M)) for text in pages.values())
    assert listed == len(errors.message_catalogue())
    assert errors.message_task("geoboresight/io/products/enmap.py", "read") == "reading"
    assert errors.message_task("geoboresight/io/georef.py", "read_glt") == "georef"
    assert errors.message_task("geoboresight/operations/_surface.py", "sun_angles") == "shadow"
    assert errors.message_task("geoboresight/engine.py", "run") == "qgis"
    assert errors.message_task("geoboresight/newmodule.py", "f") == errors.FALLBACK
    index = errors.catalogue_markdown()
    assert [f"{errors.CATALOGUE_FOLDER}/{page}.md" for page, _, _ in errors.TASKS] == re.findall(
        r"\]\((\S+\.md)\)", index
    )


def test_no_page_of_the_docs_is_over_400_lines():
    pages = [*(ROOT / "docs").glob("*.md"), *(ROOT / "docs").glob("*/*.md")]
    long = {
        p.name: n for p in pages if (n := len(p.read_text(encoding="utf-8").splitlines())) > 400
    }
    assert not long, long


# --------------------------------------------------------------------------- validation
def test_the_validation_report_is_on_the_site_whole_and_links_to_it_stay_there():
    pages, anchors = site.validation_report_pages()
    report = (ROOT / "validation" / "REPORT.md").read_text(encoding="utf-8")
    headings = re.findall(r"^##+ .+$", report, flags=re.M)
    shown = re.findall(r"^##+ .+$", "\n".join(pages.values()), flags=re.M)
    assert sorted(shown) == sorted(headings)  # every section, once
    shadow = next(h for h in headings if h.startswith("## Shadow map"))[3:]
    assert anchors[site._slug(shadow)] == "validation-report/shadow-map.md"
    out = site.rewrite_links(
        f"[r](../validation/REPORT.md#{site._slug(shadow)}) [c](../CHANGELOG.md)",
        "shadow.md",
        "https://github.com/o/r",
    )
    assert f"[r](validation-report/shadow-map.md#{site._slug(shadow)})" in out
    assert "[c](changelog.md)" in out


def test_the_method_pages_link_to_the_validation_page_and_no_link_is_a_placeholder():
    for name in ("shadow", "deshadow", "dem", "anomaly"):
        text = (ROOT / "docs" / f"{name}.md").read_text(encoding="utf-8")
        assert "](validation.md#" in text, name
        assert "hold-out:" not in text, name  # the tables live on the validation page
    pages = [ROOT / "README.md", ROOT / "mkdocs.yml", *sorted((ROOT / "docs").rglob("*.md"))]
    placeholder = re.compile(r"example\.(org|com)|github\.com/(OWNER|USER|your)", re.I)
    assert not [p.name for p in pages if placeholder.search(p.read_text(encoding="utf-8"))]


def test_the_operations_and_kernels_reference_is_split_by_area():
    pages = site.reference_pages()
    for table in site.SPLIT:
        page = next(p for p, _, t, _ in site.REFERENCE if t == table)
        areas = [p for p in pages if p.startswith(f"reference/{page}/")]
        assert len(areas) >= 5, areas
        assert "::: " not in pages[f"reference/{page}.md"]  # the index links, the areas hold
        nav = site.reference_nav()[f"reference/{page}.md"]
        assert sorted(next(iter(e.values())) for e in nav[1:]) == sorted(areas)
    assert site.area_of("geoboresight.operations.shadow_map") == ("shadow", "Shadow")
    assert site.area_of("geoboresight.anomaly.rx")[0] == "anomaly"
    assert site.area_of("geoboresight.radiometry.calibrate")[0] == "more"


def test_the_install_pages_commands_print_what_it_shows(tmp_path, monkeypatch):
    """Every ``$ geoboresight ...`` block of docs/install.md, run in order in an empty folder:
    each line the page shows (``...`` stands for lines left out) is a line the command
    prints."""
    import shlex

    from click.testing import CliRunner

    from geoboresight.cli import main

    text = (ROOT / "docs" / "install.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```console\n\$ (geoboresight [^\n]+)\n(.*?)```", text, flags=re.S)
    assert len(blocks) == 6, [command for command, _ in blocks]
    monkeypatch.chdir(tmp_path)
    (tmp_path / "out").mkdir()
    for command, shown in blocks:
        result = CliRunner().invoke(main, shlex.split(command)[1:], catch_exceptions=False)
        assert result.exit_code == 0, (command, result.output)
        printed = [line.rstrip() for line in result.output.splitlines()]
        for line in shown.splitlines():
            if line.strip() and line.strip() != "...":
                assert any(_same_line(line.rstrip(), p) for p in printed), (command, line)


_NUMBER = re.compile(r"[-+]?\d+\.\d+(?:[eE][-+]?\d+)?")


def _same_line(shown: str, printed: str) -> bool:
    """The same words, and numbers equal to 1e-6 relative: the page shows one run's figures
    at full precision, and another NumPy (1.26 beside QGIS) simulates the scene and sums the
    statistics in another order, which moves their last digits."""
    if _NUMBER.sub("#", shown) != _NUMBER.sub("#", printed):
        return False
    a = [float(v) for v in _NUMBER.findall(shown)]
    b = [float(v) for v in _NUMBER.findall(printed)]
    return all(abs(x - y) <= 1e-6 * max(abs(x), abs(y)) for x, y in zip(a, b, strict=True))
