"""DR element: the Adriaenssens-Barnes spline beam, M = EI (|kappa| - kappa_0) per node triplet."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, NamedTuple, Sequence

import numpy as np
from numba import njit

from .checks import positive
from .errors import DRError
from .vec import add, add_to, cross, get, norm, scale, sub


class Fields(NamedTuple):
    """The spline beams' arrays in :class:`dr.kernels.Packed`."""

    beam_idx: np.ndarray  # (b, 3) spline-beam triplets s, i, f
    beam_EI: np.ndarray  # N mm^2
    beam_k0: np.ndarray  # 1/mm rest curvature
    beam_w: np.ndarray  # weight (1/2 at a clamp: the other half belongs to the mirrored beam)
    beam_l: np.ndarray  # mm, rest length attributed to the node


@dataclass
class Beam:
    """A beam as :meth:`dr.Model.add_beam` was given it (EI_strong None: the spline beam)."""

    chain: np.ndarray
    EI: float
    EA: float | None
    EI_strong: float | None
    GJ: float | None
    orientation: np.ndarray | None
    closed: bool


class Methods:
    """The :class:`dr.Model` method that adds beams: spline beams, and strips (:mod:`dr.strips`)."""

    def add_beam(
        self,
        chain: Sequence[int],
        EI: float,
        EA: float | None = None,
        *,
        EI_strong: float | None = None,
        GJ: float | None = None,
        orientation: Sequence[int] | None = None,
        closed: bool = False,
    ) -> None:
        """Add a beam along ``chain``; its rest shape is the reference geometry.

        Without ``EI_strong`` it is the isotropic spline beam (Adriaenssens & Barnes):
        M = EI (|kappa| - kappa_0) per node triplet. Having no material frame it cannot tell
        which way its rest curvature points, so where it is naturally curved a tilt of the
        curvature plane costs nothing at first order (energy ~ tilt^4): give ``EI_strong``
        (= EI for an isotropic section), ``GJ`` and ``orientation`` for a rod that can. With ``EI_strong`` and ``GJ`` it is a strip:
        weak-axis EI, strong-axis EI_strong, torsion GJ, its plane set by ``orientation``
        (one node per edge, e.g. the membrane node next to the edge); the forces are the exact
        gradient of one energy, so the orientation nodes get their reactions. ``EA`` adds an
        axial link per segment (role 'frame'). Units: N mm^2, N.
        """
        c = self.node_indices("beam chain", chain)
        if c.size < 3 and not closed:
            raise DRError("a beam chain needs at least 3 nodes")
        if len(set(c.tolist())) != c.size:
            raise DRError("beam chain visits a node twice; for a loop give each node once and closed=True")
        ei = positive("beam EI (N mm^2)", EI)
        n_edges = c.size if closed else c.size - 1
        nxt = np.roll(c, -1)[:n_edges]
        self.rest_lengths("beam edge", c[:n_edges], nxt, None)
        ends = (np.roll(c, 1), np.roll(c, -1)) if closed else (c[:-2], c[2:])
        x = self.ref_positions()
        folded = np.flatnonzero(np.linalg.norm(x[ends[1]] - x[ends[0]], axis=1) == 0.0)
        if folded.size:
            k = folded[0]
            raise DRError(f"beam chain folds back on itself: nodes {ends[0][k]} and {ends[1][k]} on either side of "
                          "a node coincide (no curvature is defined there); move them apart")
        orient = None
        if orientation is not None:
            orient = self.node_indices("beam orientation", orientation, True)
            if orient.size != n_edges:
                raise DRError(f"beam orientation needs one node per edge ({n_edges}), got {orient.size}")
        if EI_strong is not None:
            if GJ is None or orient is None:
                raise DRError("a strip beam (EI_strong given) also needs GJ and orientation")
            positive("beam EI_strong (N mm^2)", EI_strong)
            positive("beam GJ (N mm^2)", GJ)
        ea = None if EA is None else positive("beam EA (N)", EA)
        self.stored[Fields].append(Beam(c, ei, ea, EI_strong, GJ, orient, closed))
        if ea is not None:
            self.add_link(c[:n_edges], nxt, ea, role="frame")


def beam_triplets(model, ghost_id: dict, *, strip: bool) -> Iterator[tuple]:
    """(prev, node, next, weight, edge slot before, edge slot after, beam) of every node triplet
    of the strip beams (``strip``) or the isotropic ones of ``model``, beam by beam.

    A closed beam has one triplet per node; an open one per inner node, and at a clamped end
    one with the clamp ghost (row ``ghost_id[(beam number, end)]``) at half weight (the other
    half belongs to the mirrored beam). Edge slots index the beam's orientation (-1: none).
    """
    for b, beam in enumerate(model.stored[Fields]):
        if (beam.EI_strong is not None) != strip:
            continue
        c = beam.chain
        m = c.size
        if beam.closed:
            for p in range(m):
                yield c[p - 1], c[p], c[(p + 1) % m], 1.0, p - 1, p, beam
            continue
        for p in range(1, m - 1):
            yield c[p - 1], c[p], c[p + 1], 1.0, p - 1, p, beam
        if (b, 0) in ghost_id:
            yield ghost_id[(b, 0)], c[0], c[1], 0.5, -1, 0, beam
        if (b, -1) in ghost_id:
            yield c[-2], c[-1], ghost_id[(b, -1)], 0.5, m - 2, -1, beam


def pack(model, rest) -> Fields:
    """The isotropic beams of ``model`` (:meth:`dr.Model.add_beam` without ``EI_strong``), their
    rest curvatures and lengths from the rest positions ``rest.X`` (:class:`dr.model.Rest`)."""
    rows = list(beam_triplets(model, rest.ghost_id, strip=False))
    idx = np.array([r[:3] for r in rows], dtype=np.int64).reshape(-1, 3)
    X = rest.X
    s, i, f = idx.T
    return Fields(
        beam_idx=idx,
        beam_EI=np.array([r[6].EI for r in rows], dtype=float),
        beam_k0=curvatures(X, idx) if rows else np.zeros(0),
        beam_w=np.array([r[3] for r in rows], dtype=float),
        beam_l=0.5 * (np.linalg.norm(X[i] - X[s], axis=1) + np.linalg.norm(X[f] - X[i], axis=1)),
    )


def forces(X: np.ndarray, P, moment: np.ndarray) -> dict[str, np.ndarray]:
    """Adds each triplet's bending moment EI (kappa - kappa_0) (N mm) to ``moment`` (n,) at its
    middle node (ghost triplets' middle is the clamped node); reports nothing of its own."""
    if P.beam_idx.size == 0:
        return {}
    b = P.beam_idx[:, 1]
    kap = curvatures(X, P.beam_idx)
    np.add.at(moment, b[b < P.n], (P.beam_EI * (kap - P.beam_k0))[b < P.n])
    return {}


def stencils(P) -> np.ndarray:
    """The rows of X each spline beam's energy depends on (b, 3): its triplet."""
    return P.beam_idx


def edges(P) -> np.ndarray:
    """Node pairs (k, 2) of the triplets' two edges."""
    return np.concatenate([P.beam_idx[:, :2], P.beam_idx[:, 1:]])


@njit(cache=True, error_model="numpy", inline="always")
def curvature(xs, xi, xf):
    """Circle curvature through a triplet, 2 |a x b| / (|a| |b| |c|) (1/mm), with a = xi - xs,
    b = xf - xi, and (a, b, |a|, |b|, a x b, |a x b|)."""
    a, b = sub(xi, xs), sub(xf, xi)
    la, lb, lc = norm(a), norm(b), norm(sub(xf, xs))
    cr = cross(a, b)
    lcr = norm(cr)
    return 2.0 * lcr / (la * lb * lc), a, b, la, lb, cr, lcr


@njit(cache=True, error_model="numpy")
def curvatures(X, idx):
    """Curvatures (b,) of triplets idx (b, 3) at positions X, 1/mm."""
    out = np.zeros(idx.shape[0])
    for k in range(idx.shape[0]):
        out[k] = curvature(get(X, idx[k, 0]), get(X, idx[k, 1]), get(X, idx[k, 2]))[0]
    return out


@njit(cache=True, error_model="numpy", inline="always")
def gradient(X, P, G, D):
    """Add the beams' energy gradient to G. Returns the largest nodal force, N."""
    fmax = 0.0
    for k in range(P.beam_idx.shape[0]):
        s, i, f = P.beam_idx[k, 0], P.beam_idx[k, 1], P.beam_idx[k, 2]
        kap, a, b, la, lb, cr, lcr = curvature(get(X, s), get(X, i), get(X, f))
        if lcr <= 1e-14 * la * lb:
            continue  # straight: no bending plane (and no moment if the rest state is straight)
        m = P.beam_w[k] * P.beam_EI[k] * (kap - P.beam_k0[k])
        n = scale(cr, 1.0 / lcr)
        ea = cross(n, a)  # length la, towards the centre of curvature
        eb = cross(n, b)
        sa, sb = m / (la * la), m / (lb * lb)
        fmax = max(fmax, abs(m) / min(la, lb))
        # Adriaenssens & Barnes: ends pushed away from the centre, middle node towards it
        add_to(G, s, ea, sa)
        add_to(G, f, eb, sb)
        add_to(G, i, add(scale(ea, sa), scale(eb, sb)), -1.0)
    return fmax


@njit(cache=True, error_model="numpy")
def strain_energy(X, P):
    """Strain energy (membrane, frame bending, frame torsion, frame axial) of all triplets, N mm:
    bending M^2 L / (2 EI) only."""
    e = 0.0
    for k in range(P.beam_idx.shape[0]):
        kap = curvature(get(X, P.beam_idx[k, 0]), get(X, P.beam_idx[k, 1]), get(X, P.beam_idx[k, 2]))[0]
        dm = kap - P.beam_k0[k]
        e += 0.5 * P.beam_w[k] * P.beam_EI[k] * dm * dm * P.beam_l[k]
    return 0.0, e, 0.0, 0.0


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Row sums (4, 8, 4) EI/l^3 of a triplet's lateral stiffness plus the geometric M/l^2."""
    for k in range(P.beam_idx.shape[0]):
        s, i, f = P.beam_idx[k, 0], P.beam_idx[k, 1], P.beam_idx[k, 2]
        kap, _, _, la, lb, _, _ = curvature(get(X, s), get(X, i), get(X, f))
        lm = min(la, lb)
        m = abs(P.beam_w[k] * P.beam_EI[k] * (kap - P.beam_k0[k]))
        kb = P.beam_w[k] * P.beam_EI[k] / (lm * lm * lm)
        S[s] += 4.0 * kb + m / (lm * lm)
        S[i] += 8.0 * kb + 2.0 * m / (lm * lm)
        S[f] += 4.0 * kb + m / (lm * lm)
