"""The layers of setup.cfg's import-linter contracts, measured independently of import-linter:
every module's imports are read with `ast`, those inside functions and under TYPE_CHECKING
included, and no module may import a layer above its own or a sibling package of its layer;
the packages then have no cycle, no two modules import each other even through others (an
import for type checking or inside a function is a loop too), the package root imports nothing
of the project, and the Blender add-on imports none of it."""

from __future__ import annotations

import ast
import configparser
import functools
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


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


@functools.cache
def _parsed(path: Path) -> ast.Module:
    """A file's syntax tree, parsed once for all the checks here (the whole tree takes seconds)."""
    return ast.parse(path.read_text(encoding="utf-8"), str(path))


def module_files(repo: Path, roots: list[str]) -> dict[str, Path]:
    modules = {}
    for root in roots:
        for path in sorted((repo / root).rglob("*.py")):
            parts = list(path.relative_to(repo).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            modules[".".join(parts)] = path
    return modules


def imported_modules(module: str, path: Path, modules: dict[str, Path]) -> set[str]:
    """The project modules `module` imports anywhere in its file (a name imported from a package
    counts as its submodule when it is one, else as the package)."""

    def known(name: str) -> str | None:
        while name and name not in modules:
            name = name.rpartition(".")[0]
        return name or None

    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(_parsed(path)):
        if isinstance(node, ast.Import):
            found.update(known(alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: from the package, up level - 1
                parent = package.split(".")[: len(package.split(".")) - node.level + 1]
                base = ".".join([*parent, *([base] if base else [])])
            for alias in node.names:
                submodule = f"{base}.{alias.name}"
                found.add(submodule if submodule in modules else known(base))
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
    """module -> the format libraries (setup.cfg's `formats` contract) it imports anywhere."""
    found: dict[str, set[str]] = {}
    for module, path in module_files(repo, roots).items():
        for node in ast.walk(_parsed(path)):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and not node.level and node.module:
                names = [node.module]
            for name in names:
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
