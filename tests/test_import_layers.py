"""The layers of setup.cfg's import-linter contracts, measured independently of import-linter:
every module's imports are read with `ast`, those inside functions and under TYPE_CHECKING
included, with `importlib.import_module("...")` and `__import__("...")` of a literal name, and,
in a file that imports a name it computes, every project module its strings name (`"pkg.module"`,
`"pkg.module:attribute"`: the tables the command line and the database import from by name);
relative imports are resolved. No module may import a layer above its own or a sibling package
of its layer (so no pipeline imports another); the packages then have no cycle, no two modules
import each other even through others (an import for type checking or inside a function is a
loop too), the package root imports nothing of the project, and the Blender add-on imports none
of it. setup.cfg's layers are checked against DESIGN.md's order, so the contract itself cannot
drift from the design."""

from __future__ import annotations

import ast
import configparser
import functools
import re
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

# DESIGN.md's layers, the top first: cli -> app -> the pipelines -> semantic_map, articulation ->
# geometry, evaluation -> core. setup.cfg may split a layer or add one between two (the model
# folder, the formats), never put a package above one DESIGN.md puts over it.
DESIGN_LAYERS = [
    ["homemodel.cli"],
    ["homemodel.app"],
    ["modeller", "turntable", "photogrammetry", "shape_completion", "tracking"],
    ["semantic_map", "articulation"],
    ["homemodel.geometry", "homemodel.evaluation"],
    ["homemodel.core"],
]
# A string that may name a module for a later import: dotted (`pkg.module`) or `module:attribute`.
_MODULE_NAME = re.compile(r"[A-Za-z_]\w*(?:(?:\.[A-Za-z_]\w*)+(?::[\w.]+)?|:[\w.]+)")
# The modules that import a module whose name they compute (from a table of names, which the
# string rule above reads): a new one must be looked at, so the list is exact.
COMPUTED_IMPORTS = {
    "homemodel.app.database.manifest",
    "homemodel.app.database.warm_up",
    "homemodel.cli.commands",
    "homemodel.geometry.open3d_loader",
}


@dataclass(frozen=True)
class Layering:
    roots: list[str]  # the import-linter root packages
    layers: list[list[str]]  # top first; a layer's packages are independent siblings


def read_layering(setup_cfg: Path) -> Layering:
    config = configparser.ConfigParser()
    config.read(setup_cfg)
    layers = config["importlinter:contract:layers"]["layers"].split("\n")
    return Layering(
        roots=config["importlinter"]["root_packages"].split(),
        layers=[[p.strip() for p in line.split("|")] for line in layers if line.strip()],
    )


@dataclass(frozen=True)
class Imports:
    """What one file imports, names resolved to absolute ones."""

    statements: tuple[tuple[str, tuple[str, ...]], ...]  # (module, names of `from module import names`)
    called: tuple[str, ...]  # the literal names given to import_module/__import__
    in_strings: tuple[str, ...]  # dotted names in strings (a module only if the project has it)
    computed: bool  # an import_module/__import__ whose name is not a literal


def _is_import_call(call: ast.Call) -> bool:
    name = call.func.attr if isinstance(call.func, ast.Attribute) else getattr(call.func, "id", None)
    return name in ("import_module", "__import__") and bool(call.args)


@functools.cache
def file_imports(path: Path, package: str) -> Imports:
    """Every import of the file at `path` (a module of `package`), anywhere in it; parsed once
    for all the checks here (the parse is most of this file's CPU)."""
    statements, called, in_strings, computed = [], [], [], False
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), str(path))):
        if isinstance(node, ast.Import):
            statements += [(alias.name, ()) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the package, up level - 1
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, *([base] if base else [])])
            statements.append((base, tuple(alias.name for alias in node.names)))
        elif isinstance(node, ast.Call) and _is_import_call(node):
            argument = node.args[0]
            if isinstance(argument, ast.Constant) and isinstance(argument.value, str) and not argument.value.startswith("."):
                called.append(argument.value)
            else:  # a relative name depends on its package argument: listed as computed, to be looked at
                computed = True
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and _MODULE_NAME.fullmatch(node.value):
            in_strings.append(node.value.partition(":")[0])
    return Imports(tuple(statements), tuple(called), tuple(in_strings), computed)


def module_files(repo: Path, roots: list[str]) -> dict[str, Path]:
    modules = {}
    for root in roots:
        for path in sorted((repo / root).rglob("*.py")):
            parts = list(path.relative_to(repo).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            modules[".".join(parts)] = path
    return modules


def _package_holding(module: str, path: Path) -> str:
    return module if path.name == "__init__.py" else module.rpartition(".")[0]


def imported_modules(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules `module` imports anywhere in its file (a name imported from a package
    counts as its submodule when it is one, else as the package; a string counts when the file
    imports a computed name and the string names a project module exactly: elsewhere a dotted
    string is data, as content_key's package names, which it finds without importing)."""

    def known(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    imports = file_imports(path, _package_holding(module, path))
    found = {name for name in (*imports.called, *(imports.in_strings if imports.computed else ())) if name in modules}
    for base, names in imports.statements:
        if not names:
            found.add(known(base))
        for name in names:
            found.add(f"{base}.{name}" if f"{base}.{name}" in modules else known(base))
    found.discard(None)
    found.discard(module)
    return found  # type: ignore[return-value]


def import_graph(repo: Path, roots: list[str]) -> dict[str, set[str]]:
    modules = module_files(repo, roots)
    return {module: imported_modules(module, path, modules) for module, path in modules.items()}


def _package_of(module: str, layering: Layering) -> tuple[int, str] | None:
    """(layer index, package) of the longest layer package that holds `module`."""
    best = None
    for index, layer in enumerate(layering.layers):
        for package in layer:
            if (module == package or module.startswith(package + ".")) and (best is None or len(package) > len(best[1])):
                best = (index, package)
    return best


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one node (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, edges = work[-1]
            step = next(edges, None)
            if step is not None:
                if step not in index:
                    index[step] = low[step] = len(index)
                    stack.append(step)
                    on_stack.add(step)
                    work.append((step, iter(sorted(graph.get(step, ())))))
                elif step in on_stack:
                    low[node] = min(low[node], index[step])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def layer_violations(graph: dict[str, set[str]], layering: Layering) -> list[str]:
    """Every import of a higher layer or of a sibling package, every package cycle, and every
    project import of the package root or of the add-on."""
    problems = []
    packages: dict[str, set[str]] = {}
    for module, targets in graph.items():
        source = _package_of(module, layering)
        for target in sorted(targets):
            if module.split(".")[0] == "blender_addons" and target.split(".")[0] != "blender_addons":
                problems.append(f"{module} -> {target}: the add-on imports the toolkit")
            if module == layering.layers[-1][0].split(".")[0]:
                problems.append(f"{module} -> {target}: the package root imports the project")
            destination = _package_of(target, layering)
            if source is None or destination is None or source[1] == destination[1]:
                continue
            packages.setdefault(source[1], set()).add(destination[1])
            if destination[0] < source[0]:
                problems.append(f"{module} -> {target}: {source[1]} imports {destination[1]}, a layer above it")
            elif destination[0] == source[0]:
                problems.append(f"{module} -> {target}: {source[1]} imports its sibling {destination[1]}")
    problems += [f"packages in a cycle: {' <-> '.join(c)}" for c in _cycles(packages)]
    return problems


def design_order_violations(layering: Layering, design: list[list[str]]) -> list[str]:
    """Where setup.cfg's layers break `design`'s order: a package missing, one put at or above a
    package `design` puts over it, or the pipelines (design's third layer) not kept as siblings."""
    where = {package: index for index, layer in enumerate(layering.layers) for package in layer}
    problems = [f"{package}: in no layer of setup.cfg" for layer in design for package in layer if package not in where]
    for rank, layer in enumerate(design):
        for upper in layer:
            for lower in (p for below in design[rank + 1 :] for p in below):
                if upper in where and lower in where and where[upper] >= where[lower]:
                    problems.append(f"{upper} is not above {lower}")
    if len({where.get(pipeline) for pipeline in design[2]}) != 1:
        problems.append(f"the pipelines {design[2]} are not one layer of siblings")
    return problems


def test_setup_cfg_keeps_design_md_order() -> None:
    assert design_order_violations(read_layering(REPO / "setup.cfg"), DESIGN_LAYERS) == []


def test_a_contract_that_breaks_design_md_order_is_found(tmp_path: Path) -> None:
    _tree(tmp_path, {"setup.cfg": "[importlinter]\nroot_packages =\n    x\n[importlinter:contract:layers]\nlayers =\n"
                                  "    cli\n    app\n    p | q\n    core\n    r\n    geo\n"})  # fmt: skip
    design = [["cli"], ["app"], ["p", "q", "r"], ["geo", "core"], ["base"]]
    assert design_order_violations(read_layering(tmp_path / "setup.cfg"), design) == [
        "base: in no layer of setup.cfg",
        "r is not above core",
        "the pipelines ['p', 'q', 'r'] are not one layer of siblings",
    ]


def test_the_code_keeps_the_layers_of_setup_cfg() -> None:
    layering = read_layering(REPO / "setup.cfg")
    assert layering.layers[0] == ["homemodel.cli"] and layering.layers[-1] == ["homemodel.core"]
    graph = import_graph(REPO, layering.roots)
    assert len(graph) > 250 and sum(len(t) for t in graph.values()) > 900  # the whole project was read
    unplaced = [m for m in graph if _package_of(m, layering) is None and m.split(".")[0] != "blender_addons"]
    assert sorted(unplaced) == ["homemodel", "homemodel.__main__"], unplaced  # the root: only the version and -m
    assert layer_violations(graph, layering) == []


def module_cycles(graph: dict[str, set[str]]) -> list[str]:
    """Every set of modules that import one another, directly or round a loop."""
    return [" <-> ".join(cycle) for cycle in _cycles(graph)]


def test_no_module_imports_itself_round_a_loop() -> None:
    layering = read_layering(REPO / "setup.cfg")
    assert module_cycles(import_graph(REPO, layering.roots)) == []


def format_importers(repo: Path, roots: list[str], libraries: set[str]) -> dict[str, set[str]]:
    """module -> the format libraries (setup.cfg's `formats` contract) it imports anywhere,
    by a statement or by import_module/__import__."""
    found: dict[str, set[str]] = {}
    for module, path in module_files(repo, roots).items():
        imports = file_imports(path, _package_holding(module, path))
        for name in (*(base for base, _ in imports.statements), *imports.called):
            if name.split(".")[0] in libraries:
                found.setdefault(module, set()).add(name.split(".")[0])
    return found


def read_formats(setup_cfg: Path) -> tuple[list[str], set[str]]:
    """The `formats` contract: the packages that may open no format library, and those libraries."""
    config = configparser.ConfigParser()
    config.read(setup_cfg)
    contract = config["importlinter:contract:formats"]
    return contract["source_modules"].split(), set(contract["forbidden_modules"].split())


def test_formats_are_opened_only_in_exchange_and_core() -> None:
    layering = read_layering(REPO / "setup.cfg")
    sources, libraries = read_formats(REPO / "setup.cfg")
    packages = {package for layer in layering.layers for package in layer}
    assert packages - set(sources) == {"homemodel.exchange", "homemodel.core"}  # every other package is bound
    importers = format_importers(REPO, layering.roots, libraries)
    outside = {m: libs for m, libs in importers.items() if not m.startswith(("homemodel.exchange.", "homemodel.core."))}
    assert outside == {}
    assert {"lxml", "pxr"} <= set().union(*importers.values())  # the scan sees the formats' own (pxr: in a function)


def _tree(root: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text)


def test_an_upward_import_inside_a_function_a_sibling_and_a_root_import_are_found(tmp_path: Path) -> None:
    _tree(tmp_path, {
        "setup.cfg": "[importlinter]\nroot_packages =\n    top\n    a\n    b\n    low\n"
                     "[importlinter:contract:layers]\nlayers =\n    top\n    a | b\n    low\n",
        "top/__init__.py": "", "a/__init__.py": "", "b/__init__.py": "", "low/__init__.py": "",
        "top/cli.py": "from a import thing\nimport low.core\n",  # downwards: fine
        "a/thing.py": "from . import other\n",
        "a/other.py": "def f():\n    from low.core import g\n    return g\n",
        "b/sibling.py": "from a.thing import x\n",  # a sibling
        "low/core.py": "def g():\n    if True:\n        import top.cli\n",  # upwards, inside a function
    })  # fmt: skip
    layering = read_layering(tmp_path / "setup.cfg")
    graph = import_graph(tmp_path, layering.roots)
    assert graph["a.thing"] == {"a.other"} and graph["a.other"] == {"low.core"}
    assert layer_violations(graph, layering) == [
        "b.sibling -> a.thing: b imports its sibling a",
        "low.core -> top.cli: low imports top, a layer above it",
        "packages in a cycle: a <-> low <-> top",
    ]


def test_a_loop_through_a_type_checking_import_or_a_function_is_found(tmp_path: Path) -> None:
    _tree(tmp_path, {
        "setup.cfg": "[importlinter]\nroot_packages =\n    p\n[importlinter:contract:layers]\nlayers =\n    p\n",
        "p/__init__.py": "",
        "p/spec.py": "from p.rules import check\n",
        "p/rules.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from p.spec import Spec\n",  # type-only
        "p/tasks.py": "from p.request import Request\ndef run():\n    from p.worker import work\n",
        "p/worker.py": "from p.tasks import run\n",  # back to tasks: a loop through a function's import
        "p/request.py": "",
        "p/alone.py": "import p.request\n",  # downwards only: no loop
    })  # fmt: skip
    layering = read_layering(tmp_path / "setup.cfg")
    graph = import_graph(tmp_path, layering.roots)
    assert sorted(module_cycles(graph)) == ["p.rules <-> p.spec", "p.tasks <-> p.worker"]
    assert layer_violations(graph, layering) == []  # within one package: only the loop test sees it


def test_a_format_library_opened_inside_a_function_or_for_type_checking_is_found(tmp_path: Path) -> None:
    _tree(tmp_path, {
        "p/__init__.py": "",
        "p/model.py": "def save():\n    from lxml import etree\n",
        "p/nodes.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    import xml.etree.ElementTree as ET\n",
        "p/plain.py": "import json\nfrom . import model\n",  # json and a relative import: not formats
    })  # fmt: skip
    assert format_importers(tmp_path, ["p"], {"lxml", "xml", "pygltflib"}) == {"p.model": {"lxml"}, "p.nodes": {"xml"}}


def test_open3d_is_imported_only_through_its_loader() -> None:
    """`load_open3d` leaves Open3D's dash/plotly viewer out; a plain `import open3d` would bring it back."""
    layering = read_layering(REPO / "setup.cfg")
    assert set(format_importers(REPO, layering.roots, {"open3d"})) == {"homemodel.geometry.open3d_loader"}


def test_imports_by_name_relative_ones_and_tables_of_names_are_found(tmp_path: Path) -> None:
    _tree(tmp_path, {
        "setup.cfg": "[importlinter]\nroot_packages =\n    top\n    mid\n    low\n"
                     "[importlinter:contract:layers]\nlayers =\n    top\n    mid\n    low\n",
        "top/__init__.py": "", "mid/__init__.py": "", "low/__init__.py": "", "low/deep/__init__.py": "",
        "top/table.py": "import importlib\nPARTS = {'a': 'mid.parts:build'}\n"  # a table of names: downwards
                        "def part(name):\n    return importlib.import_module(PARTS[name].partition(':')[0])\n",
        "mid/parts.py": "import importlib\ndef build():\n    return importlib.import_module('top.table')\n",
        "low/deep/leaf.py": "from .. import base\nfrom ..base import f\nKIND, CODE = 'mid', 'top.table'\n",  # data
        "low/base.py": "def f():\n    return __import__('mid.parts')\n",
        "low/computed.py": "import importlib\ndef load(name):\n    return importlib.import_module(name)\n",
        "low/relative.py": "import importlib\nimportlib.import_module('.base', 'low')\n",
    })  # fmt: skip
    layering = read_layering(tmp_path / "setup.cfg")
    graph = import_graph(tmp_path, layering.roots)
    assert graph["top.table"] == {"mid.parts"} and graph["low.deep.leaf"] == {"low.base"}
    assert layer_violations(graph, layering) == [
        "mid.parts -> top.table: mid imports top, a layer above it",
        "low.base -> mid.parts: low imports mid, a layer above it",
        "packages in a cycle: mid <-> top",
    ]
    assert module_cycles(graph) == ["mid.parts <-> top.table"]
    assert computed_importers(tmp_path, layering.roots) == {"top.table", "low.computed", "low.relative"}


def computed_importers(repo: Path, roots: list[str]) -> set[str]:
    """The modules that give import_module/__import__ a name they compute."""
    return {m for m, path in module_files(repo, roots).items() if file_imports(path, _package_holding(m, path)).computed}


def test_every_import_of_a_computed_name_is_one_the_string_rule_reads() -> None:
    """Each of these imports names from a table of literal module names in its own file (read
    as imports above); a new one must be looked at before it joins the list."""
    assert computed_importers(REPO, read_layering(REPO / "setup.cfg").roots) == COMPUTED_IMPORTS
