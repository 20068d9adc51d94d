"""`homemodel eval voxel-iou PRED GT` and `homemodel eval surface-distance PRED GT`.

PRED and GT are mesh files (OBJ, STL, PLY, OFF, glTF) or model folders (their model.glb),
in the same frame and units. Each command prints one line per figure, `name value`, so
scripts can read it; `--json` prints the same figures as one JSON object.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from homemodel.cli.errors import exit_on_error
from homemodel.cli.option_fields import field_option

eval_app = typer.Typer(no_args_is_help=True)

PRED_HELP = "reconstructed mesh file or model folder"
GT_HELP = "ground-truth mesh file or model folder, same frame and units"
SURFACE = "homemodel.evaluation.surface"


def _print_figures(figures: dict[str, float], as_json: bool) -> None:
    if as_json:
        typer.echo(json.dumps(figures))
        return
    width = max(len(name) for name in figures)
    for name, value in figures.items():
        typer.echo(f"{name:<{width}}  {value:.6g}")


@eval_app.command("voxel-iou")
def voxel_iou_command(
    pred: Path = typer.Argument(..., help=PRED_HELP),
    gt: Path = typer.Argument(..., help=GT_HELP),
    voxel_size_m: float | None = typer.Option(
        None, "--voxel-size-m", help="also the IoU on a metric grid of this voxel size (meshes' units)"
    ),
    as_json: bool = typer.Option(False, "--json", help="print the figures as one JSON object"),
) -> None:
    """VoxelIOU of two solids: Rock et al.'s (200^3 over [-2,2]^3 after joint normalisation), optionally metric."""
    from homemodel.evaluation import rock_voxel_iou, voxel_iou
    from homemodel.geometry.mesh_io import load_mesh

    with exit_on_error():
        pred_mesh, gt_mesh = load_mesh(pred), load_mesh(gt)
        figures = {"rock_voxel_iou": rock_voxel_iou(pred_mesh, gt_mesh)}
        if voxel_size_m is not None:
            figures["voxel_iou"] = voxel_iou(pred_mesh, gt_mesh, voxel_size_m=voxel_size_m)
    _print_figures(figures, as_json)


@eval_app.command("surface-distance")
def surface_distance_command(
    pred: Path = typer.Argument(..., help=PRED_HELP),
    gt: Path = typer.Argument(..., help=GT_HELP),
    samples: int = field_option(f"{SURFACE}:f_score.n_samples", "--samples", help="points sampled on each surface"),
    threshold_fraction: float = field_option(
        f"{SURFACE}:f_score.threshold_fraction",
        "--f-threshold",
        help="F-score distance threshold as a fraction of gt's bounding-box diagonal",
    ),
    seed: int = field_option(f"{SURFACE}:f_score.seed", help="seed of the surface sampling"),
    as_json: bool = typer.Option(False, "--json", help="print the figures as one JSON object"),
) -> None:
    """Surface distance: Rock et al.'s (RMS both ways / cube side), the mean in the meshes' units, and the F-score."""
    from homemodel.evaluation import (
        f_score,
        mean_surface_distance_m,
        rock_surface_distance,
    )
    from homemodel.evaluation.surface import check_sample_count, check_threshold_fraction
    from homemodel.geometry.mesh_io import load_mesh

    with exit_on_error():
        check_sample_count(samples)  # before the meshes are read: a bad option fails at once
        check_threshold_fraction(threshold_fraction)
        pred_mesh, gt_mesh = load_mesh(pred), load_mesh(gt)
        figures = {
            "rock_surface_distance": rock_surface_distance(pred_mesh, gt_mesh, n_samples=samples, seed=seed),
            "mean_surface_distance_m": mean_surface_distance_m(pred_mesh, gt_mesh, n_samples=samples, seed=seed),
            f"f_score@{threshold_fraction:g}": f_score(
                pred_mesh, gt_mesh, threshold_fraction=threshold_fraction, n_samples=samples, seed=seed
            ),
        }
    _print_figures(figures, as_json)
