"""compile_model: array layout against the Morphology it came from, wheels, shapes, device mirrors."""

import numpy as np
import pytest
import warp as wp
from morphkit_testing import ALL_CREATURES, creature, every_joint, mimic, planar_arm, wheeled

from morphkit.errors import GraphError
from morphkit.graph import BaseType, JointType, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.model import KinematicModel, compile_model


@pytest.mark.parametrize("name", ALL_CREATURES)
def test_layout_matches_morphology(name):
    m = creature(name)
    k = compile_model(m)
    assert isinstance(k, KinematicModel)
    assert k.link_count == m.link_count and k.joint_count == m.joint_count
    assert k.coordinate_count == m.coordinate_count and k.dof == m.dof
    assert k.base_coordinate_count == m.base_coordinate_count
    assert k.coordinate_names == m.coordinate_names
    np.testing.assert_array_equal(k.joint_q_start, m.joint_q_start)
    np.testing.assert_array_equal(k.joint_qd_start, m.joint_qd_start)
    np.testing.assert_array_equal(k.link_parent, m.link_parent)
    # Topological order: every parent comes before its child, and link j + 1 is joint j's child.
    for j, joint in enumerate(m.joints):
        assert k.joint_parent[j] == m.link_index(joint.parent) < j + 1
        assert k.link_names[j + 1] == joint.child
        assert k.joint_type[j] == int(joint.type)
        np.testing.assert_allclose(k.joint_X_parent[j], joint.origin.as_array())
    np.testing.assert_allclose(k.rest_q, m.rest_q())
    lo, hi = m.coordinate_limits
    np.testing.assert_array_equal(k.coordinate_lower, lo)
    np.testing.assert_array_equal(k.coordinate_upper, hi)
    assert k.ee_names == tuple(e.name for e in m.end_effectors)
    for e, ee in enumerate(m.end_effectors):
        assert k.link_names[k.ee_link[e]] == ee.link
        np.testing.assert_allclose(k.ee_offset[e], ee.offset)
        assert k.ee_role[e] == int(ee.role)
    assert not k.joint_X_parent.flags.writeable


def test_base_widths():
    widths = {"floating": 7, "planar": 3, "wheeled": 3, "fixed": 0}
    for base, width in widths.items():
        k = compile_model(every_joint(base))
        assert k.base_type == BaseType[base.upper()]
        assert k.base_coordinate_count == width
        # revolute 1 + spherical 4 + prismatic 1 + continuous 1 + fixed 0 + revolute 1 + spherical 4 + revolute 1
        assert k.coordinate_count == width + 13


def test_mimic_fields():
    k = compile_model(mimic())
    j = k.joint_index("finger_b")
    assert k.joint_mimic_target[j] == k.joint_index("finger_a")
    assert k.joint_mimic_multiplier[j] == -1.0 and k.joint_mimic_offset[j] == 0.1
    assert k.joint_q_start[j + 1] == k.joint_q_start[j]  # driven: no coordinate of its own
    assert k.coordinate_count == 2
    assert (k.joint_mimic_target[[k.joint_index("wrist"), k.joint_index("finger_a")]] == -1).all()


def test_wheels():
    k = compile_model(wheeled(radius=0.05, track=0.3))
    assert k.wheel_count == 2 and k.wheel_radius == 0.05
    left, right = k.joint_index("wheel_l_joint"), k.joint_index("wheel_r_joint")
    np.testing.assert_array_equal(k.wheel_joint, [left, right])
    assert k.joint_wheel[left] == 0 and k.joint_wheel[right] == 1
    np.testing.assert_allclose(k.wheel_lateral, [0.15, -0.15])
    np.testing.assert_array_equal(k.wheel_sign, [1.0, -1.0])  # the right wheel's axis points right
    assert k.coordinate_names == ("base_x", "base_y", "base_yaw", "lift", "pan")


def test_wheel_axis_must_point_sideways():
    b = MorphologyBuilder("bad_wheel")
    b.set_base("wheeled")
    b.add_link("chassis")
    b.add_link("wheel")
    b.add_joint_continuous("w", "chassis", "wheel", origin=Transform((0, 0.1, 0.05)), axis=(0, 0, 1))
    b.set_wheels(["w"], 0.05)
    with pytest.raises(GraphError, match=r"wheel 'w'.*sideways"):
        compile_model(b.build())


def test_shapes():
    b = MorphologyBuilder("shapes")
    b.set_base("fixed")
    b.add_link("a", shapes=[Shape(ShapeType.SPHERE, radius=0.1), Shape(ShapeType.BOX, size=(0.2, 0.4, 0.6))])
    b.add_link("b", shapes=[Shape(ShapeType.CAPSULE, radius=0.05, length=0.3, origin=Transform((0, 0, -0.15))),
                            Shape(ShapeType.CYLINDER, radius=0.02, length=0.1)])
    b.add_joint_fixed("j", "a", "b")
    k = compile_model(b.build())
    np.testing.assert_array_equal(k.shape_link, [0, 0, 1, 1])
    expected = [ShapeType.SPHERE, ShapeType.BOX, ShapeType.CAPSULE, ShapeType.CYLINDER]
    np.testing.assert_array_equal(k.shape_type, expected)
    np.testing.assert_allclose(k.shape_params, [[0.1, 0, 0], [0.1, 0.2, 0.3], [0.05, 0.15, 0], [0.02, 0.05, 0]])
    np.testing.assert_allclose(k.shape_X_link[2], [0, 0, -0.15, 0, 0, 0, 1])


def test_lookups_name_valid_choices():
    k = compile_model(planar_arm())
    assert k.link_index("fore") == 2 and k.joint_index("elbow") == 1 and k.ee_index("tip") == 0
    assert k.coordinate_index("elbow") == 1
    with pytest.raises(GraphError, match="no link 'hand' \\(links: base, upper, fore\\)"):
        k.link_index("hand")
    with pytest.raises(GraphError, match="no joint 'knee'"):
        k.joint_index("knee")


def test_single_link_model():
    b = MorphologyBuilder("rock")
    b.add_link("rock")
    k = compile_model(b.build())
    assert k.link_count == 1 and k.joint_count == 0 and k.coordinate_count == 7 and k.dof == 0


def test_device_arrays_cached_per_device_and_dtype():
    k = compile_model(every_joint())
    a32 = k.arrays("cpu")
    assert k.arrays("cpu") is a32
    assert a32.joint_X_parent.dtype == wp.transform and a32.joint_X_parent.shape == (k.joint_count,)
    np.testing.assert_allclose(a32.joint_X_parent.numpy(), k.joint_X_parent, atol=1e-7)
    a64 = k.arrays("cpu", "float64")
    assert a64 is not a32 and a64.joint_axis.dtype == wp.vec3d
    np.testing.assert_array_equal(a64.joint_axis.numpy(), k.joint_axis)
    assert k.arrays("cpu", np.float64) is a64
    moved = k.to("cpu")
    assert moved.device == "cpu" and moved.arrays() is a32  # shares the cache
    with pytest.raises(GraphError, match="unsupported dtype"):
        k.arrays("cpu", "int32")


def test_joint_types_recorded():
    k = compile_model(every_joint())
    types = {k.joint_names[j]: JointType(int(t)) for j, t in enumerate(k.joint_type)}
    assert types == {"a_rev": JointType.REVOLUTE, "a_sph": JointType.SPHERICAL, "a_pri": JointType.PRISMATIC,
                     "a_con": JointType.CONTINUOUS, "a_fix": JointType.FIXED, "b_rev": JointType.REVOLUTE,
                     "b_sph": JointType.SPHERICAL, "b_rev2": JointType.REVOLUTE}
