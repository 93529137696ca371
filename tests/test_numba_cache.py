"""Compiled kernels follow the sources: an edit of a function another module inlines runs at
the next import (numba stamps a cached kernel with its own file only)."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# one membrane link of EA 1 N, rest length 1 mm, stretched to 2 mm: N = 1 N, N eps L0 / 2 = 0.5 N mm
SCRIPT = """
import numpy as np, dr
from dr.links import strain_energy
assert dr.__file__.startswith({root!r}), dr.__file__
m = dr.Model(np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]]))
m.add_link([0], [1], 1.0, rest_length=[1.0])
P = m.pack()
print(strain_energy(np.vstack([m.nodes, np.zeros((P.n_total - P.n, 3))]), P)[0])
"""


def _energy(copy: Path) -> float:
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env.update(PYTHONPATH=str(copy), OPENBLAS_NUM_THREADS="1")
    out = subprocess.run([sys.executable, "-c", SCRIPT.format(root=str(copy))], cwd=copy, env=env,
                         capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return float(out.stdout.split()[-1])


@pytest.mark.slow
def test_an_edited_inlined_function_runs_after_the_edit(tmp_path):
    shutil.copytree(ROOT / "dr", tmp_path / "dr", ignore=shutil.ignore_patterns("__pycache__"))
    assert _energy(tmp_path) == pytest.approx(0.5)
    assert list((tmp_path / "dr" / "__pycache__").glob("links.strain_energy-*.nbi"))  # it was cached
    vec = tmp_path / "dr" / "vec.py"
    source = vec.read_text()
    old = "return math.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])"
    assert source.count(old) == 1
    vec.write_text(source.replace(old, "return 2.0 * " + old[len("return "):]))  # |d| reads 4 mm
    # N = 3 N, eps = 3: 4.5 N mm; the stale kernel would still give 0.5
    assert _energy(tmp_path) == pytest.approx(4.5)
