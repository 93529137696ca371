"""What is modelled, independently of any solver: frame (:mod:`scenes.frame`), membrane,
pre-stretch, supports, mesh.

A scene is a tree of frozen dataclasses. Every field is checked when the scene is built (the
checks: :mod:`scenes.fields`), and a bad field raises :class:`SceneError` naming it
(``frame.corner_radius``) and the fix. Units are mm, N, MPa throughout.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from .errors import SceneError
from .fields import (PRESTRETCH_MAX, Section, between, boolean, finite, gent_jm_value, integer_at_least,
                     non_negative, one_of, optional, permittivity_value, positive, prestretch_list,
                     prestretch_spec, show_value, spec)
from .electrodes import ElectrodeSpec, check_electrodes, electrodes_from_list
from .frame import FrameSpec
from .geometry import Outline
from .prestretch import PrestretchPath

MAX_DIVISIONS = 400
"""Most mesh divisions per side (about 70,000 DR nodes)."""

MAX_GRADING = 16.0
"""Largest mesh.grading: frame spacing h0 / 16 (the finest mesh is limited by MAX_DIVISIONS too)."""

GENT_JM_VHB = 6.0**2 + 2.0 / 6.0 - 3.0
"""Gent's Jm for VHB: a uniaxial locking stretch of 6 (published fits), I1 - 3 = 33.3."""


# ----------------------------------------------------------------------------- sections


def parent_table(data: dict[str, Any], key: str) -> tuple[dict[str, Any], str]:
    """(table, field) that the dotted ``key`` names in a scene mapping (:meth:`Scene.to_dict`);
    an item of an array of tables is named by its name: ``electrodes.left.voltage``."""
    *path, last = key.split(".")
    node: Any = data
    for p in path:
        if isinstance(node, list):
            node = next((item for item in node if isinstance(item, dict) and item.get("name") == p), None)
            if node is None:
                raise SceneError(f"no electrode named {p!r} in {key!r}")
        elif p in node and isinstance(node[p], (dict, list)):
            node = node[p]
        else:
            raise SceneError(f"unknown scene section {p!r} in {key!r}")
    if isinstance(node, list):
        raise SceneError(f"{key!r} names a table, not a field: add the field, e.g. {key}.voltage")
    return node, last


@dataclass(frozen=True)
class MembraneSpec(Section):
    """The pre-stretched film. ``thickness`` is the thickness as mounted (stretched), as in Table I."""

    _prefix = "membrane"
    E: float = spec(1.0, positive, "MPa", "Young's modulus of the film")
    thickness: float = spec(0.05, positive, "mm", "film thickness in the mounted, flat state")
    law: str = spec(
        "linear",
        one_of("linear", "neo-hookean", "gent"),
        "",
        "'linear': Hookean in the engineering strain from the rest state (the DR link law); "
        "'neo-hookean' and 'gent' (locking): incompressible, mu = E / 3",
    )
    gent_jm: float = spec(
        GENT_JM_VHB, gent_jm_value, "",
        "Gent law's Jm = I1 - 3 at locking (default: VHB, uniaxial locking stretch 6); larger is "
        "closer to neo-Hookean",
    )
    tension_only: bool = spec(True, boolean, "", "slack membrane carries no compression")
    permittivity: float = spec(
        4.65, permittivity_value, "", "relative permittivity eps_r of the film (>= 1; VHB 4.65)"
    )
    unstretched_thickness: float | None = spec(
        None,
        optional(positive),
        "mm",
        "film thickness H before pre-stretch, for the electric field; default thickness * l1 l2 "
        "(prestretch^2 where isotropic)",
    )


@dataclass(frozen=True)
class LoadingSpec(Section):
    """Pre-stretch (1.0 = none) and the sweep that ``demes solve`` runs by default. A pair
    [l1, l2] pre-stretches the film unequally along the pre-stretch axes (the scene's x and y
    turned by prestretch_angle). The solvers apply a pair along the straight line from (1, 1),
    and a pre-stretch level (of the sweep, of ``--prestretch``) is its larger member, the other
    following the line: a scene at [1.3, 1.0] is at 1.2 on its path at [1.2, 1.0]."""

    _prefix = "loading"
    prestretch: float | tuple = spec(
        1.5, prestretch_spec, "",
        "pre-stretch ratio (isotropic), or a pair [l1, l2]: the principal pre-stretches along the "
        "pre-stretch axes (x, y turned by prestretch_angle)")
    prestretch_angle: float = spec(
        0.0, between(-180.0, 180.0), "deg",
        "turn of the pre-stretch axes from the scene's x, y (counter-clockwise); read with a pair only")
    sweep: tuple = spec(
        (1.0, 1.1, 1.2, 1.3, 1.4, 1.5, 1.6, 1.7, 1.8, 1.9, 2.0),
        prestretch_list,
        "",
        "pre-stretch levels of a sweep: the ratio, or for a pair its larger member (the other on the "
        "line from 1 to the pair)",
    )
    voltage: float = spec(0.0, non_negative, "V", "voltage across the film's electrodes")


@dataclass(frozen=True)
class SupportSpec(Section):
    """How the base is held: 'taped' pins the base and its corner fillets and clamps the sides."""

    _prefix = "supports"
    base: str = spec(
        "taped",
        one_of("taped", "pinned"),
        "",
        "'taped': base region pinned, side tangents clamped; 'pinned': base nodes pinned only",
    )


@dataclass(frozen=True)
class PerturbationSpec(Section):
    """Symmetry-breaking initial shape: z = (amplitude + asymmetry * x / (L/2)) * (y / H)^2."""

    _prefix = "perturbation"
    amplitude: float = spec(0.5, finite, "mm", "initial apex lift (+ is up)",
                            bounds="|amplitude| <= the base side; not 0 while asymmetry is 0")
    asymmetry: float = spec(0.0, finite, "mm", "antisymmetric lift of the sides (tilt)",
                            bounds="|asymmetry| <= the base side")

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.amplitude == 0.0 and self.asymmetry == 0.0:
            raise SceneError(
                "perturbation.amplitude = 0: the flat state is an unstable equilibrium and "
                "nothing would break its symmetry; give a small lift such as 0.5 mm"
            )


@dataclass(frozen=True)
class MeshSpec(Section):
    """Mesh density: lattice divisions along the base side (DR) / element size side/divisions (FEM)."""

    _prefix = "mesh"
    divisions: int = spec(28, integer_at_least(4, MAX_DIVISIONS), "", "divisions per base side",
                          bounds=f"whole number in [4, {MAX_DIVISIONS}]; divisions x 2^fem.refinement <= {2 * MAX_DIVISIONS}")
    grading: float = spec(
        1.0, between(1.0, MAX_GRADING, why=" (1: uniform; the frame spacing is h0 / grading)"), "",
        "triangle mesh (the FEM's and dr.membrane_net 'triangles'): element size h0 / grading at the outline, "
        "growing by half the distance from it up to h0 = side / divisions inside; 1: uniform. The lattice nets "
        "('clustered', 'links') are uniform",
        bounds=f"[1, {MAX_GRADING:g}]; divisions x grading x 2^fem.refinement <= {2 * MAX_DIVISIONS}")


@dataclass(frozen=True)
class DRSpec(Section):
    """Settings of the dynamic-relaxation solver."""

    _prefix = "dr"
    membrane_net: str = spec(
        "clustered",
        one_of("clustered", "links", "triangles"),
        "",
        "'clustered': one tension per lattice line (the paper); 'links': one per segment; "
        "'triangles': constant-strain triangles on the FEM's mesh at fem.refinement",
    )
    tolerance: float = spec(
        1e-6, between(1e-12, 0.1, why=" (relative residual; below 1e-12 it is round-off)"), "",
        "residual / largest internal force")
    mass_safety: float = spec(
        2.0, between(1.0, 1e3, why=" (below 1 the time step is unstable; 2 is safe)"), "",
        "fictitious mass safety factor f (>= 1)")
    max_iterations: int = spec(3_000_000, integer_at_least(1), "", "time-step limit (per pre-stretch step)")
    prestretch_step: float = spec(
        0.025, non_negative, "", "largest pre-stretch increment on the way to a state (0: all at once)",
        bounds=f"0, or in [0.001, {PRESTRETCH_MAX:g}]")
    prestretch_step_max: float = spec(
        0.0, non_negative, "",
        "largest pre-stretch increment the path grows to away from the flat state (doubling after each "
        "converged step, halved on a stop); 0: every step dr.prestretch_step",
        bounds=f"0, or in [dr.prestretch_step, {PRESTRETCH_MAX:g}]")
    coarse_start: bool = spec(
        True, boolean, "",
        "with 'triangles' at fem.refinement >= 1, from the flat state: follow the path on refinement 0 and "
        "relax its state, interpolated, on the fine mesh")
    check_contact: bool = spec(True, boolean, "", "stop on frame self-contact or membrane folds")
    masses: str = spec(
        "frame", one_of("frame", "tensor", "scalar"), "",
        "'frame': the frame rod's nodes share one sparse mass from its own stiffness, the film tensor "
        "masses; 'tensor': a 3x3 mass per node; 'scalar': Barnes' masses (docs/dynamic_relaxation.md)")
    damping: str = spec(
        "kinetic", one_of("kinetic", "viscous", "fire"), "",
        "'kinetic' (Barnes' kinetic damping), 'viscous' (Underwood's adaptive coefficient) or 'fire' "
        "(Bitzek et al.'s velocity mixing)")

    def __post_init__(self) -> None:
        super().__post_init__()
        if 0.0 < self.prestretch_step < 1e-3 or self.prestretch_step > PRESTRETCH_MAX:
            raise SceneError(
                f"dr.prestretch_step = {self.prestretch_step:g} must be 0 (all at once) or lie in "
                f"[0.001, {PRESTRETCH_MAX:g}]: smaller steps make tens of thousands of relaxations"
            )
        if self.prestretch_step_max and not self.prestretch_step <= self.prestretch_step_max <= PRESTRETCH_MAX:
            raise SceneError(
                f"dr.prestretch_step_max = {self.prestretch_step_max:g} must be 0 (fixed steps) or lie in "
                f"[dr.prestretch_step = {self.prestretch_step:g}, {PRESTRETCH_MAX:g}]: the path grows its "
                "steps from dr.prestretch_step up to it; raise it or set it to 0"
            )


@dataclass(frozen=True)
class FEMSpec(Section):
    """Settings of the finite-element reference."""

    _prefix = "fem"
    element: str = spec("P1", one_of("P1", "P2"), "", "membrane element")
    refinement: int = spec(0, integer_at_least(0, 5), "", "times the element size is halved",
                           bounds=f"whole number in [0, 5]; mesh.divisions x 2^refinement <= {2 * MAX_DIVISIONS}")
    time_limit: float = spec(
        0.0, between(0.0, 1e7), "s", "wall-time budget of one sweep (0: none); spent, the path stops with status 'time_limit'"
    )


@dataclass(frozen=True)
class Scene:
    """A complete DEMES scene. Build with :func:`scenes.load` or :func:`scenes.paper_demes`."""

    name: str = spec("scene", None, "", "the scene's name; the default output folder is named after it",
                     bounds="text of at most 100 characters, no / or \\")
    description: str = spec("", None, "", "what the scene is, in words", bounds="text of at most 10,000 characters")
    frame: FrameSpec = field(default_factory=FrameSpec)
    membrane: MembraneSpec = field(default_factory=MembraneSpec)
    loading: LoadingSpec = field(default_factory=LoadingSpec)
    supports: SupportSpec = field(default_factory=SupportSpec)
    perturbation: PerturbationSpec = field(default_factory=PerturbationSpec)
    mesh: MeshSpec = field(default_factory=MeshSpec)
    dr: DRSpec = field(default_factory=DRSpec)
    fem: FEMSpec = field(default_factory=FEMSpec)
    electrodes: tuple[ElectrodeSpec, ...] = ()

    SECTIONS: ClassVar[dict[str, type]] = {  # the scene's TOML tables and their specs, in file order
        "frame": FrameSpec,
        "membrane": MembraneSpec,
        "loading": LoadingSpec,
        "supports": SupportSpec,
        "perturbation": PerturbationSpec,
        "mesh": MeshSpec,
        "dr": DRSpec,
        "fem": FEMSpec,
    }
    LISTS: ClassVar[dict[str, type]] = {  # the scene's arrays of tables ([[key]]), after the sections
        "electrodes": ElectrodeSpec,
    }

    def __post_init__(self) -> None:
        object.__setattr__(self, "electrodes", electrodes_from_list(self.electrodes))
        for key, limit in (("name", 100), ("description", 10_000)):
            value = getattr(self, key)
            if not isinstance(value, str) or len(value) > limit:
                raise SceneError(f"{key} = {show_value(value)} must be a text of at most {limit} characters")
        if any(c in self.name for c in '/\\\0') or not self.name.isprintable() or self.name in ("", ".", ".."):
            raise SceneError(f"name = {self.name!r} names the output folder: use letters, digits, '_' or '-'")
        side = self.outline.side_length
        for key in ("amplitude", "asymmetry"):
            if abs(getattr(self.perturbation, key)) > side:
                raise SceneError(
                    f"perturbation.{key} = {getattr(self.perturbation, key):g} mm is larger than the "
                    f"frame's base side ({side:.3g} mm): it is a small lift that breaks the symmetry, e.g. 0.5"
                )
        fine = self.mesh.divisions * 2**self.fem.refinement
        if fine > 2 * MAX_DIVISIONS:
            raise SceneError(
                f"mesh.divisions x 2^fem.refinement = {fine} is above {2 * MAX_DIVISIONS}: lower "
                "mesh.divisions or fem.refinement"
            )
        if fine * self.mesh.grading > 2 * MAX_DIVISIONS:
            raise SceneError(
                f"mesh.grading = {self.mesh.grading:g} makes the frame spacing side / {fine * self.mesh.grading:g} "
                f"(mesh.divisions x mesh.grading x 2^fem.refinement), above {2 * MAX_DIVISIONS}: lower "
                "mesh.grading, mesh.divisions or fem.refinement"
            )
        check_electrodes(self.electrodes, self.outline, self.loading.voltage, self.frame.open_regions)

    @property
    def prestretch(self) -> float:
        """The pre-stretch's path value: the ratio, or the larger of a pair (:mod:`scenes.prestretch`)."""
        p = self.loading.prestretch
        return max(p) if isinstance(p, tuple) else p

    @property
    def prestretch_path(self) -> PrestretchPath:
        """How the pre-stretch is applied along the path (isotropic, or a pair's line from 1)."""
        return PrestretchPath.of(self.loading.prestretch, self.loading.prestretch_angle)

    @property
    def outline(self) -> Outline:
        """The frame centreline outline (flat reference, mm)."""
        return self.frame.geometry

    @property
    def spacing(self) -> float:
        """Nominal mesh spacing: base side / divisions, mm."""
        return self.outline.side_length / self.mesh.divisions

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> "Scene":
        """Build and check a scene from a nested mapping (the parsed TOML)."""
        if not isinstance(data, dict):
            raise SceneError("a scene must be a table of sections")
        known = set(cls.SECTIONS) | set(cls.LISTS) | {"name", "description"}
        unknown = sorted(set(data) - known)
        if unknown:
            raise SceneError(
                f"unknown section or field {unknown[0]!r}; a scene has: {', '.join(sorted(known))}"
            )
        kwargs: dict[str, Any] = {k: data[k] for k in ("name", "description") if k in data}
        for key, section in cls.SECTIONS.items():
            if key in data:
                kwargs[key] = section.from_dict(data[key])
        if "electrodes" in data:
            kwargs["electrodes"] = data["electrodes"]  # checked by __post_init__
        return cls(**kwargs)

    def to_dict(self) -> dict[str, Any]:
        """Nested mapping that :meth:`from_dict` turns back into an equal scene."""
        out: dict[str, Any] = {"name": self.name, "description": self.description}
        for key in self.SECTIONS:
            out[key] = getattr(self, key).to_dict()
        if self.electrodes:
            out["electrodes"] = [e.to_dict() for e in self.electrodes]
        return out

    def updated(self, **changes: Any) -> "Scene":
        """A checked copy with fields changed by dotted name: ``updated(**{"frame.model": "strip"})``.

        ``prestretch=1.3`` is short for ``loading.prestretch``; on a scene with a pair, a number
        is a path value and moves the pair along its line (:mod:`scenes.prestretch`). An
        electrode's field is named by the electrode: ``electrodes.left.voltage``.
        """
        data = self.to_dict()
        for key, value in changes.items():
            if key == "prestretch":
                key = "loading.prestretch"
                path = self.prestretch_path
                if not path.isotropic and isinstance(value, (int, float)) and not isinstance(value, bool):
                    value = list(path.pair(float(value)))
            node, last = parent_table(data, key)
            if last not in node and not (node is data and last in self.LISTS):
                raise SceneError(f"unknown scene field {key!r}")
            node[last] = value
        return Scene.from_dict(data)

    def base_region(self) -> tuple[float, float]:
        """Arc lengths (s_right, s_left), mm: frame points with s <= s_right or s >= s_left are held.

        'taped' holds the base and the fillets of its two corners; 'pinned' only the straight base.
        """
        o = self.outline
        if self.supports.base == "taped":
            return o.clamp_arc_lengths()
        first, last = o.pieces[0], o.pieces[-1]
        return first.s_start + first.length, last.s_start

    def clamps(self) -> list[tuple[float, np.ndarray]]:
        """Where the frame tangent is clamped: (arc length mm, unit tangent (3,)) pairs.

        'taped' clamps the side tangents where the base corner fillets end (the whole strip is
        taped flat there); 'pinned' clamps nothing.
        """
        if self.supports.base != "taped":
            return []
        s = np.array(self.outline.clamp_arc_lengths())
        _, tangents = self.outline.evaluate(s)
        return [(float(si), np.array([t[0], t[1], 0.0])) for si, t in zip(s, tangents)]

    def initial_lift(self, xy: np.ndarray) -> np.ndarray:
        """Initial out-of-plane offset z (mm) of points (m, 2): the symmetry-breaking perturbation."""
        o = self.outline
        y = xy[:, 1] / o.height()
        x = xy[:, 0] / o.base_half_length
        p = self.perturbation
        return (p.amplitude + p.asymmetry * x) * np.clip(y, 0.0, None) ** 2
