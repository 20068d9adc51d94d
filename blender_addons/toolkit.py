"""Running the homemodel toolkit as a child process: the extension never imports it, so
open3d, pycolmap and the toolkit's numpy never meet Blender's.

Which command runs is, in order: the HOMEMODEL_COMMAND environment variable, the
extension's preference, or `homemodel` on PATH. It may hold arguments
(`/home/me/homemodel/.venv/bin/python -m homemodel`).
"""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
from dataclasses import dataclass
from pathlib import Path

ENV_COMMAND = "HOMEMODEL_COMMAND"
DEFAULT_COMMAND = "homemodel"
MISSING_HINT = (
    "the homemodel toolkit was not found: install it (make demo) and set its path in "
    "Edit > Preferences > Add-ons > homemodel"
)


class ToolkitError(Exception):
    """The toolkit is missing or refused its input; the message is one line for the user."""


def command_words(preference: str = "") -> list[str]:
    text = os.environ.get(ENV_COMMAND) or preference or DEFAULT_COMMAND
    words = shlex.split(text)
    if not words or shutil.which(words[0]) is None:
        raise ToolkitError(f"{MISSING_HINT} (tried {text!r})")
    return words


@dataclass
class Result:
    returncode: int
    stdout: str
    stderr: str

    def error_line(self) -> str:
        """The toolkit's own one-line error (`error: ...`), or the last line it wrote."""
        lines = [line for line in self.stderr.splitlines() if line.strip()]
        errors = [line for line in lines if line.startswith("error:")]
        return (errors or lines or [f"homemodel exited with code {self.returncode}"])[-1]


def run(args: list[str], preference: str = "", *, accept: tuple[int, ...] = (0,)) -> Result:
    """Run `homemodel ARGS`; ToolkitError with the toolkit's message unless the exit code is accepted."""
    try:
        done = subprocess.run(command_words(preference) + args, capture_output=True, text=True, check=False)
    except OSError as exc:
        raise ToolkitError(f"{MISSING_HINT} ({exc})") from None
    result = Result(done.returncode, done.stdout, done.stderr)
    if done.returncode not in accept:
        raise ToolkitError(result.error_line())
    return result


def start(args: list[str], preference: str = "", *, log_path: Path, env: dict[str, str] | None = None) -> subprocess.Popen:
    """Start `homemodel ARGS` in the background, its output going to `log_path`."""
    log = open(log_path, "w", encoding="utf-8")
    try:
        with log:  # the child holds its own copy of the file
            return subprocess.Popen(
                command_words(preference) + args, stdout=log, stderr=subprocess.STDOUT, text=True, env={**os.environ, **(env or {})}
            )
    except OSError as exc:
        log.close()
        raise ToolkitError(f"{MISSING_HINT} ({exc})") from None


def read_json(path: Path):
    with open(path, encoding="utf-8") as f:
        return json.load(f)
