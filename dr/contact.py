"""Checks that stop a relaxation with a named reason: frame self-contact, membrane folds.

Called with the real node positions, a check returns None or a message. The frame-contact
test also runs inside the compiled time loop (see :func:`dr.integrator.run`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from results.crossing import film_crossing


@njit(cache=True, error_model="numpy")
def _segment_distance(p1, q1, p2, q2):
    """Smallest distance between segments p1-q1 and p2-q2 (clamped closest points)."""
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    a = d1 @ d1
    e = d2 @ d2
    f = d2 @ r
    c = d1 @ r
    b = d1 @ d2
    den = a * e - b * b
    s = 0.0
    if den > 1e-12 * a * e:
        s = min(max((b * f - c * e) / den, 0.0), 1.0)
    t = (b * s + f) / e
    if t < 0.0:
        t = 0.0
        s = min(max(-c / a, 0.0), 1.0)
    elif t > 1.0:
        t = 1.0
        s = min(max((b - c) / a, 0.0), 1.0)
    w = p1 + s * d1 - p2 - t * d2
    return math.sqrt(w @ w)


@njit(cache=True, error_model="numpy")
def closest_segments(x, seg, closed, distance):
    """Closest pair of segments of a chain that may touch (:func:`may_touch`): (distance, a, b)."""
    return closest_pair(x, seg, all_pairs(seg.shape[0], closed), closed, distance)


@njit(cache=True, error_model="numpy")
def arc_starts(x, seg):
    """(k + 1,) mm: the chain's arc length at the start of each of its k segments, then its length."""
    start = np.zeros(seg.shape[0] + 1)
    for a in range(seg.shape[0]):
        d = x[seg[a, 1]] - x[seg[a, 0]]
        start[a + 1] = start[a] + math.sqrt(d @ d)
    return start


@njit(cache=True, error_model="numpy")
def may_touch(x, seg, start, a, b, closed, distance):
    """Whether segments a < b of a chain (``start``: :func:`arc_starts`) can touch at
    ``distance`` mm rather than being the rod's own chord: not neighbours, and either at least
    pi/2 ``distance`` of chain between them (either way round a closed one: closer, the
    centreline must turn back through more than a half circle of that diameter to bring them
    within it) or facing each other (their directions more than 90 deg apart: the chain
    folded back between them). Without the arc-length rule a segment shorter than the contact
    distance, where two landmarks of an outline lie close, touches its neighbours' neighbours
    on a straight frame."""
    if b < a + 2 or (closed and a == 0 and b == seg.shape[0] - 1):
        return False
    between = start[b] - start[a + 1]
    if closed:
        between = min(between, start[-1] - (start[b + 1] - start[a]))
    if between >= 0.5 * math.pi * distance:
        return True
    ta = x[seg[a, 1]] - x[seg[a, 0]]
    tb = x[seg[b, 1]] - x[seg[b, 0]]
    return ta @ tb < 0.0


@njit(cache=True, error_model="numpy")
def all_pairs(k, closed):
    """Index pairs (a, b) of non-neighbouring segments of a chain of k segments."""
    out = np.empty((k * k // 2 + 1, 2), dtype=np.int64)
    m = 0
    for a in range(k):
        for b in range(a + 2, k):
            if not (closed and a == 0 and b == k - 1):
                out[m, 0], out[m, 1] = a, b
                m += 1
    return out[:m]


@njit(cache=True, error_model="numpy")
def closest_pair(x, seg, pairs, closed, distance):
    """Closest of the given segment pairs that may touch at ``distance`` (:func:`may_touch`): (distance, a, b)."""
    start = arc_starts(x, seg)
    best, ba, bb = np.inf, -1, -1
    for p in range(pairs.shape[0]):
        a, b = pairs[p, 0], pairs[p, 1]
        if not may_touch(x, seg, start, a, b, closed, distance):
            continue
        d = _segment_distance(x[seg[a, 0]], x[seg[a, 1]], x[seg[b, 0]], x[seg[b, 1]])
        if d < best:
            best, ba, bb = d, a, b
    return best, ba, bb


@njit(cache=True, error_model="numpy")
def pairs_within(x, seg, closed, reach):
    """Non-neighbouring segment pairs closer than ``reach``: the candidates of a Verlet list
    (which of them may touch is decided when they are checked, :func:`closest_pair`).

    A cheap sphere test (midpoint distance minus half lengths) skips most pairs."""
    k = seg.shape[0]
    mid = np.empty((k, 3))
    half = np.empty(k)
    for a in range(k):
        mid[a] = 0.5 * (x[seg[a, 0]] + x[seg[a, 1]])
        d = x[seg[a, 1]] - x[seg[a, 0]]
        half[a] = 0.5 * math.sqrt(d @ d)
    out = np.empty((k * k // 2 + 1, 2), dtype=np.int64)
    m = 0
    for a in range(k):
        for b in range(a + 2, k):
            if closed and a == 0 and b == k - 1:
                continue
            dm = mid[a] - mid[b]
            if math.sqrt(dm @ dm) - half[a] - half[b] > reach:
                continue
            if _segment_distance(x[seg[a, 0]], x[seg[a, 1]], x[seg[b, 0]], x[seg[b, 1]]) < reach:
                out[m, 0], out[m, 1] = a, b
                m += 1
    return out[:m]


@njit(cache=True, error_model="numpy")
def most_folded(x, tri, pairs):
    """Smallest cosine between normals of adjacent triangles, and that pair's index."""
    worst, where = 2.0, -1
    for k in range(pairs.shape[0]):
        t1, t2 = tri[pairs[k, 0]], tri[pairs[k, 1]]
        n1 = np.cross(x[t1[1]] - x[t1[0]], x[t1[2]] - x[t1[0]])
        n2 = np.cross(x[t2[1]] - x[t2[0]], x[t2[2]] - x[t2[0]])
        l1, l2 = math.sqrt(n1 @ n1), math.sqrt(n2 @ n2)
        c = (n1 @ n2) / (l1 * l2) if l1 > 0.0 and l2 > 0.0 else -1.0
        if c < worst:
            worst, where = c, k
    return worst, where


@njit(cache=True, error_model="numpy")
def most_shrunk(x, edges, rest):
    """Smallest ratio of an edge's length to its reference length, and that edge."""
    worst, where = np.inf, -1
    for k in range(edges.shape[0]):
        d = x[edges[k, 1]] - x[edges[k, 0]]
        r = math.sqrt(d @ d) / rest[k]
        if r < worst:
            worst, where = r, k
    return worst, where


class FrameContact:
    """Stops when two frame segments that may touch (:func:`may_touch`) come closer than ``distance`` mm.

    Parameters
    ----------
    chain
        Frame node indices in order; ``closed`` joins the last to the first.
    distance
        Contact distance (the strip thickness: two strip faces touch), mm.
    """

    def __init__(self, chain: np.ndarray, distance: float, closed: bool = True) -> None:
        c = np.asarray(chain, dtype=np.int64)
        nxt = np.roll(c, -1) if closed else c[1:]
        self.segments = np.stack([c[: nxt.size], nxt], axis=1)
        self.nodes = c
        self.closed = closed
        self.distance = float(distance)

    def __call__(self, x: np.ndarray) -> str | None:
        d, a, b = closest_segments(x, self.segments, self.closed, self.distance)
        if d >= self.distance:
            return None
        i, j = self.segments[a, 0], self.segments[b, 0]
        return (
            f"frame self-contact: segments at nodes {i} and {j} are {d:.3g} mm apart "
            f"(contact at {self.distance:.3g} mm), near ({x[i, 0]:.1f}, {x[i, 1]:.1f}, {x[i, 2]:.1f}) mm"
        )


class MembraneFold:
    """Flags a membrane that has folded over (adjacent triangles facing opposite ways) or whose
    nodes have met (a triangle edge shrunk below ``meet_ratio`` of its reference length).

    ``triangles`` must be consistently oriented over the reference positions ``x0``;
    ``cos_limit`` is the cosine between adjacent normals below which the surface counts as
    folded (-0.5: more than 120 deg between them).
    """

    def __init__(self, triangles: np.ndarray, x0: np.ndarray, cos_limit: float = -0.5,
                 meet_ratio: float = 0.01) -> None:
        tri = np.asarray(triangles, dtype=np.int64)
        edges: dict[tuple[int, int], int] = {}
        pairs = []
        for t, (a, b, c) in enumerate(tri):
            for e in ((a, b), (b, c), (c, a)):
                key = (min(e), max(e))
                if key in edges:
                    pairs.append((edges[key], t))
                else:
                    edges[key] = t
        self.triangles = tri
        self.pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self.edges = np.array(sorted(edges), dtype=np.int64).reshape(-1, 2)
        self.rest = np.linalg.norm(x0[self.edges[:, 1]] - x0[self.edges[:, 0]], axis=1)
        self.cos_limit = cos_limit
        self.meet_ratio = meet_ratio

    def __call__(self, x: np.ndarray) -> str | None:
        ratio, e = most_shrunk(x, self.edges, self.rest)
        if ratio < self.meet_ratio:
            i, j = self.edges[e]
            p = x[i]
            return (f"membrane nodes met: nodes {i} and {j} are {ratio * self.rest[e]:.2g} mm apart "
                    f"(flat: {self.rest[e]:.3g} mm) near ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm")
        c, k = most_folded(x, self.triangles, self.pairs)
        if c >= self.cos_limit:
            return None
        p = x[self.triangles[self.pairs[k, 0]]].mean(axis=0)
        return (f"membrane folded over: adjacent triangles at {np.degrees(np.arccos(max(c, -1.0))):.0f} deg "
                f"near ({p[0]:.1f}, {p[1]:.1f}, {p[2]:.1f}) mm")


class FilmCrossing:
    """Flags a film that passes through itself, or a frame that passes through the film
    (:func:`results.crossing.film_crossing`); relax gives such a state status 'film_contact'.

    ``triangles`` are the film's (t, 3) node triplets, ``frame`` the frame's node chain
    (``closed``: the last joins the first).
    """

    status = "film_contact"

    def __init__(self, triangles: np.ndarray, frame: np.ndarray, closed: bool = True) -> None:
        self.triangles = np.asarray(triangles, dtype=np.int64)
        c = np.asarray(frame, dtype=np.int64)
        nxt = np.roll(c, -1) if closed else c[1:]
        self.segments = np.stack([c[: nxt.size], nxt], axis=1)

    def __call__(self, x: np.ndarray) -> str | None:
        found = film_crossing(x, self.triangles, self.segments)
        return None if found is None else found.describe()
