"""docs/api.md runs as written: every Python block, in order, on the bundled sample scene."""

from __future__ import annotations

import os
import pathlib
import re
import shutil

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def test_every_example_of_the_api_page_runs(tmp_path, capsys):
    text = (ROOT / "docs" / "api.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert len(blocks) >= 6
    (tmp_path / "sample_data").symlink_to(ROOT / "sample_data")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        namespace: dict = {}
        for i, code in enumerate(blocks):
            exec(compile(code, f"docs/api.md block {i + 1}", "exec"), namespace)
    finally:
        os.chdir(cwd)
    printed = capsys.readouterr().out
    assert "1009.109 / 922.0" in printed and "True" in printed
    for name in ("ratio.tif", "classes.tif", "dem.tif", "rx.tif", "roc.png", "report.html"):
        assert (tmp_path / "out" / name).stat().st_size > 0, name
    assert not [p for p in (tmp_path / "out").rglob(".*") if p.is_file()]  # no temp litter
    shutil.rmtree(tmp_path / "out")


@pytest.mark.parametrize("name", sorted(__import__("geoboresight").KERNELS))
def test_public_kernels_have_numpydoc_with_the_reference(name):
    import geoboresight as gb

    doc = getattr(gb, name).__doc__ or ""
    for section in ("Parameters", "Returns", "References"):
        assert re.search(rf"^\s*{section}\n\s*-+\n", doc, flags=re.M), (name, section)
    assert "Brook" in doc or "Remote Sens" in doc, name


def test_the_docs_use_the_flat_api_only():
    """What a user reads imports from ``geoboresight`` itself: no ``from geoboresight.io ...``
    and no call or class through a submodule (``geoboresight.io.dark.DarkLevels(...)``). The
    developer's guide names the modules it describes; a module named as where a method lives
    (``geoboresight.anomaly.rx``) is no import."""
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    deep = re.compile(
        r"from geoboresight\.\w|import geoboresight\.\w|geoboresight(?:\.\w+)+\.(?:[A-Z]\w*|\w+\()"
    )
    found = [
        f"{page.name}:{n}: {line.strip()}"
        for page in pages
        if page.name != "DEVELOPING.md"
        for n, line in enumerate(page.read_text(encoding="utf-8").splitlines(), start=1)
        if deep.search(line)
    ]
    assert not found, "\n".join(found)


# --------------------------------------------------------------------------- docstring Examples
def _own_doc(obj) -> str:
    """An object's own docstring (a class's, not its dataclass-generated signature)."""
    doc = obj.__dict__.get("__doc__") if isinstance(obj, type) else obj.__doc__
    return doc or ""


def _with_examples() -> list[str]:
    import geoboresight as gb

    return sorted(
        n for n in gb.__all__ if re.search(r"^\s*Examples\n\s*-+\n", _own_doc(getattr(gb, n)), re.M)
    )


#: The names a newcomer meets first: each shows how it is called, and what it gives, in an
#: Examples section that runs.
MOST_USED = {
    "ratio_file",
    "stats_file",
    "shadow_map_file",
    "deshadow_file",
    "rx_file",
    "relative_dem_file",
    "geolocate_file",
    "info_file",
    "boresight_ratio",
    "describe",
    "BandChoice",
    "DualLayout",
    "FlightGeometry",
    "Matching",
}


def test_the_most_used_names_have_examples():
    missing = sorted(MOST_USED - set(_with_examples()))
    assert not missing, f"no Examples section: {missing}"


@pytest.mark.parametrize("name", _with_examples())
def test_docstring_examples_run_as_written(name, tmp_path, monkeypatch):
    """Each Examples section runs as a doctest from a folder like the repository's top (the
    sample scene in ``sample_data/``, outputs into ``out/``), and prints what it shows."""
    import doctest

    import geoboresight as gb

    (tmp_path / "sample_data").symlink_to(ROOT / "sample_data")
    (tmp_path / "out").mkdir()
    monkeypatch.chdir(tmp_path)
    # As NumPy's examples take ``np`` as imported, these take ``gb`` (``import geoboresight as
    # gb``, docs/api.md) when they do not import it themselves.
    test = doctest.DocTestParser().get_doctest(
        _own_doc(getattr(gb, name)), {"gb": gb}, f"gb.{name}", None, 0
    )
    assert test.examples, name
    report = []
    runner = doctest.DocTestRunner(
        optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE, verbose=False
    )
    runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)
