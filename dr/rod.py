"""DR frame element: the FEM reference's discrete rod with edge frames from bond points.

The formulation is the FEM's (``docs/discrete-problem.md``), written here as compiled energy and
hand-derived gradient so both solvers minimise the same discrete frame energy. Every edge
(x0, x1) carries an orthonormal frame (t, d2, n): t along the edge, d2 across the strip towards
the film, n = t x d2. The across direction comes from the edge's *bond point* p, the midpoint
of the two bond nodes of its ends (film nodes ``frame.bond_lever`` inside the centreline):
d2 = unit(q - (q.t) t), q = p - (x0 + x1)/2. Held edges (both ends supported) keep their flat
frame. Per vertex between edges a and b, with Q = R_a^T R_b, the curvature-twist vector
kappa = 2 axial(Q - Q^T) / (1 + tr Q) and

* ``STRIP``: E = (GJ dk_t^2 + EI dk_d2^2 + EI_s dk_n^2) / (2 l_v), dk = kappa - kappa_0;
* ``PAPER`` (isotropic, no material frame): kb = 2 t_a x t_b / (1 + t_a . t_b),
  E = EI (|kb| - |kb_0|)^2 / (2 l_v);

l_v the Voronoi length (free edges only). A vertex stencil has seven rows: prev, node, next and
the two bond nodes of each edge (-1 where not needed).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Sequence

import numpy as np
from numba import njit

from .blocks import add_rotated, frame_blocks, gershgorin
from .checks import positive
from .errors import DRError
from .vec import add, add_to, axpy, cross, dot, get, norm, scale, sub, unit_vjp

STRIP, PAPER = 0, 1
# columns of Packed.rod_par: weight 1/(2 l_v), stiffnesses, rest kappa, model, held flags, then
# the rest frames (t, d2, n) of edges a and b
W, GJ, EIW, EIS, K0, MODEL, HELD_A, HELD_B, FRAME_A, FRAME_B = 0, 1, 2, 3, 4, 7, 8, 9, 10, 19
N_PAR = 28
ROWS = 7


class Fields(NamedTuple):
    """The rods' arrays in :class:`dr.kernels.Packed`."""

    rod_idx: np.ndarray  # (r, 7) rod vertex stencils, see rod_rows
    rod_par: np.ndarray  # (r, N_PAR)
    rod_blocks: np.ndarray  # (r, 7, 6) scratch: mass blocks in the vertex's material frame


@dataclass
class Rod:
    """A rod as :meth:`dr.Model.add_rod` was given it (bond None: the isotropic rod)."""

    chain: np.ndarray
    bond: np.ndarray | None
    EI: float
    EI_strong: float | None
    GJ: float | None
    closed: bool


class Methods:
    """The :class:`dr.Model` method that adds rods."""

    def add_rod(self, chain: Sequence[int], *, EA: float, EI: float, EI_strong: float | None = None,
                GJ: float | None = None, bond: Sequence[int] | None = None, closed: bool = False) -> None:
        """Add the discrete rod with bond points (:mod:`dr.rod`, the FEM reference's frame).

        With ``EI_strong`` and ``GJ`` it is the strip (weak-axis EI, strong-axis, torsion; its
        plane set by ``bond``, one bond node per chain node); otherwise the isotropic rod.
        Edges whose two ends are supported on all axes keep their flat frame. ``EA`` adds an
        axial link per edge (role 'frame'); ``EA = 0`` adds none (a joint between rods whose
        edges have their links already). Units: N mm^2, N.
        """
        c = self.node_indices("rod chain", chain)
        if c.size < 3:
            raise DRError("a rod chain needs at least 3 nodes")
        b = None
        if EI_strong is not None:
            if GJ is None or bond is None:
                raise DRError("a strip rod (EI_strong given) also needs GJ and bond nodes")
            b = self.node_indices("rod bond", bond)
            if b.size != c.size:
                raise DRError(f"rod bond needs one node per chain node ({c.size}), got {b.size}")
            positive("rod EI_strong (N mm^2)", EI_strong)
            positive("rod GJ (N mm^2)", GJ)
        self.stored[Fields].append(Rod(c, b, positive("rod EI (N mm^2)", EI), EI_strong, GJ, bool(closed)))
        n_edges = c.size if closed else c.size - 1
        if EA != 0:
            self.add_link(c[:n_edges], np.roll(c, -1)[:n_edges], positive("rod EA (N)", EA), role="frame")


def pack(model, rest) -> Fields:
    """The rods of ``model`` (:meth:`dr.Model.add_rod`) with their rest frames and curvatures
    from the reference nodes; ``rest`` is unused."""
    if not model.stored[Fields]:
        return Fields(np.zeros((0, ROWS), np.int64), np.zeros((0, N_PAR)), np.zeros((0, ROWS, 6)))
    held = model.fixed.all(axis=1)
    X = model.nodes
    idx_all, par_all = [], []
    for rod in model.stored[Fields]:
        c, m = rod.chain, rod.chain.size
        n_edges = m if rod.closed else m - 1
        ends = np.column_stack([c[:n_edges], np.roll(c, -1)[:n_edges]])
        edge_held = held[ends[:, 0]] & held[ends[:, 1]]
        length = np.linalg.norm(X[ends[:, 1]] - X[ends[:, 0]], axis=1)
        t0 = (X[ends[:, 1]] - X[ends[:, 0]]) / length[:, None]
        n0 = np.tile([0.0, 0.0, 1.0], (n_edges, 1))
        frames = np.concatenate([t0, np.cross(n0, t0), n0], axis=1)  # (E, 9): t, d2, n
        k = np.arange(m) if rod.closed else np.arange(1, m - 1)
        a, b = (k - 1) % n_edges, k % n_edges
        keep = ~(edge_held[a] & edge_held[b])
        a, b = a[keep], b[keep]
        rows = rod_rows(c, rod.bond, rod.closed)[keep]
        w = np.where(edge_held, 0.0, length)
        par = np.zeros((rows.shape[0], N_PAR))
        par[:, W] = 1.0 / (w[a] + w[b])  # 1 / (2 l_v)
        par[:, EIW] = rod.EI
        strip = rod.EI_strong is not None
        par[:, MODEL] = STRIP if strip else PAPER
        if strip:
            par[:, EIS], par[:, GJ] = rod.EI_strong, rod.GJ
        par[:, HELD_A], par[:, HELD_B] = edge_held[a], edge_held[b]
        par[:, FRAME_A:FRAME_A + 9] = frames[a]
        par[:, FRAME_B:FRAME_B + 9] = frames[b]
        xl = np.zeros((ROWS, 3))
        for r in range(rows.shape[0]):  # rest curvature of the flat state
            gather(X, rows[r], xl)
            par[r, K0:K0 + 3] = rod_local(xl, par[r], xl, False)[3]
        idx_all.append(rows)
        par_all.append(par)
    idx = np.vstack(idx_all)
    return Fields(idx, np.vstack(par_all), np.zeros((idx.shape[0], ROWS, 6)))


def forces(X: np.ndarray, P, moment: np.ndarray) -> dict[str, np.ndarray]:
    """Nothing: the rods report no forces (``moment`` is left alone)."""
    return {}


def stencils(P) -> np.ndarray:
    """The rows of X each rod vertex's energy depends on (r, 7; -1: none): its stencil."""
    return P.rod_idx


def edges(P) -> np.ndarray:
    """None: a rod's edges are its frame links (add_rod's EA), which the drift scale of dr.relax takes."""
    return np.zeros((0, 2), np.int64)


@njit(cache=True, error_model="numpy")
def edge_frame(xl, r0, r1, rb0, with_d2):
    """Frame (t, d2, n) of the edge from row r0 to r1 with bond rows rb0, rb0 + 1."""
    x0, x1 = get(xl, r0), get(xl, r1)
    e = sub(x1, x0)
    le = norm(e)
    t = scale(e, 1.0 / le)
    if not with_d2:
        return t, t, t, le, t, 0.0, 0.0
    p = scale(add(get(xl, rb0), get(xl, rb0 + 1)), 0.5)
    q = sub(p, scale(add(x0, x1), 0.5))
    qt = dot(q, t)
    r = axpy(-qt, t, q)
    lr = norm(r)
    d2 = scale(r, 1.0 / lr)
    return t, d2, cross(t, d2), le, q, qt, lr


@njit(cache=True, error_model="numpy")
def _edge_vjp(xl, r0, r1, rb0, with_d2, geo, g_t, g_d2, g_n, gl):
    """Pull gradients on (t, d2, n) of an edge back onto the local rows gl."""
    t, d2, n, le, q, qt, lr = geo
    if with_d2:
        g_t = add(g_t, cross(d2, g_n))
        g_d2 = add(g_d2, cross(g_n, t))
        g_r = unit_vjp(d2, lr, g_d2)
        g_q = axpy(-dot(t, g_r), t, g_r)
        g_t = add(g_t, add(scale(q, -dot(t, g_r)), scale(g_r, -qt)))
        add_to(gl, rb0, g_q, 0.5)
        add_to(gl, rb0 + 1, g_q, 0.5)
        add_to(gl, r0, g_q, -0.5)
        add_to(gl, r1, g_q, -0.5)
    g_e = unit_vjp(t, le, g_t)
    add_to(gl, r1, g_e, 1.0)
    add_to(gl, r0, g_e, -1.0)


@njit(cache=True, error_model="numpy", inline="always")
def _rest(par, col):
    return ((par[col], par[col + 1], par[col + 2]), (par[col + 3], par[col + 4], par[col + 5]),
            (par[col + 6], par[col + 7], par[col + 8]))


@njit(cache=True, error_model="numpy", inline="always")
def _combine(w, R):
    """w_0 R_0 + w_1 R_1 + w_2 R_2."""
    return axpy(w[0], R[0], axpy(w[1], R[1], scale(R[2], w[2])))


@njit(cache=True, error_model="numpy")
def rod_local(xl, par, gl, want_grad):
    """Bending and torsion energy (N mm) of one vertex from its local rows xl (7, 3); with
    ``want_grad`` the gradient is added to gl (7, 3). Also returns the vertex's material frame
    (t, d2, n) and its curvature vector (strip: (k_t, k_d2, k_n); paper: kb)."""
    strip = par[MODEL] == STRIP
    held_a, held_b = par[HELD_A] > 0.0, par[HELD_B] > 0.0
    ga = edge_frame(xl, 0, 1, 3, strip)
    gb = edge_frame(xl, 1, 2, 5, strip)
    Ra = _rest(par, FRAME_A) if held_a else (ga[0], ga[1], ga[2])
    Rb = _rest(par, FRAME_B) if held_b else (gb[0], gb[1], gb[2])
    frame = Rb if held_a else Ra
    z = (0.0, 0.0, 0.0)
    if not strip:
        ta, tb = Ra[0], Rb[0]
        c = cross(ta, tb)
        den = 1.0 + dot(ta, tb)
        kb = scale(c, 2.0 / den)
        lk = norm(kb)
        k0 = norm((par[K0], par[K0 + 1], par[K0 + 2]))
        dk = lk - k0
        e_bend = par[W] * par[EIW] * dk * dk
        if want_grad:
            # 2 W EI (kb - k0 kb/|kb|): smooth where the rest state is straight (k0 = 0)
            g_kb = scale(kb, 2.0 * par[W] * par[EIW] * (1.0 - k0 / lk if k0 > 0.0 else 1.0))
            g_c = scale(g_kb, 2.0 / den)
            g_den = -dot(g_kb, kb) / den
            if not held_a:
                _edge_vjp(xl, 0, 1, 3, False, ga, axpy(g_den, tb, cross(tb, g_c)), z, z, gl)
            if not held_b:
                _edge_vjp(xl, 1, 2, 5, False, gb, axpy(g_den, ta, cross(g_c, ta)), z, z, gl)
        return e_bend, 0.0, frame, kb
    Q = ((dot(Ra[0], Rb[0]), dot(Ra[0], Rb[1]), dot(Ra[0], Rb[2])),
         (dot(Ra[1], Rb[0]), dot(Ra[1], Rb[1]), dot(Ra[1], Rb[2])),
         (dot(Ra[2], Rb[0]), dot(Ra[2], Rb[1]), dot(Ra[2], Rb[2])))
    den = 1.0 + Q[0][0] + Q[1][1] + Q[2][2]
    kap = (2.0 * (Q[2][1] - Q[1][2]) / den, 2.0 * (Q[0][2] - Q[2][0]) / den,
           2.0 * (Q[1][0] - Q[0][1]) / den)
    d0, d1, d2 = kap[0] - par[K0], kap[1] - par[K0 + 1], kap[2] - par[K0 + 2]
    e_twist = par[W] * par[GJ] * d0 * d0
    e_bend = par[W] * (par[EIW] * d1 * d1 + par[EIS] * d2 * d2)
    if want_grad:
        gk = (2.0 * par[W] * par[GJ] * d0, 2.0 * par[W] * par[EIW] * d1, 2.0 * par[W] * par[EIS] * d2)
        gw = scale(gk, 2.0 / den)
        gd = -dot(gk, kap) / den
        gQ = ((gd, -gw[2], gw[1]), (gw[2], gd, -gw[0]), (-gw[1], gw[0], gd))
        if not held_a:  # dE/dRa_j = sum_k gQ_jk Rb_k
            _edge_vjp(xl, 0, 1, 3, True, ga, _combine(gQ[0], Rb), _combine(gQ[1], Rb),
                      _combine(gQ[2], Rb), gl)
        if not held_b:  # dE/dRb_k = sum_j gQ_jk Ra_j
            _edge_vjp(xl, 1, 2, 5, True, gb, _combine((gQ[0][0], gQ[1][0], gQ[2][0]), Ra),
                      _combine((gQ[0][1], gQ[1][1], gQ[2][1]), Ra),
                      _combine((gQ[0][2], gQ[1][2], gQ[2][2]), Ra), gl)
    return e_bend, e_twist, frame, kap


@njit(cache=True, error_model="numpy")
def gather(X, idx, xl):
    """Local rows (7, 3) of a vertex stencil; unused rows are zero."""
    for r in range(ROWS):
        k = idx[r]
        for c in range(3):
            xl[r, c] = X[k, c] if k >= 0 else 0.0


@njit(cache=True, error_model="numpy")
def rod_hessian(xl, idx, par, H):
    """Hessian (21, 21) of one vertex term by central differences of its exact gradient."""
    _differences(xl, idx, par, H, True)


@njit(cache=True, error_model="numpy")
def rod_hessian_forward(xl, idx, par, H):
    """The Hessian by forward differences: half the gradient calls, first-order accurate (for
    a mass bound, whose safety factor covers that)."""
    _differences(xl, idx, par, H, False)


@njit(cache=True, error_model="numpy")
def _differences(xl, idx, par, H, central):
    gp = np.zeros((ROWS, 3))
    gm = np.zeros((ROWS, 3))
    h = 1e-6 * norm(sub(get(xl, 2), get(xl, 0)))
    H[:] = 0.0
    if not central:
        rod_local(xl, par, gm, True)
    for r in range(ROWS):
        if idx[r] < 0:
            continue
        for c in range(3):
            x0 = xl[r, c]
            gp[:] = 0.0
            xl[r, c] = x0 + h
            rod_local(xl, par, gp, True)
            if central:
                gm[:] = 0.0
                xl[r, c] = x0 - h
                rod_local(xl, par, gm, True)
            xl[r, c] = x0
            step = 2.0 * h if central else h
            for rr in range(ROWS):
                for cc in range(3):
                    H[3 * rr + cc, 3 * r + c] = (gp[rr, cc] - gm[rr, cc]) / step


@njit(cache=True, error_model="numpy", inline="always")
def gradient(X, P, G, D):
    """Add all rod vertices' energy gradient to G and, if D has rows, the strip rod's mass
    blocks turned with each vertex's material frame. Returns the largest nodal force, N."""
    xl = np.zeros((ROWS, 3))
    gl = np.zeros((ROWS, 3))
    fmax = 0.0
    for k in range(P.rod_idx.shape[0]):
        idx = P.rod_idx[k]
        gather(X, idx, xl)
        gl[:] = 0.0
        _, _, frame, _ = rod_local(xl, P.rod_par[k], gl, True)
        # no blocks (rod_blocks without rows): the rod's stiffness is in the frame mass
        turn = D.shape[0] > 0 and P.rod_blocks.shape[0] > 0 and P.rod_par[k, MODEL] == STRIP
        for r in range(ROWS):
            if idx[r] >= 0:
                add_to(G, idx[r], get(gl, r), 1.0)
                if turn:
                    add_rotated(D, idx[r], P.rod_blocks[k, r], frame)
        for r in range(3):
            fmax = max(fmax, norm(get(gl, r)))
    return fmax


@njit(cache=True, error_model="numpy")
def strain_energy(X, P):
    """Strain energy (membrane, frame bending, frame torsion, frame axial) of all rod vertices,
    N mm: bending and torsion."""
    xl = np.zeros((ROWS, 3))
    e_bend = e_twist = 0.0
    for k in range(P.rod_idx.shape[0]):
        gather(X, P.rod_idx[k], xl)
        eb, et, _, _ = rod_local(xl, P.rod_par[k], xl, False)
        e_bend += eb
        e_twist += et
    return 0.0, e_bend, e_twist, 0.0


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Gershgorin row sums of each vertex term's Hessian into S (scalar masses, and the
    isotropic rod always), or else the strip rod's blocks in its material frame into
    P.rod_blocks for :func:`gradient` to turn; nothing where the frame mass carries the rod
    (P.rod_blocks without rows, :mod:`dr.frame_mass`)."""
    if P.rod_blocks.shape[0] == 0 and not with_links:
        return
    xl = np.zeros((ROWS, 3))
    H = np.zeros((3 * ROWS, 3 * ROWS))
    for k in range(P.rod_idx.shape[0]):
        idx = P.rod_idx[k]
        gather(X, idx, xl)
        rod_hessian(xl, idx, P.rod_par[k], H)
        if with_links or P.rod_par[k, MODEL] == PAPER:
            gershgorin(H, idx, S)
        else:
            _, _, frame, _ = rod_local(xl, P.rod_par[k], xl, False)
            frame_blocks(H, idx >= 0, frame, P.rod_blocks[k])


def rod_rows(chain: np.ndarray, bond: np.ndarray | None, closed: bool) -> np.ndarray:
    """Vertex stencils (k, 7) of a chain: prev, node, next and the bond nodes of both edges.

    ``bond`` (m,) is each chain node's bond node (None: the isotropic rod needs none); the bond
    point of edge (k, k+1) is the midpoint of bond[k] and bond[k+1].
    """
    m = chain.size
    k = np.arange(m) if closed else np.arange(1, m - 1)
    rows = np.full((k.size, ROWS), -1, dtype=np.int64)
    rows[:, 0], rows[:, 1], rows[:, 2] = chain[(k - 1) % m], chain[k], chain[(k + 1) % m]
    if bond is not None:
        rows[:, 3], rows[:, 4] = bond[(k - 1) % m], bond[k]
        rows[:, 5], rows[:, 6] = bond[k], bond[(k + 1) % m]
    return rows
