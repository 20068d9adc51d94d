"""Where the npm packages homemodel runs (the Khronos glTF validator) and serves (three.js)
are installed; none is fetched at run time.

Looked for, in order: the `node_modules` folder named by HOMEMODEL_NODE_MODULES; a
checkout's `tools/node_modules` (what `make setup` installs, found beside the package only
when it runs from a checkout); node's global folder (`npm install -g`). An installed
homemodel has no checkout, so it needs one of the other two.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

NODE_MODULES_ENV = "HOMEMODEL_NODE_MODULES"
# The versions tools/package.json pins, for the install hint.
PINNED = {"gltf-validator": "2.0.0-dev.3.10", "three": "0.170.0"}


def node_modules_folders() -> list[Path]:
    """The folders searched for an npm package, first match wins."""
    folders = []
    if named := os.environ.get(NODE_MODULES_ENV):
        folders.append(Path(named))
    folders.append(Path(__file__).resolve().parents[2] / "tools" / "node_modules")
    if node := shutil.which("node"):
        folders.append(Path(node).resolve().parents[1] / "lib" / "node_modules")
    return folders


def find_node_package(name: str) -> Path | None:
    """The folder of the installed npm package `name`, or None."""
    for folder in node_modules_folders():
        if (folder / name / "package.json").is_file():
            return folder / name
    return None


def install_hint(name: str) -> str:
    """How to install `name`, for a one-line error."""
    pinned = f"{name}@{PINNED[name]}" if name in PINNED else name
    return (
        f"the npm package {name} is not installed: run `make setup` in a checkout, or "
        f"`npm install -g {pinned}`, or set {NODE_MODULES_ENV} to a node_modules folder that holds it"
    )
