"""What ``demes validate`` runs: solver sweeps, the speed-against-error study and hard cases.

A run is one solver on one variant of the scene over a list of pre-stretches. The plan lists
runs only; executing them is :mod:`validation.report.runner`, comparing them :mod:`validation.report.compare`.
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
NETS = {"links": LINKS, "clustered": {**PAPER_DR, "frame.model": "strip"}}  # the paper's nets on the strip

HARD_FEM_TIME_LIMIT = {False: 240.0, True: 60.0}
"""Wall-time budget (s) of a hard case's FEM run, full and quick mode."""


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
        'sweep' (the main comparison), 'reference' (FEM levels), 'speed', 'budget', 'drconv'
        (DR's own refinement), 'netconv' (the nets' own refinement), 'second' (other stable
        states), 'hard', 'experiment' (voltage sweeps).
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


def _levels(lo: float, hi: float, step: float) -> tuple[float, ...]:
    return tuple(float(v) for v in np.round(np.arange(lo, hi + step / 2, step), 6))


@dataclass(frozen=True)
class Settings:
    """What the full and the quick plan differ in."""

    quick: bool
    sweep: tuple[float, ...]  # the main comparison's pre-stretch levels
    coarse: dict[str, Any]  # scene changes of the runs on the scene's own mesh
    levels: tuple[int, ...]  # FEM reference refinement levels
    element: str  # the FEM reference's membrane element
    speed_lam: float  # the pre-stretch of the speed study and the error budget
    dr_meshes: tuple[int, ...]  # DR mesh densities of the speed study
    dr_tols: tuple[float, ...]  # DR tolerances of the speed study
    hard_lams: tuple[float, ...]  # pre-stretches of the hard cases
    second_lams: tuple[float, ...]  # pre-stretches of the search for second stable states
    dr_graded: tuple[tuple[int, float, int], ...] = ()  # DR's graded meshes: (divisions, grading, refinement)
    graded_tols: tuple[float, ...] = ()  # their tolerances
    fem_graded: tuple[tuple[str, int, float, int], ...] = ()  # the FEM's: (element, divisions, grading, refinement)

    @property
    def fem_study(self) -> dict[str, Any]:
        """The FEM reference's scene changes: its own element, which the FEM runs of the error
        budget and the speed study use too (a model-form row changes one ingredient, not the element)."""
        return {**self.coarse, **REFERENCE, "fem.element": self.element}

    @property
    def tight(self) -> float:
        """DR's tightest tolerance: its own refinement and the nets' are solved to it."""
        return min(self.dr_tols)


GRADED_DR = ((20, 2.0, 0), (14, 2.0, 1), (28, 4.0, 0), (14, 4.0, 1), (20, 4.0, 1))
"""The speed study's graded meshes of DR (divisions, mesh.grading, fem.refinement): the P1
shape error at 130 % lives at the frame, so grading towards it buys the most per unknown
(docs/discrete-problem.md, "Graded meshes")."""

GRADED_FEM = (("P1", 20, 2.0, 0), ("P2", 14, 2.0, 0), ("P1", 14, 4.0, 1), ("P2", 14, 4.0, 0), ("P2", 14, 4.0, 1))
"""The FEM's graded meshes in the speed study (element, divisions, mesh.grading, refinement):
P1 too, which on a graded mesh reaches 0.1 % sooner than P2 (measured)."""

def settings(quick: bool) -> Settings:
    """The full plan's settings, or the quick plan's: the same study on a coarse mesh and three
    pre-stretch levels, so that every table and figure of the report is produced in minutes."""
    if quick:
        # P1: the quick plan checks the harness, not the reference's accuracy
        return Settings(quick=True, sweep=(1.0, 1.15, 1.3), coarse={"mesh.divisions": 8}, levels=(0, 1),
                        element="P1", speed_lam=1.3, dr_meshes=(4, 6, 8), dr_tols=(1e-4, 1e-6),
                        hard_lams=(1.0, 1.3), second_lams=(1.15, 1.3), dr_graded=((6, 2.0, 0),),
                        graded_tols=(1e-6,), fem_graded=(("P1", 6, 2.0, 0),))
    # levels: r0-r2 at every pre-stretch; r1-r3 where r0-r2 are not enough. Quadratic triangles:
    # measured against P1 at equal DOFs, the r0-r2 error estimate at 1.4-1.7 falls from
    # 1.2/0.51/5.0/0.82 deg to 0.18/0.34/0.51/0.53 deg. Second states: below first contact (about 1.77)
    return Settings(quick=False, sweep=_levels(1.0, 2.0, 0.1), coarse={}, levels=(0, 1, 2, 3), element="P2",
                    speed_lam=1.3, dr_meshes=(10, 14, 20, 28, 40), dr_tols=(1e-4, 1e-5, 1e-6),
                    hard_lams=(1.0, 1.3, 1.5), second_lams=_levels(1.1, 1.7, 0.1),
                    dr_graded=GRADED_DR, graded_tols=(1e-5, 1e-6, 1e-7), fem_graded=GRADED_FEM)


def build_plan(quick: bool = False, *, studies: Sequence[Any] = ()) -> Plan:
    """The full plan (100-200 % in 10 % steps, FEM P2 levels r0-r2, r3 at 160-170 %), or the
    quick one (:func:`settings`), with the runs of each study (:class:`validation.report.study.Study`)."""
    s = settings(quick)
    runs = [*main_runs(s), *reference_runs(s), *budget_runs(s), *speed_dr_runs(s), *speed_graded_dr_runs(s),
            *drconv_runs(s),
            *netconv_runs(s), second_states_run(s), *speed_fem_runs(s), *hard_cases(s.coarse, s.hard_lams, quick)]
    for study in studies:
        runs += study.runs(coarse=s.coarse, quick=quick)
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


def budget_runs(s: Settings) -> list[Run]:
    """Model-form error: one ingredient changed at a time against the matched DR model, at the
    speed study's pre-stretch (the error budget's), each from the flat state (measured: DR
    matched reached 1.3 from flat in 39 s, and through 1.1 and 1.2 in 378 s)."""
    lam, c, fem = (s.speed_lam,), s.coarse, s.fem_study
    return [
        Run("dr_links_strip", "dr", {**c, **LINKS}, lam, group="budget", cold=True,
            title="DR link net, strip frame (the paper's lattice alone)"),
        Run("dr_clustered_strip", "dr", {**c, **PAPER_DR, "frame.model": "strip"}, lam, group="budget", cold=True,
            title="DR clustered net, strip frame (clustering alone)"),
        Run("dr_links_paper", "dr", {**c, **LINKS, "frame.model": "paper"}, lam, group="budget", cold=True,
            title="DR link net, isotropic frame (frame model alone)"),
        Run("dr_matched_bt3", "dr", {**c, **MATCHED, "frame.I": None}, lam, group="budget", cold=True,
            title="DR matched, weak-axis I = b t^3/12 instead of Table I's 0.0003 mm^4"),
        Run("fem_paper_r0", "fem", {**fem, "frame.model": "paper"}, lam, group="budget", cold=True,
            title="FEM, isotropic frame (Table I), refinement 0"),
        Run("fem_bt3_r0", "fem", {**fem, "frame.I": None}, lam, group="budget", cold=True,
            title="FEM, weak-axis I = b t^3/12, refinement 0"),
        Run("fem_film_r0", "fem", {**fem, "frame.film_offset": True}, lam, group="budget", cold=True,
            title="FEM, film bonded on the strip's top face, refinement 0"),
    ]


def speed_dr_runs(s: Settings) -> list[Run]:
    """Speed against error: DR over mesh density and tolerance, each state from scratch."""
    return [Run(f"speed_dr_n{n}_tol{tol:.0e}", "dr", {**MATCHED, "mesh.divisions": n, "dr.tolerance": tol},
                (s.speed_lam,), group="speed", title=f"DR matched, {n} divisions, tol {tol:.0e}", cold=True)
            for n in s.dr_meshes for tol in s.dr_tols]


def speed_graded_dr_runs(s: Settings) -> list[Run]:
    """DR on graded meshes (mesh.grading), each state from scratch."""
    return [Run(f"speed_dr_n{n}_g{g:g}{f'_r{k}' if k else ''}_tol{tol:.0e}", "dr",
                {**MATCHED, "mesh.divisions": n, "mesh.grading": g, "fem.refinement": k, "dr.tolerance": tol},
                (s.speed_lam,), group="speed", cold=True,
                title=f"DR matched, {n} divisions graded {g:g}{f', refinement {k}' if k else ''}, tol {tol:.0e}")
            for n, g, k in s.dr_graded for tol in s.graded_tols]


def drconv_runs(s: Settings) -> list[Run]:
    """DR's own refinement over the whole sweep: its limit beside the FEM's at every pre-stretch.
    A third level (40 divisions: 5 min a state) runs only at the speed study's pre-stretch,
    where the limit then has its observed order; elsewhere two levels, with the formal one."""
    return [Run(f"drconv_n{n}", "dr", {**MATCHED, "mesh.divisions": n, "dr.tolerance": s.tight},
                (s.speed_lam,) if i >= 2 else s.sweep, group="drconv", title=f"DR matched, {n} divisions, tol {s.tight:.0e}")
            for i, n in enumerate(doubling_chain(s.dr_meshes))]


def netconv_runs(s: Settings) -> list[Run]:
    """The paper's nets refined by the same doubling of the mesh: their own limits, so that the
    model-form rows compare limits, not two discretisation errors."""
    return [Run(f"netconv_{net}_n{n}", "dr", {**variant, "mesh.divisions": n, "dr.tolerance": s.tight},
                (s.speed_lam,), group="netconv", title=f"DR {net} net, strip frame, {n} divisions")
            for n in doubling_chain(s.dr_meshes) for net, variant in NETS.items()]


def second_states_run(s: Settings) -> Run:
    """Other stable states: the pre-stretch applied at once from flat (the paper's way; its
    transient can land off the quasi-static path), each state polished and checked by the FEM."""
    return Run("second_states", "dr", {**s.coarse, **MATCHED, "dr.prestretch_step": 0.0, "dr.tolerance": s.tight},
               s.second_lams, group="second", cold=True, polish=True,
               title="DR matched, pre-stretch at once from flat, polished by the FEM (r0)")


def speed_fem_runs(s: Settings) -> list[Run]:
    """The FEM in the speed study, from the flat state each time, up to r2 (r3 would add
    minutes for one point), and on the graded meshes (:data:`GRADED_FEM`)."""
    return [Run(f"speed_fem_r{k}", "fem", s.fem_study, (s.speed_lam,), refinement=k, group="speed",
                title=f"FEM, {s.element}, refinement {k}", cold=True)
            for k in s.levels[:3]] + [
        Run(f"speed_fem_{el}_n{n}_g{g:g}_r{k}", "fem",
            {**s.fem_study, "fem.element": el, "mesh.divisions": n, "mesh.grading": g},
            (s.speed_lam,), refinement=k, group="speed", cold=True,
            title=f"FEM, {el}, {n} divisions graded {g:g}, refinement {k}")
        for el, n, g, k in s.fem_graded]


def doubling_chain(meshes: Sequence[int]) -> list[int]:
    """The longest chain n, 2n, 4n, ... among the mesh densities."""
    best: list[int] = []
    for n in meshes:
        chain = [n]
        while chain[-1] * 2 in meshes:
            chain.append(chain[-1] * 2)
        best = max(best, chain, key=len)
    return best if len(best) >= 2 else []


def hard_cases(coarse: dict[str, Any], lams: tuple[float, ...], quick: bool) -> list[Run]:
    """Numerical-stability cases, each run by DR on the paper's link net (and by the FEM where
    it has a counterpart): they stress DR's time stepping, which the net exercises as the
    triangles do, at a third of the triangles' cost per step."""
    cases: list[tuple[str, dict[str, Any], tuple[float, ...], str]] = [
        ("zero_prestretch", {}, (1.0,), "no pre-stretch: must stay flat with no energy"),
        ("tiny_prestretch", {}, (1.001,), "pre-stretch 1.001"),
        ("very_high_prestretch", {}, (2.5, 3.0) if not quick else (2.0,), "pre-stretch beyond the paper's 200 %"),
        ("stiff_frame", {"frame.E": 260000.0}, lams, "frame 100x stiffer"),
        ("soft_frame", {"frame.E": 26.0}, lams, "frame 100x softer"),
        ("coarse_mesh", {"mesh.divisions": 4}, lams, "4 divisions per side"),
        ("asymmetric", {"perturbation.asymmetry": 2.0}, lams, "antisymmetric tilt of the sides, 2 mm"),
        ("tiny_perturbation", {"perturbation.amplitude": 1e-4}, lams, "apex lift 1e-4 mm"),
        ("square_frame", {"frame.outline": "polygon", "frame.vertices": [[-20.0, 0.0], [20.0, 0.0], [20.0, 40.0], [-20.0, 40.0]]},
         lams, "square frame outline (40 mm sides)"),
    ]
    if not quick:
        cases.append(("fine_mesh", {"mesh.divisions": 56}, (1.3,), "56 divisions per side"))
    runs = []
    for name, change, case_lams, title in cases:
        runs.append(Run(f"hard_dr_{name}", "dr", {**coarse, **LINKS, **change}, case_lams, group="hard", title=title))
        if name not in ("fine_mesh",):
            # a hard case may make the reference crawl (measured: the 100x softer frame took 20 min
            # to get from 1.0 to 1.12); its time limit keeps the report's budget
            limit = {"fem.time_limit": HARD_FEM_TIME_LIMIT[quick]}
            runs.append(Run(f"hard_fem_{name}", "fem", {**coarse, **REFERENCE, **change, **limit}, case_lams, group="hard",
                            title=title))
    # below f = 1 the time step is unstable and the scene refuses it (dr.relax itself, given one,
    # stops with status 'diverged' before any contact is reported: tests/test_errors.py)
    runs.append(Run("hard_dr_mass_safety_1", "dr", {**coarse, **LINKS, "dr.mass_safety": 1.0}, lams, group="hard",
                    title="DR mass safety factor f = 1 (the stability bound; scenes refuse f < 1)"))
    return runs
