"""What ``demes validate`` runs: the core comparison, and each study's runs.

A run is one solver on one variant of the scene over a list of pre-stretches. The core runs are
DR (the paper's model and the matched one) and the FEM reference levels over the sweep, and DR's
own refinement; the studies (:mod:`validation.report.studies`) add theirs. The plan lists runs only; executing them is :mod:`validation.report.runner`, comparing them :mod:`validation.report.compare`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np

# the scene variants every comparison is about (dotted scene changes)
PAPER_DR = {"frame.model": "paper", "dr.membrane_net": "clustered"}  # the paper's model
# DR on the FEM's own discrete problem: membrane triangles on its mesh, its rod, bond, supports
MATCHED = {"frame.model": "strip", "dr.membrane_net": "triangles"}
LINKS = {"frame.model": "strip", "dr.membrane_net": "links"}  # the paper's lattice, strip frame
REFERENCE = {"frame.model": "strip"}  # the FEM reference: continuum membrane + strip

@dataclass(frozen=True)
class Run:
    """One sweep of one solver on one scene variant.

    Attributes
    ----------
    label
        Unique name; the folder of its files under ``runs/``.
    solver
        'dr' or 'fem'.
    changes
        Scene field changes (dotted names) on top of the validated scene.
    prestretches
        Pre-stretch ratios, solved in increasing order (continuation / warm start).
    refinement
        FEM refinement level.
    group
        'sweep' (the main comparison), 'reference' (FEM levels), 'drconv' (DR's own
        refinement), or a study's group.
    title
        What the run shows, for tables.
    cold
        Solve each pre-stretch from scratch (timings of the speed study) instead of a sweep.
    voltages
        A voltage run (group 'experiment', :mod:`validation.report.studies.experiment`): these voltages (V) at
        the scene's pre-stretch, one warm-started path; ``prestretches`` is then empty.
    calibrate
        Fit the scene to the experiment before the voltage run (:func:`validation.actuation.calibrate.fit`).
    polish
        Newton-polish each (cold) DR state with the FEM on the same mesh
        (:func:`fem_reference.solve_from`) and keep the FEM's state with its stability: the
        search for second stable states (group 'second').
    """

    label: str
    solver: str
    changes: dict[str, Any] = field(default_factory=dict)
    prestretches: tuple[float, ...] = ()
    refinement: int = 0
    group: str = "sweep"
    title: str = ""
    cold: bool = False
    voltages: tuple[float, ...] = ()
    calibrate: bool = False
    polish: bool = False


@dataclass(frozen=True)
class Plan:
    """All runs of one validation, and the settings the comparisons need."""

    runs: tuple[Run, ...]
    sweep: tuple[float, ...]  # the pre-stretch levels of the main comparison
    speed_prestretch: float  # the state of the speed-against-error study
    reference_levels: tuple[int, ...]  # FEM refinement levels extrapolated to the reference

    def by_group(self, group: str) -> list[Run]:
        return [r for r in self.runs if r.group == group]

    def get(self, label: str) -> Run:
        return next(r for r in self.runs if r.label == label)


def levels_between(lo: float, hi: float, step: float) -> tuple[float, ...]:
    return tuple(float(v) for v in np.round(np.arange(lo, hi + step / 2, step), 6))


@dataclass(frozen=True)
class Settings:
    """What the full and the quick plan differ in (a study derives its own choices from ``quick``)."""

    quick: bool
    sweep: tuple[float, ...]  # the main comparison's pre-stretch levels
    coarse: dict[str, Any]  # scene changes of the runs on the scene's own mesh
    levels: tuple[int, ...]  # FEM reference refinement levels
    element: str  # the FEM reference's membrane element
    speed_lam: float  # the pre-stretch of DR's third refinement level, the speed study and the error budget
    dr_meshes: tuple[int, ...]  # DR's mesh densities (its refinement: the doubling chain among them)
    dr_tols: tuple[float, ...]  # DR's tolerances

    @property
    def fem_study(self) -> dict[str, Any]:
        """The FEM reference's scene changes: its own element, which the FEM runs of the error
        budget and the speed study use too (a model-form row changes one ingredient, not the element)."""
        return {**self.coarse, **REFERENCE, "fem.element": self.element}

    @property
    def tight(self) -> float:
        """DR's tightest tolerance: its own refinement and the nets' are solved to it."""
        return min(self.dr_tols)


def settings(quick: bool) -> Settings:
    """The full plan's settings, or the quick plan's: the same study on a coarse mesh and three
    pre-stretch levels, so that every table and figure of the report is produced in minutes."""
    if quick:
        # P1: the quick plan checks the harness, not the reference's accuracy
        return Settings(quick=True, sweep=(1.0, 1.15, 1.3), coarse={"mesh.divisions": 8}, levels=(0, 1),
                        element="P1", speed_lam=1.3, dr_meshes=(4, 6, 8), dr_tols=(1e-4, 1e-6))
    # levels: r0-r2 at every pre-stretch; r1-r3 where r0-r2 are not enough. Quadratic triangles:
    # measured against P1 at equal DOFs, the r0-r2 error estimate at 1.4-1.7 falls from
    # 1.2/0.51/5.0/0.82 deg to 0.18/0.34/0.51/0.53 deg
    return Settings(quick=False, sweep=levels_between(1.0, 2.0, 0.1), coarse={}, levels=(0, 1, 2, 3), element="P2",
                    speed_lam=1.3, dr_meshes=(10, 14, 20, 28, 40), dr_tols=(1e-4, 1e-5, 1e-6))


def build_plan(quick: bool = False, *, studies: Sequence[Any] = ()) -> Plan:
    """The full plan (100-200 % in 10 % steps, FEM P2 levels r0-r2, r3 at 160-170 %), or the
    quick one (:func:`settings`), with the runs of each study (:class:`validation.report.study.Study`)."""
    s = settings(quick)
    runs = [*main_runs(s), *reference_runs(s), *drconv_runs(s)]
    for study in studies:
        runs += study.runs(s)
    return Plan(tuple(runs), s.sweep, s.speed_lam, s.levels)


def main_runs(s: Settings) -> list[Run]:
    """The main comparison: DR as the paper built it and DR matched to the FEM, over the sweep."""
    return [
        Run("dr_paper", "dr", {**s.coarse, **PAPER_DR}, s.sweep,
            title="DR as the paper built it: clustered net, isotropic frame (Table I)"),
        Run("dr_matched", "dr", {**s.coarse, **MATCHED}, s.sweep,
            title="DR matched to the FEM: membrane triangles on its mesh, strip frame"),
    ]


def reference_runs(s: Settings) -> list[Run]:
    """The FEM reference levels. The finest level costs minutes a state: it runs only where the
    r0-r2 estimate misses 0.5 deg (the curl's turn at 1.6-1.7), and the reference there
    extrapolates r1-r3."""
    finest = s.sweep if s.quick else (1.6, 1.7)
    return [Run(f"fem_r{k}", "fem", s.fem_study, finest if k == s.levels[-1] else s.sweep, refinement=k,
                group="reference", title=f"FEM reference, strip frame, {s.element}, refinement {k}")
            for k in s.levels]


def drconv_runs(s: Settings) -> list[Run]:
    """DR's own refinement over the whole sweep: its limit beside the FEM's at every pre-stretch.
    A third level (40 divisions: 5 min a state) runs only at the speed study's pre-stretch,
    where the limit then has its observed order; elsewhere two levels, with the formal one."""
    return [Run(f"drconv_n{n}", "dr", {**MATCHED, "mesh.divisions": n, "dr.tolerance": s.tight},
                (s.speed_lam,) if i >= 2 else s.sweep, group="drconv", title=f"DR matched, {n} divisions, tol {s.tight:.0e}")
            for i, n in enumerate(doubling_chain(s.dr_meshes))]








def doubling_chain(meshes: Sequence[int]) -> list[int]:
    """The longest chain n, 2n, 4n, ... among the mesh densities."""
    best: list[int] = []
    for n in meshes:
        chain = [n]
        while chain[-1] * 2 in meshes:
            chain.append(chain[-1] * 2)
        best = max(best, chain, key=len)
    return best if len(best) >= 2 else []
