"""The paper's DEMES with the scikit-fem reference: a pre-stretch sweep written for ParaView.

Run:  python examples/fem_paper_demes.py  (about a minute; writes out/fem_example/).
DEMES_QUICK=1 runs the strip on a coarse mesh in seconds (what the tests do).

The 'strip' frame (the real 4 x 0.127 mm ABS strip: weak/strong-axis bending, torsion) curls the
apex up; the paper's isotropic frame (I = 0.0003 mm^4) collapses in-plane instead, and the sweep
stops where the frame or the film first touches itself.
"""

import os
from pathlib import Path

import fem_reference
import scenes
from results import level_label, write_pvd

quick = os.environ.get("DEMES_QUICK") == "1"
out = Path("out/fem_example")
for model in ("strip",) if quick else ("strip", "paper"):
    scene = scenes.paper_demes(prestretch=1.5, frame_model=model, **({"mesh.divisions": 4} if quick else {}))
    entries = []
    for res in fem_reference.sweep(scene, [1.1, 1.3, 1.5], refinement=0):
        vtu = res.write_vtk(out / f"{model}_{level_label(res.prestretch)}.vtu")
        entries.append((res.prestretch, vtu))
        print(f"{model:6s} lambda = {level_label(res.prestretch)}  theta = {res.bending_angle:6.1f} deg  "
              f"E = {res.energy['total']:.4f} N mm  {res.status}  ({res.wall_time:.1f} s)")
        if not res.converged:
            print("       ", res.message)
    write_pvd(out / f"{model}.pvd", entries)
print(f"open {out}/strip.pvd in ParaView")
