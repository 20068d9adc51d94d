"""What every pipeline entry returns (`modeller.build`, `turntable.reconstruct`,
`photogrammetry.reconstruct`, `shape_completion.complete`): the model folder's summary, the map
entry the options named, and the model's registration into that map. Each pipeline's result
adds its own stages' products to this one type."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from homemodel.core.model_summary import ModelSummary

if TYPE_CHECKING:  # the map's modules (0.019 CPU-s) are imported only to register a model
    from homemodel.model_folder.map_entry import MapEntry, Registration


@dataclass(kw_only=True)
class ModelResult:
    summary: ModelSummary | None = None  # the model folder's summary.json, set by the entry
    map_entry: MapEntry | None = None  # where the options asked the model to be registered
    registration: Registration | None = None  # where it was registered, when `map_entry` was given

    def register(self, model_dir: Path, map_entry: MapEntry | None) -> None:
        """Register the model folder `model_dir` as `map_entry` says (nothing without one)."""
        self.map_entry = map_entry
        if map_entry is not None:
            from homemodel.model_folder.map_entry import add_model_folder

            self.registration = add_model_folder(model_dir, map_entry)
