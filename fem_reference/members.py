"""Cross-members in the FEM: a rod along each member's centreline and rigid joints where it
meets the outline.

A member is the same discrete rod as the outline's (:class:`~fem_reference.frame.Rod`), open,
on the mesh nodes of its centreline. Each edge's director point is the midpoint of its ends'
points on the member's bond line, ``frame.bond_lever`` to its left (the film is bonded on both
sides; either turns the section), as the outline's are on its bond line. Where the member meets
the outline, a joint ties them: the rod's vertex energy, with the flat angle as its rest, on the
3-node chains of :func:`scenes.members.member_joints`. Its stiffness is ``FrameSpec.joint_EI`` out of the
film's plane and the strong-axis EI_s in it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from scenes import Scene
from scenes.members import member_joints

from .frame import Rod, RodProperties
from .mesh import MembraneMesh


def _directors(mesh: MembraneMesh, bond_points: np.ndarray) -> sp.csr_matrix:
    """Interpolation rows of each edge's director point: the midpoint of its ends' bond points."""
    return mesh.interpolation(0.5 * (bond_points[:-1] + bond_points[1:]))[0]


def member_rods(scene: Scene, mesh: MembraneMesh, X: np.ndarray, held: np.ndarray, props: RodProperties
                ) -> list[Rod]:
    """The rods of the scene's members (section ``props``, the outline's) and of their joints to
    the outline (:func:`scenes.members.member_joints`), on reference positions X (nn, 3) mm with
    ``held`` (nn,) nodes."""
    fr = scene.frame
    joint = RodProperties(fr.model, 0.0, fr.joint_EI, fr.EI_strong, fr.joint_EI)
    rods = [Rod(X, chain, False, held, props, _directors(mesh, bonds))
            for chain, bonds in zip(mesh.members, mesh.member_inner)]
    for chain, bonds in member_joints(mesh.frame_nodes, mesh.frame_inner, mesh.members, mesh.member_inner):
        rods.append(Rod(X, chain, False, held, joint, _directors(mesh, bonds)))
    return rods
