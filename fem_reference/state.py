"""What a FEM path reports: its steps (:class:`StepRecord`), where it got to (:class:`Outcome`),
and the shared :class:`results.Result` of a state (:func:`make_result`)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from results import ENERGY_KEYS, Result
from results.path import jumps_message, neutral_stiffness
from scenes import Scene
from scenes.electric import highest_voltage

from .model import DemesProblem, Evaluation
from .newton import NotFactorizable
from .output import blocks, compressed_fraction, paper_formula_membrane_energy, slack_fractions
from .stability import lowest_free_mode

@dataclass
class StepRecord:
    """One continuation step: its pre-stretch, Newton residual history and eigenmode steps."""

    prestretch: float
    iterations: int
    residuals: list[float]
    eigen_steps: int

    def as_dict(self) -> dict:
        return {"prestretch": self.prestretch, "iterations": self.iterations,
                "residuals": self.residuals, "eigen_steps": self.eigen_steps}


@dataclass
class Outcome:
    """Where the path got to for one requested pre-stretch."""

    y: np.ndarray
    prestretch: float
    status: str
    detail: str
    records: list[StepRecord] = field(default_factory=list)
    first_contact: tuple[float, float] | None = None  # (last free, first in contact) lambda
    snaps: list[tuple[float, float]] = field(default_factory=list)  # branches left: (last on, first off)
    lowest_eigenvalue: float = float("nan")

    @property
    def converged(self) -> bool:
        return self.status == "converged"



STATUS_WORDS = {"converged": "converged", "self_contact": "stopped at self-contact",
                "film_contact": "stopped where the film passes through itself or the frame",
                "unstable": "found no stable state", "max_iterations": "did not converge",
                "diverged": "diverged", "time_limit": "stopped at the time limit",
                "not_finite": "stopped at a non-finite value"}
"""A path's status in the words of a state's message."""


@dataclass(frozen=True)
class Stability:
    """The lowest eigenvalue (N/mm^3; NaN where not computed) of a state's tangent, and whether
    the state counts as stable."""

    omega: float
    stable: bool


def newton_tails(records: list[StepRecord]) -> list[list[float]]:
    """The last four relative residuals of each continuation step (quadratic: each about the
    square of the one before, down to the round-off floor near 1e-10)."""
    return [rec.residuals[-4:] for rec in records]


def make_result(problem: DemesProblem, out: Outcome, requested: float, wall: float,
                steps_total: int, state_scene: Scene | None = None) -> Result:
    """The shared ``Result`` of a FEM state; ``state_scene`` is its scene (default: the
    problem's at the pre-stretch reached)."""
    scene = problem.scene
    lam = out.prestretch
    ev = problem.evaluate(out.y, 1)
    residual = _relative_residual(problem, ev, lam)
    stability = _stability(problem, out)
    iterations = sum(r.iterations for r in out.records)
    flat = stress_free(scene, lam)
    compressed = 0.0 if flat else compressed_fraction(problem, out.y)
    slack = (0.0, 0.0) if flat else slack_fractions(problem, out.y)
    status, converged, message = _status_and_message(scene, out, requested, residual, iterations, stability,
                                                     compressed)
    mesh = problem.mesh
    if state_scene is None:
        state_scene = scene if lam == scene.prestretch else scene.updated(prestretch=lam)
    res = Result(
        solver="fem",
        x=out.y.reshape(-1, 3).copy(),
        x0=problem.X.copy(),
        converged=converged,
        status=status,
        message=message,
        iterations=iterations,
        residual=residual,
        wall_time=wall,
        energy=_energy(ev),
        residual_history=np.array([v for r in out.records for v in r.residuals]),
        prestretch=lam,
        frame_nodes=mesh.frame_nodes.copy(),
        frame_s=mesh.frame_s.copy(),
        scene=state_scene,
        blocks=blocks(problem, out.y, state_scene),
        point_data={},
        info=_info(problem, out, requested, steps_total, stability, compressed, slack),
    )
    res.check_crossings(mesh.film_cells[:, :3], contact_checked=True)  # the path stops at every contact
    return res


def _energy(ev: Evaluation) -> dict[str, float]:
    """The energy parts of a state (N mm) and their total."""
    energy = {k: ev.parts.get(k, 0.0) for k in ENERGY_KEYS if k != "total"}
    energy["total"] = sum(energy.values())
    return energy


def stress_free(scene: Scene, lam: float) -> bool:
    """Whether the state at pre-stretch ``lam`` is the flat, stress-free film: no pre-stretch and
    no voltage (with a voltage on, the Maxwell stress compresses the film at lambda = 1)."""
    return lam == 1.0 and highest_voltage(scene) == 0.0


def _relative_residual(problem: DemesProblem, ev: Evaluation, lam: float) -> float:
    """Largest free nodal force over the force scale (0 at the flat, stress-free state)."""
    residual = ev.gradient[problem.free]
    return 0.0 if stress_free(problem.scene, lam) else float(np.abs(residual).max() / ev.force_scale)


def _stability(problem: DemesProblem, out: Outcome) -> Stability:
    """The lowest eigenvalue of a converged state, and its stability (the flat, stress-free state
    is stable by definition; a tangent that cannot be factorised leaves it unknown: unstable)."""
    lam = out.prestretch
    flat = stress_free(problem.scene, lam)
    omega = float("nan")
    if not flat:
        try:
            omega = lowest_free_mode(problem, out.y)[0] if out.converged else float("nan")
        except NotFactorizable:
            pass
    stable = bool(omega > -neutral_stiffness(problem.scene)) if np.isfinite(omega) else flat
    return Stability(omega, stable)


def _status_and_message(scene: Scene, out: Outcome, requested: float, residual: float, iterations: int,
                        stability: Stability, compressed: float) -> tuple[str, bool, str]:
    """The state's status, whether it counts as converged, and the sentence that says so: a
    non-linear film in compression over more than 1 % of its area is not a converged state."""
    lam = out.prestretch
    status, converged = out.status, out.converged
    message = (f"lambda = {lam:.3f}: {STATUS_WORDS[status]}; relative residual {residual:.1e} after {iterations} "
               f"Newton iterations in {len(out.records)} continuation steps")
    if out.detail:
        message += f"; {out.detail}"
    if converged:
        message += (f"; {'stable' if stability.stable else 'UNSTABLE'} (lowest eigenvalue {stability.omega:.3g} N/mm^3)"
                    if not stress_free(scene, lam) else "; the flat state")
    if scene.membrane.law != "linear" and compressed > 0.01:
        status, converged = "compression", False
        message += (f"; the {scene.membrane.law} film is in compression over {100 * compressed:.1f} % of its "
                    "area: it would wrinkle, which this membrane model does not represent")
    if out.snaps:
        message += "; " + jumps_message(out.snaps)
    if lam < requested - 1e-12:
        message += f"; the requested lambda = {requested:.3f} was not reached"
    return status, converged, message


def _info(problem: DemesProblem, out: Outcome, requested: float, steps_total: int, stability: Stability,
          compressed: float, slack: tuple[float, float]) -> dict:
    """The state's ``info``: its path, stability, mesh and model, and what the film does."""
    scene, mesh = problem.scene, problem.mesh
    info = {
        "newton": [r.as_dict() for r in out.records],
        "newton_tails": newton_tails(out.records),
        "lowest_eigenvalue_N_per_mm3": stability.omega,
        "stable": stability.stable,
        "continuation_steps": len(out.records),
        "continuation_steps_total": steps_total,
        "n_dofs": problem.n_dofs,
        "n_free_dofs": int(problem.free.size),
        "n_elements": int(mesh.cells.shape[0]),
        "refinement": int(round(np.log2(scene.spacing / mesh.spacing))),
        "element": mesh.element,
        "mesh_size_mm": mesh.spacing,
        "frame_model": scene.frame.model,
        "film_offset_mm": problem.offset,
        "director_lever_mm": scene.frame.lever,
        "compressed_area_fraction": compressed,
        "slack_area_fraction_any": slack[0],
        "slack_area_fraction_full": slack[1],
        "energy_membrane_paper_formula": paper_formula_membrane_energy(problem, out.y),
        "requested_prestretch": requested,
    }
    if out.first_contact is not None:
        info["first_contact_prestretch"] = out.first_contact
    if out.snaps:
        info["snaps"] = out.snaps
    return info
