"""The frame's own stiffness as its mass: one sparse SPD mass over the frame's nodes.

The frame rod is ~1000 times stiffer in its plane (strong axis) and ~50 times stiffer axially
than out of it, and a node-local mass cannot follow those modes on a curved frame: they move
nodes along and across the frame at once, so the stiff bending mode sets the explicit step
(docs/dynamic_relaxation.md, "Frame mass"). Here the frame nodes (the rod's chain and bond
nodes, fully free ones) share one mass matrix

    M_F = f/2 ( sum_v |H_v| + sum_links |K_l| + blockdiag(D_i + S_i I) ),

|H_v| the absolute value of each rod vertex term's Hessian over its nodes (its duplicate rows
merged), |K_l| the exact stiffness of each frame link with |T|, and D_i, S_i what the other
elements (the film) put on node i, as for the node-local tensor masses. Each term bounds its own
stiffness (H <= |H|), so M_F >= f/2 K on the frame and the leapfrog step is stable for f >= 1
as before; any SPD mass leaves the fixed point R = 0 where it is. The film's nodes keep their
3x3 masses, and the update stays explicit: M_F is factorised (a Cholesky factor in envelope
form, the nodes numbered along a reverse Cuthill-McKee order, so the closed loop's band stays
narrow) when it is refreshed, and each step solves with the factor.

Between refreshes the mass turns with the frame, as the node-local tensor masses do: each node
has the frame (t, d2, n) of an edge next to it, and with R_i the rotation of that frame since
the refresh, M = R M_ref R^T (R block-diagonal), so M^-1 = R M_ref^-1 R^T with the same factor.
A frame whose strong axis has turned by 0.05 rad without this puts 1000 x 0.05^2 = 2.5 times
the weak-axis stiffness on the weak-axis mass: unstable (measured on the 8-division DEMES).

The envelope of row i holds the columns first[i] .. i of the lower triangle; the factor L
overwrites the matrix in place.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import reverse_cuthill_mckee

from .rod import HELD_A, HELD_B, MODEL, ROWS, STRIP, edge_frame, gather, rod_hessian_forward
from .links import tension


class FrameMass(NamedTuple):
    """The pattern and the factor of the frame's mass (see the module docstring)."""

    nodes: np.ndarray  # (f,) model node of each frame-mass node, in elimination order
    pos: np.ndarray  # (n,) frame-mass position of each model node, -1 outside
    first: np.ndarray  # (3f,) first column of each row's envelope
    start: np.ndarray  # (3f + 1,) offsets of the rows in env
    env: np.ndarray  # (nnz,) the matrix, then its Cholesky factor L (M = L L^T)
    rod_local: np.ndarray  # (r, 7) merged index of each stencil row in its term (-1: not in the mass)
    rod_nodes: np.ndarray  # (r, 7) frame-mass position of each merged node (-1: padding)
    link_in: np.ndarray  # (l,) bool: the link's stiffness is in this mass
    edges: np.ndarray  # (f, 4) end nodes and bond nodes of the edge whose frame the node follows
    kind: np.ndarray  # (f,) FIXED (held edge), FULL (frame from bond points), TANGENT (no bond)
    frame_ref: np.ndarray  # (f, 9) the edge frames (t, d2, n) at the refresh
    turn: np.ndarray  # (f, 9) rotation R of each node since the refresh, row-major
    y: np.ndarray  # (3f,) scratch of the solves


def empty(n: int, n_links: int) -> FrameMass:
    """No frame mass: every node keeps its own 3x3 mass."""
    z = np.zeros(0, np.int64)
    return FrameMass(z, np.full(n, -1, np.int64), z, np.zeros(1, np.int64), np.zeros(0), np.zeros((0, ROWS), np.int64),
                     np.zeros((0, ROWS), np.int64), np.zeros(n_links, bool), np.zeros((0, 4), np.int64), z,
                     np.zeros((0, 9)), np.zeros((0, 9)), np.zeros(0))


def frame_mass_pattern(P, fixed: np.ndarray) -> FrameMass | None:
    """The frame mass of a packed model with rods, or None where it cannot be built.

    Its nodes are the rods' stencil nodes that are free on all axes; held nodes drop out (they
    do not move). A stencil node held on some axes only has no local frame mass (the held
    axes would couple into the free ones through the factor): None, and the model keeps
    node-local masses. ``fixed`` (n, 3) bool.
    """
    n = P.n
    if P.rod_idx.shape[0] == 0:
        return None
    rows = P.rod_idx
    used = np.unique(rows[rows >= 0])
    if used.size and (used >= n).any():
        return None  # virtual nodes are pulled back onto real ones; not in this mass
    partial = fixed[used].any(axis=1) & ~fixed[used].all(axis=1)
    if partial.any():
        return None
    members = used[~fixed[used].all(axis=1)]
    if members.size == 0:
        return None
    inside = np.zeros(n, bool)
    inside[members] = True
    held = fixed.all(axis=1)
    i, j = P.link_ij[:, 0], P.link_ij[:, 1]
    link_in = P.link_frame & (inside[i] | inside[j]) & (inside[i] | held[i]) & (inside[j] | held[j])
    # node graph of the terms, ordered by reverse Cuthill-McKee
    local = {int(v): k for k, v in enumerate(members)}
    pairs = []
    for stencil in rows:
        ks = sorted({local[int(v)] for v in stencil if v >= 0 and inside[v]})
        pairs += [(a, b) for a in ks for b in ks]
    for a, b in P.link_ij[link_in]:
        if inside[a] and inside[b]:
            pairs += [(local[int(a)], local[int(b)]), (local[int(b)], local[int(a)])]
    pairs += [(k, k) for k in range(members.size)]
    pr = np.array(pairs)
    graph = coo_matrix((np.ones(len(pr)), (pr[:, 0], pr[:, 1])), shape=(members.size,) * 2).tocsr()
    order = reverse_cuthill_mckee(graph, symmetric_mode=True)
    nodes = members[order]
    pos = np.full(n, -1, np.int64)
    pos[nodes] = np.arange(nodes.size)
    # envelope: the first coupled DOF of each row (the node's first DOF at least)
    first_node = np.arange(nodes.size)
    np.minimum.at(first_node, pos[members[pr[:, 0]]], pos[members[pr[:, 1]]])
    first = np.repeat(3 * first_node, 3)
    start = np.zeros(3 * nodes.size + 1, np.int64)
    start[1:] = np.cumsum(np.arange(3 * nodes.size) - first + 1)
    # each stencil's rows merged onto its distinct frame-mass nodes
    rod_local = np.full(rows.shape, -1, np.int64)
    rod_nodes = np.full(rows.shape, -1, np.int64)
    for k, stencil in enumerate(rows):
        distinct: list[int] = []
        for r, v in enumerate(stencil):
            if v >= 0 and inside[v]:
                if pos[v] not in distinct:
                    distinct.append(int(pos[v]))
                rod_local[k, r] = distinct.index(int(pos[v]))
        rod_nodes[k, :len(distinct)] = distinct
    edges, kind = _node_edges(P, pos, nodes.size)
    turn = np.tile(np.eye(3).ravel(), (nodes.size, 1))
    return FrameMass(nodes.astype(np.int64), pos, first.astype(np.int64), start, np.zeros(start[-1]), rod_local,
                     rod_nodes, link_in, edges, kind, np.zeros((nodes.size, 9)), turn, np.zeros(3 * nodes.size))


FIXED, FULL, TANGENT = 0, 1, 2


def _node_edges(P, pos: np.ndarray, f: int) -> tuple[np.ndarray, np.ndarray]:
    """The edge each frame-mass node turns with: a vertex's node and bond rows its outgoing edge
    (the incoming one where that is held), the neighbours' rows the edge they share with it."""
    edges = np.full((f, 4), -1, np.int64)
    kind = np.zeros(f, np.int64)
    ranked = np.full(f, -1)
    for stencil, par in zip(P.rod_idx, P.rod_par):
        strip = par[MODEL] == STRIP
        a = (stencil[0], stencil[1], stencil[3], stencil[4], par[HELD_A] > 0)
        b = (stencil[1], stencil[2], stencil[5], stencil[6], par[HELD_B] > 0)
        centre = b if not b[4] else a
        for rows, edge, rank in (((0, 3), a, 0), ((2, 6), b, 0), ((1, 4, 5), centre, 1)):
            for r in rows:
                v = stencil[r]
                if v < 0 or pos[v] < 0 or ranked[pos[v]] > rank:
                    continue
                ranked[pos[v]] = rank
                edges[pos[v]] = edge[:4]
                kind[pos[v]] = FIXED if edge[4] else (FULL if strip else TANGENT)
    return edges, kind


@njit(cache=True, error_model="numpy")
def _frame(X, fm, a, xl):
    """Edge frame (t, d2, n) of node a's edge, flattened (9,); d2, n unused for TANGENT.
    xl: (4, 3) scratch."""
    e = fm.edges[a]
    for r in range(4):
        if e[r] >= 0:
            xl[r, 0], xl[r, 1], xl[r, 2] = X[e[r], 0], X[e[r], 1], X[e[r], 2]
    t, d2, nn, _, _, _, _ = edge_frame(xl, 0, 1, 2, fm.kind[a] == FULL)
    return (t[0], t[1], t[2], d2[0], d2[1], d2[2], nn[0], nn[1], nn[2])


@njit(cache=True, error_model="numpy")
def follow(X, fm):
    """Rotations of the nodes' edge frames since the refresh (fm.turn). Returns the largest
    entry of R - I over the nodes (about the largest turn, rad)."""
    xl = np.zeros((4, 3))
    turned = 0.0
    for a in range(fm.nodes.shape[0]):
        k = fm.kind[a]
        if k == FIXED:
            continue
        f = _frame(X, fm, a, xl)
        g = fm.frame_ref[a]
        R = fm.turn[a]
        if k == FULL:  # R = Q Q_ref^T, Q = [t d2 n] by columns
            for r in range(3):
                for c in range(3):
                    R[3 * r + c] = f[r] * g[c] + f[3 + r] * g[3 + c] + f[6 + r] * g[6 + c]
        else:  # the smallest rotation taking the reference tangent to the current one
            v = (g[1] * f[2] - g[2] * f[1], g[2] * f[0] - g[0] * f[2], g[0] * f[1] - g[1] * f[0])
            cth = g[0] * f[0] + g[1] * f[1] + g[2] * f[2]
            w = 1.0 / (1.0 + cth)
            K = ((0.0, -v[2], v[1]), (v[2], 0.0, -v[0]), (-v[1], v[0], 0.0))
            for r in range(3):
                for c in range(3):
                    kk = K[r][0] * K[0][c] + K[r][1] * K[1][c] + K[r][2] * K[2][c]
                    R[3 * r + c] = (1.0 if r == c else 0.0) + K[r][c] + w * kk
        for r in range(9):
            turned = max(turned, abs(R[r] - (1.0 if r % 4 == 0 else 0.0)))
    return turned


@njit(cache=True, error_model="numpy")
def _restart_frames(X, fm):
    """The current edge frames become the reference; no rotation."""
    xl = np.zeros((4, 3))
    for a in range(fm.nodes.shape[0]):
        R = fm.turn[a]
        for r in range(9):
            R[r] = 1.0 if r % 4 == 0 else 0.0
        if fm.kind[a] != FIXED:
            f = _frame(X, fm, a, xl)
            for r in range(9):
                fm.frame_ref[a, r] = f[r]


@njit(cache=True, error_model="numpy", inline="always")
def _add(fm, p, q, v):
    """M[p, q] += v for DOFs p >= q (the lower triangle)."""
    fm.env[fm.start[p] + q - fm.first[p]] += v


@njit(cache=True, error_model="numpy")
def _add_block(fm, a, b, block, ra, rb):
    """Add the 3x3 block (rows 3 ra.., columns 3 rb.. of ``block``) at nodes a, b (positions)."""
    for c in range(3):
        for d in range(3):
            p, q = 3 * a + c, 3 * b + d
            if p >= q:
                _add(fm, p, q, block[3 * ra + c, 3 * rb + d])


@njit(cache=True, error_model="numpy")
def _rod_terms(X, P, fm):
    """sum_v |H_v| of the rod vertex terms, merged onto their frame-mass nodes."""
    xl = np.zeros((ROWS, 3))
    H = np.zeros((3 * ROWS, 3 * ROWS))
    for k in range(P.rod_idx.shape[0]):
        idx = P.rod_idx[k]
        m = 0
        while m < ROWS and fm.rod_nodes[k, m] >= 0:
            m += 1
        if m == 0:
            continue
        gather(X, idx, xl)
        rod_hessian_forward(xl, idx, P.rod_par[k], H)
        Hm = np.zeros((3 * m, 3 * m))
        for r in range(ROWS):
            a = fm.rod_local[k, r]
            if a < 0:
                continue
            for s in range(ROWS):
                b = fm.rod_local[k, s]
                if b < 0:
                    continue
                for c in range(3):
                    for d in range(3):
                        Hm[3 * a + c, 3 * b + d] += H[3 * r + c, 3 * s + d]
        w, V = np.linalg.eigh(0.5 * (Hm + Hm.T))
        A = (V * np.abs(w)) @ V.T
        for a in range(m):
            for b in range(m):
                pa, pb = fm.rod_nodes[k, a], fm.rod_nodes[k, b]
                if pa >= pb:
                    _add_block(fm, pa, pb, A, a, b)


@njit(cache=True, error_model="numpy")
def _link_terms(X, P, fm):
    """The exact stiffness EA/L0 e e^T + |T|/L (I - e e^T) of each link in the mass, +-K."""
    K = np.zeros((6, 6))
    for k in range(P.link_ij.shape[0]):
        if not fm.link_in[k]:
            continue
        i, j = P.link_ij[k, 0], P.link_ij[k, 1]
        d = X[j, :] - X[i, :]
        L = np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        e = d / L
        ka = P.link_EA[k] / P.link_L0[k]
        kg = abs(tension(P.link_EA[k], P.link_L0[k], L, P.link_tension_only[k])) / L
        for c in range(3):
            for dd in range(3):
                v = (ka - kg) * e[c] * e[dd] + (kg if c == dd else 0.0)
                K[c, dd], K[3 + c, 3 + dd], K[c, 3 + dd], K[3 + c, dd] = v, v, -v, -v
        ends = (fm.pos[i], fm.pos[j])
        for a in range(2):
            for b in range(2):
                pa, pb = ends[a], ends[b]
                if pa >= 0 and pb >= 0 and pa >= pb:
                    _add_block(fm, pa, pb, K, a, b)


@njit(cache=True, error_model="numpy")
def refresh(X, P, D, S, fm, half_safety):
    """Assemble M_F at X from the rods, the links in it and the node blocks D, S of the other
    elements (D from the gradient at X), and factorise it in place. Returns -1, or the first
    model node whose pivot is not positive (nothing resists it in some direction)."""
    if fm.nodes.shape[0] == 0:
        return -1
    _restart_frames(X, fm)
    fm.env[:] = 0.0
    _rod_terms(X, P, fm)
    _link_terms(X, P, fm)
    tensor = D.shape[0] > 0
    for a in range(fm.nodes.shape[0]):
        i = fm.nodes[a]
        s = S[i]
        if tensor:
            blk = ((D[i, 0], D[i, 3], D[i, 4]), (D[i, 3], D[i, 1], D[i, 5]), (D[i, 4], D[i, 5], D[i, 2]))
            for c in range(3):
                for d in range(c + 1):
                    _add(fm, 3 * a + c, 3 * a + d, blk[c][d])
        for c in range(3):
            _add(fm, 3 * a + c, 3 * a + c, s)
        # a direction that nothing resists (a slack film's bond node in its plane) gets a sliver
        # of the node's mass rather than none, as the node-local masses do
        trace = 0.0
        for c in range(3):
            trace += fm.env[fm.start[3 * a + c + 1] - 1]
        for c in range(3):
            _add(fm, 3 * a + c, 3 * a + c, 1e-6 * trace)
    for k in range(fm.env.shape[0]):
        fm.env[k] *= half_safety
    return _factorise(fm)


@njit(cache=True, error_model="numpy")
def _factorise(fm):
    """In-place envelope Cholesky; -1, or the model node of the first non-positive pivot."""
    env, first, start = fm.env, fm.first, fm.start
    for i in range(first.shape[0]):
        fi, si = first[i], start[i]
        for j in range(fi, i + 1):
            fj, sj = first[j], start[j]
            acc = env[si + j - fi]
            for k in range(max(fi, fj), j):
                acc -= env[si + k - fi] * env[sj + k - fj]
            if j < i:
                env[si + j - fi] = acc / env[sj + j - fj]
            elif acc > 0.0 and np.isfinite(acc):
                env[si + i - fi] = np.sqrt(acc)
            else:
                return fm.nodes[i // 3]
    return -1


@njit(cache=True, error_model="numpy")
def solve(fm, R, A, free):
    """A = M_F^-1 R on the frame-mass nodes (rows of R, A: model nodes)."""
    env, first, start, y = fm.env, fm.first, fm.start, fm.y
    N = first.shape[0]
    for a in range(fm.nodes.shape[0]):  # y = R^T r
        i, T = fm.nodes[a], fm.turn[a]
        for c in range(3):
            y[3 * a + c] = T[c] * R[i, 0] + T[3 + c] * R[i, 1] + T[6 + c] * R[i, 2]
    for i in range(N):  # L z = y
        fi, si = first[i], start[i]
        acc = y[i]
        for k in range(fi, i):
            acc -= env[si + k - fi] * y[k]
        y[i] = acc / env[si + i - fi]
    for i in range(N - 1, -1, -1):  # L^T x = z
        fi, si = first[i], start[i]
        y[i] /= env[si + i - fi]
        yi = y[i]
        for k in range(fi, i):
            y[k] -= env[si + k - fi] * yi
    for a in range(fm.nodes.shape[0]):  # A = R x
        i, T = fm.nodes[a], fm.turn[a]
        for c in range(3):
            A[i, c] = (T[3 * c] * y[3 * a] + T[3 * c + 1] * y[3 * a + 1] + T[3 * c + 2] * y[3 * a + 2]) * free[i, c]


@njit(cache=True, error_model="numpy")
def momentum_max2(fm, V):
    """Largest |M_F v|^2 over the frame-mass nodes, N^2 (v in mm per step, dt = 1); the
    rotation R keeps the norm of a node's momentum, so M_ref R^T v is measured."""
    env, first, start, y = fm.env, fm.first, fm.start, fm.y
    N = first.shape[0]
    w = np.zeros(N)
    for a in range(fm.nodes.shape[0]):
        i, T = fm.nodes[a], fm.turn[a]
        for c in range(3):
            y[3 * a + c] = T[c] * V[i, 0] + T[3 + c] * V[i, 1] + T[6 + c] * V[i, 2]
    for i in range(N):  # w = L^T v
        fi, si = first[i], start[i]
        for k in range(fi, i + 1):
            w[k] += env[si + k - fi] * y[i]
    best = 0.0
    for a in range(fm.nodes.shape[0]):
        m2 = 0.0
        for c in range(3):  # (L w) at the node's rows
            i = 3 * a + c
            fi, si = first[i], start[i]
            acc = 0.0
            for k in range(fi, i + 1):
                acc += env[si + k - fi] * w[k]
            m2 += acc * acc
        if m2 > best or m2 != m2:
            best = m2
    return best


@njit(cache=True, error_model="numpy")
def diagonal(fm, M):
    """Write the diagonal of M_F (from its factor: sum_k L_pk^2) into the node-local mass rows
    M (n, 6) of the frame-mass nodes, off-diagonal entries zero."""
    env, start = fm.env, fm.start
    for a in range(fm.nodes.shape[0]):
        i = fm.nodes[a]
        for c in range(3):
            p = 3 * a + c
            acc = 0.0
            for k in range(start[p], start[p + 1]):
                acc += env[k] * env[k]
            M[i, c] = acc
            M[i, 3 + c] = 0.0
