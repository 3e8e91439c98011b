"""The state codec: a :class:`~morphkit.motion.Motion` ⇄ ACE states, in NumPy and, differentiably, in torch.

Encoding is :func:`~morphkit.motion.states.character_state_from_motion` /
:func:`~morphkit.motion.states.human_state_from_motion` (NumPy, through the FK kernels) and
:func:`character_state_from_q` / :func:`human_state_from_q` (torch, through
:mod:`morphkit.torch`'s autograd over the same kernels: what a trainer scores is what is exported).

Decoding (:func:`decode_character_states`) turns a sequence of character states x^r back into
joint coordinates and a world root trajectory. Frame 0 takes its ground position and yaw from
``initial_pose`` (default: the origin, facing +x); every later frame integrates the root's velocity
slots, the ones Ψ reads and ACE's G is trained to match (:func:`velocity_path`):

- yaw from ``root_angular_velocity``: the heading-frame rotation of the step, undone from the tilt
  ``root_orientation``, gives ``q_{t-1}`` in frame t's heading frame, whose yaw is ``ψ_{t-1} - ψ_t``;
- the ground position from ``root_linear_velocity`` / fps (frame t's step, in frame t's heading frame);

while the root height is ``root_height`` and the tilt ``root_orientation`` (in the heading frame). On
encoded motion these equal the step slots (``previous_root_orientation``, ``root_displacement``;
:func:`ground_path`) exactly; a model's output need not agree with itself, and the exported path must
be the one it was scored on (docs/experiments/velocity-path.md).
Quaternions are renormalised; 1-DoF joints are clamped into their limits and the clamping is
reported. Planar and wheeled bases keep (x, y, yaw) (their wheels turn with the path, as in every
:class:`~morphkit.motion.Motion`); a fixed base has no base coordinates.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from morphkit.errors import MotionFormatError
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.motion.motion import Motion
from morphkit.motion.states import StateLayout, character_state, character_state_layout, human_state
from morphkit.rotations import (
    quat_canonical,
    quat_conjugate,
    quat_from_rotation_vector,
    quat_from_yaw,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    yaw_from_quat,
)

if TYPE_CHECKING:
    import torch

    from morphkit.model import KinematicModel

__all__ = [
    "ClampReport",
    "character_state_from_q",
    "decode_character_states",
    "ground_path",
    "human_state_from_q",
    "stance_flags_of",
    "velocity_path",
    "world_end_effectors",
]


@dataclass(frozen=True)
class ClampReport:
    """How much decoding had to clamp joint coordinates into their limits.

    Attributes:
        clamped_fraction: Fraction of (frame, limited coordinate) entries that were outside.
        max_violation: Largest distance to the limit [rad or m] (0 when nothing was clamped).
        coordinates: Names of the coordinates clamped at least once.
    """

    clamped_fraction: float
    max_violation: float
    coordinates: tuple[str, ...]

    def __str__(self) -> str:
        if not self.coordinates:
            return "no joint coordinate outside its limits"
        return (f"{100 * self.clamped_fraction:.2f}% of limited coordinates clamped (max {self.max_violation:.4g}): "
                f"{', '.join(self.coordinates)}")


def _initial_xy_yaw(initial_pose: Any) -> tuple[np.ndarray, float]:
    if initial_pose is None:
        return np.zeros(2), 0.0
    p = np.asarray(initial_pose, dtype=float)
    if p.shape == (3,):
        return p[:2].copy(), float(p[2])
    if p.shape == (7,):
        return p[:2].copy(), float(yaw_from_quat(quat_normalize(p[3:])))
    raise MotionFormatError(f"initial_pose: expected (x, y, yaw) or a root pose [7], got shape {list(p.shape)}")


def decode_character_states(
    states: np.ndarray,
    morphology: Morphology,
    fps: float,
    *,
    initial_pose: Any = None,
    name: str = "",
    layout: StateLayout | None = None,
) -> tuple[Motion, ClampReport]:
    """A :class:`Motion` from character states x^r (inverse of ``character_state_from_motion``).

    Args:
        states: [T, D] character states of ``morphology`` (not normalised).
        morphology: The character.
        fps: Frame rate [1/s].
        initial_pose: Frame 0's ground position and heading: ``(x, y, yaw)`` or a root pose
            ``T_world_root`` [7] (its height and tilt are ignored: the state has them). Default:
            the origin, facing +x.
        name: The motion's name.
        layout: The states' layout (default :func:`~morphkit.motion.states.character_state_layout`'s,
            without stance flags; :func:`stance_flags_of` reads them where the layout has them).

    Returns:
        The motion and a :class:`ClampReport`.

    Raises:
        MotionFormatError: a state of the wrong width or a bad ``initial_pose``.
    """
    layout = character_state_layout(morphology) if layout is None else layout
    x = np.asarray(states, dtype=float)
    if x.ndim != 2 or x.shape[1] != layout.dim:
        raise MotionFormatError(
            f"states: expected shape [T, {layout.dim}] for {morphology.name!r}, got {list(x.shape)}"
        )
    T = x.shape[0]
    xy0, yaw0 = _initial_xy_yaw(initial_pose)
    xy, yaw = velocity_path(x, layout, fps)
    xy = xy0 + quat_rotate(quat_from_yaw(np.full(T, yaw0)), np.pad(xy, ((0, 0), (0, 1))))[:, :2]
    yaw = yaw0 + yaw
    heading_q = quat_from_yaw(yaw)
    b = morphology.base_coordinate_count
    q = np.zeros((T, morphology.coordinate_count))
    if morphology.base == BaseType.FLOATING:
        tilt = quat_normalize(x[:, layout.slice("root_orientation")])
        q[:, :2] = xy
        q[:, 2] = x[:, layout.slice("root_height")][:, 0]
        q[:, 3:7] = quat_canonical(quat_multiply(heading_q, tilt))
    elif morphology.base in (BaseType.PLANAR, BaseType.WHEELED):
        q[:, :2] = xy
        q[:, 2] = yaw
    q[:, b:] = x[:, layout.slice("joint_q")]
    report = _normalise_and_clamp(morphology, q)
    return Motion(morphology, fps, q, name), report


def stance_flags_of(states: Any, layout: StateLayout) -> np.ndarray:
    """The stance flags [T, F] (bool) of character or human states [T, D] whose layout has ``foot_contacts``.

    Raises:
        MotionFormatError: a layout without stance flags.
    """
    if "foot_contacts" not in layout.names():
        raise MotionFormatError(f"{layout.kind} states without stance flags (no foot_contacts field)")
    return np.asarray(states, dtype=float)[..., layout.slice("foot_contacts")] > 0.5


def ground_path(states: Any, layout: StateLayout) -> tuple[Any, Any]:
    """The root's ground path of character states [..., T, D] (NumPy or torch, differentiable).

    Frame 0 sits at the origin facing +x; later frames integrate yaw from
    ``previous_root_orientation`` (``ψ_t = ψ_{t-1} - yaw(q_{t-1} in frame t)``) and the position
    from ``root_displacement`` (frame t's step, in frame t's heading axes). Frame 0's own step and
    yaw change are ignored (they lead to a frame outside the window).

    Returns:
        ``(xy, yaw)``: ground positions [..., T, 2] [m] and headings [..., T] [rad].
    """
    torch_in = type(states).__module__.split(".", 1)[0] == "torch"
    x = states if torch_in else np.asarray(states, dtype=float)
    dyaw = -yaw_from_quat(quat_normalize(x[..., layout.slice("previous_root_orientation")]))
    disp = x[..., layout.slice("root_displacement")]
    if torch_in:
        import torch

        dyaw = torch.cat([torch.zeros_like(dyaw[..., :1]), dyaw[..., 1:]], dim=-1)
        yaw = torch.cumsum(dyaw, dim=-1)
        d3 = torch.cat([disp, torch.zeros_like(disp[..., :1])], dim=-1)
        step = quat_rotate(quat_from_yaw(yaw), d3)[..., :2]
        step = torch.cat([torch.zeros_like(step[..., :1, :]), step[..., 1:, :]], dim=-2)
        return torch.cumsum(step, dim=-2), yaw
    return _integrate(dyaw, disp)


def _integrate(dyaw: np.ndarray, disp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Headings from yaw changes [..., T] and ground positions from heading-frame steps [..., T, 2], frame 0's own
    change and step ignored (NumPy)."""
    dyaw = dyaw.copy()
    dyaw[..., 0] = 0.0
    yaw = np.cumsum(dyaw, axis=-1)
    d3 = np.concatenate([disp, np.zeros_like(disp[..., :1])], axis=-1)
    step = quat_rotate(quat_from_yaw(yaw), d3)[..., :2]
    step[..., 0, :] = 0.0
    return np.cumsum(step, axis=-2), yaw


def velocity_path(states: np.ndarray, layout: StateLayout, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """The root's ground path of character states [..., T, D] integrated from their velocity slots (NumPy).

    As :func:`ground_path`, with frame t's step ``root_linear_velocity[:2] / fps`` and its yaw change from
    ``root_angular_velocity``: ``q_{t-1}`` in frame t's heading frame is the tilt ``root_orientation`` with the
    step's heading-frame rotation (rotation vector ω / fps) undone, and ``ψ_t - ψ_{t-1}`` is minus its yaw.

    Returns:
        ``(xy, yaw)``: ground positions [..., T, 2] [m] and headings [..., T] [rad].
    """
    x = np.asarray(states, dtype=float)
    step_h = quat_from_rotation_vector(x[..., layout.slice("root_angular_velocity")] / fps)
    previous = quat_multiply(quat_conjugate(step_h), quat_normalize(x[..., layout.slice("root_orientation")]))
    return _integrate(-yaw_from_quat(previous), x[..., layout.slice("root_linear_velocity")][..., :2] / fps)


def world_end_effectors(states: Any, layout: StateLayout, ee_local: Any) -> Any:
    """End-effectors [..., T, E, 3] in the window's ground frame (:func:`ground_path`'s), z up from the ground.

    ``ee_local`` [..., T, E, 3] are heading-frame positions (relative to the root, e.g. FK of the
    states' joints); the root stands at ``root_height`` over its ground path. NumPy or torch.
    """
    xy, yaw = ground_path(states, layout)
    height = states[..., layout.slice("root_height")]
    if type(states).__module__.split(".", 1)[0] == "torch":
        import torch

        origin = torch.cat([xy, height], dim=-1)
    else:
        origin = np.concatenate([xy, np.asarray(height, dtype=float)], axis=-1)
    rotated = quat_rotate(quat_from_yaw(yaw)[..., None, :], ee_local)
    return origin[..., None, :] + rotated


def _normalise_and_clamp(morphology: Morphology, q: np.ndarray) -> ClampReport:
    """Renormalise spherical joints' quaternions and clamp limited 1-DoF joints, in place."""
    lower, upper = morphology.coordinate_limits
    names = morphology.coordinate_names
    limited = np.zeros(q.shape[1], dtype=bool)
    for j, start in zip(morphology.joints, morphology.joint_q_start[:-1], strict=True):
        if morphology.is_driven(j):
            continue
        if j.type == JointType.SPHERICAL:
            q[:, start : start + 4] = quat_canonical(quat_normalize(q[:, start : start + 4]))
        elif j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            limited[start] = np.isfinite(lower[start]) or np.isfinite(upper[start])
    cols = np.flatnonzero(limited)
    if not cols.size or not q.shape[0]:
        return ClampReport(0.0, 0.0, ())
    v = q[:, cols]
    over = np.maximum(v - upper[cols], 0.0) + np.maximum(lower[cols] - v, 0.0)
    q[:, cols] = np.clip(v, lower[cols], upper[cols])
    hit = over > 0
    return ClampReport(
        float(hit.mean()), float(over.max()), tuple(names[c] for c, h in zip(cols, hit.any(axis=0), strict=True) if h)
    )


# ---- torch twins ----------------------------------------------------------------------------


def _model(morphology: Morphology, model: KinematicModel | None) -> KinematicModel:
    if model is not None:
        return model
    from morphkit.motion._fk import compiled_model

    return compiled_model(morphology)


def _check_q(morphology: Morphology, q: torch.Tensor) -> None:
    if q.dim() < 2 or q.shape[-1] != morphology.coordinate_count:
        raise MotionFormatError(
            f"q: expected a motion of shape [..., T, {morphology.coordinate_count}] for {morphology.name!r}, "
            f"got {list(q.shape)}"
        )


def character_state_from_q(
    morphology: Morphology, q: torch.Tensor, fps: float, *, model: KinematicModel | None = None
) -> torch.Tensor:
    """Character states x^r [..., T, D] of coordinates ``q`` [..., T, C], differentiable in ``q``.

    Root pose, end-effectors and wheel angles come from morphkit's FK kernels through
    :mod:`morphkit.torch`; the formulas are those of the NumPy encoder (the same code), so the
    two agree to rounding. Use ``float64`` for finite-difference checks.

    Args:
        morphology: The character.
        q: Coordinates [..., T, C] (torch tensor, any device the model supports).
        fps: Frame rate [1/s].
        model: Its compiled model (default: compiled once per morphology, on the CPU).
    """
    import morphkit.torch as mt

    _check_q(morphology, q)
    k = _model(morphology, model)
    Ts = mt.fk(k, q, time_series=True)  # wheels turn with the base path, as in Motion
    ee = mt.end_effector_positions(k, q, time_series=True)
    return character_state(Ts[..., 0, :], q[..., morphology.base_coordinate_count :], ee, fps,
                           morphology=morphology)


def human_state_from_q(
    morphology: Morphology, q: torch.Tensor, fps: float, *, model: KinematicModel | None = None
) -> torch.Tensor:
    """Human states x^h [..., T, D] of coordinates ``q`` [..., T, C], differentiable in ``q``
    (as :func:`character_state_from_q`)."""
    import morphkit.torch as mt

    _check_q(morphology, q)
    k = _model(morphology, model)
    Ts = mt.fk(k, q, time_series=True)  # wheels turn with the base path, as in Motion
    ee = mt.end_effector_positions(k, q, time_series=True)
    return human_state(Ts[..., 0, :], Ts[..., :3], ee, fps)
