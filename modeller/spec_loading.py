"""Read a YAML measurement spec into its pydantic model; write the specs' JSON Schemas.

Every failure is one `SpecError` line naming the file and the dotted field, e.g.
`cupboard.yaml: doors.0.width_m: door is 0.9 m wide but the cupboard is 0.8 m`.
"""

from __future__ import annotations

from pathlib import Path

from homemodel.core.atomic import write_json
from homemodel.core.errors import InputError, SpecError
from homemodel.core.input_files import confined_path
from homemodel.core.yaml_specs import FieldError, read_yaml_mapping, validate_mapping
from modeller.kinds import SPEC_TYPES
from modeller.specs import Spec


def load_spec(path: Path) -> Spec:
    """Parse and check the spec at `path`; its `kind` field selects the model type."""
    path = Path(path)
    data = read_yaml_mapping(path)
    kinds = ", ".join(SPEC_TYPES)
    if "kind" not in data:
        raise SpecError(f"{path}: kind: missing; expected one of {kinds}")
    spec_type = SPEC_TYPES.get(data["kind"]) if isinstance(data["kind"], str) else None
    if spec_type is None:
        raise SpecError(f"{path}: kind: unknown kind {data['kind']!r}; expected one of {kinds}")
    return _with_checked_photos(path, validate_mapping(path, data, spec_type))


def _with_checked_photos(path: Path, spec: Spec) -> Spec:
    """The spec with its photos' paths made absolute from the spec's folder, each photo read
    and its face's corners found, so a bad photo is refused before anything is built."""
    if not spec.photos:
        return spec
    from modeller.photo_texture import check_photo

    photos = []
    for i, photo in enumerate(spec.photos):
        try:
            photo = photo.model_copy(update={"photo": confined_path(path.parent, photo.photo, folder_role="spec's folder")})
        except InputError as exc:
            raise SpecError(f"{path}: photos.{i}.photo: {exc}") from None
        try:
            check_photo(photo)
        except FieldError as exc:
            raise SpecError(f"{path}: photos.{i}.{'.'.join(str(part) for part in exc.loc)}: {exc}") from None
        photos.append(photo)
    return spec.model_copy(update={"photos": photos})


def write_spec_schemas(out_dir: Path) -> list[Path]:
    """Write `<kind>.schema.json` for every spec kind into `out_dir` (for editors and the add-on)."""
    out_dir = Path(out_dir)
    paths = []
    for kind, spec_type in SPEC_TYPES.items():
        path = out_dir / f"{kind}.schema.json"
        write_json(path, spec_type.model_json_schema())
        paths.append(path)
    return paths
