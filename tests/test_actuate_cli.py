"""``demes actuate`` end to end on a coarse mesh: DR and FEM on one discrete problem."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from validation.actuation.actuate import parse_voltages
from validation.cli import main
from validation.actuation.electromechanics import capacitor_energy


def _rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


@pytest.mark.slow
def test_actuate_both_solvers(tmp_path, capsys):
    out = tmp_path / "act"
    sets = ["--set", "mesh.divisions=6", "--set", 'dr.membrane_net="triangles"']
    code = main(["actuate", "--frame-model", "strip", "--prestretch", "1.15", *sets,
                 "--voltage", "0:3000:1500", "--solver", "both", "--out", str(out), "--no-progress"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "DR against FEM over 3 voltages" in printed
    runs = {s: _rows(out / f"actuate_{s}_strip.csv") for s in ("dr", "fem")}
    for solver, rows in runs.items():
        volts = [float(r["voltage [V]"]) for r in rows]
        assert volts == [0.0, 1500.0, 3000.0]
        assert (out / f"actuate_{solver}_strip_1500V.vtu").exists()
        stroke = np.array([float(r["stroke [deg]"]) for r in rows])
        assert stroke[0] == 0.0 and np.all(np.diff(stroke) > 0)  # the frame uncurls as V rises
        for r in rows[1:]:
            # E_cap = integral of eps V^2 / 2h over the current area >= A C V^2 / 2 with the
            # mean thickness (Cauchy-Schwarz), and close to it for a nearly uniform film
            v, area, h = (float(r[k]) for k in ("voltage [V]", "film_area [mm^2]", "film_thickness [mm]"))
            mean_field = capacitor_energy(v, area, h, 4.65)
            assert mean_field <= float(r["energy_capacitor [N mm]"]) <= 1.05 * mean_field
    for a, b in zip(runs["dr"], runs["fem"]):  # the same discrete problem: the same states
        assert float(a["bending_angle [deg]"]) == pytest.approx(float(b["bending_angle [deg]"]), abs=0.05)
    text = (out / "actuate_fem_strip.pvd").read_text()
    assert 'timestep="1500"' in text and (out / "stroke_voltage.png").exists()
    report = (out / "report.md").read_text()
    assert "## Against the experiment" in report and "stroke_voltage.png" in report
    assert "data:image/png;base64" in (out / "index.html").read_text()


def test_voltage_labels_exact_on_the_grid():
    v = parse_voltages("0:0.3:0.1")
    assert v.labels == ("0", "0.1", "0.2", "0.3") and v.values[3] == 0.3
    assert parse_voltages("0:3000:100").labels[15] == "1500"
    assert parse_voltages("500, 2250").values == (500.0, 2250.0)


@pytest.mark.parametrize("text, words", [("-100:3000:100", "negative"), ("0:3000:-5", "step"),
                                          ("3000:0:100", "stop is below start"), ("0:abc:1", "not a number"),
                                          ("1000,500", "increase"), ("0:1e9:0.001", "at most")])
def test_bad_voltage_ranges(text, words, tmp_path, capsys):
    code = main(["actuate", f"--voltage={text}", "--out", str(tmp_path), "--no-progress"])
    assert code == 2
    err = capsys.readouterr().err
    assert words in err and "Traceback" not in err


def test_a_voltage_on_the_clustered_net_is_refused(tmp_path, capsys):
    code = main(["actuate", "--solver", "dr", "--set", "mesh.divisions=6", "--voltage", "0:1000:500",
                 "--out", str(tmp_path), "--no-progress"])
    assert code == 2
    err = capsys.readouterr().err
    assert "dr.membrane_net" in err and "Traceback" not in err
