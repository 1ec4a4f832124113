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
    parameters the message names (Python names), for the faces to word (:func:`worded`).

    Examples
    --------
    >>> import geoboresight as gb
    >>> try:
    ...     gb.ratio_file("no/such.hdr", output="out/ratio.tif")
    ... except gb.GeoboresightError as exc:
    ...     print(type(exc).__name__, exc)
    InputError merged cube no/such.hdr does not exist: check the path
    """

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


#: The tasks a user meets messages in, in the order a newcomer meets them: (page, title,
#: the modules whose messages belong to it). A module is matched by its path under the package
#: (``io/products/``: a folder; ``io/raster.py:parse_creation``: one function); the most
#: specific match wins, and a module no task names goes to :data:`FALLBACK`.
TASKS = (
    (
        "reading",
        "Reading an image or a sensor product",
        ("io/", "stats.py", "operations/stats.py", "io/checks.py:no_valid_error"),
    ),
    (
        "radiance",
        "Radiance and the instrument's calibration",
        ("sensor/calibration.py", "io/calibration.py", "io/radiance.py", "operations/radiance.py"),
    ),
    (
        "options",
        "Giving an operation its options",
        (
            "algorithms/",
            "operations/_guard.py",
            "progress.py",
            "io/raster.py:parse_creation",
            "operations/stats.py:parse_",
            "io/raster.py:check_creation",
            "io/raster.py:writer_options",
            "stats.py:parse_",
        ),
    ),
    (
        "writing",
        "Writing outputs",
        (
            "io/write.py",
            "io/vector.py",
            "io/scene.py",
            "io/orthoscene.py",
            "io/raster.py:verify_written",
        ),
    ),
    (
        "shadow",
        "Shadow maps, classes and de-shadowing",
        (
            "shadow/",
            "operations/shadow",
            "operations/_shadow",
            "operations/deshadow.py",
            "operations/_surface.py",
            "operations/_dark.py",
            "io/checks.py",
        ),
    ),
    (
        "dem",
        "The boresight offset and the relative DEM",
        ("dem/", "sensor/", "operations/dem.py", "operations/offset.py", "operations/_offset.py"),
    ),
    (
        "anomaly",
        "Anomalies, unmixing and ROC curves",
        ("anomaly/", "operations/anomaly.py", "io/anomaly.py", "io/spectra.py"),
    ),
    (
        "georef",
        "Georeferencing",
        (
            "georef/",
            "io/georef.py",
            "io/navigation.py",
            "operations/georef",
            "operations/_glt.py",
            "operations/_gcps.py",
            "operations/_geometry.py",
            "operations/direct_georef.py",
            "operations/boresight_calibrate.py",
            "io/sample.py",
        ),
    ),
    ("simulate", "Simulating a scene", ("simulate/", "operations/simulate.py")),
    ("qgis", "QGIS, the engine and batch runs", ("engine.py", "batch.py", "report/")),
)

#: The task of a message whose module no task names.
FALLBACK = "options"

#: Where the pages of messages are written, beside the troubleshooting page.
CATALOGUE_FOLDER = "messages"


def message_task(module: str, func: str) -> str:
    """The task (a page of :data:`TASKS`) of a message raised in ``func`` of ``module``
    (``geoboresight/io/dual.py``)."""
    where = module.split("/", 1)[1] if "/" in module else module
    best, length = FALLBACK, -1
    for page, _title, prefixes in TASKS:
        for prefix in prefixes:
            path, _, name = prefix.partition(":")
            matched = where == path or (path.endswith("/") and where.startswith(path))
            matched = matched or (not path.endswith((".py", "/")) and where.startswith(path))
            if matched and (not name or func.startswith(name)):
                score = len(path) + (1000 if name else 0)
                if score > length:
                    best, length = page, score
    return best


def _entry(cls: str, func: str, module: str, template: str) -> str:
    text = " ".join(template.split())
    fence = "``" if "`" in text else "`"
    pad = " " if "`" in text else ""
    return f"- **{cls}**: {fence}{pad}{text}{pad}{fence} ({func}, `{module}`)"


def catalogue_pages() -> dict[str, str]:
    """The pages of messages, ``{"messages/<task>.md": markdown}``: every message of the code,
    one page per task (:data:`TASKS`), in the order of the source."""
    by_task: dict[str, list[str]] = {page: [] for page, _, _ in TASKS}
    for mod, func, cls, template in message_catalogue():
        by_task[message_task(mod, func)].append(_entry(cls, func, mod, template))
    pages = {}
    for page, title, _ in TASKS:
        lines = [
            f"# {title}: every message",
            "",
            "Generated from the source by `python -m geoboresight.errors --update "
            "docs/troubleshooting.md`; what each kind of error means and what to do is on the "
            "[troubleshooting page](../troubleshooting.md). `{...}` marks what the message "
            "fills in (a path, a value); the function and module that raise it follow.",
            "",
            *by_task[page],
            "",
        ]
        pages[f"{CATALOGUE_FOLDER}/{page}.md"] = "\n".join(lines)
    return pages


def catalogue_markdown() -> str:
    """The generated part of docs/troubleshooting.md: the pages of messages, by task, with
    how many each holds."""
    counts = {page: 0 for page, _, _ in TASKS}
    for mod, func, _cls, _template in message_catalogue():
        counts[message_task(mod, func)] += 1
    lines = [CATALOGUE_BEGIN, ""]
    for page, title, _ in TASKS:
        lines.append(f"- [{title}]({CATALOGUE_FOLDER}/{page}.md): {counts[page]} messages")
    lines += ["", CATALOGUE_END]
    return "\n".join(lines) + "\n"


def _update(path: str) -> bool:
    """Rewrite the generated part of ``path`` and the pages of messages beside it; True when
    anything changed."""
    import os

    with open(path, encoding="utf-8") as f:
        text = f.read()
    head, _, rest = text.partition(CATALOGUE_BEGIN)
    _, _, tail = rest.partition(CATALOGUE_END)
    new = head + catalogue_markdown().rstrip("\n") + tail
    changed = new != text
    if changed:
        with open(path, "w", encoding="utf-8") as f:
            f.write(new)
    folder = os.path.join(os.path.dirname(os.path.abspath(path)), CATALOGUE_FOLDER)
    os.makedirs(folder, exist_ok=True)
    pages = catalogue_pages()
    for name in sorted(os.listdir(folder)):  # a task that no longer exists
        if name.endswith(".md") and f"{CATALOGUE_FOLDER}/{name}" not in pages:
            os.remove(os.path.join(folder, name))
            changed = True
    for name, page in pages.items():
        target = os.path.join(os.path.dirname(folder), name)
        old = open(target, encoding="utf-8").read() if os.path.exists(target) else None
        if old != page:
            with open(target, "w", encoding="utf-8") as f:
                f.write(page)
            changed = True
    return changed


if __name__ == "__main__":  # pragma: no cover
    import sys

    if sys.argv[1:2] == ["--update"]:
        target = sys.argv[2] if len(sys.argv) > 2 else "docs/troubleshooting.md"
        print(f"{target}: {'updated' if _update(target) else 'up to date'}")
    else:
        sys.stdout.write(catalogue_markdown())
