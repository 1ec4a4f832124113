"""The documentation stands alone: a user of the published package has README.md and docs/,
not the development notes beside the repository, so no tracked text file points outside it,
every relative link of the Markdown pages reaches a file, and every command-line example uses
options the command has (retired spellings stay hidden aliases, never examples)."""

from __future__ import annotations

import pathlib
import re
import shlex
import subprocess

import click
import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
#: What a published checkout does not have: the shared design notes and the paper's text.
#: (Spelled in pieces so that this file does not match itself.)
_SHARED, _DESIGN, _PAPER = "shared", "DESIGN" + ".md", "paper" + ".txt"
OUTSIDE = re.compile(rf"\.\./{_SHARED}|{_SHARED}/DESIGN|DESIGN\.md|paper\.txt")
TEXT = {".py", ".md", ".toml", ".txt", ".cfg", ".ini", ".yml", ".yaml", ".json", ".html", ".sh"}


def _tracked() -> list[pathlib.Path]:
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [ROOT / p for p in out.decode().split("\0") if p]


def test_no_tracked_text_file_points_outside_the_repository():
    files = [
        p
        for p in _tracked()
        if p.is_file() and (p.suffix in TEXT or p.name in ("Makefile", "run", "metadata.txt"))
    ]
    assert any(p.name == "README.md" for p in files)
    hits = [
        f"{p.relative_to(ROOT)}:{i}: {line.strip()}"
        for p in files
        for i, line in enumerate(p.read_text(errors="replace").splitlines(), 1)
        if OUTSIDE.search(line)
    ]
    assert not hits, "\n".join(hits)


def test_the_pattern_catches_what_it_should():
    for text in (f"see ../{_SHARED}/{_DESIGN}", f"{_DESIGN} §Shape", f"the paper ({_PAPER})"):
        assert OUTSIDE.search(text), text
    assert not OUTSIDE.search("docs/method.md and docs/DEVELOPING.md")


_LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)|!\[[^\]]*\]\(([^)\s]+)\)")


def _links(page: pathlib.Path) -> list[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)  # code is not a link
    text = re.sub(r"`[^`\n]*`", "", text)
    return [a or b for a, b in _LINK.findall(text)]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_relative_links_reach_a_file(page):
    missing = []
    for target in _links(page):
        if re.match(r"[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue  # a URL (https:, mailto:) or an anchor of this page
        path = (page.parent / target.split("#", 1)[0]).resolve()
        if not path.exists():
            missing.append(target)
        elif ROOT not in path.parents:
            missing.append(f"{target} (outside the repository)")
    assert not missing, f"{page.name}: {missing}"


def test_the_link_finder_sees_links():
    page = ROOT / "README.md"
    assert any(t.startswith("docs/") for t in _links(page))


def _examples(page: pathlib.Path):
    """``(line, argv)`` of every ``geoboresight ...`` command in the page's code blocks."""
    for block in re.findall(r"```[a-z]*\n(.*?)```", page.read_text(), flags=re.S):
        text = block.replace("\\\n", " ")
        for line in text.splitlines():
            line = line.strip().removeprefix("$ ")
            if line.startswith("geoboresight "):
                line = line.split(" #", 1)[0]
                yield line, shlex.split(line)[1:]


def _command(argv):
    from geoboresight.cli import main

    cmd, ctx, rest = main, click.Context(main), list(argv)
    while isinstance(cmd, click.Group) and rest and not rest[0].startswith("-"):
        sub = cmd.get_command(ctx, rest[0])
        if sub is None:
            return None, rest
        cmd, ctx, rest = sub, click.Context(sub, parent=ctx), rest[1:]
    return cmd, rest


def test_command_line_examples_use_current_options():
    seen, wrong = 0, []
    for page in PAGES:
        for line, argv in _examples(page):
            if not argv or argv[0] in ("--help", "--version"):
                continue
            cmd, rest = _command(argv)
            if cmd is None:
                wrong.append(f"{page.name}: unknown command in {line!r}")
                continue
            known = {o for p in cmd.params if not getattr(p, "hidden", False) for o in p.opts}
            known |= {
                o for p in cmd.params if not getattr(p, "hidden", False) for o in p.secondary_opts
            }
            known.add("--help")
            for token in rest:
                name = token.split("=", 1)[0]
                if name.startswith("--") and name not in known:
                    wrong.append(f"{page.name}: {name} in {line!r}")
            seen += 1
    assert seen > 20, seen
    assert not wrong, "\n".join(wrong)
