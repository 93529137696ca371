"""The rules of the pre-stretch path, defined once: the FEM's continuation and DR's path follow
them (docs/path.md).

The path starts from the flat state at lambda = 1, an equilibrium that loses stability at the
buckling pre-stretch. A state whose lowest mode has a negative stiffness is a saddle: it is
left along that mode, on the side :func:`side_of_mode` picks from the scene's lift, and
solved again. A step whose state moved far more than the path's rate so far predicts, or
turned away from the direction of the branch's last step, is a jump (a limit point or a
bifurcation passed over): the step is cut until it is shorter than
:data:`LOCATE`, where the jump is accepted and recorded (last pre-stretch on the old branch,
first on the new one) in ``info['snaps']``. So the state a
pre-stretch gives does not depend on the steps a command asks for.
"""

from __future__ import annotations

import numpy as np

LOCATE = 1e-3
"""A jump is located to a pre-stretch step shorter than this, then accepted."""

PLANAR = 1e-6
"""A state whose nodes all lie within this fraction of the side length of the flat state's
height is the flat state itself (round-off moves it no further)."""

AFTER_EVENT = 4 * LOCATE
"""The step after a jump or a bifurcation: small, because the new branch's own rate is not
known yet (the first step after an event is never called a jump) and a second bifurcation
can follow close behind (on a square the twist of the flat state turns into the curl 0.003
further on)."""

JUMP_RATIO = 3.0
"""A step is a jump when its state moved more than this many times what the last step's rate
(largest nodal move per unit pre-stretch) predicts."""

JUMP_FLOOR = 0.02
"""...and more than this fraction of the side length: the flat branch barely moves, so any
move of the order of the lift would read as a jump off it."""


UNSEEN = 1e-3
"""A mode whose cosine with the lift is below this is one the lift does not see."""


def neutral_stiffness(scene) -> float:
    """N/mm^3: a lowest eigenvalue of the stiffness per unit film area (u K u / u A u, A the
    nodal film areas) above minus this counts as zero, a neutral mode (a slack film, round-off):
    1e-6 of E h / side^2, far below any physical out-of-plane stiffness of the film. Both
    solvers judge stability by it."""
    return 1e-6 * scene.membrane.E * scene.membrane.thickness / scene.outline.side_length**2


def side_of_mode(mode: np.ndarray, *, apex: int, lift: np.ndarray, up: float, flat: np.ndarray) -> float:
    """+1 or -1: the sign that puts the scene's lift side on the mode ``mode`` (n, 3).

    The apex goes to the side ``up`` (the sign of ``perturbation.amplitude``); a mode that
    leaves the apex in the plane (a twist) is taken with a positive projection on the lift
    ``lift`` (n, 3), which carries the scene's ``perturbation.asymmetry``. Where the lift does
    not see the mode (a twist under a lift symmetric about x = 0: the projection is round-off,
    different in each solver), the side x > 0 goes to the side ``up``: a projection of the sign
    of ``up`` on the asymmetry's own shape, x y^2 at the flat positions ``flat`` (n, 3) mm (so
    that a scene lifted the other way gives the state mirrored through the plane, twist and
    all)."""
    mode = np.asarray(mode)
    tilt = float(mode[apex, 2])
    if abs(tilt) > 1e-6 * float(np.abs(mode).max()):
        return float(np.sign(tilt) * up)
    along = float(np.sum(mode[:, 2] * lift[:, 2]))
    if abs(along) > UNSEEN * np.linalg.norm(mode[:, 2]) * np.linalg.norm(lift[:, 2]):
        return float(np.sign(along))
    flat = np.asarray(flat)
    tilt_shape = flat[:, 0] * np.clip(flat[:, 1], 0.0, None) ** 2
    return float(np.sign(np.sum(mode[:, 2] * tilt_shape)) * up or up)


STRAY = 0.5
"""A step whose state ends farther than this fraction of the secant's predicted move from the
secant's prediction left the branch (:func:`strayed`)."""


def strayed(move: np.ndarray, last_move: np.ndarray | None, rate: float | None, step: float,
            side_length: float) -> bool:
    """Whether a step of ``step`` in pre-stretch whose nodes moved by ``move`` (n, 3) mm left the
    branch whose last step moved them by ``last_move`` at ``rate`` (its largest nodal move per
    unit pre-stretch; either None: no last step on this branch): it moved less than the
    secant predicts (``last_move`` scaled to ``step``) and ended more than :data:`STRAY` times
    that prediction from it. This sees what the rate and turn tests (:func:`jumped`,
    :func:`turned`) do not: a step that stopped on a nearer stable state of another branch, short
    of where its own went, in the branch's direction. A move beyond the prediction is the rate
    test's: just after a bifurcation the new branch accelerates (on the strip DEMES the first
    steps off the flat state moved 1.2 to 2.2 times the secant's prediction, on the branch).
    Moves within :data:`JUMP_FLOOR` of the side are no jump."""
    if last_move is None or rate is None:
        return False
    moved, last = np.reshape(move, (-1, 3)), np.reshape(last_move, (-1, 3))
    predicted = last * (rate * step / max(float(np.linalg.norm(last, axis=1).max()), 1e-300))
    reach = float(np.linalg.norm(predicted, axis=1).max())
    length = float(np.linalg.norm(moved, axis=1).max())
    if max(length, reach) <= JUMP_FLOOR * side_length or length >= reach:
        return False
    return largest_move(moved, predicted) > STRAY * reach


def planar(x: np.ndarray, flat: np.ndarray, side_length: float) -> bool:
    """Whether positions ``x`` (n, 3) mm are the flat state ``flat`` (n, 3) but for in-plane moves.

    Leaving the flat state is a bifurcation: the step that does is cut (as a jump's) until
    it is shorter than :data:`LOCATE`, so both solvers leave it just past the buckling
    pre-stretch, along the one mode that has gone unstable there."""
    return float(np.abs(np.asarray(x)[:, 2] - np.asarray(flat)[:, 2]).max()) <= PLANAR * side_length


def largest_move(x: np.ndarray, x_before: np.ndarray) -> float:
    """Largest nodal distance between two states (n, 3), mm."""
    return float(np.linalg.norm(np.asarray(x) - np.asarray(x_before), axis=1).max())


def jumps_message(snaps: list[tuple[float, float]]) -> str:
    """The clause of a state's message that names its located jumps (``info['snaps']``: last
    pre-stretch on the old branch, first on the new one), '' for none."""
    if not snaps:
        return ""
    return "jumped at " + ", ".join(f"lambda = {a:.4f} -> {b:.4f}" for a, b in snaps) + " (where the path left its branch)"


def jumped(move: float, step: float, rate: float | None, side_length: float) -> bool:
    """Whether a step of ``step`` in pre-stretch whose state moved ``move`` mm left the branch
    the last steps followed at ``rate`` mm per unit pre-stretch (None: no rate yet, e.g. the
    first step or the first after a jump, which is never called one)."""
    if rate is None:
        return False
    return move > jump_distance(step, rate, side_length)


def jump_distance(step: float, rate: float, side_length: float) -> float:
    """mm: the largest nodal move of a step of ``step`` in pre-stretch on a branch moving at
    ``rate`` mm per unit pre-stretch beyond which the step is a jump (:func:`jumped`)."""
    return max(JUMP_RATIO * rate * step, JUMP_FLOOR * side_length)


TURN = 0.5
"""A step whose move (all nodes) makes a cosine below this with the last step's move on the
branch turned off it: a smooth branch turns little between two steps (measured 0.976-0.992 on
a pentagon's curl), a jump to a nearer state of another branch turns away (-0.50)."""


def turned(move: np.ndarray, last_move: np.ndarray | None, side_length: float) -> bool:
    """Whether a step whose nodes moved by ``move`` (n, 3) mm (or flat, 3n) turned away from the
    direction of the branch's last step ``last_move`` (None: no last step on this branch, e.g. the first
    after an event). The rate test (:func:`jumped`) cannot see a jump to a state nearer than
    the last step's rate predicts, which a step taken just after a bifurcation, where the new
    branch grows steeply, can make. A move within :data:`JUMP_FLOOR` of the side is no jump."""
    if last_move is None or np.linalg.norm(np.reshape(move, (-1, 3)), axis=1).max() <= JUMP_FLOOR * side_length:
        return False
    a, b = np.ravel(move), np.ravel(last_move)
    return float(a @ b) < TURN * float(np.linalg.norm(a) * np.linalg.norm(b))
