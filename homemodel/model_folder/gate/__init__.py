"""The validation gate: a model folder, a URDF or a glb must pass every check before it is
exported, registered in a map or stored in the database."""

from homemodel.model_folder.gate.validate import validate_path

__all__ = ["validate_path"]
