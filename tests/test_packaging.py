"""The packages stand alone: what setuptools ships (the packages and their package data,
built by its own build_py into a folder outside the checkout) runs with the checkout out of
reach, finds its catalogue, validator script and summary schema, and names how to install the
npm package it cannot find."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import trimesh

REPO = Path(__file__).resolve().parents[1]

# Run in the shipped copy: where each module came from, the spec forms' examples, and the
# gate's glTF check, as JSON.
PROBE = """
import json, sys
from pathlib import Path
import homemodel.model_folder.gate.gltf as gltf
import homemodel, homemodel.app.blender.spec_forms as forms
from homemodel.core.summary_files import SUMMARY_SCHEMAS
kinds = forms.spec_kinds()
check = gltf.khronos_check(Path(sys.argv[1]))
print(json.dumps({
    "files": [homemodel.__file__, forms.__file__, str(gltf.VALIDATOR_SCRIPT), *(str(s.path()) for s in SUMMARY_SCHEMAS)],
    "schemas_as_generated": [s.file_name for s in SUMMARY_SCHEMAS if json.loads(s.path().read_text()) == s.schema()],
    "kinds": len(kinds),
    "with_examples": sorted(k for k, v in kinds.items() if set(v["example"]) - {"kind"}),
    "check": [check.passed, check.detail],
}))
"""


@pytest.fixture(scope="module")
def shipped(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The packages as a wheel would hold them, from setuptools' build_py."""
    root = tmp_path_factory.mktemp("shipped")
    command = [sys.executable, "-c", "from setuptools import setup; setup()", "-q",
               "egg_info", "--egg-base", str(root), "build_py", "--build-lib", str(root / "lib")]  # fmt: skip
    done = subprocess.run(command, cwd=REPO, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    return root / "lib"


def _probe(lib: Path, glb: Path, **env: str) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in ("HOMEMODEL_NODE_MODULES", "PYTHONPATH")}
    done = subprocess.run(
        [sys.executable, "-c", PROBE, str(glb)], cwd=glb.parent, capture_output=True, text=True, timeout=120,
        env={**clean, "PYTHONPATH": str(lib), **env},
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_the_shipped_packages_run_without_the_checkout(shipped: Path, tmp_path: Path) -> None:
    from homemodel.core.node_packages import node_modules_folders

    glb = tmp_path / "box.glb"
    glb.write_bytes(trimesh.Scene(trimesh.creation.box(extents=(0.1, 0.2, 0.3))).export(file_type="glb"))
    from modeller.kinds import SPEC_TYPES

    in_catalogue = sorted(set(SPEC_TYPES) & {path.stem for path in (REPO / "examples" / "catalogue").glob("*.yaml")})

    alone = _probe(shipped, glb)
    assert all(Path(f).is_relative_to(shipped) for f in alone["files"]), alone["files"]
    # each summary file's JSON Schema ships, as its model generates it
    assert alone["schemas_as_generated"] == ["summary.json", "home_summary.json", "export_summary.json"]
    assert alone["kinds"] == len(SPEC_TYPES) and alone["with_examples"] == in_catalogue and len(in_catalogue) >= 20
    if not any((folder / "gltf-validator").is_dir() for folder in node_modules_folders()[2:]):  # none installed -g
        assert alone["check"][0] is False and "npm install -g gltf-validator@" in alone["check"][1]

    told = _probe(shipped, glb, HOMEMODEL_NODE_MODULES=str(REPO / "tools" / "node_modules"))
    assert told["check"] == [True, "0 errors, 0 warnings"]

