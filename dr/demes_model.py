"""The DR model of a DEMES scene: the paper's net (links or clustered cables) or membrane
triangles on the FEM's mesh (``dr.membrane_net = "triangles"``), with the frame, its supports,
the symmetry-breaking lift, the contact checks and the model's mirror map."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial import cKDTree

from results.path import neutral_stiffness
from scenes import Scene, SceneError
from scenes.electric import electrode_coverage, film_coefficients, highest_voltage
from scenes.fields import prestretch_value
from scenes.members import member_joints
from scenes.mesh import membrane_mesh

from .contact import FilmCrossing, FrameContact, MembraneFold
from .model import Model
from .net import Net, build_net
from .symmetry import Symmetry, model_symmetries


@dataclass
class DemesModel:
    """A scene's DR model and what the result needs to know about it."""

    model: Model
    net: Net | None  # the paper's lattice (None for triangles)
    start: np.ndarray  # (n, 3) initial positions with the symmetry-breaking lift, mm
    contact: FrameContact | None
    final_checks: list
    mirror: np.ndarray | None  # node index of each node's mirror image (x -> -x), if symmetric
    cable_area: float  # mm^2, of a cable at the net's spacing (the force scale)
    frame_nodes: np.ndarray  # frame node ids along the outline from the base midpoint
    frame_s: np.ndarray  # their arc lengths, mm
    spacing: float  # mm
    neutral: float  # N/mm^3, results.path.neutral_stiffness
    symmetries: list[Symmetry]  # the model's (dr.symmetry.model_symmetries)
    members: tuple[np.ndarray, ...] = ()  # node ids along each cross-member (scenes.mesh.TriangleMesh.members)
    strip_band: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int64))  # open windows' bands


def check_voltage_net(scene: Scene, voltage: float) -> None:
    """A voltage needs a net that holds its nodes in the plane: the clustered net's nodes slide
    along their cables, and the dielectric's softening folds it at once (measured: Table I,
    strip, 28 divisions, folded between 125 V and 148 V)."""
    if voltage > 0 and scene.dr.membrane_net == "clustered":
        raise SceneError(
            f"a voltage ({voltage:g} V) with dr.membrane_net = 'clustered': its nodes slide along "
            "their cables and the film's electrostatic softening folds the net; use "
            "dr.membrane_net = 'links' or 'triangles'")


def cable_area(scene: Scene, spacing: float) -> float:
    """Cable area (mm^2) that makes the net a film of the scene's thickness: A = sqrt(3)/2 h s.

    A triangular net of links EA at spacing s is, for small strains, an isotropic membrane
    with E t = 2/sqrt(3) EA/s and Poisson's ratio 1/3 (docs/elements.md, 'The film as a net of cables').
    """
    return np.sqrt(3) / 2 * scene.membrane.thickness * spacing


def build(scene: Scene, prestretch: float | None = None) -> DemesModel:
    """Build the DR model of ``scene`` at ``prestretch`` (default: the scene's)."""
    lam = scene.prestretch if prestretch is None else prestretch_value("pre-stretch", prestretch)
    check_voltage_net(scene, highest_voltage(scene))
    if scene.prestretch_path.isotropic:
        return _build(scene, lam)
    # unequal pre-stretch: built unstretched, then every membrane element given the tensor; the
    # symmetries are those of the film off the flat state (at lambda = 1 the tensor is I, and an
    # angled pre-stretch's lost mirror would not show)
    dm = _build(scene, 1.0)
    set_prestretch(dm.model, scene, max(scene.prestretch, lam, SYMMETRY_PROBE))
    symmetries = model_symmetries(dm.model, dm.mirror)
    set_prestretch(dm.model, scene, lam)
    return replace(dm, symmetries=symmetries)


SYMMETRY_PROBE = 1.5
"""Path value at which an unequal pre-stretch's symmetries are found if the path stays below it."""


def set_prestretch(model: Model, scene: Scene, lam: float, current: float | None = None) -> None:
    """Give ``model``'s membrane the pre-stretch of ``scene`` at path value ``lam``; ``current``:
    the path value it has now (isotropic: its rest lengths are scaled by current / lam)."""
    path = scene.prestretch_path
    if path.isotropic:
        model.scale_membrane_rest_lengths(current / lam)
    else:
        model.set_membrane_prestretch(path.tensor(lam))


def _build(scene: Scene, lam: float) -> DemesModel:
    """The DR model at the isotropic pre-stretch ``lam``."""
    if scene.frame.film_offset:
        raise SceneError("frame.film_offset = true (the film on the strip's face) is modelled by the FEM "
                         "reference only; set frame.film_offset = false for DR")
    if scene.dr.membrane_net == "triangles":
        return _build_triangles(scene, lam)
    if scene.frame.members:
        raise SceneError(f"frame.members (a frame with windows) is modelled on the scene's triangle mesh: set "
                         f"dr.membrane_net = \"triangles\" (the paper's {scene.dr.membrane_net} net has no "
                         "member lines)")
    if scene.membrane.law != "linear":
        raise SceneError(
            f"membrane.law = {scene.membrane.law!r}: the DR net models the 'linear' (Hookean cable) "
            f"law only; use dr.membrane_net = 'triangles' or the FEM reference for {scene.membrane.law!r}"
        )
    outline = scene.outline
    s_right, s_left = scene.base_region()
    clamps = scene.clamps()
    landmarks = [0.0, outline.apex_arc_length(), s_right, s_left, *outline.breakpoints()]
    frame = scene.frame
    net = build_net(outline, scene.mesh.divisions, landmarks, frame.lever)
    nf = net.n_frame
    fs = net.frame_s
    held = (fs <= s_right + 1e-9) | (fs >= s_left - 1e-9)
    m = Model(net.nodes)
    m.triangles = net.triangles
    m.support(np.flatnonzero(held))

    if frame.model == "strip":
        # the FEM's rod: each edge's strip plane passes through its bond nodes, frame.bond_lever
        # inside, at every mesh density (docs/discrete-problem.md)
        m.add_rod(np.arange(nf), EA=frame.EA, EI=frame.EI, closed=True, EI_strong=frame.EI_strong,
                  GJ=frame.GJ, bond=net.bond_nodes)
    else:
        # the paper's isotropic spline beam on the free part, clamped where the tape ends
        chain = np.arange(nf)
        if clamps:
            r, l = net.frame_node_at(clamps[0][0]), net.frame_node_at(clamps[1][0])
            for (_, tangent), node in zip(clamps, (r, l)):
                m.clamp(node, tangent, taped=True)
            chain = chain[r:l + 1]
        m.add_beam(chain, EI=frame.EI, EA=frame.EA, closed=not clamps)

    # membrane: the row between centreline and bond line as triangles; inside, the lattice
    # lines as clustered cables (the paper) or one link per segment
    mem = scene.membrane
    m.add_triangles(net.row_triangles, E=mem.E, thickness=mem.thickness, prestretch=lam, law="linear",
                    tension_only=mem.tension_only)
    for cable, film in zip(net.cables, net.cable_film):
        flat = np.linalg.norm(np.diff(net.nodes[cable], axis=0), axis=1)
        # the cable carries the film it stands for: E h (film area) / (cable length), which is
        # E A inside the lattice and makes up for the lattice's margin at the bond line
        EA = mem.E * mem.thickness * film / flat.sum()
        if scene.dr.membrane_net == "clustered":
            m.add_cluster(cable, EA, rest_length=flat.sum() / lam, tension_only=mem.tension_only)
        else:
            m.add_link(cable[:-1], cable[1:], EA, rest_length=flat / lam, tension_only=mem.tension_only)

    m.add_dielectric(net.triangles, film_coefficients(scene, electrode_coverage(scene, net.nodes[net.triangles])))
    start = net.nodes.copy()
    start[:, 2] += np.where(m.fixed[:, 2], 0.0, scene.initial_lift(net.nodes[:, :2]))
    contact, final_checks = None, []
    if scene.dr.check_contact:
        contact = FrameContact(np.arange(nf), frame.thickness)
        final_checks = [MembraneFold(net.triangles, net.nodes), FilmCrossing(net.triangles, np.arange(nf))]
    mirror = _mirror_map(net.nodes)
    return DemesModel(m, net, start, contact, final_checks, mirror, cable_area(scene, net.spacing),
                      np.arange(nf), net.frame_s, net.spacing, neutral_stiffness(scene), model_symmetries(m, mirror))


def _build_triangles(scene: Scene, lam: float) -> DemesModel:
    """Constant-strain triangles on the scene's mesh at ``fem.refinement`` with the frame rod
    of bond points: the FEM reference's discrete problem (docs/discrete-problem.md)."""
    frame = scene.frame
    mesh = membrane_mesh(scene, scene.fem.refinement)
    nodes = np.column_stack([mesh.nodes, np.zeros(len(mesh.nodes))])
    m = Model(nodes)
    film = mesh.film_triangles
    m.triangles = film
    s_right, s_left = scene.base_region()
    tol = 1e-9 * scene.outline.length
    held = (mesh.frame_s <= s_right + tol) | (mesh.frame_s >= s_left - tol)
    m.support(mesh.frame_nodes[held])
    mem = scene.membrane
    m.add_triangles(film, E=mem.E, thickness=mem.thickness, prestretch=lam, law=mem.law,
                    tension_only=mem.tension_only, gent_jm=mem.gent_jm)
    if mesh.strip_band.any():  # the open windows' strip bands: the strip's material (scenes.windows)
        m.add_triangles(mesh.band_triangles, E=frame.E, thickness=frame.thickness, prestretch=1.0, law="linear",
                        tension_only=False, film=False)
    strip = frame.model == "strip"
    m.add_rod(mesh.frame_nodes, EA=frame.EA, EI=frame.EI, closed=True,
              EI_strong=frame.EI_strong if strip else None, GJ=frame.GJ if strip else None,
              bond=mesh.bond_nodes if strip else None)
    for chain, bonds in zip(mesh.members, mesh.member_bonds):
        m.add_rod(chain, EA=frame.EA, EI=frame.EI, EI_strong=frame.EI_strong if strip else None,
                  GJ=frame.GJ if strip else None, bond=bonds if strip else None)
    for chain, bonds in member_joints(mesh.frame_nodes, mesh.bond_nodes, mesh.members, mesh.member_bonds):
        m.add_rod(chain, EA=0.0, EI=frame.joint_EI, EI_strong=frame.EI_strong if strip else None,
                  GJ=frame.joint_EI if strip else None, bond=bonds if strip else None)
    m.add_dielectric(film, film_coefficients(scene, electrode_coverage(scene, nodes[film])))
    start = nodes.copy()
    start[:, 2] += np.where(m.fixed[:, 2], 0.0, scene.initial_lift(nodes[:, :2]))
    contact, final_checks = None, []
    if scene.dr.check_contact:
        contact = FrameContact(mesh.frame_nodes, frame.thickness)
        final_checks = [MembraneFold(film, nodes), FilmCrossing(film, mesh.frame_nodes)]
    mirror = _mirror_map(nodes)
    return DemesModel(m, None, start, contact, final_checks, mirror, cable_area(scene, mesh.spacing),
                      mesh.frame_nodes, mesh.frame_s, mesh.spacing, neutral_stiffness(scene),
                      model_symmetries(m, mirror), mesh.members, mesh.band_triangles)


def _mirror_map(nodes: np.ndarray) -> np.ndarray | None:
    """Index of each node's mirror image across x = 0, or None if the model is not symmetric."""
    dist, idx = cKDTree(nodes).query(nodes * [-1.0, 1.0, 1.0])
    scale = np.ptp(nodes[:, 0]) or 1.0
    return idx if np.all(dist < 1e-9 * scale) else None
