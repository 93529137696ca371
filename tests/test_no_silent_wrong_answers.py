"""A wrong answer never comes back with a clean status: NaN states, degenerate input,
divergence, films passing through themselves and slack film are named."""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

import dr
import scenes
from fem_reference.newton import newton
from results.crossing import film_crossing


# ----------------------------------------------------------------------------- NaN sources, DR


def three_nodes() -> dr.Model:
    m = dr.Model([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    m.support([0, 2])
    m.add_link(0, 1, EA=1.0)
    m.add_link(1, 2, EA=1.0)
    return m


def test_a_zero_length_link_at_the_start_is_an_error_naming_its_nodes():
    """Was: converged True with x[1] = NaN, residual 0 and energy NaN."""
    m = three_nodes()
    start = m.nodes.copy()
    start[1] = start[0]
    with pytest.raises(dr.DRError, match="link between nodes 0 and 1: the nodes coincide"):
        dr.relax(m, x_start=start)


def cantilever(x: np.ndarray) -> dr.Model:
    m = dr.Model(x)
    m.clamp(0, (1, 0, 0))
    m.add_beam(np.arange(x.shape[0]), EI=1.0, EA=100.0)
    m.add_load(x.shape[0] - 1, (0, 0, -0.01))
    return m


def test_coincident_beam_nodes_are_an_error_naming_them():
    """Was: converged True with positions not finite."""
    x = np.zeros((11, 3))
    x[:, 0] = np.arange(11.0)
    start = x.copy()
    start[5] = start[4]
    with pytest.raises(dr.DRError, match="nodes 4 and 5"):
        dr.relax(cantilever(x), x_start=start)
    with pytest.raises(dr.DRError, match="beam edge between nodes 4 and 5: the nodes coincide"):
        cantilever(start)  # in the reference geometry


def test_a_film_node_on_a_strip_edge_line_is_an_error_naming_it():
    """The strip's plane is set by a membrane node beside each edge: on the edge's line there is
    no plane (0/0)."""
    x = np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0], [3, 0, 0], [0.5, 1, 0], [1.5, 1, 0], [2.5, 1, 0]], float)
    m = dr.Model(x)
    m.clamp(0, (1, 0, 0), taped=True)
    m.support([4, 5, 6])
    m.add_beam([0, 1, 2, 3], EI=1.0, EA=100.0, EI_strong=10.0, GJ=1.0, orientation=[4, 5, 6])
    m.add_load(3, (0, 0, -0.01))
    start = x.copy()
    start[5] = [1.5, 0.0, 0.0]  # on the line of edge 1-2
    with pytest.raises(dr.DRError, match="orientation node 5 lies on the edge's line"):
        dr.relax(m, x_start=start)


def test_a_nan_during_the_run_stops_as_not_finite_with_the_last_finite_state():
    """The load drives node 1 exactly onto node 0 in the first step: the link's force is 0/0
    from then on. NumPy's max would keep the NaN, numba's max(acc, nan) dropped it."""
    m = dr.Model([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    m.support(0)
    m.support(1, axes="yz")
    m.add_link(0, 1, EA=1.0)
    m.add_load(1, (-2.0, 0.0, 0.0))  # scalar mass f/2 EA/L0 = 1: x1 = 1 + 1/2 (-2) = 0
    res = dr.relax(m, masses="scalar")
    assert res.status == "not_finite" and not res.converged
    assert "link between nodes 0 and 1: the nodes coincide" in res.message
    assert np.all(np.isfinite(res.x))


# ----------------------------------------------------------------------------- NaN, FEM


class NaNAfterOneStep:
    """A quadratic bowl whose gradient turns NaN at node 1 (DOF 3) once Newton has stepped."""

    n_dofs = 6
    free = np.arange(6)
    mass = sp.eye(6, format="csr")

    def energy(self, y):
        return float(0.5 * np.sum((y - 1.0) ** 2))

    def evaluate(self, y, order=2):
        g = y - 1.0
        if np.abs(y).max() > 0.5:
            g[3] = np.nan
        return SimpleNamespace(total=self.energy(y), gradient=g, tangent=sp.eye(6, format="csr"), force_scale=1.0)


def test_fem_newton_names_the_node_where_a_nan_appeared():
    out = newton(NaNAfterOneStep(), np.zeros(6), max_iterations=5)
    assert out.status == "not_finite" and not out.converged and out.bad_node == 1


# ----------------------------------------------------------------------------- divergence before contact


def test_an_unstable_time_step_is_diverged_not_contact():
    """Masses at half the stability bound on the paper scene: the blow-up looks like
    self-contact by iteration 6, yet with the contact checks on or off the run says 'diverged'
    and names the factor."""
    scene = scenes.paper_demes(1.5, **{"mesh.divisions": 12})
    dm = dr.build(scene)
    for checks in (True, False):
        res = dr.relax(dm.model, mass_safety=0.5, x_start=dm.start, max_iterations=2000,
                       contact=dm.contact if checks else None, final_checks=dm.final_checks if checks else ())
        assert res.status == "diverged", res.message
        assert "mass_safety = 0.5" in res.message and np.all(np.isfinite(res.x))


def test_a_stable_run_into_contact_is_still_contact():
    """A stable run that curls into itself is reported as contact, not as divergence."""
    scene = scenes.paper_demes(1.5, **{"mesh.divisions": 12, "frame.E": 26.0})
    res = dr.solve(scene)
    assert res.status in ("self_contact", "membrane_fold", "film_contact"), res.message
    assert "diverged" not in res.message


# ----------------------------------------------------------------------------- film crossing


def strip_of_triangles(n: int = 12) -> tuple[np.ndarray, np.ndarray]:
    """A flat strip 0 <= x <= n, 0 <= y <= 1 of 2n triangles."""
    xs = np.arange(n + 1.0)
    nodes = np.array([[x, y, 0.0] for x in xs for y in (0.0, 1.0)])
    tri = []
    for k in range(n):
        a, b, c, d = 2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 3
        tri += [[a, c, b], [b, c, d]]
    return nodes, np.array(tri)


def test_a_film_rolled_through_itself_is_a_crossing_and_a_tight_roll_is_not():
    nodes, tri = strip_of_triangles()
    assert film_crossing(nodes, tri) is None

    def roll(turn):  # wind the strip about the y axis through ``turn`` rad, the radius shrinking
        x = nodes.copy()
        phi = turn * nodes[:, 0] / nodes[:, 0].max()
        r = 3.0 - 0.1 * phi  # a spiral: each turn inside the one before
        x[:, 0], x[:, 2] = r * np.sin(phi), 3.0 - r * np.cos(phi)
        return x

    assert film_crossing(roll(1.9 * np.pi), tri) is None  # a spiral: no crossing
    # folded back over itself at x = 6, the returning half sloping down through the first
    folded = nodes.copy()
    back = nodes[:, 0] > 6.0
    folded[back, 0] = 12.0 - nodes[back, 0]
    folded[back, 2] = 0.5 - 0.3 * (nodes[back, 0] - 6.0)
    found = film_crossing(folded, tri)
    assert found is not None and found.kind == "film" and "passes through itself" in found.describe()


def test_a_frame_segment_through_the_film_is_a_crossing():
    nodes, tri = strip_of_triangles(4)
    frame = np.vstack([nodes, [[2.3, 0.4, -1.0], [2.3, 0.4, 1.0]]])
    found = film_crossing(frame, tri, np.array([[10, 11]]))
    assert found is not None and found.kind == "frame"
    assert film_crossing(frame, tri, np.array([[0, 2]])) is None  # along the film's own edge


# ----------------------------------------------------------------------------- slack


def test_dr_slack_fractions_are_in_the_info_and_the_csv_row():
    scene = scenes.paper_demes(1.3, "strip", **{"mesh.divisions": 8, "dr.membrane_net": "links"})
    res = dr.solve(scene)
    row = res.summary()
    for key in ("slack_area_fraction_any", "slack_area_fraction_full"):
        assert 0.0 <= res.info[key] <= 1.0 and row[key] == res.info[key]
    assert res.info["slack_area_fraction_full"] <= res.info["slack_area_fraction_any"]
    # the paper's formula N eps L / 2 is the exact N eps L0 / 2 times L / L0 > 1 on a taut film
    assert res.info["energy_membrane_paper_formula"] > res.energy["membrane"]


def test_fem_reports_both_slack_fractions_in_the_info_and_the_csv_row():
    """A FEM result of the flat mesh shrunk across the base: the inclined lattice families go
    slack over the whole film (see test_fem_demes for the closed-form stretches)."""
    from fem_reference.model import DemesProblem
    from fem_reference.state import Outcome, make_result

    pb = DemesProblem(scenes.paper_demes(1.3, "strip", **{"mesh.divisions": 4}), 0, "P1")
    pb.lam = 1.3
    squeezed = (pb.X * [1.0, 0.5, 1.0]).ravel()
    res = make_result(pb, Outcome(squeezed, 1.3, "max_iterations", ""), 1.3, 0.0, 0)
    assert (res.info["slack_area_fraction_any"], res.info["slack_area_fraction_full"]) == pytest.approx((1.0, 0.0))
    assert res.summary()["slack_area_fraction_any"] == res.info["slack_area_fraction_any"]
    assert res.info["energy_membrane_paper_formula"] > 0.0
