"""The result of any solver: one equilibrium state with its fields, measures and VTK output."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import metrics
from .crossing import film_crossing, frame_crossing
from .path import jumps_message
from .vtk import CellBlock, write_vtu

ENERGY_KEYS = ("membrane", "frame_bending", "frame_torsion", "frame_axial", "total")
"""Names of the energy split (N mm), the same for every solver (see ENERGY_DEFINITION)."""

ENERGY_DEFINITION = (
    "Energy: the exact elastic energy of the model, in N mm. Each membrane link or cable and each "
    "frame axial link of tension N = EA eps, strain eps = (L - L0) / L0 from its rest length L0, "
    "stores N eps L0 / 2 (a slack tension-only element nothing); the FEM film stores the same "
    "per lattice direction, E h / (2 lambda) sum_k eps_k^2 per unit flat area. The frame stores "
    "M^2 L / (2 EI) per node (strip: also in-plane bending and torsion T^2 L / (2 GJ)). The paper "
    "writes E_DR = sum N eps L / 2 + sum M^2 L / (2 EI), with the current length L: its membrane "
    "part is larger than the exact one by L / L0, about the pre-stretch (1.5-2x at 150-200 %), "
    "and is given beside it as info['energy_membrane_paper_formula']."
)
"""The energy every solver reports, in words and symbols: the one definition the report quotes."""

SUMMARY_COLUMNS = (
    ("prestretch", "-"),
    ("bending_angle", "deg"),
    ("branch", "-"),
    ("angle_unreadable", "-"),
    ("apex_x", "mm"),
    ("apex_y", "mm"),
    ("apex_z", "mm"),
    ("mid_height_width", "mm"),
    ("energy_membrane", "N mm"),
    ("energy_frame_bending", "N mm"),
    ("energy_frame_torsion", "N mm"),
    ("energy_frame_axial", "N mm"),
    ("energy_total", "N mm"),
    ("slack_area_fraction_any", "-"),
    ("slack_area_fraction_full", "-"),
    ("iterations", "-"),
    ("residual", "-"),
    ("newton_step", "mm"),
    ("wall_time", "s"),
    ("contact_checked", "-"),
    ("stable", "-"),
    ("lowest_eigenvalue", "N/mm^3"),
    ("jumps", "-"),
    ("lower_state", "-"),
    ("converged", "-"),
    ("status", "-"),
    ("message", "-"),
)
"""Columns of a state's one-line summary (CSV tables), with units."""


def lower_state_words(lower: dict[str, Any]) -> str:
    """The clause that names a state of lower energy found from another start
    (``info['lower_state']``)."""
    return (f"a stable state of lower energy was found from {lower['start']}: "
            f"{lower['bending_angle']:.2f} deg ({lower['branch']}), E = {lower['energy_total']:.6g} N mm")


@dataclass
class Result:
    """One equilibrium state (or the last state reached, if ``converged`` is False).

    Attributes
    ----------
    solver
        'dr' or 'fem'.
    x, x0
        Node positions now and in the flat reference, (n, 3) mm.
    converged, status, message
        Whether the solver met its tolerance; a one-word status ('converged', 'max_iterations',
        'diverged', 'self_contact', ...) and a sentence that says what happened.
    iterations, residual, residual_history, wall_time
        Solver steps, final relative residual, its history, seconds.
    energy
        Strain energy split (N mm), keys :data:`ENERGY_KEYS`.
    prestretch
        The pre-stretch ratio of this state.
    frame_nodes, frame_s
        Indices into x of the frame centreline nodes, ordered along the closed frame from the
        base midpoint, and their reference arc lengths (mm). None if the model has no frame.
    scene
        The scene this state solves (None for a low-level model).
    blocks, point_data
        What the VTK file holds: cell blocks with per-cell fields, and per-node fields.
    info
        Solver-specific extras (kinetic-energy peaks, element forces, ...); for scenes also
        ``slack_area_fraction_any`` / ``_full``: the flat membrane area with at least one /
        every link family slack (a tension field / a slack film).
    """

    solver: str
    x: np.ndarray
    x0: np.ndarray
    converged: bool
    status: str
    message: str
    iterations: int
    residual: float
    wall_time: float
    energy: dict[str, float]
    residual_history: np.ndarray = field(default_factory=lambda: np.zeros(0))
    prestretch: float = float("nan")
    frame_nodes: np.ndarray | None = None
    frame_s: np.ndarray | None = None
    scene: Any = None
    blocks: dict[str, CellBlock] = field(default_factory=dict)
    point_data: dict[str, np.ndarray] = field(default_factory=dict)
    info: dict[str, Any] = field(default_factory=dict)
    # the solver's (converged, status, message) before the angle was read: a second reading (in
    # a sweep) starts from it; not copied by dataclasses.replace, whose copy is read afresh
    _before_reading: tuple[bool, str, str] | None = field(default=None, init=False, repr=False, compare=False)

    # ----------------------------------------------------------------- frame measures
    def frame_arc(self) -> tuple[np.ndarray, np.ndarray, float]:
        """The frame nodes' positions (k, 3) mm, their arc lengths on the flat outline (k,) mm
        and the outline's length (mm): what every frame measure is computed from."""
        if self.frame_nodes is None or self.frame_s is None:
            raise ValueError("this model has no frame: add a beam chain or solve a scene")
        length = self.scene.outline.length if self.scene is not None else float(self.frame_s[-1])
        return self.x[self.frame_nodes], self.frame_s, length

    def frame_curve(self, samples: int | None = None) -> np.ndarray:
        """Frame centreline (k, 3) mm: the frame nodes in order, or ``samples`` points at equal
        reference arc length from the base midpoint."""
        x, s, length = self.frame_arc()
        return x if samples is None else metrics.resample(x, s, length, samples)

    def frame_point(self, s: float | np.ndarray) -> np.ndarray:
        """Frame position(s) (m, 3) at reference arc length(s) s, mm."""
        x, s_nodes, length = self.frame_arc()
        return metrics.frame_at(x, s_nodes, length, np.atleast_1d(s))

    def _need_scene(self) -> None:
        if self.scene is None:
            raise ValueError("this measure is defined on a scene; use dr.solve(scene)")

    @property
    def apex(self) -> np.ndarray:
        """Apex position (3,) mm: the frame point opposite the base."""
        self._need_scene()
        return self.frame_point(self.scene.outline.apex_arc_length())[0]

    def _continuous_angle(self) -> float:
        """The bending angle as read off the frame (deg), before the check that it can be read."""
        self._need_scene()
        x, s, _ = self.frame_arc()
        if not np.isfinite(x).all():
            return float("nan")
        theta = metrics.outline_bending_angle(x, s, self.scene.outline)
        previous = self.info.get("previous_bending_angle")
        usable = previous is not None and np.isfinite(previous)
        return metrics.nearest_turn(theta, previous) if usable else theta

    @property
    def segment_turns(self) -> np.ndarray | None:
        """For a frame with windows in a row (every member from one side to the other), the turn
        (deg) of the frame's midline along each window from the base to the apex
        (:func:`results.metrics.segment_turns`); None for other frames."""
        self._need_scene()
        bounds = self.scene.frame.segment_bounds
        if bounds is None:
            return None
        x, s, length = self.frame_arc()
        outline = self.scene.outline
        return metrics.segment_turns(x, s, length, outline.apex_arc_length(), outline.side_length, bounds)

    @property
    def bending_angle(self) -> float:
        """Bending angle (deg): base midpoint -> apex above the flat plane, in the symmetry plane,
        continuous from the flat state (:func:`results.metrics.bending_angle`); in a sweep, the
        turn nearest the previous state's angle (``info['previous_bending_angle']``). Positive
        on the 'up' branch, negative on the 'down' one; NaN where it cannot be read
        (:attr:`angle_unreadable`)."""
        theta = self._continuous_angle()
        return float("nan") if metrics.unreadable_angle(theta, self.info.get("crossing")) else theta

    @property
    def branch(self) -> str:
        """'up' or 'down': the side of the flat plane the apex went to from the flat state (the
        sign of the continuous angle), 'flat' on the flat branch, 'twisted' out of the plane
        with the apex untilted (:func:`results.metrics.branch`)."""
        return metrics.branch(self._continuous_angle(), self._lift())

    def _lift(self) -> float:
        """The frame's largest distance from the flat plane, / side length."""
        x, _, _ = self.frame_arc()
        return float(np.abs(x[:, 2]).max() / self.scene.outline.side_length)

    @property
    def angle_unreadable(self) -> str | None:
        """Why the bending angle cannot be read (a key of :data:`results.metrics.UNREADABLE`), or
        None."""
        return metrics.unreadable_angle(self._continuous_angle(), self.info.get("crossing"))

    def check_crossings(self, triangles: np.ndarray | None, contact_checked: bool) -> None:
        """Look for the frame or film passing through itself and name the state's branch.

        ``triangles`` (t, 3): the film's triangles (node indices into x; None: no film);
        ``contact_checked``: whether the solver stopped on contact on its way here. Sets
        ``info['contact_checked']``, ``info['crossing']`` ('frame_crossing', 'film_crossing' or
        None) with ``info['crossing_where']`` in words, then :meth:`label_angle`.
        """
        self.info["contact_checked"] = bool(contact_checked)
        self.info["crossing"], self.info["crossing_where"] = None, ""
        if self.frame_nodes is None or self.scene is None:
            return
        frame = np.asarray(self.frame_nodes)
        found = frame_crossing(self.x[frame], self.scene.frame.thickness)
        if found is None and triangles is not None and len(triangles):
            found = film_crossing(self.x, triangles, np.stack([frame, np.roll(frame, -1)], axis=1))
        if found is not None:
            self.info["crossing"] = "frame_crossing" if found.kind == "frame_self" else "film_crossing"
            self.info["crossing_where"] = found.describe()
        self.label_angle()

    def continue_from(self, previous: float) -> None:
        """Read the angle as the continuation of a sweep's previous state at ``previous`` deg."""
        self.info["previous_bending_angle"] = previous
        self.label_angle()

    def label_angle(self) -> None:
        """Set ``info['branch']`` and ``info['angle_unreadable']``; a converged state whose angle
        cannot be read is no answer: its status becomes 'unreadable' (not converged), and the
        message says why."""
        if self.scene is None or self.frame_nodes is None:
            return
        if self._before_reading is None:
            self._before_reading = (self.converged, self.status, self.message)
        self.converged, self.status, self.message = self._before_reading
        theta = self._continuous_angle()
        reason = metrics.unreadable_angle(theta, self.info.get("crossing"))
        side = metrics.branch(theta, self._lift())
        self.info["branch"], self.info["angle_unreadable"] = side, reason
        for clause in self._shape_remarks(theta, side, reason):
            if clause not in self.message:  # a copy of a state read before
                self.message += f"; {clause}"
        if reason is None:
            return
        if self.converged:
            self.converged, self.status = False, "unreadable"
        words = self.info.get("crossing_where") if reason in ("frame_crossing", "film_crossing") else ""
        if "the bending angle cannot be read" not in self.message:  # a copy of a state read before
            self.message += (f"; the bending angle cannot be read: {words or metrics.UNREADABLE[reason]}"
                             + (f", reading {theta:.1f} deg" if np.isfinite(theta) else ""))

    def _shape_remarks(self, theta: float, side: str, reason: str | None) -> list[str]:
        """The clauses on the shape a reader needs beside its angle: an apex against the scene's
        lift, a curl past half a turn (:func:`results.metrics.past_half_turn`)."""
        out = []
        lift = self.scene.perturbation.amplitude
        if lift and side in ("up", "down") and side != ("up" if lift > 0 else "down"):
            out.append(f"the apex went {side}, against the scene's lift (perturbation.amplitude = {lift:g} mm)")
        half = metrics.past_half_turn(theta) if reason is None else None
        if half:
            out.append(half)
        return out

    @property
    def remarks(self) -> list[str]:
        """What a reader of this state should know beside its numbers, in words (each also a
        clause of :attr:`message`): the jumps its path located (``info['snaps']``), an apex
        against the scene's lift, a curl past half a turn, and a state of lower energy found
        from another start (``info['lower_state']``, see :meth:`note_lower_state`)."""
        out = [jumps_message(self.info["snaps"])] if self.info.get("snaps") else []
        if self.scene is not None and self.frame_nodes is not None:
            theta = self._continuous_angle()
            reason = metrics.unreadable_angle(theta, self.info.get("crossing"))
            out += self._shape_remarks(theta, metrics.branch(theta, self._lift()), reason)
        lower = self.info.get("lower_state")
        if lower:
            out.append(lower_state_words(lower))
        mirror = self.info.get("mirror_state")
        if mirror:
            out.append(f"its mirror image through the flat plane is a stable state of the same energy on the lift's "
                       f"side: {mirror['bending_angle']:.2f} deg ({mirror['branch']})")
        return out

    def note_lower_state(self, other: "Result", start: str) -> None:
        """Record ``other``, a stable state of lower energy at this pre-stretch found from another
        ``start`` (words, e.g. 'the pre-stretch applied at once'), in ``info['lower_state']``
        (its start, bending angle, branch, total energy) and as a clause of the message."""
        self.info["lower_state"] = {"start": start, "bending_angle": other.bending_angle, "branch": other.branch,
                                    "energy_total": other.energy["total"]}
        self.message += "; " + lower_state_words(self.info["lower_state"])

    def note_mirror_state(self, other: "Result") -> None:
        """Record ``other``, this state's mirror image through the flat plane, a stable state of
        the same energy on the scene's lift's side, in ``info['mirror_state']`` (its bending
        angle, branch, total energy) and as a clause of the message."""
        self.info["mirror_state"] = {"bending_angle": other.bending_angle, "branch": other.branch,
                                     "energy_total": other.energy["total"]}
        self.message += "; " + self.remarks[-1]

    @property
    def mid_height_width(self) -> float:
        """In-plane width of the frame at mid-height (mm, along the base): the collapse measure."""
        self._need_scene()
        right, left = self.frame_point(np.array(self.scene.outline.mid_height_arc_lengths()))
        return float(right[0] - left[0])

    def shape_error(self, other: "Result") -> tuple[float, float]:
        """RMS and max frame-curve distance to ``other`` at equal arc length, / side length."""
        self._need_scene()
        xa, sa, length = self.frame_arc()
        xb, sb, _ = other.frame_arc()
        return metrics.shape_error(xa, sa, xb, sb, length, self.scene.outline.side_length)

    # ----------------------------------------------------------------- output
    def summary(self) -> dict[str, Any]:
        """One row of scalar results, keys :data:`SUMMARY_COLUMNS` (NaN where not defined): the
        measures, the energies, the cost, and which state it is: ``stable`` and
        ``lowest_eigenvalue`` (per unit film area; '' and NaN where not checked), ``newton_step``
        (DR: the largest nodal length of the Newton step K^-1 r from the state to the discrete
        equilibrium, an estimate of the stopping error; NaN where not computed), ``jumps`` (the
        path's located jumps, 'from->to' pre-stretches joined by '; ') and ``lower_state`` (a
        stable state of lower energy found from another start, in words)."""
        row: dict[str, Any] = {"prestretch": self.prestretch}
        try:
            apex = self.apex
            row.update(
                bending_angle=self.bending_angle,
                branch=self.branch,
                angle_unreadable=self.angle_unreadable or "",
                apex_x=apex[0],
                apex_y=apex[1],
                apex_z=apex[2],
                mid_height_width=self.mid_height_width,
            )
        except ValueError:
            row.update(
                bending_angle=np.nan, branch="", angle_unreadable="", apex_x=np.nan, apex_y=np.nan, apex_z=np.nan,
                mid_height_width=np.nan,
            )
        for k in ENERGY_KEYS:
            row[f"energy_{k}"] = self.energy.get(k, 0.0)
        for k in ("slack_area_fraction_any", "slack_area_fraction_full"):
            row[k] = self.info.get(k, np.nan)
        row.update(
            iterations=self.iterations,
            residual=self.residual,
            newton_step=self.info.get("newton_step_mm", np.nan),
            wall_time=self.wall_time,
            contact_checked=self.info.get("contact_checked", ""),
            stable="" if self.info.get("stable") is None else bool(self.info["stable"]),
            lowest_eigenvalue=self.info.get("lowest_eigenvalue_N_per_mm3", np.nan),
            jumps="; ".join(f"{a:.4f}->{b:.4f}" for a, b in self.info.get("snaps") or []),
            lower_state=lower_state_words(self.info["lower_state"]) if self.info.get("lower_state") else "",
            converged=self.converged,
            status=self.status,
            message=self.message,
        )
        return row

    def write_vtk(self, path: str | Path) -> Path:
        """Write this state as a .vtu file for ParaView (atomically); returns the path.

        Point data always holds the displacement from the flat reference (mm).
        """
        point_data = {"displacement_mm": self.x - self.x0, **self.point_data}
        return write_vtu(path, self.x, self.blocks, point_data)
