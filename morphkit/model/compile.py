"""Compile a :class:`~morphkit.graph.Morphology` into a :class:`KinematicModel`."""

from __future__ import annotations

from typing import Any

import numpy as np

from morphkit.conventions import quat_rotate, transform_multiply
from morphkit.errors import GraphError
from morphkit.graph.morphology import Morphology
from morphkit.graph.types import BaseType, JointType, ShapeType
from morphkit.model.kinematic_model import KinematicModel

__all__ = ["compile_model"]


def _readonly(a: Any, dtype: Any) -> np.ndarray:
    out = np.array(a, dtype=dtype)
    out.setflags(write=False)
    return out


def compile_model(m: Morphology, *, device: Any = None) -> KinematicModel:
    """Flatten a morphology into the arrays kernels read.

    Args:
        m: A validated morphology (from a reader or :class:`~morphkit.graph.MorphologyBuilder`).
        device: Default Warp device of the model (``None``: Warp's default device when first used).

    Returns:
        The compiled model; its Warp mirrors are built lazily per device by
        :meth:`KinematicModel.arrays`.

    Raises:
        GraphError: if a wheel's axis does not point sideways (it could not roll the base forward).
    """
    J = m.joint_count
    joint_index = {j.name: i for i, j in enumerate(m.joints)}
    link_index = {name: i for i, name in enumerate(m.link_names)}

    joint_type = [int(j.type) for j in m.joints]
    joint_parent = [link_index[j.parent] for j in m.joints]
    X_parent = np.array([j.origin.as_array() for j in m.joints]).reshape(J, 7)
    axis = np.array([j.axis for j in m.joints], dtype=float).reshape(J, 3)

    mimic_target = np.full(J, -1, dtype=np.int32)
    mimic_mul = np.ones(J)
    mimic_off = np.zeros(J)
    for i, j in enumerate(m.joints):
        if j.mimic is not None:
            mimic_target[i] = joint_index[j.mimic.joint]
            mimic_mul[i] = j.mimic.multiplier
            mimic_off[i] = j.mimic.offset

    lim_lo = np.full(J, -np.inf)
    lim_hi = np.full(J, np.inf)
    for i, j in enumerate(m.joints):
        if j.limit is not None and j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            lim_lo[i], lim_hi[i] = j.limit.lower, j.limit.upper
    coord_lo, coord_hi = m.coordinate_limits

    joint_wheel, wheel_joint, wheel_lateral, wheel_sign = _wheels(m, joint_index, joint_parent, X_parent, axis)

    ee_link = [link_index[e.link] for e in m.end_effectors]
    ee_offset = np.array([e.offset for e in m.end_effectors], dtype=float).reshape(-1, 3)
    ee_role = [int(e.role) for e in m.end_effectors]

    shape_link, shape_type, shape_X, shape_params = _shapes(m)

    return KinematicModel(
        name=m.name,
        base_type=BaseType(m.base),
        link_names=m.link_names,
        joint_names=m.joint_names,
        ee_names=tuple(e.name for e in m.end_effectors),
        coordinate_names=m.coordinate_names,
        link_parent=_readonly(m.link_parent, np.int32),
        joint_type=_readonly(joint_type, np.int32),
        joint_parent=_readonly(joint_parent, np.int32),
        joint_X_parent=_readonly(X_parent, np.float64),
        joint_axis=_readonly(axis, np.float64),
        joint_q_start=_readonly(m.joint_q_start, np.int32),
        joint_qd_start=_readonly(m.joint_qd_start, np.int32),
        joint_mimic_target=_readonly(mimic_target, np.int32),
        joint_mimic_multiplier=_readonly(mimic_mul, np.float64),
        joint_mimic_offset=_readonly(mimic_off, np.float64),
        joint_wheel=_readonly(joint_wheel, np.int32),
        joint_limit_lower=_readonly(lim_lo, np.float64),
        joint_limit_upper=_readonly(lim_hi, np.float64),
        coordinate_lower=_readonly(coord_lo, np.float64),
        coordinate_upper=_readonly(coord_hi, np.float64),
        rest_q=_readonly(m.rest_q(), np.float64),
        ee_link=_readonly(ee_link, np.int32),
        ee_offset=_readonly(ee_offset, np.float64),
        ee_role=_readonly(ee_role, np.int32),
        shape_link=_readonly(shape_link, np.int32),
        shape_type=_readonly(shape_type, np.int32),
        shape_X_link=_readonly(np.array(shape_X, dtype=float).reshape(-1, 7), np.float64),
        shape_params=_readonly(np.array(shape_params, dtype=float).reshape(-1, 3), np.float64),
        wheel_joint=_readonly(wheel_joint, np.int32),
        wheel_radius=float(m.wheels.radius) if m.wheels is not None and m.base == BaseType.WHEELED else 0.0,
        wheel_lateral=_readonly(wheel_lateral, np.float64),
        wheel_sign=_readonly(wheel_sign, np.float64),
        collision_exclude=_readonly(
            np.array([(m.link_names.index(a), m.link_names.index(b)) for a, b in m.collision_excludes],
                     dtype=np.int32).reshape(-1, 2), np.int32),
        device=None if device is None else str(device),
    )


def _wheels(m: Morphology, joint_index: dict[str, int], joint_parent: list[int], X_parent: np.ndarray,
            axis: np.ndarray) -> tuple[np.ndarray, list[int], list[float], list[float]]:
    """Per joint its wheel index (-1: none) [J]; per wheel its joint, lateral position [m] and rolling sign.

    Lateral position and sign come from the rest pose, so wheels mounted under intermediate fixed links work too.

    Raises:
        GraphError: a wheel's axis does not point sideways.
    """
    joint_wheel = np.full(m.joint_count, -1, dtype=np.int32)
    wheel_joint: list[int] = []
    wheel_lateral: list[float] = []
    wheel_sign: list[float] = []
    if m.wheels is not None and m.base == BaseType.WHEELED:
        rest = m.rest_link_poses()
        for w, name in enumerate(m.wheels.joints):
            ji = joint_index[name]
            joint_wheel[ji] = w
            wheel_joint.append(ji)
            T_root_joint = transform_multiply(rest[joint_parent[ji]], X_parent[ji])
            axis_root = quat_rotate(T_root_joint[3:], axis[ji])
            if abs(axis_root[1]) < 0.5:
                raise GraphError(
                    f"wheel {name!r}: axis {list(np.round(axis_root, 3))} (in the root frame) does not point "
                    "sideways (along ±y), so the wheel cannot roll the base forward",
                    location=m.joints[ji].location,
                )
            wheel_lateral.append(float(T_root_joint[1]))
            wheel_sign.append(1.0 if axis_root[1] > 0 else -1.0)
    return joint_wheel, wheel_joint, wheel_lateral, wheel_sign


def _shapes(m: Morphology) -> tuple[list[int], list[int], list[np.ndarray], list[tuple[float, float, float]]]:
    """Every link's shapes in link order: link, type, pose in the link, and size parameters (sphere: radius; capsule
    and cylinder: radius, half length; box: half extents; mesh: scale)."""
    shape_link: list[int] = []
    shape_type: list[int] = []
    shape_X: list[np.ndarray] = []
    shape_params: list[tuple[float, float, float]] = []
    for li, link in enumerate(m.links):
        for s in link.shapes:
            shape_link.append(li)
            shape_type.append(int(s.type))
            shape_X.append(s.origin.as_array())
            if s.type == ShapeType.SPHERE:
                shape_params.append((s.radius, 0.0, 0.0))
            elif s.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
                shape_params.append((s.radius, 0.5 * s.length, 0.0))
            elif s.type == ShapeType.BOX:
                shape_params.append((0.5 * s.size[0], 0.5 * s.size[1], 0.5 * s.size[2]))
            else:
                shape_params.append(tuple(s.scale))  # type: ignore[arg-type]
    return shape_link, shape_type, shape_X, shape_params
