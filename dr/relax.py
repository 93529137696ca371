"""``relax``: find the static equilibrium of a :class:`dr.Model` by dynamic relaxation."""

from __future__ import annotations


import time
from typing import Callable, Sequence

import numpy as np
from tqdm import tqdm

from results import CellBlock, Result

from . import integrator as itg
from .contact import FrameContact
from .errors import DRError
from .masses import masses_at, unresisted
from .stability import potential_energy
from .beams import curvatures
from .damping import SCHEMES
from .finite import degenerate_elements, where_not_finite
from .kernels import Packed, energy, place_virtual
from .strips import EIW, KN0, KW0, LBAR, TAU0, strip_measures
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

    Returns
    -------
    Result
        The equilibrium (``converged``), or the last state reached with ``status``
        'max_iterations', 'diverged' (energy rising or a node jumping: an unstable time step;
        checked before any contact or fold is reported), 'not_finite' (a NaN/inf position,
        force or energy; the last finite state is returned and the message names the node and
        the degenerate element), 'self_contact' or 'membrane_fold', and a message with the
        residual and iteration count.

    Raises
    ------
    DRError
        Bad settings, or start positions that give no finite force (coincident nodes of a
        link, cable or beam, a strip orientation node on its edge's line: named).
    """
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
    t0 = time.perf_counter()
    P = model.pack()
    n = P.n
    X = np.zeros((P.n_total, 3))
    if x_start is None:
        X[:n] = model.nodes
    else:
        xs = np.asarray(x_start, dtype=float)
        if xs.shape != (n, 3) or not np.all(np.isfinite(xs)):
            raise DRError(f"x_start must be a finite ({n}, 3) array of positions (mm)")
        X[:n] = xs
    loads = model.loads
    positions = "start" if x_start is not None else "reference"
    degenerate = degenerate_elements(X, P)
    if degenerate:
        raise DRError(f"the {positions} positions are degenerate: {'; '.join(degenerate)}; move the nodes apart")
    watched = np.zeros(n, dtype=bool)
    segments, closed, distance = np.zeros((0, 2), np.int64), False, 0.0
    if contact is not None:
        watched[contact.nodes] = True
        segments, closed, distance = contact.segments, contact.closed, contact.distance
    built = masses_at(model, P, X, masses, mass_safety, watched, segments)
    P, st, fm, masses = built.P, built.state, built.frame, built.kind
    if not (np.isfinite(st.R).all() and np.isfinite(st.Minv).all()):
        raise DRError(
            f"the {positions} positions give a non-finite force or mass, first at {where_not_finite(X, st.R, P)}; "
            "look for coincident nodes or stiffnesses so large that they overflow"
        )
    runaway = max(float(np.linalg.norm(np.ptp(X[:n], axis=0))), 1e-9)
    cfg = itg.Settings(
        damping=SCHEMES[damping], half_safety=0.5 * mass_safety, max_steps=int(chunk), closed=bool(closed),
        contact_distance=float(distance), tol=float(tol), force_floor=_force_floor(X, P, loads, tol, force_scale),
        runaway=runaway, mass_every=MASS_EVERY,
        drift=DRIFT_TURN * _shortest_edge(X, P), frame_drift=FRAME_DRIFT * _shortest_edge(X, P),
        frame_turn=FRAME_TURN,
    )
    unresisted(itg.start(st, P, fm, cfg.half_safety), "after the first step")

    e_start = potential_energy(X, P, loads)

    def diverging() -> str | None:
        """Why the run is unstable (energy rising), or None."""
        e_now = potential_energy(X, P, loads)
        rise = e_now - e_start
        if not np.isfinite(rise) or rise <= ENERGY_RISE * max(abs(e_start), abs(e_now), 1e-300):
            return None  # a NaN energy is named 'not_finite' when the result is made
        return (f"the energy rose from {e_start:.4g} to {e_now:.4g} N mm, which damping cannot do: "
                f"the time step is unstable with mass_safety = {mass_safety:g}; raise it (f >= 1 is "
                "stable, 2 is safe)")

    it, peaks, folded_chunks = 1, 0, 0
    history: list[tuple[int, float]] = []
    status, message = "max_iterations", ""
    good = X.copy()
    bar = tqdm(total=int(max_iterations), desc="DR", unit="step", disable=not progress, leave=False)
    try:
        while True:
            steps_left = int(max_iterations) - it
            try:
                code, steps, pk, fmax, rmax = itg.run(st, P, cfg._replace(max_steps=min(chunk, steps_left)), fm)
            except np.linalg.LinAlgError:  # a NaN reached the strip's mass bound (an eigensolver)
                code, steps, pk, fmax, rmax = itg.NONFINITE, 0, 0, np.nan, np.nan
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
                status = "not_finite"
                message = (f"a value became NaN/inf at iteration {it}, first at {where}; the last finite "
                           f"state (iteration {last_good}) is returned")
                break
            unstable = (f"a node jumped more than the model size ({runaway:.3g} mm) in one step: the time "
                        f"step is unstable with mass_safety = {mass_safety:g}; raise it (2 is safe)"
                        if code == itg.RUNAWAY else diverging())
            if unstable:
                X[:] = good
                status = "diverged"
                message = (f"DR diverged at iteration {it} ({unstable}); the state of iteration "
                           f"{last_good} is returned")
                break
            if code == itg.CONTACT:
                status, message = "self_contact", f"stopped at iteration {it}: {contact(X[:n])}"
                break
            check, hit = next(((c, msg) for c, msg in ((c, c(X[:n])) for c in final_checks) if msg), (None, None))
            folded_chunks = folded_chunks + 1 if hit else 0
            if code == itg.CONVERGED:
                if hit:
                    status = getattr(check, "status", "membrane_fold")
                    message = f"converged in {it} iterations to a state with {hit}"
                else:
                    status = "converged"
                    message = f"converged in {it} iterations ({peaks} kinetic-energy peaks), residual {rel:.2e}"
                break
            if folded_chunks >= FOLD_PATIENCE:
                status = getattr(check, "status", "membrane_fold")
                message = (
                    f"stopped at iteration {it}, not converged (relative residual {rel:.2e}): {hit}, "
                    f"for the last {folded_chunks * chunk} steps; a net folded over has no equilibrium to reach"
                )
                break
            if it >= max_iterations:
                message = (
                    f"not converged: max_iterations = {int(max_iterations)} reached with relative "
                    f"residual {rel:.2e} (tol {tol:g}), {peaks} kinetic-energy peaks"
                )
                break
            good[:] = X
    finally:
        bar.close()
    residual_now = history[-1][1]
    res = make_result(
        model, P, X, status == "converged", status, message, it, residual_now,
        np.array(history), time.perf_counter() - t0,
        {"ke_peaks": peaks, "mass_safety": mass_safety, "masses": masses, "damping": damping,
         "frame_mass_nodes": int(fm.nodes.size)},
    )
    if not all(np.isfinite(v) for v in res.energy.values()) and status != "not_finite":
        res.converged, res.status = False, "not_finite"
        res.message = f"the energy is not finite ({res.message})"
    return res


def _shortest_edge(X: np.ndarray, P: Packed) -> float:
    """The shortest distance between two real nodes that an element joins, mm."""
    n = P.n
    pairs = [P.link_ij, P.clu_seg, P.beam_idx[:, :2], P.beam_idx[:, 1:], P.tri_idx[:, :2], P.tri_idx[:, 1:],
             P.tri_idx[:, ::2]]
    ij = np.concatenate([p.reshape(-1, 2) for p in pairs])
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
    """Link and cluster tensions (N) and beam bending moments at nodes (N mm)."""
    out: dict[str, np.ndarray] = {}
    i, j = P.link_ij.T
    L = np.linalg.norm(X[j] - X[i], axis=1)
    t = P.link_EA / P.link_L0 * (L - P.link_L0)
    out["link_tension"] = np.where(P.link_tension_only & (t < 0), 0.0, t)
    seg_len = np.linalg.norm(X[P.clu_seg[:, 1]] - X[P.clu_seg[:, 0]], axis=1)
    total = np.bincount(P.clu_seg_cluster, weights=seg_len, minlength=P.clu_L0.size)
    tc = P.clu_EA / P.clu_L0 * (total - P.clu_L0)
    out["cluster_tension"] = np.where(P.clu_tension_only & (tc < 0), 0.0, tc)
    moment = np.zeros(P.n)
    if P.beam_idx.size:
        b = P.beam_idx[:, 1]
        kap = curvatures(X, P.beam_idx)
        np.add.at(moment, b[b < P.n], (P.beam_EI * (kap - P.beam_k0))[b < P.n])
    if P.strip_idx.size:
        meas = strip_measures(X, P.strip_idx)
        m_w = P.strip_par[:, EIW] * (meas[:, 0] - P.strip_par[:, KW0]) / P.strip_par[:, LBAR]
        np.add.at(moment, P.strip_idx[:, 1], m_w)
        out["strip_twist"] = meas[:, 2] - P.strip_par[:, TAU0]
        out["strip_strong_curvature"] = meas[:, 1] - P.strip_par[:, KN0]
    out["node_moment"] = moment
    return out


def make_result(
    model: Model,
    P: Packed,
    X: np.ndarray,
    converged: bool,
    status: str,
    message: str,
    iterations: int,
    residual: float,
    history: np.ndarray,
    wall_time: float,
    info: dict,
) -> Result:
    """Assemble the shared Result (energies, element forces, VTK blocks) of a DR state."""
    place_virtual(X, P)
    e_mem, e_bend, e_twist, e_ax = energy(X, P)
    en = {
        "membrane": e_mem,
        "frame_bending": e_bend,
        "frame_torsion": e_twist,
        "frame_axial": e_ax,
        "total": e_mem + e_bend + e_twist + e_ax,
    }
    forces = element_forces(model, P, X)
    n = P.n
    # display: offsets and ghosts are drawn at the frame node they belong to
    real = np.arange(X.shape[0])
    real[n : n + P.off_geo.shape[0]] = P.off_geo[:, 1]
    blocks: dict[str, CellBlock] = {}
    mem = ~P.link_frame
    if mem.any():
        blocks["membrane_links"] = CellBlock("line", real[P.link_ij[mem]], {"tension_N": forces["link_tension"][mem]})
    if P.clu_seg.size:
        blocks["membrane_clusters"] = CellBlock(
            "line",
            real[P.clu_seg],
            {"tension_N": forces["cluster_tension"][P.clu_seg_cluster], "cluster_id": P.clu_seg_cluster.astype(float)},
        )
    if P.link_frame.any():
        seg = real[P.link_ij[P.link_frame]]
        blocks["frame"] = CellBlock(
            "line",
            seg,
            {
                "axial_force_N": forces["link_tension"][P.link_frame],
                "bending_moment_Nmm": forces["node_moment"][seg].mean(axis=1),
            },
        )
    if model.triangles is not None:
        blocks["membrane_surface"] = CellBlock("triangle", model.triangles)
    point_data = {
        "bending_moment_Nmm": forces["node_moment"],
        "fixed": model.fixed.any(axis=1).astype(float),
        "load_N": model.loads,
    }
    frame_nodes = frame_s = None
    if model._beams:
        chain = model._beams[0].chain
        frame_nodes = chain
        seg = np.linalg.norm(np.diff(model.nodes[chain], axis=0), axis=1)
        frame_s = np.concatenate([[0.0], np.cumsum(seg)])
    info = dict(info)
    info.update({k: v for k, v in forces.items()})
    return Result(
        solver="dr",
        x=X[:n].copy(),
        x0=model.nodes.copy(),
        converged=converged,
        status=status,
        message=message,
        iterations=int(iterations),
        residual=float(residual),
        wall_time=float(wall_time),
        energy=en,
        residual_history=history,
        frame_nodes=frame_nodes,
        frame_s=frame_s,
        blocks=blocks,
        point_data=point_data,
        info=info,
    )
