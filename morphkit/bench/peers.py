"""Peer FK implementations for ``morphkit bench fk``, each built from one :class:`Morphology`.

Every peer is constructed from the same morphology morphkit compiles, so the creatures are identical
across implementations: the same links, joint origins, axes and coordinate values.

- ``pytorch_kinematics``: a chain built from URDF text written here from the morphology. URDF has
  no ball joint, so a spherical joint becomes three revolute joints about z, y and x through two
  massless dummy links (``R = Rz(yaw) Ry(pitch) Rx(roll)``, morphkit's rpy convention); its
  quaternion is converted to those three angles before timing. pytorch-kinematics has no floating
  base either: the base transform is applied to its root-relative link poses in torch (timed).
- ``pinocchio``: a ``pin.Model`` built joint by joint (``JointModelRX/RY/RZ``, ``RevoluteUnaligned``,
  ``PX/PY/PZ``, ``PrismaticUnaligned``, ``Spherical``, ``FreeFlyer``); every link is a frame.
  Its ``q`` layout equals morphkit's (free flyer ``[p, xyzw]``, spherical xyzw), so poses pass
  through unchanged. One pose per call, in a Python loop.
- ``mujoco``: the MJCF model :func:`morphkit.io.mjcf.dump_mjcf` writes (``free``, ``hinge``, ``slide``,
  ``ball`` joints; one body per link, its joint at the body origin); quaternions reordered to wxyz.
  One pose per call (``mj_kinematics``), in a Python loop.

Fixed and floating bases are supported; planar and wheeled bases, mimic joints and wheels are not
(the benchmark creatures need none of them) and raise :class:`~morphkit.errors.ConfigError`.
Heavy peers are imported inside functions: a missing peer raises ``ImportError`` at construction.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from morphkit.conventions import rpy_from_quat
from morphkit.errors import ConfigError
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.io.mjcf import dump_mjcf

__all__ = [
    "MujocoFK",
    "PinocchioFK",
    "PytorchKinematicsFK",
    "Workload",
    "check_supported",
    "urdf_text_for_peers",
]


@dataclass
class Workload:
    """Timed callables of one implementation on one batch of poses (inputs prepared, untimed)."""

    fwd: Callable[[], Any]
    """Forward kinematics of every pose in the batch (all link poses)."""
    fwd_bwd: Callable[[], Any] | None
    """Forward plus the gradient of the sum of link positions w.r.t. the coordinates (or its analogue)."""
    poses: int
    """Poses one call evaluates (a Python-loop peer may cap it below the batch size)."""


def check_supported(m: Morphology) -> None:
    """Raise :class:`ConfigError` when the peers cannot express ``m`` exactly."""
    if m.base not in (BaseType.FIXED, BaseType.FLOATING):
        raise ConfigError(f"{m.name}: peer adapters support fixed and floating bases, not {m.base.name.lower()}")
    driven = [j.name for j in m.joints if m.is_driven(j)]
    if driven:
        raise ConfigError(f"{m.name}: peer adapters do not support mimic or wheel joints ({', '.join(driven)})")


def _fmt(values: Any) -> str:
    return " ".join(repr(float(v)) for v in values)


def _spherical_to_zyx(q_xyzw: np.ndarray) -> np.ndarray:
    """Angles ``[yaw, pitch, roll]`` [..., 3] with ``R = Rz(yaw) Ry(pitch) Rx(roll)`` (rpy convention)."""
    return rpy_from_quat(q_xyzw)[..., ::-1]


# ---------------------------------------------------------------------------------------------
# pytorch-kinematics
# ---------------------------------------------------------------------------------------------
def urdf_text_for_peers(m: Morphology) -> str:
    """URDF of ``m``'s kinematic tree for pytorch-kinematics (no shapes; spherical → z, y, x revolutes).

    The base is dropped: the root link is the URDF root and the base transform is applied outside.
    Dummy links of a spherical joint ``j`` are ``j__z`` and ``j__y``; its joints ``j__rz``, ``j__ry``,
    ``j__rx``.
    """
    check_supported(m)
    links = [f'  <link name="{link.name}"/>' for link in m.links]
    joints = []

    def joint(name: str, jtype: str, parent: str, child: str, xyz: Any, rpy: Any, axis: Any) -> str:
        bounded = jtype in ("revolute", "prismatic")
        limit = '<limit lower="-1e9" upper="1e9" effort="1" velocity="1"/>' if bounded else ""
        return (
            f'  <joint name="{name}" type="{jtype}"><parent link="{parent}"/><child link="{child}"/>'
            f'<origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/><axis xyz="{_fmt(axis)}"/>{limit}</joint>'
        )

    for j in m.joints:
        xyz, rpy = j.origin.xyz, j.origin.rpy
        if j.type == JointType.SPHERICAL:
            links += [f'  <link name="{j.name}__z"/>', f'  <link name="{j.name}__y"/>']
            zero = (0.0, 0.0, 0.0)
            z_link, y_link = f"{j.name}__z", f"{j.name}__y"
            joints.append(joint(f"{j.name}__rz", "revolute", j.parent, z_link, xyz, rpy, (0, 0, 1)))
            joints.append(joint(f"{j.name}__ry", "revolute", z_link, y_link, zero, zero, (0, 1, 0)))
            joints.append(joint(f"{j.name}__rx", "revolute", y_link, j.child, zero, zero, (1, 0, 0)))
        else:
            jtype = {JointType.FIXED: "fixed", JointType.PRISMATIC: "prismatic"}.get(j.type, "revolute")
            joints.append(joint(j.name, jtype, j.parent, j.child, xyz, rpy, j.axis))
    return "\n".join([f'<robot name="{m.name}">', *links, *joints, "</robot>"]) + "\n"


def _torch_matrix_from_quat(q: Any) -> Any:
    """Rotation matrices [..., 3, 3] from xyzw quaternions [..., 4] (torch)."""
    import torch

    x, y, z, w = q.unbind(-1)
    return torch.stack(
        [
            1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w),
            2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
            2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y),
        ],
        dim=-1,
    ).unflatten(-1, (3, 3))  # fmt: skip


class PytorchKinematicsFK:
    """pytorch-kinematics (``Chain.forward_kinematics_tensor``, float32, its analytical backward).

    Args:
        m: The creature.
        dtype: Torch dtype of the chain and inputs.
    """

    name = "pytorch_kinematics"

    def __init__(self, m: Morphology, *, dtype: Any = None) -> None:
        import pytorch_kinematics as pk
        import torch

        self.m = m
        self.dtype = dtype or torch.float32
        self.chain = pk.build_chain_from_urdf(urdf_text_for_peers(m)).to(dtype=self.dtype)
        frame_to_idx = getattr(self.chain, "frame_to_idx", {})
        self.frame_index = torch.tensor([frame_to_idx.get(link.name, -1) for link in m.links], dtype=torch.long)
        names = self.chain.get_joint_parameter_names()
        # Column of each chain parameter in our q (spherical: one column of the converted angles).
        index = {n: i for i, n in enumerate(names)}
        self._columns: list[tuple[int, int, int]] = []  # (chain column, q start, angle index or -1)
        for j, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
            if j.type == JointType.SPHERICAL:
                for k, axis in enumerate("zyx"):
                    self._columns.append((index[f"{j.name}__r{axis}"], start, k))
            elif j.type != JointType.FIXED:
                self._columns.append((index[j.name], start, -1))
        self.n_params = len(names)

    def inputs(self, q: np.ndarray) -> tuple[Any, Any]:
        """Chain parameters [B, n_params] and base ``[p, xyzw]`` [B, 7] (None for a fixed base)."""
        import torch

        q = np.asarray(q, dtype=np.float64)
        th = np.zeros((q.shape[0], self.n_params))
        for col, start, k in self._columns:
            th[:, col] = q[:, start] if k < 0 else _spherical_to_zyx(q[:, start : start + 4])[:, k]
        base = torch.as_tensor(q[:, :7], dtype=self.dtype) if self.m.base == BaseType.FLOATING else None
        return torch.as_tensor(th, dtype=self.dtype), base

    def positions(self, th: Any, base: Any) -> Any:
        """World link positions [B, link_count, 3] (torch)."""
        if hasattr(self.chain, "forward_kinematics_tensor"):  # pytorch-kinematics >= 0.10: one stacked tensor
            T = self.chain.forward_kinematics_tensor(th)  # [frames, B, 4, 4]
            p = T[self.frame_index, :, :3, 3].transpose(0, 1)  # [B, L, 3]
        else:
            import torch

            Ts = self.chain.forward_kinematics(th)  # {link name: Transform3d [B]}
            p = torch.stack([Ts[link.name].get_matrix()[:, :3, 3] for link in self.m.links], dim=1)
        if base is None:
            return p
        R = _torch_matrix_from_quat(base[:, 3:7])  # [B, 3, 3]
        return base[:, None, :3] + p @ R.transpose(1, 2)

    def link_positions(self, q: np.ndarray) -> np.ndarray:
        th, base = self.inputs(q)
        return self.positions(th, base).detach().double().numpy()

    def workload(self, q: np.ndarray) -> Workload:
        th, base = self.inputs(q)
        th_g = th.clone().requires_grad_(True)
        base_g = None if base is None else base.clone().requires_grad_(True)

        def fwd() -> Any:
            return self.positions(th, base)

        def fwd_bwd() -> Any:
            th_g.grad = None
            if base_g is not None:
                base_g.grad = None
            self.positions(th_g, base_g).sum().backward()
            return th_g.grad

        return Workload(fwd, fwd_bwd, th.shape[0])


# ---------------------------------------------------------------------------------------------
# Pinocchio
# ---------------------------------------------------------------------------------------------
def _pin_joint_model(pin: Any, j: Any) -> Any:
    axis = np.asarray(j.axis, dtype=float)
    unit = {(1, 0, 0): "X", (0, 1, 0): "Y", (0, 0, 1): "Z"}.get(tuple(np.round(axis, 12)))
    if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
        return getattr(pin, f"JointModelR{unit}")() if unit else pin.JointModelRevoluteUnaligned(axis)
    if j.type == JointType.PRISMATIC:
        return getattr(pin, f"JointModelP{unit}")() if unit else pin.JointModelPrismaticUnaligned(axis)
    if j.type == JointType.SPHERICAL:
        return pin.JointModelSpherical()
    raise ConfigError(f"{j.name}: no Pinocchio joint for {j.type.name.lower()}")


def _pin_se3(pin: Any, T: Any) -> Any:
    x, y, z, w = T.quat
    return pin.SE3(pin.Quaternion(w, x, y, z).matrix(), np.asarray(T.xyz, dtype=float))


class PinocchioFK:
    """Pinocchio (``framesForwardKinematics`` per pose in a Python loop; float64).

    ``fwd_bwd`` is ``computeJointJacobians`` + ``updateFramePlacements`` per pose: Pinocchio's
    gradient analogue (Jacobians w.r.t. the tangent space), not a reverse-mode gradient.

    Args:
        m: The creature.
        max_poses: Poses timed per call at most (a Python loop runs at a rate independent of B).
    """

    name = "pinocchio"

    def __init__(self, m: Morphology, *, max_poses: int = 2000) -> None:
        import pinocchio as pin

        check_supported(m)
        self.pin, self.m, self.max_poses = pin, m, max_poses
        model = pin.Model()
        model.name = m.name
        root_joint = 0
        if m.base == BaseType.FLOATING:
            root_joint = model.addJoint(0, pin.JointModelFreeFlyer(), pin.SE3.Identity(), "base")
        # Each link hangs on a Pinocchio joint with a placement (fixed joints fold into it).
        owner = {m.root: (root_joint, pin.SE3.Identity())}
        for j in m.joints:
            pj, placement = owner[j.parent]
            placement = placement * _pin_se3(pin, j.origin)
            if j.type == JointType.FIXED:
                owner[j.child] = (pj, placement)
            else:
                owner[j.child] = (model.addJoint(pj, _pin_joint_model(pin, j), placement, j.name), pin.SE3.Identity())
        self.frame_ids = []
        for link in m.links:
            pj, placement = owner[link.name]
            # (name, parent joint, parent frame, placement, type): the form Pinocchio 2.x and 3.x+ both accept.
            frame = pin.Frame(f"{link.name}__link", pj, 0, placement, pin.FrameType.OP_FRAME)
            self.frame_ids.append(model.addFrame(frame))
        if model.nq != m.coordinate_count:
            raise ConfigError(f"{m.name}: Pinocchio model has nq={model.nq}, morphkit {m.coordinate_count}")
        self.model, self.data = model, model.createData()

    def link_positions(self, q: np.ndarray) -> np.ndarray:
        out = np.zeros((len(q), self.m.link_count, 3))
        for b, qb in enumerate(np.asarray(q, dtype=np.float64)):
            self.pin.framesForwardKinematics(self.model, self.data, qb)
            for i, f in enumerate(self.frame_ids):
                out[b, i] = self.data.oMf[f].translation
        return out

    def workload(self, q: np.ndarray) -> Workload:
        pin, model, data = self.pin, self.model, self.data
        qs = [np.ascontiguousarray(v) for v in np.asarray(q[: self.max_poses], dtype=np.float64)]

        def fwd() -> None:
            for qb in qs:
                pin.framesForwardKinematics(model, data, qb)

        def fwd_bwd() -> None:
            for qb in qs:
                pin.computeJointJacobians(model, data, qb)
                pin.updateFramePlacements(model, data)

        return Workload(fwd, fwd_bwd, len(qs))


# ---------------------------------------------------------------------------------------------
# MuJoCo
# ---------------------------------------------------------------------------------------------
class MujocoFK:
    """MuJoCo (``mj_kinematics`` per pose in a Python loop; float64).

    ``fwd_bwd`` is ``mj_kinematics`` + ``mj_comPos`` + ``mj_jacBody`` for every link, summing the
    translational Jacobians: the gradient of the sum of link positions w.r.t. the velocity
    coordinates, MuJoCo's analogue of the reverse-mode gradient.

    Args:
        m: The creature.
        max_poses: Poses timed per call at most.
    """

    name = "mujoco"

    def __init__(self, m: Morphology, *, max_poses: int = 2000) -> None:
        import mujoco

        self.mj, self.m, self.max_poses = mujoco, m, max_poses
        check_supported(m)
        self.model = mujoco.MjModel.from_xml_string(dump_mjcf(m))
        self.data = mujoco.MjData(self.model)
        self.body_ids = [mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, link.name) for link in m.links]
        # Reorder xyzw → wxyz for the free joint's and ball joints' quaternions.
        perm = np.arange(m.coordinate_count)
        quat_starts = [3] if m.base == BaseType.FLOATING else []
        quat_starts += [s for j, s in zip(m.joints, m.joint_q_start[:-1], strict=True) if j.type == JointType.SPHERICAL]
        for k in quat_starts:
            perm[k : k + 4] = [k + 3, k, k + 1, k + 2]
        self._perm = perm
        if self.model.nq != m.coordinate_count:
            raise ConfigError(f"{m.name}: MuJoCo model has nq={self.model.nq}, morphkit {m.coordinate_count}")

    def qpos(self, q: np.ndarray) -> np.ndarray:
        """MuJoCo ``qpos`` [B, nq] of morphkit coordinates [B, coordinate_count]."""
        return np.ascontiguousarray(np.asarray(q, dtype=np.float64)[:, self._perm])

    def link_positions(self, q: np.ndarray) -> np.ndarray:
        out = np.zeros((len(q), self.m.link_count, 3))
        for b, qb in enumerate(self.qpos(q)):
            self.data.qpos[:] = qb
            self.mj.mj_kinematics(self.model, self.data)
            out[b] = self.data.xpos[self.body_ids]
        return out

    def workload(self, q: np.ndarray) -> Workload:
        mj, model, data, bodies = self.mj, self.model, self.data, self.body_ids
        qs = list(self.qpos(q[: self.max_poses]))
        jacp = np.zeros((3, model.nv))
        grad = np.zeros(model.nv)

        def fwd() -> None:
            for qb in qs:
                data.qpos[:] = qb
                mj.mj_kinematics(model, data)

        def fwd_bwd() -> None:
            for qb in qs:
                data.qpos[:] = qb
                mj.mj_kinematics(model, data)
                mj.mj_comPos(model, data)
                grad[:] = 0.0
                for body in bodies:
                    mj.mj_jacBody(model, data, jacp, None, body)
                    grad[:] += jacp.sum(axis=0)

        return Workload(fwd, fwd_bwd, len(qs))
