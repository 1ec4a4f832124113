"""Errors a user can act on.

Every failure that comes from the user's input (a file, a band, a parameter) is raised as a
:class:`GeoboresightError` whose message names the thing at fault and says what to do. Faces
(CLI, QGIS, rio) print the message alone, without a traceback.

The message names parameters as Python does (``parameter 'vnir'``, ``overwrite=True``); an
error that names parameters lists them in ``params``, and each face words them its own way
(:func:`worded`): the CLI with its options (``--vnir``), the engine (QGIS) with each field's
label.
"""

from collections.abc import Callable


class GeoboresightError(Exception):
    """Base class: a problem the user can fix; the message says how. ``params``: the
    parameters the message names (Python names), for the faces to word (:func:`worded`)."""

    def __init__(self, *args, params=()):
        super().__init__(*args)
        self.params = tuple(params)


class InputError(GeoboresightError, ValueError):
    """A missing or unreadable file, a band or wavelength that does not exist, mismatched grids."""


class ParameterError(GeoboresightError, ValueError):
    """A parameter outside its range, of the wrong type, or inconsistent with another."""


class OutputError(GeoboresightError, OSError):
    """An output that would overwrite an input, or an existing file without ``overwrite``."""


class ResourceError(GeoboresightError, OSError):
    """The machine ran out of something the run needs (memory); the message says what to lower."""


class Cancelled(GeoboresightError):
    """The user cancelled the run (QGIS cancel button, Ctrl-C); partial outputs were removed."""


def shown(value, limit: int = 80) -> str:
    """``repr(value)`` cut to a readable length for an error line (a 200,000-character CRS
    string is named by its start and its length, not echoed whole)."""
    text = repr(value)
    if len(text) <= limit:
        return text
    return f"{text[: limit - 1]}… ({len(str(value)):,} characters)"


def worded(exc: BaseException, name: Callable[[str], str]) -> str:
    """``exc``'s message (on one line) with each parameter of its ``params`` named by
    ``name(param)``, a face's word for it: ``parameter 'vnir'`` and ``'vnir'`` become
    ``name('vnir')``, ``overwrite=True`` becomes ``name('overwrite')``."""
    text = " ".join(str(exc).split())
    for p in getattr(exc, "params", ()):
        if p == "overwrite":
            text = text.replace("overwrite=True", name(p))
            continue
        text = text.replace(f"parameter '{p}'", name(p)).replace(f"'{p}'", name(p))
    return text


def cli_option(param: str) -> str:
    """A parameter as the command line spells it: ``--vnir``, ``--height-factor``."""
    return "--" + param.replace("_", "-")


# --- The catalogue of messages (docs/troubleshooting.md is checked against it) ----------------

#: Markers around the generated part of docs/troubleshooting.md.
CATALOGUE_BEGIN = "<!-- BEGIN GENERATED: python -m geoboresight.errors --update -->"
CATALOGUE_END = "<!-- END GENERATED -->"


def error_classes() -> list[type]:
    """:class:`GeoboresightError` and every subclass, in definition order."""
    found, todo = [], [GeoboresightError]
    while todo:
        cls = todo.pop(0)
        found.append(cls)
        todo.extend(cls.__subclasses__())
    return found


def message_catalogue(root: str | None = None) -> list[tuple[str, str, str, str]]:
    """Every message a user can meet: ``(module, function, error class, template)`` for each
    construction of a :class:`GeoboresightError` subclass (and each ``self._fail(...)`` of a
    spec parameter) in the package's source, found by parsing it. ``{...}`` in a template is
    the expression the message shows there (a path, a value)."""
    import ast
    import os

    root = root or os.path.dirname(os.path.abspath(__file__))
    names = {c.__name__ for c in error_classes()}
    entries = []
    for folder, dirs, files in os.walk(root):
        dirs[:] = sorted(d for d in dirs if d != "__pycache__")
        for name in sorted(files):
            if not name.endswith(".py"):
                continue
            path = os.path.join(folder, name)
            module = os.path.relpath(path, os.path.dirname(root)).replace(os.sep, "/")
            with open(path, encoding="utf-8") as f:
                tree = ast.parse(f.read())
            for func, call in _calls(tree):
                callee = (
                    call.func.attr
                    if isinstance(call.func, ast.Attribute)
                    else (call.func.id if isinstance(call.func, ast.Name) else "")
                )
                if callee in names and call.args:
                    entries.append((module, func, callee, _template(call.args[0])))
                elif callee == "_fail" and call.args:
                    template = "parameter '{name}': " + _template(call.args[0])
                    entries.append((module, func, "ParameterError", template))
    return entries


def _calls(tree):
    """(enclosing function name, call node) for every call in ``tree``."""
    import ast

    def walk(node, func):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                yield from walk(child, child.name)
            else:
                if isinstance(child, ast.Call):
                    yield func, child
                yield from walk(child, func)

    yield from walk(tree, "<module>")


def _template(node) -> str:
    """The text of a message expression, with ``{...}`` for the parts computed at run time."""
    import ast

    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return node.value
    if isinstance(node, ast.JoinedStr):
        return "".join(
            v.value if isinstance(v, ast.Constant) else "{" + ast.unparse(v.value) + "}"
            for v in node.values
        )
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
        return _template(node.left) + _template(node.right)
    return "{" + ast.unparse(node) + "}"


def catalogue_markdown() -> str:
    """The generated part of docs/troubleshooting.md: every message, by module."""
    lines = [CATALOGUE_BEGIN, ""]
    module = None
    for mod, func, cls, template in message_catalogue():
        if mod != module:
            module = mod
            lines += ["", f"### `{mod}`", ""]
        text = " ".join(template.split())
        fence = "``" if "`" in text else "`"
        pad = " " if "`" in text else ""
        lines.append(f"- **{cls}** ({func}): {fence}{pad}{text}{pad}{fence}")
    lines += ["", CATALOGUE_END]
    return "\n".join(lines[:2] + lines[3:]) + "\n"


def _update(path: str) -> bool:
    """Rewrite the generated part of ``path``; True when it changed."""
    with open(path, encoding="utf-8") as f:
        text = f.read()
    head, _, rest = text.partition(CATALOGUE_BEGIN)
    _, _, tail = rest.partition(CATALOGUE_END)
    new = head + catalogue_markdown().rstrip("\n") + tail
    if new != text:
        with open(path, "w", encoding="utf-8") as f:
            f.write(new)
    return new != text


if __name__ == "__main__":  # pragma: no cover
    import sys

    if sys.argv[1:2] == ["--update"]:
        target = sys.argv[2] if len(sys.argv) > 2 else "docs/troubleshooting.md"
        print(f"{target}: {'updated' if _update(target) else 'up to date'}")
    else:
        sys.stdout.write(catalogue_markdown())
