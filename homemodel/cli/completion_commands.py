"""`homemodel completion library|train|run|benchmark`: a whole mesh of a new object from one depth image."""

from __future__ import annotations

from pathlib import Path

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.map_flags import (
    ID_OPTION,
    MAP_OPTION,
    PARENT_OPTION,
    XYZ_OPTION,
    echo_registration,
    map_entry_from_flags,
)
from homemodel.cli.option_fields import field_option, from_options
from homemodel.cli.progress import Column, figures_table, fitted_table, make_console, progress_bar

completion_app = typer.Typer(no_args_is_help=True)

LIBRARY = "shape_completion.library:write_procedural_library"
COMPLETER = "shape_completion.pipeline:ShapeCompleter.__init__"
COMPLETION = "shape_completion.model_export:CompletionOptions"
BENCHMARK = "shape_completion.benchmark:BenchmarkOptions"


@completion_app.command("library")
@from_options
def library_command(
    out: Path = typer.Option(..., "--out", help="folder to write LIBRARY/<class>/<class>_NNN.ply into"),
    classes: str | None = typer.Option(
        None, "--classes", help="comma-separated classes (default: every class the generator makes)"
    ),
    per_class: int = field_option(f"{LIBRARY}.per_class", min=1, max=500, help="instances per class"),
    seed: int = field_option(f"{LIBRARY}.seed", help="seed of the generator"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Write the procedural class library (cups and mugs, bottles, glasses, bowls, spoons) to start from."""
    from homemodel.core.atomic import atomic_dir
    from shape_completion.library import write_procedural_library

    with exit_on_error():
        names = None if classes is None else [c.strip() for c in classes.split(",") if c.strip()]
        with atomic_dir(out, force=force) as tmp:
            written = write_procedural_library(tmp, classes=names, per_class=per_class, seed=seed)
    typer.echo(f"wrote {len(written)} meshes in {len({path.parent.name for path in written})} classes to {out}")


@completion_app.command("train")
@from_options
def train_command(
    library_dir: Path = typer.Argument(..., help="LIBRARY/<class>/<mesh files>, metres, z up"),
    out: Path = typer.Option(..., "--out", help="model file to write (.npz of arrays: it carries no code)"),
    views: int = field_option(f"{COMPLETER}.n_views", "--views", min=4, max=500, help="depth views per mesh on a sphere"),
    filler_queries: int = field_option(
        f"{COMPLETER}.filler_queries_per_class",
        "--filler-queries",
        min=1,
        max=1000,
        help="completions per class the filler learns from",
    ),
    seed: int = field_option(f"{COMPLETER}.random_state", "--seed", help="random_state of every learner"),
    force: bool = typer.Option(False, "--force", help="replace an existing model file"),
) -> None:
    """Render the library, learn the retrieval forest and the boosted filler, save the model."""
    from homemodel.core.errors import OutputExistsError
    from shape_completion.library import load_library
    from shape_completion.model_io import save_model
    from shape_completion.pipeline import ShapeCompleter

    console = make_console()
    with exit_on_error():
        if out.exists() and not force:
            raise OutputExistsError(f"{out}: exists (use --force to replace it)")
        library = load_library(library_dir)
        with progress_bar(console, "completion") as progress:
            completer = ShapeCompleter(n_views=views, filler_queries_per_class=filler_queries, random_state=seed).fit(
                library, progress=progress
            )
        save_model(completer, out, force=force)
    console.print(
        figures_table(
            f"homemodel completion train {library_dir}",
            [
                ("classes", ", ".join(library.class_names)),
                ("meshes", str(len(library.meshes))),
                ("training views", str(len(completer.view_shape_))),
                ("training s", f"{completer.training_seconds_:.1f}"),
                ("library fingerprint", library.fingerprint[:16]),
            ],
        )
    )
    console.print(f"model: {out}")


@completion_app.command("run")
@from_options
def run_command(
    model_file: Path = typer.Argument(..., help="a model file from `homemodel completion train`"),
    depth_png: Path = typer.Argument(..., help="16-bit depth PNG (units of depth_scale_m) or float EXR in metres"),
    camera: Path = typer.Option(
        ...,
        "--camera",
        help="camera.yaml: width, height, fx, fy, cx, cy, depth_scale_m; optional map_from_camera (4x4, the"
        " camera's pose, OpenCV axes) to write the model upright",
    ),
    out: Path = typer.Option(..., "--out", help="model folder to write"),
    mask: Path | None = field_option(f"{COMPLETION}.mask_path", "--mask", help="8-bit mask PNG, non-zero on the object"),
    library: Path | None = field_option(
        f"{COMPLETION}.library_dir", "--library", help="refuse the model unless trained on this library"
    ),
    name: str | None = field_option(f"{COMPLETION}.name", help="model name (default: the depth image's file name)"),
    density_kg_m3: float = field_option(
        f"{COMPLETION}.density_kg_m3", "--density-kg-m3", old=("--density",), min=1.0, help="for the inertial, kg/m^3"
    ),
    map_path: Path | None = MAP_OPTION,
    parent_id: str | None = PARENT_OPTION,
    object_id: str | None = ID_OPTION,
    xyz: tuple[float, float, float] = XYZ_OPTION,
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Complete the object seen in one depth image into a model folder: upright (+z up, origin on the
    support under the object) when camera.yaml gives the camera's pose or the depth image shows the
    support plane, else in the camera's frame (OpenCV); summary.json names the frame."""
    from shape_completion import CompletionOptions, complete

    console = make_console()
    with exit_on_error():
        map_entry = map_entry_from_flags(map_path, parent_id, object_id or name or depth_png.stem, xyz)
        options = CompletionOptions(
            camera_path=camera,
            mask_path=mask,
            library_dir=library,
            name=name,
            density_kg_m3=density_kg_m3,
            map_entry=map_entry,
        )
        with progress_bar(console, "completion") as progress:
            completion = complete(model_file, depth_png, out, options, progress=progress, force=force)
    fit = completion.fit
    rows = [
        ("class (retrieved)", f"{completion.class_name} ({completion.retrieved_name})"),
        ("match distance mm", f"{1000 * fit.match_distance_m:.2f}"),
        ("fit distance mm", f"{1000 * fit.fit_distance_m:.2f}"),
        ("symmetry planes", str(len(fit.planes_camera))),
        ("triangles", str(completion.summary.triangles)),
        ("size mm", " x ".join(f"{1000 * v:.0f}" for v in completion.summary.extents_m)),
        ("up from", completion.frame.up_from or "[yellow]nothing: in the camera's frame[/]"),
    ] + [(f"{stage} s", f"{seconds:.2f}") for stage, seconds in completion.times_s.items()]
    rows.append(("total s", f"{sum(completion.times_s.values()):.2f}"))
    console.print(figures_table(f"homemodel completion run {depth_png}", rows))
    console.print(f"model: {out}")
    if completion.registration is not None:
        echo_registration(completion.registration)


@completion_app.command("benchmark")
@from_options
def benchmark_command(
    library_dir: Path = typer.Argument(..., help="LIBRARY/<class>/<mesh files>"),
    out: Path = typer.Option(..., "--out", help="folder for results.json, table.md, examples.png"),
    train: int = field_option(
        f"{BENCHMARK}.train_per_class", "--train", min=2, help="training instances per class (first by name)"
    ),
    test: int = field_option(
        f"{BENCHMARK}.test_per_class", "--test", min=1, help="unseen test instances per class (the next ones)"
    ),
    views: int = field_option(f"{BENCHMARK}.n_views", "--views", min=4, max=500, help="depth views per training mesh"),
    queries: int = field_option(
        f"{BENCHMARK}.queries_per_instance", "--queries", min=1, help="random query views per test instance"
    ),
    filler_queries: int = field_option(
        f"{BENCHMARK}.filler_queries_per_class",
        "--filler-queries",
        min=1,
        max=1000,
        help="completions per class the filler learns from",
    ),
    seed: int = field_option(f"{BENCHMARK}.random_state", "--seed", help="seed of the learners and the query views"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """D3.1 Table 1's protocol: per class, VoxelIOU and surface distance of each stage and of the oracle."""
    from homemodel.core.atomic import prepare_out_dir
    from shape_completion.benchmark import STAGES, BenchmarkOptions, run_benchmark, write_benchmark
    from shape_completion.library import load_library

    console = make_console()
    options = BenchmarkOptions(
        train_per_class=train,
        test_per_class=test,
        n_views=views,
        queries_per_instance=queries,
        filler_queries_per_class=filler_queries,
        random_state=seed,
    )
    with exit_on_error():
        prepare_out_dir(out, force=force, inputs=[library_dir])
        library = load_library(library_dir)
        with progress_bar(console, "completion") as progress:
            result = run_benchmark(library, options, progress=progress)
        write_benchmark(result, out, force=force, inputs=[library_dir])
    means = result.class_means()
    columns = [Column("class", keep=True)]
    columns += [Column(f"IoU {stage}", justify="right") for stage in STAGES]
    columns += [Column(f"dist {stage}", justify="right") for stage in STAGES]
    cells = [
        [class_name, *(f"{row[f'iou_{st}']:.3f}" for st in STAGES), *(f"{row[f'distance_{st}']:.4f}" for st in STAGES)]
        for class_name, row in means.items()
    ]
    # Narrow terminals keep the IoUs and the final distance.
    drop = [f"dist {stage}" for stage in STAGES if stage != "filling"]
    console.print(fitted_table(console, f"homemodel completion benchmark {library_dir}", columns, cells, drop))
    console.print(
        f"training: {result.training_seconds:.1f} s; query: mean {result.mean_query_seconds:.2f} s,"
        f" max {result.max_query_seconds:.2f} s\nresults: {out}"
    )
