"""`homemodel addon ...`: what the Blender extension asks of the toolkit, through files.

The extension runs in Blender's own Python and never imports the toolkit; it calls these
commands as a child process and reads their JSON (see `homemodel.app.blender.model_document`).
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from homemodel.cli.errors import exit_on_error

addon_app = typer.Typer(no_args_is_help=True, help="Files for the Blender extension: spec forms, model and home documents.")

OUT_FILE = typer.Option(..., "--out", help="the JSON document to write")
OUT_DIR = typer.Option(..., "--out", help="the folder to write")
FORCE = typer.Option(False, "--force", help="replace a non-empty output folder")


@addon_app.command("kinds")
def kinds() -> None:
    """Print every spec kind's JSON Schema and a filled-in example, as one JSON object."""
    from homemodel.app.blender.spec_forms import spec_kinds

    with exit_on_error():
        typer.echo(json.dumps(spec_kinds()))


@addon_app.command("check-spec")
def check_spec(spec: Path = typer.Argument(..., help="a measurement spec, YAML or JSON")) -> None:
    """Print the spec's problems as JSON, one {field, message} each; exit 1 when there are any."""
    from homemodel.app.blender.spec_forms import spec_problems

    with exit_on_error():
        problems = spec_problems(spec)
    typer.echo(json.dumps(problems))
    raise typer.Exit(1 if problems else 0)


@addon_app.command("build")
def build(
    spec: Path = typer.Argument(..., help="a measurement spec, YAML or JSON"),
    out: Path = OUT_DIR,
    name: str = typer.Option(None, "--name", help="the model's name (default: the spec's file name)"),
    force: bool = FORCE,
) -> None:
    """Build the spec into a model folder, with `blender.json`, the model document, beside it."""
    from homemodel.exchange.urdf.read import find_urdf, load_urdf
    from homemodel.app.blender.model_document import model_document
    from homemodel.core.atomic import write_json
    from homemodel.core.yaml_specs import read_yaml_mapping
    from modeller import BuildOptions
    from modeller import build as build_spec

    with exit_on_error():
        built = build_spec(spec, out, BuildOptions(name=name), force=force)
        # Read back from the folder: its textures are where the document must point.
        write_json(out / "blender.json", model_document(load_urdf(find_urdf(out)), spec=read_yaml_mapping(spec)))
    typer.echo(built.validation.format())
    raise typer.Exit(0 if built.valid else 1)


@addon_app.command("describe")
def describe(
    model: Path = typer.Argument(..., help="a model folder (model.urdf or mobility.urdf), a .urdf, or a .glb Blender exported"),
    out: Path = OUT_FILE,
) -> None:
    """Write the model document of a URDF model, or of a glb Blender's exporter wrote from a
    scene laid out with the extension (custom properties included)."""
    from homemodel.core.atomic import write_json

    with exit_on_error():
        if model.suffix.lower() == ".glb":  # the strict GLB reader alone: no trimesh in this child
            from homemodel.exchange.blender_glb import model_document_from_glb

            write_json(out, model_document_from_glb(model))
        else:
            from homemodel.exchange.urdf.read import find_urdf, load_urdf
            from homemodel.app.blender.model_document import model_document, spec_of_model_folder

            urdf = find_urdf(model)
            write_json(out, model_document(load_urdf(urdf), spec=spec_of_model_folder(urdf.parent)))


@addon_app.command("export")
def export(
    document: Path = typer.Argument(..., help="a model document the extension wrote"),
    out: Path = OUT_DIR,
    force: bool = FORCE,
) -> None:
    """Write the model folder (URDF, glb, meshes) of a model document and run the validation
    gate on it; print the gate's report; exit 1 when a check failed."""
    from homemodel.model_folder.write import PipelineSummary, write_model_folder
    from homemodel.app.blender.model_document import model_from_document
    from homemodel.exchange.blender_document import read_document

    with exit_on_error():
        model = model_from_document(read_document(document), str(document))
        written = write_model_folder(model, out, PipelineSummary(source="blender", inputs={"document": document}), force=force)
    typer.echo(written.validation.format())
    raise typer.Exit(0 if written.valid else 1)


@addon_app.command("describe-map")
def describe_map(
    map_path: Path = typer.Argument(..., metavar="MAP.xml", help="a semantic map whose objects refer to model folders"),
    out: Path = OUT_DIR,
    force: bool = FORCE,
) -> None:
    """Write home.json and one model document per object of the map, for the extension to import."""
    from homemodel.app.blender.home import describe_map as describe

    with exit_on_error():
        typer.echo(describe(map_path, out, force=force))


@addon_app.command("export-home")
def export_home(
    home: Path = typer.Argument(..., help="the home document the extension wrote"),
    out: Path = OUT_DIR,
    force: bool = FORCE,
) -> None:
    """Write map.xml and a validated model folder per object; exit 1 when a model failed the gate."""
    from homemodel.app.blender.home import export_home as export

    with exit_on_error():
        result = export(home, out, force=force)
    typer.echo(f"wrote {result.map_path}")
    for object_id, checks in result.failed.items():
        for check in checks:
            typer.echo(f"FAIL  {object_id}: {check}")
    raise typer.Exit(0 if result.ok else 1)
