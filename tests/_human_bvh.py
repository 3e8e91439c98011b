"""Synthetic human clips in several joint-naming conventions, for the canonical-human tests (tests/motion,
tests/retarget): the canonical human moved by smooth random joint rotations, written as BVH text under
another convention's joint names (and, optionally, other bone lengths)."""

from __future__ import annotations

import dataclasses

import numpy as np

from morphkit.io.bvh import dump_bvh
from morphkit.motion import Motion, canonical_human, ground_motion, motion_to_bvh
from morphkit.rotations import quat_from_rotation_vector, quat_from_yaw

CMU22 = {
    "Hips": "root", "LeftUpLeg": "lhip", "LeftLeg": "lknee", "LeftFoot": "lankle", "LeftToeBase": "ltoe",
    "RightUpLeg": "rhip", "RightLeg": "rknee", "RightFoot": "rankle", "RightToeBase": "rtoe",
    "Spine": "lowerback", "Spine1": "upperback", "Spine2": "chest", "Neck": "lowerneck", "Head": "upperneck",
    "LeftShoulder": "lclavicle", "LeftArm": "lshoulder", "LeftForeArm": "lelbow", "LeftHand": "lwrist",
    "RightShoulder": "rclavicle", "RightArm": "rshoulder", "RightForeArm": "relbow", "RightHand": "rwrist",
}
"""Canonical link → CMU-22 joint name."""


def canonical_clip(frames: int = 40, fps: float = 30.0, seed: int = 0) -> Motion:
    """The canonical human walking forward and turning while every joint swings (≤ 0.35 rad), grounded."""
    c = canonical_human()
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    q = np.tile(c.rest_q(), (frames, 1))
    q[:, 0], q[:, 1], q[:, 2] = 0.9 * t, 0.1 * np.sin(t), 0.98
    q[:, 3:7] = quat_from_yaw(0.4 * t)
    for start in c.joint_q_start[:-1]:
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        angle = 0.35 * np.sin(2 * np.pi * rng.uniform(0.5, 1.5) * t + rng.uniform(0, 2 * np.pi))
        q[:, start : start + 4] = quat_from_rotation_vector(angle[:, None] * axis)
    return ground_motion(Motion(c, fps, q, "synthetic"))


def renamed_bvh(motion: Motion, names: dict[str, str] | None = None, *,
                bone_scale: dict[str, float] | None = None) -> str:
    """``motion`` (of the canonical human) as BVH text whose joints are called ``names[link]`` (default: the
    link's own name), each bone into a link in ``bone_scale`` scaled by that factor (the root's path by
    the legs' mean factor)."""
    bvh = motion_to_bvh(motion)
    names = names or {}
    joint_names = tuple(names.get(n, n) for n in bvh.joint_names)
    offsets = np.array(bvh.joint_offsets)
    columns = np.array(bvh.motion)
    if bone_scale:
        for link, f in bone_scale.items():
            offsets[bvh.joint_names.index(link)] *= f
        legs = np.mean([bone_scale.get(n, 1.0) for n in ("LeftLeg", "LeftFoot", "RightLeg", "RightFoot")])
        columns[:, :3] *= legs
    sites = tuple(dataclasses.replace(e, joint=joint_names[e.parent]) for e in bvh.end_sites)
    return dump_bvh(dataclasses.replace(bvh, joint_names=joint_names, joint_offsets=offsets, end_sites=sites,
                                        motion=columns))
