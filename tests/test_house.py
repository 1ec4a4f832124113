"""The house rules (docs/DEVELOPING.md, "Layers, one direction"), checked over the whole package so they cannot drift:
one public API, specs that are declarations of file-level operations, one name per concept,
kernels free of files, no pyplot."""

from __future__ import annotations

import ast
import inspect
import pathlib
import subprocess
import sys

import pytest

import geoboresight as gb
from geoboresight.algorithms import registry
from geoboresight.algorithms.spec import Algorithm

PKG = pathlib.Path(gb.__file__).parent
SPEC_MODULES = sorted(
    p for p in (PKG / "algorithms").glob("*.py") if p.name not in ("spec.py", "__init__.py")
)
KERNEL_FILES = sorted(
    [PKG / "ratio.py", PKG / "stats.py"]
    + [
        p
        for d in ("shadow", "dem", "anomaly", "simulate", "georef")
        for p in (PKG / d).glob("*.py")
    ]
)

#: Parameters that name one concept in every operation: same kind, default, range and unit.
SHARED = (
    "vnir",
    "swir",
    "seam_nm",
    "vnir_wavelengths",
    "swir_wavelengths",
    "band_mode",
    "vnir_nm",
    "swir_nm",
    "vnir_to_nm",
    "swir_to_nm",
    "tolerance_nm",
    "block_rows",
    "seed",
    "cloud_mask",
    "flying_height",
    "ifov_mrad",
    "squint_deg",
    "sun_zenith",
    "sun_azimuth",
    "include_nm",
    "exclude_nm",
)
#: Where one operation legitimately departs from a shared parameter's default or range, and why.
EXCEPTIONS = {
    # Dense matching averages band ranges (900–970 against 980–1,100 nm): the single 1,010 nm
    # band is too weak to match (docs/dem.md); offset and co-registration use the ratio's bands.
    **{
        (op, name): "band means for dense matching"
        for op in ("disparity", "relative-dem")
        for name in ("vnir_nm", "swir_nm", "vnir_to_nm", "swir_to_nm")
    },
    # The simulator's geometry has physical limits the analysis does not share: its sun stays
    # above 5° elevation, its squint is signed (either optic may lead), its flight is airborne.
    ("simulate", "sun_zenith"): "simulated sun above 5° elevation",
    ("simulate", "squint_deg"): "signed squint of the simulated bench",
    ("simulate", "flying_height"): "airborne altitudes only",
    # Per-pixel spectral work reads every band of a strip: 16 lines keep its buffers small.
    **{(op, "block_rows"): "strips of all bands" for op in ("rx", "svdd", "unmix")},
}
#: Spellings retired for one name per concept (kept only as hidden aliases).
RETIRED = {
    "numerator_nm",
    "denominator_nm",
    "image",
    "wavelengths",
    "boresight_vnir",
    "boresight_swir",
    "block_lines",
}


def _ops():
    return list(registry().values())


def test_every_spec_runs_its_file_level_operation_exported_at_the_top():
    for alg in _ops():
        fn = alg.run
        assert fn.__name__ == alg.name.replace("-", "_") + "_file", alg.name
        assert getattr(gb, fn.__name__) is alg.operation, fn.__name__
        assert alg.operation.__wrapped__ is fn and alg.operation.spec is alg
        assert fn.__module__.startswith(("geoboresight.operations.", "geoboresight.report.")), fn
        assert fn.__doc__ and "References" in fn.__doc__ and "Parameters" in fn.__doc__, fn


def test_a_spec_whose_operation_disagrees_is_refused_at_import():
    from geoboresight.algorithms._common import BANDS, DUAL_PARAMS
    from geoboresight.algorithms.spec import Group

    alg = registry()["ratio"]
    rest = tuple(p for p in alg.params if p.name in ("output", "block_rows"))
    kw = dict(name="x", display_name="x", group=alg.group, short_help="", help="", run=alg.run)
    with pytest.raises(TypeError, match="block_rows"):
        Algorithm(params=(*DUAL_PARAMS, BANDS, alg.param("output")), **kw)
    # A group whose member default differs from its value's default is refused too.
    other = tuple(
        type(p)(**{**p.__dict__, "default": 900.0}) if p.name == "vnir_nm" else p
        for p in BANDS.params
    )
    with pytest.raises(TypeError, match="vnir_nm"):
        Algorithm(
            params=(*DUAL_PARAMS, Group(name="bands", value=BANDS.value, params=other), *rest), **kw
        )


def test_one_name_per_concept_and_one_default_per_shared_parameter():
    seen: dict[str, tuple] = {}
    kinds: dict[str, tuple] = {}
    for alg in _ops():
        for p in alg.params:
            assert p.name not in RETIRED, f"{alg.name}: retired name {p.name}"
            if p.name not in SHARED:
                continue
            key = (
                p.kind,
                getattr(p, "unit", None),
                p.default,
                getattr(p, "minimum", None),
                getattr(p, "maximum", None),
            )
            # Kind and unit agree everywhere; default and range too, but for the exceptions.
            first_alg, first = kinds.setdefault(p.name, (alg.name, key[:2]))
            assert key[:2] == first, f"{p.name}: {first_alg} {first} vs {alg.name} {key[:2]}"
            if (alg.name, p.name) not in EXCEPTIONS:
                first_alg, first = seen.setdefault(p.name, (alg.name, key))
                assert key == first, f"{p.name}: {first_alg} {first} vs {alg.name} {key}"


def _meaning(description: str) -> str:
    """A parameter's meaning: its description up to the first bracket, colon or semicolon
    (what follows says how this operation uses it, or its default)."""
    import re

    return re.split(r" \(|: |; |, if ", description, maxsplit=1)[0].strip()


def test_one_meaning_per_name():
    """A shared name means one thing in every operation: the same meaning, and for the
    parameter objects that define it, the same text."""
    meanings: dict[str, tuple[str, str]] = {}
    for alg in _ops():
        for p in alg.params:
            if p.name not in SHARED:
                continue
            first = meanings.setdefault(p.name, (alg.name, _meaning(p.description)))
            assert _meaning(p.description) == first[1], (
                f"{p.name}: '{first[1]}' in {first[0]} but '{_meaning(p.description)}' in "
                f"{alg.name}"
            )
    # A description states no value of its own: defaults differ between operations (the DEM
    # matches 980 nm where the ratio takes 1010 nm), and "the ratio's 1010 nm" beside a
    # default of 980 nm once misled users.
    import re

    for alg in _ops():
        for p in alg.params:
            if p.name in ("vnir_nm", "swir_nm"):
                assert not re.search(r"\d", p.description), (alg.name, p.name, p.description)


def test_specs_are_declarations_no_loops_and_short():
    for path in SPEC_MODULES:
        tree = ast.parse(path.read_text())
        loops = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.For | ast.While)]
        assert not loops, f"{path.name}: loops at lines {loops}"
        assert len(path.read_text().splitlines()) <= 450, path.name


def _imports(tree):
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            yield from (a.name for a in n.names)
        elif isinstance(n, ast.ImportFrom):
            yield ("." * n.level) + (n.module or "")


def _module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(PKG.parent).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _import_graph() -> dict[str, set[str]]:
    """Package module -> the package modules it imports (at the top or inside a function)."""
    paths = {_module_name(p): p for p in PKG.rglob("*.py")}
    graph = {}
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
        deps = set()
        for n in ast.walk(ast.parse(path.read_text())):
            if isinstance(n, ast.ImportFrom):
                if n.level:
                    base = package.split(".")[: len(package.split(".")) - (n.level - 1)]
                    target = ".".join(base + ([n.module] if n.module else []))
                else:
                    target = n.module
                # "from . import presets" depends on the submodule, not on the package.
                subs = [f"{target}.{a.name}" for a in n.names if f"{target}.{a.name}" in paths]
                deps.update(subs if len(subs) == len(n.names) else [target, *subs])
            elif isinstance(n, ast.Import):
                deps.update(a.name for a in n.names)
        graph[name] = {d for d in deps if d in paths and d != name}
    return graph


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` (a list of modules, the first repeated last), or None."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(v):
        state[v] = 1
        path.append(v)
        for w in sorted(graph[v]):
            if state.get(w) == 1:
                return path[path.index(w) :] + [w]
            if w not in state and (found := visit(w)):
                return found
        path.pop()
        state[v] = 2
        return None

    for v in sorted(graph):
        if v not in state and (found := visit(v)):
            return found
    return None


def test_the_cycle_finder_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def test_no_import_cycle_in_the_package():
    """Every module import, even one deferred into a function, points one way: io/cube.py and
    io/raster.py both read ENVI headers through io/envi.py instead of through each other."""
    graph = _import_graph()
    assert "geoboresight.io.envi" in graph["geoboresight.io.raster"]
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_bottom_layer_imports_nothing_above_it():
    """Kernels and the figure module sit below the I/O layer: no import of io, the file-level
    operations, the specs or a face (figures render; io.write.save_figure writes the PNG)."""
    above = ("geoboresight.io", "geoboresight.operations", "geoboresight.algorithms")
    faces = {"geoboresight.cli", "geoboresight.rio", "geoboresight.batch", "geoboresight.engine"}
    graph = _import_graph()
    for path in [*KERNEL_FILES, PKG / "figures.py"]:
        deps = graph[_module_name(path)]
        up = {d for d in deps if d.startswith(above) or d in faces}
        assert not up, f"{path.name} imports {sorted(up)}"


#: The floors of the house, from the top: a module imports only from its own floor or below.
FLOORS = (
    (
        "geoboresight.cli",
        "geoboresight.rio",
        "geoboresight.batch",
        "geoboresight.engine",
        "geoboresight.demo",
        "geoboresight._stub",
    ),
    ("geoboresight.algorithms",),
    ("geoboresight.report",),
    ("geoboresight.operations",),
    ("geoboresight.io",),
    (
        "geoboresight.shadow",
        "geoboresight.anomaly",
        "geoboresight.dem",
        "geoboresight.georef",
        "geoboresight.simulate",
        "geoboresight.stats",
        "geoboresight.ratio",
        "geoboresight.html",
    ),
    ("geoboresight.sensor",),
    (
        "geoboresight.errors",
        "geoboresight.progress",
        "geoboresight._version",
        "geoboresight._threads",
        "geoboresight.figures",
    ),
)
#: The kernel packages (arrays in, arrays out), which io never imports.
KERNEL_PACKAGES = FLOORS[5]


def _floor(module: str) -> int | None:
    for i, floor in enumerate(FLOORS):
        if any(module == m or module.startswith(m + ".") for m in floor):
            return i
    return None


def test_every_module_stands_on_a_floor_and_no_arrow_runs_back_up():
    """Every import, even one deferred into a function, points to the module's own floor or
    one below it (docs/DEVELOPING.md, "Layers, one direction")."""
    graph = _import_graph()
    up = []
    for module, deps in graph.items():
        if module == "geoboresight":  # the lazy API: imports nothing at its top
            continue
        assert _floor(module) is not None, f"{module} stands on no floor of FLOORS"
        up += [
            f"{module} -> {d}" for d in deps if d != "geoboresight" and _floor(d) < _floor(module)
        ]
    assert not up, "\n".join(up)


def test_the_shadow_maps_kernels_stand_in_three_rooms_one_way():
    """The shadow map's kernels: the spectral steps (shadow/darkness.py) below the surface
    prior (shadow/prior.py: the DSM's cast, its refinement, registration and agreement) below
    the block kernels that run both (shadow/blocks.py); none imports one above it, and every
    step of the surface prior is in its one module."""
    graph = _import_graph()
    darkness, prior, blocks = (f"geoboresight.shadow.{m}" for m in ("darkness", "prior", "blocks"))
    assert not {prior, blocks} & graph[darkness], graph[darkness]
    assert blocks not in graph[prior] and {darkness, prior} <= graph[blocks]
    from geoboresight.shadow import blocks as b
    from geoboresight.shadow import darkness as d
    from geoboresight.shadow import prior as p

    for name in ("surface_prior", "dsm_shadow_fraction", "prior_registration", "prior_agreement"):
        assert getattr(p, name).__module__ == prior, name
        assert not hasattr(d, name), name
    for name in ("shadow_map_block", "shadow_fraction_block", "prior_map_block", "register_prior"):
        assert getattr(b, name).__module__ == blocks, name


def test_the_shadow_kernels_share_only_public_names_imported_at_the_top():
    """A shadow kernel module uses another module's public names only, imported at its top:
    a private name (``_x``) never crosses a module's border, and no module of the package is
    imported inside a function (a lazy import of a heavy library stays allowed)."""
    crossing, deferred = [], []
    for path in sorted((PKG / "shadow").glob("*.py")):
        tree = ast.parse(path.read_text())
        modules = set()  # names bound to package modules ("from . import darkness")
        for node in ast.walk(tree):
            if not isinstance(node, ast.ImportFrom) or not (
                node.level or "geoboresight" in (node.module or "")
            ):
                continue
            if node not in tree.body:
                deferred.append(f"{path.name}:{node.lineno}")
            for alias in node.names:
                if alias.name.startswith("_") and not alias.name.startswith("__"):
                    crossing.append(f"{path.name}:{node.lineno} imports {alias.name}")
                if node.module is None:
                    modules.add(alias.asname or alias.name)
        for node in ast.walk(tree):
            if (
                isinstance(node, ast.Attribute)
                and isinstance(node.value, ast.Name)
                and node.value.id in modules
                and node.attr.startswith("_")
                and not node.attr.startswith("__")
            ):
                crossing.append(f"{path.name}:{node.lineno} uses {node.value.id}.{node.attr}")
    assert not crossing, "\n".join(crossing)
    assert not deferred, "package modules imported inside a function: " + ", ".join(deferred)


def test_io_imports_no_kernel_package():
    graph = _import_graph()
    for module, deps in graph.items():
        if module.startswith("geoboresight.io"):
            kernels = sorted(d for d in deps if d.startswith(KERNEL_PACKAGES))
            assert not kernels, f"{module} imports {kernels}"


def test_operations_import_no_other_operation():
    """An operation module imports io, the instrument and kernels; what operations share lives
    there or in a private helper module of operations (``_x.py``), never in another
    operation's module."""
    graph = _import_graph()
    for module, deps in graph.items():
        if not module.startswith("geoboresight.operations."):
            continue
        others = sorted(
            d
            for d in deps
            if d.startswith("geoboresight.operations.") and not d.rsplit(".", 1)[1].startswith("_")
        )
        assert not others, f"{module} imports {others}"


def test_no_file_level_operation_takes_more_than_15_parameters():
    """Values group the rest (``bands=BandChoice(...)``), ``progress`` and ``overwrite``
    counted."""
    for alg in _ops():
        params = inspect.signature(alg.operation).parameters
        assert len(params) <= 15, f"{alg.run.__name__} takes {len(params)} parameters"


def test_io_modules_use_no_private_part_of_a_cube():
    for path in (PKG / "io").glob("*.py"):
        if path.name == "cube.py":
            continue
        tree = ast.parse(path.read_text())
        private = [
            n.lineno for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr == "_parts"
        ]
        assert not private, f"{path.name}: Cube._parts at lines {private}"


def test_kernels_do_not_touch_files():
    for path in KERNEL_FILES:
        tree = ast.parse(path.read_text())
        mods = set(_imports(tree))
        assert not {m for m in mods if m.startswith("rasterio")}, path
        assert not {m for m in mods if m.endswith(".io") or ".io." in m}, path
        calls = [
            n.lineno
            for n in ast.walk(tree)
            if isinstance(n, ast.Call) and isinstance(n.func, ast.Name) and n.func.id == "open"
        ]
        assert not calls, f"{path}: open() at lines {calls}"


def test_no_pyplot_and_no_backend_switch():
    for path in PKG.rglob("*.py"):
        tree = ast.parse(path.read_text())
        assert not [m for m in _imports(tree) if "pyplot" in m], path
        assert not any(
            isinstance(n, ast.ImportFrom) and any(a.name == "pyplot" for a in n.names)
            for n in ast.walk(tree)
        ), path
        uses = [
            n.lineno
            for n in ast.walk(tree)
            if isinstance(n, ast.Call)
            and isinstance(n.func, ast.Attribute)
            and n.func.attr == "use"
            and isinstance(n.func.value, ast.Name)
            and n.func.value.id in ("matplotlib", "mpl")
        ]
        assert not uses, f"{path}: matplotlib.use at lines {uses}"


def test_import_is_lazy_and_the_api_resolves():
    code = (
        "import sys, geoboresight as gb; "
        "heavy = [m for m in ('rasterio', 'numpy', 'sklearn', 'matplotlib') if m in sys.modules]; "
        "print(','.join(heavy)); "
        "missing = [n for n in gb.__all__ if getattr(gb, n, None) is None]; print(missing)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    heavy, missing = out.stdout.splitlines()
    assert heavy == ""
    assert missing == "[]"
    assert set(gb.__all__) <= set(dir(gb))


def test_the_stub_declares_exactly_the_lazy_api():
    """geoboresight/__init__.pyi (what type checkers and IDEs read) names every entry of
    ``__all__``, each imported under its own name from the module the lazy table gives."""
    from geoboresight import _stub

    text = (PKG / "__init__.pyi").read_text()
    assert text == _stub.render(text), "run python -m geoboresight._stub --update"
    stub = ast.parse(text)
    declared = {}
    annotated = set()
    for node in stub.body:
        if isinstance(node, ast.ImportFrom):
            assert node.level == 1, ast.unparse(node)
            for alias in node.names:
                assert alias.asname == alias.name, f"{alias.name}: re-export as itself"
                assert alias.name not in declared, f"{alias.name} declared twice"
                declared[alias.name] = f"geoboresight.{node.module}"
        elif isinstance(node, ast.AnnAssign):
            annotated.add(node.target.id)
    assert sorted(declared) == gb.__all__
    assert declared == {n: gb._API[n] for n in gb.__all__}
    assert {"__version__", "__all__", "KERNELS", "OPERATIONS", "VALUES", "IO"} <= annotated


def _value_classes(fn) -> set[type]:
    """The package's classes an operation's signature names: its defaults' types, the
    classes of its annotations (``DarkLevels | None``) and its spec's parameter groups."""
    import typing

    found = set()
    hints = typing.get_type_hints(inspect.unwrap(fn))
    for p in inspect.signature(fn).parameters.values():
        if p.default is not inspect.Parameter.empty and p.default is not None:
            found.add(type(p.default))
        stack = [hints.get(p.name)]
        while stack:
            hint = stack.pop()
            if isinstance(hint, type):
                found.add(hint)
            stack.extend(typing.get_args(hint))
    found.update(g.value for g in fn.spec.groups)
    return {c for c in found if c.__module__.startswith("geoboresight.") and c is not gb.Progress}


def test_every_value_an_operation_takes_is_at_the_top_and_in_the_stub():
    """A script builds every argument of an operation from ``geoboresight`` alone (``import
    geoboresight as gb; gb.shadow_map_file(..., surface=gb.SurfaceModel(dsm=...))``), and an
    IDE sees where each class comes from."""
    stub = (PKG / "__init__.pyi").read_text()
    seen = set()
    for alg in _ops():
        for cls in _value_classes(alg.operation):
            name = cls.__name__
            assert getattr(gb, name, None) is cls, f"{alg.name}: {name} is not gb.{name}"
            assert name in gb.VALUES, f"{alg.name}: {name} is not in geoboresight.VALUES"
            assert f" import {name} as {name}\n" in stub, f"{name} is not in the stub"
            seen.add(name)
    assert {"SurfaceModel", "Detection", "MapCalibration", "DarkLevels", "Detectability"} <= seen
    assert sorted(seen) == sorted(gb.VALUES), "VALUES holds a class no operation takes"


def test_the_stub_ships_in_the_wheel():
    import tomllib

    config = tomllib.loads((PKG.parent / "pyproject.toml").read_text())
    data = config["tool"]["setuptools"]["package-data"]["geoboresight"]
    assert "__init__.pyi" in data and "py.typed" in data
    assert (PKG / "py.typed").is_file()


def test_kernels_share_one_calling_convention():
    """f(data..., valid=None, *, options): where a public kernel takes a validity mask, it is
    the first parameter with a default, and every later parameter is keyword-only."""
    for name in gb.KERNELS:
        fn = getattr(gb, name)
        params = list(inspect.signature(fn).parameters.values())
        names = [p.name for p in params]
        if "valid" not in names:
            continue
        i = names.index("valid")
        assert params[i].default is None, name
        assert all(p.default is inspect.Parameter.empty for p in params[:i]), name
        assert all(p.kind is inspect.Parameter.KEYWORD_ONLY for p in params[i + 1 :]), name


def test_the_registry_names_every_spec_module_and_its_operations():
    # algorithms.SPECS lets one command import its own spec module only: it must name every
    # spec module of the package and exactly the operations each declares.
    import importlib
    import pkgutil

    import geoboresight.algorithms as algorithms

    real = {}
    for info in pkgutil.iter_modules(algorithms.__path__):
        if info.name == "spec" or info.name.startswith("_"):
            continue
        module = importlib.import_module(f"geoboresight.algorithms.{info.name}")
        real[info.name] = tuple(a.name for a in module.ALGORITHMS)
    assert algorithms.SPECS == real
    assert all(algorithms.get(n).name == n for names in real.values() for n in names)
    # The top-level names: every spec's operation, and nothing else.
    runs = {
        a.run.__name__: f"geoboresight.algorithms.{m}"
        for m, ns in real.items()
        for a in importlib.import_module(f"geoboresight.algorithms.{m}").ALGORITHMS
    }
    assert gb.OPERATIONS == runs


def test_one_command_imports_its_own_module_only():
    # Start-up: `geoboresight ratio` must not import the other operations' science stacks.
    import subprocess
    import sys

    code = (
        "import sys; from geoboresight.cli import main\n"
        "cmd = main.get_command(None, 'ratio'); assert cmd is not None\n"
        "print(','.join(m for m in ('scipy', 'sklearn', 'matplotlib', 'pykrige', "
        "'geoboresight.operations.anomaly', 'geoboresight.algorithms.dem') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_functions_are_short():
    """A function reads at once: none over 150 lines in the file-level operations, none over
    200 anywhere in the package (docstring included)."""
    long = []
    for path in PKG.rglob("*.py"):
        limit = 150 if path.parent.name == "operations" else 200
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                lines = node.end_lineno - node.lineno + 1
                if lines > limit:
                    long.append(f"{path.relative_to(PKG)}:{node.lineno} {node.name}: {lines}")
    assert not long, "\n".join(long)
