"""Continuation in pre-stretch from the flat state, stability checks, and the ``Result`` of a state.

Path: lambda = 1 is the flat, stress-free state at 0 V; with a voltage on, the Maxwell stress
compresses the unstretched film and its state there is solved from the lifted start like any
other (the film buckles). Each continuation step raises lambda by at most
``MAX_STEP`` and solves by Newton from a tangent predictor, K dy/dlambda = -dg/dlambda at the
last state (a secant where that tangent cannot be factorised; the first step from the flat
state); a failed step is halved, and where the branch ends (a limit point) a long Newton solve
looks for the state it snaps to. Every converged state's tangent is checked: while it has a
negative eigenvalue (the flat state loses stability almost at once) the state is pushed along
the lowest eigenmode, on the lift's side, and solved again, so only stable states are accepted.
The step on which the flat state buckles and a step that jumps off the branch are cut until
located (the rules of :mod:`results.path`). After each step the frame is checked
for self-contact and the taut film for folds; the first one stops the path, with the pre-stretch
located by bisection. Refined levels follow the path on the coarsest mesh, each level starting
Newton from the state of the level below (mesh sequencing), falling back to its own continuation.
"""

from __future__ import annotations

import time
from typing import Iterator, Sequence

import numpy as np

from results import Result
from results.crossing import Crossing, film_crossing
from results.path import AFTER_EVENT, LOCATE, jumped, largest_move, neutral_stiffness, planar, side_of_mode, turned
from scenes import Scene, SceneError
from scenes.fields import integer_at_least, prestretch_list

from .contact import Contact, frame_contact, membrane_fold
from .model import DemesProblem
from .newton import NewtonResult, NotFactorizable, factorisation_count, newton, positive_shift, shift_scale
from .stability import lowest_free_mode
from .state import Outcome, StepRecord, make_result, stress_free

FIRST_STEP = 0.01
MAX_STEP = 0.05
MAX_NEWTON = 100
SNAP_ITERATIONS = 600  # a snap-through is a long way for Newton with line search
SADDLE = 1e-4  # residual below which an indefinite tangent means a saddle is near
MIN_STEP = 1e-4
TOLERANCE = 1e-8  # largest free nodal force / largest membrane nodal force (round-off floor ~1e-10)
MAX_EIGEN_STEPS = 6
CONTACT_BRACKET = 1e-3  # first contact is located to within this pre-stretch interval


class Continuation:
    """Follows the stable equilibrium path of a :class:`DemesProblem` in pre-stretch."""

    def __init__(self, problem: DemesProblem, deadline: float | None = None):
        """``deadline``: a ``time.perf_counter()`` value after which the path stops."""
        self.problem = problem
        self.deadline = deadline
        self.scene = problem.scene
        self.lam = 1.0
        self.y = problem.reference()
        self.previous: tuple[float, np.ndarray] | None = None
        self.step = FIRST_STEP
        self.side = self.scene.outline.side_length
        self.flat = problem.initial_guess(lift=False).reshape(-1, 3)
        self.rate: float | None = None  # largest nodal move per unit pre-stretch on the last step (mm)
        self.last_move: np.ndarray | None = None  # the last step's move on the branch (results.path.turned)
        self.neutral = neutral_stiffness(self.scene)
        self.apex = problem.mesh.frame_nodes[self.scene.outline.nearest_to_apex(problem.mesh.frame_s)]
        self.lift = problem.initial_guess() - problem.initial_guess(lift=False)
        self.snaps: list[tuple[float, float]] = []  # (last state on the branch, state snapped to)
        self.up = np.sign(self.scene.perturbation.amplitude) or 1.0  # + : apex up
        centroids = problem.X[problem.mesh.film_cells[:, :3], :2].mean(axis=1)
        self.band = self.scene.outline.distance(centroids) < self.scene.frame.lever
        self.start_records: list[StepRecord] = []  # the Newton solve of the state at lambda = 1, if any
        self.start_failure: Outcome | None = None
        self.stress_free_start = stress_free(self.scene, 1.0)
        if not self.stress_free_start:
            self._solve_start()

    def _solve_start(self) -> None:
        """With a voltage on, the film at lambda = 1 is not stress-free: the Maxwell stress
        compresses it, the flat state is no equilibrium and the film buckles. Its state is solved
        as any other (pushes off saddles included), from the lifted start, so that the lift
        chooses the side it buckles to; where that fails, the path stops there."""
        nr, pushes, _ = self.solve_at(1.0, self.problem.initial_guess())
        self.start_records = [StepRecord(1.0, nr.iterations, nr.history, pushes)]
        if nr.converged:
            self.y = nr.y
            return
        self.start_failure = Outcome(self.y, 1.0, "diverged" if nr.status == "line_search" else nr.status,
                                     f"the state at lambda = 1 with the voltage on (the film compressed by its "
                                     f"Maxwell stress) was not found: Newton {nr.status}, residual {nr.residual:.2e} "
                                     f"after {nr.iterations} iterations", self.start_records)

    # ------------------------------------------------------------------ one state
    def _flat_saddle(self, lam: float) -> bool:
        """Whether the flat state at ``lam`` is a saddle (Newton from flat, no pushes)."""
        self.problem.lam = lam
        nr = newton(self.problem, self.flat.ravel(), tol=TOLERANCE, max_iterations=MAX_NEWTON, saddle=SADDLE,
                    deadline=self.deadline)
        self.problem.lam = self.lam
        if nr.status == "saddle":  # indefinite where the residual is small: past buckling
            return True
        if not nr.converged or nr.positive_definite:
            return False
        try:
            return self._lowest(nr.y)[0] < -self.neutral
        except NotFactorizable:
            return False

    def _lowest(self, y: np.ndarray) -> tuple[float, np.ndarray]:
        return lowest_free_mode(self.problem, y)

    def _eigen_push(self, y: np.ndarray, phi_free: np.ndarray) -> np.ndarray | None:
        """Step from saddle y along the mode, on the lift's side (:func:`results.path.side_of_mode`)
        first, to where the energy is lower."""
        pb = self.problem
        phi = np.zeros(pb.n_dofs)
        phi[pb.free] = phi_free
        phi /= np.linalg.norm(phi.reshape(-1, 3), axis=1).max()
        sign = side_of_mode(phi.reshape(-1, 3), apex=self.apex, lift=self.lift.reshape(-1, 3), up=self.up,
                            flat=self.flat)
        e0 = pb.energy(y)
        for side in (sign, -sign):
            alpha = 0.05 * self.side
            for _ in range(30):
                trial = y + alpha * side * phi
                if pb.energy(trial) < e0 - 1e-12 * abs(e0):
                    return trial
                alpha *= 0.5
        return None

    def solve_at(self, lam: float, start: np.ndarray, max_iterations: int = 0
                 ) -> tuple[NewtonResult, int, float]:
        """Stable equilibrium at ``lam`` from ``start``: Newton, then eigenmode steps while the
        tangent has a negative eigenvalue. Returns the Newton result, the number of eigenmode
        steps and the lowest eigenvalue checked (NaN when the tangent was positive definite)."""
        self.problem.lam = lam
        its = max_iterations or MAX_NEWTON
        nr = newton(self.problem, start, tol=TOLERANCE, max_iterations=its, saddle=SADDLE,
                    deadline=self.deadline)
        pushes, omega = 0, float("nan")
        while (nr.converged and not nr.positive_definite) or nr.status == "saddle":
            try:
                omega, phi = self._lowest(nr.y)
            except NotFactorizable:
                nr.status, nr.converged = "diverged", False
                break
            if omega > -self.neutral:
                if nr.status == "saddle":  # only neutral modes: carry on with plain Newton
                    history = nr.history
                    nr = newton(self.problem, nr.y, tol=TOLERANCE, max_iterations=its)
                    nr.history = history + nr.history
                break  # a zero mode (slack film): neutral, not unstable
            if pushes == MAX_EIGEN_STEPS:
                nr.status, nr.converged = "unstable", False
                break
            pushed = self._eigen_push(nr.y, phi)
            if pushed is None:
                nr.status, nr.converged = "unstable", False
                break
            history = nr.history
            nr = newton(self.problem, pushed, tol=TOLERANCE, max_iterations=its, saddle=SADDLE,
                        deadline=self.deadline)
            nr.history = history + nr.history
            pushes += 1
        return nr, pushes, omega

    def contact(self, y: np.ndarray) -> Contact | Crossing | None:
        """Frame self-contact, the film (or the frame) passing through the film, or a membrane
        fold at positions y, if any."""
        pb = self.problem
        x = y.reshape(-1, 3)
        mesh = pb.mesh
        found = frame_contact(x[mesh.frame_nodes], pb.held_chain, self.scene.frame.thickness)
        if found is not None:
            return found
        frame = mesh.frame_nodes
        crossing = film_crossing(x, mesh.film_cells[:, :3], np.stack([frame, np.roll(frame, -1)], axis=1))
        if crossing is not None:
            return crossing
        # a slack film has no stiffness and its wrinkles are arbitrary: only taut folds count;
        # and the band bonded to the strip is left out: the film leaves the strip's inner edge
        # at an angle (the strip's torque acts there), which is not a fold of the free film
        tension = pb.membrane.principal_tensions(pb.film_positions(y), pb.lam)[0][0].mean(axis=1)
        taut = np.zeros(len(mesh.cells), bool)  # the strip bands are no film
        taut[~mesh.strip_band] = (tension > 1e-3 * tension.max()) & ~self.band
        return membrane_fold(x, mesh.cells[:, :3], mesh.linear.f2t, taut)

    # ------------------------------------------------------------------ the path
    def _predictor(self, lam: float) -> np.ndarray:
        if self.lam == 1.0 and self.stress_free_start:  # left along its lowest mode where it is a saddle
            return self.problem.initial_guess(lift=False)
        tangent = self._path_tangent()
        if tangent is not None:
            return self.y + tangent * (lam - self.lam)
        if self.previous is None:
            return self.y
        lam0, y0 = self.previous
        return self.y + (self.y - y0) * (lam - self.lam) / (self.lam - lam0)

    def _path_tangent(self) -> np.ndarray | None:
        """dy/dlambda at the current state: K dy = -dg/dlambda (central difference in lambda)."""
        pb, h = self.problem, 1e-6
        f = pb.free
        grads = []
        for lam in (self.lam + h, self.lam - h):
            pb.lam = lam
            grads.append(pb.evaluate(self.y, 1).gradient[f])
        pb.lam = self.lam
        K = pb.evaluate(self.y, 2).tangent[f][:, f].tocsc()
        M = pb.mass[f][:, f].tocsc()
        try:
            _, fac = positive_shift(K, M, shift_scale(K, M))
        except NotFactorizable:
            return None
        dy = np.zeros(pb.n_dofs)
        dy[f] = -fac.solve((grads[0] - grads[1]) / (2 * h))
        return dy

    def _bisect_contact(self, bad: float) -> tuple[float, float]:
        """Narrow the first contact between the current state and ``bad``; moves to the last
        contact-free state found; the bracket ends narrower than CONTACT_BRACKET."""
        while bad - self.lam > CONTACT_BRACKET:
            mid = 0.5 * (self.lam + bad)
            nr, _, _ = self.solve_at(mid, self.y)
            if nr.converged and self.contact(nr.y) is None:
                self.previous, self.lam, self.y = (self.lam, self.y), mid, nr.y
            else:
                bad = mid
        self.problem.lam = self.lam
        return self.lam, bad

    def _out_of_time(self, records: list[StepRecord]) -> Outcome:
        self.problem.lam = self.lam
        return Outcome(self.y, self.lam, "time_limit",
                       f"the time limit (fem.time_limit = {self.scene.fem.time_limit:g} s) was spent "
                       f"at lambda = {self.lam:.4f} with a step of {self.step:.2g}", records)

    def advance(self, target: float, guess: np.ndarray | None = None) -> Outcome:
        """Follow the path up to ``target``; stop early on failure or contact.

        A ``guess`` of the state at ``target`` (e.g. from a coarser mesh) is tried first; if it
        does not lead to a stable, contact-free equilibrium the path is stepped as usual.
        """
        if self.start_failure is not None:
            return self.start_failure
        records, self.start_records = self.start_records, []
        if guess is not None and target > self.lam:
            nr, pushes, _ = self.solve_at(target, guess)
            records.append(StepRecord(target, nr.iterations, nr.history, pushes))
            if nr.converged and self.contact(nr.y) is None:
                self.previous, self.lam, self.y = (self.lam, self.y), target, nr.y
                self.last_move = None
        while self.lam < target - 1e-12:
            if self.deadline is not None and time.perf_counter() > self.deadline:
                return self._out_of_time(records)
            lam = min(self.lam + self.step, target)
            if target - lam < 0.25 * self.step:  # do not leave a sliver before the target
                lam = target
            on_plane = planar(self.y.reshape(-1, 3), self.flat, self.side)
            if on_plane and self.step >= 2 * LOCATE and self._flat_saddle(lam):
                self.step *= 0.5  # the flat state buckled within this step: locate where
                continue
            nr, pushes, _ = self.solve_at(lam, self._predictor(lam))
            if not nr.converged and self.lam > 1.0:  # retry without the predictor
                nr, pushes, _ = self.solve_at(lam, self.y)
            if not nr.converged and self.step < 2 * MIN_STEP:
                # the branch ends (a limit point): look for the state it snaps to
                nr, pushes, _ = self.solve_at(lam, self.y, SNAP_ITERATIONS)
                if nr.converged:
                    self.snaps.append((self.lam, lam))
            records.append(StepRecord(lam, nr.iterations, nr.history, pushes))
            if nr.status == "time_limit":
                return self._out_of_time(records)
            if nr.status == "not_finite":
                # a NaN/inf is a degenerate model or state, not a step too long: stop and say where
                self.problem.lam = self.lam
                cells = np.flatnonzero((self.problem.mesh.cells == nr.bad_node).any(axis=1))
                where = (f"node {nr.bad_node} (elements {', '.join(map(str, cells[:4]))})"
                         if nr.bad_node >= 0 else "the energy")
                return Outcome(self.y, self.lam, "not_finite",
                               f"a non-finite force or energy at lambda = {lam:.4f}, first at {where}; "
                               f"the last finite state (lambda = {self.lam:.4f}) is kept", records)
            if not nr.converged:
                self.step *= 0.5
                if self.step >= MIN_STEP:
                    continue
                self.problem.lam = self.lam
                return Outcome(self.y, self.lam, "unstable" if nr.status == "unstable" else
                               ("max_iterations" if nr.status == "max_iterations" else "diverged"),
                               f"Newton failed at lambda = {lam:.4f} ({nr.status}, residual "
                               f"{nr.residual:.2e} after {nr.iterations} iterations) even with "
                               f"steps below {MIN_STEP:g}", records)
            moved = nr.y - self.y
            move = largest_move(nr.y.reshape(-1, 3), self.y.reshape(-1, 3))
            if on_plane and not planar(nr.y.reshape(-1, 3), self.flat, self.side):
                self.snaps.append((self.lam, lam))  # left the flat state
                self.rate, self.last_move, self.step = None, None, AFTER_EVENT
            elif (pushes or jumped(move, lam - self.lam, self.rate, self.side)
                  or turned(moved, self.last_move, self.side)):
                # the branch lost its stability within this step, or the state left it
                if self.step >= 2 * LOCATE:
                    self.step *= 0.5  # cut the step until the event is located
                    continue
                if (self.lam, lam) not in self.snaps:
                    self.snaps.append((self.lam, lam))
                self.rate, self.last_move, self.step = None, None, AFTER_EVENT
            else:
                self.rate, self.last_move = move / (lam - self.lam), moved
            found = self.contact(nr.y)
            if found is not None:
                free, bad = self._bisect_contact(lam)
                return Outcome(self.y, self.lam, "film_contact" if isinstance(found, Crossing) else "self_contact",
                               f"{found.describe()} at lambda = {lam:.4f}; first contact between "
                               f"lambda = {free:.4f} and {bad:.4f}", records, (free, bad))
            self.previous, self.lam, self.y = (self.lam, self.y), lam, nr.y
            if nr.iterations <= 5:
                self.step = min(1.5 * self.step, MAX_STEP)
            elif nr.iterations > 12:
                # not below MIN_STEP: where Newton takes many iterations at any step (a soft
                # mode near round-off) the step would otherwise shrink towards 0 and the path stall
                self.step = max(0.7 * self.step, MIN_STEP)
        self.problem.lam = self.lam
        return Outcome(self.y, self.lam, "converged", "", records)


# ----------------------------------------------------------------------------- paths


def _check_prestretches(prestretches: Sequence[float]) -> list[float]:
    if isinstance(prestretches, np.ndarray):
        prestretches = prestretches.tolist()
    return sorted(set(prestretch_list("prestretches", prestretches)))


def refinement_level(scene: Scene, refinement: int | None) -> int:
    """The FEM refinement level asked for (default ``scene.fem.refinement``), checked."""
    if not isinstance(scene, Scene):
        raise SceneError(f"expected a scenes.Scene, got {type(scene).__name__}; use scenes.load(...)")
    return scene.fem.refinement if refinement is None else integer_at_least(0, 5)("fem.refinement", refinement)


def sweep(scene: Scene, prestretches: Sequence[float], refinement: int | None = None
          ) -> Iterator[Result]:
    """States at increasing pre-stretch, one continuation path from the flat state.

    Parameters
    ----------
    scene
        The DEMES scene; ``scene.fem.element`` picks P1 or P2.
    prestretches
        Pre-stretch ratios (>= 1), solved in increasing order.
    refinement
        Times the element size is halved (default ``scene.fem.refinement``).

    Yields
    ------
    Result
        One per requested pre-stretch, until the path stops (contact, no convergence): the
        state that stopped it is yielded with its status and nothing after it. ``iterations``
        (Newton iterations on this mesh), ``info['factorisations']`` (sparse Cholesky
        factorisations on this mesh) and ``wall_time`` (including the coarser levels' work) count
        since the previous state.
    """
    for states in _sweep(scene, prestretches, refinement, every_level=False):
        yield states[-1]


def sweep_levels(scene: Scene, prestretches: Sequence[float], refinement: int | None = None
                 ) -> Iterator[list[Result]]:
    """As :func:`sweep`, with the state of every coarser level too: the nested meshes
    refinement 0 to ``refinement`` along one path, for a mesh convergence estimate per state.

    Yields
    ------
    list of Result
        Per requested pre-stretch, the states of the levels still on their path, coarse to fine
        (``info['refinement']`` says which); the finest is last and ends the sweep as
        :func:`sweep`'s does. A coarser level whose path stopped is left out from then on.
        A coarser state's ``wall_time`` is its own level's work.
    """
    yield from _sweep(scene, prestretches, refinement, every_level=True)


def _sweep(scene: Scene, prestretches: Sequence[float], refinement: int | None, every_level: bool
           ) -> Iterator[list[Result]]:
    lams = _check_prestretches(prestretches)
    level = refinement_level(scene, refinement)
    problem = DemesProblem(scene, level, scene.fem.element)
    limit = scene.fem.time_limit
    deadline = time.perf_counter() + limit if limit > 0 else None
    path = Continuation(problem, deadline)
    # mesh sequencing: the path is followed on the coarsest mesh and every finer level starts
    # Newton from the state of the level below (slender frames make Newton's region of fast
    # convergence shrink with h; r0 -> r2 directly took 34 iterations at 1.6 where r1 -> r2 takes
    # a few, and a level costs 4-8x the one below)
    guides = [Continuation(DemesProblem(scene, k, scene.fem.element), deadline) for k in range(level)]
    steps = {id(p): 0 for p in (path, *guides)}
    theta: dict[int, float] = {}
    for lam in lams:
        t0 = time.perf_counter()
        factorised = factorisation_count(problem.free.size)
        snapped = len(path.snaps)
        below, alive, coarse = None, [], []
        for guide in guides:
            tg = time.perf_counter()
            g_out = guide.advance(lam, _transferred(below, guide.problem))
            below = (guide.problem, g_out.y) if g_out.converged else None
            if g_out.converged:
                alive.append(guide)  # a level whose path stopped drops out; the next goes on by itself
            if every_level:
                steps[id(guide)] += len(g_out.records)
                coarse.append(_level_result(guide, g_out, lam, time.perf_counter() - tg, steps[id(guide)], theta))
        guides = alive
        out = path.advance(lam, _transferred(below, problem))
        out.snaps = path.snaps[snapped:]
        steps[id(path)] += len(out.records)
        res = _level_result(path, out, lam, 0.0, steps[id(path)], theta)
        res.wall_time = time.perf_counter() - t0
        res.info["factorisations"] = factorisation_count(problem.free.size) - factorised  # on this mesh
        yield [*coarse, res]
        if not (out.converged and res.converged):  # also a state whose angle cannot be read
            return


def _level_result(path: Continuation, out: Outcome, lam: float, wall: float, steps: int,
                  theta: dict[int, float]) -> Result:
    """The Result of one level's state; ``theta`` holds each level's last bending angle (deg),
    so that the angle is continued along the sweep."""
    res = make_result(path.problem, out, lam, wall, steps)
    if id(path) in theta:
        res.continue_from(theta[id(path)])
    theta[id(path)] = res.bending_angle
    return res


def _transferred(below: tuple[DemesProblem, np.ndarray] | None, problem: DemesProblem) -> np.ndarray | None:
    """A coarser level's state (problem, y) as a start on ``problem``'s mesh (None: no start)."""
    if below is None:
        return None
    coarse, y = below
    return problem.hold(coarse.mesh.transfer(y.reshape(-1, 3), problem.mesh))


def solve(scene: Scene, refinement: int | None = None) -> Result:
    """Equilibrium at ``scene.prestretch`` (continuation from the flat state inside)."""
    return next(iter(sweep(scene, [scene.prestretch], refinement)))


_NEWTON_STATUS = {"saddle": "unstable", "line_search": "diverged"}
"""Newton's own stops, as the path reports them (:func:`make_result`)."""


def solve_from(scene: Scene, x_start: np.ndarray, refinement: int | None = None) -> Result:
    """The stable equilibrium at ``scene.prestretch`` that Newton reaches from ``x_start``.

    Newton (with eigenmode steps off a saddle) starts at ``x_start`` (n, 3) mm, a state on this
    problem's nodes, e.g. DR's on the same discrete problem, with no continuation path: it
    polishes a state found another way and says whether it is stable (``info['stable']``,
    ``info['lowest_eigenvalue_N_per_mm3']``). How a second stable state is checked.
    """
    level = refinement_level(scene, refinement)
    problem = DemesProblem(scene, level, scene.fem.element)
    x = np.asarray(x_start, dtype=float)
    if x.shape != problem.X.shape or not np.all(np.isfinite(x)):
        raise SceneError(f"x_start must be finite positions (n, 3) on the FEM's nodes at refinement {level} "
                         f"({problem.X.shape[0]} nodes), got shape {x.shape}; give a state of this mesh")
    t0 = time.perf_counter()
    lam = scene.prestretch
    path = Continuation(problem)
    nr, pushes, _ = path.solve_at(lam, problem.hold(x))
    status, detail = _NEWTON_STATUS.get(nr.status, nr.status), ""
    if nr.converged:
        found = path.contact(nr.y)
        if found is not None:
            status, detail = ("film_contact" if isinstance(found, Crossing) else "self_contact"), found.describe()
    problem.lam = lam
    out = Outcome(nr.y if nr.converged else problem.hold(x), lam, status, detail,
                  [StepRecord(lam, nr.iterations, nr.history, pushes)])
    return make_result(problem, out, lam, time.perf_counter() - t0, nr.iterations)
