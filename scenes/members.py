"""Cross-members: straight strips across the frame that divide its film into windows.

A member is the centreline of a strip of the frame's section, from one point of the outline to
another (``frame.members``, in the flat scene's x, y: the outline's frame, base along +x centred on
the origin). It is bonded to the film on both sides and joined rigidly to the outline where it
meets it (a T junction of three strips). Two members may cross: a rigid junction of four strips
(:class:`Crossing`). The members cut the region inside the outline into windows, covered by film
but those ``frame.open_windows`` names (:mod:`scenes.windows`); ``[[electrodes]]`` regions can
follow them.

What a scene can model is checked here, each refusal naming the member and the fix: both ends on
the outline, the member inside it, meeting the outline and any member it crosses at
:data:`MIN_ANGLE_DEG` or more, crossings inside the film and apart, members that do not cross
apart, and every window wider than the strip.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
import shapely
from shapely.ops import polygonize, unary_union

from .errors import SceneError
from .geometry import Outline

ON_OUTLINE = 0.01
"""Largest distance of a member's end from the outline, as a fraction of the strip width: the
end is moved onto the outline (a point typed on a straight side is on it to round-off)."""

MIN_ANGLE_DEG = 30.0
"""Smallest angle between a member and the outline where they meet: at a shallower angle the two
strips overlap along a length of several widths, which a junction at one point does not model."""


@dataclass(frozen=True)
class Member:
    """A straight cross-member's centreline in the flat scene, mm: from ``start`` to ``end``, both
    on the outline at arc lengths ``s_start`` and ``s_end``."""

    start: np.ndarray
    end: np.ndarray
    s_start: float
    s_end: float

    @property
    def length(self) -> float:
        """Centreline length, mm."""
        return float(np.linalg.norm(self.end - self.start))

    @property
    def direction(self) -> np.ndarray:
        """Unit vector (2,) from start to end."""
        return (self.end - self.start) / self.length

    @property
    def line(self) -> shapely.LineString:
        """The centreline as a shapely line, mm."""
        return shapely.LineString([self.start, self.end])


def frame_members(outline: Outline, ends: Sequence, width: float, lever: float, name: str = "frame.members"
                  ) -> tuple[Member, ...]:
    """The checked members of ``ends`` ((k, 2, 2) mm) on ``outline`` for a strip ``width`` (mm)
    whose film turns its section ``lever`` mm from its centreline.

    Raises
    ------
    SceneError
        Naming the member (``frame.members[k]``) and the fix.
    """
    if len(ends) == 0:
        return ()
    ends = np.asarray(ends, float).reshape(-1, 2, 2)
    s, gap = outline.project(ends.reshape(-1, 2))
    s, gap = s.reshape(-1, 2), gap.reshape(-1, 2)
    on = outline.evaluate(s.ravel())
    points, tangents = on[0].reshape(-1, 2, 2), on[1].reshape(-1, 2, 2)
    members = []
    for k in range(len(ends)):
        for j in range(2):
            if gap[k, j] > ON_OUTLINE * width:
                x, y = ends[k, j]
                raise SceneError(
                    f"{name}[{k}] ends at [{x:g}, {y:g}], {gap[k, j]:.3g} mm from the frame's outline: a "
                    "member runs from the outline to the outline; put both ends on its centreline (the "
                    "sides of frame.vertices, in the outline's frame: base along +x centred on the origin)")
        member = Member(points[k, 0], points[k, 1], float(s[k, 0]), float(s[k, 1]))
        if member.length < 2.0 * width:
            raise SceneError(f"{name}[{k}] is {member.length:.3g} mm long, shorter than two strip widths "
                             f"(frame.width = {width:g} mm): it would join the outline to itself")
        for j in range(2):
            t, d = tangents[k, j], member.direction
            sine = abs(float(t[0] * d[1] - t[1] * d[0]))
            if sine < np.sin(np.radians(MIN_ANGLE_DEG)):
                raise SceneError(
                    f"{name}[{k}] meets the outline at {np.degrees(np.arcsin(min(sine, 1.0))):.3g} deg: a "
                    f"member must cross the frame's strip at {MIN_ANGLE_DEG:g} deg or more")
        inside = outline.contains(member.start + np.linspace(0.02, 0.98, 49)[:, None] * (member.end - member.start))
        if not inside.all():
            raise SceneError(f"{name}[{k}] leaves the frame: its centreline runs outside the outline "
                             "between its ends; a member spans the film from one side to another")
        try:
            for shift in (0.0, lever):
                ring_crossings(outline, member, lever, shift)
        except ValueError:
            raise SceneError(f"{name}[{k}] ends too near a corner: its strip's bond line (frame.bond_lever to its "
                             "left) does not cross the outline's near its ends; move its ends along the sides, "
                             "away from the corners") from None
        members.append(member)
    found = []
    for i in range(len(members)):
        for j in range(i + 1, len(members)):
            a, b = members[i], members[j]
            if a.line.intersects(b.line):
                found.append(_checked_crossing(outline, members, (i, j), width, lever, f"{name}[{i}] and {name}[{j}]"))
            elif a.line.distance(b.line) < width:
                raise SceneError(
                    f"{name}[{i}] and {name}[{j}] come closer than the strip width: members that do not cross "
                    f"are kept frame.width = {width:g} mm apart or more")
    for p in range(len(found)):
        for q in range(p + 1, len(found)):
            gap = float(np.linalg.norm(found[p].points[0] - found[q].points[0]))
            if gap < 2.0 * width:
                raise SceneError(
                    f"{name}: the crossings of members {found[p].pair} and {found[q].pair} are {gap:.3g} mm apart: "
                    f"a junction joins two members; keep crossings 2 x frame.width = {2 * width:g} mm apart or more")
    for k, window in enumerate(windows(outline, members, width)):
        film = window.buffer(-0.5 * width)
        if film.is_empty or film.area <= 0.0:
            x, y = window.representative_point().coords[0]
            raise SceneError(
                f"{name}: the window round [{x:.3g}, {y:.3g}] is narrower than the strip (frame.width = "
                f"{width:g} mm): no film would be left between its strips; move the members apart or "
                "away from the corners")
    return tuple(members)


@dataclass(frozen=True)
class Crossing:
    """Where members ``pair`` = (i, j), i < j, cross (a rigid junction of four strips), mm: the
    points (4, 2) where i's centreline meets j's centreline and j's bond line, and where i's bond
    line (``frame.bond_lever`` to its left) meets j's centreline and j's bond line."""

    pair: tuple[int, int]
    points: np.ndarray

    def on(self, k: int) -> tuple[tuple[int, int], tuple[int, int]]:
        """Which of :attr:`points` lie on member k's centreline and which on its bond line."""
        return ((0, 1), (2, 3)) if k == self.pair[0] else ((0, 2), (1, 3))


def crossings(members: Sequence[Member], lever: float) -> list[Crossing]:
    """Every crossing of two members' centrelines, with its four line crossings (:class:`Crossing`)."""
    out = []
    for i in range(len(members)):
        for j in range(i + 1, len(members)):
            a, b = members[i], members[j]
            if a.line.intersects(b.line):
                out.append(Crossing((i, j), _crossing_points(a, b, lever)))
    return out


def _crossing_points(a: Member, b: Member, lever: float) -> np.ndarray:
    """(4, 2) mm: where a's centreline and bond line meet b's centreline and bond line
    (:class:`Crossing`'s order)."""
    return np.array([_meet(a, b, sa, sb, lever) for sa in (0.0, 1.0) for sb in (0.0, 1.0)])


def _left(member: Member) -> np.ndarray:
    return np.array([-member.direction[1], member.direction[0]])


def _meet(a: Member, b: Member, shift_a: float, shift_b: float, lever: float) -> np.ndarray:
    """Where a's centreline moved ``shift_a`` levers to its left meets b's moved ``shift_b``."""
    pa, pb = a.start + shift_a * lever * _left(a), b.start + shift_b * lever * _left(b)
    matrix = np.column_stack([a.direction, -b.direction])
    t = np.linalg.solve(matrix, pb - pa)
    return pa + t[0] * a.direction


def _checked_crossing(outline: Outline, members: Sequence[Member], pair: tuple[int, int], width: float,
                      lever: float, what: str) -> Crossing:
    """The crossing of the members ``pair``, refused where a four-strip junction does not model it:
    too shallow (checked first: parallel lines do not meet), or so near the outline that its
    strips' bands overlap the outline's."""
    a, b = members[pair[0]], members[pair[1]]
    sine = abs(float(a.direction[0] * b.direction[1] - a.direction[1] * b.direction[0]))
    if sine < np.sin(np.radians(MIN_ANGLE_DEG)):
        raise SceneError(f"{what} cross at {np.degrees(np.arcsin(min(sine, 1.0))):.3g} deg: members cross at "
                         f"{MIN_ANGLE_DEG:g} deg or more")
    points = _crossing_points(a, b, lever)
    near = float(outline.distance(points).min())
    if near < lever + width:
        x, y = points[0]
        raise SceneError(f"{what} cross at [{x:.3g}, {y:.3g}], where their strips come {near:.3g} mm from the "
                         "outline: a junction of four strips lies inside the film, frame.bond_lever + frame.width = "
                         f"{lever + width:g} mm or more from the outline; move the members' ends")
    return Crossing(pair, points)


def ring_crossings(outline: Outline, member: Member, lever: float, shift: float) -> tuple[float, float]:
    """Arc lengths (mm) of the two outline points whose bond points (``lever`` mm inside) lie on
    the member's centreline moved ``shift`` mm to its left, the one nearest its start and the one
    nearest its end along it: there that line crosses the outline's bond line (the mesh puts frame
    nodes there, so that their bond nodes lie on it).

    Raises
    ------
    ValueError
        If the line does not cross the bond line within half the member's length of an end.
    """
    d = member.direction
    origin = member.start + shift * np.array([-d[1], d[0]])

    def off_line(s: np.ndarray) -> np.ndarray:  # signed distance of the bond points from the line
        q = outline.inner_offset(np.atleast_1d(s), lever) - origin
        return q[:, 0] * d[1] - q[:, 1] * d[0]

    grid = np.linspace(0.0, outline.length, max(2001, int(outline.length / (0.05 * lever))))
    f = off_line(grid)
    crossings = []
    for k in np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) <= 0):
        lo, hi, f_lo = grid[k], grid[k + 1], f[k]
        for _ in range(60):  # bisection to round-off
            mid = 0.5 * (lo + hi)
            if np.sign(off_line(mid)[0]) == np.sign(f_lo):
                lo = mid
            else:
                hi = mid
        s = 0.5 * (lo + hi)
        crossings.append((float((outline.inner_offset(np.array([s]), lever)[0] - origin) @ d) / member.length, s))
    along = np.array([c[0] for c in crossings])
    out = []
    for end in (0.0, 1.0):
        near = np.flatnonzero(np.abs(along - end) < 0.5) if along.size else along
        if near.size == 0:
            raise ValueError("no crossing")
        out.append(float(np.mod(crossings[near[np.argmin(np.abs(along[near] - end))]][1], outline.length)))
    return out[0], out[1]


def windows(outline: Outline, members: Sequence[Member], width: float) -> list[shapely.Polygon]:
    """The windows: the regions the members cut the outline's inside into (centreline to
    centreline, mm), ordered by their centroid's y, then x."""
    ring = shapely.LinearRing(outline.polyline(min(outline.side_length, width) / 40)[0])
    # each line runs on past the outline, so that it crosses the ring's chords however they lie
    reach = [shapely.LineString([m.start - width * m.direction, m.end + width * m.direction]) for m in members]
    faces = list(polygonize(unary_union([ring, *reach])))
    faces = [f for f in faces if f.area > 0]
    return sorted(faces, key=lambda f: (round(f.centroid.y, 9), round(f.centroid.x, 9)))


def midline_fractions(outline: Outline, members: Sequence[Member]) -> np.ndarray | None:
    """Where each member crosses the frame's midline (the midpoints of its two sides at equal
    fractions of the way from the base midpoint to the apex, ``results.metrics.bending_angle``):
    the fraction of that way, the mean of its two ends' (m,), in the members' order. None unless
    every member runs from one side to the other (windows in a row, base to apex)."""
    if not members or crossings(members, 0.0):
        return None
    L, s_apex = outline.length, outline.apex_arc_length()
    out = []
    for m in members:
        right = [s for s in (m.s_start, m.s_end) if 0.0 < s < s_apex]
        left = [s for s in (m.s_start, m.s_end) if s_apex < s < L]
        if len(right) != 1 or len(left) != 1:
            return None
        out.append(0.5 * (right[0] / s_apex + (L - left[0]) / (L - s_apex)))
    return np.array(out)


def mirror_plan(members: Sequence[Member], tol: float) -> tuple[list[int], list[int], dict[int, int]] | None:
    """How the members of a mirror-symmetric frame mesh on its right half: the members right of
    the axis x = 0, those that cross it square, and each left member's right partner (mirror
    image); None if the members are not mirror-symmetric so (a member on the axis, crossing it
    aslant or touching it, or one without its mirror image) or two of them cross. ``tol``: mm, the
    length below which two coordinates are the same."""
    if crossings(members, 0.0):
        return None
    right, crossing, left = [], [], []
    for k, m in enumerate(members):
        x = np.array([m.start[0], m.end[0]])
        if x.min() > tol:
            right.append(k)
        elif x.max() < -tol:
            left.append(k)
        elif x.min() < -tol and x.max() > tol and abs(m.start[1] - m.end[1]) < tol and abs(x.sum()) < tol:
            crossing.append(k)
        else:
            return None
    partner = {}
    for k in left:
        mirrored = sorted(map(tuple, np.round(np.array([members[k].start, members[k].end]) * [-1.0, 1.0] / tol)))
        match = [j for j in right if sorted(map(tuple, np.round(np.array([members[j].start, members[j].end]) / tol)))
                 == mirrored]
        if not match:
            return None
        partner[k] = match[0]
    if len(partner) != len(right):
        return None
    return right, crossing, partner


def member_joints(frame_nodes: np.ndarray, frame_bonds: np.ndarray, members: Sequence[np.ndarray],
                  member_bonds: Sequence[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """The joints of the members to the outline and to each other, as 3-node rod chains with
    their nodes' bonds.

    At a member's start J the chain is P, J, m (P the frame node before J, m the member's next
    node), at its end J' it is m', J', Q (Q the frame node after J'): each runs with the member
    and with the outline (counter-clockwise), so every edge has its bond on its left. J's bond is
    the member's. Where members i < j cross at their shared node C, the chain is i's node before
    C, C, j's node after it, C's bond i's: with each member's own rod running through C, this
    ties the four strips rigidly. ``frame_bonds`` and ``member_bonds`` are indexed like
    ``frame_nodes`` and ``members``: bond node ids (DR) or bond points (the FEM) alike.

    Returns
    -------
    list of (chain, bonds)
        Node ids (3,) and the bonds of those nodes (3, ...), two per member.
    """
    where = {int(v): k for k, v in enumerate(frame_nodes)}
    n = len(frame_nodes)
    out = []
    for chain, bonds in zip(members, member_bonds):
        k0, k1 = where[int(chain[0])], where[int(chain[-1])]
        out.append((np.array([frame_nodes[(k0 - 1) % n], chain[0], chain[1]]),
                    np.stack([frame_bonds[(k0 - 1) % n], bonds[0], bonds[1]])))
        out.append((np.array([chain[-2], chain[-1], frame_nodes[(k1 + 1) % n]]),
                    np.stack([bonds[-2], bonds[-1], frame_bonds[(k1 + 1) % n]])))
    for i in range(len(members)):
        for j in range(i + 1, len(members)):
            for c in np.intersect1d(members[i][1:-1], members[j][1:-1]):
                a, b = int(np.flatnonzero(members[i] == c)[0]), int(np.flatnonzero(members[j] == c)[0])
                out.append((np.array([members[i][a - 1], c, members[j][b + 1]]),
                            np.stack([member_bonds[i][a - 1], member_bonds[i][a], member_bonds[j][b + 1]])))
    return out
