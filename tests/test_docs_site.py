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
        assert getattr(importlib.import_module(module), name) is getattr(gb, name)
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
