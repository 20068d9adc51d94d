"""What a command's child process imports: the suite and the Blender extension start hundreds
of `homemodel` children, and a command that needs no mesh must not pay the 1.3-1.6 CPU-s of
trimesh (with scipy and networkx) before it starts."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from cli_promise import REPO

MESH_LIBRARIES = ("trimesh", "scipy", "networkx", "open3d", "sklearn")


def _imported_by_command(*args: object) -> list[str]:
    """The mesh libraries loaded once `homemodel ARGS` has run in a fresh interpreter."""
    code = (
        "import json, sys\n"
        "from homemodel.cli.launcher import main\n"
        f"sys.argv = ['homemodel', *{[str(a) for a in args]!r}]\n"
        "try:\n    main()\nexcept SystemExit as done:\n    assert done.code in (0, None), done.code\n"
        f"print(json.dumps([m for m in {MESH_LIBRARIES!r} if m in sys.modules]))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=REPO, timeout=120,
                          env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin"})
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.splitlines()[-1])


def test_printing_a_turntable_board_imports_no_mesh_library(tmp_path: Path) -> None:
    assert _imported_by_command("turntable", "board", "--out", tmp_path / "board") == []
    assert (tmp_path / "board" / "board.yaml").is_file() and (tmp_path / "board" / "board.pdf").is_file()


def test_describing_a_blender_glb_imports_no_mesh_library(tmp_path: Path) -> None:
    """The extension's glb import: the strict GLB reader gives the arrays, trimesh is not needed."""
    from homemodel.exchange import blender_document as keys
    from homemodel.exchange.glb import pack_glb

    model = json.dumps({"name": "cup", "category": "cup", "affordances": [], "properties": {}})
    glb = tmp_path / "scene.glb"
    glb.write_bytes(pack_glb({"asset": {"version": "2.0"}, "nodes": [{"extras": {keys.MODEL: model, keys.LINK: "base"}}]}))
    assert _imported_by_command("addon", "describe", glb, "--out", tmp_path / "doc.json") == []
    doc = json.loads((tmp_path / "doc.json").read_text())
    assert doc["format"] == keys.MODEL_FORMAT and [link["name"] for link in doc["links"]] == ["base"]


def test_turntable_reconstruct_stays_the_entry_function_whichever_is_imported_first() -> None:
    """The package imports its pipeline lazily; the submodule of the same name, once imported,
    must not take the entry function's place (`turntable.reconstruct(...)`, README)."""
    import importlib

    module = importlib.import_module("turntable.reconstruct")
    import turntable
    from turntable import ReconstructOptions, reconstruct

    assert reconstruct is module.reconstruct and turntable.reconstruct is module.reconstruct
    assert callable(turntable.reconstruct) and ReconstructOptions is module.ReconstructOptions
