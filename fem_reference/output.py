"""What a FEM state writes to VTK and reports about its membrane (slack, compression)."""

from __future__ import annotations

import numpy as np

from results import CellBlock

from .model import DemesProblem


def membrane_stresses(problem: DemesProblem, y: np.ndarray) -> dict[str, np.ndarray]:
    """Per element (quadrature-point mean): principal tensions (N/mm), stresses (MPa), energy
    density (N/mm = N mm per mm^2 of flat area), and the area ratio current/flat."""
    xm = problem.film_positions(y)
    tensions, J = problem.membrane.principal_tensions(xm, problem.lam)
    # incompressible film: current thickness = mounted thickness / (current / flat area)
    stress = tensions * J / problem.membrane.h
    return {
        "strain_energy_density_N_per_mm": problem.membrane.element_energy_density(xm, problem.lam),
        "tension_principal_1_N_per_mm": tensions[0].mean(axis=1),
        "tension_principal_2_N_per_mm": tensions[1].mean(axis=1),
        "stress_principal_1_MPa": stress[0].mean(axis=1),
        "stress_principal_2_MPa": stress[1].mean(axis=1),
        "area_ratio": J.mean(axis=1),
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


def slack_fraction(problem: DemesProblem, y: np.ndarray) -> float:
    """Fraction of the flat membrane area where both principal tensions vanish (slack links)."""
    tensions, _ = problem.membrane.principal_tensions(problem.film_positions(y), problem.lam)
    scale = max(float(np.abs(tensions).max()), 1e-300)
    slack = tensions[0] <= 1e-9 * scale
    weights = problem.membrane.basis.dx
    return float((weights * slack).sum() / weights.sum())


def blocks(problem: DemesProblem, y: np.ndarray) -> dict[str, CellBlock]:
    """VTK cell blocks: membrane elements with their fields, frame edges with section forces."""
    x = y.reshape(-1, 3)
    mesh = problem.mesh
    return {
        "membrane": CellBlock(mesh.cell_type, mesh.cells, membrane_stresses(problem, y)),
        "frame": CellBlock("line", problem.rod.edges, problem.rod.section_forces(x)),
    }
