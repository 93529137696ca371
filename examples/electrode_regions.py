"""Actuate one half of a DEMES film: two electrodes, the left one driven, in both solvers.

Run: python examples/electrode_regions.py   (about 10 s once DR is compiled). The film of the
paper's DEMES is split into two electrodes along its axis; the voltage on the left one uncurls
the frame less than the whole film would, and DR's triangles and the FEM's P1 (one discrete
problem) agree. DEMES_QUICK=1 runs it on a coarse mesh (what the tests do).
"""

import os

import dr
import scenes
from fem_reference.actuation import voltage_sweep

quick = os.environ.get("DEMES_QUICK") == "1"
scene = scenes.paper_demes(prestretch=1.2, **{"mesh.divisions": 8 if quick else 14,
                                              "dr.membrane_net": "triangles"})
# polygons in the flat scene (mm); they may reach past the film and share a side
two = scene.updated(electrodes=[
    {"name": "left", "region": [[-60, -10], [0, -10], [0, 80], [-60, 80]]},
    {"name": "right", "region": [[0, -10], [60, -10], [60, 80], [0, 80]]},
])
volts = [0.0, 1000.0, 2000.0]
runs = {"DR, left driven": dr.voltage_sweep(two, volts, electrodes=["left"]),
        "FEM, left driven": voltage_sweep(two, volts, electrodes=["left"]),
        "DR, whole film": dr.voltage_sweep(scene, volts)}
for label, states in runs.items():
    for res in states:
        print(f"{label:17s} V = {res.info['voltage_V']:6.0f} V: bending angle {res.bending_angle:7.3f} deg, "
              f"E_cap {res.info['capacitor_energy']:.4f} N mm, {res.status}")
