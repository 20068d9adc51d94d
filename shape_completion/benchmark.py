"""The protocol of D3.1 Table 1 (after Rock et al.): train on part of each class, complete
unseen instances from rendered depth images, and score every stage against the truth.

Per class: mean VoxelIOU and surface distance (Rock et al.'s conventions,
`homemodel.evaluation`) of retrieval only (the retrieved mesh at its view's pose), after
fitting (rigid fit + symmetric TPS), after filling (the final mesh), and of the
nearest-neighbour oracle: the training mesh with the best IoU against the unseen instance
(both in their own frames), the ceiling of any retrieval.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import trimesh

from homemodel.core.atomic import atomic_dir, write_bytes_atomic, write_json, write_text_atomic
from homemodel.core.checks import require_at_least
from homemodel.core.errors import InputError
from homemodel.core.progress import Progress, no_progress
from homemodel.evaluation import rock_surface_distance, rock_voxel_iou, voxel_iou
from homemodel.geometry.raycast import RayCaster
from shape_completion.library import Library
from shape_completion.pipeline import Completion, ShapeCompleter
from shape_completion.queries import FILLER_CAMERA, random_query_pose

STAGES = ("retrieval", "fitting", "filling", "oracle")
DISTANCE_SAMPLES = 20_000


@dataclass(kw_only=True)
class BenchmarkOptions:
    train_per_class: int = 15
    test_per_class: int = 5
    n_views: int = 40
    queries_per_instance: int = 4
    filler_queries_per_class: int = 20
    random_state: int = 0  # of the learners and the query views

    def check(self) -> None:
        require_at_least("train_per_class", self.train_per_class, 2)
        require_at_least("test_per_class", self.test_per_class, 1)
        require_at_least("n_views", self.n_views, 4)
        require_at_least("queries_per_instance", self.queries_per_instance, 1)
        require_at_least("filler_queries_per_class", self.filler_queries_per_class, 1)


@dataclass(kw_only=True)
class QueryScore:
    class_name: str
    instance: str
    retrieved: str
    voxel_iou: dict[str, float]
    surface_distance: dict[str, float]
    seconds: float


@dataclass(kw_only=True)
class Example:
    """What the figure shows of one query."""

    class_name: str
    depth_m: np.ndarray
    completion: Completion
    truth: trimesh.Trimesh


@dataclass(kw_only=True)
class BenchmarkResult:
    options: BenchmarkOptions
    scores: list[QueryScore]
    training_seconds: float
    examples: list[Example] = field(default_factory=list)

    def class_means(self) -> dict[str, dict[str, float]]:
        """Per class: mean IoU and distance per stage, keyed `iou_<stage>` / `distance_<stage>`."""
        table = {}
        for class_name in sorted({s.class_name for s in self.scores}):
            rows = [s for s in self.scores if s.class_name == class_name]
            means = {f"iou_{st}": float(np.mean([r.voxel_iou[st] for r in rows])) for st in STAGES}
            means |= {f"distance_{st}": float(np.mean([r.surface_distance[st] for r in rows])) for st in STAGES}
            means["queries"] = len(rows)
            table[class_name] = means
        return table

    def markdown(self) -> str:
        """The per-class table as Markdown, with the mean over classes and the timings."""
        means = self.class_means()
        header = "| class | " + " | ".join(f"IoU {s}" for s in STAGES) + " | "
        header += " | ".join(f"dist {s}" for s in STAGES) + " |"
        lines = [header, "|---" * (1 + 2 * len(STAGES)) + "|"]
        for class_name, row in means.items():
            cells = [f"{row[f'iou_{s}']:.3f}" for s in STAGES] + [f"{row[f'distance_{s}']:.4f}" for s in STAGES]
            lines.append(f"| {class_name} | " + " | ".join(cells) + " |")
        overall = [np.mean([r[f"iou_{s}"] for r in means.values()]) for s in STAGES]
        overall += [np.mean([r[f"distance_{s}"] for r in means.values()]) for s in STAGES]
        lines.append(
            "| **mean** | "
            + " | ".join(f"{v:.3f}" if i < len(STAGES) else f"{v:.4f}" for i, v in enumerate(overall))
            + " |"
        )
        lines.append("")
        lines.append(
            f"training {self.training_seconds:.1f} s; query mean {self.mean_query_seconds:.2f} s,"
            f" max {self.max_query_seconds:.2f} s"
        )
        return "\n".join(lines) + "\n"

    @property
    def mean_query_seconds(self) -> float:
        return float(np.mean([s.seconds for s in self.scores]))

    @property
    def max_query_seconds(self) -> float:
        return float(np.max([s.seconds for s in self.scores]))


def split_library(library: Library, options: BenchmarkOptions) -> tuple[Library, Library]:
    """The first `train_per_class` meshes of each class (by name) to train, the next `test_per_class` to test."""
    train, test = [], []
    for class_name in library.class_names:
        members = sorted((m for m in library.meshes if m.class_name == class_name), key=lambda m: m.name)
        needed = options.train_per_class + options.test_per_class
        if len(members) < needed:
            raise InputError(
                f"class {class_name!r} has {len(members)} meshes; --train {options.train_per_class}"
                f" --test {options.test_per_class} needs {needed}"
            )
        train += members[: options.train_per_class]
        test += members[options.train_per_class : needed]
    return Library(meshes=train, fingerprint=library.fingerprint), Library(meshes=test, fingerprint=library.fingerprint)


def oracle_mesh(truth: trimesh.Trimesh, library: Library) -> trimesh.Trimesh:
    """The library mesh whose solid overlaps `truth` best in their own frames (ranked on a
    coarse grid, 1/48 of the object's size, for speed)."""
    voxel = float(np.max(truth.extents)) / 48
    scores = [voxel_iou(m.mesh, truth, voxel_size_m=voxel) for m in library.meshes]
    return library.meshes[int(np.argmax(scores))].mesh


def run_benchmark(library: Library, options: BenchmarkOptions, progress: Progress | None = None) -> BenchmarkResult:
    """Train on the first `train_per_class` meshes of each class, score the next `test_per_class`."""
    options.check()
    train, test = split_library(library, options)
    return benchmark_split(train, test, options, progress)


@dataclass(frozen=True)
class CompletedView:
    """One random view of a test mesh, completed: its depth, the completion, the truth in the
    camera's frame, and the completion's time."""

    camera_from_object: np.ndarray
    depth_m: np.ndarray
    completion: Completion
    truth: trimesh.Trimesh
    seconds: float


def complete_random_view(completer: ShapeCompleter, mesh: trimesh.Trimesh, rng: np.random.Generator) -> CompletedView:
    """Render `mesh` from a random query pose and complete it, timing the completion alone."""
    camera_from_object = random_query_pose(mesh, rng)
    depth = RayCaster(mesh).depth(FILLER_CAMERA, camera_from_object)
    started = time.perf_counter()
    completion = completer.complete(depth, FILLER_CAMERA)
    seconds = time.perf_counter() - started
    return CompletedView(camera_from_object, depth, completion, mesh.copy().apply_transform(camera_from_object), seconds)


def benchmark_split(
    train: Library,
    test: Library,
    options: BenchmarkOptions,
    progress: Progress | None = None,
    *,
    completer: ShapeCompleter | None = None,
) -> BenchmarkResult:
    """Train on `train` (`completer`, when given, is the one fitted, so a caller can keep it),
    score every mesh of `test` (whose classes `train` must hold)."""
    report = progress or no_progress
    unknown = sorted(set(test.class_names) - set(train.class_names))
    if unknown:
        raise InputError(f"test classes {unknown} are not among the training classes {train.class_names}")
    started = time.perf_counter()
    completer = completer or ShapeCompleter(
        n_views=options.n_views,
        filler_queries_per_class=options.filler_queries_per_class,
        random_state=options.random_state,
    )
    completer.fit(train, progress=report)
    training_seconds = time.perf_counter() - started
    rng = np.random.default_rng(options.random_state + 7)
    scores, examples = [], []
    total = len(test.meshes) * options.queries_per_instance
    for index, entry in enumerate(test.meshes):
        oracle = oracle_mesh(entry.mesh, train)
        for q in range(options.queries_per_instance):
            report("completing test views", index * options.queries_per_instance + q, total)
            view = complete_random_view(completer, entry.mesh, rng)
            completion, truth = view.completion, view.truth
            staged = {
                "retrieval": completion.retrieved,
                "fitting": completion.deformed,
                "filling": completion.mesh,
                "oracle": oracle.copy().apply_transform(view.camera_from_object),
            }
            scores.append(
                QueryScore(
                    class_name=entry.class_name,
                    instance=entry.name,
                    retrieved=completion.retrieved_name,
                    voxel_iou={k: rock_voxel_iou(m, truth) for k, m in staged.items()},
                    surface_distance={
                        k: rock_surface_distance(m, truth, n_samples=DISTANCE_SAMPLES) for k, m in staged.items()
                    },
                    seconds=view.seconds,
                )
            )
            if q == 0 and not any(e.class_name == entry.class_name for e in examples):
                examples.append(Example(class_name=entry.class_name, depth_m=view.depth_m, completion=completion, truth=truth))
    report("completing test views", total, total)
    return BenchmarkResult(options=options, scores=scores, training_seconds=training_seconds, examples=examples)


def write_benchmark(result: BenchmarkResult, out_dir: Path, *, force: bool = False, inputs: list[Path] = ()) -> None:
    """results.json (options, per-class means, timings, every query's scores), table.md and
    examples.png into `out_dir`, atomically."""
    from shape_completion.figures import examples_png

    results = {
        "options": vars(result.options),
        "classes": result.class_means(),
        "training_seconds": result.training_seconds,
        "mean_query_seconds": result.mean_query_seconds,
        "max_query_seconds": result.max_query_seconds,
        "queries": [vars(s) for s in result.scores],
    }
    with atomic_dir(Path(out_dir), force=force, inputs=inputs) as tmp:
        write_json(tmp / "results.json", results)
        write_text_atomic(tmp / "table.md", result.markdown())
        write_bytes_atomic(tmp / "examples.png", examples_png(result.examples))
