"""Frame outline geometry: a closed polygon with filleted (rounded) corners.

The outline is the frame centreline in the flat reference state, in the plane z = 0, in a
canonical frame: the base side (the polygon's first side) lies on the x axis with its midpoint at
the origin and the interior at y > 0. Arc length s (mm) starts at the base midpoint and runs
counter-clockwise, so the base's right-hand corner comes first.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .errors import SceneError


@dataclass(frozen=True)
class _Piece:
    """A straight segment (radius 0) or a circular arc of the outline."""

    s_start: float  # mm
    length: float  # mm
    start: np.ndarray  # (2,) mm
    direction: np.ndarray  # (2,) unit tangent at start
    turn: float = 0.0  # rad, signed turning angle over the piece (arcs only; + is left)
    centre: np.ndarray | None = None  # (2,) mm, arcs only
    radius: float = 0.0  # mm, arcs only

    def at(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points (m, 2) and unit tangents (m, 2) at local arc lengths u (m,)."""
        u = np.asarray(u, dtype=float)
        if self.radius == 0.0:
            return self.start + u[:, None] * self.direction, np.tile(self.direction, (u.size, 1))
        angle = np.sign(self.turn) * u / self.radius
        c, s = np.cos(angle), np.sin(angle)
        d = self.direction
        tangent = np.stack([c * d[0] - s * d[1], s * d[0] + c * d[1]], axis=1)
        radial = self.start - self.centre
        points = self.centre + np.stack(
            [c * radial[0] - s * radial[1], s * radial[0] + c * radial[1]], axis=1
        )
        return points, tangent


def _canonical_vertices(vertices: np.ndarray) -> np.ndarray:
    """Rotate and translate so side 0 runs along +x centred on the origin, interior above."""
    v = np.asarray(vertices, dtype=float)
    area2 = np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    if area2 < 0:  # clockwise: reverse but keep side 0 (v0 -> v1) as the base
        v = np.concatenate([v[1::-1], v[:1:-1]])
    d = v[1] - v[0]
    angle = np.arctan2(d[1], d[0])
    rot = np.array([[np.cos(-angle), -np.sin(-angle)], [np.sin(-angle), np.cos(-angle)]])
    v = (v - 0.5 * (v[0] + v[1])) @ rot.T
    return v


@dataclass(frozen=True)
class Outline:
    """Closed frame centreline: polygon ``vertices`` (mm) with fillets of ``corner_radius`` (mm).

    Parameters
    ----------
    vertices
        (k, 2) polygon corners in mm, any orientation; side 0 (vertex 0 -> 1) is the base.
    corner_radius
        Fillet radius at every corner, mm (0 gives sharp corners).
    """

    vertices: np.ndarray
    corner_radius: float
    pieces: list[_Piece] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        v = np.asarray(self.vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 2 or v.shape[0] < 3:
            raise SceneError("frame.vertices must be a list of at least 3 [x, y] points in mm")
        if not np.all(np.isfinite(v)):
            raise SceneError("frame.vertices must be finite numbers (mm)")
        v = _canonical_vertices(v)
        object.__setattr__(self, "vertices", v)
        k = len(v)
        sides = np.roll(v, -1, axis=0) - v
        side_len = np.linalg.norm(sides, axis=1)
        if np.any(side_len <= 1e-9 * side_len.max()):
            raise SceneError("frame.vertices has repeated points: every side needs a length")
        if self._self_intersects(v):
            raise SceneError("frame.vertices do not form a simple closed polygon: sides cross")
        d = sides / side_len[:, None]
        # corner j joins side j-1 (incoming) and side j (outgoing)
        d_in = np.roll(d, 1, axis=0)
        cross = d_in[:, 0] * d[:, 1] - d_in[:, 1] * d[:, 0]
        turn = np.arctan2(cross, np.sum(d_in * d, axis=1))
        if np.any(np.abs(turn) > np.pi - 1e-6):
            raise SceneError("frame.vertices has a corner that folds back on itself (180 deg)")
        r = float(self.corner_radius)
        if not np.isfinite(r) or r < 0:
            raise SceneError(f"frame.corner_radius = {r} mm must be >= 0")
        trim = r * np.tan(np.abs(turn) / 2)  # tangent length of each fillet
        used = trim + np.roll(trim, -1)  # side j loses trim[j] and trim[j+1]
        bad = np.flatnonzero(used > side_len * (1 - 1e-9))
        if bad.size:
            j = bad[0]
            rmax = r * side_len[j] / used[j]
            raise SceneError(
                f"frame.corner_radius = {r} mm is too large: the fillets overlap on side {j} "
                f"({side_len[j]:.3g} mm long); use less than {rmax:.3g} mm"
            )
        pieces: list[_Piece] = []
        s = 0.0
        # start at the base midpoint (origin), run along side 0 to corner 1, then round
        order = list(range(1, k)) + [0]
        start = np.zeros(2)
        for j in order:
            end = v[j] - trim[j] * d_in[j]
            length = float(np.linalg.norm(end - start))
            pieces.append(_Piece(s, length, start, d_in[j].copy()))
            s += length
            if trim[j] > 0:
                normal = np.array([-d_in[j][1], d_in[j][0]]) * np.sign(turn[j])
                arc_len = r * abs(turn[j])
                pieces.append(_Piece(s, arc_len, end, d_in[j].copy(), turn[j], end + r * normal, r))
                s += arc_len
            start = v[j] + trim[j] * d[j]
        # last straight piece back to the base midpoint
        length = float(np.linalg.norm(start))
        pieces.append(_Piece(s, length, start, d[0].copy()))
        object.__setattr__(self, "pieces", pieces)

    @staticmethod
    def _self_intersects(v: np.ndarray) -> bool:
        k = len(v)
        a, b = v, np.roll(v, -1, axis=0)
        for i in range(k):
            for j in range(i + 2, k):
                if i == 0 and j == k - 1:
                    continue
                if _segments_cross(a[i], b[i], a[j], b[j]):
                    return True
        return False

    # ------------------------------------------------------------------ queries
    @property
    def length(self) -> float:
        """Total centreline length, mm."""
        last = self.pieces[-1]
        return last.s_start + last.length

    @property
    def side_length(self) -> float:
        """Length of the base side of the sharp polygon, mm (the normalising length)."""
        return float(np.linalg.norm(self.vertices[1] - self.vertices[0]))

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points (m, 2) and unit tangents (m, 2) at arc lengths s (mm), wrapped to [0, L)."""
        s = np.mod(np.atleast_1d(np.asarray(s, dtype=float)), self.length)
        starts = np.array([p.s_start for p in self.pieces])
        which = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(self.pieces) - 1)
        points = np.empty((s.size, 2))
        tangents = np.empty((s.size, 2))
        for k in np.unique(which):
            sel = which == k
            p, t = self.pieces[k].at(s[sel] - self.pieces[k].s_start)
            points[sel], tangents[sel] = p, t
        return points, tangents

    def inner_offset(self, s: np.ndarray, distance: float) -> np.ndarray:
        """Points (m, 2) ``distance`` mm inside the outline, along the inward normal at arc
        lengths s (mm): the strip's bond line for ``distance = frame.bond_lever``."""
        p, t = self.evaluate(s)
        return p + distance * np.column_stack([-t[:, 1], t[:, 0]])

    def breakpoints(self) -> np.ndarray:
        """Arc lengths (mm) where pieces meet (fillet ends), ascending, 0 included."""
        return np.array([p.s_start for p in self.pieces])

    def polyline(self, spacing: float) -> tuple[np.ndarray, np.ndarray]:
        """Points (m, 2) at most ``spacing`` mm apart along the outline and their arc lengths.

        Piece ends are always included so that fillets start and end on a node.
        """
        s_all = []
        for p in self.pieces:
            n = max(1, int(np.ceil(p.length / spacing - 1e-9)))
            s_all.append(p.s_start + p.length * np.arange(n) / n)
        s = np.concatenate(s_all)
        return self.evaluate(s)[0], s

    def intersect_line(self, point: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Crossings of the infinite line ``point + t * direction`` with the outline.

        Returns line parameters t (mm, sorted) and the outline arc lengths s at the crossings.
        Tangential touches are dropped.
        """
        p0 = np.asarray(point, float)
        d = np.asarray(direction, float)
        d = d / np.linalg.norm(d)
        ts, ss = [], []
        for piece in self.pieces:
            if piece.length == 0:
                continue
            if piece.radius == 0.0:
                e = piece.direction
                den = d[0] * e[1] - d[1] * e[0]
                if abs(den) < 1e-12:
                    continue
                w = piece.start - p0
                t = (w[0] * e[1] - w[1] * e[0]) / den
                u = (w[0] * d[1] - w[1] * d[0]) / den
                if -1e-12 <= u < piece.length - 1e-12:
                    ts.append(t)
                    ss.append(piece.s_start + max(u, 0.0))
            else:
                w = p0 - piece.centre
                b = w @ d
                disc = b * b - (w @ w - piece.radius**2)
                if disc <= 1e-12 * piece.radius**2:
                    continue
                for t in (-b - np.sqrt(disc), -b + np.sqrt(disc)):
                    q = p0 + t * d - piece.centre
                    r0 = piece.start - piece.centre
                    ang = np.arctan2(r0[0] * q[1] - r0[1] * q[0], r0 @ q) * np.sign(piece.turn)
                    ang = np.mod(ang, 2 * np.pi)
                    u = ang * piece.radius
                    if -1e-12 <= u < piece.length - 1e-12:
                        ts.append(t)
                        ss.append(piece.s_start + max(u, 0.0))
        ts, ss = np.array(ts), np.array(ss)
        order = np.argsort(ts)
        ts, ss = ts[order], ss[order]
        # a line through a piece junction is found twice: keep one
        keep = np.ones(ts.size, bool)
        keep[1:] = np.diff(ts) > 1e-9 * self.side_length
        return ts[keep], ss[keep]

    def contains(self, points: np.ndarray, spacing: float | None = None) -> np.ndarray:
        """Whether points (m, 2) lie strictly inside the outline (even-odd rule)."""
        poly = self.polyline(spacing or self.side_length / 400)[0]
        x, y = points[:, 0:1], points[:, 1:2]
        a, b = poly, np.roll(poly, -1, axis=0)
        straddle = (a[:, 1] > y) != (b[:, 1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = a[:, 0] + (y - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
        return np.count_nonzero(straddle & (x < x_cross), axis=1) % 2 == 1

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Exact distance (mm) from points (m, 2) to the outline."""
        return self.project(points)[1]

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The outline's nearest points to points (m, 2): their arc lengths (m,) and distances
        (m,), mm, exact piece by piece."""
        points = np.atleast_2d(np.asarray(points, float))
        best = np.full(points.shape[0], np.inf)
        s_best = np.zeros(points.shape[0])
        for piece in self.pieces:
            if piece.length == 0:
                continue
            if piece.radius == 0.0:
                u = np.clip((points - piece.start) @ piece.direction, 0.0, piece.length)
            else:
                rel = points - piece.centre
                r0 = piece.start - piece.centre
                ang = np.mod(np.arctan2(r0[0] * rel[:, 1] - r0[1] * rel[:, 0], rel @ r0) * np.sign(piece.turn),
                             2 * np.pi)
                # off the arc: the nearer end (the angle past the arc's end, or before its start)
                past = ang > abs(piece.turn)
                nearer_end = np.where(ang - abs(piece.turn) < 2 * np.pi - ang, piece.length, 0.0)
                u = np.where(past, nearer_end, ang * piece.radius)
            d = np.linalg.norm(points - piece.at(u)[0], axis=1)
            closer = d < best
            best[closer], s_best[closer] = d[closer], piece.s_start + u[closer]
        return np.mod(s_best, self.length), best

    # ------------------------------------------------------------ landmarks
    @property
    def base_half_length(self) -> float:
        """Half the length of the base side of the sharp polygon, mm."""
        return 0.5 * self.side_length

    def clamp_arc_lengths(self) -> tuple[float, float]:
        """Arc lengths (mm) where the taped base region ends on the right and left.

        The taped region is the base side together with the fillets of its two corners, so the
        clamps sit where those fillets meet the adjacent sides (at the sharp corners when the
        radius is 0).
        """
        pieces = self.pieces
        # pieces: [base right half, (arc at corner 1), side 1, ..., (arc at corner 0), base left half]
        right = pieces[1] if pieces[1].radius > 0 else pieces[0]
        left = pieces[-2] if pieces[-2].radius > 0 else pieces[-1]
        s_right = right.s_start + right.length
        s_left = left.s_start
        return float(s_right), float(s_left)

    def nearest_to_apex(self, arc_lengths: np.ndarray) -> int:
        """Index of the arc length in ``arc_lengths`` (mm, e.g. a mesh's frame nodes) nearest the
        apex's: the node the solvers read the apex's side from."""
        return int(np.argmin(np.abs(np.asarray(arc_lengths) - self.apex_arc_length())))

    def apex_arc_length(self) -> float:
        """Arc length (mm) of the apex: the outline point farthest from the base line.

        Where a whole stretch is equally far (a side parallel to the base), the point on it
        nearest the base's perpendicular bisector is taken.
        """
        s = np.linspace(0, self.length, 20001)[:-1]
        pts = self.evaluate(s)[0]
        h = pts[:, 1]
        cand = np.flatnonzero(h >= h.max() - 1e-9 * self.side_length)
        best = cand[np.argmin(np.abs(pts[cand, 0]))]
        # refine on a fine local grid
        ds = self.length / 20000
        s_loc = np.linspace(s[best] - ds, s[best] + ds, 2001)
        p_loc = self.evaluate(s_loc)[0]
        score = p_loc[:, 1] - 1e-6 * np.abs(p_loc[:, 0])
        return float(np.mod(s_loc[np.argmax(score)], self.length))

    def height(self) -> float:
        """Height of the apex above the base line, mm."""
        return float(self.evaluate(self.apex_arc_length())[0][0, 1])

    def mid_height_arc_lengths(self) -> tuple[float, float]:
        """Arc lengths (mm) on the right and left branches at half the apex height."""
        s_apex = self.apex_arc_length()
        s_right, s_left = self.clamp_arc_lengths()
        half = 0.5 * self.height()
        out = []
        for a, b in ((s_right, s_apex), (s_apex, s_left)):
            s = np.linspace(a, b, 4001)
            y = self.evaluate(s)[0][:, 1]
            k = np.flatnonzero(np.diff(np.sign(y - half)) != 0)
            if k.size == 0:
                raise SceneError("frame outline has no point at half the apex height on a side")
            k = k[0]
            out.append(float(s[k] + (half - y[k]) * (s[k + 1] - s[k]) / (y[k + 1] - y[k])))
        return out[0], out[1]


def _segments_cross(p1, p2, q1, q2) -> bool:
    def orient(a, b, c):
        return np.sign((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))

    o1, o2 = orient(p1, p2, q1), orient(p1, p2, q2)
    o3, o4 = orient(q1, q2, p1), orient(q1, q2, p2)
    return bool(o1 * o2 < 0 and o3 * o4 < 0)


def equilateral_triangle(side_length: float) -> np.ndarray:
    """Vertices (3, 2) of an equilateral triangle with its base on the x axis, mm."""
    h = side_length * np.sqrt(3) / 2
    return np.array([[-side_length / 2, 0.0], [side_length / 2, 0.0], [0.0, h]])
