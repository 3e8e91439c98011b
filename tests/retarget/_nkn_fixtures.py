"""Shared pieces of the NKN tests: a human data folder with two skeletons of one topology, moved procedurally.

The clips are generated in closed form (no synthesis, milliseconds): the root walks forward while
turning slowly and bobbing, hips and knees swing about the lateral axis, arms swing opposite to the
legs, the spine sways. Each skeleton's root height follows its leg length, so feet stay near the ground.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np


def human():
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology

    return read_morphology(resolve_morphology("human"))


def _quat(axis: np.ndarray, angle: np.ndarray) -> np.ndarray:
    from morphkit.rotations import quat_from_axis_angle

    return quat_from_axis_angle(np.asarray(axis, float), angle)


def walk_motion(morphology, frames: int, *, seed: int, fps: float = 30.0, name: str = "walk"):
    """A procedural walk of any skeleton of the shipped human's topology."""
    from morphkit.graph import JointType
    from morphkit.motion import Motion

    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    freq = rng.uniform(0.8, 1.2)
    phase = 2 * np.pi * freq * t + rng.uniform(0, 2 * np.pi)
    speed = rng.uniform(0.6, 1.3) * morphology.leg_length / 0.93
    yaw_rate = rng.uniform(-0.4, 0.4)
    yaw = rng.uniform(-np.pi, np.pi) + yaw_rate * t
    q = np.zeros((frames, morphology.coordinate_count))
    q[:, 0] = np.cumsum(speed * np.cos(yaw)) / fps
    q[:, 1] = np.cumsum(speed * np.sin(yaw)) / fps
    q[:, 2] = morphology.rest_stance_height - 0.02 + 0.02 * np.cos(2 * phase)
    q[:, 3:7] = _quat([0, 0, 1], yaw)
    amp = rng.uniform(0.3, 0.5)
    for j, start in zip(morphology.joints, morphology.joint_q_start[:-1], strict=True):
        if j.type != JointType.SPHERICAL:
            continue
        side = 1.0 if "Left" in j.name else -1.0
        if j.name.endswith("UpLeg"):
            angle = side * amp * np.sin(phase)
        elif j.name.endswith("Leg"):
            angle = 0.6 * amp * (1 + np.sin(phase + side * np.pi / 2))
        elif j.name.endswith("Arm") and "Fore" not in j.name:
            q[:, start : start + 4] = _quat([1, 0, 0], np.full(frames, -side * 1.2))  # arms down from the T-pose
            continue
        elif j.name.endswith("ForeArm"):
            angle = -0.3 - 0.2 * (1 + side * np.sin(phase))
        elif j.name.startswith("Spine"):
            q[:, start : start + 4] = _quat([0, 0, 1], 0.05 * np.sin(phase))
            continue
        else:
            q[:, start : start + 4] = [0, 0, 0, 1]
            continue
        q[:, start : start + 4] = _quat([0, 1, 0], angle)
    return Motion(morphology, fps, q, name)


def write_skeleton_clips(folder: Path, *, clips: int = 3, frames: int = 96) -> Path:
    """``clips`` clips each of the shipped human and of a variant (legs ×0.8, arms ×1.2), as .npz."""
    from morphkit.motion import write_motion
    from morphkit.retarget.nkn.skeleton import scale_limbs

    folder.mkdir(parents=True, exist_ok=True)
    base = human()
    for k, skel in enumerate((base, scale_limbs(base, {"legs": 0.8, "arms": 1.2}, name="human_b"))):
        for i in range(clips):
            write_motion(walk_motion(skel, frames, seed=10 * k + i, name=f"walk_{k}_{i}"), folder / f"walk_{k}_{i}.npz")
    return folder
