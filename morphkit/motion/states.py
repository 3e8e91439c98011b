"""ACE state vectors (Li et al. 2023, §6.1–6.2) and their normalisation statistics.

Both states are built from world-space arrays, so they are pure functions that tests can feed
with analytic motions; :func:`human_state_from_motion` and :func:`character_state_from_motion`
run the FK kernels first.

**Heading frame.** Frame ``t``'s local frame has its origin at the root link, its z axis along
world up and its x axis along the root's forward axis (+x of the root link) projected on the
ground. "In the heading frame" below means: expressed in that frame's axes (positions also
relative to its origin).

**Velocities** are backward differences times ``fps`` (``v_t = (p_t - p_{t-1}) fps``); frame 0
reuses frame 1's difference. Angular velocity is the rotation vector of ``q_t q_{t-1}⁻¹`` times
``fps`` (world axes, then expressed in the heading frame). Linear velocities of points are world
velocities expressed in the heading frame's axes.

Human state x^h (§6.1), dimension ``1 + 4 + 6 + 3 (L - 1) + 6 E``:

============================  =======  ==================================================
field                         dims     meaning
============================  =======  ==================================================
``root_height``               1        root z above the ground [m]
``root_orientation``          4        root orientation in the heading frame (xyzw, w >= 0)
``root_linear_velocity``      3        [m/s], heading frame
``root_angular_velocity``     3        [rad/s], heading frame
``joint_positions``           3(L-1)   every non-root link origin, heading frame [m]
``ee_positions``              3E       end-effectors, heading frame [m]
``ee_velocities``             3E       [m/s], heading frame
============================  =======  ==================================================

The paper's human uses 17 joints (51 dims); here every non-root link of the morphology counts,
so the dimension follows the skeleton (CMU's 22-joint skeleton gives 63).

Character state x^r (§6.2), dimension ``1 + 4 + 2 + 4 + 6 + (C - B) + 6 E``:

===============================  =======  ===============================================
field                            dims     meaning
===============================  =======  ===============================================
``root_height``                  1        root z [m]
``root_orientation``             4        heading frame (xyzw, w >= 0)
``root_displacement``            2        ``p_t - p_{t-1}`` in the ground plane, heading frame [m]
``previous_root_orientation``    4        ``q_{t-1}`` in frame t's heading frame (xyzw, w >= 0)
``root_linear_velocity``         3        [m/s], heading frame
``root_angular_velocity``        3        [rad/s], heading frame
``joint_q``                      C - B    joint coordinates (spherical: xyzw, w >= 0)
``ee_positions``                 3E       heading frame [m]
``ee_velocities``                3E       [m/s], heading frame
===============================  =======  ===============================================

``previous_root_orientation`` carries the yaw change between frames, and ``root_displacement``
the step, so a sequence of states can be integrated back into a world trajectory.

**Stance flags** (beyond the paper, ``contacts=True`` in the layouts): both states may end with
``foot_contacts`` [F], one flag per end-effector of role ``foot`` (1 in stance, 0 in swing), in the
morphology's end-effector order. A creature's synthesised data take them from the synthesis' plan;
any other motion from :func:`foot_contact_flags` (the contact rule's ``stance flags`` preset).

**Derived slots.** Given the previous state, the root velocities and the end-effector velocities
follow from a state's own root step, height and orientations and its end-effector positions, which
follow from its tilt and joints by FK: :func:`derive_character_state` recomputes them, so a model
that predicts only the first can complete a state whose every slot agrees with its export.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from morphkit._atomic import atomic_path
from morphkit.contact_rules import STANCE_FLAGS, ContactRule, contact_flags
from morphkit.conventions import backward_difference
from morphkit.errors import MotionFormatError, SourceLocation
from morphkit.graph import JointType, Morphology
from morphkit.rotations import (
    axis_angle_from_quat,
    heading_frame,
    quat_canonical,
    quat_conjugate,
    quat_multiply,
    quat_rotate,
    quat_rotate_inverse,
)

if TYPE_CHECKING:
    from morphkit.motion.motion import Motion

__all__ = [
    "NormStats",
    "StateLayout",
    "character_state",
    "character_state_from_motion",
    "character_state_layout",
    "derive_character_state",
    "foot_contact_flags",
    "foot_names",
    "heading_frame",
    "human_state",
    "human_state_from_motion",
    "human_state_layout",
    "to_heading_frame",
]


@dataclass(frozen=True)
class StateLayout:
    """Where each named field lies in a state vector.

    Attributes:
        kind: ``"human"`` or ``"character"``.
        fields: ``(name, start, stop)`` per field, in order.
        ee_names: End-effector names, in the order of the ``ee_*`` fields.
    """

    kind: str
    fields: tuple[tuple[str, int, int], ...]
    ee_names: tuple[str, ...]

    @property
    def dim(self) -> int:
        """Length of the state vector."""
        return self.fields[-1][2]

    def slice(self, name: str) -> slice:
        """The slice of field ``name`` in the last axis of a state."""
        for n, a, b in self.fields:
            if n == name:
                return slice(a, b)
        raise KeyError(f"no state field {name!r} (fields: {', '.join(n for n, _, _ in self.fields)})")

    def names(self) -> tuple[str, ...]:
        return tuple(n for n, _, _ in self.fields)

    def replace(self, state: Any, parts: Mapping[str, Any]) -> Any:
        """``state`` [..., dim] (NumPy or torch, differentiable) with the fields named in ``parts`` set to their
        values [..., field length]; the other fields kept."""
        return _cat([parts.get(name, state[..., a:b]) for name, a, b in self.fields])


def _layout(kind: str, sizes: Sequence[tuple[str, int]], ee_names: tuple[str, ...]) -> StateLayout:
    fields = []
    start = 0
    for name, n in sizes:
        fields.append((name, start, start + n))
        start += n
    return StateLayout(kind, tuple(fields), ee_names)


def foot_names(morphology: Morphology) -> tuple[str, ...]:
    """The end-effectors of role ``foot``, in the morphology's order (the stance flags' order)."""
    from morphkit.graph import EndEffectorRole

    return tuple(e.name for e in morphology.end_effectors if e.role == EndEffectorRole.FOOT)


def _with_contacts(sizes: list[tuple[str, int]], morphology: Morphology, contacts: bool) -> list[tuple[str, int]]:
    return [*sizes, ("foot_contacts", len(foot_names(morphology)))] if contacts else sizes


def human_state_layout(morphology: Morphology, *, contacts: bool = False) -> StateLayout:
    """Layout of the human state x^h for ``morphology`` (see the module docstring); ``contacts`` adds
    the stance flags."""
    e = len(morphology.end_effectors)
    sizes = [
        ("root_height", 1),
        ("root_orientation", 4),
        ("root_linear_velocity", 3),
        ("root_angular_velocity", 3),
        ("joint_positions", 3 * (morphology.link_count - 1)),
        ("ee_positions", 3 * e),
        ("ee_velocities", 3 * e),
    ]
    return _layout("human", _with_contacts(sizes, morphology, contacts),
                   tuple(x.name for x in morphology.end_effectors))


def character_state_layout(morphology: Morphology, *, contacts: bool = False) -> StateLayout:
    """Layout of the character state x^r for ``morphology`` (see the module docstring); ``contacts`` adds
    the stance flags."""
    e = len(morphology.end_effectors)
    sizes = [
        ("root_height", 1),
        ("root_orientation", 4),
        ("root_displacement", 2),
        ("previous_root_orientation", 4),
        ("root_linear_velocity", 3),
        ("root_angular_velocity", 3),
        ("joint_q", morphology.coordinate_count - morphology.base_coordinate_count),
        ("ee_positions", 3 * e),
        ("ee_velocities", 3 * e),
    ]
    return _layout("character", _with_contacts(sizes, morphology, contacts),
                   tuple(x.name for x in morphology.end_effectors))


# ---- heading frame and differences (NumPy arrays or torch tensors) -------------------------


def _is_torch(x: Any) -> bool:
    return type(x).__module__.split(".", 1)[0] == "torch"


def _cat(parts: list[Any]) -> Any:
    if _is_torch(parts[0]):
        import torch

        return torch.cat(parts, dim=-1)
    return np.concatenate(parts, axis=-1)


def _as_float(x: Any) -> Any:
    return x if _is_torch(x) else np.asarray(x, dtype=float)


def to_heading_frame(heading: Any, points: Any, *, direction: bool = False) -> Any:
    """Express world points (or, with ``direction=True``, vectors) [..., T, K..., 3] in heading frames [..., T, 7]."""
    heading, points = _as_float(heading), _as_float(points)
    extra = points.ndim - heading.ndim
    shape = tuple(heading.shape[:-1]) + (1,) * extra
    origin = heading[..., :3].reshape(*shape, 3)
    v = points if direction else points - origin
    return quat_rotate_inverse(heading[..., 3:].reshape(*shape, 4), v)


def _rotation_steps(q: Any) -> Any:
    """World rotation ``q_t q_{t-1}⁻¹`` per frame [..., T, 4] (frame 0 copies frame 1; identity for one frame)."""
    if q.shape[-2] < 2:
        return _cat([q[..., :3] * 0.0, q[..., 3:] * 0.0 + 1.0])
    steps = quat_multiply(q[..., 1:, :], quat_conjugate(q[..., :-1, :]))
    return _cat_time(steps[..., :1, :], steps)


def _cat_time(a: Any, b: Any) -> Any:
    if _is_torch(a):
        import torch

        return torch.cat([a, b], dim=-2)
    return np.concatenate([a, b], axis=-2)


def _root_terms(root_pose: Any, fps: float) -> dict[str, Any]:
    """Root blocks of both states from root poses [..., T, 7]."""
    heading = heading_frame(root_pose)
    inv_h = quat_conjugate(heading[..., 3:])
    q = root_pose[..., 3:]
    step = _rotation_steps(q)
    disp = quat_rotate(inv_h, backward_difference(root_pose[..., :3], -2))
    prev_q = quat_multiply(quat_conjugate(step), q)
    return {
        "heading": heading,
        "root_height": root_pose[..., 2:3],
        "root_orientation": quat_canonical(quat_multiply(inv_h, q)),
        "root_displacement": disp[..., :2],
        "previous_root_orientation": quat_canonical(quat_multiply(inv_h, prev_q)),
        "root_linear_velocity": disp * fps,
        "root_angular_velocity": quat_rotate(inv_h, axis_angle_from_quat(step)) * fps,
    }


def _check_frames(what: str, arrays: dict[str, Any], root_pose: Any, time_axis: dict[str, int]) -> None:
    frames = root_pose.shape[-2]
    for name, a in arrays.items():
        if a.ndim < -time_axis[name] or a.shape[time_axis[name]] != frames:
            raise MotionFormatError(f"{what}: {name} has shape {list(a.shape)}, root_pose has {frames} frames")


def _flat_tail(x: Any) -> Any:
    """[..., T, K, 3] → [..., T, 3K]."""
    return x.reshape(*x.shape[:-2], -1)


def human_state(root_pose: Any, link_positions: Any, ee_positions: Any, fps: float, *, contacts: Any = None) -> Any:
    """Human state x^h per frame (§6.1; layout in :func:`human_state_layout`).

    NumPy arrays or torch tensors (differentiable), with any leading batch shape.

    Args:
        root_pose: World pose of the root link ``T_world_root``, shape [..., T, 7].
        link_positions: World positions of all links (root first), shape [..., T, L, 3] [m].
        ee_positions: World positions of the end-effectors, shape [..., T, E, 3] [m].
        fps: Frame rate [1/s].
        contacts: Stance flags [..., T, F] appended as ``foot_contacts`` (``None``: none).

    Returns:
        [..., T, 11 + 3 (L - 1) + 6 E (+ F)] (float64 for NumPy input).
    """
    root_pose, link_positions, ee_positions = _as_float(root_pose), _as_float(link_positions), _as_float(ee_positions)
    _check_frames("human_state", {"link_positions": link_positions, "ee_positions": ee_positions}, root_pose,
                  {"link_positions": -3, "ee_positions": -3})
    r = _root_terms(root_pose, fps)
    h = r["heading"]
    joints = _flat_tail(to_heading_frame(h, link_positions[..., 1:, :]))
    ee = _flat_tail(to_heading_frame(h, ee_positions))
    ee_vel = _flat_tail(to_heading_frame(h, backward_difference(ee_positions, -3) * fps, direction=True))
    return _cat(
        [
            r["root_height"],
            r["root_orientation"],
            r["root_linear_velocity"],
            r["root_angular_velocity"],
            joints,
            ee,
            ee_vel,
            *_contact_block(contacts, root_pose),
        ]
    )


def _canonical_joint_q(morphology: Morphology, joint_q: Any) -> Any:
    """Joint coordinates with every spherical joint's quaternion in the ``w >= 0`` half."""
    b = morphology.base_coordinate_count
    parts, at = [], 0
    for j, start in zip(morphology.joints, morphology.joint_q_start[:-1], strict=True):
        if j.type == JointType.SPHERICAL and not morphology.is_driven(j):
            s = start - b
            parts += [joint_q[..., at:s], quat_canonical(joint_q[..., s : s + 4])]
            at = s + 4
    if not parts:
        return joint_q
    return _cat([*parts, joint_q[..., at:]])


def character_state(
    root_pose: Any,
    joint_q: Any,
    ee_positions: Any,
    fps: float,
    *,
    morphology: Morphology | None = None,
    contacts: Any = None,
) -> Any:
    """Character state x^r per frame (§6.2; layout in :func:`character_state_layout`).

    NumPy arrays or torch tensors (differentiable), with any leading batch shape.

    Args:
        root_pose: World pose of the root link, shape [..., T, 7].
        joint_q: Joint coordinates (``q`` without the base), shape [..., T, C - B].
        ee_positions: World end-effector positions, shape [..., T, E, 3] [m].
        fps: Frame rate [1/s].
        morphology: When given, spherical joints' quaternions are put in the ``w >= 0`` half.
        contacts: Stance flags [..., T, F] appended as ``foot_contacts`` (``None``: none).

    Returns:
        [..., T, 17 + (C - B) + 6 E (+ F)] (float64 for NumPy input).
    """
    root_pose, joint_q, ee_positions = _as_float(root_pose), _as_float(joint_q), _as_float(ee_positions)
    _check_frames("character_state", {"joint_q": joint_q, "ee_positions": ee_positions}, root_pose,
                  {"joint_q": -2, "ee_positions": -3})
    if morphology is not None:
        joint_q = _canonical_joint_q(morphology, joint_q)
    r = _root_terms(root_pose, fps)
    h = r["heading"]
    ee = _flat_tail(to_heading_frame(h, ee_positions))
    ee_vel = _flat_tail(to_heading_frame(h, backward_difference(ee_positions, -3) * fps, direction=True))
    return _cat(
        [
            r["root_height"],
            r["root_orientation"],
            r["root_displacement"],
            r["previous_root_orientation"],
            r["root_linear_velocity"],
            r["root_angular_velocity"],
            joint_q,
            ee,
            ee_vel,
            *_contact_block(contacts, root_pose),
        ]
    )


def _contact_block(contacts: Any, root_pose: Any) -> list[Any]:
    if contacts is None:
        return []
    if _is_torch(root_pose):
        import torch

        return [torch.as_tensor(contacts, dtype=root_pose.dtype, device=root_pose.device)]
    c = np.asarray(contacts, dtype=float)
    if c.shape[:-1] != root_pose.shape[:-1]:
        raise MotionFormatError(f"contacts has shape {list(c.shape)}, root_pose has {root_pose.shape[-2]} frames")
    return [c]


def foot_contact_flags(motion: Motion, *, rule: ContactRule = STANCE_FLAGS) -> np.ndarray:
    """Stance flags [T, F] (1.0 / 0.0) of a motion's feet (:func:`foot_names`) by the contact ``rule``.

    The ground of each foot is its clip's 5th-percentile height, clamped to ``[0, rule.height]`` (a human's
    toe joint rests a few centimetres up); :data:`~morphkit.contact_rules.STANCE_FLAGS` by default.
    """
    m = motion.morphology
    names = foot_names(m)
    if not names or motion.frame_count == 0:
        return np.zeros((motion.frame_count, len(names)))
    index = {e.name: i for i, e in enumerate(m.end_effectors)}
    feet = motion.end_effector_positions()[:, [index[n] for n in names]]
    ground = np.clip(np.percentile(feet[..., 2], 5, axis=0), 0.0, rule.height)
    return contact_flags(feet, motion.fps, rule, ground).astype(float)


def _flags(motion: Motion, contacts: Any) -> Any:
    if contacts is None or contacts is False:
        return None
    return foot_contact_flags(motion) if contacts is True else contacts


def human_state_from_motion(motion: Motion, *, contacts: Any = None) -> np.ndarray:
    """:func:`human_state` of a motion (link and end-effector positions from the FK kernels).

    ``contacts``: stance flags [T, F], or ``True`` for :func:`foot_contact_flags` (``None``: no flags).
    """
    return human_state(motion.root_pose(), motion.link_positions(), motion.end_effector_positions(), motion.fps,
                       contacts=_flags(motion, contacts))


def character_state_from_motion(motion: Motion, *, contacts: Any = None) -> np.ndarray:
    """:func:`character_state` of a motion (end-effector positions from the FK kernels).

    ``contacts``: stance flags [T, F] (e.g. the synthesis' plan), or ``True`` for
    :func:`foot_contact_flags` (``None``: no flags).
    """
    return character_state(
        motion.root_pose(), motion.joint_q, motion.end_effector_positions(), motion.fps, morphology=motion.morphology,
        contacts=_flags(motion, contacts),
    )


def derive_character_state(prev: Any, cur: Any, ee_positions: Any, fps: float, layout: StateLayout) -> Any:
    """``cur`` [..., D] with its derived slots recomputed from its own root and joint slots and ``prev``.

    Both are denormalised character states of ``layout`` (NumPy or torch, differentiable); ``prev``
    is frame t − 1's, whose ee block is taken as its end-effectors. Recomputed:

    * ``root_orientation`` made unit (``w >= 0``);
    * ``previous_root_orientation`` = R_z(Δψ) · ``prev``'s root orientation, Δψ the yaw of ``cur``'s
      (the yaw change is all ``cur`` says there);
    * ``root_linear_velocity`` = (``root_displacement``, height change) · fps;
    * ``root_angular_velocity`` = rotation vector of ``root_orientation · previous_root_orientation⁻¹`` · fps;
    * ``ee_positions`` = ``ee_positions`` [..., E, 3] (FK of ``cur``'s tilt and joints, heading frame);
    * ``ee_velocities`` = (e_t − R_z(Δψ) e_{t−1} + step) · fps.

    These are the numbers :func:`character_state` gives the motion the states decode to.
    """
    from morphkit.rotations import quat_from_yaw, quat_normalize, yaw_from_quat

    sl = layout.slice
    ro = quat_canonical(quat_normalize(cur[..., sl("root_orientation")]))
    # q_{t-1} in frame t's heading frame: the previous state's tilt turned by the yaw change cur carries
    dyaw = yaw_from_quat(quat_normalize(cur[..., sl("previous_root_orientation")]))
    pro = quat_canonical(quat_multiply(quat_from_yaw(dyaw), quat_normalize(prev[..., sl("root_orientation")])))
    disp = _cat([cur[..., sl("root_displacement")], cur[..., sl("root_height")] - prev[..., sl("root_height")]])
    omega = axis_angle_from_quat(quat_multiply(ro, quat_conjugate(pro))) * fps
    e_prev = prev[..., sl("ee_positions")].reshape(ee_positions.shape)
    turn = quat_from_yaw(dyaw)[..., None, :]
    ee_vel = (ee_positions - quat_rotate(turn, e_prev) + disp[..., None, :]) * fps
    parts = {"root_orientation": ro, "previous_root_orientation": pro, "root_linear_velocity": disp * fps,
             "root_angular_velocity": omega, "ee_positions": _flat_tail(ee_positions),
             "ee_velocities": _flat_tail(ee_vel)}
    return layout.replace(cur, parts)


# ---- normalisation ------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class NormStats:
    """Per-dimension mean and standard deviation of a state dataset: ``x_n = (x - mean) / std``.

    Dimensions that never vary in the data (e.g. a wheeled base's root height) get ``std = 1`` so
    normalising never divides by zero.
    """

    mean: np.ndarray
    """[D] float64."""
    std: np.ndarray
    """[D] float64, > 0."""

    @staticmethod
    def fit(states: np.ndarray | Sequence[np.ndarray], *, min_std: float = 1e-6, layout: StateLayout | None = None,
            field_floor: float = 0.0) -> NormStats:
        """Statistics over all frames of one [T, D] array or a list of them.

        With ``layout`` and ``field_floor`` > 0, no dimension's std is below ``field_floor`` times its field's RMS
        (the root-mean-square of the field's values over the data, e.g. of every joint position): a dimension the
        data barely moves (a synthetic human's spine, its roll) is then not scaled up into hundreds of standard
        deviations by data that does move it.
        """
        arrays = list(states) if isinstance(states, (list, tuple)) else [states]
        data = np.concatenate([np.asarray(s, dtype=float).reshape(-1, np.shape(s)[-1]) for s in arrays], axis=0)
        mean = data.mean(axis=0)
        std = data.std(axis=0)
        if layout is not None and field_floor > 0:
            for _name, a, b in layout.fields:
                rms = float(np.sqrt(np.mean(data[:, a:b] ** 2)))
                std[a:b] = np.maximum(std[a:b], field_floor * rms)
        std = np.where(std < min_std, 1.0, std)
        return NormStats(mean, std)

    def normalize(self, x: Any) -> Any:
        """``(x - mean) / std`` for NumPy arrays or torch tensors (statistics moved to ``x``'s device)."""
        mean, std = self._like(x)
        return (x - mean) / std

    def denormalize(self, x: Any) -> Any:
        """``x * std + mean`` (inverse of :meth:`normalize`)."""
        mean, std = self._like(x)
        return x * std + mean

    def _like(self, x: Any) -> tuple[Any, Any]:
        if isinstance(x, np.ndarray):
            return self.mean, self.std
        import torch

        return (
            torch.as_tensor(self.mean, dtype=x.dtype, device=x.device),
            torch.as_tensor(self.std, dtype=x.dtype, device=x.device),
        )

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write ``mean`` and ``std`` to an ``.npz`` file (atomically)."""
        with atomic_path(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, mean=self.mean, std=self.std)

    @staticmethod
    def load(path: str | os.PathLike[str]) -> NormStats:
        """Read statistics written by :meth:`save`.

        Raises:
            MotionFormatError: if the file lacks ``mean``/``std`` or they disagree in shape.
        """
        try:
            with np.load(path) as data:
                mean, std = np.asarray(data["mean"], dtype=float), np.asarray(data["std"], dtype=float)
        except (KeyError, ValueError, OSError) as exc:
            raise MotionFormatError(f"not a normalisation file: {exc}", location=SourceLocation(str(path))) from None
        if mean.shape != std.shape or mean.ndim != 1 or (std <= 0).any():
            raise MotionFormatError("mean/std must be two [D] arrays with std > 0", location=SourceLocation(str(path)))
        return NormStats(mean, std)
