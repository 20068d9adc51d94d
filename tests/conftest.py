"""Fixtures shared by the test modules: the example specs, the shared data folder beside the
repository, the semantic map of Figure 47's house, and the catalogue built once and put
through the validation gate."""

from __future__ import annotations

import json
import math
import os
import shutil
import sys
import time
from pathlib import Path
from typing import NamedTuple

import pytest
from fixture_cache import cached_folder, content_key
from model_summaries import unchecked_summary_problems
from sample_house import build_house

from articulation.model import Model
from homemodel.exchange.map_xml import save_map
from homemodel.model_folder.gate.report import ValidationReport
from semantic_map import SemanticMap

# CPU seconds per test phase into a JSON file, when HOMEMODEL_CPU_PROFILE names one.
pytest_plugins = ("cpu_profile",)
# Hypothesis, when first imported, loads every installed "hypothesis" entry point; the only one is
# trio's (0.3 CPU-s in each worker, for strategies no test uses).
os.environ.setdefault("HYPOTHESIS_NO_PLUGINS", "1")

REPO = Path(__file__).resolve().parents[1]
# ../shared/data beside the checkout; HOMEMODEL_SHARED_DATA moves it (a test shows the skips without it).
SHARED_DATA = Path(os.environ.get("HOMEMODEL_SHARED_DATA", REPO.parent / "shared" / "data"))
# What `homemodel build` runs: a change to any of it builds the kitchen again.
KITCHEN_CODE = ("homemodel", "modeller", "articulation", "semantic_map")
NO_SHARED_DATA = f"needs the shared data folder {SHARED_DATA} (real photos and tag images), which is absent"


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests using the `shared_data` fixture are marked `shared_data` too (`-m "not shared_data"`
    leaves out all that read it; -m selects after this hook). The longest test files go first."""
    for item in items:
        if "shared_data" in getattr(item, "fixturenames", ()):
            item.add_marker(pytest.mark.shared_data)
    longest_files_first(items)


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    """Without ../shared/data, the tests marked `shared_data` are skipped before their fixtures
    are made. Raised here, every such skip has this one place, so `-ra` sums them up in one line."""
    if item.get_closest_marker("shared_data") and not SHARED_DATA.is_dir():
        pytest.skip(NO_SHARED_DATA)


# `make test` runs `-n auto --dist loadfile --no-loadscope-reorder`: xdist gives each worker a
# whole test file at a time, in the order collected. The files go longest first by the wall
# seconds durations.json lists (`make durations` measures them, cold), a file not measured yet
# first of all, so that the last files to start are short and the workers end together; the
# rest keep their order. The cached fixtures two files share (tests/photo_runs.py) are made by
# the longer file, long before the shorter one starts, so no worker waits on another's lock.
DURATIONS = Path(__file__).with_name("durations.json")


def longest_files_first(items: list[pytest.Item], file_wall_s: dict[str, float] | None = None) -> None:
    """Order the tests by their file's measured wall time, the longest first, each file kept
    whole and in order; files not measured first."""
    wall = file_wall_s if file_wall_s is not None else json.loads(DURATIONS.read_text())["file_wall_s"]
    items.sort(key=lambda item: -wall.get(item.path.name, math.inf))  # stable


# A fresh clone's .venv holds no bytecode (uv writes none): the first collection compiles numpy,
# trimesh, typer, hypothesis... (7-8 CPU-s), and workers collecting side by side each compile
# the same modules. Then the other workers wait for the first one's collection and read its
# bytecode. A module that test files import but conftest does not (the controller has imported
# conftest's) tells a cold cache; a warm one (a rerun) starts every worker at once.
COLD_SIGN = "typer.testing"
COLLECTED = "collected-by-gw0"  # in the run's basetemp, beside the workers' own
COLLECTION_WAIT_S = 300


def bytecode_is_cold(module: str = COLD_SIGN) -> bool:
    """Whether `module`'s source has no bytecode cached for this Python yet (where any is written)."""
    import importlib.util

    spec = importlib.util.find_spec(module)
    if sys.dont_write_bytecode or spec is None or not spec.origin or not spec.origin.endswith(".py"):
        return False
    return not Path(importlib.util.cache_from_source(spec.origin)).exists()


def _collected_flag(config: pytest.Config) -> Path | None:
    """The file the first worker writes once it has collected; None outside xdist's workers."""
    workerinput = getattr(config, "workerinput", None)
    if workerinput is None or not config.option.basetemp:
        return None
    return Path(config.option.basetemp).parent / f"{COLLECTED}-{workerinput['testrunuid']}"


@pytest.hookimpl(tryfirst=True)
def pytest_collection(session: pytest.Session) -> None:
    """Workers after the first wait for its collection while the bytecode cache is cold."""
    flag = _collected_flag(session.config)
    if flag is None or session.config.workerinput["workerid"] == "gw0" or not bytecode_is_cold():
        return
    deadline = time.monotonic() + COLLECTION_WAIT_S
    while not flag.exists() and time.monotonic() < deadline:
        time.sleep(0.1)


@pytest.hookimpl(trylast=True)
def pytest_collection_finish(session: pytest.Session) -> None:
    flag = _collected_flag(session.config)
    if flag is not None and session.config.workerinput["workerid"] == "gw0":
        flag.touch()


@pytest.hookimpl(optionalhook=True)  # xdist may be off (-p no:xdist)
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int | None:
    """`-n auto`: one worker more than the cores this process may use. A test waiting (on a
    server, a window, a child process, a sleep) leaves its core to the spare worker: about 230
    of the suite's 1,560 core-seconds were idle with one worker a core. PYTEST_XDIST_AUTO_NUM_WORKERS
    still decides where it is set (xdist's own hook reads it)."""
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return None
    return len(os.sched_getaffinity(0)) + 1


class BuiltExample(NamedTuple):
    """A catalogue example: its spec, the model built from it, and the gate's report on the exported files."""

    spec: object
    model: Model
    report: ValidationReport


@pytest.fixture(scope="module", autouse=True)
def model_summaries_follow_the_schema(tmp_path_factory: pytest.TempPathFactory):
    """Each module's new summary files (its tests' and the fixtures it made, session ones
    included) are accepted by the published JSON Schema of their name: any summary.json is a
    model folder's."""
    yield
    problems = unchecked_summary_problems(tmp_path_factory.getbasetemp())
    assert not problems, "a summary file breaks its schema in homemodel/schemas/:\n" + "\n".join(problems[:10])


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """`../shared/data` beside the repository: real photos and tag images (see its README).
    Where it is absent, the tests asking for it are skipped before this is reached."""
    return SHARED_DATA


@pytest.fixture(scope="session")
def catalogue_dir() -> Path:
    """`examples/catalogue`: one spec of every kind the modeller builds."""
    return REPO / "examples" / "catalogue"


@pytest.fixture(scope="session")
def kitchen_dir() -> Path:
    """`examples/kitchen`: the Figure 47 kitchen's specs and its `home.yaml`."""
    return REPO / "examples" / "kitchen"


@pytest.fixture(scope="session")
def textured_dir() -> Path:
    """`examples/textured`: specs with photos on their faces."""
    return REPO / "examples" / "textured"


@pytest.fixture(scope="session")
def built_kitchen(tmp_path_factory: pytest.TempPathFactory, kitchen_dir: Path) -> Path:
    """`homemodel build examples/kitchen` (`map.xml` and `models/`), made once per content of
    the kitchen and the code that builds it (fixture_cache) and copied for the session."""
    from typer.testing import CliRunner

    from homemodel.cli import app

    def build(folder: Path) -> None:
        result = CliRunner().invoke(app, ["build", str(kitchen_dir), "--out", str(folder / "out")])
        assert result.exit_code == 0, result.output

    key = content_key(inputs=[kitchen_dir], packages=KITCHEN_CODE)
    out = tmp_path_factory.mktemp("kitchen") / "out"
    shutil.copytree(cached_folder("built_kitchen", key, build) / "out", out)
    return out


@pytest.fixture(scope="module")
def kitchen_map(built_kitchen: Path) -> Path:
    """The demo kitchen's map, for the tracking tests' views."""
    return built_kitchen / "map.xml"


@pytest.fixture(scope="module")
def simulator(kitchen_map: Path):  # noqa: ANN201 (tracking's types stay out of every test's imports)
    """The view simulator of the demo kitchen."""
    from tracking.simulate_view import ViewSimulator

    return ViewSimulator.load(kitchen_map)


class Catalogue:
    """The catalogue examples by name, each built in Blender, exported and validated by the
    gate the first time a test asks for it, then kept for the session."""

    def __init__(self, specs_dir: Path, out_dir: Path) -> None:
        self._specs_dir, self._out_dir = specs_dir, out_dir
        self._built: dict[str, BuiltExample] = {}

    def __getitem__(self, name: str) -> BuiltExample:
        if name not in self._built:
            from homemodel.exchange.model_files import export_model
            from homemodel.model_folder.gate.validate import validate_path
            from modeller import build_model, load_spec

            path = self._specs_dir / f"{name}.yaml"
            model = build_model(path)
            export_model(model, self._out_dir / name)
            self._built[name] = BuiltExample(load_spec(path), model, validate_path(self._out_dir / name))
        return self._built[name]


@pytest.fixture(scope="session")
def catalogue(catalogue_dir: Path, tmp_path_factory: pytest.TempPathFactory) -> Catalogue:
    return Catalogue(catalogue_dir, tmp_path_factory.mktemp("catalogue"))


@pytest.fixture
def house() -> SemanticMap:
    """Figure 47's house, fresh for each test (tests change it)."""
    return build_house()


@pytest.fixture
def house_file(house: SemanticMap, tmp_path: Path) -> Path:
    path = tmp_path / "map.xml"
    save_map(house, path)
    return path
