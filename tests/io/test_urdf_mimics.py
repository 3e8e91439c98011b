"""Mimics as vendor URDFs write them: a chain of mimics is driven by its last joint; a fixed joint's mimic is moot."""

from __future__ import annotations

import numpy as np
import pytest

from morphkit.graph import JointType
from morphkit.graph.kinematics import link_poses
from morphkit.io.urdf import parse_urdf
from morphkit.rotations import yaw_from_quat


def _joint(name: str, parent: str, child: str, kind: str = "revolute", mimic: str = "") -> str:
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3"/>{mimic}</joint>')


def test_a_chain_of_mimics_is_driven_by_the_joint_at_its_end() -> None:
    """j2 = -1·j1 + 0.2 and j1 = 2·j0 + 0.1 give j2 = -2·j0 + 0.1: the poses are those of the chain's algebra."""
    text = ('<robot name="r">' + "".join(f'<link name="l{i}"/>' for i in range(4))
            + _joint("j0", "l0", "l1")
            + _joint("j1", "l1", "l2", mimic='<mimic joint="j0" multiplier="2" offset="0.1"/>')
            + _joint("j2", "l2", "l3", mimic='<mimic joint="j1" multiplier="-1" offset="0.2"/>') + "</robot>")
    with pytest.warns(UserWarning, match=r"joint 'j2' mimics 'j1', itself a mimic: read as a mimic of 'j0'"):
        m = parse_urdf(text, source="r.urdf")
    mimic = m.joints[2].mimic
    assert mimic is not None and mimic.joint == "j0"
    np.testing.assert_allclose([mimic.multiplier, mimic.offset], [-2.0, 0.1])
    q0 = 0.35
    q = m.rest_q()
    q[m.joint_q_start[0]] = q0
    yaw = np.cumsum([q0, 2 * q0 + 0.1, -(2 * q0 + 0.1) + 0.2])  # each joint turns about z, 0.3 m along its x
    tip = 0.3 + 0.3 * np.cos(yaw[0]) + 0.3 * np.cos(yaw[1])
    poses = link_poses(m, q[None])[0]
    np.testing.assert_allclose(poses[3, 0], tip, atol=1e-12)
    np.testing.assert_allclose(yaw_from_quat(poses[3, 3:]), yaw[2], atol=1e-12)  # j2's own turn, composed


def test_a_fixed_joint_keeps_no_mimic() -> None:
    """example-robot-data's talos_reduced locks its gripper joints as fixed but keeps their <mimic>."""
    text = ('<robot name="r"><link name="a"/><link name="b"/><link name="c"/>' + _joint("drive", "a", "b")
            + _joint("locked", "b", "c", kind="fixed", mimic='<mimic joint="drive" multiplier="1"/>') + "</robot>")
    with pytest.warns(UserWarning, match=r"joint 'locked' is fixed: its <mimic> of 'drive' is ignored"):
        m = parse_urdf(text, source="r.urdf")
    assert m.joints[1].type == JointType.FIXED and m.joints[1].mimic is None
