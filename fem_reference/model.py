"""Discrete models as Newton problems: the DEMES (membrane + frame + supports) and a lone rod.

DEMES unknowns: positions y of all membrane mesh nodes, (nn, 3) flattened node-major (scikit-fem's
vector DOF order). The boundary nodes are the frame's centreline nodes. With a film offset d the
membrane does not act on the centreline but on the strip's film face: the membrane's boundary
positions are x_b + d n(x) (n the strip normal), a nonlinear map Phi whose first and second
derivatives enter the gradient (J^T g_m) and the tangent (J^T K_m J + d sum f_b . d2n_b).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
from skfem import BilinearForm
from skfem.helpers import dot as fdot

from scenes import Scene
from scenes.electric import electrode_coverage, film_coefficients

from .frame import Rod, RodProperties, StencilTerms, scatter
from .dielectric import Dielectric
from .members import member_rods
from .membrane import Membrane
from .mesh import MembraneMesh, build_mesh
from .rod_kernels import Jets

ENERGY_PARTS = ("membrane", "frame_bending", "frame_torsion", "frame_axial")


@dataclass
class Evaluation:
    """Total energy (N mm) and its parts, gradient (N), tangent (N/mm), force scale (N)."""

    total: float
    parts: dict[str, float]
    gradient: np.ndarray
    tangent: sp.csr_matrix | None
    force_scale: float
    membrane_gradient: np.ndarray = field(default_factory=lambda: np.zeros(0))


@BilinearForm
def mass_form(u, v, w):
    """The film's mass per unit area: the L2 inner product of two displacement fields."""
    return fdot(u, v)


class DemesProblem:
    """The scene's discrete energy at a pre-stretch ``lam`` (set the attribute to change it).

    Parameters
    ----------
    scene
        The DEMES scene (frame, membrane, supports, perturbation).
    refinement, element
        Mesh level (element size scene.spacing / 2^refinement) and 'P1' or 'P2'.
    """

    def __init__(self, scene: Scene, refinement: int, element: str):
        self.scene = scene
        self.mesh: MembraneMesh = build_mesh(scene, refinement, element)
        mem = scene.membrane
        film = self.mesh.part_basis(strip=False)
        self.membrane = Membrane(film, mem.law, mem.E, mem.thickness, mem.tension_only, mem.gent_jm,
                                 path=scene.prestretch_path)
        band = self.mesh.part_basis(strip=True)
        fr = scene.frame
        # the open windows' strip bands: the strip's material, unstretched (scenes.windows)
        self.strip = None if band is None else Membrane(band, "linear", fr.E, fr.thickness, False)
        lin = self.mesh.linear  # the film elements' straight triangles, (nel, 3, 2)
        t = lin.t if film.tind is None else lin.t[:, film.tind]
        self.electrode_cover = electrode_coverage(scene, np.transpose(lin.p[:, t], (2, 1, 0)))
        # at the scene's voltages; set .coefficient (film_coefficients) to change them
        self.dielectric = Dielectric(film, film_coefficients(scene, self.electrode_cover))
        self.X = self.membrane.X
        nn = self.X.shape[0]
        self.n_dofs = 3 * nn
        self.lam = scene.prestretch

        chain, s = self.mesh.frame_nodes, self.mesh.frame_s
        s_right, s_left = scene.base_region()
        tol = 1e-9 * scene.outline.length
        held_chain = (s <= s_right + tol) | (s >= s_left - tol)
        self.held_chain = held_chain
        held = np.zeros(nn, bool)
        held[chain[held_chain]] = True
        self.held = held
        self.free = np.flatnonzero(~np.repeat(held, 3))
        self.offset = fr.film_offset_distance
        props = RodProperties(fr.model, fr.EA, fr.EI, fr.EI_strong, fr.GJ)
        self.rod = Rod(self.X, chain, True, held, props, self._directors(),
                       self.offset)
        self.member_rods = member_rods(scene, self.mesh, self.X, held, props)
        self.offset_nodes = np.flatnonzero(~held_chain)  # chain positions moved by the offset
        self.mass = mass_form.assemble(self.mesh.basis).tocsr()

    def _directors(self) -> sp.csr_matrix:
        """Interpolation rows of the director points: the strip's inner edge (a line of mesh
        edges b/2 inside the frame) halfway along each frame edge."""
        inner = self.mesh.frame_inner
        return self.mesh.interpolation(0.5 * (inner + np.roll(inner, -1, axis=0)))[0]

    # ------------------------------------------------------------------ states
    def initial_guess(self, lift: bool = True) -> np.ndarray:
        """Flat reference with (``lift``) the scene's symmetry-breaking lift; the film at z = d."""
        x = self.X.copy()
        if lift:
            x[:, 2] += self.scene.initial_lift(self.X[:, :2])
        x[~self.held, 2] += self.offset
        x[self.mesh.frame_nodes[~self.held_chain], 2] -= self.offset
        return x.ravel()

    def hold(self, x: np.ndarray) -> np.ndarray:
        """``x`` (flattened) with the held nodes at their reference positions: Newton moves only
        the free DOFs, so a start state (e.g. transferred from a coarser mesh, which moves the
        refined nodes of a held fillet with the film) must put the supports where they are."""
        y = x.reshape(-1, 3).copy()
        y[self.held] = self.X[self.held]
        return y.ravel()

    def reference(self) -> np.ndarray:
        """The flat state (the equilibrium at lambda = 1), flattened."""
        return self.X.ravel().copy()

    # ------------------------------------------------------------------ energy
    def _film_positions(self, x: np.ndarray, order: int = 2):
        """Membrane node positions (the film face at the frame) and the strip normals with their
        derivatives that the offset map uses (None without an offset; no derivatives with order 0)."""
        xm = x.copy()
        if self.offset == 0.0:
            return xm, None, None
        chain = self.mesh.frame_nodes
        xm[chain[self.held_chain], 2] += self.offset
        n, ids = self.rod.normals(x, self.offset_nodes, order)
        xm[chain[self.offset_nodes]] += self.offset * n.val
        return xm, n, ids

    def energy(self, y: np.ndarray) -> float:
        """Total energy (N mm) at positions y (3 nn,)."""
        x = y.reshape(-1, 3)
        xm, _, _ = self._film_positions(x, order=0)
        rod = sum(sum(r.evaluate(x, order=0)[0].values()) for r in (self.rod, *self.member_rods))
        strip = 0.0 if self.strip is None else self.strip.energy(x, 1.0)
        return self.membrane.energy(xm, self.lam) + strip + self.dielectric.energy(xm) + rod

    def evaluate(self, y: np.ndarray, order: int = 2) -> Evaluation:
        """Energy parts, gradient and (order 2) tangent at positions y (3 nn,)."""
        x = y.reshape(-1, 3)
        xm, n, ids = self._film_positions(x)
        e_m, g_m, K_m = self.membrane.evaluate(xm, self.lam, order)
        e_d = 0.0
        if np.any(self.dielectric.coefficient):
            e_d, g_d, K_d = self.dielectric.evaluate(xm, order)
            g_m = g_m + g_d
            K_m = K_m + K_d if order >= 2 else None
        rod_e, g_f, K_f = self.rod.evaluate(x, order)
        if self.strip is not None:  # the strip's own material: no offset (members have none), energy in the membrane's
            e_s, g_s, K_s = self.strip.evaluate(x, 1.0, order)
            e_m += e_s
            g_f = g_f + g_s
            K_f = K_f + K_s if order >= 2 else None
        for rod in self.member_rods:
            e, g_r, K_r = rod.evaluate(x, order)
            rod_e = {k: rod_e[k] + e[k] for k in rod_e}
            g_f = g_f + g_r
            K_f = K_f + K_r if order >= 2 else None
        g, K = g_m.copy(), K_m
        if n is not None:
            J1 = self._offset_jacobian(n, ids)
            g = g_m + J1.T @ g_m
            if order >= 2:
                J = sp.identity(self.n_dofs, format="csr") + J1
                K = J.T @ K_m @ J + self._offset_curvature(n, ids, g_m)
        g = g + g_f
        if order >= 2:
            K = (K + K_f).tocsr()
        parts = {
            "membrane": e_m,
            "frame_bending": rod_e["bending"],
            "frame_torsion": rod_e["torsion"],
            "frame_axial": rod_e["axial"],
            "electrostatic": e_d,
        }
        fm = np.linalg.norm(g_m.reshape(-1, 3), axis=1).max()
        return Evaluation(sum(parts.values()), parts, g, K if order >= 2 else None,
                          float(fm) if fm > 0 else 1.0, g_m)

    def _offset_jacobian(self, n, ids) -> sp.csr_matrix:
        """d(offset * n_b)/dy as a sparse (3 nn, 3 nn) matrix."""
        rows_node = self.mesh.frame_nodes[self.offset_nodes]
        S, k = ids.shape
        rows = np.broadcast_to((3 * rows_node[:, None] + np.arange(3))[:, :, None], (S, 3, 3 * k))
        cols = np.broadcast_to(((3 * ids[:, :, None] + np.arange(3)).reshape(S, 1, 3 * k)), (S, 3, 3 * k))
        J = sp.coo_matrix((self.offset * n.grad.ravel(), (rows.ravel(), cols.ravel())),
                          shape=(self.n_dofs, 3 * self.rod.n_points)).tocsr()
        return (J @ self.rod.B3).tocsr()

    def _offset_curvature(self, n, ids, g_m: np.ndarray) -> sp.csr_matrix:
        """sum_b offset * f_b . d2 n_b / dy2, f_b the membrane force on the film at node b."""
        f = g_m.reshape(-1, 3)[self.mesh.frame_nodes[self.offset_nodes]]
        H = self.offset * np.einsum("sc,scij->sij", f, n.hess)
        term = StencilTerms(Jets(np.zeros(len(f)), np.zeros(H.shape[:2]), H), ids)
        _, K = scatter([term], self.rod.n_points, 2)
        return (self.rod.B3.T @ K @ self.rod.B3).tocsr()

    def film_positions(self, y: np.ndarray) -> np.ndarray:
        """Where the membrane nodes are (nn, 3): boundary nodes moved onto the film face."""
        return self._film_positions(y.reshape(-1, 3), order=0)[0]


class RodProblem:
    """A lone rod under dead loads (for checks against the elastica): energy = rod - f . y."""

    def __init__(self, rod: Rod, held: np.ndarray, loads: np.ndarray):
        self.rod = rod
        self.n_dofs = 3 * rod.n_nodes
        self.free = np.flatnonzero(~np.repeat(held, 3))
        self.loads = np.asarray(loads, dtype=float).ravel()
        lengths = np.zeros(rod.n_nodes)
        np.add.at(lengths, rod.edges.ravel(), np.repeat(0.5 * rod.rest_length, 2))
        self.mass = sp.diags(np.repeat(np.maximum(lengths, 1e-12), 3)).tocsr()

    def energy(self, y: np.ndarray) -> float:
        return sum(self.rod.evaluate(y.reshape(-1, 3), order=0)[0].values()) - self.loads @ y

    def evaluate(self, y: np.ndarray, order: int = 2) -> Evaluation:
        parts, g, K = self.rod.evaluate(y.reshape(-1, 3), order)
        g = g - self.loads
        scale = max(np.abs(self.loads).max(), 1e-30)
        return Evaluation(sum(parts.values()) - self.loads @ y, parts, g, K, scale)


class MembraneProblem:
    """A lone membrane on any scikit-fem vector basis, held nodes, dead nodal loads (N).

    Energy = W_membrane(x) - loads . y; for checks against closed forms (pressure, patches).
    """

    def __init__(self, membrane: Membrane, lam: float, held: np.ndarray, loads: np.ndarray):
        self.membrane = membrane
        self.lam = lam
        self.n_dofs = 3 * membrane.n_nodes
        self.free = np.flatnonzero(~np.repeat(held, 3))
        self.loads = np.asarray(loads, dtype=float).ravel()
        self.mass = mass_form.assemble(membrane.basis).tocsr()

    def energy(self, y: np.ndarray) -> float:
        return self.membrane.energy(y.reshape(-1, 3), self.lam) - self.loads @ y

    def evaluate(self, y: np.ndarray, order: int = 2) -> Evaluation:
        e, g, K = self.membrane.evaluate(y.reshape(-1, 3), self.lam, order)
        scale = max(float(np.linalg.norm(g.reshape(-1, 3), axis=1).max()),
                    float(np.abs(self.loads).max()), 1e-30)
        return Evaluation(e - self.loads @ y, {"membrane": e}, g - self.loads, K, scale, g)
