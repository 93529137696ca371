"""A design study on a Dask cluster: the strip DEMES's bending angle over strip thickness, film
thickness and pre-stretch (examples/design_grid.toml), as `demes sweep examples/design_grid.toml`.

Run:  python examples/design_sweep.py [--quick] [--scheduler tcp://HOST:8786 | --workers N]
(about 2 minutes on a 2-worker LocalCluster; --quick or DEMES_QUICK=1: a coarse mesh and two
pre-stretches, under a minute). The table is out/design_grid/design_grid.csv (and .parquet), the plots are in
out/design_grid/figures/; an interrupted study resumes from the points it finished.
"""

import os
import sys
from pathlib import Path

from scenes import tomllib
from validation.design.grid import grid_from_dict
from validation.design.sweep import run_design_sweep

if __name__ == "__main__":  # the LocalCluster's worker processes import this file again
    path = Path(__file__).with_name("design_grid.toml")
    data = tomllib.loads(path.read_text())
    quick = "--quick" in sys.argv or os.environ.get("DEMES_QUICK") == "1"
    if quick:
        data["set"]["mesh"]["divisions"] = 6
        data["prestretch"] = [1.05, 1.1]
    scheduler = sys.argv[sys.argv.index("--scheduler") + 1] if "--scheduler" in sys.argv else None
    grid = grid_from_dict(data, name=path.stem + ("_quick" if quick else ""), base_dir=path.parent)
    workers = int(sys.argv[sys.argv.index("--workers") + 1]) if "--workers" in sys.argv else 2
    study = run_design_sweep(grid, Path("out") / grid.name, scheduler=scheduler, workers=workers)

    angles = study.table.pivot_table(index=["frame.thickness", "membrane.thickness"], columns="prestretch",
                                     values="bending_angle")
    print("bending angle [deg] by strip thickness, film thickness [mm] (rows) and pre-stretch (columns):")
    print(angles.round(1).to_string())
    print(f"{len(study.solved)} paths solved in {study.wall_time:.0f} s; table: {study.files['csv']}")
