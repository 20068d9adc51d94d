"""The command keeps large freed blocks for reuse (`launcher.keep_freed_memory`): arrays of growing
sizes, each freed before the next, fault in about the largest one's pages, not every one's."""

from __future__ import annotations

import os
import platform
import subprocess
import sys

import pytest

from cli_promise import REPO

_PROBE = """
import resource, sys
import numpy as np
if sys.argv[1] == "kept":
    from homemodel.cli.launcher import keep_freed_memory
    keep_freed_memory()
faults = lambda: resource.getrusage(resource.RUSAGE_SELF).ru_minflt
before = faults()
for mib in [1, 2, 3, 4, 6, 8] * 3:
    block = np.ones(mib << 17)  # float64: mib MiB
    del block
print(faults() - before)
"""


def _faults(mode: str) -> int:
    # glibc's own settings from the environment (MALLOC_*_, GLIBC_TUNABLES) would set what is compared.
    env = {k: v for k, v in os.environ.items() if not k.startswith(("MALLOC_", "GLIBC_TUNABLES"))}
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, mode], capture_output=True, text=True, cwd=REPO, timeout=60, env=env
    )
    assert done.returncode == 0, done.stderr[-2000:]
    return int(done.stdout.split()[-1])


@pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="mallopt's thresholds are glibc's")
def test_freed_blocks_are_reused_not_faulted_in_again() -> None:
    largest = 8 << 20 >> 12  # pages of the 8 MiB block
    kept, default = _faults("kept"), _faults("default")
    assert kept < 1.25 * largest, (kept, default)  # once the largest block's pages, and little more
    # glibc's default gives them back: 5,131 here; where the kernel backs the heap with huge pages
    # (transparent huge pages "always") both counts are far smaller, 2,320 against 4.
    assert default > 2 * kept, (kept, default)
