"""Unequal pre-stretch (loading.prestretch = [l1, l2], loading.prestretch_angle): the flat film's
energy and tensions against their closed forms for every law in both solvers, frame invariance
(the film, its deformation and its pre-stretch axes turned together), an equal pair as the
isotropic pre-stretch bit for bit, DR and the FEM on one discrete problem, the path, bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest
from skfem import Basis, ElementTriP1, ElementVector, MeshTri

import dr
import fem_reference
import scenes
from dr.kernels import energy
from fem_reference.membrane import Membrane
from scenes import SceneError
from scenes.prestretch import PrestretchPath, parse_levels
from validation.cli import main

E, H, JM = 1.0, 0.05, 10.0  # MPa, mm (mounted), Gent's Jm
LAWS = ("linear", "neo-hookean", "gent")
CASES = (((1.3, 1.0), 0.0), ((1.0, 1.25), 0.0), ((1.4, 1.15), 35.0))
"""(pair, angle of the pre-stretch axes in deg)."""


def closed_form_density(law: str, pair: tuple[float, float], angle: float) -> float:
    """Energy per flat area (N/mm) of the flat film held at its pre-stretch, by hand from each
    law: the linear law's three lattice families (0, 60, 120 deg) each pre-stretched
    1 / sqrt(cos^2(phi - a) / l1^2 + sin^2(phi - a) / l2^2); the incompressible laws from
    I1 = l1^2 + l2^2 + 1 / (l1 l2)^2, which the axes' turn does not change."""
    l1, l2 = pair
    if law == "linear":
        total = 0.0
        for phi in (0.0, 60.0, 120.0):
            t = math.radians(phi - angle)
            lam = 1.0 / math.sqrt(math.cos(t) ** 2 / l1**2 + math.sin(t) ** 2 / l2**2)
            total += (lam - 1.0) ** 2 / (2.0 * lam)
        return E * H * total
    x = l1**2 + l2**2 + 1.0 / (l1 * l2) ** 2 - 3.0
    mu_h = E / 3.0 * H
    return mu_h / 2.0 * (x if law == "neo-hookean" else -JM * math.log(1.0 - x / JM))


def closed_form_tensions(law: str, pair: tuple[float, float]) -> tuple[float, float]:
    """Principal tensions (N/mm) of the flat film along the pre-stretch axes (angle 0): the
    incompressible laws mu h (l_i^2 - 1 / (l1 l2)^2) (Gent: over 1 - (I1 - 3) / Jm); the linear
    law E h sum_k (lambda_k - 1) m_k m_k^T, the 60 and 120 deg families alike."""
    l1, l2 = pair
    if law == "linear":
        lam60 = 1.0 / math.sqrt(0.25 / l1**2 + 0.75 / l2**2)
        return E * H * ((l1 - 1.0) + 0.5 * (lam60 - 1.0)), E * H * 1.5 * (lam60 - 1.0)
    x = l1**2 + l2**2 + 1.0 / (l1 * l2) ** 2 - 3.0
    scale = E / 3.0 * H / (1.0 if law == "neo-hookean" else 1.0 - x / JM)
    return scale * (l1**2 - 1.0 / (l1 * l2) ** 2), scale * (l2**2 - 1.0 / (l1 * l2) ** 2)


def patch(turn_deg: float = 0.0) -> MeshTri:
    """A 10 mm square of 32 triangles, turned by ``turn_deg`` about the origin."""
    mesh = MeshTri.init_tensor(np.linspace(0, 10.0, 5), np.linspace(0, 10.0, 5))
    c, s = math.cos(math.radians(turn_deg)), math.sin(math.radians(turn_deg))
    return MeshTri(np.array([[c, -s], [s, c]]) @ mesh.p, mesh.t)


def fem_membrane(mesh: MeshTri, law: str, pair, angle: float) -> Membrane:
    basis = Basis(mesh, ElementVector(ElementTriP1(), 3))
    return Membrane(basis, law, E, H, True, JM, path=PrestretchPath.of(tuple(pair), angle))


def dr_energy(mesh: MeshTri, law: str, pair, angle: float, x: np.ndarray) -> float:
    """DR's membrane triangles on ``mesh`` at the pre-stretch tensor of ``pair``, energy at x."""
    nodes = np.column_stack([mesh.p.T, np.zeros(mesh.p.shape[1])])
    m = dr.Model(nodes)
    path = PrestretchPath.of(tuple(pair), angle)
    m.add_triangles(mesh.t.T, E=E, thickness=H, prestretch=path.tensor(max(pair)), law=law, gent_jm=JM)
    P = m.pack()
    X = np.zeros((P.n_total, 3))
    X[: P.n] = x
    return float(sum(energy(X, P)))


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("pair, angle", CASES)
def test_flat_film_energy_matches_the_closed_form_in_both_solvers(law, pair, angle):
    mesh = patch()
    area = 100.0
    expected = closed_form_density(law, pair, angle) * area
    mem = fem_membrane(mesh, law, pair, angle)
    assert mem.energy(mem.X, max(pair)) == pytest.approx(expected, rel=1e-12)
    assert dr_energy(mesh, law, pair, angle, mem.X) == pytest.approx(expected, rel=1e-12)


@pytest.mark.parametrize("law", LAWS)
@pytest.mark.parametrize("pair", [(1.3, 1.0), (1.1, 1.35)])
def test_flat_film_tensions_match_the_closed_form(law, pair):
    mem = fem_membrane(patch(), law, pair, 0.0)
    tensions, _ = mem.principal_tensions(mem.X, max(pair))
    assert np.allclose(tensions[0], max(closed_form_tensions(law, pair)), rtol=1e-10)
    assert np.allclose(tensions[1], min(closed_form_tensions(law, pair)), rtol=1e-10)


@pytest.mark.parametrize("law", LAWS)
def test_turning_film_deformation_and_axes_together_keeps_the_energy(law):
    """Frame invariance: the film turned with its deformation and its pre-stretch axes stores the
    same energy, in both solvers; any turn for the incompressible laws, turns that map the
    linear law's lattice (0, 60, 120 deg) onto itself for it."""
    pair, angle = (1.35, 1.1), 20.0
    mesh = patch()
    X = np.column_stack([mesh.p.T, np.zeros(mesh.p.shape[1])])
    # a smooth deformation with stretch, shear and lift
    x = X + np.column_stack([0.03 * X[:, 0] + 0.01 * X[:, 1] ** 2 / 10, -0.02 * X[:, 1] + 0.015 * X[:, 0],
                             0.05 * X[:, 0] * X[:, 1] / 10])
    base_fem = fem_membrane(mesh, law, pair, angle).energy(x, max(pair))
    base_dr = dr_energy(mesh, law, pair, angle, x)
    assert base_dr == pytest.approx(base_fem, rel=1e-12)
    for turn in (60.0, 180.0) if law == "linear" else (90.0, 37.0):
        c, s = math.cos(math.radians(turn)), math.sin(math.radians(turn))
        R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        turned = patch(turn)
        assert fem_membrane(turned, law, pair, angle + turn).energy(x @ R.T, max(pair)) == pytest.approx(base_fem, rel=1e-11)
        assert dr_energy(turned, law, pair, angle + turn, x @ R.T) == pytest.approx(base_dr, rel=1e-11)


def small_scene(**changes) -> scenes.Scene:
    return scenes.paper_demes(1.3, **{"dr.membrane_net": "triangles", "mesh.divisions": 6, "fem.element": "P1",
                                      **changes})


@pytest.mark.parametrize("solve", [dr.solve, lambda s: fem_reference.solve(s, refinement=0)], ids=["dr", "fem"])
def test_an_equal_pair_is_the_isotropic_pre_stretch_bit_for_bit(solve):
    iso = solve(small_scene())
    pair = solve(small_scene(**{"loading.prestretch": [1.3, 1.3], "loading.prestretch_angle": 30.0}))
    assert np.array_equal(iso.x, pair.x) and iso.energy == pair.energy


@pytest.mark.parametrize("pair, angle", [((1.3, 1.0), 0.0), ((1.3, 1.1), 30.0)])
def test_dr_and_the_fem_agree_on_one_discrete_problem_with_an_unequal_pair(pair, angle):
    """DR's triangles and the FEM's P1 on the same mesh minimise one energy: the same state."""
    scene = small_scene(**{"loading.prestretch": list(pair), "loading.prestretch_angle": angle})
    d, f = dr.solve(scene), fem_reference.solve(scene, refinement=0)
    assert d.converged and f.converged
    assert abs(d.bending_angle - f.bending_angle) < 0.01
    assert d.energy["total"] == pytest.approx(f.energy["total"], rel=1e-6)
    iso = fem_reference.solve(small_scene(), refinement=0)
    assert abs(f.bending_angle - iso.bending_angle) > 1.0  # another state than the isotropic 1.3


def test_the_path_moves_a_pair_along_its_line():
    scene = small_scene(**{"loading.prestretch": [1.3, 1.0]})
    assert scene.prestretch == 1.3
    assert scene.updated(prestretch=1.15).loading.prestretch == (1.15, 1.0)
    res = dr.solve(scene, 1.15)
    assert res.prestretch == 1.15 and res.scene.loading.prestretch == (1.15, 1.0)
    assert parse_levels("--prestretch", ["1.15,1", "1.3,1.0"]) == ((1.3, 1.0), [1.15, 1.3])


def test_the_link_net_takes_an_unequal_pair():
    """The paper's link net (rest lengths |P^-1 d|): an equal pair is the isotropic net bit for
    bit, an unequal one relaxes to another converged state."""
    net = {"dr.membrane_net": "links", "mesh.divisions": 6}
    iso = dr.solve(scenes.paper_demes(1.3, **net))
    same = dr.solve(scenes.paper_demes(1.3, **net, **{"loading.prestretch": [1.3, 1.3]}))
    other = dr.solve(scenes.paper_demes(1.3, **net, **{"loading.prestretch": [1.0, 1.3]}))
    assert np.array_equal(iso.x, same.x)
    assert other.converged and abs(other.bending_angle - iso.bending_angle) > 1.0


@pytest.mark.parametrize("value, field", [([0.9, 1.2], "loading.prestretch[0]"), ([1.2], "loading.prestretch"),
                                          ([1.1, 1.2, 1.3], "loading.prestretch")])
def test_a_bad_pair_is_a_one_line_error_naming_the_field(value, field):
    with pytest.raises(SceneError, match=field.replace("[", r"\[").replace("]", r"\]")):
        small_scene(**{"loading.prestretch": value})
    with pytest.raises(SceneError, match="loading.prestretch_angle"):
        small_scene(**{"loading.prestretch_angle": 200.0})


def test_the_cli_solves_pairs_and_refuses_pairs_off_one_line(tmp_path, capsys):
    common = ["--solver", "dr", "--mesh-levels", "6", "--set", "mesh.divisions=6", "--set", "dr.membrane_net=triangles",
              "--no-progress"]
    assert main(["solve", *common, "--prestretch", "1.1,1", "1.2,1", "--out", str(tmp_path / "ok")]) == 0
    assert "pre-stretch 1.2,1 along axes at 0 deg" in capsys.readouterr().out
    assert main(["solve", *common, "--prestretch", "1.1,1", "1.2,1.2", "--out", str(tmp_path / "bad")]) != 0
    err = capsys.readouterr().err
    assert "--prestretch: the pairs must lie on one line" in err and "Traceback" not in err


def test_a_design_grid_takes_pairs_and_keys_the_line(tmp_path):
    """``prestretch = [[l1, l2], ...]`` in a grid sets the scene's pair and sweeps its path
    values; two scenes on different lines are different families."""
    from validation.design.grid import load_grid

    text = 'scene = "demes_paper"\nsolver = "dr"\nprestretch = [[1.1, 1.0], [1.2, 1.0]]\n[product]\n"mesh.divisions" = [6]\n'
    (tmp_path / "g.toml").write_text(text)
    grid = load_grid(tmp_path / "g.toml")
    assert grid.prestretches == (1.1, 1.2)
    assert scenes.Scene.from_dict(grid.families[0].scene_data).prestretch_path == PrestretchPath.of((1.2, 1.0))
    (tmp_path / "h.toml").write_text(text.replace("[[1.1, 1.0], [1.2, 1.0]]", "[[1.0, 1.1], [1.0, 1.2]]"))
    assert load_grid(tmp_path / "h.toml").families[0].key != grid.families[0].key
