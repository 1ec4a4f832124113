"""The command reference: one page per group of operations, one section per operation, made
from the list of operations that every face is generated from (the registry of specs, read
through ``geoboresight.algorithms.registry``), the command line's own options (the click
command built from each spec) and the QGIS dialog's field labels (the engine's description).

Loaded by docs/hooks/site.py; tests/test_docs_site.py checks that every operation and every
option of every operation is in it.
"""

from __future__ import annotations

#: The folder of the reference's pages in the site.
FOLDER = "commands"

#: What a parameter of each kind is, in a user's words.
KINDS = {
    "raster": "raster",
    "multiraster": "rasters",
    "file": "file",
    "band": "band number",
    "number": "number",
    "wavelength": "wavelength",
    "enum": "choice",
    "bool": "switch",
    "string": "text",
    "raster_out": "GeoTIFF",
    "vector_out": "GeoPackage or GeoJSON",
    "file_out": "file",
    "folder_out": "folder",
}


def group_id(group: str) -> str:
    from geoboresight.engine import group_id as engine_group_id

    return engine_group_id(group)


def page_of(group: str) -> str:
    """The reference page of a group of operations (``commands/shadow.md``)."""
    return f"{FOLDER}/{group_id(group)}.md"


def value_text(value) -> str:
    """A default as a reader types it: ``922``, ``0.5``, ``on``, ``"band-means"``."""
    if isinstance(value, bool):
        return "on" if value else "off"
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() and abs(value) < 1e15 else f"{value:g}"
    return str(value)


def _cell(text: str) -> str:
    return " ".join(str(text).split()).replace("|", "\\|")


def _code(text: str) -> str:
    return f"`` {text} ``" if "`" in text else f"`{text}`"


def flags(command, name: str) -> list[str]:
    """The command line's spellings of the parameter ``name`` (``-o``, ``--output``;
    ``--gmm/--no-gmm`` for a switch), read from the click command."""
    for option in command.params:
        if option.name == name and not getattr(option, "hidden", False):
            if option.secondary_opts:
                return ["/".join([*option.opts, *option.secondary_opts])]
            return sorted(option.opts, key=lambda o: (o.startswith("--"), o))
    return []


def what(p) -> str:
    """The type column: the kind of value, and for a choice its values."""
    kind = KINDS.get(p.kind, p.kind)
    if p.kind == "number" and getattr(p, "integer", False):
        kind = "whole number"
    if p.kind == "enum":
        kind = "one of " + ", ".join(_code(c) for c in p.choices)
    if p.kind == "band":
        kind = f"band number of `--{p.raster.replace('_', '-')}`"
    extension = getattr(p, "extension", "") or ""
    if p.kind == "file_out" and extension:
        kind = f".{extension} file"
    extensions = getattr(p, "extensions", ()) or ()
    if p.kind == "file" and extensions:
        kind = "file (" + ", ".join(f".{e.lstrip('.')}" for e in extensions) + ")"
    return kind


def span(p) -> str:
    """The range and units column: ``0–1``, ``≥ 3 px``, ``nm``."""
    lo, hi = getattr(p, "minimum", None), getattr(p, "maximum", None)
    unit = getattr(p, "unit", "") or ""
    if lo is not None and hi is not None:
        text = f"{value_text(float(lo))}–{value_text(float(hi))}"
    elif lo is not None:
        text = f"≥ {value_text(float(lo))}"
    elif hi is not None:
        text = f"≤ {value_text(float(hi))}"
    else:
        text = ""
    return f"{text} {unit}".strip()


def default_text(p) -> str:
    if p.required:
        return "required"
    if p.default is None or p.default == "":
        return "none"
    return _code(value_text(p.default))


def _help(text: str) -> list[str]:
    """A spec's help as Markdown: its paragraphs, bullets ("• ...") as a list."""
    out = []
    for para in text.split("\n\n"):
        lines = [line.strip() for line in para.split("\n")]
        bullets = [line for line in lines if line.startswith(("•", "- "))]
        if bullets:
            head = [line for line in lines if not line.startswith(("•", "- "))]
            out += [" ".join(head), ""] if head else []
            out += [f"- {line.lstrip('•- ').strip()}" for line in bullets]
        else:
            out.append(" ".join(lines))
        out.append("")
    return out


def section(alg, command, labels: dict[str, str]) -> list[str]:
    """One operation's section: purpose, options, outputs, results, one example."""
    python = getattr(alg.run, "__name__", "")
    lines = [
        f"## {alg.name}",
        "",
        f"**{alg.display_name}**: {alg.short_help}",
        "",
        f"`geoboresight {alg.name}`, `rio boresight {alg.name}`; in QGIS *Processing Toolbox ▸ "
        f"geoboresight ▸ {alg.group} ▸ {alg.display_name}*"
        + (f"; in Python `gb.{python}(...)`." if python else "."),
        "",
        *_help(alg.help),
    ]
    if alg.positional:
        lines += [
            "The "
            + ", ".join(f"`{n}`" for n in alg.positional)
            + " may also be given as argument(s): "
            + f"`geoboresight {alg.name} {' '.join(n.upper() for n in alg.positional)}`.",
            "",
        ]
    lines += [
        "**Options**",
        "",
        "| command line | QGIS field | type | default | range, units | what it is |",
        "|---|---|---|---|---|---|",
    ]
    for p in alg.inputs:
        lines.append(
            f"| {', '.join(_code(f) for f in flags(command, p.name))} "
            f"| {_cell(labels.get(p.name, p.label))} | {_cell(what(p))} | {default_text(p)} "
            f"| {_cell(span(p))} | {_cell(p.description)} |"
        )
    lines += [
        "",
        "**Outputs**",
        "",
        "| command line | QGIS field | written as | required | what it is |",
        "|---|---|---|---|---|",
    ]
    for p in alg.outputs:
        lines.append(
            f"| {', '.join(_code(f) for f in flags(command, p.name))} "
            f"| {_cell(labels.get(p.name, p.label))} | {_cell(what(p))} "
            f"| {'yes' if p.required else 'no'} | {_cell(p.description)} |"
        )
    lines.append("")
    results = [(r.name, r.description) for r in alg.results]
    if results:
        lines += [
            "**Results printed** (also `--json`, and QGIS outputs a model can chain): "
            + "; ".join(f"`{n}` ({_cell(d)})" for n, d in results)
            + ".",
            "",
        ]
    if alg.example:
        lines += ["**Example**", "", "```bash", alg.example_command(), "```", ""]
    return lines


def pages() -> dict[str, str]:
    """``{path: markdown}``: the index of every operation, then one page per group."""
    from geoboresight.algorithms import GROUPS, registry
    from geoboresight.cli import make_command
    from geoboresight.engine import field_label

    algs = list(registry().values())
    index = [
        "# Command reference",
        "",
        "Every operation, as `geoboresight OPERATION --option value ...` (and `rio boresight "
        "OPERATION ...`), as a tool of the QGIS Processing Toolbox, and as a Python function "
        "of `import geoboresight as gb`. Each option's QGIS field is beside it; a Python "
        "argument has the option's name with `_` for `-` (`--vnir-nm` is `vnir_nm`). The "
        "options every command takes (`--overwrite`, `--json`, `--cog`, ...) are on the "
        "[command line](../cli.md) page. These pages are made from the same list of "
        "operations as the command line and the QGIS tools.",
        "",
    ]
    out = {}
    for group in GROUPS:
        members = [a for a in algs if a.group == group]
        if not members:
            continue
        page = page_of(group)
        name = page.split("/", 1)[1]
        index += [f"## [{group}]({name})", "", "| operation | what it does |", "|---|---|"]
        body = [f"# {group}", ""]
        for alg in members:
            index.append(f"| [`{alg.name}`]({name}#{alg.name}) | {_cell(alg.short_help)} |")
            labels = {p.name: field_label(p) for p in alg.params}
            body += section(alg, make_command(alg), labels)
        index.append("")
        out[page] = "\n".join(body)
    out[f"{FOLDER}/index.md"] = "\n".join(index)
    return out


def nav() -> list:
    """The site's navigation entries of the reference: the index, then one page per group."""
    from geoboresight.algorithms import GROUPS, registry

    used = {a.group for a in registry().values()}
    return [f"{FOLDER}/index.md", *({g: page_of(g)} for g in GROUPS if g in used)]
