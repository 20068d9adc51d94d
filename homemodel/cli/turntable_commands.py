"""`homemodel turntable board|simulate|reconstruct|import|capture`: the AprilTag turntable (D3.1
section 3.3.3), and real cameras' recordings and live streams as its captures."""

from __future__ import annotations

import io
import os
import sys
from pathlib import Path
from typing import Literal

import typer
from rich.console import Console

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
from homemodel.cli.progress import figures_table, make_console, stage_bars

turntable_app = typer.Typer(no_args_is_help=True)

SIMULATION = "turntable.simulate:SimulationOptions"
RECONSTRUCT = "turntable.reconstruction:ReconstructOptions"
IMPORT = "turntable.recordings.importer:ImportOptions"


def _console_beside_blender() -> Console:
    """A console on a copy of stdout's descriptor: while Blender renders, fds 1 and 2 are
    redirected to swallow its log, and the progress bar must stay visible."""
    try:
        fd = os.dup(sys.stdout.fileno())
    except (AttributeError, OSError, io.UnsupportedOperation):  # not a real file (a test runner)
        return make_console()
    stream = open(fd, "w", buffering=1, encoding="utf-8")  # noqa: SIM115 (lives as long as the command)
    return Console(file=stream, width=None if stream.isatty() else 120)


@turntable_app.command()
@from_options
def board(
    out: Path = typer.Option(..., "--out", help="output folder: board.pdf and board.yaml"),
    # The simulator's default board is the one printed by default.
    diameter_m: float = field_option(f"{SIMULATION}.table_diameter_m", "--diameter-m", help="table diameter (m)"),
    tag_size_m: float = field_option(f"{SIMULATION}.tag_size_m", help="edge of each tag's black square (m)"),
    paper: str = field_option("turntable.board_pdf:write_board_pdf.paper", help="paper size; large tables tile over pages"),
    first_id: int = field_option("turntable.board:grid_board.first_id", help="first tag36h11 id to use"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Write a printable, true-to-scale tag36h11 grid for a round table, and its board.yaml."""
    from homemodel.core.atomic import atomic_dir
    from homemodel.core.errors import InputError
    from turntable.board import grid_board, save_board
    from turntable.board_pdf import write_board_pdf

    with exit_on_error():
        try:
            layout = grid_board(table_diameter_m=diameter_m, tag_size_m=tag_size_m, first_id=first_id)
        except ValueError as exc:
            raise InputError(f"board: {exc}") from None
        with atomic_dir(out, force=force) as tmp:
            pages = write_board_pdf(layout, tmp / "board.pdf", paper=paper)
            save_board(layout, tmp / "board.yaml")
    ids = [t.id for t in layout.tags]
    make_console().print(
        figures_table(
            "homemodel turntable board",
            [
                ("table diameter", f"{diameter_m * 1000:.0f} mm"),
                ("tag size", f"{tag_size_m * 1000:g} mm"),
                ("tags", f"{len(ids)} (ids {ids[0]}-{ids[-1]})"),
                ("pages", f"{pages} x {paper}"),
            ],
        )
    )
    typer.echo(f"board: {out / 'board.pdf'} (print at 100 %), {out / 'board.yaml'}")


@turntable_app.command()
@from_options
def simulate(
    mesh: Path = typer.Argument(..., help="object mesh (PLY, OBJ, STL, GLB...), metres unless --mesh-scale"),
    out: Path = typer.Option(..., "--out", help="capture folder to write"),
    frames: int = field_option(f"{SIMULATION}.frames", help="frames over one turn"),
    width_px: int = field_option(f"{SIMULATION}.width_px", "--width-px", old=("--width",), help="image width"),
    height_px: int = field_option(f"{SIMULATION}.height_px", "--height-px", old=("--height",), help="image height"),
    fov_deg: float = field_option(f"{SIMULATION}.horizontal_fov_deg", "--fov-deg", help="horizontal field of view"),
    camera_distance_m: float = field_option(
        f"{SIMULATION}.camera_distance_m", help="tripod's horizontal distance from the axis"
    ),
    camera_height_m: float = field_option(f"{SIMULATION}.camera_height_m", help="camera height above the table top"),
    diameter_m: float = field_option(
        f"{SIMULATION}.table_diameter_m", "--diameter-m", help="table diameter (m) of the generated board"
    ),
    tag_size_m: float = field_option(f"{SIMULATION}.tag_size_m", help="tag size (m) of the generated board"),
    board_yaml: Path | None = field_option(
        f"{SIMULATION}.board_path", "--board", help="use this board.yaml instead of a generated grid"
    ),
    lighting: str = field_option(f"{SIMULATION}.lighting", help="studio lights, or an even ambient light"),
    renderer: str = field_option(
        f"{SIMULATION}.renderer", help="colour by Blender's Cycles, or by ray casting (direct light, less CPU)"
    ),
    samples: int = field_option(f"{SIMULATION}.samples", help="Cycles samples per pixel"),
    depth_format: str = field_option(f"{SIMULATION}.depth_format", help="16-bit PNG or float EXR depth"),
    depth_scale_m: float = field_option(f"{SIMULATION}.depth_scale_m", help="metres per unit of the depth PNGs"),
    depth_noise_m: float = field_option(
        f"{SIMULATION}.depth_noise_m", help="depth noise std at 0.7 m (grows with depth^2); 0: none"
    ),
    mesh_scale: float = field_option(f"{SIMULATION}.mesh_scale"),
    seed: int = field_option(f"{SIMULATION}.random_state", "--seed", help="seed of the depth noise and the sampling"),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Render a synthetic turntable capture of MESH (colour by Cycles or ray casting; depth, poses, truth)."""
    from turntable.simulate import SimulationOptions, simulate_capture

    options = SimulationOptions(
        frames=frames,
        width_px=width_px,
        height_px=height_px,
        horizontal_fov_deg=fov_deg,
        camera_distance_m=camera_distance_m,
        camera_height_m=camera_height_m,
        table_diameter_m=diameter_m,
        tag_size_m=tag_size_m,
        board_path=board_yaml,
        lighting=lighting,
        renderer=renderer,
        samples=samples,
        depth_format=depth_format,
        depth_scale_m=depth_scale_m,
        depth_noise_m=depth_noise_m,
        mesh_scale=mesh_scale,
        random_state=seed,
    )
    console = _console_beside_blender()
    with exit_on_error():
        with stage_bars(console) as report:
            result = simulate_capture(mesh, out, options, force=force, progress=report)
    console.print(
        figures_table(
            f"homemodel turntable simulate {mesh}",
            [
                ("frames", str(result.frames)),
                (f"colour ({renderer})", f"{result.render_s:.1f} s ({result.render_s / result.frames:.2f} s/frame)"),
                ("depth (ray casting)", f"{result.depth_s:.1f} s"),
            ],
        )
    )
    typer.echo(f"capture: {out}")


def refuse_a_recording(capture_dir: Path) -> None:
    """A recording, or another file, given where a capture folder goes (the import step
    skipped) is refused in a line that says what to run first; the capture's own check said
    `no such capture folder` of an existing file, or named a missing camera.yaml."""
    from homemodel.core.errors import InputError
    from turntable.recordings.detect import detect_format

    if not capture_dir.exists() or (capture_dir / "camera.yaml").is_file():
        return
    try:
        form = detect_format(capture_dir)
    except InputError:
        form = None
    if form is not None:
        camera = " --camera camera.yaml" if form == "tum" else ""  # TUM carries no intrinsics
        raise InputError(
            f"{capture_dir}: a recording (format {form}), not a capture folder: import it first "
            f"(homemodel turntable import {capture_dir} --board board.yaml{camera} --out scan/), then reconstruct scan/"
        )
    if capture_dir.is_file():
        raise InputError(f"{capture_dir}: a file, not a capture folder (camera.yaml, board.yaml, color/, depth/)")


@turntable_app.command()
@from_options
def reconstruct(
    capture_dir: Path = typer.Argument(..., help="capture folder: camera.yaml, board.yaml, color/, depth/"),
    out: Path = typer.Option(..., "--out", help="model folder to write"),
    name: str = field_option(f"{RECONSTRUCT}.name", help="model name"),
    voxel_size_m: float = field_option(f"{RECONSTRUCT}.voxel_size_m", help="merging voxel size (m): the finest detail the mesh keeps"),
    detector: str = field_option(f"{RECONSTRUCT}.detection.detector", help="tag detector"),
    srgb: bool | None = typer.Option(
        None,
        "--srgb/--linear",
        help="colour images are sRGB-encoded (most cameras) or linear; default: the capture's, measured from its tags (a simulated capture's: linear)",
        show_default=False,
    ),
    min_tags: int = field_option(f"{RECONSTRUCT}.pose.min_tags", help="frames seeing fewer board tags are skipped"),
    refine: bool = field_option(
        f"{RECONSTRUCT}.turntable_refinement",
        "--turntable-refinement/--no-turntable-refinement",
        help="refine all poses under the turntable's motion",
    ),
    texture_size_px: int = field_option(f"{RECONSTRUCT}.texture_size_px", help="baked texture size; 0: no texture"),
    density_kg_m3: float = field_option(f"{RECONSTRUCT}.density_kg_m3", help="for the inertial (kg/m^3)"),
    picture: bool = field_option(f"{RECONSTRUCT}.picture", help="also draw picture.png: the mesh with the camera orbit"),
    map_path: Path | None = MAP_OPTION,
    parent_id: str | None = PARENT_OPTION,
    object_id: str | None = ID_OPTION,
    xyz: tuple[float, float, float] = XYZ_OPTION,
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Reconstruct a metric, coloured mesh from a turntable capture and export it as a model."""
    from turntable.reconstruct import reconstruct as run
    from turntable.reconstruction import ReconstructOptions
    from turntable.pose import PoseOptions
    from turntable.tags import DetectionOptions

    console = make_console()
    with exit_on_error():
        refuse_a_recording(capture_dir)
        map_entry = map_entry_from_flags(map_path, parent_id, object_id or name, xyz)
        options = ReconstructOptions(
            detection=DetectionOptions(detector=detector),
            color_encoding="auto" if srgb is None else "srgb" if srgb else "linear",
            pose=PoseOptions(min_tags=min_tags),
            voxel_size_m=voxel_size_m,
            turntable_refinement=refine,
            texture_size_px=texture_size_px,
            name=name,
            density_kg_m3=density_kg_m3,
            picture=picture,
            map_entry=map_entry,
        )
        with stage_bars(console) as progress:
            result = run(capture_dir, out, options, progress=progress, force=force)
    summary = result.summary.turntable  # the folder's summary.json: its own figures, then the common ones
    tags, errors, orbit = summary.tags_per_frame, summary.reprojection_error_px, summary.orbit
    rows = [
        ("frames used", f"{summary.frames_used} of {summary.frames_total} ({summary.frames_skipped} skipped)"),
        ("tags per frame", f"{tags.mean:.1f} (min {tags.min}, max {tags.max})"),
        ("reprojection error", f"{errors.mean:.3f} px (max {errors.max:.3f})"),
        ("orbit radius / circle RMS", f"{orbit.radius_m * 1000:.1f} mm / {orbit.circle_rms_m * 1000:.3f} mm"),
    ]
    if summary.turntable_refinement is not None:
        fit = summary.turntable_refinement
        verdict = "applied" if fit.accepted else "rejected (kept PnP poses)"
        rows.append(("turntable refinement", f"{verdict}: {fit.rms_px:.3f} px vs PnP {fit.pnp_rms_px:.3f} px"))
    encoding = summary.color_encoding
    rows += [
        ("colour encoding", f"{encoding.color_encoding} ({encoding.decided_by})"),
        ("turn seen / largest gap", f"{summary.turn.seen_fraction:.0%} / {summary.turn.largest_gap_deg:.0f} deg"),
        ("points merged / after outliers", f"{summary.points_merged} / {summary.points_after_outlier_removal}"),
        ("triangles", f"{summary.triangles} (watertight: {'yes' if summary.watertight else 'no'})"),
        ("extent", " x ".join(f"{v * 1000:.1f}" for v in result.summary.extents_m) + " mm"),
    ]
    rows += [(f"time: {stage}", f"{seconds:.2f} s") for stage, seconds in result.summary.times_s.items()]
    console.print(figures_table(f"homemodel turntable reconstruct {capture_dir}", rows))
    for stem, reason in list(result.skipped.items())[:5]:
        console.print(f"skipped {stem}: {reason}")
    if (gap := result.turn.warning()) is not None:
        console.print(f"warning: {gap}", soft_wrap=True)  # one line, however long
    typer.echo(f"model: {out}")
    if result.registration is not None:
        echo_registration(result.registration)


@turntable_app.command("import")
@from_options
def import_(
    recording: Path = typer.Argument(..., help="RealSense .bag, ROS 1 .bag, ROS 2 bag folder, TUM or Open3D folder"),
    board_yaml: Path = typer.Option(..., "--board", help="the turntable's board.yaml"),
    out: Path = typer.Option(..., "--out", help="capture folder to write"),
    camera_yaml: Path | None = field_option(
        f"{IMPORT}.camera_path",
        "--camera",
        help="camera.yaml for recordings without intrinsics (TUM; a file's own intrinsics win), and/or "
        "color_from_depth: the depth camera's pose for a recording without it (a ROS bag without /tf_static)",
    ),
    form: str | None = field_option(f"{IMPORT}.format", "--format", help="default: told from the recording's layout"),
    every: int = field_option(f"{IMPORT}.every", help="keep one frame in N (thins a long recording: --every 6 keeps 150 of 900)"),
    start_s: float = field_option(f"{IMPORT}.start_s", "--start", help="skip the recording's first S seconds"),
    end_s: float | None = field_option(f"{IMPORT}.end_s", "--end", help="stop S seconds after the recording's start (cut it to one turn)"),
    depth_units_m: float | None = field_option(
        f"{IMPORT}.depth_units_m",
        help="metres per unit of the 16-bit depth, when not the format's (a TUM-layout folder in mm: 0.001); "
        "default: the recording's own",
    ),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Turn a real RGB-D camera's recording into a capture folder (depth registered to colour)."""
    from homemodel.core.errors import InputError
    from turntable.recordings import ImportOptions, import_recording

    console = make_console()
    with exit_on_error():
        options = ImportOptions(
            format=form,
            camera_path=camera_yaml,
            every=every,
            start_s=start_s,
            end_s=end_s,
            depth_units_m=depth_units_m,
        )
        try:
            options.check()
        except ValueError as exc:
            raise InputError(f"import: {exc}") from None
        with stage_bars(console) as progress:
            report = import_recording(recording, board_yaml, out, options, progress=progress, force=force)
    dropped = report.frames_dropped
    rows = [
        ("format", report.format),
        ("frames read", f"{report.color_frames} colour, {report.depth_frames} depth"),
        ("pairs associated", f"{report.pairs_associated} (largest offset {report.max_time_offset_ms:.1f} ms)"),
        ("frames dropped", f"{dropped['color']} colour, {dropped['depth']} depth"),
        ("frames written", str(report.frames_written)),
        ("depth registration", report.registration),
        ("depth units", f"{report.depth_scale_m * 1000:g} mm"),
        ("intrinsics from", report.intrinsics_from),
        ("time", f"{report.time_s:.1f} s"),
    ]
    console.print(figures_table(f"homemodel turntable import {recording}", rows))
    for line in report.intrinsics_disagreement + report.notes:
        console.print(f"warning: {line}")
    typer.echo(f"capture: {out}")


@turntable_app.command()
@from_options
def capture(
    out: Path = typer.Option(..., "--out", help="capture folder to write"),
    board_yaml: Path = typer.Option(..., "--board", help="the turntable's board.yaml"),
    device: Literal["realsense"] = typer.Option("realsense", "--device", help="the kind of camera"),
    serial: str | None = typer.Option(None, "--serial", help="the camera's serial number (default: the only one)"),
    playback: Path | None = typer.Option(None, "--playback", help="play this RealSense .bag instead of a camera"),
    step_deg: float = field_option(
        "turntable.capture_live:LiveCaptureOptions.step_deg", help="keep a frame each time the table turned this much"
    ),
    force: bool = typer.Option(False, "--force", help="replace a non-empty output folder"),
) -> None:
    """Record one turn of the table from a connected camera; stops by itself once the circle is covered."""
    from rich.live import Live

    from homemodel.core.errors import InputError
    from turntable.board import load_board
    from turntable.capture_live import LiveCaptureOptions, LiveStatus, capture_turn
    from turntable.recordings.realsense import RealSenseSource

    console = make_console()

    def view(status: LiveStatus) -> str:
        bar = "".join("#" if seen else "." for seen in status.covered)
        lines = [
            f"frames {status.frames_seen}, kept {status.frames_kept}; turned {status.turned_deg:6.1f} deg",
            f"circle [{bar}] {status.covered.mean() * 100:.0f} %",
            f"tags seen: {len(status.tag_ids)} {status.tag_ids[:12]}",
        ]
        if status.warning:
            lines.append(f"[yellow]warning: {status.warning}[/]")
        return "\n".join(lines)

    with exit_on_error():
        options = LiveCaptureOptions(step_deg=step_deg)
        try:
            options.check()
        except ValueError as exc:
            raise InputError(f"capture: {exc}") from None
        board = load_board(board_yaml)
        source = RealSenseSource(bag=playback, serial=serial)
        with Live("waiting for frames", console=console, refresh_per_second=8, transient=True) as live:
            result = capture_turn(source, board, out, options, on_status=lambda s: live.update(view(s)), force=force)
    # Incomplete after a whole turn (the last sector's start reached): blurred or missing frames
    # left sectors empty; short of it, the capture was stopped or the recording ended early.
    whole_turn = result.turned_deg >= 360.0 * (1 - 1 / options.sectors)
    unseen = "" if result.complete else (
        " (a whole turn, but a blurred or missing frame leaves its sector empty)" if whole_turn else " (stopped early)"
    )
    rows = [
        ("frames seen / kept", f"{result.frames_seen} / {result.frames_kept}"),
        ("turned", f"{result.turned_deg:.1f} deg"),
        ("circle covered", f"{result.coverage * 100:.0f} %{unseen}"),
        ("warnings", f"{result.warnings['blur']} blurred, {result.warnings['tags']} with too few tags"),
    ]
    console.print(figures_table(f"homemodel turntable capture --device {device}", rows))
    typer.echo(f"capture: {out}")
