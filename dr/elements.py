"""The DR element types: each is one module (see docs/elements.md, "Adding an element").

The kernels run them in this order, so it fixes the order in which their forces are summed.
"""

from . import beams, clusters, dielectric, links, rod, strips, triangles

ELEMENTS = (links, clusters, beams, strips, triangles, rod, dielectric)
