"""DR's assembled stiffness (dr.hessian) against products of the gradient's own differences, and
the lowest mode it gives (dr.stability) against the matrix-free Lanczos search."""

import numpy as np
import pytest
from test_dr_elements import strip_model

import dr
import scenes
from dr import hessian, stability
from dr.kernels import gradient


def column_by_column(model, x: np.ndarray) -> np.ndarray:
    """K (3n, 3n) N/mm by central differences of the gradient one DOF at a time, symmetrised,
    on the free DOFs (Table I's spline beam's forces are not exactly a gradient: their own
    matrix is not symmetric, by about 1e-5 of its largest entry)."""
    P = model.pack()
    X, G = np.zeros((P.n_total, 3)), np.zeros((P.n_total, 3))
    h = 1e-6 * float(np.ptp(x, axis=0).max())
    free = (~model.fixed).reshape(-1)
    K = np.zeros((free.size, free.size))
    for c in np.flatnonzero(free):
        out = []
        for sign in (1.0, -1.0):
            X[: P.n] = x
            X.reshape(-1)[c] += sign * h
            gradient(X, P, G, np.zeros((0, 6)))
            out.append(G[: P.n].reshape(-1) * free)
        K[:, c] = (out[0] - out[1]) / (2.0 * h)
    return 0.5 * (K + K.T)


MODELS = {
    "triangles, strip rod": ("strip", {"dr.membrane_net": "triangles"}),
    "clustered net, strip rod": ("strip", {"dr.membrane_net": "clustered"}),
    "links, strip rod": ("strip", {"dr.membrane_net": "links"}),
    "triangles, Table I beam, voltage": ("paper", {"dr.membrane_net": "triangles", "loading.voltage": 2000.0}),
    "clustered net, Table I beam (clamp ghosts)": ("paper", {"dr.membrane_net": "clustered"}),
}


def curled(nodes: np.ndarray) -> np.ndarray:
    """The nodes moved by a smooth field with no symmetry, a fiftieth of their extent."""
    span = float(np.ptp(nodes, axis=0).max())
    u = nodes / span
    return nodes + 0.02 * span * np.stack([u[:, 1] ** 2, u[:, 0] * u[:, 1], u[:, 0] + 2 * u[:, 1] ** 2 + 0.1], axis=1)


def assert_assembled_is_the_derivative(model, x: np.ndarray) -> None:
    """K assembled by groups of nodes (each difference moves a whole group) equals K taken one
    DOF at a time, and it took no more differences than that."""
    free = ~model.fixed
    pat = hessian.pattern(model.pack(), free.any(axis=1))
    K, pairs = hessian.stiffness_matrix(model.pack(), x, free, pat, 1e-6 * float(np.ptp(x, axis=0).max()))
    expected = column_by_column(model, x)
    assert np.abs(K.toarray() - expected).max() <= 1e-7 * np.abs(expected).max()
    assert pairs <= free.sum()


@pytest.mark.parametrize("frame, changes", MODELS.values(), ids=MODELS.keys())
def test_the_assembled_stiffness_is_the_derivative_of_the_gradient(frame, changes):
    """At a curled state with no symmetry, on each kind of DEMES model."""
    model = dr.build(scenes.paper_demes(1.2, frame, **{"mesh.divisions": 6, **changes})).model
    x = curled(model.nodes)
    x[model.fixed.all(axis=1)] = model.nodes[model.fixed.all(axis=1)]
    assert_assembled_is_the_derivative(model, x)


@pytest.mark.parametrize("offset", [0.0, 0.3])
def test_the_assembled_stiffness_of_a_strip_with_offset_nodes_and_a_taped_clamp(offset):
    """The strip element, its offset nodes and a clamp's ghost, with clusters and links."""
    model = strip_model(taped_end=True, offset=offset)
    x = curled(model.nodes)
    x[model.fixed.all(axis=1)] = model.nodes[model.fixed.all(axis=1)]
    assert_assembled_is_the_derivative(model, x)


def test_the_lowest_mode_by_inertia_is_the_lanczos_one(monkeypatch):
    """On the flat DEMES past its buckling load (a saddle) and on the stable curled state DR
    leaves it for: the same lowest eigenvalue and mode as Lanczos on the matrix-free operator (the
    saddle's by the descent from the assembled K's mode to the matrix-free one's)."""
    scene = scenes.paper_demes(1.1, "strip", **{"dr.membrane_net": "triangles", "mesh.divisions": 8})
    held = dr.build(scene)
    held.model.support(np.arange(held.model.n), "z")
    flat = dr.relax(held.model, tol=1e-8, x_start=held.model.nodes, masses="frame")
    curled = dr.solve(scene)
    model = dr.build(scene).model
    for x in (flat.x, curled.x):
        assembled = stability.lowest_mode(model, x)
        with monkeypatch.context() as patch:
            patch.setattr(stability, "_by_inertia", lambda op, start: (False, None, None, None))
            lanczos = stability.lowest_mode(model, x)
        assert assembled.found and lanczos.found
        assert assembled.eigenvalue == pytest.approx(lanczos.eigenvalue, rel=1e-4, abs=stability.NEUTRAL)
        cosine = np.sum(assembled.shape * lanczos.shape) / np.linalg.norm(assembled.shape) / np.linalg.norm(lanczos.shape)
        assert abs(cosine) > 0.999


def test_the_newton_step_of_a_loosely_relaxed_state_is_its_distance_to_the_equilibrium():
    """A DEMES relaxed to a residual of 1e-10, and relaxed to 1e-4 from it pushed 0.5 mm along
    its soft mode: the Newton step K^-1 r at the loose state has the length of its distance to
    the tight one (within 5 %), and the loose state moved by it is a hundred times closer. A
    solve relaxed to 1e-4 is moved by such steps to the equilibrium: it ends a hundred times
    closer than the loose relaxation, and reports its remaining step."""
    scene = scenes.paper_demes(1.2, "strip", **{"mesh.divisions": 8, "dr.membrane_net": "triangles"})
    tight = dr.solve(scene.updated(**{"dr.tolerance": 1e-10}))
    model = dr.build(scene).model
    soft = stability.lowest_mode(model, tight.x)
    loose = dr.relax(model, tol=1e-4, x_start=tight.x + 0.5 * soft.shape)
    assert tight.converged and loose.converged
    mode = stability.lowest_mode(model, loose.x)
    distance = np.linalg.norm(loose.x - tight.x, axis=1).max()
    step = np.linalg.norm(mode.newton_step, axis=1).max()
    assert distance > 1e-3 and step == pytest.approx(distance, rel=0.05)
    assert np.linalg.norm(loose.x + mode.newton_step - tight.x, axis=1).max() < 0.01 * distance
    assert tight.info["newton_step_mm"] < 1e-3 * distance
    polished = dr.solve(scene.updated(**{"dr.tolerance": 1e-4}))
    assert polished.converged and polished.info["newton_steps"] >= 1
    assert np.linalg.norm(polished.x - tight.x, axis=1).max() < 0.01 * distance
    assert polished.info["newton_step_mm"] < 0.01 * distance
