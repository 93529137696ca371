"""Use the low-level DR model on any structure: a cable net with a clustered edge cable.

A square net of links, pinned at its corners, carries a point load at the middle; its free
edges are one clustered cable each (sliding over the edge nodes). Run:
python examples/custom_structure.py
"""

import numpy as np

import dr

n = 9  # nodes per side
g = np.linspace(0.0, 80.0, n)
xx, yy = np.meshgrid(g, g, indexing="ij")
nodes = np.stack([xx.ravel(), yy.ravel(), np.zeros(n * n)], axis=1)
idx = np.arange(n * n).reshape(n, n)

m = dr.Model(nodes)
m.support([idx[0, 0], idx[0, -1], idx[-1, 0], idx[-1, -1]])
# interior links, pre-tensioned by 5 % shorter rest lengths
inner_i = np.concatenate([idx[1:-2, 1:-1].ravel(), idx[1:-1, 1:-2].ravel()])
inner_j = np.concatenate([idx[2:-1, 1:-1].ravel(), idx[1:-1, 2:-1].ravel()])
rest = 0.95 * np.linalg.norm(nodes[inner_j] - nodes[inner_i], axis=1)
m.add_link(inner_i, inner_j, EA=50.0, rest_length=rest, tension_only=True)
# links from the edges to the first inner row
for edge, inner in ((idx[0, 1:-1], idx[1, 1:-1]), (idx[-1, 1:-1], idx[-2, 1:-1]),
                    (idx[1:-1, 0], idx[1:-1, 1]), (idx[1:-1, -1], idx[1:-1, -2])):
    m.add_link(edge, inner, EA=50.0, rest_length=0.95 * 10.0, tension_only=True)
# each free edge is one clustered cable from corner to corner
for chain in (idx[0, :], idx[-1, :], idx[:, 0], idx[:, -1]):
    m.add_cluster(chain, EA=500.0, rest_length=0.97 * 80.0)
m.add_load(idx[n // 2, n // 2], (0.0, 0.0, -2.0))

res = dr.relax(m, tol=1e-6)
print(res.message)
print(f"middle node deflection {res.x[idx[n // 2, n // 2], 2]:.3f} mm, "
      f"edge cable tensions {np.round(res.info['cluster_tension'], 3)} N")
res.write_vtk("out/example/cable_net.vtu")
