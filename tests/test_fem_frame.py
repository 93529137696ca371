"""The FEM frame alone: elastica cantilevers against the exact elastica, and its convergence order."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from fem_reference.frame import Rod, RodProperties
from fem_reference.model import RodProblem
from fem_reference.newton import newton


def exact_elastica_tip(alpha: float, load_angle_deg: float = 90.0) -> np.ndarray:
    """Tip (x, y)/L of a clamped inextensible cantilever along x under a dead end load P at
    ``load_angle_deg`` from its axis, alpha = P L^2 / EI, by shooting on
    theta'' = -alpha sin(beta - theta), theta(0) = 0, theta'(1) = 0 (the branch that bends
    towards the load)."""
    beta = np.radians(load_angle_deg)

    def shoot(k0: float):
        rhs = lambda s, q: [q[1], -alpha * np.sin(beta - q[0]), np.cos(q[0]), np.sin(q[0])]
        return solve_ivp(rhs, (0.0, 1.0), [0.0, k0, 0.0, 0.0], rtol=1e-12, atol=1e-14).y[:, -1]

    ks = np.linspace(1e-9, alpha, 81)
    end_moment = np.array([shoot(k)[1] for k in ks])
    roots = [brentq(lambda k: shoot(k)[1], a, b, xtol=1e-14)
             for a, b, fa, fb in zip(ks[:-1], ks[1:], end_moment[:-1], end_moment[1:]) if fa * fb < 0]
    k0 = max(roots, key=lambda k: shoot(k)[0])  # the tip turned most towards the load
    return shoot(k0)[2:]


def cantilever(n: int, alpha: float, model: str, plane: str, load_angle_deg: float = 90.0,
               steps: int = 4
               ) -> np.ndarray:
    """Tip (x, y or z)/L of the discrete rod: n segments, clamped by a held ghost edge.

    'strip' rods take their director points far off to the side (+y), which keeps the strip
    plane the x-y plane: 'in' loads (in the x-y plane) bend the strong axis, 'out' loads (x-z)
    the weak one.
    """
    L, EI = 100.0, 2.0
    x = np.linspace(-L / n, L, n + 2)  # node 0 is the ghost behind the clamp at node 1
    X = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    held = np.zeros(n + 2, bool)
    held[:2] = True
    stiff_axis = EI if (model == "paper" or plane == "out") else 1e3 * EI
    props = RodProperties(model, EA=1e6 * stiff_axis / L**2,
                          EI=EI if model == "paper" or plane == "out" else 7.0,
                          EI_strong=stiff_axis if plane == "in" else 3e3 * EI, GJ=0.5 * EI)
    directors = None
    if model == "strip":  # one director point per edge, 1e6 L away: rows of extra held nodes
        mids = 0.5 * (X[:-1] + X[1:]) + [0.0, 1e6 * L, 0.0]
        X = np.vstack([X, mids])
        held = np.concatenate([held, np.ones(n + 1, bool)])
        directors = sp.csr_matrix((np.ones(n + 1), (np.arange(n + 1), n + 2 + np.arange(n + 1))),
                                  shape=(n + 1, X.shape[0]))
    rod = Rod(X, np.arange(n + 2), False, held, props, directors)
    axis = 1 if plane == "in" else 2
    P = alpha * stiff_axis / L**2
    beta = np.radians(load_angle_deg)
    y = X.ravel().copy()
    for frac in np.linspace(0.0, 1.0, steps + 1)[1:]:  # load steps
        loads = np.zeros_like(X)
        loads[n + 1, 0] = frac * P * np.cos(beta)
        loads[n + 1, axis] = frac * P * np.sin(beta)
        res = newton(RodProblem(rod, held, loads), y, tol=1e-8, max_iterations=100)
        assert res.converged, res.status
        y = res.y
    tip = y.reshape(-1, 3)[n + 1]
    return np.array([tip[0], tip[axis]]) / L


@pytest.mark.parametrize("alpha", [1.0, 10.0])
@pytest.mark.parametrize("model,plane", [("paper", "in"), ("strip", "out"), ("strip", "in")])
def test_cantilever_matches_exact_elastica(alpha, model, plane):
    exact = exact_elastica_tip(alpha)
    tip = cantilever(40, alpha, model, plane)
    # within 0.1 % of the tip deflection (and so of the length)
    assert np.all(np.abs(tip - exact) <= 1e-3 * exact[1]), (tip, exact)


def test_exact_elastica_small_load_limit():
    # the shooting solution itself: P L^2 / EI -> 0 gives the linear beam, deflection alpha / 3
    assert exact_elastica_tip(1e-4)[1] == pytest.approx(1e-4 / 3, rel=1e-4)


def test_cantilever_converges_at_second_order():
    exact = exact_elastica_tip(1.0)
    errors = [np.linalg.norm(cantilever(n, 1.0, "paper", "in") - exact) for n in (10, 20, 40)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 1.8) & (orders < 2.2)), orders


def test_rotation_past_140_degrees_is_exact():
    # a load leaning back at 150 deg from the axis, P L^2 / EI = 20: the tip turns by 146 deg
    exact = exact_elastica_tip(20.0, 150.0)
    tip = cantilever(80, 20.0, "paper", "in", 150.0, steps=20)
    assert np.all(np.abs(tip - exact) <= 1e-3), (tip, exact)


def twisted_strip(n: int, torque: float, GJ: float, lever: float = 2.0) -> tuple[float, float]:
    """End twist (rad) of a straight 'strip' rod clamped by a held first edge, under a couple:
    a force torque / lever across the strip at the director point of its last edge (the film's
    pull at the bond lever) and the opposite force on that edge's centreline; and the length
    (mm) from the clamp to that edge's midpoint.

    The director points are extra nodes at ``lever`` beside the edge midpoints (+y), free only
    across the strip (z): the section turns by atan((z_director - z_midpoint) / lever).
    """
    L = 20.0
    x = np.linspace(-L / n, L, n + 2)  # node 0-1: the held (clamped) edge
    X = np.column_stack([x, np.zeros_like(x), np.zeros_like(x)])
    mids = 0.5 * (X[:-1] + X[1:]) + [0.0, lever, 0.0]
    nodes = np.vstack([X, mids])
    held = np.zeros(nodes.shape[0], bool)
    held[:2] = True
    held[n + 2] = True  # the clamped edge's director point
    directors = sp.csr_matrix((np.ones(n + 1), (np.arange(n + 1), n + 2 + np.arange(n + 1))),
                              shape=(n + 1, nodes.shape[0]))
    props = RodProperties("strip", EA=100.0, EI=0.3, EI_strong=50.0, GJ=GJ)
    rod = Rod(nodes, np.arange(n + 2), False, held, props, directors)
    loads = np.zeros_like(nodes)
    loads[-1, 2] = torque / lever
    loads[n:n + 2, 2] = -0.5 * torque / lever
    problem = RodProblem(rod, held, loads)
    directors_z = 3 * np.arange(n + 3, nodes.shape[0]) + 2
    problem.free = np.union1d(np.flatnonzero(~np.repeat(np.r_[held[:n + 2], np.ones(n + 1, bool)], 3)),
                              directors_z)
    res = newton(problem, nodes.ravel(), tol=1e-9, max_iterations=50)
    assert res.converged, (res.status, res.history)
    tip = res.y.reshape(-1, 3)
    twist = np.arctan2(tip[-1, 2] - 0.5 * (tip[n, 2] + tip[n + 1, 2]), lever)
    return twist, mids[-1, 0] - X[1, 0]


@pytest.mark.parametrize("n", [4, 16])
def test_strip_twists_by_torque_times_length_over_GJ(n):
    """A torque T at the bond lever twists the strip by T L / GJ: exact for any number of edges
    in the small-angle limit (every vertex carries T; the clamped one counts half an edge).
    The deviation is geometric, O(twist^2): 2e-6 at this torque."""
    GJ, torque = 2.6, 1e-4
    twist, length = twisted_strip(n, torque, GJ)
    assert twist == pytest.approx(torque * length / GJ, rel=1e-5)
