"""One entry's build as a worker gets it. Its own module so that both the tasks, which the
process running the build imports, and `entry_build`, which only the workers import, use it
without importing each other."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from homemodel.app.database.manifest import Job, RepairSpec


@dataclass(kw_only=True)
class BuildRequest:
    """What a worker needs: the job, its key, where the database lives, how to repair."""

    job: Job
    key: str
    db_dir: Path
    repair: RepairSpec | None  # None: imported assets are not repaired
