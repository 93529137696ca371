"""The frame of a scene: the strip's centreline outline, its cross-section, material and model,
and its cross-members; the section's stiffnesses (N, N mm^2) that both solvers take from it."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from .errors import SceneError
from .fields import (Section, between, boolean, member_list, non_negative, one_of, optional, point_list, positive, spec,
                     vertex_list)
from .geometry import Outline, equilateral_triangle
from .members import Member, frame_members, midline_fractions
from .windows import open_windows


@dataclass(frozen=True)
class FrameSpec(Section):
    """The frame strip: outline of its centreline, cross-section, material and model. A frame
    with windows adds cross-members (frame.members): straight strips of the same section, each
    from a point of the outline to another, in the flat scene's x, y (the outline's frame: the
    side from the first vertex to the second along +x, centred on the origin), two of them joined
    rigidly where they cross. They cut the film
    into windows, covered by film except those frame.open_windows names by a point inside each;
    each member is bonded to the film and joined rigidly to the outline where it meets it
    (docs/elements.md, 'Frames with windows'). An [[electrodes]] region per covered window drives
    the windows one by one."""

    _prefix = "frame"
    outline: str = spec("triangle", one_of("triangle", "polygon"), "",
                        "centreline outline: the equilateral triangle of frame.side_length, or the polygon of frame.vertices")
    side_length: float = spec(52.0, between(1e-2, 1e5), "mm", "side of the equilateral triangle (outline = 'triangle')")
    vertices: Any = spec(None, vertex_list, "mm", "polygon corners in any orientation, the side from the first to the second is the base (needed by outline = 'polygon')")
    corner_radius: float = spec(5.0, non_negative, "mm", "fillet radius at every corner", bounds="> frame.width / 2")
    model: str = spec(
        "strip",
        one_of("strip", "paper"),
        "",
        "'strip': weak/strong-axis bending and torsion (curls); 'paper': Table I's isotropic beam with I "
        "(collapses in-plane, docs/elements.md)",
    )
    film_offset: bool = spec(
        False, boolean, "", "film bonded on one face: membrane forces act at t/2 off the centreline"
    )
    film_side: str = spec("top", one_of("top", "bottom"), "", "face the film is bonded to")
    E: float = spec(2600.0, positive, "MPa", "Young's modulus of the strip")
    poisson: float = spec(0.35, between(-1.0, 0.5, low_open=True, high_open=True), "",
                          "Poisson's ratio (torsion: G = E / (2 (1 + nu)))")
    width: float = spec(4.0, positive, "mm", "strip width b (in the membrane plane)")
    thickness: float = spec(0.127, positive, "mm", "strip thickness t", bounds="> 0, < frame.width")
    A: float | None = spec(0.5, optional(positive), "mm^2", "axial area; default b t")
    I: float | None = spec(
        0.0003, optional(positive), "mm^4", "weak-axis / isotropic second moment; default b t^3/12"
    )
    bond_lever: float | None = spec(
        None, optional(positive), "mm",
        "distance from the centreline to the film points that turn the strip's section; default b/2",
        bounds="> 0, <= frame.width, or unset",
    )

    members: Any = spec((), member_list, "mm",
                        "cross-members: straight strips of the frame's section across the film, each from a "
                        "point of the outline to another, [[x1, y1], [x2, y2]]; two may cross (a rigid junction of "
                        "four strips); [] is one window",
                        bounds=f"{member_list.bounds}; inside it, at 30 deg or more to it and to a member it crosses, "
                        "crossings inside the film and apart, members that do not cross apart by frame.width, "
                        "every window wider than frame.width")
    open_windows: Any = spec((), point_list, "mm",
                             "a point inside each window left without film, [x, y]; [] covers every window",
                             bounds=f"{point_list.bounds}; each inside its own window, more than frame.width / 2 "
                             "from its strips; film in one window at least")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.outline == "polygon" and self.vertices is None:
            raise SceneError("frame.outline = 'polygon' needs frame.vertices = [[x, y], ...] (mm)")
        if self.corner_radius <= 0.5 * self.width:
            raise SceneError(
                f"frame.corner_radius = {self.corner_radius:g} mm must exceed half the strip width "
                f"(frame.width / 2 = {0.5 * self.width:g} mm): a flat strip bent round a tighter "
                "corner folds over itself at its inner edge"
            )
        if self.thickness >= self.width:
            raise SceneError(
                f"frame.thickness = {self.thickness:g} mm must be smaller than frame.width = "
                f"{self.width:g} mm: the strip bends about its weak axis out of the membrane plane"
            )
        if self.bond_lever is not None and self.bond_lever > self.width:
            raise SceneError(
                f"frame.bond_lever = {self.bond_lever:g} mm must not exceed frame.width = "
                f"{self.width:g} mm: the film is bonded across the strip, not beyond it"
            )
        _ = self.open_regions  # build (and so check) the outline, its members and open windows now
        if self.members and self.film_offset:
            raise SceneError("frame.film_offset = true is not modelled with frame.members (a film on one "
                             "face of crossing strips); set frame.film_offset = false")

    @cached_property
    def geometry(self) -> Outline:
        """The centreline outline in the canonical frame (base on the x axis)."""
        if self.outline == "triangle":
            return Outline(equilateral_triangle(self.side_length), self.corner_radius)
        return Outline(np.array(self.vertices), self.corner_radius)

    @cached_property
    def cross_members(self) -> tuple[Member, ...]:
        """The checked cross-members in the outline's frame (empty: one window)."""
        return frame_members(self.geometry, self.members, self.width, self.lever)

    @cached_property
    def open_regions(self) -> tuple:
        """The open windows' regions (shapely polygons, centreline to centreline, mm), in the
        order of ``open_windows``."""
        return open_windows(self.geometry, self.cross_members, self.width, self.open_windows)

    @cached_property
    def segment_bounds(self) -> np.ndarray | None:
        """Where the members cross the frame's midline, as fractions of the way from the base to
        the apex (:func:`scenes.members.midline_fractions`); None unless the windows are in a
        row."""
        return midline_fractions(self.geometry, self.cross_members)

    @property
    def joint_EI(self) -> float:
        """Out-of-plane stiffness (N mm^2) of a member's joint to the outline: the stiffer of
        the strip's weak-axis bending and torsion (a relative rotation about the outline's
        tangent bends the member and twists the outline, about the member's the reverse), so the
        junction of three strips is as stiff as the strips over the joint's Voronoi length; in
        the plane the joint has the strong-axis EI_s. Isotropic EI for model = 'paper'."""
        return max(self.EI, self.GJ) if self.model == "strip" else self.EI

    @property
    def lever(self) -> float:
        """Bond lever (mm): where, inside the centreline, the film turns the strip's section."""
        return self.bond_lever if self.bond_lever is not None else 0.5 * self.width

    @property
    def area(self) -> float:
        """Axial cross-section area, mm^2."""
        return self.A if self.A is not None else self.width * self.thickness

    @property
    def EA(self) -> float:
        """Axial stiffness, N."""
        return self.E * self.area

    @property
    def EI(self) -> float:
        """Weak-axis (out-of-membrane-plane) bending stiffness, N mm^2; isotropic for 'paper'."""
        i = self.I if self.I is not None else self.width * self.thickness**3 / 12
        return self.E * i

    @property
    def EI_strong(self) -> float:
        """Strong-axis (in-plane) bending stiffness E t b^3 / 12, N mm^2."""
        return self.E * self.thickness * self.width**3 / 12

    @property
    def GJ(self) -> float:
        """Saint-Venant torsional stiffness of a thin strip, N mm^2.

        J = b t^3 / 3 (1 - 0.63 t / b), the thin-rectangle formula (Roark).
        """
        g = self.E / (2 * (1 + self.poisson))
        b, t = self.width, self.thickness
        return g * b * t**3 / 3 * (1 - 0.63 * t / b)

    @property
    def film_offset_distance(self) -> float:
        """Signed normal offset (mm, + towards the top face) at which the film acts; 0 if off."""
        if not self.film_offset:
            return 0.0
        return (0.5 if self.film_side == "top" else -0.5) * self.thickness
