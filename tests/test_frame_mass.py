"""The frame mass (dr.frame_mass) bounds the stiffness it replaces, at states it did not make."""

import numpy as np
import pytest
import scipy.linalg as sla

import dr
import scenes
from dr import masses
from dr.kernels import gradient


def _dense_mass(st, fm, n):
    """The mass the time loop uses: node blocks, and L L^T of the frame mass's factor."""
    M = np.zeros((3 * n, 3 * n))
    for i in range(n):
        if fm.pos[i] < 0:
            a, b, c, d, e, f = st.M[i]
            M[3 * i:3 * i + 3, 3 * i:3 * i + 3] = [[a, d, e], [d, b, f], [e, f, c]]
    N = fm.first.size
    L = np.zeros((N, N))
    for p in range(N):
        q = np.arange(fm.first[p], p + 1)
        L[p, q] = fm.env[fm.start[p]:fm.start[p + 1]]
    dof = (3 * fm.nodes[:, None] + np.arange(3)).ravel()
    M[np.ix_(dof, dof)] = L @ L.T
    return M


@pytest.mark.parametrize("prestretch", [1.1, 1.3])
def test_frame_mass_bounds_the_stiffness(prestretch):
    """With f = 2 the masses are f/2 times a bound of K, so every generalised eigenvalue of
    K v = w M v is at most 1 (K by central differences of the exact gradient, at a curled
    state of the 8-division DEMES); the node-local tensor masses' largest w is near 2."""
    scene = scenes.paper_demes(prestretch, "strip", **{"dr.membrane_net": "triangles", "mesh.divisions": 8})
    state = dr.solve(scene)
    assert state.converged
    model = dr.build(scene).model
    P0 = model.pack()
    n = P0.n
    X = state.x.copy()
    built = masses.masses_at(model, P0, np.vstack([X, np.zeros((P0.n_total - n, 3))]), "frame", 2.0)
    assert built.kind == "frame" and built.frame.nodes.size > 0
    P, st, fm = built.P, built.state, built.frame
    free = (~model.fixed).reshape(-1)

    def grad(x):
        G = np.zeros_like(x)
        gradient(x.copy(), P, G, np.zeros((0, 6)))
        return G.reshape(-1)

    K = np.zeros((3 * n, 3 * n))
    h = 1e-6
    for k in np.flatnonzero(free):
        i, c = divmod(k, 3)
        xp, xm = X.copy(), X.copy()
        xp[i, c] += h
        xm[i, c] -= h
        K[:, k] = (grad(xp) - grad(xm)) / (2 * h)
    K = 0.5 * (K + K.T)[np.ix_(free, free)]
    M = _dense_mass(st, fm, n)[np.ix_(free, free)]
    w = sla.eigh(K, M, eigvals_only=True)
    assert w.max() <= 1.0 + 1e-6
