"""The DR element registry: what each registered module must hold, and that the kernels' record
and the model are made from the registry alone (docs/elements.md, "Adding an element")."""

import numpy as np
import pytest

import dr
from dr.elements import ELEMENTS
from dr.kernels import Packed, Virtual

PARTS = ("Fields", "pack", "gradient", "strain_energy", "stiffness", "forces", "edges", "stencils")


@pytest.mark.parametrize("element", ELEMENTS, ids=lambda e: e.__name__)
def test_a_registered_element_module_has_every_part(element):
    missing = [p for p in PARTS if not hasattr(element, p)]
    assert not missing, f"{element.__name__} lacks {missing}"


def test_the_kernels_record_is_the_virtual_nodes_then_each_element_in_registry_order():
    expected = list(Virtual._fields) + [f for e in ELEMENTS for f in e.Fields._fields]
    assert list(Packed._fields) == expected
    assert len(set(expected)) == len(expected), "two element types name an array alike"


def test_the_model_has_each_registered_add_method_and_packs_absent_types_empty():
    for e in ELEMENTS:
        for name in vars(getattr(e, "Methods", object)):
            if not name.startswith("__"):
                assert hasattr(dr.Model, name), name
    x = np.zeros((5, 3))
    x[:, 0] = np.arange(5.0)
    m = dr.Model(x)
    m.clamp(0, (1.0, 0.0, 0.0))
    m.add_beam(range(5), EI=1.0, EA=10.0)
    P = m.pack()
    present = {e.__name__.split(".")[-1]: getattr(P, e.Fields._fields[0]).shape[0] for e in ELEMENTS}
    # a beam with EA: the spline beam's triplets (3 inner nodes and the clamp's) and 4 axial links
    assert {k: v for k, v in present.items() if v} == {"links": 4, "beams": 4}
