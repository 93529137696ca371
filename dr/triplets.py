"""The node triplets of a model's beams, which the spline beam and the strip act on."""

from __future__ import annotations

from typing import Iterator


def beam_triplets(model, ghost_id: dict, *, strip: bool) -> Iterator[tuple]:
    """(prev, node, next, weight, edge slot before, edge slot after, beam) of every node triplet
    of the strip beams (``strip``) or the isotropic ones of ``model``, beam by beam.

    A closed beam has one triplet per node; an open one per inner node, and at a clamped end
    one with the clamp ghost (row ``ghost_id[(beam number, end)]``) at half weight (the other
    half belongs to the mirrored beam). Edge slots index the beam's orientation (-1: none).
    """
    for b, beam in enumerate(model._beams):
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
