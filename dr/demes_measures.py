"""Measures of a DR state of a DEMES model that its result reports: the slack areas of the
film, the membrane energy by the paper's formula and the asymmetry across the mirror plane."""

from __future__ import annotations

import numpy as np

from results import Result

from .clusters import lengths as cable_lengths
from .demes_model import DemesModel
from .kernels import place_virtual
from .links import lengths as link_lengths, tensions
from .model import Model
from .triangles import (AREA as TRI_AREA, DIRECTIONS as TRI_DIRECTIONS, FAMILY_LAM as TRI_FAMILY_LAM, FILM as TRI_FILM,
                        LAW as TRI_LAW, LINEAR as TRI_LINEAR, energy as triangle_energy)


def paper_formula_membrane_energy(model: Model, x: np.ndarray) -> float:
    """The membrane energy by the paper's formula, sum of N eps L / 2 over the membrane's links
    and cables with the *current* length L, plus the exact energy of the row of triangles at
    the bond line (N mm; ``results.ENERGY_DEFINITION`` defines both).

    The exact energy of a Hookean element is N eps L0 / 2; the formula is larger by L / L0,
    about the pre-stretch. Reported beside the exact energy so the energies can be read
    against the paper's."""
    P = model.pack()
    X = np.vstack([x, np.zeros((P.n_total - P.n, 3))])
    place_virtual(X, P)
    mem = ~P.link_frame
    L, L0 = link_lengths(X, P)[mem], P.link_L0[mem]
    eps = (L - L0) / L0
    N = tensions(P.link_EA[mem], L0, L, P.link_tension_only[mem])
    Lc = cable_lengths(X, P)
    eps_c = (Lc - P.clu_L0) / P.clu_L0
    Nc = tensions(P.clu_EA, P.clu_L0, Lc, P.clu_tension_only)
    # the row of triangles at the bond line is no tension element: its exact energy is added
    return float(0.5 * (np.sum(N * eps * L) + np.sum(Nc * eps_c * Lc)) + triangle_energy(X, P))


def slack_fractions(dm: DemesModel, res: Result) -> tuple[float, float]:
    """Fractions of the flat membrane area with at least one slack direction (a tension field,
    wrinkles) and with only slack directions (fully slack).

    Constant-strain triangles (the DR triangles, the nets' row at the bond line) are measured
    by their strains, the nets' lattice triangles by their edges' cables."""
    area, some, full = _triangle_slack(dm, res.x)
    if dm.net is not None:
        parts = zip((area, some, full), _lattice_slack(dm, res))
        area, some, full = (np.concatenate(p) for p in parts)
    if area.size == 0 or not np.isfinite(area).all():
        return float("nan"), float("nan")
    return float(area[some].sum() / area.sum()), float(area[full].sum() / area.sum())


def _lattice_slack(dm: DemesModel, res: Result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per lattice triangle of a net: flat area, whether some / all of its cable edges are slack
    (tension not above 1e-9 of the largest membrane tension)."""
    tri = dm.net.triangles[dm.net.row_triangles.shape[0]:]
    x0 = dm.net.nodes
    area = 0.5 * np.linalg.norm(np.cross(x0[tri[:, 1]] - x0[tri[:, 0]], x0[tri[:, 2]] - x0[tri[:, 0]]), axis=1)
    edges, tension = [], []
    for name in ("membrane_links", "membrane_clusters"):
        if name in res.blocks:
            edges.append(res.blocks[name].connectivity)
            tension.append(res.blocks[name].cell_data["tension_N"])
    if not edges:
        return area, np.zeros(area.size, bool), np.zeros(area.size, bool)
    edges, tension = np.sort(np.vstack(edges), axis=1), np.concatenate(tension)
    n = x0.shape[0]
    keys = edges[:, 0] * n + edges[:, 1]
    taut = keys[tension > 1e-9 * max(float(tension.max()), 1e-300)]
    t_edges = np.sort(np.stack([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]], axis=1), axis=2)
    t_keys = t_edges[..., 0] * n + t_edges[..., 1]
    membrane = np.isin(t_keys, keys)
    slack = membrane & ~np.isin(t_keys, taut)
    some = slack.any(axis=1)
    return area, some, some & (slack == membrane).all(axis=1)


def _triangle_slack(dm: DemesModel, x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per constant-strain triangle: flat area, whether some / all families are slack. With the
    linear law a family (lattice direction m_k) is slack where its strain lambda |F m_k| - 1 is
    not positive, as the FEM measures it; the neo-Hookean film's principal tensions are not
    measured here (NaN areas)."""
    P = dm.model.pack()
    film = P.tri_par[:, TRI_FILM] == 1.0
    idx, grad, par = P.tri_idx[film], P.tri_grad[film], P.tri_par[film]
    if idx.shape[0] == 0:
        return np.zeros(0), np.zeros(0, bool), np.zeros(0, bool)
    area = par[:, TRI_AREA]
    if par[0, TRI_LAW] != TRI_LINEAR:
        return np.full(area.size, np.nan), np.zeros(area.size, bool), np.zeros(area.size, bool)
    F = np.einsum("tai,taj->tij", x[idx], grad)  # (t, 3, 2) deformation gradients
    stretch = np.linalg.norm(np.einsum("tij,kj->tki", F, TRI_DIRECTIONS), axis=2)  # (t, 3)
    slack = par[:, list(TRI_FAMILY_LAM)] * stretch - 1.0 <= 0.0
    return area, slack.any(axis=1), slack.all(axis=1)


def asymmetry(x: np.ndarray, mirror: np.ndarray) -> float:
    """Largest distance between a node and the mirror image of its mirror node, mm."""
    return float(np.max(np.linalg.norm(x - x[mirror] * [-1.0, 1.0, 1.0], axis=1)))
