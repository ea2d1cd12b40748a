"""The plane objects (fkev_slepc/model/plane.py): lookup by name, errors naming the field and the value,
and the attributes against the models they describe."""

from __future__ import annotations

import numpy as np
import pytest

from builders import bahgat_willmert
from test_out_of_plane import rect_section
from fkev_slepc.model.operators import Model
from fkev_slepc.model.plane import IN, OUT, PLANES, Plane, planes_of
from fkev_slepc.scene.cases import CASES


def test_parse_finds_each_plane_by_its_name():
    assert PLANES == ("in", "out")
    assert [Plane.parse(name) for name in PLANES] == [IN, OUT]
    assert Plane.parse(OUT) is OUT
    assert (IN.suffix, OUT.suffix) == ("", "-out")
    assert planes_of("both") == (IN, OUT) and planes_of("out") == (OUT,)


@pytest.mark.parametrize("value", ["both", "Out", " in", "", None, 1])
def test_parse_names_the_field_and_the_value(value):
    with pytest.raises(ValueError, match=r"^plane: must be one of in, out \(got " + repr(value).replace("(", r"\(")):
        Plane.parse(value)


def test_errors_name_the_flag_given():
    with pytest.raises(ValueError, match=r"^--plane: must be one of in, out \(got 'up'\)$"):
        Plane.parse("up", "--plane")
    with pytest.raises(ValueError, match=r"^--plane: must be one of in, out \(got 'neither'\)$"):
        planes_of("neither", "--plane")


def test_attributes_describe_the_models():
    """The DOFs per node, the absent terms (the out-of-plane model's operators without them are the
    full case's) and the rigid-body loads are those of the Model of each plane."""
    scene = bahgat_willmert(elements=(2, 2, 2))
    for plane in (IN, OUT):
        section = rect_section(scene, 2.07e11, 7760.0) if plane.section else None
        model = Model(scene, plane=plane.name, section=section)
        assert model.mechanism.node_dofs.shape[1] == plane.dofs_per_node == 3
        p = model.pieces(np.radians(10.0))
        assert [getattr(p, t) is not None for t in OUT.absent_terms] == [plane.has_term(t) for t in OUT.absent_terms]
        q = model.qep(p, 1000.0, "full")
        assert (q.damping is not None) == plane.flutter  # a gyroscopic C, or none: K symmetric (§19.6)
        if plane.rigid_loads:
            assert np.any(model.load_pieces(np.radians([10.0])).per_w2 != 0)
        else:
            with pytest.raises(ValueError, match="no rigid-body loads"):
                model.load_pieces(np.radians([10.0]))
    assert all(getattr(CASES["full"], t) for t in OUT.absent_terms)  # the full case has them in plane
