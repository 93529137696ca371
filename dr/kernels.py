"""The model's energy, its gradient (forces) and the stiffness bounds behind the masses.

Each element type is its own module with ``gradient``, ``energy`` and ``stiffness`` over its
arrays in :class:`Packed`: links, clusters (clustered cables), beams (spline beams), strips,
triangles (membrane) and rod (the FEM's frame rod); the functions here run them in turn and
handle the virtual nodes.

Everything acts on an extended position array X = [real nodes; virtual nodes]. Virtual nodes
are positions derived from real ones:

- ghosts (moving clamp ghosts): the mirror image of a beam's second node across the plane
  through the clamped node normal to the clamped tangent (second-order clamp, docs/elements.md);
- offsets: a frame node moved by a signed distance along the strip normal, where the film is
  bonded on one face of the strip (the membrane then acts t/2 off the centreline).

Rows of X: real nodes (n), offsets, ghosts.

Kernels accumulate the energy gradient G = dE/dX; the residual is R = loads - G after the
virtual-node gradients are pulled back onto the real nodes (chain rule), so every node that a
virtual node or a strip orientation depends on gets its reaction.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from . import beams, clusters, dielectric, links, rod, strips, triangles
from .blocks import add_reflected
from .frames import Z0, gather, node_frame, node_frame_vjp, scatter
from .vec import add_to, axpy, dot, get, scale, sub


class Packed(NamedTuple):
    """Element arrays of a model, as the kernels take them (see :class:`dr.Model`)."""

    n: int  # real nodes
    ghost_src: np.ndarray  # (g,) node mirrored
    ghost_clamp: np.ndarray  # (g,) clamped node
    ghost_t: np.ndarray  # (g, 3) unit clamped tangent
    off_geo: np.ndarray  # (o, 5) frame geometry indices of the offset node's frame node
    off_d: np.ndarray  # (o,) signed offset along the strip normal, mm
    link_ij: np.ndarray  # (l, 2)
    link_EA: np.ndarray  # N
    link_L0: np.ndarray  # mm
    link_tension_only: np.ndarray  # bool
    link_frame: np.ndarray  # bool: frame axial (True) or membrane (False), for the energy split
    link_block: np.ndarray  # bool: its stiffness is in the frame mass (dr.frame_mass), not in D
    clu_ptr: np.ndarray  # (c+1,) into clu_nodes
    clu_nodes: np.ndarray  # chains, concatenated
    clu_EA: np.ndarray  # N
    clu_L0: np.ndarray  # mm, rest length of the whole cable
    clu_tension_only: np.ndarray  # bool
    clu_seg: np.ndarray  # (s, 2) cable segments (node pairs), all clusters
    clu_seg_cluster: np.ndarray  # (s,) cluster of each segment
    clu_work: np.ndarray  # (len(clu_nodes),) scratch: segment lengths of the current step
    beam_idx: np.ndarray  # (b, 3) spline-beam triplets s, i, f
    beam_EI: np.ndarray  # N mm^2
    beam_k0: np.ndarray  # 1/mm rest curvature
    beam_w: np.ndarray  # weight (1/2 at a clamp: the other half belongs to the mirrored beam)
    beam_l: np.ndarray  # mm, rest length attributed to the node
    strip_idx: np.ndarray  # (k, 5) frame geometry of strip nodes
    strip_par: np.ndarray  # (k, 9) KB, KT, EIW, EIS, GJ, KW0, KN0, TAU0, LBAR
    strip_blocks: np.ndarray  # (k, 5, 6) scratch: mass blocks in the material frame
    tri_idx: np.ndarray  # (t, 3) membrane triangles
    tri_grad: np.ndarray  # (t, 3, 2) flat shape-function gradients, 1/mm
    tri_par: np.ndarray  # (t, 6) see dr.triangles (area, E h, lambda, tension-only, law, Gent Jm)
    rod_idx: np.ndarray  # (r, 7) rod vertex stencils, see dr.rod
    rod_par: np.ndarray  # (r, dr.rod.N_PAR)
    rod_blocks: np.ndarray  # (r, 7, 6) scratch: mass blocks in the vertex's material frame
    diel_idx: np.ndarray  # (d, 3) triangles of the dielectric film, see dr.dielectric
    diel_par: np.ndarray  # (d, 2) flat area (mm^2), coefficient c (N/mm)

    @property
    def n_total(self) -> int:
        """Rows of the extended position array: real nodes, offsets, ghosts."""
        return self.n + self.off_geo.shape[0] + self.ghost_src.shape[0]


# ----------------------------------------------------------------------------- virtual nodes


class Virtual(NamedTuple):
    """The fields of :class:`Packed` that define the virtual nodes. The per-step code passes
    this small record rather than the whole of ``Packed``: a compiled call increments and
    decrements the reference count of every array in its record arguments, and the 37 of
    ``Packed`` cost about 0.5 us per call."""

    n: int
    ghost_src: np.ndarray
    ghost_clamp: np.ndarray
    ghost_t: np.ndarray
    off_geo: np.ndarray
    off_d: np.ndarray


@njit(cache=True, error_model="numpy", inline="always")
def virtual(P):
    """The :class:`Virtual` record of a :class:`Packed` (same arrays, no copies)."""
    return Virtual(P.n, P.ghost_src, P.ghost_clamp, P.ghost_t, P.off_geo, P.off_d)



@njit(cache=True, error_model="numpy")
def place_virtual(X, P):
    """Positions of the virtual nodes from the real ones: ghosts, then offsets (rows n...).
    P: :class:`Packed` or :class:`Virtual`."""
    n = P.n  # first offset row
    base = n + P.off_geo.shape[0]
    for k in range(P.ghost_src.shape[0]):
        xs, xc = get(X, P.ghost_src[k]), get(X, P.ghost_clamp[k])
        t = get(P.ghost_t, k)
        g = axpy(-2.0 * dot(sub(xs, xc), t), t, xs)
        X[base + k, 0], X[base + k, 1], X[base + k, 2] = g
    xl = np.zeros((5, 3))
    for k in range(P.off_geo.shape[0]):
        idx = P.off_geo[k]
        gather(X, idx, xl)
        nu = node_frame(xl, idx[3] < 0, idx[4] < 0)[4]
        q = axpy(P.off_d[k], nu, get(xl, 1))
        X[n + k, 0], X[n + k, 1], X[n + k, 2] = q


@njit(cache=True, error_model="numpy")
def pull_back_virtual(X, G, P):
    """Move gradients on virtual nodes onto the real nodes they are made from (chain rule):
    offsets (onto frame nodes and the nodes their normals depend on), then ghosts."""
    n = P.n
    base = n + P.off_geo.shape[0]
    xl = np.zeros((5, 3))
    gl = np.zeros((5, 3))
    for k in range(P.off_geo.shape[0]):
        idx = P.off_geo[k]
        g_q = get(G, n + k)
        gather(X, idx, xl)
        f1, f2 = idx[3] < 0, idx[4] < 0
        n1, l1, n2, l2, nu, ls = node_frame(xl, f1, f2)
        gl[:] = 0.0
        add_to(gl, 1, g_q, 1.0)
        node_frame_vjp(xl, f1, f2, n1, l1, n2, l2, nu, ls, Z0, Z0, scale(g_q, P.off_d[k]), gl)
        scatter(G, idx, gl, 1.0)
    for k in range(P.ghost_src.shape[0]):
        g = get(G, base + k)
        t = get(P.ghost_t, k)
        # g = R x_src + (I - R) x_clamp with R = I - 2 t t^T (symmetric)
        gt = 2.0 * dot(g, t)
        add_to(G, P.ghost_src[k], axpy(-gt, t, g), 1.0)
        add_to(G, P.ghost_clamp[k], t, gt)



# ----------------------------------------------------------------------------- all elements


@njit(cache=True, error_model="numpy")
def gradient(X, P, G, D):
    """Energy gradient dE/dX of all elements on the real nodes, in G (n_total, 3).

    X must hold the real positions in its first P.n rows; virtual rows are recomputed. If D
    has rows, direction-dependent stiffness blocks are accumulated in it (links, triangles,
    and the strip blocks of :func:`stiffness` turned with the current material frames).
    Returns the largest element force (N) for the relative residual.
    """
    has_virtual = X.shape[0] > P.n
    if has_virtual:
        vp = virtual(P)
        place_virtual(X, vp)
    G[:] = 0.0
    if D.shape[0] > 0:
        D[:] = 0.0
    # each element type is called only when the model has it: a call costs its record's
    # reference counting even when it returns at once (see dr.integrator.run)
    fmax = 0.0
    if P.link_ij.shape[0] > 0:
        fmax = max(fmax, links.gradient(X, P, G, D))
    if P.clu_seg.shape[0] > 0:
        fmax = max(fmax, clusters.gradient(X, P, G, D))
    if P.beam_idx.shape[0] > 0:
        fmax = max(fmax, beams.gradient(X, P, G, D))
    if P.strip_idx.shape[0] > 0:
        fmax = max(fmax, strips.gradient(X, P, G, D))
    if P.tri_idx.shape[0] > 0:
        fmax = max(fmax, triangles.gradient(X, P, G, D))
    if P.rod_idx.shape[0] > 0:
        fmax = max(fmax, rod.gradient(X, P, G, D))
    if P.diel_idx.shape[0] > 0:
        fmax = max(fmax, dielectric.gradient(X, P, G, D))
    if has_virtual:
        pull_back_virtual(X, G, vp)
        if D.shape[0] > 0:
            pull_back_blocks(D, vp)
    return fmax


@njit(cache=True, error_model="numpy")
def energy(X, P):
    """Strain energy split (membrane, frame bending, frame torsion, frame axial), N mm."""
    place_virtual(X, P)
    e_mem, e_ax = links.energy(X, P)
    e_mem += clusters.energy(X, P) + triangles.energy(X, P)
    e_bend, e_twist = strips.energy(X, P)
    rb, rt = rod.energy(X, P)
    return e_mem, e_bend + rb + beams.energy(X, P), e_twist + rt, e_ax


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Per-node stiffness bound S (n_total,) for the fictitious masses m = f dt^2/2 S.

    ``with_links``: scalar masses, every element's bound goes into S; otherwise links and
    linear-law triangles leave theirs to the direction-dependent blocks of :func:`gradient`,
    and strips keep blocks in their material frames for it to turn. Virtual nodes pass theirs
    to the nodes they are made from.
    """
    if X.shape[0] > P.n:
        place_virtual(X, virtual(P))
    S[:] = 0.0
    # called only for the element types the model has, as in gradient
    if P.link_ij.shape[0] > 0:
        links.stiffness(X, P, S, with_links)
    if P.clu_seg.shape[0] > 0:
        clusters.stiffness(X, P, S, with_links)
    if P.beam_idx.shape[0] > 0:
        beams.stiffness(X, P, S, with_links)
    if P.strip_idx.shape[0] > 0:
        strips.stiffness(X, P, S, with_links)
    if P.tri_idx.shape[0] > 0:
        triangles.stiffness(X, P, S, with_links)
    if P.rod_idx.shape[0] > 0:
        rod.stiffness(X, P, S, with_links)
    if P.diel_idx.shape[0] > 0:
        dielectric.stiffness(X, P, S, with_links)
    n = P.n
    base = n + P.off_geo.shape[0]
    for k in range(P.off_geo.shape[0]):
        S[P.off_geo[k, 1]] += S[n + k]
    for k in range(P.ghost_src.shape[0]):
        S[P.ghost_src[k]] += S[base + k]


@njit(cache=True, error_model="numpy")
def pull_back_blocks(D, P):
    """Move the virtual nodes' stiffness blocks onto the real nodes they are made from."""
    off = P.n
    for k in range(P.off_geo.shape[0]):
        for c in range(6):
            D[P.off_geo[k, 1], c] += D[off + k, c]
    base = off + P.off_geo.shape[0]
    for k in range(P.ghost_src.shape[0]):
        add_reflected(D, P.ghost_src[k], D[base + k], get(P.ghost_t, k))
