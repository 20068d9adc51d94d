"""SciPy imported without its decorators parsing docstrings (`skip_scipy_doc_notes`, 0.07 CPU-s of a
completion query's imports): no docstring is parsed for them, and the decorated functions work as before."""

from __future__ import annotations

import json
import subprocess
import sys

from cli_promise import REPO

_PROBE = """
import json
from homemodel.core.scipy_doc_notes import skip_scipy_doc_notes
skip_scipy_doc_notes()
import scipy._lib._docscrape as docscrape
parsed = []
parse = docscrape.NumpyDocString._parse
docscrape.NumpyDocString._parse = lambda self: (parsed.append(1), parse(self))[1]
import numpy as np
import scipy.linalg
from scipy.cluster.vq import kmeans2
solved = scipy.linalg.solve(np.array([[2.0, 0.0], [0.0, 4.0]]), np.array([2.0, 8.0])).tolist()
batched = scipy.linalg.det(np.stack([np.eye(2), 3 * np.eye(2)])).tolist()  # the batch decorator's own work
_, cells = kmeans2(np.array([[0.0], [0.1], [10.0], [10.1]]), 2, minit="++", seed=0)
print(json.dumps([len(parsed), solved, batched, len(set(cells[:2])), len(set(cells)), scipy.linalg.solve.__doc__]))
"""


def test_scipy_imports_without_parsing_docstrings_and_works() -> None:
    done = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    parsed, solved, batched, first_cells, cells, doc = json.loads(done.stdout.splitlines()[-1])
    assert parsed == 0  # 70 or more without the skip (scipy.linalg's batch notes alone)
    assert solved == [1.0, 2.0] and batched == [1.0, 9.0]
    assert first_cells == 1 and cells == 2
    assert "Solve the equation" in doc and "batch" not in doc  # its own text, without the added note
