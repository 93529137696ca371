"""DR solution of a DEMES scene: ``solve`` one state along the pre-stretch path (stepping off
saddles along their lowest mode), ``sweep`` pre-stretch; the model is built by
:mod:`dr.demes_model`, the state's measures by :mod:`dr.demes_measures`."""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Iterator, Sequence

import numpy as np

from results import CellBlock, Result
from results.path import (AFTER_EVENT, LOCATE, jump_distance, jumped, jumps_message, largest_move, planar, strayed,
                          turned)
from scenes import Scene
from scenes.mesh import membrane_mesh
from scenes.transfer import transfer_linear

from . import stability
from .demes_measures import asymmetry, paper_formula_membrane_energy, slack_fractions
from .demes_model import DemesModel, build, set_prestretch
from .film_cells import film_surface
from .relax import relax
from .saddles import lowest_mode, off_saddles, relax_settings
from .symmetry import kept_by, restore


LEASH = 1.0
"""A path step whose relaxation takes a node this many times the jump distance
(:func:`results.path.jump_distance`) from where it started is given up and cut, as a step
found to have jumped is, before it reaches the far state: on an octagon's turn three such
trials took 29,126 of the path's 79,860 steps relaxed to their end, 16,519 on the leash. A
relaxation that passes the jump distance on its way and settles within it costs a cut step."""


def solve(scene: Scene, prestretch: float | None = None, x_start: np.ndarray | None = None,
          progress: bool = False, from_prestretch: float = 1.0, path_rate: float | None = None,
          path_move: np.ndarray | None = None) -> Result:
    """Equilibrium of ``scene`` by dynamic relaxation (the paper's model).

    The pre-stretch is raised from ``from_prestretch`` to ``prestretch`` in steps of
    ``scene.dr.prestretch_step``, each relaxed to ``scene.dr.tolerance``: a quasi-static path
    that follows the rules of :mod:`results.path`, as the FEM's continuation. Applied at once,
    the pseudo-dynamic transient can settle on another equilibrium (measured: the strip frame
    at 115 % ends twisted at 1.060 N mm from one jump, curled at 1.015 N mm by steps). The path
    starts from the flat state. With ``scene.dr.prestretch_step_max`` the steps double after
    each converged step up to it; a step that stops is retried at half its size from the last
    converged state. Every converged state is checked for stability (its lowest mode with DR's
    masses, :mod:`dr.stability`); a step within which the branch lost its stability, left the
    flat state or jumped is halved until it is shorter than ``results.path.LOCATE``, and the
    saddle there is left along its lowest mode on the lift's side. With ``scene.dr.coarse_start`` (triangles at ``fem.refinement >= 1``,
    from the flat state) the path is followed on refinement 0 and its state, interpolated onto
    the fine mesh, relaxed there at ``scene.dr.tolerance``; if that does not converge the fine
    mesh follows the path by itself.

    Parameters
    ----------
    prestretch
        Pre-stretch ratio (default ``scene.prestretch``).
    x_start
        Start positions (n, 3) mm: a state at ``from_prestretch`` (default: the flat state).
    from_prestretch
        The pre-stretch of the start state.
    path_rate
        The path's rate at the start state (``info['path_rate']`` of the state it was solved
        as), mm per unit pre-stretch, so that a jump on the first step is found too.
    path_move
        The path's last step's move at the start state (n, 3) mm (``info['path_move']``), so
        that a first step turning off the branch is found too (:func:`results.path.turned`).
    """
    t0 = time.perf_counter()
    lam = scene.prestretch if prestretch is None else float(prestretch)
    dm = build(scene, lam)
    runs = _relaxations(scene, dm, lam, x_start=x_start, from_prestretch=from_prestretch,
                        progress=progress, path_rate=path_rate, path_move=path_move)
    res = _path_result(scene, dm, runs, requested=lam)
    # the state's cost as the FEM counts its own: the model, the stability checks and the
    # steps off saddles included, not only the relaxations (info['relaxation_time'])
    res.wall_time = time.perf_counter() - t0
    return res


@dataclass(frozen=True)
class PathRuns:
    """The relaxations that reached a state of :func:`solve`, in order."""

    runs: list[Result]  # every relaxation: their iterations and times add up
    path: list[float]  # the pre-stretch levels tried, the last one the state's
    coarse: Result | None  # the state on refinement 0 the fine mesh started from (None: no such start)
    coarse_failed: Result | None  # the fine mesh's relaxation from it, where it did not converge
    snaps: list[tuple[float, float]]  # jumps located on the way: (last level on the branch, first off it)
    rate: float | None  # the path's rate at the end, mm per unit pre-stretch (results.path.jumped)
    last_move: np.ndarray | None  # the path's last step's move at the end, mm (results.path.turned)

    @property
    def iterations(self) -> int:
        return sum(r.iterations for r in self.runs)

    @property
    def wall_time(self) -> float:
        """s"""
        return sum(r.wall_time for r in self.runs)

    def history(self) -> np.ndarray:
        """The residual histories end to end (k, 2), iterations counted from the first run's start."""
        parts, done = [], 0
        for r in self.runs:
            if r.residual_history.size:
                parts.append(r.residual_history + np.array([[done, 0.0]]))
            done += r.iterations
        return np.vstack(parts) if parts else self.runs[-1].residual_history


def _relaxations(scene: Scene, dm: DemesModel, lam: float, *, x_start: np.ndarray | None,
                 from_prestretch: float, progress: bool, path_rate: float | None,
                 path_move: np.ndarray | None) -> PathRuns:
    """Relax ``dm`` to pre-stretch ``lam`` as :func:`solve` says: from refinement 0's state, or
    along the pre-stretch path."""
    st = scene.dr
    coarse = None
    if x_start is None and st.coarse_start and st.membrane_net == "triangles" and scene.fem.refinement > 0:
        coarse = solve(scene.updated(**{"fem.refinement": 0}), lam, progress=progress, from_prestretch=from_prestretch)
    if x_start is None and st.prestretch_step == 0:
        x_start = dm.start  # at once, as the paper did: the pseudo-dynamic transient from the lift
    elif x_start is None:
        # the flat state: an equilibrium that the stability check leaves along its lowest mode,
        # on the lift's side (the lift itself need not be that mode: on a rectangle its
        # transient ends on the mirror branch)
        x_start = dm.model.nodes.copy()
    settings = relax_settings(scene, dm)
    runs: list[Result] = []
    levels, coarse_failed = PathLevels([lam], [], path_rate, path_move), None
    if coarse is not None:
        runs.append(coarse)
        if coarse.converged:
            runs.append(relax(dm.model, tol=st.tolerance, x_start=_coarse_to_fine(scene, coarse.x, dm),
                              progress=progress, **settings))
        coarse_failed = None if runs[-1].converged else runs[-1]
    if coarse is None or coarse_failed is not None:
        levels = _follow_path(scene, dm, x_start, from_prestretch, lam, runs, relax_with=settings,
                              progress=progress, trend=levels)
    return PathRuns(runs, levels.tried, coarse, coarse_failed, levels.snaps, levels.rate, levels.last_move)


def _path_result(scene: Scene, dm: DemesModel, runs: PathRuns, *, requested: float) -> Result:
    """The Result of the state the last relaxation of ``runs`` reached, with the whole path's
    iterations, time and residual history, the scene at the pre-stretch reached, and the DEMES
    measures (slack areas, the paper's energy formula, the asymmetry, crossings)."""
    last, reached = runs.runs[-1], runs.path[-1]
    # a path that stopped on the way is reported where it stopped, not where it was headed
    state_scene = scene if reached == scene.prestretch else scene.updated(prestretch=reached)
    message = _path_message(last.message, runs, requested=requested)
    info = {**last.info, **_model_info(scene, dm, runs)}
    info["slack_area_fraction_any"], info["slack_area_fraction_full"] = slack_fractions(dm, last)
    if dm.net is not None:  # the formula is a sum over tension elements: the nets only
        info["energy_membrane_paper_formula"] = paper_formula_membrane_energy(dm.model, last.x)
    if dm.mirror is not None:
        asym = asymmetry(last.x, dm.mirror)
        info["asymmetry_mm"] = asym
        if scene.perturbation.asymmetry == 0.0 and asym > 1e-3 * scene.outline.side_length:
            message += f"; the mirror symmetry broke (asymmetry {asym:.3g} mm)"
    res = replace(
        last, iterations=runs.iterations, wall_time=runs.wall_time, residual_history=runs.history(),
        scene=state_scene, prestretch=reached, frame_nodes=dm.frame_nodes, frame_s=dm.frame_s, message=message,
        blocks={**last.blocks, "membrane_surface": film_surface(dm.model, last.x, state_scene), **_members(dm)},
        info=info,
    )
    res.check_crossings(dm.model.triangles, contact_checked=scene.dr.check_contact)
    return res


def _path_message(message: str, runs: PathRuns, *, requested: float) -> str:
    """The last relaxation's ``message`` with the pre-stretch reached and how the path got there."""
    reached = runs.path[-1]
    message = f"lambda = {reached:.3f}: {message}"
    if runs.coarse is not None:
        message += (f" (started from refinement 0's state, {runs.coarse.iterations} of the iterations there)"
                    if runs.coarse_failed is None
                    else f" (the start from refinement 0 failed: {runs.coarse_failed.message})")
    if len(runs.path) > 1:
        message += f" (pre-stretch step {len(runs.path)}; {runs.iterations} iterations in all)"
    if runs.snaps:
        message += "; " + jumps_message(runs.snaps)
    if reached < requested:
        message += f"; the requested lambda = {requested:.3f} was not reached"
    return message


def _model_info(scene: Scene, dm: DemesModel, runs: PathRuns) -> dict:
    """The DR model's sizes and the path's length for ``Result.info``."""
    return dict(
        n_nodes=dm.model.n,
        n_free_dofs=int(np.count_nonzero(~dm.model.fixed[: dm.model.n])),
        n_frame_nodes=dm.frame_nodes.size,
        n_cables=len(dm.net.cables) if dm.net is not None else 0,
        n_triangles=int(dm.model.triangles.shape[0]) if dm.net is None else 0,
        spacing_mm=dm.spacing,
        cable_area_mm2=dm.cable_area,
        membrane_net=scene.dr.membrane_net,
        frame_model=scene.frame.model,
        prestretch_steps=len(runs.path),
        coarse_iterations=runs.coarse.iterations if runs.coarse is not None else 0,
        reached_prestretch=runs.path[-1],
        snaps=runs.snaps,
        relaxation_time=runs.wall_time,
        path_rate=runs.rate,
        path_move=runs.last_move,
    )


def _follow_path(scene: Scene, dm: DemesModel, x_start: np.ndarray, start: float, stop: float,
                 runs: list[Result], *, relax_with: dict, progress: bool, trend: PathLevels) -> PathLevels:
    """Relax ``dm`` along the pre-stretch path from ``x_start`` at ``start`` to ``stop``
    (see :func:`solve`), appending every relaxation to ``runs``; ``trend``: the path's rate
    and last move at ``start`` for the jump tests (:func:`results.path.jumped`,
    :func:`results.path.turned`)."""
    st = scene.dr
    levels = PathLevels([], [], trend.rate, trend.last_move)
    step, largest = st.prestretch_step, max(st.prestretch_step_max, st.prestretch_step)
    reached, current = start, stop
    side = scene.outline.side_length
    drifting: set[str] = set()  # symmetries DR's stable states do not keep on this model
    while True:
        lam = _ramp(reached, stop, step)[0]
        set_prestretch(dm.model, scene, lam, current)
        current = lam
        levels.tried.append(lam)
        last = lam == stop
        # every step to the full tolerance: a loosely relaxed state can lie tens of mm off
        # the path on a soft mode, and the jump test compares states
        # a step that would be cut as a jump is given up once it has gone LEASH times that far
        leash = (LEASH * jump_distance(lam - reached, levels.rate, side)
                 if levels.rate is not None and lam > reached and step >= 2 * LOCATE else 0.0)
        res = relax(dm.model, tol=st.tolerance, x_start=x_start, progress=progress and last, leash=leash,
                    **relax_with)
        runs.append(res)
        if res.status == "too_far":
            step *= 0.5
            continue
        on_plane = planar(x_start, dm.model.nodes, side)
        kept = [g for g in kept_by(x_start, dm.symmetries, side) if g.name not in drifting]
        broken = [g for g in kept if g not in kept_by(res.x, kept, side)] if res.converged else []
        mode = None
        if broken and step < 2 * LOCATE:
            # the state fell off a symmetric one (dr.symmetry), to a side round-off and drift
            # picked: leave the symmetric state instead along its lowest mode, on the lift's
            # side; where that state is stable, DR only drifts off it on this model (a soft
            # clustered net does, at every step): that symmetry is not followed further
            symmetric = replace(res, x=restore(x_start, kept, dm.model.fixed))
            mode = lowest_mode(dm, symmetric, relax_with)
            if stability.is_negative(mode):
                res = symmetric
            else:
                drifting.update(g.name for g in broken)
                broken, mode = [], None
        broke = bool(broken)
        if mode is None and res.converged:
            mode = lowest_mode(dm, res, relax_with)
        if (mode is not None and lam > reached and step >= 2 * LOCATE
                and (broke or stability.is_saddle(mode, dm.neutral))):
            # the branch lost its stability within this step: locate where, so that it is left
            # near the bifurcation, where the side the lift asks for is still downhill
            step *= 0.5
            continue
        if mode is not None:
            res = off_saddles(scene, dm, res, runs, relax_with=relax_with, mode=mode, unstable=broke, polish=last)
        if res.status == "unstable" and not last:
            # a state still a saddle after the steps off it is left by the path's next step
            # from the last pushed state, where the mode has grown; only a requested level is
            # reported unstable (just past a bifurcation on a gripper with double members the
            # energy along the mode falls only within 0.005 mm of the saddle, and five pushes
            # each relaxed back within 1e-9 mm)
            res = runs[-1] = replace(res, converged=True, status="converged")
        if not res.converged and step > st.prestretch_step:
            step = max(0.5 * step, st.prestretch_step)  # retry from the last converged state
            continue
        if not res.converged:
            return levels
        moved = res.x - x_start
        move = largest_move(res.x, x_start)
        jump = lam > reached and (jumped(move, lam - reached, levels.rate, side)
                                  or turned(moved, levels.last_move, side)
                                  or strayed(moved, levels.last_move, levels.rate, lam - reached, side))
        event = False
        if lam <= reached:  # a state relaxed at its own pre-stretch: no path, no rate
            pass
        elif jump and step >= 2 * LOCATE and not res.info.get("saddle_steps"):
            step *= 0.5  # cut the step until the jump is located
            continue
        elif (on_plane and not planar(res.x, dm.model.nodes, side)) or res.info.get("saddle_steps") or jump:
            levels.snaps.append((reached, lam))  # left the flat state, a saddle or a branch's end
            event = True
        else:
            levels.rate = move / (lam - reached)
        if lam > reached:
            levels.last_move = None if event else moved
        if last:
            return levels
        x_start, reached = res.x, lam
        # after an event the new branch's rate is not known, and a second one can follow close
        step = AFTER_EVENT if event else min(2.0 * step, largest)
        if event:
            levels.rate = None


@dataclass
class PathLevels:
    """The pre-stretch levels a DR path tried (the last one the state's), the jumps it located
    (last level on the old branch, first on the new one), its rate at the end (mm per unit
    pre-stretch; None right after a jump) and its last step's move on the branch (n, 3) mm
    (None right after an event; :func:`results.path.turned`)."""

    tried: list[float]
    snaps: list[tuple[float, float]]
    rate: float | None
    last_move: np.ndarray | None = None


def _coarse_to_fine(scene: Scene, x_coarse: np.ndarray, dm: DemesModel) -> np.ndarray:
    """A state of the triangles on refinement 0 (positions of its mesh's nodes, mm) on the finer
    mesh of ``dm``: interpolated linearly in the flat coordinates (the outline's new boundary
    nodes extrapolated, :func:`scenes.transfer.transfer_linear`), supported coordinates back where
    the fine model holds them (the refined nodes of a held fillet would move with the film)."""
    x = transfer_linear(membrane_mesh(scene, 0), x_coarse, dm.model.nodes[:, :2])
    fixed = dm.model.fixed
    x[fixed] = dm.start[fixed]
    return x


def _ramp(start: float, stop: float, step: float) -> list[float]:
    """Pre-stretch levels from just above ``start`` to ``stop``, at most ``step`` apart."""
    if step <= 0 or stop <= start:
        return [stop]
    n = int(np.ceil((stop - start) / step - 1e-9))
    # the last level is ``stop`` itself, bit for bit: results are keyed by it; the others are
    # rounded off the float noise of the division (1.2, not 1.2000000000000002)
    return [round(start + (stop - start) * k / n, 12) for k in range(1, n)] + [float(stop)]


def _members(dm: DemesModel) -> dict[str, CellBlock]:
    """The cross-members' edges as their own VTK block (their links are in the frame's too), and
    the open windows' strip bands (scenes.windows), as the FEM writes them."""
    out = {}
    if dm.members:
        out["members"] = CellBlock("line", np.vstack([np.column_stack([c[:-1], c[1:]]) for c in dm.members]))
    if len(dm.strip_band):
        out["strip_band"] = CellBlock("triangle", dm.strip_band)
    return out


def sweep(scene: Scene, prestretches: Sequence[float], progress: bool = False,
          start: Result | None = None) -> Iterator[Result]:
    """States at increasing pre-stretch, each reached from the previous one.

    Every converged state is checked for stability; a flat one (a saddle past the buckling
    load) is left along its lowest mode on the lift's side (:func:`solve`). A state that stops (contact, fold, divergence, no
    convergence) is yielded at the pre-stretch it reached, with its status, and nothing after
    it: the path cannot go on from there (as the FEM's continuation). ``start``, a converged
    state of the same scene (e.g. the last one an interrupted sweep finished), is where the
    sweep continues from.
    """
    x_prev, lam_prev, theta, rate, move = None, 1.0, None, None, None
    if start is not None and start.converged:
        x_prev, lam_prev, theta = start.x, start.prestretch, start.bending_angle
        rate, move = start.info.get("path_rate"), start.info.get("path_move")
    for lam in sorted(set(float(v) for v in prestretches)):
        res = solve(scene, lam, x_start=x_prev, progress=progress, from_prestretch=lam_prev, path_rate=rate,
                    path_move=move)
        if theta is not None:
            res.continue_from(theta)  # the angle is continued along the sweep
        yield res
        if not res.converged:
            return
        x_prev, lam_prev, theta = res.x, lam, res.bending_angle
        rate, move = res.info.get("path_rate"), res.info.get("path_move")
