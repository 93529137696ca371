"""Form-find the paper's DEMES by dynamic relaxation at a few pre-stretches and write VTK.

Run: python examples/solve_paper_demes.py   (then open out/example/dr_strip.pvd in ParaView)
"""

from pathlib import Path

import dr
import scenes

out = Path("out/example")
scene = scenes.paper_demes(frame_model="strip")  # the real 4 x 0.127 mm strip; "paper" = Table I
for res in dr.sweep(scene, [1.1, 1.3, 1.5]):
    print(f"{res.prestretch:.2f}: {res.status:13s} bending angle {res.bending_angle:7.2f} deg, "
          f"apex {res.apex.round(2)} mm, energy {res.energy['total']:.4g} N mm, {res.wall_time:.1f} s")
    res.write_vtk(out / f"dr_strip_{res.prestretch:.2f}.vtu")
