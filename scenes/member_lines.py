"""A member's two lines on the mesh: its centreline and its bond line as chains of points at the
mesh spacing (:mod:`scenes.mesh`), with the nodes where crossing members' lines meet, and the
spacing of points along a line (uniform, or graded by a local size)."""

from __future__ import annotations

from typing import Callable, NamedTuple, Sequence

import numpy as np

from .members import Crossing, Member, crossings, ring_crossings
from .scene import Scene

SizeField = Callable[[np.ndarray], np.ndarray]
"""Local element size (m,) mm at flat points (m, 2) mm."""

GRADING_SAMPLES = 257
"""Samples of the local spacing along a boundary piece or the symmetry axis."""


def spaced(a: float, b: float, h: float) -> np.ndarray:
    """Points from a (included) towards b (excluded) at most h apart."""
    n = max(1, int(np.ceil(abs(b - a) / h - 1e-9)))
    return a + (b - a) * np.arange(n) / n


def graded(a: float, b: float, h_of: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """Points from a (included) towards b (excluded) at the local spacing h_of(t) (mm) of the
    parameter t: equal steps of the integral of 1/h, the fewest at most h apart."""
    t = np.linspace(a, b, GRADING_SAMPLES)
    density = np.abs(b - a) / (GRADING_SAMPLES - 1) / h_of(t)
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]))])
    n = max(1, int(np.ceil(cum[-1] - 1e-9)))
    return np.interp(cum[-1] * np.arange(n) / n, cum, t)


class Lines(NamedTuple):
    """Members meshed so far: the points and, per member, its centreline chain, its bond line
    (a chain of mesh edges) and each centreline node's bond node."""

    points: np.ndarray
    centre: list[np.ndarray]
    bond_lines: list[np.ndarray]
    bonds: list[np.ndarray]

    def with_member(self, points: np.ndarray, centre: np.ndarray, bond_line: np.ndarray, bonds: np.ndarray
                    ) -> "Lines":
        """These lines and one more member's, on ``points``."""
        return Lines(points, self.centre + [centre], self.bond_lines + [bond_line], self.bonds + [bonds])

    @property
    def segments(self) -> list[np.ndarray]:
        """The edges (k, 2) the mesh must keep: every chain's."""
        return [np.column_stack([c[:-1], c[1:]]) for c in self.centre + self.bond_lines]


def rows_between(points: np.ndarray, centre: tuple[int, int], bond: tuple[int, int], h: float,
             size: SizeField | None, stations: Sequence[tuple[float, int | None, int | None]] = ()
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """New points on the straight line between the points ``centre`` at the spacing h (or the
    local size), and as many on the parallel line between the points ``bond`` at the same
    fractions of its length: beside the centreline's up to a shift along the line, which the
    section's direction does not see. ``stations`` (fraction, centreline point id or None, bond
    point id or None) are fractions where both lines have a node, the given points where they
    exist (a crossing member's lines), new ones otherwise; the spacing fills between them.
    Returns the points and the ids of both rows."""
    a, b = points[centre[0]], points[centre[1]]
    c, d = points[bond[0]], points[bond[1]]
    length = float(np.linalg.norm(b - a))
    marks = sorted(stations)
    stops = [0.0, *(m[0] for m in marks), 1.0]
    fractions, given = [], []
    for k, (lo, hi) in enumerate(zip(stops[:-1], stops[1:])):
        if size is None:
            f = spaced(lo, hi, h / length)
        else:
            f = graded(lo, hi, lambda t: size(a + t[:, None] * (b - a)) / length)
        fractions.append(f[1:] if k == 0 else f)
        given += [(None, None)] * (f.size - 1) if k == 0 else [marks[k - 1][1:]] + [(None, None)] * (f.size - 1)
    along = np.concatenate(fractions)
    centre_ids, bond_ids, new = np.empty(along.size, int), np.empty(along.size, int), []
    for row, ids, start, end in ((0, centre_ids, a, b), (1, bond_ids, c, d)):
        for k, (t, mark) in enumerate(zip(along, given)):
            if mark[row] is None:
                ids[k] = len(points) + len(new)
                new.append(start + t * (end - start))
            else:
                ids[k] = mark[row]
    return (np.vstack([points, *new]) if new else points), centre_ids, bond_ids


def member_lines(scene: Scene, members: Sequence[Member], s: np.ndarray, points: np.ndarray,
                  ring_of: Callable[[int], int], size: SizeField | None, lines: Lines | None = None) -> Lines:
    """Each member's centreline and bond line as chains of new points, with each centreline
    node's bond node.

    The centreline runs from its start's frame node to its end's through the bond nodes where it
    crosses the bond ring; its bond line runs ``frame.bond_lever`` to its left between the two
    bond nodes where that line crosses the ring (frame nodes are placed so that their bond nodes
    lie there, :func:`scenes.members.ring_crossings`), a node beside each inner node of the centreline
    (:func:`rows_between`). The two nodes of each end share the bond line's end. Where two members
    cross, the four points where their lines meet are nodes of both (:class:`scenes.members.Crossing`),
    each beside a node of the other line of its member (that node the crossing's own where
    another crossing point lies within a third of the spacing along the member, new otherwise).
    ``s`` are the frame nodes' arc lengths (ids 0, 1, ...) and ``ring_of(i)`` frame node i's bond node.
    """
    L, lever = scene.outline.length, scene.frame.lever
    lines = lines or Lines(points, [], [], [])
    found = crossings(members, lever)
    first = len(lines.points)
    if found:
        lines = lines._replace(points=np.vstack([lines.points, *(c.points for c in found)]))
    for k, member in enumerate(members):
        at = [int(np.argmin(np.abs(np.mod(s - sj + 0.5 * L, L) - 0.5 * L)))
              for sj in (member.s_start, *ring_crossings(scene.outline, member, lever, 0.0), member.s_end,
                         *ring_crossings(scene.outline, member, lever, lever))]
        ends, bond_ends = (ring_of(at[1]), ring_of(at[2])), (ring_of(at[4]), ring_of(at[5]))
        stations = _crossing_stations(lines.points, found, first, k, ends, bond_ends, scene.spacing)
        points, inner, beside = rows_between(lines.points, ends, bond_ends, scene.spacing, size, stations)
        lines = lines.with_member(points, np.concatenate([[at[0], ends[0]], inner, [ends[1], at[3]]]),
                                  np.concatenate([[bond_ends[0]], beside, [bond_ends[1]]]),
                                  np.concatenate([[bond_ends[0]] * 2, beside, [bond_ends[1]] * 2]))
    return lines


def _crossing_stations(points: np.ndarray, found: Sequence[Crossing], first: int, k: int, ends: tuple[int, int],
                       bond_ends: tuple[int, int], h: float) -> list[tuple[float, int | None, int | None]]:
    """Member k's stations (:func:`rows_between`) at its crossings: the crossing points on its
    centreline, each taking the one on its bond line within h / 3 along the member, and the others
    on its bond line alone. Crossing c's points have ids ``first + 4 c`` on."""
    a, b = points[ends[0]], points[ends[1]]
    c, d = points[bond_ends[0]], points[bond_ends[1]]
    length, bond_length = float(np.linalg.norm(b - a)), float(np.linalg.norm(d - c))
    u = (b - a) / length
    stations: list[list] = []
    for n, crossing in enumerate(found):
        if k in crossing.pair:
            on_centre, _ = crossing.on(k)
            stations += [[float((crossing.points[q] - a) @ u) / length, first + 4 * n + q, None] for q in on_centre]
    for n, crossing in enumerate(found):
        if k in crossing.pair:
            for q in crossing.on(k)[1]:
                t = float((crossing.points[q] - c) @ u) / bond_length
                near = [m for m in stations if m[2] is None and m[1] is not None and abs(m[0] - t) * length < h / 3]
                if near:
                    min(near, key=lambda m: abs(m[0] - t))[2] = first + 4 * n + q
                else:
                    stations.append([t, None, first + 4 * n + q])
    return [tuple(m) for m in stations]
