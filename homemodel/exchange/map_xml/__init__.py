"""Load and save semantic maps: parsed safely, validated against the XSD both ways, written
atomically and deterministically."""

from __future__ import annotations

import functools
from pathlib import Path

from lxml import etree

from homemodel.core.atomic import write_bytes_atomic
from homemodel.core.errors import MapError, OutputError
from homemodel.core.safe_xml import parse_xml_bytes, parse_xml_file
from homemodel.exchange.map_xml.read import apartment_from_tree
from homemodel.exchange.map_xml.write import NAMESPACE, apartment_to_bytes
from semantic_map.hierarchy import SemanticMap

SCHEMA_PATH = Path(__file__).parent / "semantic_map.xsd"


@functools.cache
def _schema() -> etree.XMLSchema:
    return etree.XMLSchema(parse_xml_file(SCHEMA_PATH))


def _first_error(tree: etree._ElementTree) -> etree._LogEntry | None:
    schema = _schema()
    if schema.validate(tree):
        return None
    return schema.error_log[0]


def _readable(message: str) -> str:
    return message.replace(f"{{{NAMESPACE}}}", "")


def validate_tree(tree: etree._ElementTree, source: str) -> None:
    """Raise MapError naming `source`, the line and the problem unless `tree` fits the XSD."""
    error = _first_error(tree)
    if error is not None:
        raise MapError(f"{source}: line {error.line}: {_readable(error.message)}")


def load_map(path: Path) -> SemanticMap:
    """Read and validate a map file; errors name the file, the line and the problem."""
    path = Path(path)
    tree = parse_xml_file(path)
    validate_tree(tree, str(path))
    return SemanticMap(apartment_from_tree(tree, str(path)))


def map_to_bytes(smap: SemanticMap) -> bytes:
    """The map's XML document, checked against the XSD; the same map gives the same bytes."""
    try:
        data = apartment_to_bytes(smap.apartment)
    except ValueError as exc:  # lxml refuses NUL bytes and control characters
        raise MapError(f"the map holds text XML cannot carry: {exc}") from None
    tree = parse_xml_bytes(data, "map")
    error = _first_error(tree)
    if error is not None:
        # Name the object holding the offending line: a line number of an unwritten file helps no one.
        element = next((el for el in tree.iter() if el.sourceline == error.line), tree.getroot())
        owner = next((a.get("id") for a in [element, *element.iterancestors()] if a.get("id")), None)
        where = f" (in {owner!r})" if owner else ""
        raise MapError(f"the map is invalid{where}: {_readable(error.message)}")
    return data


def save_map(smap: SemanticMap, path: Path) -> None:
    """Validate, then write atomically: a failed save leaves the old file untouched."""
    path = Path(path)
    try:
        data = map_to_bytes(smap)
    except MapError as exc:
        raise MapError(f"{path}: not saved: {exc}") from None
    try:
        write_bytes_atomic(path, data)
    except OutputError as exc:  # a full disk, a read-only folder: already names the file
        raise MapError(str(exc)) from None
    except OSError as exc:
        raise MapError(f"{path}: cannot write: {exc.strerror or exc}") from None
