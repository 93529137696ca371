"""Shared test set-up: single-threaded BLAS (small arrays, shared 2-core machine), the quick
validation report (made once, used by the validation tests and the validation example)."""

import os

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")


@pytest.fixture(scope="session")
def report(tmp_path_factory):
    """``demes validate --quick`` on the paper scene: (folder, files)."""
    import scenes
    from validation.validate import validate

    out = tmp_path_factory.mktemp("report")
    files = validate(scenes.load("demes_paper"), out, quick=True, workers=2, progress=False)
    return out, files
