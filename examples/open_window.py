"""Leave a window of a frame without film: the gripper's middle window open, in both solvers.

Run: python examples/open_window.py   (about 20 s once DR is compiled). `frame.open_windows` names
the window by a point inside it; the window's electrode goes too (an electrode needs film). The
covered segments curl, the open one, bare strip, hardly turns, and DR's triangles and the FEM's P1
(one discrete problem) give every segment's turn alike. Both states are written for ParaView,
the open window's strip bands as a block of their own. DEMES_QUICK=1 runs a coarse mesh.
"""

import os

import dr
import fem_reference
import scenes

quick = os.environ.get("DEMES_QUICK") == "1"
scene = scenes.load("multisegment_gripper")
electrodes = [e for e in scene.to_dict()["electrodes"] if e["name"] != "middle"]
scene = scene.updated(**{"frame.open_windows": [[0, 45]], "electrodes": electrodes,
                         "mesh.divisions": 6 if quick else 8, "fem.element": "P1"})
for label, states in (("DR", dr.sweep(scene, [1.15])), ("FEM", fem_reference.sweep(scene, [1.15]))):
    res = list(states)[-1]
    base, middle, tip = res.segment_turns
    print(f"{label:3s} at {res.prestretch}: turns base {base:7.3f}, middle (open) {middle:7.3f}, tip {tip:7.3f} deg, "
          f"energy {res.energy['total']:.8f} N mm, apex {res.branch}, {res.status}")
    print("written", res.write_vtk(f"out/open_window/{label.lower()}_1.15.vtu"), "with the blocks", ", ".join(res.blocks))
