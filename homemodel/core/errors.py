"""The one exception hierarchy of homemodel.

The library raises these and never prints or exits; the CLI turns them into a
one-line message and exit code 2.
"""

import contextlib
import errno
from collections.abc import Iterator
from pathlib import Path

# What the system says when an output cannot be written: the user's to fix, not a bug (EISDIR,
# ENOTDIR: a file's output path given as a folder, or under a file).
WRITE_ERRNOS = frozenset(
    {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EPERM, errno.EFBIG, errno.EISDIR, errno.ENOTDIR}
)


class HomemodelError(Exception):
    """Base of every error homemodel raises on purpose."""


class InputError(HomemodelError):
    """A file or value given by the user is missing, unreadable or impossible."""


class SpecError(InputError):
    """A measurement spec (YAML) is invalid; the message names the file and the field."""


class UnsafeXMLError(InputError):
    """An XML file uses a DOCTYPE, entities, or exceeds the size bound."""


class MapError(HomemodelError):
    """A semantic map is invalid or a query on it cannot be answered."""


class ModelError(HomemodelError):
    """An articulated model is inconsistent (unknown link, cycle, two roots, ...)."""


class OutputExistsError(HomemodelError):
    """An output folder is not empty and --force was not given."""


class OutputError(HomemodelError):
    """An output cannot be written: a full disk, a read-only or immutable folder."""


@contextlib.contextmanager
def errors_naming(source: Path | str) -> Iterator[None]:
    """Prefix `source` to a HomemodelError raised in the block that does not name it yet, so a
    message deep in a pipeline ("no depth point fell inside ...") still says which input."""
    try:
        yield
    except HomemodelError as exc:
        if str(source) in str(exc):
            raise
        raise type(exc)(f"{source}: {exc}") from None
