"""Left-right mirroring of a motion: the same clip as its mirror image across the sagittal plane.

The reflection is $M = \\mathrm{diag}(1, -1, 1)$ in world axes (x forward, y left, z up; see
:mod:`morphkit.conventions`). A mirrored pose puts every link where its left-right partner was,
reflected: $p'_i = M\\,p_{\\sigma(i)}$ and $R'_i = M R_{\\sigma(i)} M$, with $\\sigma$ the partner
map (a link on the midline is its own partner). A clip turning left becomes one turning right, a
wave of the left hand one of the right hand. Mocap pipelines double their data this way (PFNN,
MANN); morphkit uses it to make a small human data set symmetric (ACE's ``data.human_mirror``).

Partners are found from the description alone, top-down: joint ``j'`` is ``j``'s partner when its
parent link is the partner of ``j``'s parent link and its origin is ``j``'s origin reflected
(translation $M t$, rotation $M R M$, i.e. quaternion $(-x, y, -z, w)$). Then the coordinates map as
$M (T_o R(a, \\theta)) M = T'_o R(Ma, -\\theta)$: a revolute partner whose axis is $Ma$ takes
$-\\theta$, one whose axis is $-Ma$ takes $\\theta$; a prismatic one $d$ or $-d$; a spherical one
the partner's quaternion reflected. A description without such partners is refused.
"""

from __future__ import annotations

import numpy as np

from morphkit.errors import ConfigError
from morphkit.graph import BaseType, JointType, Morphology
from morphkit.motion.motion import Motion

__all__ = ["MIRRORED_SUFFIX", "MIRROR_TOLERANCE", "mirror_motion", "mirror_partners"]

MIRRORED_SUFFIX = "_mirrored"
"""What :func:`mirror_motion` appends to a clip's name."""

MIRROR_TOLERANCE = 1e-6
"""Largest difference [m, or unit-vector/quaternion components] between a joint's origin or axis and
its partner's reflected one that still counts as a mirror image."""

_REFLECT = np.array([1.0, -1.0, 1.0])
_QUAT_REFLECT = np.array([-1.0, 1.0, -1.0, 1.0])
"""$M R M$ for a rotation $R$ with quaternion (x, y, z, w) of $M = \\mathrm{diag}(1, -1, 1)$."""


def _same_rotation(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(min(np.abs(a - b).max(), np.abs(a + b).max()) <= MIRROR_TOLERANCE)


def _close(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.abs(a - b).max() <= MIRROR_TOLERANCE)


def mirror_partners(morphology: Morphology) -> tuple[tuple[int, float], ...]:
    """Each joint's mirror partner and the sign its coordinate takes.

    End-effector offsets and collision shapes are not compared: a motion holds joint coordinates only.

    Returns:
        Per joint (in the morphology's joint order), ``(partner joint index, sign)``: a revolute,
        continuous or prismatic joint's mirrored value is ``sign`` times its partner's value;
        spherical joints take their partner's quaternion reflected (sign 1), fixed joints nothing.

    Raises:
        ConfigError: a joint without a partner (the description is not left-right symmetric), naming it.
    """
    link_partner = {morphology.root: morphology.root}
    out: list[tuple[int, float]] = []
    for j in morphology.joints:
        parent = link_partner.get(j.parent)
        t, r = np.asarray(j.origin.xyz, float), np.asarray(j.origin.quat, float)
        a = np.asarray(j.axis, float)
        found: tuple[int, float] | None = None
        for k, c in enumerate(morphology.joints):
            if c.parent != parent or c.type != j.type or not _close(np.asarray(c.origin.xyz, float), _REFLECT * t):
                continue
            if not _same_rotation(np.asarray(c.origin.quat, float), _QUAT_REFLECT * r):
                continue
            b = np.asarray(c.axis, float)
            if j.type in (JointType.SPHERICAL, JointType.FIXED):
                found = (k, 1.0)
            elif _close(b, _REFLECT * a) or _close(b, -_REFLECT * a):
                flip = _close(b, _REFLECT * a)
                # M R(a, θ) M = R(Ma, −θ); a translation along a reflects without a sign change
                rotational = j.type in (JointType.REVOLUTE, JointType.CONTINUOUS)
                found = (k, (-1.0 if flip else 1.0) if rotational else (1.0 if flip else -1.0))
            if found is not None:
                break
        if found is None:
            raise ConfigError(
                f"mirror: {morphology.name!r} is not left-right symmetric: joint {j.name!r} (origin {j.origin.xyz}) "
                "has no partner whose origin and axis are its reflection across the x-z plane")
        out.append(found)
        link_partner[j.child] = morphology.joints[found[0]].child
    return tuple(out)


def mirror_motion(motion: Motion, *, name: str | None = None) -> Motion:
    """The motion reflected across the world x-z plane, every link in its partner's place.

    Args:
        motion: A motion of a left-right symmetric creature (:func:`mirror_partners`).
        name: The mirrored clip's name (default: ``motion.name`` + :data:`MIRRORED_SUFFIX`).

    Returns:
        A motion of the same creature, frame rate and length.

    Raises:
        ConfigError: the creature is not left-right symmetric.
    """
    m = motion.morphology
    partners = mirror_partners(m)
    q, out = motion.q, np.array(motion.q, copy=True)
    if m.base == BaseType.FLOATING:
        out[:, 1] = -q[:, 1]
        out[:, 3:7] = q[:, 3:7] * _QUAT_REFLECT
    elif m.base in (BaseType.PLANAR, BaseType.WHEELED):
        out[:, 1], out[:, 2] = -q[:, 1], -q[:, 2]
    starts = m.joint_q_start
    for i, (k, sign) in enumerate(partners):
        lo, hi = starts[i], starts[i + 1]
        if hi == lo:
            continue
        src = q[:, starts[k]:starts[k + 1]]
        if src.shape[1] != hi - lo:
            raise ConfigError(f"mirror: joint {m.joints[i].name!r} has coordinates and its partner "
                              f"{m.joints[k].name!r} follows another joint (or the other way round)")
        out[:, lo:hi] = src * _QUAT_REFLECT if m.joints[i].type == JointType.SPHERICAL else sign * src
    return Motion(m, motion.fps, out, name=f"{motion.name}{MIRRORED_SUFFIX}" if name is None else name)
