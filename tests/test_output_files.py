"""Every file the project writes gets the user's umask (as any new file of theirs) and is
written atomically: no temporary file is left beside it."""

import os
import stat

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

import dr  # noqa: E402
from results import CellBlock, atomic_write_text, save_result, write_pvd, write_vtu  # noqa: E402
from validation.cli import main  # noqa: E402
from validation.common.plotting import save_figure  # noqa: E402
from validation.design.sweep import write_table  # noqa: E402
from validation.common.tables import write_csv  # noqa: E402


@pytest.fixture
def umask():
    """Set the process umask for one test, and put the old one back."""
    old = os.umask(0o022)
    yield os.umask
    os.umask(old)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def _cable_state() -> dr.Model:
    m = dr.Model(np.array([[0.0, 0, 0], [50.0, 0, 0], [100.0, 0, 0]]))
    m.support([0, 2])
    m.add_link([0, 1], [1, 2], EA=1000.0, rest_length=49.0, tension_only=True)
    m.add_load(1, (0.0, 0.0, -1.0))
    return dr.relax(m, tol=1e-6)


def _write_every_kind(folder) -> list:
    """One file of each kind the project writes (text, CSV, Parquet, VTU, PVD, NPZ, PNG)."""
    res = _cable_state()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    table = pd.DataFrame({"prestretch": [1.1, 1.2], "bending_angle": [50.0, 80.0]})
    vtu = write_vtu(folder / "s.vtu", np.eye(3), {"tri": CellBlock("triangle", np.array([[0, 1, 2]]))})
    return [
        atomic_write_text(folder / "report.md", "# report\n"),
        write_csv(folder / "rows.csv", [{"prestretch": 1.1}]),
        *write_table(table, folder, "study").values(),
        vtu,
        write_pvd(folder / "s.pvd", [(1.1, vtu)]),
        save_result(folder / "state.npz", res),
        res.write_vtk(folder / "state.vtu"),
        save_figure(fig, folder / "fig.png"),
    ]


@pytest.mark.parametrize("mask, mode", [(0o022, 0o644), (0o077, 0o600), (0o002, 0o664)])
def test_written_files_follow_the_umask(tmp_path, umask, mask, mode):
    umask(mask)
    written = _write_every_kind(tmp_path)
    assert {p.suffix for p in written} >= {".md", ".csv", ".parquet", ".vtu", ".pvd", ".npz", ".png"}
    assert {p.name: oct(_mode(p)) for p in written} == {p.name: oct(mode) for p in written}
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(p.name for p in written)


def test_demes_solve_output_is_readable_by_others_under_umask_022(tmp_path, umask, capsys):
    umask(0o022)
    out = tmp_path / "run"
    assert main(["solve", "--solver", "dr", "--mesh-levels", "6", "--prestretch", "1.0", "1.1", "--out", str(out),
                 "--no-progress"]) == 0
    files = sorted(out.iterdir())
    assert {p.suffix for p in files} >= {".csv", ".pvd", ".vtu", ".txt"}
    assert not [p.name for p in files if p.name.startswith(".")]
    assert {p.name: oct(_mode(p)) for p in files} == {p.name: "0o644" for p in files}
