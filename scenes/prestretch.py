"""The film's pre-stretch: isotropic, or unequal along two axes, and the path it is applied on.

``loading.prestretch`` is a number lambda (the same stretch in every direction) or a pair
[l1, l2], the principal pre-stretches along the pre-stretch axes: the scene's x and y turned by
``loading.prestretch_angle`` (deg, counter-clockwise). The solvers apply a pre-stretch along a
path from the flat, unstretched film; the path's value is one number, the larger principal
pre-stretch, and the pair follows the straight line from (1, 1) to the scene's pair:

    l_i(lambda) = 1 + (lambda - 1) (l_i - 1) / (max(l1, l2) - 1).

So a sweep, a continuation step or ``demes solve --prestretch`` names a pre-stretch by that
one number for any scene. The film's rest state is its flat state mapped by P^-1, with the
pre-stretch tensor P = R diag(l1, l2) R^T (R the turn by the angle): a fibre of flat direction
m has the rest length |P^-1 m| per unit flat length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PrestretchPath:
    """The pre-stretch along the solvers' path: ``rise`` (each principal pre-stretch's rise per
    unit rise of the path value; (1, 1) isotropic) and the axes' ``angle_deg``."""

    rise: tuple[float, float] = (1.0, 1.0)
    angle_deg: float = 0.0

    @classmethod
    def of(cls, prestretch: float | tuple[float, float], angle_deg: float = 0.0) -> "PrestretchPath":
        """The path through ``prestretch`` (a number: isotropic; a pair [l1, l2]: unequal)."""
        if isinstance(prestretch, (int, float)):
            return cls()
        l1, l2 = prestretch
        top = max(l1, l2)
        if l1 == l2 or top == 1.0:
            return cls()
        return cls(((l1 - 1.0) / (top - 1.0), (l2 - 1.0) / (top - 1.0)), float(angle_deg))

    @property
    def isotropic(self) -> bool:
        return self.rise == (1.0, 1.0)

    def pair(self, lam: float) -> tuple[float, float]:
        """The principal pre-stretches (l1, l2) at path value ``lam`` (the larger is ``lam`` itself)."""
        return tuple(lam if r == 1.0 else 1.0 + (lam - 1.0) * r for r in self.rise)  # type: ignore[return-value]

    def tensor(self, lam: float) -> np.ndarray:
        """P (2, 2) at path value ``lam``: R diag(l1, l2) R^T in the scene's x, y."""
        l1, l2 = self.pair(lam)
        c, s = math.cos(math.radians(self.angle_deg)), math.sin(math.radians(self.angle_deg))
        R = np.array([[c, -s], [s, c]])
        return R @ np.diag([l1, l2]) @ R.T

    def area_stretch(self, lam: float) -> float:
        """l1 l2: the flat film's area over its unstretched area (its thickness is divided by it)."""
        if self.isotropic:
            return lam * lam
        l1, l2 = self.pair(lam)
        return l1 * l2

    def fibre_stretches(self, lam: float, directions: np.ndarray) -> np.ndarray:
        """Pre-stretch of fibres along flat unit ``directions`` (k, 2): 1 / |P^-1 m|; ``lam``
        for every direction where isotropic."""
        if self.isotropic:
            return np.full(len(directions), float(lam))
        return 1.0 / np.linalg.norm(np.linalg.solve(self.tensor(lam), np.asarray(directions, float).T), axis=0)


def parse_levels(name: str, values: list) -> tuple[tuple[float, float] | None, list[float]]:
    """Pre-stretch levels as a user gives them: numbers (path values, each once, ascending), or
    pairs ("l1,l2" or [l1, l2]) on one line from (1, 1). Returns the farthest pair (None for numbers: the
    scene's own pre-stretch path applies) and the path values. ``name`` is the option or field
    named in an error."""
    from .errors import SceneError
    from .fields import prestretch_spec

    tokens = [v.split(",") if isinstance(v, str) else list(v) if isinstance(v, (list, tuple)) else [v] for v in values]
    parsed = [prestretch_spec(f"{name}[{i}]", [_number(name, p) for p in t] if len(t) > 1 else _number(name, t[0]))
              for i, t in enumerate(tokens)]
    pairs = [p for p in parsed if isinstance(p, tuple)]
    if not pairs:
        return None, sorted(set(parsed))  # type: ignore[arg-type]
    if len(pairs) != len(parsed):
        raise SceneError(f"{name}: give every level as a pair l1,l2 or every level as a number, not both")
    target = max(pairs, key=max)
    path = PrestretchPath.of(target)
    off = [p for p in pairs if max(abs(a - b) for a, b in zip(p, path.pair(max(p)))) > 1e-9 * max(p)]
    if off:
        raise SceneError(
            f"{name}: the pairs must lie on one line from 1,1 (the path the pre-stretch is applied on); "
            f"{off[0][0]:g},{off[0][1]:g} is off the line to {target[0]:g},{target[1]:g}")
    return target, sorted({max(p) for p in pairs})


def _number(name: str, text: object) -> float:
    from .errors import SceneError

    try:
        return float(text)  # type: ignore[arg-type]
    except ValueError:
        raise SceneError(f"{name}: {text!r} is not a number (a level is a ratio such as 1.3, or a pair 1.3,1.0)")
