"""Validate DR against the FEM reference on the paper's DEMES and read the numbers back.

Run:  python examples/validate_paper_demes.py [--full]
(quick: about a minute on a coarse mesh; --full: about half an hour on two cores, level 3 of the FEM most of it). Same as
`demes validate [--quick]`; an interrupted run resumes from the states it finished. The tests run
it (quick) to make the report they check.

The report is reports/<scene>[_quick]/index.html; every number is also in metrics.json.
"""

import json
import sys
from pathlib import Path

import scenes
from results import level_label
from validation.report.validate import validate

# the runs go to a Dask LocalCluster, whose worker processes import this file again
if __name__ == "__main__":
    quick = "--full" not in sys.argv
    scene = scenes.load("demes_paper")
    out = Path("reports") / f"{scene.name}{'_quick' if quick else ''}"
    files = validate(scene, out, quick=quick)
    print(f"report: {files['html']}")

    metrics = json.loads((out / "metrics.json").read_text())
    print("lambda  theta FEM [deg]  theta DR matched [deg]  shape RMS DR matched [/side]")
    for row in metrics["headline"]:
        print(f"{level_label(row['prestretch']):>6s}  {row['theta_fem']:14.2f}  {row['theta_matched']:22.2f}  "
              f"{row.get('shape_rms_matched', float('nan')):28.4f}")
    for row in metrics["time_to_error"]:  # None: not reached by that method in this study
        print(f"time to {row['shape_error']:.1%} shape error: DR {row['time_dr']} s, FEM {row['time_fem']} s, "
              f"FEM / DR {row['ratio_fem_over_dr']}")
