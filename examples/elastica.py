"""A cantilever of the real frame strip under a tip load, against the exact elastica.

Run: python examples/elastica.py   (a few seconds; DEMES_QUICK=1: 10 and 20 segments only)
"""

import os

import numpy as np

import dr
from validation.common.closed_forms import elastica_cantilever

EA, EI, L = 1300.0, 0.78, 80.0  # Table I strip, N and N mm^2; length mm
for segments in (10, 20) if os.environ.get("DEMES_QUICK") == "1" else (10, 20, 40):
    x = np.zeros((segments + 1, 3))
    x[:, 0] = np.linspace(0.0, L, segments + 1)
    m = dr.Model(x)
    m.clamp(0, (1.0, 0.0, 0.0))
    m.add_beam(np.arange(segments + 1), EI=EI, EA=EA)
    m.add_load(segments, (0.0, 0.0, -3.0 * EI / L**2))  # P L^2 / EI = 3
    res = dr.relax(m, tol=1e-8)
    x_ref, z_ref, _ = elastica_cantilever(3.0)
    err = np.hypot(res.x[-1, 0] / L - x_ref, -res.x[-1, 2] / L - z_ref) / np.hypot(x_ref, z_ref)
    print(f"{segments:3d} segments: tip error {err:.2e}, {res.iterations} steps, {res.wall_time:.2f} s")
