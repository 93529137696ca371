"""What a FEM state writes to VTK and reports about its membrane (slack, compression)."""

from __future__ import annotations

import numpy as np

from results import CellBlock
from results.film import FilmLaw, film_fields
from scenes import Scene

from .laws import prestretch_row
from .membrane import LATTICE_ANGLES_DEG
from .model import DemesProblem


def membrane_fields(problem: DemesProblem, y: np.ndarray, scene: Scene) -> dict[str, np.ndarray]:
    """Per element: the strain energy density (N/mm = N mm per mm^2 of flat area, quadrature
    mean) and the film fields of :func:`results.film.film_fields` at its centroid, for
    ``scene`` (the state's pre-stretch and voltage)."""
    xm = problem.film_positions(y)
    return {
        "strain_energy_density_N_per_mm": problem.membrane.element_energy_density(xm, problem.lam),
        **film_fields(problem.membrane.centroid_gradient(xm), FilmLaw.of_scene(scene, problem.electrode_cover)),
    }


def compressed_fraction(problem: DemesProblem, y: np.ndarray) -> float:
    """Fraction of the flat membrane area whose smaller principal tension is compressive
    (below -1e-6 of the largest tension): wrinkling, which a membrane cannot carry."""
    tensions, _ = problem.membrane.principal_tensions(problem.film_positions(y), problem.lam)
    t2 = tensions[1]
    bad = t2 < -1e-6 * max(float(np.abs(tensions).max()), 1e-300)
    basis = problem.membrane.basis
    weights = basis.dx  # (nel, nqp) quadrature weights times Jacobians, mm^2
    return float((weights * bad).sum() / weights.sum())


def _family_strains(problem: DemesProblem, y: np.ndarray) -> np.ndarray:
    """Strain from the rest state of the link-net law's three lattice families, (3, nel, nqp)."""
    F = problem.membrane.deformation_gradient(problem.film_positions(y))  # (3, 2, nel, nqp)
    lams = prestretch_row(problem.membrane.path, problem.lam)[:3]  # each family's pre-stretch
    return np.array([np.linalg.norm(np.einsum("ij...,j->i...", F, [np.cos(a), np.sin(a)]), axis=0) * lam - 1.0
                     for a, lam in zip(np.radians(LATTICE_ANGLES_DEG), lams)])


def paper_formula_membrane_energy(problem: DemesProblem, y: np.ndarray) -> float:
    """The link-net film's energy by the paper's formula N eps L / 2 with the current length L,
    N mm: the exact density E h / (2 lambda_k) eps_k^2 times (1 + eps_k) summed over the families
    (NaN for the neo-Hookean film, which has no links)."""
    m = problem.membrane
    if m.law != "linear":
        return float("nan")
    eps = _family_strains(problem, y)
    if m.tension_only:
        eps = np.maximum(eps, 0.0)
    w = eps**2 * (1.0 + eps)
    if m.path.isotropic:
        density = m.E * m.h / (2.0 * problem.lam) * np.sum(w, axis=0)
    else:
        density = 0.5 * m.E * m.h * np.sum(w / prestretch_row(m.path, problem.lam)[:3, None, None], axis=0)
    return float((m.basis.dx * density).sum())


def slack_fractions(problem: DemesProblem, y: np.ndarray) -> tuple[float, float]:
    """Fractions of the flat membrane area (quadrature-weighted) that are partly slack (at least
    one slack link family: a tension field, wrinkles) and fully slack (every family).

    The link-net law's families are its three lattice directions, slack where their strain
    from the rest state is not positive; for the neo-Hookean film they are the principal
    directions, slack where the principal tension is not above 1e-9 of the largest.
    """
    membrane = problem.membrane
    if membrane.law == "linear":
        slack = _family_strains(problem, y) <= 0.0
    else:
        tensions, _ = membrane.principal_tensions(problem.film_positions(y), problem.lam)
        slack = tensions <= 1e-9 * max(float(np.abs(tensions).max()), 1e-300)
    weights = membrane.basis.dx
    total = weights.sum()
    return (float((weights * slack.any(axis=0)).sum() / total),
            float((weights * slack.all(axis=0)).sum() / total))


def blocks(problem: DemesProblem, y: np.ndarray, scene: Scene) -> dict[str, CellBlock]:
    """VTK cell blocks: film elements with their fields, the open windows' strip bands, frame
    edges with section forces (the members' in a block of their own); ``scene`` is the state's
    (its pre-stretch and voltage)."""
    x = y.reshape(-1, 3)
    mesh = problem.mesh
    out = {
        "membrane": CellBlock(mesh.cell_type, mesh.film_cells, membrane_fields(problem, y, scene)),
        "frame": CellBlock("line", problem.rod.edges, problem.rod.section_forces(x)),
    }
    if problem.strip is not None:
        out["strip_band"] = CellBlock(mesh.cell_type, mesh.cells[mesh.strip_band])
    members = [rod for rod in problem.member_rods if rod.props.EA > 0]  # the joints have no section of their own
    if members:
        forces = [rod.section_forces(x) for rod in members]
        out["members"] = CellBlock("line", np.vstack([rod.edges for rod in members]),
                                   {k: np.concatenate([f[k] for f in forces]) for k in forces[0]})
    return out
