"""Form-find the paper's DEMES by dynamic relaxation at a few pre-stretches and write VTK.

Run: python examples/solve_paper_demes.py   (about 20 s; then open out/example/dr_strip.pvd in
ParaView, or look at out/example/dr_strip.png). DEMES_QUICK=1 runs it on a coarse mesh in seconds
(what the tests do).
"""

import os
from pathlib import Path

import dr
import scenes
from results import level_label, write_pvd
from results.render import render_states

quick = os.environ.get("DEMES_QUICK") == "1"
out = Path("out/example")
# the real 4 x 0.127 mm strip (the default); frame_model="paper" is Table I's isotropic beam
scene = scenes.paper_demes(frame_model="strip", **({"mesh.divisions": 8} if quick else {}))
states, entries = [], []
for res in dr.sweep(scene, [1.1, 1.3, 1.5]):
    print(f"{level_label(res.prestretch)}: {res.status:13s} bending angle {res.bending_angle:7.2f} deg, "
          f"apex {res.apex.round(2)} mm, energy {res.energy['total']:.4g} N mm, {res.wall_time:.1f} s")
    entries.append((res.prestretch, res.write_vtk(out / f"dr_strip_{level_label(res.prestretch)}.vtu")))
    states.append(res)
write_pvd(out / "dr_strip.pvd", entries)
print("wrote", render_states(states, out / "dr_strip.png", "DR, strip frame"))
