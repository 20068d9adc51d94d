"""Editing measurement specs in tests: read an example, change one field, write it back."""

from __future__ import annotations

import copy
from pathlib import Path

import yaml


def read_spec(path: Path) -> dict:
    return yaml.safe_load(path.read_text())


def write_spec(tmp_path: Path, data: dict, name: str = "spec.yaml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def with_field(data: dict, dotted: str, value: object) -> dict:
    """A copy of `data` with the field at the dotted path (list indices as numbers) set."""
    data = copy.deepcopy(data)
    *parents, last = [int(p) if p.isdigit() else p for p in dotted.split(".")]
    node = data
    for part in parents:
        node = node.setdefault(part, {}) if isinstance(node, dict) else node[part]
    node[last] = value
    return data
