"""The model's energy, its gradient (forces) and the stiffness bounds behind the masses.

Each element type is its own module (the registry dr.elements: links, clusters, beams, strips,
triangles, rod, dielectric) with ``gradient``, ``strain_energy`` and ``stiffness`` over its
arrays in :class:`Packed`; the functions here run those the model has in turn and handle the
virtual nodes.

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

from .blocks import add_reflected
from .frames import Z0, gather, node_frame, node_frame_vjp, scatter
from .elements import ELEMENTS
from .vec import add_to, axpy, dot, get, scale, sub


class Virtual(NamedTuple):
    """The fields of :class:`Packed` that define the virtual nodes. The per-step code passes
    this small record rather than the whole of ``Packed``: a compiled call increments and
    decrements the reference count of every array in its record arguments, and the 35 of
    ``Packed`` cost about 0.5 us per call."""

    n: int  # real nodes
    ghost_src: np.ndarray  # (g,) node mirrored
    ghost_clamp: np.ndarray  # (g,) clamped node
    ghost_t: np.ndarray  # (g, 3) unit clamped tangent
    off_geo: np.ndarray  # (o, 5) frame geometry indices of the offset node's frame node
    off_d: np.ndarray  # (o,) signed offset along the strip normal, mm


class Packed(NamedTuple("PackedFields", [*Virtual.__annotations__.items(),
                                         *((f, t) for e in ELEMENTS for f, t in e.Fields.__annotations__.items())])):
    """Arrays of a model, as the kernels take them (see :class:`dr.Model`): the fields of
    :class:`Virtual`, then each element type's ``Fields`` in the order of dr.elements. A type
    the model lacks has arrays with no rows; every model has this one record type, so the
    kernels are compiled once for all."""

    __slots__ = ()

    @property
    def n_total(self) -> int:
        """Rows of the extended position array: real nodes, offsets, ghosts."""
        return self.n + self.off_geo.shape[0] + self.ghost_src.shape[0]


# ----------------------------------------------------------------------------- virtual nodes


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
# Compiled code cannot loop over modules. Each of these three is written out, once per process,
# as a straight run of calls, one per element type in the order of ELEMENTS and each only when
# the model has that element (its first array has rows), and inlined into the kernel that calls
# it before typing: the same code as calls written by hand, compiled once, so adding an element
# type costs a step nothing. (An inlined overload would also compile each run on its own,
# element functions inlined in it: 10 s more on a cold cache.)


def _in_turn(function: str, arguments: str, *, start: str, each: str, result: str):
    """A compiled, always inlined function of (X, P, ``arguments``) that calls ``function`` of
    each element module the model has, each call's value put into the statement ``each`` (``{}``)."""
    namespace = {}
    lines = [f"def in_turn(X, P{arguments}):", f"    {start}"]
    for k, element in enumerate(ELEMENTS):
        namespace[f"element_{k}"] = getattr(element, function)
        lines += [f"    if P.{element.Fields._fields[0]}.shape[0] > 0:",
                  "        " + each.format(f"element_{k}(X, P{arguments})")]
    lines.append(f"    return {result}")
    exec("\n".join(lines), namespace)
    return njit(error_model="numpy", inline="always")(namespace["in_turn"])


all_gradients = _in_turn("gradient", ", G, D", start="fmax = 0.0", each="fmax = max(fmax, {})", result="fmax")
"""Each element type's ``gradient`` in turn; the largest element force (N)."""

all_strain_energies = _in_turn("strain_energy", "", start="e_mem = e_bend = e_twist = e_ax = 0.0",
                               each="m, b, t, a = {}; e_mem += m; e_bend += b; e_twist += t; e_ax += a",
                               result="e_mem, e_bend, e_twist, e_ax")
"""The sums of each element type's ``strain_energy`` (membrane, frame bending, torsion, axial), N mm."""

all_stiffnesses = _in_turn("stiffness", ", S, with_links", start="pass", each="{}", result="None")
"""Each element type's ``stiffness`` in turn."""


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
    fmax = all_gradients(X, P, G, D)
    if has_virtual:
        pull_back_virtual(X, G, vp)
        if D.shape[0] > 0:
            pull_back_blocks(D, vp)
    return fmax


@njit(cache=True, error_model="numpy")
def energy(X, P):
    """Strain energy split (membrane, frame bending, frame torsion, frame axial), N mm."""
    place_virtual(X, P)
    return all_strain_energies(X, P)


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
    all_stiffnesses(X, P, S, with_links)
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
