"""The fictitious masses of a DR state: which kind a model gets, and building them at x."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import frame_mass as fmm
from . import integrator as itg
from .errors import DRError
from .kernels import Packed, stiffness


class Masses(NamedTuple):
    """A time-loop state at rest with its masses built (see :func:`masses_at`)."""

    P: Packed  # the packed model, the frame mass's elements leaving their node blocks to it
    state: itg.State
    frame: fmm.FrameMass  # empty where the model has none
    kind: str  # the masses built: 'frame', 'tensor' or 'scalar'


def masses_at(model, P: Packed, X: np.ndarray, kind: str, safety: float,
              watched: np.ndarray | None = None, segments: np.ndarray | None = None) -> Masses:
    """Masses of ``model`` (packed as ``P``) at positions ``X`` (n_total, 3) mm, changed in
    place by the time loop. ``kind`` 'frame' falls back to 'tensor' where no frame mass can be
    built (:func:`dr.frame_mass.frame_mass_pattern`). ``watched``, ``segments``: the contact
    check's nodes and segments. Raises DRError for a free node that nothing resists."""
    n = P.n
    fm = fmm.frame_mass_pattern(P, model.fixed) if kind == "frame" else None
    if fm is None:
        kind = "scalar" if kind == "scalar" else "tensor"
        fm = fmm.empty(n, P.link_ij.shape[0])
    else:
        # the rods and the links in the frame mass leave their node blocks to it
        P = P._replace(link_block=fm.link_in, rod_blocks=np.zeros((0,) + P.rod_blocks.shape[1:]))
    st = itg.new_state(X, (~model.fixed).astype(float), model.loads, kind != "scalar",
                       np.zeros(n, bool) if watched is None else watched,
                       np.zeros((0, 2), np.int64) if segments is None else segments)
    update(st, P, fm, safety)
    return Masses(P, st, fm, kind)


def update(st: itg.State, P: Packed, fm: fmm.FrameMass, safety: float) -> None:
    """Rebuild the stiffness bounds (beams, cables, strip blocks; all of it for scalar
    masses), the residual and directional blocks, and the masses. A free node that nothing
    resists is an input error."""
    tensor = st.D.shape[0] > 0
    stiffness(st.X, P, st.S, not tensor)
    itg.residual(st, P)
    diag = st.S[: P.n] + (st.D[: P.n, :3].max(axis=1) if tensor else 0.0)
    loose = np.flatnonzero((diag <= 0) & st.free.any(axis=1) & (fm.pos < 0))
    if loose.size:
        unresisted(int(loose[0]), "")
    itg.build_masses(st, 0.5 * safety, fm.pos)
    unresisted(itg.refresh_frame(st, P, fm, 0.5 * safety) if tensor else -1, "")


def unresisted(node: int, when: str) -> None:
    """The input error of a free node without stiffness in some direction (node -1: none)."""
    if node >= 0:
        raise DRError(
            f"node {node} can move but no element resists it{' ' + when if when else ''} (no stiffness); "
            "connect it to an element or support it"
        )
