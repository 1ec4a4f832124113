"""The repository speaks to its users in the present tense: the history of its development
(work sessions, tracker numbers, numbered hold-out groups, who did what) lives in the commit
messages, not in the tracked files. This test lists every line that tells it, as file:line."""

from __future__ import annotations

import pathlib
import re
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parent.parent
TEXT = {
    ".py",
    ".md",
    ".toml",
    ".txt",
    ".cfg",
    ".ini",
    ".yml",
    ".yaml",
    ".json",
    ".html",
    ".sh",
    ".hdr",
    ".csv",
    ".xml",
    ".qml",
}
_ORDINAL = (
    "first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|previous|earlier|"
    "last|next|this|that|same|each|both"
)
#: What tells the history. Each pattern is narrow enough that ordinary words pass: a pytest
#: "session" fixture, a QGIS desktop session, "a helper function", a regex's group(1).
HISTORY = re.compile(
    "|".join(
        (
            r"\b(?:session|issue)s?\s*#?\d+",  # "issue 24", "session 3", "issue #12"
            rf"\b(?:{_ORDINAL})\s+sessions?\b",  # "the second session"
            r"\bsessions?\s+of\s+issue",
            r"\bhold-?out\s+(?:group|set)s?\s*\d",  # "hold-out group 12"
            r"\b(?:hold-?out\s+)?groups?\s+\d+(?:\s*(?:,|and|\+|–|to)\s*\d+)*\s*\((?:seen|hold)",
            r"\bgroups?\s+\d+\s*(?:,|and|\+)\s*\d+\b",  # "groups 4 + 5", "groups 6 and 7"
            r"\bgroup[- ]\d+\b(?!\s*(?:px|pixels|bands|lines|m\b|%))",  # "group 14", "group-4 seed"
            r"\bthe lead(?:'s)?\b(?!\s+time)",  # a role
            r"\blead's\b",
            r"\b(?:a|the|one|another)\s+helper\s+(?:prototyped|tried|found|measured|wrote|ran)\b",
            r"\bhelpers?\s+prototyped\b",
            r"\bthe issue's\b",
            r"\bas the issue (?:asks|says|words it)\b",
        )
    ),
    re.IGNORECASE,
)


def _tracked() -> list[pathlib.Path]:
    try:
        out = subprocess.run(
            ["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, check=True
        ).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    me = pathlib.Path(__file__).resolve()
    return [
        p
        for p in (ROOT / name for name in out.decode().split("\0") if name)
        if p.is_file()
        and p.resolve() != me
        and (p.suffix in TEXT or p.name in ("Makefile", "metadata.txt", "LICENSE"))
    ]


def history_lines(paths) -> list[str]:
    """Every line of these files that tells the development history, as "file:line: text"."""
    hits = []
    for p in paths:
        for i, line in enumerate(p.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            if HISTORY.search(line):
                hits.append(f"{p.relative_to(ROOT)}:{i}: {line.strip()[:160]}")
    return hits


def test_no_tracked_file_tells_the_development_history():
    files = _tracked()
    assert any(p.name == "README.md" for p in files)
    hits = history_lines(files)
    assert not hits, f"{len(hits)} lines tell the history:\n" + "\n".join(hits)


@pytest.mark.parametrize(
    "text",
    [
        "Hold-out scenes (issue 15, second session)",
        "Sixth session: the predicted shadow registered to the image",
        "the lead's decision after the validation above",
        "A helper prototyped an optional stage",
        "**Hold-out group 13** (run once)",
        "Development scenes and groups 4 + 5 (seen)",
        "on group-4 m2 seed 24 (relief 15 m)",
        "image (EnPT issue #12)",
        "Goals (Issue 24), as measured",
        "the check as the issue words it",
    ],
)
def test_the_pattern_catches_history(text):
    assert HISTORY.search(text), text


@pytest.mark.parametrize(
    "text",
    [
        '@pytest.fixture(scope="session")',
        "def pytest_sessionfinish(session, exitstatus):",
        "one QGIS desktop session in a fresh profile",
        "GRASS's time includes its session start-up",
        "a helper function that reads the header",
        "m.group(0) is the whole match",
        "pixels in a group 3 px wide",
        "the issue of dark offsets on raw DN",
        "the lead time of the sensor",
        "the hold-out scenes are drawn at random",
    ],
)
def test_the_pattern_lets_ordinary_words_pass(text):
    assert not HISTORY.search(text), text
