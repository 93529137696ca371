"""DR element: links (bars or cables), T = EA/L0 (L - L0), tension-only if asked."""

from __future__ import annotations

from typing import NamedTuple, Sequence

import numpy as np
from numba import njit

from results import CellBlock

from .blocks import add_block
from .errors import DRError
from .vec import add_to, get, norm, scale, sub


class Fields(NamedTuple):
    """The links' arrays in :class:`dr.kernels.Packed`."""

    link_ij: np.ndarray  # (l, 2)
    link_EA: np.ndarray  # N
    link_L0: np.ndarray  # mm
    link_tension_only: np.ndarray  # bool
    link_frame: np.ndarray  # bool: frame axial (True) or membrane (False), for the energy split
    link_block: np.ndarray  # bool: its stiffness is in the frame mass (dr.frame_mass), not in D


class Methods:
    """The :class:`dr.Model` method that adds links."""

    def add_link(
        self,
        i: int | Sequence[int],
        j: int | Sequence[int],
        EA: float | Sequence[float],
        rest_length: float | Sequence[float] | None = None,
        tension_only: bool = False,
        role: str = "membrane",
    ) -> None:
        """Add links (bars or cables) between nodes i and j: T = EA/L0 (L - L0).

        ``role`` ('membrane' or 'frame') decides where their energy is counted.
        """
        ii = self.node_indices("link i", np.atleast_1d(i), True)
        jj = self.node_indices("link j", np.atleast_1d(j), True)
        if ii.shape != jj.shape:
            raise DRError("link i and j must have the same length")
        if np.any(ii == jj):
            raise DRError("a link joins a node to itself; give two different nodes")
        ea = np.broadcast_to(np.asarray(EA, dtype=float), ii.shape).copy()
        if np.any(~np.isfinite(ea)) or np.any(ea <= 0):
            raise DRError("link EA must be positive (N)")
        if role not in ("membrane", "frame"):
            raise DRError(f"link role = {role!r}: use 'membrane' or 'frame'")
        L0 = self.rest_lengths("link", ii, jj, rest_length)
        self.stored[Fields].append((ii, jj, ea, L0, np.full(ii.shape, tension_only), np.full(ii.shape, role == "frame")))


def scale_membrane(stored: list, factor: float) -> list:
    """The membrane links of ``stored`` with rest lengths times ``factor``; frame links as they are."""
    return [(i, j, ea, np.where(frame, L0, L0 * factor), to, frame) for i, j, ea, L0, to, frame in stored]


def prestretch_membrane(stored: list, model, P: np.ndarray) -> list:
    """The membrane links of ``stored`` with rest lengths |P^-1 d| (d their flat x, y span, P
    the pre-stretch tensor (2, 2)); frame links as they are."""
    ref = model.ref_positions()[:, :2]
    return [(i, j, ea, np.where(frame, L0, np.linalg.norm(np.linalg.solve(P, (ref[j] - ref[i]).T), axis=0)), to, frame)
            for i, j, ea, L0, to, frame in stored]


def pack(model, rest) -> Fields:
    """The links of ``model`` (:meth:`dr.Model.add_link`); ``rest`` is unused."""
    if model.stored[Fields]:
        li, lj, lea, ll0, lto, lfr = (np.concatenate(a) for a in zip(*model.stored[Fields]))
    else:
        li = lj = np.zeros(0, np.int64)
        lea = ll0 = np.zeros(0)
        lto = lfr = np.zeros(0, bool)
    return Fields(
        link_ij=np.stack([li, lj], axis=1).astype(np.int64).reshape(-1, 2),
        link_EA=lea.astype(float),
        link_L0=ll0.astype(float),
        link_tension_only=lto.astype(bool),
        link_frame=lfr.astype(bool),
        link_block=np.zeros(lfr.size, bool),
    )


def forces(X: np.ndarray, P, moment: np.ndarray) -> dict[str, np.ndarray]:
    """The tension of each link at X, N (``moment`` is left alone)."""
    return {"link_tension": tensions(P.link_EA, P.link_L0, lengths(X, P), P.link_tension_only)}


def cells(P, real: np.ndarray, forces: dict[str, np.ndarray]) -> dict[str, CellBlock]:
    """VTK line blocks: the membrane links with their tensions (N), the frame links with their
    axial forces (N) and the mean of their end nodes' ``node_moment`` (N mm). ``real`` maps a
    row of X to the real node it is drawn at."""
    blocks = {}
    mem = ~P.link_frame
    if mem.any():
        blocks["membrane_links"] = CellBlock("line", real[P.link_ij[mem]], {"tension_N": forces["link_tension"][mem]})
    if P.link_frame.any():
        seg = real[P.link_ij[P.link_frame]]
        blocks["frame"] = CellBlock("line", seg, {"axial_force_N": forces["link_tension"][P.link_frame],
                                                  "bending_moment_Nmm": forces["node_moment"][seg].mean(axis=1)})
    return blocks


def stencils(P) -> np.ndarray:
    """The rows of X each link's energy depends on (k, 2): its two nodes."""
    return P.link_ij


def edges(P) -> np.ndarray:
    """Node pairs (k, 2) the links join."""
    return P.link_ij


@njit(cache=True, error_model="numpy")
def tension(EA, L0, L, tension_only):
    """Axial force (N) at length L (mm); a slack tension-only element carries none."""
    t = EA / L0 * (L - L0)
    if tension_only and t < 0.0:
        return 0.0
    return t


def lengths(X: np.ndarray, P) -> np.ndarray:
    """Length of each link at positions X (n_total, 3) mm, mm."""
    i, j = P.link_ij.T
    return np.linalg.norm(X[j] - X[i], axis=1)


@njit(cache=True, error_model="numpy")
def tensions(EA, L0, L, tension_only):
    """:func:`tension` of each of a set of elements (links, or clustered cables of total length
    L), N: the law's one writing serves the kernels and the reported forces."""
    t = np.empty(L.shape[0])
    for k in range(L.shape[0]):
        t[k] = tension(EA[k], L0[k], L[k], tension_only[k])
    return t


@njit(cache=True, error_model="numpy", inline="always")
def gradient(X, P, G, D):
    """Add the links' energy gradient to G and, if D has rows, each link end's exact block
    EA/L0 e e^T + |T|/L (I - e e^T) (a link's stiffness is at most twice its block diagonal),
    except for the links whose stiffness the frame mass carries (``link_block``).
    Returns the largest link force, N."""
    fmax = 0.0
    for k in range(P.link_ij.shape[0]):
        i, j = P.link_ij[k, 0], P.link_ij[k, 1]
        d = sub(get(X, j), get(X, i))
        L = norm(d)
        t = tension(P.link_EA[k], P.link_L0[k], L, P.link_tension_only[k])
        fmax = max(fmax, abs(t))
        add_to(G, i, d, -t / L)
        add_to(G, j, d, t / L)
        if D.shape[0] > 0 and not P.link_block[k]:
            e = scale(d, 1.0 / L)
            ka, kg = P.link_EA[k] / P.link_L0[k], abs(t) / L
            add_block(D, i, e, ka, kg)
            add_block(D, j, e, ka, kg)
    return fmax


@njit(cache=True, error_model="numpy")
def strain_energy(X, P):
    """Strain energy (membrane, frame bending, frame torsion, frame axial), N mm: N eps L0 / 2
    of each link, as membrane or frame axial by its role."""
    e_mem = e_frame = 0.0
    for k in range(P.link_ij.shape[0]):
        L = norm(sub(get(X, P.link_ij[k, 1]), get(X, P.link_ij[k, 0])))
        t = tension(P.link_EA[k], P.link_L0[k], L, P.link_tension_only[k])
        e = 0.5 * t * t * P.link_L0[k] / P.link_EA[k]
        if P.link_frame[k]:
            e_frame += e
        else:
            e_mem += e
    return e_mem, 0.0, 0.0, e_frame


@njit(cache=True, error_model="numpy")
def stiffness(X, P, S, with_links):
    """Scalar bound EA/L0 + |T|/L per link end (Barnes), for scalar masses (``with_links``)."""
    if not with_links:
        return
    for k in range(P.link_ij.shape[0]):
        i, j = P.link_ij[k, 0], P.link_ij[k, 1]
        L = norm(sub(get(X, j), get(X, i)))
        t = tension(P.link_EA[k], P.link_L0[k], L, P.link_tension_only[k])
        kk = P.link_EA[k] / P.link_L0[k] + abs(t) / L
        S[i] += kk
        S[j] += kk
