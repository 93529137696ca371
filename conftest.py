"""Set-up for the whole suite (tests/, the packages' doctests, README.md and docs/*.md):
single-threaded BLAS (small arrays, shared 2-core machine), off-screen pyvista, and doctests run
in a fresh folder so that the files their examples write do not land in the working tree."""

import os

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")


@pytest.fixture(autouse=True)
def _doctests_in_a_fresh_folder(request, tmp_path, monkeypatch):
    if type(request.node).__name__ == "DoctestItem":
        monkeypatch.chdir(tmp_path)
