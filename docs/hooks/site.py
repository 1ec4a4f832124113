"""MkDocs hooks of the documentation site (mkdocs.yml ``hooks``).

- The pages made from elsewhere: the home page (README.md without its fresh-clone section),
  the changelog (CHANGELOG.md), the command reference (docs/hooks/commands.py: one page per
  group of operations, from the registry of specs), the API reference (one mkdocstrings entry
  per public name of ``geoboresight``, the operations and kernels on one page per area), the
  validation report (validation/REPORT.md, one page per method) and the gallery
  (docs/hooks/gallery.py, run on the sample scene; its outputs are kept in
  ``build/docs-gallery/`` until the library, the scene or the gallery change).
- Links from a page to a file outside docs/ (``../geoboresight/io/dual.py``) point at the
  repository on GitHub, unless the site shows that file as a page (the README, the changelog,
  the validation report); a link to the site's own address reaches its page here. A link to a
  file that does not exist is a warning, which ``mkdocs build --strict`` turns into a failure.
- A public name without a docstring is a warning too.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import importlib.util
import inspect
import io
import logging
import os
import pathlib
import re
import shlex
import shutil
import tempfile
import warnings

log = logging.getLogger("mkdocs.hooks.geoboresight")
ROOT = pathlib.Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
GALLERY_CACHE = ROOT / "build" / "docs-gallery"

#: The API reference's pages: file, title, the table of ``geoboresight`` they list, what it holds.
REFERENCE = (
    (
        "operations",
        "File-level operations",
        "OPERATIONS",
        "One function per operation of the command line and the QGIS toolbox, with the same "
        "parameter names and defaults: each reads a whole flight line block by block and "
        "writes its outputs atomically.",
    ),
    (
        "kernels",
        "Kernels",
        "KERNELS",
        "The science on NumPy arrays: `f(data..., valid=None, *, options)`, where `valid` is "
        "a boolean mask of usable pixels.",
    ),
    (
        "values",
        "Option values",
        "VALUES",
        "The frozen values the operations take, one per group of options that travel together "
        "(flat on the command line and in QGIS): `bands=gb.BandChoice(vnir_nm=922)`.",
    ),
    (
        "io",
        "Reading, writing, progress and errors",
        "IO",
        "The dual-sensor reader, windowed maps over a flight line, the writers' options, "
        "progress, and the errors a script may catch.",
    ),
)


# --------------------------------------------------------------------------- checks
def missing_docstrings() -> list[str]:
    """Public names of ``geoboresight`` (its ``__all__``) without a docstring of their own (a
    dataclass's generated ``Name(field, ...)`` text does not count)."""
    import geoboresight as gb

    missing = []
    for name in gb.__all__:
        obj = getattr(gb, name)
        doc = obj.__dict__.get("__doc__") if inspect.isclass(obj) else obj.__doc__
        if dataclasses.is_dataclass(obj) and doc and doc.startswith(f"{obj.__name__}("):
            doc = None
        if not (doc or "").strip():
            missing.append(name)
    return missing


# --------------------------------------------------------------------------- pages
#: The tables of the API reference split into one page per area of the library (a page of
#: 10,000 words is not read): the area of a name is the first part of its module's name
#: (``geoboresight.operations.shadow_map`` -> ``shadow_map``), gathered as the paper's
#: applications; a module of an area not named here goes to "More".
SPLIT = ("OPERATIONS", "KERNELS")
AREAS = (
    ("sensor", "The instrument and radiance", ("sensor", "radiance")),
    ("ratio", "Boresight ratio and statistics", ("ratio", "stats", "info", "report")),
    ("shadow", "Shadow", ("shadow", "shadow_map", "shadow_truth", "deshadow")),
    ("dem", "Relative DEM and offset", ("dem", "offset")),
    ("anomaly", "Anomaly", ("anomaly", "roc")),
    ("georef", "Georeferencing", ("georef", "georef_auto", "direct_georef", "boresight_calibrate")),
    ("simulate", "Simulation", ("simulate",)),
)


def area_of(module: str) -> tuple[str, str]:
    """``(page, title)`` of the area of ``module`` (:data:`AREAS`)."""
    parts = module.split(".")[1:]
    if parts and parts[0] in ("operations", "algorithms"):
        parts = parts[1:]
    head = parts[0] if parts else ""
    for page, title, heads in AREAS:
        if head in heads:
            return page, title
    return "more", "More"


def reference_pages() -> dict[str, str]:
    """``{path: markdown}`` of the API reference: an index of every public name, then one
    page per table (for :data:`SPLIT`, an index of its areas and one page per area), one
    mkdocstrings entry per name."""
    import geoboresight as gb

    pages = {}
    index = [
        "# API reference",
        "",
        "`import geoboresight as gb` gives one flat API, loaded lazily: every name below is "
        "`gb.NAME` (documented here under the module that defines it). The pages are made "
        "from the numpydoc docstrings; `help(gb.NAME)` shows the same text.",
        "",
    ]
    for page, title, table, about in REFERENCE:
        names = getattr(gb, table)
        index += [f"## [{title}]({page}.md)", "", about, "", "| name | what it does |", "|---|---|"]
        where = {n: _defined_in(table, n, names[n]) for n in names}
        by_area: dict[tuple[str, str], list[str]] = {}
        for name in sorted(names, key=lambda n: (where[n], n)):
            area = area_of(names[name]) if table in SPLIT else ("", "")
            by_area.setdefault(area, []).append(name)
            summary = (inspect.getdoc(getattr(gb, name)) or "").split("\n\n")[0]
            summary = " ".join(summary.split()).replace("|", "\\|")
            index.append(f"| [`gb.{name}`][{where[name]}.{name}] | {summary} |")
        index.append("")
        body = [f"# {title}", "", about, ""]
        if table not in SPLIT:
            body += [f"::: {where[name]}.{name}\n" for name in by_area[("", "")]]
        else:
            order = [a[0] for a in AREAS] + ["more"]
            for area, area_title in sorted(by_area, key=lambda a: order.index(a[0])):
                members = by_area[(area, area_title)]
                body += [
                    f"- [{area_title}]({page}/{area}.md): " + ", ".join(f"`{n}`" for n in members)
                ]
                pages[f"reference/{page}/{area}.md"] = "\n".join(
                    [f"# {title}: {area_title.lower() if area != 'dem' else area_title}", ""]
                    + [f"::: {where[name]}.{name}\n" for name in members]
                )
        pages[f"reference/{page}.md"] = "\n".join(body)
    pages["reference/index.md"] = "\n".join(index)
    return pages


def _defined_in(table: str, name: str, module: str) -> str:
    """The module that defines ``gb.NAME``: an operation's function (its spec, the module
    named in ``OPERATIONS``, wraps it), anything else the module the table names."""
    import geoboresight as gb

    if table != "OPERATIONS":
        return module
    return getattr(gb, name).__wrapped__.__module__


def reference_nav() -> dict[str, list]:
    """``{placeholder page: its section}`` of the site's navigation: each split table's index,
    then its areas' pages."""
    out = {}
    for placeholder in (f"reference/{page}.md" for page, _, t, _ in REFERENCE if t in SPLIT):
        folder = placeholder.removesuffix(".md")
        areas = [p for p in reference_pages() if p.startswith(folder + "/")]
        titles = {page: title for page, title, _ in AREAS}
        order = [a[0] for a in AREAS] + ["more"]
        areas.sort(key=lambda p: order.index(p.rsplit("/", 1)[1][:-3]))
        out[placeholder] = [placeholder] + [
            {titles.get(p.rsplit("/", 1)[1][:-3], "More"): p} for p in areas
        ]
    return out


#: README.md's sections that the site's home page leaves out: what a fresh clone runs, which
#: the install page (for a user) and the developer's guide (for a contributor) say on the site.
HOME_SKIPS = ("Two commands",)


def home_page() -> str:
    """README.md without :data:`HOME_SKIPS`, with its links as seen from docs/ (``docs/x.md``
    -> ``x.md``, anything else one folder up)."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    for title in HOME_SKIPS:
        text = re.sub(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", "", text, flags=re.M | re.S)

    def relink(match):
        label, target = match.group(1), match.group(2)
        if re.match(r"^[a-z]+:|^#", target):
            return match.group(0)
        target = target[len("docs/") :] if target.startswith("docs/") else f"../{target}"
        return f"[{label}]({target})"

    return _LINK.sub(relink, text)


#: The validation report's pages on the site: (page, title, the report's sections that go
#: there, by how their heading begins); the introduction and the protocol make the first.
VALIDATION_REPORT = ROOT / "validation" / "REPORT.md"
REPORT_PAGES = (
    ("validation-report/index.md", "Validation report: protocol", ()),
    ("validation-report/shadow-map.md", "Validation report: shadow map", ("Shadow map",)),
    ("validation-report/deshadow.md", "Validation report: de-shadowing", ("De-shadowing",)),
    (
        "validation-report/dem.md",
        "Validation report: relative DEM and the relief test",
        ("Relative DEM", "The relief test"),
    ),
    ("validation-report/anomaly.md", "Validation report: anomalies", ("Anomaly",)),
)


def _slug(text: str) -> str:
    from pymdownx.slugs import slugify

    return slugify(case="lower")(text, "-")


def validation_report_pages() -> tuple[dict[str, str], dict[str, str]]:
    """validation/REPORT.md as pages of the site, one per method (:data:`REPORT_PAGES`), and
    ``{anchor: page}`` of its headings, so that a link to the report's section reaches the page
    that holds it."""
    text = VALIDATION_REPORT.read_text(encoding="utf-8")
    chunks = re.split(r"^(?=## )", text, flags=re.M)
    bodies = {page: [] for page, _, _ in REPORT_PAGES}
    for chunk in chunks:
        heading = chunk.splitlines()[0][3:] if chunk.startswith("## ") else ""
        page = next(
            (p for p, _, starts in REPORT_PAGES if heading.startswith(tuple(starts) or "\0")),
            REPORT_PAGES[0][0],
        )
        if not chunk.startswith("## "):  # the report's title and introduction
            chunk = chunk.split("\n", 1)[1] if chunk.startswith("# ") else chunk
        bodies[page].append(chunk)
    pages, anchors = {}, {}
    for page, title, _ in REPORT_PAGES:
        body = "".join(bodies[page]).strip("\n")
        pages[page] = f"# {title}\n\n{body}\n"
        for heading in re.findall(r"^#{2,6} (.+)$", body, flags=re.M):
            anchors.setdefault(_slug(heading), page)
    return pages, anchors


#: Files of the repository that are pages of the site: a link to one stays on the site.
SITE_PAGES = {"README.md": "index.md", "CHANGELOG.md": "changelog.md"}


def site_page(rel: str, anchor: str) -> str | None:
    """The site's page (from docs/) for the repository file ``rel`` (``validation/REPORT.md``)
    and its anchor; None when the file is not on the site."""
    if rel == VALIDATION_REPORT.relative_to(ROOT).as_posix():
        _, anchors = validation_report_pages()
        return anchors.get(anchor, REPORT_PAGES[0][0])
    return SITE_PAGES.get(rel)


def changelog_page() -> str:
    return (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")


# --------------------------------------------------------------------------- gallery
def _gallery_module():
    spec = importlib.util.spec_from_file_location("docs_gallery", DOCS / "hooks" / "gallery.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _gallery_key() -> str:
    """A digest of what the gallery's pictures depend on: the library, the scene, the
    gallery's own text."""
    digest = hashlib.sha256()
    for folder, pattern in (
        ("geoboresight", "**/*.py"),
        ("sample_data", "**/*"),
        ("docs/hooks", "gallery.py"),
    ):
        for path in sorted((ROOT / folder).glob(pattern)):
            if path.is_file() and "__pycache__" not in path.parts:
                digest.update(str(path.relative_to(ROOT)).encode())
                digest.update(path.read_bytes())
    return digest.hexdigest()[:16]


def _run_command(command: str) -> None:
    """One ``geoboresight ...`` line, as a shell runs it (in this process)."""
    from geoboresight.cli import main

    words = shlex.split(command)
    assert words[0] == "geoboresight", command
    main.main(args=words[1:], prog_name="geoboresight", standalone_mode=False)


def _commands_module():
    spec = importlib.util.spec_from_file_location("docs_commands", DOCS / "hooks" / "commands.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def run_gallery() -> dict[str, pathlib.Path]:
    """Run every figure's steps in a folder like the repository's top (``sample_data`` beside
    ``out/``); ``{image name: path}`` of the pictures, from the cache when nothing changed."""
    gallery = _gallery_module()
    cache = GALLERY_CACHE / _gallery_key()
    images = {
        pathlib.PurePosixPath(f["image"]).name: cache / pathlib.PurePosixPath(f["image"]).name
        for f in gallery.FIGURES
    }
    if all(p.is_file() for p in images.values()):
        return images
    shutil.rmtree(GALLERY_CACHE, ignore_errors=True)
    from mkdocs.exceptions import PluginError

    with tempfile.TemporaryDirectory(prefix="gb-gallery-") as work:
        work = pathlib.Path(work)
        (work / "sample_data").symlink_to(ROOT / "sample_data")
        (work / "out").mkdir()
        cwd = os.getcwd()
        os.chdir(work)
        try:
            for figure in gallery.FIGURES:
                log.info("gallery: %s", figure["figure"])
                for kind, text in figure["steps"]:
                    sink = io.StringIO()
                    try:
                        with (
                            contextlib.redirect_stdout(sink),
                            contextlib.redirect_stderr(sink),
                            warnings.catch_warnings(),
                        ):
                            # A raw flight line has no geotransform: rasterio says so.
                            warnings.filterwarnings("ignore", message=".*no geotransform")
                            if kind == "sh":
                                _run_command(text)
                            else:
                                exec(compile(text, f"gallery {figure['figure']}", "exec"), {})
                    except Exception as exc:
                        raise PluginError(
                            f"gallery, {figure['figure']}: {type(exc).__name__}: {exc}\n"
                            f"{text}\n{sink.getvalue()[-2000:]}"
                        ) from exc
        finally:
            os.chdir(cwd)
        cache.mkdir(parents=True)
        for figure in gallery.FIGURES:
            shutil.copyfile(
                work / figure["image"], cache / pathlib.PurePosixPath(figure["image"]).name
            )
    return images


def _wrapped(command: str, width: int = 92) -> str:
    """A long command on several lines, broken before options (``\\`` continuations: the
    same command for a shell)."""
    segments = []  # each option with its values
    for word in shlex.split(command):
        if word.startswith("-") or not segments:
            segments.append([])
        segments[-1].append(shlex.quote(word))
    lines = [""]
    for segment in map(" ".join, segments):
        if lines[-1] and len(lines[-1]) + len(segment) + 1 > width - 6:
            lines.append("")
        lines[-1] = f"{lines[-1]} {segment}".strip()
    return " \\\n    ".join(lines)


def gallery_page() -> str:
    gallery = _gallery_module()
    lines = [
        "# Gallery",
        "",
        "The paper's figures (Brook & Ben-Dor 2011) as the bundled sample scene "
        "(`sample_data/`, a simulated AISA-Dual flight line) makes them. Each figure is drawn "
        "by the commands and code shown, run from the repository's top folder after "
        "`mkdir -p out`; the site's build runs exactly this text.",
        "",
    ]
    for figure in gallery.FIGURES:
        name = pathlib.PurePosixPath(figure["image"]).name
        lines += [f"## {figure['figure']}: {figure['title']}", "", figure["caption"], ""]
        for kind, text in figure["steps"]:
            if kind == "sh":
                lines += ["```bash", _wrapped(text), "```", ""]
            else:
                lines += ["```python", text.strip(), "```", ""]
        lines += [f"![{figure['figure']}: {figure['title']}](gallery/{name})", ""]
    return "\n".join(lines)


# --------------------------------------------------------------------------- links
_LINK = re.compile(r"\[([^\]]*)\]\(([^)\s]+)\)")
_FENCE = re.compile(r"(^```.*?^```)", re.M | re.S)


def _outside_link(target: str, page_dir: pathlib.Path, repo_url: str, where: str) -> str | None:
    """The repository URL for a relative link that leaves docs/ (the site's page for a file
    the site shows: the README, the changelog, the validation report), None for one that
    stays."""
    path, _, anchor = target.partition("#")
    if not path or re.match(r"^[a-z]+:", path):
        return None
    resolved = (page_dir / path).resolve()
    if resolved.is_relative_to(DOCS) and resolved != DOCS:
        return None
    if not resolved.is_relative_to(ROOT) or not resolved.exists():
        log.warning("%s: link to %s, which does not exist", where, target)
        return None
    kind = "tree" if resolved.is_dir() else "blob"
    rel = resolved.relative_to(ROOT).as_posix()
    page = site_page(rel, anchor)
    if page is not None:  # a file the site shows as a page: the page
        target = os.path.relpath(DOCS / page, page_dir).replace(os.sep, "/")
        return target + (f"#{anchor}" if anchor else "")
    return f"{repo_url.rstrip('/')}/{kind}/main/{rel}" + (f"#{anchor}" if anchor else "")


def rewrite_links(
    markdown: str, src_uri: str, repo_url: str, site_url: str = "", pages: frozenset = frozenset()
) -> str:
    """``markdown`` with its links to files outside docs/ made repository URLs, and its links
    to the site's own address (``site_url``) of one of its ``pages`` (e.g. a page made by a
    hook, which GitHub cannot show) made relative, as MkDocs checks them (fenced code left as
    it is)."""
    page_dir = (DOCS / src_uri).parent
    home = site_url.rstrip("/") + "/"

    def relink(match):
        target = match.group(2)
        if site_url and target.startswith(home):
            path, _, anchor = target[len(home) :].partition("#")
            path = path.strip("/")
            for page in (f"{path}.md", f"{path}/index.md") if path else ("index.md",):
                if page in pages:
                    rel = os.path.relpath(DOCS / page, page_dir).replace(os.sep, "/")
                    return f"[{match.group(1)}]({rel}{'#' + anchor if anchor else ''})"
            return match.group(0)
        url = _outside_link(target, page_dir, repo_url, src_uri)
        return match.group(0) if url is None else f"[{match.group(1)}]({url})"

    parts = _FENCE.split(markdown)
    return "".join(p if p.startswith("```") else _LINK.sub(relink, p) for p in parts)


# --------------------------------------------------------------------------- MkDocs events
def expand_nav(nav: list, entries: list, placeholder: str) -> list:
    """``nav`` with the entry whose page is ``placeholder`` made a section of ``entries``
    (the command reference: one page per group of operations, whatever groups exist)."""
    out = []
    for item in nav:
        if isinstance(item, dict):
            (title, value), *_ = item.items()
            if value == placeholder:
                out.append({title: entries})
            elif isinstance(value, list):
                out.append({title: expand_nav(value, entries, placeholder)})
            else:
                out.append(item)
        else:
            out.append(item)
    return out


def on_config(config):
    commands = _commands_module()
    config["nav"] = expand_nav(config["nav"], commands.nav(), f"{commands.FOLDER}/index.md")
    for placeholder, entries in reference_nav().items():
        config["nav"] = expand_nav(config["nav"], entries, placeholder)
    return config


def on_files(files, config):
    from mkdocs.structure.files import File

    missing = missing_docstrings()
    if missing:
        log.warning("public names without a docstring: %s", ", ".join(missing))
    generated = {
        "index.md": home_page(),
        "changelog.md": changelog_page(),
        "gallery.md": gallery_page(),
        **reference_pages(),
        **_commands_module().pages(),
        **validation_report_pages()[0],
    }
    for uri, text in generated.items():
        files.append(File.generated(config, uri, content=text))
    for name, path in run_gallery().items():
        files.append(File.generated(config, f"gallery/{name}", abs_src_path=str(path)))
    return files


def on_page_markdown(markdown, page, config, files):
    pages = frozenset(f.src_uri for f in files.documentation_pages())
    return rewrite_links(
        markdown, page.file.src_uri, config["repo_url"], config["site_url"] or "", pages
    )
