"""``relax``: find the static equilibrium of a :class:`dr.Model` by dynamic relaxation."""

from __future__ import annotations


import time
from dataclasses import dataclass
from typing import Callable, NamedTuple, Sequence

import numpy as np
from tqdm import tqdm

from results import CellBlock, Result

from . import integrator as itg
from .contact import FrameContact
from .errors import DRError
from .frame_mass import FrameMass
from .masses import Masses, masses_at, unresisted
from .stability import potential_energy
from .damping import SCHEMES
from .elements import ELEMENTS
from .finite import degenerate_elements, where_not_finite
from .kernels import Packed, energy, place_virtual
from .model import Model

Check = Callable[[np.ndarray], "str | None"]

FOLD_PATIENCE = 10
"""Chunks in a row with a folded membrane (``final_checks``) after which an unconverged run stops."""

ENERGY_RISE = 0.5
"""A run whose potential energy (strain energy less the work of the loads) rose above its
starting value by this fraction of the larger of the two is diverging: kinetic damping only
ever takes energy out, so such a rise is the time step pumping it in (masses below the
stability bound). The kinetic energy is left out: with masses that follow the stiffness it is
not conserved, and a stable loaded run measured 1.6x its potential drop in it."""

MASS_EVERY = 100
"""Steps between refreshes of the stiffness bounds behind the masses (tensor masses also
follow the link directions and strip frames, see :data:`DRIFT_TURN`)."""

DRIFT_TURN = 0.01
"""Tensor masses are rebuilt once the nodes may have moved this fraction of the shortest element
edge since the last rebuild (an element turns by at most about that many radians, 0.6 deg). On
the strip DEMES with triangles (refinement 0, flat to 110 %) this cut the time per step by a
quarter with the same iterations; a fixed interval of 10 steps instead made early, fast motion
diverge (docs/dynamic_relaxation.md)."""

FRAME_DRIFT = 0.3
"""The frame mass (``masses="frame"``) is refreshed once the nodes may have moved this fraction
of the shortest element edge since its last refresh, and at every kinetic-energy restart:
between refreshes it is the stiffness of a frame that has moved by that much
(docs/dynamic_relaxation.md, "Frame mass")."""


FRAME_TURN = 0.01
"""The frame mass is also refreshed once a node's edge frame has turned about this many radians
since the last refresh. Turning the blocks with the frames is exact for a rigid turn only; the
strip's strong-axis stiffness, about 1000 times its weak-axis one, leaks into the weak
direction with the error of the turn. Measured near the flat state (6 divisions, 1.025): with
the drift rule alone the largest generalised eigenvalue of the stale mass grew from 1.0 to 16
within 26 steps (turns of 0.03-0.06 rad) and the run diverged; with this rule it converged in
35 steps (docs/dynamic_relaxation.md, "Frame mass")."""


def relax(
    model: Model,
    tol: float = 1e-6,
    mass_safety: float = 2.0,
    max_iterations: int = 2_000_000,
    x_start: np.ndarray | None = None,
    contact: FrameContact | None = None,
    final_checks: Sequence[Check] = (),
    masses: str = "frame",
    force_scale: float = 0.0,
    progress: bool = False,
    chunk: int = 20_000,
    damping: str = "kinetic",
    leash: float = 0.0,
) -> Result:
    """Relax ``model`` to equilibrium by dynamic relaxation.

    Parameters
    ----------
    tol
        Convergence when the largest nodal residual and momentum |M v|/dt at free nodes are
        below ``tol`` times the largest element force (N/N), or times the largest load,
        ``force_scale`` or ten times the round-off of the stiffest link's force over tol if
        larger. Below about 1e-8 the momentum of a stiff frame's axial masses reaches the
        round-off of the positions and DR stalls.
    mass_safety
        Safety factor f of the fictitious masses M = f dt^2/2 K (K a stiffness bound; f >= 1
        is stable, 2 is safe).
    max_iterations
        Time-step limit.
    x_start
        Starting positions (n, 3), mm (default: the reference geometry). Supported coordinates
        stay where x_start puts them, which is how support displacements are prescribed.
    contact
        A :class:`dr.FrameContact`: the run stops with status 'self_contact' when its segments
        touch (checked inside the time loop, often enough that nothing passes through).
    final_checks
        Callables (e.g. :class:`dr.MembraneFold`) for states that must not be accepted: a
        converged state they flag gets the check's ``status`` attribute (default 'membrane_fold';
        :class:`dr.FilmCrossing`: 'film_contact'), and so does an unconverged run they flag at
        FOLD_PATIENCE chunk ends in a row (a clustered net may fold for a moment on its way and
        unfold again, so a single sighting does not stop it).
    masses
        'frame': the rods' nodes share one sparse mass from the rods' and frame links' own
        stiffness (:mod:`dr.frame_mass`), every other node a tensor mass; where no rod is
        modelled, or a rod node is held on some axes only, this is 'tensor'. 'tensor':
        direction-dependent 3x3 masses from each element's stiffness, rebuilt on drift (a
        frame node is heavy along the frame only); 'scalar': Barnes' masses f dt^2/2 S.
    force_scale
        Smallest force (N) the residual is measured against: the scale of a state whose
        element forces all vanish (an unstressed structure relaxing back to its rest shape).
    progress
        Show a progress bar with the residual.
    chunk
        Steps between residual records (and progress updates).
    damping
        'kinetic' (Barnes), 'viscous' (Underwood's adaptive coefficient) or 'fire' (Bitzek
        et al.): :mod:`dr.damping`.
    leash
        mm (0: none): the run stops with status 'too_far' once a node is farther than this from
        its start. The path gives up a step that is jumping this way before its relaxation
        reaches the far state (:mod:`dr.demes`).

    Returns
    -------
    Result
        The equilibrium (``converged``), or the last state reached with ``status``
        'max_iterations', 'diverged' (energy rising or a node jumping: an unstable time step;
        checked before any contact or fold is reported), 'not_finite' (a NaN/inf position,
        force or energy; the last finite state is returned and the message names the node and
        the degenerate element), 'self_contact', 'membrane_fold' or 'too_far' (``leash``), and
        a message with the residual and iteration count.

    Raises
    ------
    DRError
        Bad settings, or start positions that give no finite force (coincident nodes of a
        link, cable or beam, a strip orientation node on its edge's line: named).
    """
    _check_settings(model, tol=tol, mass_safety=mass_safety, max_iterations=max_iterations, masses=masses,
                    damping=damping)
    t0 = time.perf_counter()
    positions = "start" if x_start is not None else "reference"
    P = model.pack()
    X = _start_positions(model, P, x_start, positions=positions)
    built = _build_masses(model, P, X, kind=masses, safety=mass_safety, contact=contact, positions=positions)
    P, st, fm = built.P, built.state, built.frame
    cfg = _loop_settings(X, P, model.loads, tol=tol, mass_safety=mass_safety, chunk=chunk, damping=damping,
                         contact=contact, force_scale=force_scale)._replace(leash=float(leash))
    unresisted(itg.start(st, P, fm, cfg.half_safety), "after the first step")
    # measured after the first step, as every energy the divergence check compares with it
    stops = _Stops(contact=contact, final_checks=final_checks, e_start=potential_energy(X, P, model.loads),
                   energy_floor=cfg.force_floor * cfg.runaway, loads=model.loads, mass_safety=mass_safety,
                   max_iterations=max_iterations, chunk=chunk, tol=tol)
    run = _run_chunks(st, P, fm, cfg, stops, progress=progress)
    info = {"ke_peaks": run.peaks, "mass_safety": mass_safety, "masses": built.kind, "damping": damping,
            "frame_mass_nodes": int(fm.nodes.size)}
    return make_result(model, P, X, run, wall_time=time.perf_counter() - t0, info=info)


class Run(NamedTuple):
    """How a relaxation's time loop ended (:func:`_run_chunks`)."""

    status: str  # 'converged', 'max_iterations', 'diverged', 'not_finite', 'self_contact' or a check's
    message: str
    iterations: int
    history: np.ndarray  # (k, 2): iteration and relative residual at each chunk end
    peaks: int  # kinetic-energy peaks


@dataclass(frozen=True)
class _Stops:
    """What ends a run besides convergence (see :func:`relax` for each)."""

    contact: FrameContact | None
    final_checks: Sequence[Check]
    e_start: float  # potential energy after the first step, N mm
    energy_floor: float  # N mm: the work of the residual floor over the model's size, below any divergence
    loads: np.ndarray  # (n, 3) N
    mass_safety: float
    max_iterations: int
    chunk: int
    tol: float


def _check_settings(model: Model, *, tol: float, mass_safety: float, max_iterations: int, masses: str,
                    damping: str) -> None:
    """Raise DRError for a bad setting of :func:`relax` or a model without supports."""
    if not (np.isfinite(tol) and tol > 0):
        raise DRError(f"tol = {tol!r} must be a positive number (relative residual, e.g. 1e-6)")
    if not (np.isfinite(mass_safety) and mass_safety > 0):
        raise DRError(f"mass_safety = {mass_safety!r} must be positive (f >= 1 is stable, 2 is safe)")
    if int(max_iterations) < 1:
        raise DRError("max_iterations must be at least 1")
    if masses not in ("frame", "tensor", "scalar"):
        raise DRError(f"masses = {masses!r}: use 'frame', 'tensor' or 'scalar'")
    if damping not in SCHEMES:
        raise DRError(f"damping = {damping!r}: use one of {', '.join(map(repr, SCHEMES))}")
    if not model.fixed.any():
        raise DRError(
            "the model has no supports: it can move as a rigid body; pin some nodes with "
            "model.support(indices) or model.clamp(i, tangent)"
        )


def _start_positions(model: Model, P: Packed, x_start: np.ndarray | None, *, positions: str) -> np.ndarray:
    """Positions (n_total, 3) mm of the real nodes at ``x_start`` (None: the reference geometry),
    the virtual ones zero. Raises DRError for a wrong shape or degenerate elements."""
    n = P.n
    X = np.zeros((P.n_total, 3))
    if x_start is None:
        X[:n] = model.nodes
    else:
        xs = np.asarray(x_start, dtype=float)
        if xs.shape != (n, 3) or not np.all(np.isfinite(xs)):
            raise DRError(f"x_start must be a finite ({n}, 3) array of positions (mm)")
        X[:n] = xs
    degenerate = degenerate_elements(X, P)
    if degenerate:
        raise DRError(f"the {positions} positions are degenerate: {'; '.join(degenerate)}; move the nodes apart")
    return X


def _build_masses(model: Model, P: Packed, X: np.ndarray, *, kind: str, safety: float,
                  contact: FrameContact | None, positions: str) -> Masses:
    """The time loop's state at X with its masses (:func:`dr.masses.masses_at`), the contact
    check's nodes watched. Raises DRError where the start gives a non-finite force or mass."""
    watched = np.zeros(P.n, dtype=bool)
    segments = np.zeros((0, 2), np.int64)
    if contact is not None:
        watched[contact.nodes] = True
        segments = contact.segments
    built = masses_at(model, P, X, kind, safety, watched, segments)
    st = built.state
    if not (np.isfinite(st.R).all() and np.isfinite(st.Minv).all()):
        raise DRError(
            f"the {positions} positions give a non-finite force or mass, first at "
            f"{where_not_finite(X, st.R, built.P)}; look for coincident nodes or stiffnesses so large that they overflow"
        )
    return built


def _loop_settings(X: np.ndarray, P: Packed, loads: np.ndarray, *, tol: float, mass_safety: float, chunk: int,
                   damping: str, contact: FrameContact | None, force_scale: float) -> itg.Settings:
    """The time loop's settings at the start positions X (n_total, 3) mm."""
    closed, distance = (contact.closed, contact.distance) if contact is not None else (False, 0.0)
    edge = _shortest_edge(X, P)
    return itg.Settings(
        damping=SCHEMES[damping], half_safety=0.5 * mass_safety, max_steps=int(chunk), closed=bool(closed),
        contact_distance=float(distance), tol=float(tol), force_floor=_force_floor(X, P, loads, tol, force_scale),
        runaway=max(float(np.linalg.norm(np.ptp(X[: P.n], axis=0))), 1e-9), mass_every=MASS_EVERY,
        drift=DRIFT_TURN * edge, frame_drift=FRAME_DRIFT * edge, frame_turn=FRAME_TURN, leash=0.0,
    )


def _chunk(st: itg.State, P: Packed, fm: FrameMass, cfg: itg.Settings) -> tuple[int, int, int, float, float]:
    """One chunk of the time loop: (stop code, steps, kinetic-energy peaks, largest element
    force N, largest residual N) as :func:`dr.integrator.run` returns them."""
    try:
        return itg.run(st, P, cfg, fm)
    except np.linalg.LinAlgError:  # a NaN reached the strip's mass bound (an eigensolver)
        return itg.NONFINITE, 0, 0, np.nan, np.nan


def _run_chunks(st: itg.State, P: Packed, fm: FrameMass, cfg: itg.Settings, stops: _Stops, *,
                progress: bool) -> Run:
    """Run the time loop chunk by chunk until it stops (:func:`relax`, Returns). A diverged or
    non-finite run is put back to its state at the last chunk end; ``st.X`` holds the end state."""
    X, n = st.X, P.n
    it, peaks, folded_chunks = 1, 0, 0
    history: list[tuple[int, float]] = []
    good = X.copy()

    def stop(status: str, message: str) -> Run:
        """The run as it stands, ended with ``status`` and ``message``."""
        return Run(status, message, it, np.array(history), peaks)

    bar = tqdm(total=int(stops.max_iterations), desc="DR", unit="step", disable=not progress, leave=False)
    try:
        while True:
            steps_left = int(stops.max_iterations) - it
            code, steps, pk, fmax, rmax = _chunk(st, P, fm, cfg._replace(max_steps=min(stops.chunk, steps_left)))
            it += steps
            peaks += pk
            bar.update(steps)
            rel = rmax / max(fmax, cfg.force_floor)
            history.append((it, rel))
            bar.set_postfix_str(f"residual {rel:.2e}")
            last_good = history[-2][0] if len(history) > 1 else 1
            if code == itg.NONFINITE:
                where = where_not_finite(X, st.R, P, good)
                X[:] = good
                return stop("not_finite", f"a value became NaN/inf at iteration {it}, first at {where}; the last "
                                          f"finite state (iteration {last_good}) is returned")
            unstable = _runaway(cfg, stops) if code == itg.RUNAWAY else _energy_rise(X, P, stops)
            if unstable:
                X[:] = good
                return stop("diverged", f"DR diverged at iteration {it} ({unstable}); the state of iteration "
                                        f"{last_good} is returned")
            if code == itg.CONTACT:
                return stop("self_contact", f"stopped at iteration {it}: {stops.contact(X[:n])}")
            if code == itg.LEASHED:
                return stop("too_far", f"stopped at iteration {it}: a node got farther than leash = "
                                       f"{cfg.leash:.3g} mm from its start")
            check, hit = _first_flag(stops.final_checks, X[:n])
            folded_chunks = folded_chunks + 1 if hit else 0
            if code == itg.CONVERGED and hit:
                return stop(getattr(check, "status", "membrane_fold"),
                            f"converged in {it} iterations to a state with {hit}")
            if code == itg.CONVERGED:
                return stop("converged", f"converged in {it} iterations ({peaks} kinetic-energy peaks), "
                                         f"residual {rel:.2e}")
            if folded_chunks >= FOLD_PATIENCE:
                return stop(getattr(check, "status", "membrane_fold"),
                            f"stopped at iteration {it}, not converged (relative residual {rel:.2e}): {hit}, for "
                            f"the last {folded_chunks * stops.chunk} steps; a net folded over has no equilibrium "
                            "to reach")
            if it >= stops.max_iterations:
                return stop("max_iterations", f"not converged: max_iterations = {int(stops.max_iterations)} "
                                              f"reached with relative residual {rel:.2e} (tol {stops.tol:g}), "
                                              f"{peaks} kinetic-energy peaks")
            good[:] = X
    finally:
        bar.close()


def _first_flag(checks: Sequence[Check], x: np.ndarray) -> tuple[Check | None, str | None]:
    """The first of ``checks`` that flags the state x (n, 3) mm, with what it says; (None, None)."""
    return next(((c, msg) for c, msg in ((c, c(x)) for c in checks) if msg), (None, None))


def _runaway(cfg: itg.Settings, stops: _Stops) -> str:
    """Why a run whose node jumped further than the model size is unstable."""
    return (f"a node jumped more than the model size ({cfg.runaway:.3g} mm) in one step: the time step is "
            f"unstable with mass_safety = {stops.mass_safety:g}; raise it (2 is safe)")


def _energy_rise(X: np.ndarray, P: Packed, stops: _Stops) -> str | None:
    """Why the run at X is unstable (its potential energy rose by :data:`ENERGY_RISE`), or None."""
    e_start, e_now = stops.e_start, potential_energy(X, P, stops.loads)
    rise = e_now - e_start
    if not np.isfinite(rise) or rise <= ENERGY_RISE * max(abs(e_start), abs(e_now)) + stops.energy_floor:
        return None  # a NaN energy is named 'not_finite' when the result is made
    return (f"the energy rose from {e_start:.4g} to {e_now:.4g} N mm, which damping cannot do: the time step is "
            f"unstable with mass_safety = {stops.mass_safety:g}; raise it (f >= 1 is stable, 2 is safe)")


def _shortest_edge(X: np.ndarray, P: Packed) -> float:
    """The shortest distance between two real nodes that an element joins, mm."""
    n = P.n
    ij = np.concatenate([e.edges(P).reshape(-1, 2) for e in ELEMENTS])
    ij = ij[(ij < n).all(axis=1) & (ij >= 0).all(axis=1)]
    if ij.shape[0] == 0:
        return 0.0
    return float(np.linalg.norm(X[ij[:, 1]] - X[ij[:, 0]], axis=1).min())


def _force_floor(X: np.ndarray, P: Packed, loads: np.ndarray, tol: float, force_scale: float) -> float:
    """The smallest force scale (N) of the convergence test: the largest load, ``force_scale``,
    and 10x the round-off of the stiffest link's force over tol (positions carry ~2 eps |x|,
    so a residual below that noise cannot be resolved)."""
    k_max = float(np.max(P.link_EA / P.link_L0)) if P.link_EA.size else 0.0
    noise = k_max * 2.0 * np.finfo(float).eps * float(np.abs(X[: P.n]).max())
    return max(float(np.max(np.linalg.norm(loads, axis=1))), float(force_scale), 10.0 * noise / tol, 1e-300)


def element_forces(model: Model, P: Packed, X: np.ndarray) -> dict[str, np.ndarray]:
    """What each element type reports at X (dr.elements: link and cluster tensions N, strip
    twists ...) and ``node_moment``: the beams' and strips' bending moments at nodes, N mm."""
    moment = np.zeros(P.n)
    out: dict[str, np.ndarray] = {}
    for e in ELEMENTS:
        out.update(e.forces(X, P, moment))
    out["node_moment"] = moment
    return out


def make_result(model: Model, P: Packed, X: np.ndarray, run: Run, *, wall_time: float, info: dict) -> Result:
    """The shared Result (energies, element forces, VTK blocks) of the state X (n_total, 3) mm
    that ``run`` ended in, after ``wall_time`` s; ``info``: the solver's extras."""
    place_virtual(X, P)
    e_mem, e_bend, e_twist, e_ax = energy(X, P)
    en = {
        "membrane": e_mem,
        "frame_bending": e_bend,
        "frame_torsion": e_twist,
        "frame_axial": e_ax,
        "total": e_mem + e_bend + e_twist + e_ax,
    }
    run = _with_finite_energy(run, en)
    forces = element_forces(model, P, X)
    frame_nodes, frame_s = _frame_arc(model)
    return Result(
        solver="dr",
        x=X[: P.n].copy(),
        x0=model.nodes.copy(),
        converged=run.status == "converged",
        status=run.status,
        message=run.message,
        iterations=int(run.iterations),
        residual=float(run.history[-1][1]),
        wall_time=float(wall_time),
        energy=en,
        residual_history=run.history,
        frame_nodes=frame_nodes,
        frame_s=frame_s,
        blocks=_blocks(model, P, forces),
        point_data={
            "bending_moment_Nmm": forces["node_moment"],
            "fixed": model.fixed.any(axis=1).astype(float),
            "load_N": model.loads,
        },
        info={**info, **forces},
    )


def _with_finite_energy(run: Run, energy: dict[str, float]) -> Run:
    """``run``, or 'not_finite' where the energy of its end state is not: a NaN the loop's
    force checks did not see."""
    if run.status == "not_finite" or all(np.isfinite(v) for v in energy.values()):
        return run
    return run._replace(status="not_finite", message=f"the energy is not finite ({run.message})")


def _blocks(model: Model, P: Packed, forces: dict[str, np.ndarray]) -> dict[str, CellBlock]:
    """The VTK cell blocks: those of the element types that draw any (membrane links and
    clusters with their tensions, the frame with its axial forces and moments) and the membrane
    surface."""
    # offsets and ghosts are drawn at the frame node they belong to
    real = np.arange(P.n_total)
    real[P.n : P.n + P.off_geo.shape[0]] = P.off_geo[:, 1]
    blocks: dict[str, CellBlock] = {}
    for e in ELEMENTS:
        if hasattr(e, "cells"):
            blocks.update(e.cells(P, real, forces))
    if model.triangles is not None:
        blocks["membrane_surface"] = CellBlock("triangle", model.triangles)
    return blocks


def _frame_arc(model: Model) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The first beam chain's nodes and their reference arc lengths (mm); None, None without one."""
    if not model.beams:
        return None, None
    chain = model.beams[0].chain
    seg = np.linalg.norm(np.diff(model.nodes[chain], axis=0), axis=1)
    return chain, np.concatenate([[0.0], np.cumsum(seg)])
