"""Parse XML from users without DOCTYPEs, entities, network access or unbounded size.

URDFs and semantic maps come from installers and from the web (PartNet-Mobility); a
billion-laughs bomb or an external entity must be refused before any tool sees the file.
"""

from __future__ import annotations

from pathlib import Path

from lxml import etree

from homemodel.core.errors import InputError, UnsafeXMLError
from homemodel.core.input_files import read_bounded

MAX_XML_BYTES = 64 * 1024 * 1024


def _parser() -> etree.XMLParser:
    return etree.XMLParser(
        resolve_entities=False,
        no_network=True,
        load_dtd=False,
        dtd_validation=False,
        huge_tree=False,
        remove_comments=True,
        remove_pis=True,
    )


def parse_xml_bytes(data: bytes, source: str) -> etree._ElementTree:
    """Parse `data`; `source` names the file in error messages."""
    if len(data) > MAX_XML_BYTES:
        raise UnsafeXMLError(f"{source}: {len(data)} bytes is over the {MAX_XML_BYTES}-byte bound for XML")
    # A DOCTYPE is the only way to declare entities; neither URDF nor our maps need one.
    head = data[:4096].lstrip().upper()
    if b"<!DOCTYPE" in data.upper() or b"<!ENTITY" in head:
        raise UnsafeXMLError(f"{source}: DOCTYPE or entity declarations are not allowed")
    try:
        tree = etree.ElementTree(etree.fromstring(data, _parser()))
    except etree.XMLSyntaxError as exc:
        raise InputError(f"{source}: not well-formed XML: {exc}") from None
    if tree.docinfo.internalDTD is not None or tree.docinfo.externalDTD is not None:
        raise UnsafeXMLError(f"{source}: DOCTYPE declarations are not allowed")
    return tree


def parse_xml_file(path: Path) -> etree._ElementTree:
    return parse_xml_bytes(read_bounded(path, MAX_XML_BYTES), str(path))
