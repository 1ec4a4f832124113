"""Write ``geoboresight/__init__.pyi`` from the lazy tables of ``geoboresight/__init__.py``.

The stub is derived, like docs/troubleshooting.md: ``python -m geoboresight._stub --update``
rewrites it; tests/test_house.py checks it is current. Its preamble (docstring and the
annotated names) is kept as it is.
"""

from __future__ import annotations

import sys
from pathlib import Path

STUB = Path(__file__).with_name("__init__.pyi")
_FIRST = "from ."


def render(current: str) -> str:
    """``current`` with its import lines replaced by one per public name, sorted by module."""
    import geoboresight

    lines = current.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(_FIRST))
    end = max(i for i, line in enumerate(lines) if line.startswith(_FIRST)) + 1
    imports = sorted(
        f"from .{module.removeprefix('geoboresight.')} import {name} as {name}"
        for name, module in geoboresight._API.items()
    )
    return "\n".join([*lines[:start], *imports, *lines[end:]]) + "\n"


def main(argv: list[str]) -> int:
    text = STUB.read_text(encoding="utf-8")
    new = render(text)
    if "--update" in argv and new != text:
        STUB.write_text(new, encoding="utf-8")
        print(f"{STUB}: updated")
    elif new != text:
        print(f"{STUB} is out of date: run python -m geoboresight._stub --update")
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
