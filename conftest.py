"""Set-up for the whole suite (tests/, the packages' doctests, README.md and docs/*.md):
single-threaded BLAS (small arrays, shared 2-core machine), off-screen pyvista, doctests run
in a fresh folder so that the files their examples write do not land in the working tree, and
the solvers' numba kernels compiled once before the tests fan out over worker processes."""

import os
import time
from pathlib import Path

import pytest

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("PYVISTA_OFF_SCREEN", "true")


@pytest.fixture(autouse=True)
def _doctests_in_a_fresh_folder(request, tmp_path, monkeypatch):
    if type(request.node).__name__ == "DoctestItem":
        monkeypatch.chdir(tmp_path)


@pytest.hookimpl(trylast=True)  # after the terminal reporter is set up
def pytest_configure(config):
    """With the tests shared between worker processes and the kernels not yet on numba's disk
    cache (a fresh checkout, or DR's sources edited), compile them here, once, before the
    workers start: otherwise every worker, and every Dask worker a test starts, compiles the
    same kernels at the same moment (about 110 s of CPU each for DR, 16 s for the FEM,
    docs/performance.md), up to four processes on two cores."""
    if hasattr(config, "workerinput") or not config.getoption("numprocesses", None):
        return
    import dr  # clears DR's cache if its sources changed (dr/cache.py)
    import fem_reference
    import scenes
    from dr.integrator import run
    from fem_reference.rod_kernels import vertex_terms

    if all(_on_disk(kernel) for kernel in (run, vertex_terms)):
        return
    reporter = config.pluginmanager.get_plugin("terminalreporter")
    if reporter:
        reporter.write_line("compiling the solvers' kernels once for the workers (numba's cache is empty or stale)")
    start = time.perf_counter()
    tiny = {"mesh.divisions": 4}
    triangles = scenes.paper_demes(1.05, **tiny, **{"dr.membrane_net": "triangles"})
    for scene in (triangles, scenes.paper_demes(1.05, **tiny), scenes.paper_demes(1.05, "paper", **tiny),
                  scenes.paper_demes(1.05, **tiny, **{"dr.membrane_net": "links"})):
        list(dr.sweep(scene, [1.05]))
    list(dr.voltage_sweep(triangles, [0.0, 500.0]))
    for law, element in (("linear", "P1"), ("neo-hookean", "P2")):
        fem_reference.solve(triangles.updated(**{"membrane.law": law, "fem.element": element}))
    if reporter:
        reporter.write_line(f"compiled in {time.perf_counter() - start:.0f} s")


def _on_disk(kernel) -> bool:
    """Whether numba's disk cache holds a compiled ``kernel`` (a cached dispatcher)."""
    name = f"{kernel.py_func.__module__.rsplit('.', 1)[-1]}.{kernel.py_func.__qualname__}-"
    return any(Path(kernel._cache._cache_path).glob(f"{name}*.nbi"))
