"""MorphologyBuilder: structure, topological order, layout, and every structural bad-input class."""

import math

import numpy as np
import pytest

from morphkit.errors import DescriptionError, GraphError, MorphkitError, SourceLocation
from morphkit.graph import (
    BaseType,
    EndEffectorRole,
    JointType,
    Limit,
    Mimic,
    MorphologyBuilder,
    Shape,
    ShapeType,
    Transform,
)

LIM = Limit(-1.0, 1.0)


def chain_builder(n=3, *, base="floating"):
    """A serial chain l0 - l1 - ... with revolute joints about z, 1 m apart along x."""
    b = MorphologyBuilder("chain", source="chain.yaml")
    b.set_base(base)
    for i in range(n):
        b.add_link(f"l{i}", location=SourceLocation("chain.yaml", 10 + i))
    for i in range(1, n):
        b.add_joint_revolute(
            f"j{i}",
            f"l{i - 1}",
            f"l{i}",
            origin=Transform((1.0, 0, 0)),
            axis=(0, 0, 1),
            limit=LIM,
            location=SourceLocation("chain.yaml", 20 + i),
        )
    return b


def test_topological_order_is_depth_first_whatever_the_insertion_order():
    b = MorphologyBuilder("tree")
    for name in ("a2", "body", "a1", "b1", "b2"):
        b.add_link(name)
    # Joints added leaf-first: the builder must still put every parent before its child.
    b.add_joint_fixed("ja2", "a1", "a2")
    b.add_joint_fixed("jb2", "b1", "b2")
    b.add_joint_fixed("ja1", "body", "a1")
    b.add_joint_fixed("jb1", "body", "b1")
    m = b.build()
    assert m.root == "body"
    assert m.link_names[0] == "body"
    for j, link in zip(m.joints, m.links[1:], strict=True):
        assert j.child == link.name
        assert m.link_index(j.parent) < m.link_index(j.child)
    # each limb contiguous (depth-first preorder)
    assert m.joint_names in (("ja1", "ja2", "jb1", "jb2"), ("jb1", "jb2", "ja1", "ja2"))
    assert m.children("body") == ("a1", "b1") or m.children("body") == ("b1", "a1")
    assert m.chain("a2") == ("ja1", "ja2")


def test_coordinate_layout_per_joint_and_base_type():
    b = MorphologyBuilder("mix")
    for n in ("r", "a", "b", "c", "d", "e", "f"):
        b.add_link(n)
    b.set_base("wheeled")
    b.add_joint_revolute("rev", "r", "a", axis=(0, 1, 0), limit=LIM)
    b.add_joint_spherical("sph", "a", "b")
    b.add_joint_prismatic("pri", "b", "c", axis=(0, 0, 1), limit=Limit(0.0, 0.5))
    b.add_joint_fixed("fix", "c", "d")
    b.add_joint_continuous("wheel", "r", "e", axis=(0, 1, 0))
    b.add_joint_revolute("mim", "a", "f", axis=(1, 0, 0), limit=LIM, mimic=Mimic("rev", -2.0, 0.1))
    b.set_wheels(["wheel"], 0.1)
    m = b.build()
    assert m.base == BaseType.WHEELED
    assert m.base_coordinate_count == 3 and m.base_dof == 2
    # rev 1 + sph 4 + pri 1 (+ wheel, mimic, fixed: 0)
    assert m.coordinate_count == 3 + 6
    assert m.dof == 1 + 3 + 1
    names = m.coordinate_names
    assert names[:3] == ("base_x", "base_y", "base_yaw")
    assert set(names[3:]) == {"rev", "sph.qx", "sph.qy", "sph.qz", "sph.qw", "pri"}
    lower, upper = m.coordinate_limits
    i = names.index("pri")
    assert (lower[i], upper[i]) == (0.0, 0.5)
    q = m.rest_q()
    assert q[names.index("sph.qw")] == 1.0
    assert [m.is_driven(j) for j in m.joints].count(True) == 2


def test_characteristic_length_is_rest_height():
    b = MorphologyBuilder("stick")
    b.add_link("hip")
    b.add_link("foot")
    b.add_link("head")
    b.add_joint_fixed("leg", "hip", "foot", origin=Transform((0, 0, -0.9)))
    b.add_joint_fixed("torso", "hip", "head", origin=Transform((0, 0, 0.8)))
    b.add_end_effector("top", "head", offset=(0, 0, 0.1), role="head")
    m = b.build()
    assert m.characteristic_length == pytest.approx(1.8)


def test_axis_and_origin_rotation_are_normalised():
    b = chain_builder(2)
    b2 = MorphologyBuilder("x")
    b2.add_link("a")
    b2.add_link("b")
    b2.add_joint_revolute("j", "a", "b", axis=(0, 0, 5), limit=LIM, origin=Transform((0, 0, 0), (0, 0, 0, 2)))
    m = b2.build()
    assert m.joints[0].axis == (0.0, 0.0, 1.0)
    assert m.joints[0].origin.quat == (0.0, 0.0, 0.0, 1.0)
    assert b.build().dof == 1


@pytest.mark.parametrize(
    ("mutate", "message", "line"),
    [
        (lambda b: b.add_link("l1", location=SourceLocation("chain.yaml", 99)), "duplicate link", 99),
        (
            lambda b: b.add_joint_fixed("j1", "l0", "l2", location=SourceLocation("chain.yaml", 98)),
            "duplicate joint",
            98,
        ),
        (
            lambda b: b.add_joint_revolute(
                "z", "l0", "l2", axis=(0, 0, 0), limit=LIM, location=SourceLocation("chain.yaml", 97)
            ),
            "zero axis",
            97,
        ),
        (
            lambda b: b.add_joint_revolute(
                "z", "l0", "l2", limit=Limit(1.0, -1.0), location=SourceLocation("chain.yaml", 96)
            ),
            "lower 1.0 > upper -1.0",
            96,
        ),
        (
            lambda b: b.add_joint_revolute(
                "z", "l0", "l2", limit=Limit(-math.inf, 1.0), location=SourceLocation("chain.yaml", 95)
            ),
            "non-finite",
            95,
        ),
        (
            lambda b: b.add_joint_fixed(
                "z", "l0", "l2", origin=Transform(("a", 0, 0)), location=SourceLocation("chain.yaml", 94)
            ),
            "expected a number",
            94,
        ),
        (
            lambda b: b.add_joint_revolute("z", "l0", "l2", location=SourceLocation("chain.yaml", 93)),
            "needs a limit",
            93,
        ),
        (
            lambda b: b.add_end_effector("e", "l2", role="claw", location=SourceLocation("chain.yaml", 92)),
            "unknown end-effector role 'claw'; expected one of: foot, hand, head, tool",
            92,
        ),
        (
            lambda b: b.add_joint("z", "hinge", "l0", "l2", location=SourceLocation("chain.yaml", 91)),
            "unknown joint type 'hinge'",
            91,
        ),
        (lambda b: b.set_base("hovering", location=SourceLocation("chain.yaml", 2)), "unknown base type", 2),
        (
            lambda b: b.add_link(
                "s", shapes=[Shape(ShapeType.SPHERE, radius=-1.0)], location=SourceLocation("chain.yaml", 90)
            ),
            "radius must be > 0",
            90,
        ),
    ],
)
def test_element_errors_name_the_line(mutate, message, line):
    b = chain_builder()
    with pytest.raises(MorphkitError) as info:
        mutate(b)
    assert message in str(info.value)
    assert info.value.location == SourceLocation("chain.yaml", line)
    assert str(info.value).startswith(f"chain.yaml:{line}: ")


@pytest.mark.parametrize(
    ("mutate", "message", "line"),
    [
        (
            lambda b: b.add_joint_fixed("x", "l0", "nowhere", location=SourceLocation("chain.yaml", 80)),
            "missing link 'nowhere'",
            80,
        ),
        (
            lambda b: b.add_joint_fixed("x", "l0", "l2", location=SourceLocation("chain.yaml", 81)),
            "two parents",
            81,
        ),
        (
            lambda b: b.add_end_effector("e", "ghost", location=SourceLocation("chain.yaml", 82)),
            "unknown link 'ghost'",
            82,
        ),
        (
            lambda b: b.add_link("island", location=SourceLocation("chain.yaml", 83)),
            "several links have no parent",
            83,  # the parentless link other than the first one
        ),
        (lambda b: b.set_root("l1", location=SourceLocation("chain.yaml", 3)), "has a parent", 21),
    ],
)
def test_structural_errors_at_build(mutate, message, line):
    b = chain_builder()
    mutate(b)
    with pytest.raises(GraphError) as info:
        b.build()
    assert message in str(info.value)
    assert info.value.location.path == "chain.yaml"
    assert info.value.location.line == line


def test_cycle_and_disconnected_links():
    b = chain_builder()
    b.add_link("x", location=SourceLocation("c.yaml", 5))
    b.add_link("y", location=SourceLocation("c.yaml", 6))
    b.add_joint_fixed("xy", "x", "y", location=SourceLocation("c.yaml", 7))
    b.add_joint_fixed("yx", "y", "x", location=SourceLocation("c.yaml", 8))
    with pytest.raises(GraphError, match="cycle"):
        b.build()
    b = chain_builder()
    b.add_link("x")
    b.add_link("y")
    b.add_joint_fixed("xy", "x", "y")
    b.set_root("l0")
    with pytest.raises(GraphError, match="'x' is not connected to the root 'l0'"):
        b.build()
    ring = MorphologyBuilder("ring")
    ring.add_link("a")
    ring.add_link("b")
    ring.add_joint_fixed("ab", "a", "b")
    ring.add_joint_fixed("ba", "b", "a")
    with pytest.raises(GraphError, match="cycle"):
        ring.build()


def test_wheels_and_mimic_validation():
    b = chain_builder(base="floating")
    b.set_wheels(["j1"], 0.1)
    with pytest.raises(GraphError, match="wheeled base"):
        b.build()
    b = chain_builder(base="wheeled")
    b.set_wheels(["j1"], 0.1)
    with pytest.raises(GraphError, match="continuous joint"):
        b.build()
    b = chain_builder()
    b.add_link("m")
    b.add_joint_revolute("jm", "l0", "m", limit=LIM, mimic=Mimic("nope"))
    with pytest.raises(GraphError, match="mimics unknown joint 'nope'"):
        b.build()
    with pytest.raises(GraphError, match="radius must be > 0"):
        chain_builder(base="wheeled").set_wheels(["j1"], 0.0)


def test_errors_are_one_hierarchy():
    assert issubclass(GraphError, MorphkitError) and issubclass(DescriptionError, MorphkitError)
    assert JointType.SPHERICAL == 4 and EndEffectorRole.FOOT == 0
    assert np.isfinite(chain_builder().build().characteristic_length)
