"""Contact-aware export by locking: feet in stance held at their touchdown point, the legs solved by IK.

Where :mod:`~morphkit.contact_export.replan` replaces a motion's steps by the planner's, ``lock`` keeps the
retargeter's own steps and only removes their slide: a foot is *in stance* by the contact rule's
``lock`` preset (:data:`~morphkit.contact_rules.LOCK`, decided from the frames up to the current
one); a stance foot's IK target is the point where it touched down, on the ground; a
lifted foot follows its own path again, the gap to it closed over ``blend_seconds``; a stance foot
whose own position has gone farther than ``max_offset`` of the leg's reach from its locked point (the
retargeter dragged it along) steps there, lifted, over ``step_seconds``. The legs are
solved by the synthesis' damped-least-squares IK kernel, warm-started from the motion's own leg angles,
so the legs keep the retargeter's style. Where a locked foot is out of the leg's reach the root comes
down until it reaches; every link is kept above the ground. Nothing else moves: the root path and
orientation and every non-leg joint stay as they were.

The result is **causal**: frame ``t`` depends on frames ``0..t`` only, so a streaming retargeter can
apply it frame by frame.

Choices that are ours (named here and in the docs): a foot is in stance within 5 cm of its ground
height (GMD's contact height, :func:`morphkit.metrics.skating_ratio`) and slower than 1 m/s, twice GMD's
skating speed, so that a foot a retargeter drags along the ground at a skating speed is still taken as
planted (a swinging foot near the ground, at touchdown and lift-off, is slower than a walk's 1–3 m/s
mid-swing only briefly, and is then released by its height); a foot's ground height is its height in
the creature's calibrated stance pose (clamped to ``[0, height]``), where the synthesis puts it on the
ground; a dragged foot steps after 30 % of its leg's reach, lifted by 10 % of it, over 0.2 s.
"""

from __future__ import annotations

import numpy as np

from morphkit.contact_rules import LOCK, ContactRule, contact_flags
from morphkit.graph import BaseType
from morphkit.motion.motion import Motion
from morphkit.synth.core import SynthConfig, prepare
from morphkit.synth.wheeled import Locomotion

__all__ = ["lock_feet", "stance_flags"]


def stance_flags(feet: np.ndarray, ground: np.ndarray, fps: float, *, rule: ContactRule = LOCK) -> np.ndarray:
    """Which feet are in stance by the contact ``rule`` (:data:`~morphkit.contact_rules.LOCK`: causal).

    Args:
        feet: Foot positions [T, F, 3] in the world [m].
        ground: Each foot's ground height [F] [m].
        fps: Frame rate [1/s]; a foot's speed at frame t is its horizontal step from frame t − 1.
        rule: The contact rule's preset.

    Returns:
        Flags [T, F] (bool).
    """
    return contact_flags(feet, fps, rule, np.asarray(ground)[None])


def lock_targets(feet: np.ndarray, stance: np.ndarray, ground: np.ndarray, blend: int, *,
                 max_offset: np.ndarray | None = None, step_frames: int = 6, step_height: float = 0.05) -> np.ndarray:
    """IK targets [T, F, 3] of the feet (see the module docstring), causally, from their own positions.

    Args:
        feet: The feet's own positions [T, F, 3] [m].
        stance: :func:`stance_flags` [T, F].
        ground: Each foot's ground height [F] [m].
        blend: Frames over which a touching-down foot comes to the ground and a lifted one returns to its path.
        max_offset: Per foot [F], the farthest its own position may get from its locked point [m] before
            the foot steps there (lifts by ``step_height``, lands over ``step_frames``); ``None``: never.
    """
    T, F, _ = feet.shape
    out = feet.copy()
    k = max(int(blend), 1)
    ks = max(int(step_frames), 1)
    for f in range(F):
        anchor = None
        since = 0  # frames since touchdown (in stance) or lift-off (in swing)
        stepping = 0  # frames left of a step to the foot's own position
        gap = np.zeros(3)  # target − own position at lift-off, closed over k (or ks) frames
        for t in range(T):
            own = feet[t, f]
            if anchor is not None and max_offset is not None and \
                    np.linalg.norm(anchor[:2] - own[:2]) > max_offset[f]:
                gap, since, anchor, stepping = out[t - 1, f] - feet[t - 1, f], 0, None, ks
            if stepping:
                # lift first, move while lifted, then set down: a step, not a glide along the ground
                s = (since + 1) / ks
                u = min(max((s - 0.2) / 0.6, 0.0), 1.0)
                out[t, f] = own + gap * (1.0 - u * u * (3.0 - 2.0 * u))
                out[t, f, 2] = max(out[t, f, 2], ground[f] + step_height * np.sqrt(np.sin(np.pi * s)))
                stepping -= 1
            elif stance[t, f]:
                if anchor is None:
                    anchor, since = np.array([own[0], own[1], ground[f]]), 0
                w = min(1.0, (since + 1) / k)
                out[t, f] = [anchor[0], anchor[1], own[2] + w * (anchor[2] - own[2])]
            else:
                if anchor is not None:
                    gap, since, anchor = out[t - 1, f] - feet[t - 1, f], 0, None
                out[t, f] = own + gap * max(0.0, 1.0 - (since + 1) / k)
            since += 1
            out[t, f, 2] = max(out[t, f, 2], ground[f])
    return out


def lock_feet(motion: Motion, *, rule: ContactRule = LOCK, blend_seconds: float = 0.1,
              max_offset: float = 0.3, step_seconds: float = 0.2, config: SynthConfig | None = None,
              stance: np.ndarray | None = None) -> Motion:
    """``motion`` with its stance feet locked at their touchdown points (see the module docstring).

    Args:
        motion: A motion of a legged creature (floating base); others come back unchanged.
        rule: When a foot is in stance (:data:`~morphkit.contact_rules.LOCK`: 5 cm above its ground height,
            1 m/s, causal).
        blend_seconds: Time over which a touching-down foot comes to the ground and a lifting foot
            returns to its own path [s].
        max_offset: Fraction of a leg's reach its foot's own position may get from its locked point
            before the foot steps to it (lifted by a tenth of the reach, over ``step_seconds``).
        config: Synthesis configuration whose IK and stance calibration are used (default :class:`SynthConfig`).
        stance: The retargeter's own stance flags [T, F] of the feet (:func:`~morphkit.motion.foot_names`
            order; as causal as the retargeter), used instead of deciding stance from height and speed.

    Returns:
        A motion of the same creature, frame rate and length: root orientation and ground path and
        every non-leg joint bit-identical to ``motion``'s; leg joints re-solved; the root lowered only
        where a locked foot is out of reach and raised only where a link would be below the ground.
    """
    m = motion.morphology
    if m.base != BaseType.FLOATING or motion.frame_count == 0:
        return motion
    rig = prepare(m, fps=motion.fps, config=config)
    if rig.locomotion != Locomotion.LEGGED or not rig.plan.legs:
        return motion
    cfg = rig.config
    solver = rig.solver
    names = [leg.end_effector for leg in rig.plan.legs]
    ee_index = {e.name: i for i, e in enumerate(m.end_effectors)}
    cols = [ee_index[n] for n in names]
    ik_ee = np.array([solver.model.ee_index(n) for n in names], dtype=np.int64)
    # every DoF of the legs' own joints, the ankles included (the synthesis' leg mask leaves them to
    # its foot-levelling step; here the foot point itself is what must stay put)
    qd = m.joint_qd_start
    joint_index = {j.name: i for i, j in enumerate(m.joints)}
    mask = np.zeros(int(qd[-1]), dtype=bool)
    for leg in rig.plan.legs:
        for name in leg.joints:
            ji = joint_index[name]
            mask[qd[ji]:qd[ji + 1]] = True
    stance_pose = Motion(m, motion.fps, np.asarray(rig.q_stance, dtype=float)[None])
    ground = np.clip(stance_pose.end_effector_positions()[0, cols, 2], 0.0, rule.height)

    feet = motion.end_effector_positions()[:, cols]
    if stance is None:
        stance = stance_flags(feet, ground, motion.fps, rule=rule)
    else:
        from morphkit.motion import foot_names

        order = {n: i for i, n in enumerate(foot_names(m))}
        stance = np.asarray(stance)[:, [order[n] for n in names]] > 0.5
    reach = np.array([leg.reach for leg in rig.plan.legs])
    targets = lock_targets(feet, stance, ground, round(blend_seconds * motion.fps), max_offset=max_offset * reach,
                           step_frames=round(step_seconds * motion.fps), step_height=0.1 * float(reach.mean()))

    def solve(q: np.ndarray, goal: np.ndarray) -> np.ndarray:
        return solver.solve(q, goal, key="lock_feet", ee=ik_ee, mask=mask, min_iterations=max(cfg.ik_iterations, 4),
                            max_iterations=max(cfg.ik_max_iterations, 24), tolerance=cfg.ik_tolerance)

    q = solve(np.array(motion.q, dtype=float, copy=True), targets)
    # a stance foot still above its target cannot reach down: lower the root by the gap, solve again
    reached = Motion(m, motion.fps, q).end_effector_positions()[:, cols]
    gap = np.where(stance, reached[..., 2] - targets[..., 2], 0.0).max(axis=1)
    low = np.nonzero(gap > 1e-3)[0]
    if low.size:
        q[low, 2] -= gap[low]
        q[low] = solve(q[low], targets[low])
    # every link above the ground (the links' origins: a retargeted torso may dip below it)
    depth = Motion(m, motion.fps, q).link_positions()[..., 2].min(axis=1)
    q[:, 2] -= np.minimum(depth, 0.0)
    return motion.replace(q=q)
