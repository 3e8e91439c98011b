"""Keeping a motion's upper body out of its own body and above the ground: a small joint change per frame.

A retargeter decides what the arms do; nothing in it knows the body's shapes, so a folded arm can
pass its wrist through the torso (measured: ACE on a quadruped with an arm, 5 % of held-out frames,
up to 10 cm deep). :func:`clear_upper_body` moves, in every frame where an upper-body shape overlaps
another shape of the creature or dips below the ground, the upper body's joints (arms, heads, tails:
the synthesis' upper body, never legs or the root) out by a short way, and leaves every other frame
exactly as it was:

* **the way out**: damped Gauss–Newton steps on the violated distances,
  Δq = (JᵀJ + λM)⁻¹ Jᵀ (clearance − d), clamped to the joint limits; ``J`` is the distances' derivative
  with respect to the upper body's 1-DoF joints and ``M = J_xᵀJ_x + 0.1 I`` measures how far a change
  moves the upper body's link origins (``J_x``), so the pose moves its points least, not its angles: a
  shoulder that swings the whole arm costs more than a wrist that tips the hand. Both derivatives are
  central finite differences through the FK kernels: a handful of joints in a few hundred frames per
  minute of motion, cheaper to write and to run than chaining the distance kernels' adjoints through FK;
* **the same way as the frame before**: a frame after a moved one starts from its own pose plus the
  previous frame's change, so consecutive frames leave the body the same way instead of each finding
  its own (which, measured on ACE's output, flipped the arm from side to side between frames);
* **as short as it can be**: the change is then shrunk to the smallest fraction that still clears
  (bisection), and refined by halving it and clearing again while that gives a shorter one, so it
  fades to nothing as the pose leaves the body;
* **else towards the standing pose**: where the steps find no way out — two shapes overlapping by a
  depth that does not change with the joints (a gripper's fingers closed past each other: the distance
  kernel's depth is flat there) — one joint moves towards its value in the synthesis' standing pose
  (which touches nothing), the one that clears with the shortest change, by as little as clears; if no
  single joint does, all of them together.

The result is **causal** (frame ``t`` depends on frames ``0..t`` only), so a streaming retargeter can
apply it frame by frame.

Choices that are ours (named here and in the docs): shape pairs are those the unrealistic-frame
metric checks (:func:`~morphkit.kernels.self_collision_pairs`, pairs that touch at rest skipped with the
synthesis' ``collision_rest_margin``, 5 mm) that touch an upper-body link, and the upper body's shapes
against the ground; the steps push to ``clearance`` (2 mm) off the surface and the shrinking stops at
touching; at most ``iterations`` (12) steps per frame, each at most 0.3 rad (or m) on any joint;
λ = 1e-3; four refinements. Ball joints in an upper body are not moved.
"""

from __future__ import annotations

import numpy as np

from morphkit.kernels import eval_fk
from morphkit.kernels.contact import (
    SelfCollisionPairs,
    eval_self_collision_distance,
    eval_shape_ground_distance,
    self_collision_pairs,
)
from morphkit.motion import compiled_model
from morphkit.motion.motion import Motion
from morphkit.synth.core import SynthConfig, prepare
from morphkit.synth.legged import limb_links

__all__ = ["UpperBodyClearance", "clear_upper_body"]

TOUCHING = 1e-6
"""Overlap [m] still taken as touching: a wheel standing on the ground, or round-off, is not a collision."""


class UpperBodyClearance:
    """The upper body's joints, limits and shape constraints of one creature (see the module docstring).

    Args:
        motion: Any motion of the creature (its morphology and frame rate pick the synthesis' rig).
        config: Synthesis configuration (upper body, rest margin; default :class:`SynthConfig`).
    """

    def __init__(self, motion: Motion, *, config: SynthConfig | None = None) -> None:
        m = motion.morphology
        rig = prepare(m, fps=motion.fps, config=config)
        self.morphology = m
        self.coordinates, self.lower, self.upper = rig.upper_coordinates
        self.rest = np.asarray(rig.q_stance, dtype=float)[self.coordinates]
        """The upper body's coordinates in the creature's standing pose, clear of the body by construction [k]."""
        self.model = compiled_model(m)
        moved: set[str] = set()
        starts = set(self.coordinates.tolist())
        for ji, j in enumerate(m.joints):
            # a joint without coordinates (fixed, a wheel driven by the base) starts where the next one does
            if m.joint_q_start[ji + 1] > m.joint_q_start[ji] and int(m.joint_q_start[ji]) in starts:
                moved |= limb_links(m, (j.name,))
        links = np.array(sorted(self.model.link_index(n) for n in moved), dtype=np.int64)
        pairs: SelfCollisionPairs | None = None
        if links.size:
            pairs = self_collision_pairs(self.model, rest_margin=rig.config.arms.collision_rest_margin).touching(links)
        self.pairs = pairs if pairs is not None and pairs.pair_count else None
        self.links = links
        """Links the upper body's joints move [L_u]."""
        self.shapes = np.flatnonzero(np.isin(np.asarray(self.model.shape_link), links))
        """Shapes on those links, kept above the ground [S]."""

    @property
    def empty(self) -> bool:
        """No upper-body joint, or nothing it could collide with."""
        return self.coordinates.size == 0 or (self.pairs is None and self.shapes.size == 0)

    def distances(self, q: np.ndarray) -> np.ndarray:
        """Signed distances [B, P + S] [m] of poses ``q`` [B, C]: every shape pair, then every upper-body shape's
        lowest point above the ground."""
        return self._measure(q)[0]

    def _measure(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distances [B, P + S] and the upper-body link origins [B, 3 L_u] of poses ``q`` [B, C]."""
        q = np.ascontiguousarray(q, dtype=np.float64)
        # wheels at 0: a wheel turns about its own axis, which leaves its shape's distances as they are
        X = eval_fk(self.model, q, device="cpu")
        parts = []
        if self.pairs is not None:
            parts.append(eval_self_collision_distance(self.model, self.pairs, X).numpy())
        if self.shapes.size:
            parts.append(eval_shape_ground_distance(self.model, X).numpy()[:, self.shapes])
        d = np.concatenate(parts, axis=1) if parts else np.zeros((len(q), 0))
        return d, X.numpy().reshape(len(q), -1, 7)[:, self.links, :3].reshape(len(q), -1)

    def clear(self, q: np.ndarray, *, clearance: float = 0.002, iterations: int = 12,
              refinements: int = 4) -> tuple[np.ndarray, np.ndarray]:
        """Poses ``q`` [T, C] (frames in time order) with their upper body moved clear, and which frames moved [T].

        Frames are cleared in order; a frame after a moved one starts from its own pose plus the previous
        frame's change (the same way out of the body, not a new one each frame), then that change is
        shrunk to the smallest fraction that still clears (bisection) and, up to ``refinements`` times, halved
        and cleared again while that makes it shorter, so it fades as the pose leaves the body.
        """
        q = np.array(q, dtype=float, copy=True)
        moved = np.zeros(len(q), dtype=bool)
        if self.empty or not len(q):
            return q, moved
        hit = np.flatnonzero((self.distances(q) < -TOUCHING).any(axis=1))
        idx = self.coordinates
        change = np.zeros(idx.size)
        for t in hit:
            raw = q[t].copy()
            if t == 0 or not moved[t - 1]:
                change[:] = 0.0
            start = raw.copy()
            start[idx] = np.clip(raw[idx] + change, self.lower, self.upper)
            change = self._shrink(raw, self._project(start, clearance, iterations)[idx] - raw[idx])
            for _ in range(refinements):
                # halve the way back to the frame's own pose and clear again: a shorter change in the same basin
                start[idx] = raw[idx] + 0.5 * change
                shorter = self._shrink(raw, self._project(start, clearance, iterations)[idx] - raw[idx])
                if np.linalg.norm(shorter) >= np.linalg.norm(change):
                    break
                change = shorter
            if not self._clear(raw, change):
                change = self._towards_rest(raw)
            q[t, idx] = raw[idx] + change
            moved[t] = True
        return q, moved

    def _project(self, q: np.ndarray, clearance: float, iterations: int, *, max_step: float = 0.3,
                 damping: float = 1e-3, eps: float = 1e-5) -> np.ndarray:
        """Gauss–Newton steps from pose ``q`` [C] until no distance is negative (or the steps run out), each pushing
        the violated ones to ``clearance``."""
        idx, k = self.coordinates, self.coordinates.size
        eye = np.eye(k)
        q = q.copy()
        d = self.distances(q[None])[0]
        for _ in range(iterations):
            r = np.maximum(clearance - d, 0.0)  # only what is violated pushes
            if (d >= -TOUCHING).all():
                break
            # central differences of every distance and link origin with respect to every upper-body coordinate
            probe = np.repeat(q[None], 2 * k, axis=0)
            probe[:, idx] += np.concatenate([eye, -eye]) * eps
            dp, xp = self._measure(probe)
            J = (dp[:k] - dp[k:]).T / (2 * eps) * (r > 0)[:, None]  # [P + S, k]
            Jx = (xp[:k] - xp[k:]).T / (2 * eps)  # [3 L_u, k]
            # the metric: how far the upper body's links move (a shoulder swings the whole arm, a wrist only the
            # hand) plus 0.1 m² per rad² (a joint that moves no link origin, a wrist's roll, still costs)
            M = Jx.T @ Jx + 0.1 * eye
            dq = np.linalg.solve(J.T @ J + damping * M, J.T @ r)
            dq *= min(1.0, max_step / max(float(np.abs(dq).max()), 1e-12))
            q[idx] = np.clip(q[idx] + dq, self.lower, self.upper)
            d = self.distances(q[None])[0]
        return q

    def _towards_rest(self, raw: np.ndarray) -> np.ndarray:
        """Where the steps found no way out (two shapes overlapping by a depth that does not change with the
        joints, as a gripper's fingers closed past each other): the shortest change [k] that clears by taking one
        upper-body coordinate towards its standing value, else all of them together."""
        idx = self.coordinates
        towards = self.rest - raw[idx]
        best: np.ndarray | None = None
        for j in np.flatnonzero(towards):
            one = np.zeros_like(towards)
            one[j] = towards[j]
            if self._clear(raw, one):
                one = self._shrink(raw, one)
                if best is None or np.abs(one).sum() < np.abs(best).sum():
                    best = one
        return best if best is not None else self._shrink(raw, towards)

    def _shrink(self, raw: np.ndarray, change: np.ndarray, *, steps: int = 6) -> np.ndarray:
        """The smallest fraction of ``change`` [k] (of the upper-body coordinates) that keeps pose ``raw`` + it clear,
        by bisection (the whole change if even that does not clear)."""
        lo, hi = 0.0, 1.0
        for _ in range(steps):
            mid = 0.5 * (lo + hi)
            if self._clear(raw, mid * change):
                hi = mid
            else:
                lo = mid
        return hi * change

    def _clear(self, raw: np.ndarray, change: np.ndarray) -> bool:
        """Pose ``raw`` [C] with ``change`` [k] added to its upper body overlaps nothing."""
        p = raw.copy()
        p[self.coordinates] += change
        return bool((self.distances(p[None])[0] >= -TOUCHING).all())


def clear_upper_body(motion: Motion, *, clearance: float = 0.002, iterations: int = 12,
                     config: SynthConfig | None = None) -> Motion:
    """``motion`` with its upper body moved out of the creature's other shapes and above the ground, frame by
    frame, by a short change of the upper body's joints (see the module docstring).

    Args:
        motion: A motion of any creature; one without an upper body (or whose upper body touches nothing)
            comes back unchanged.
        clearance: Distance the steps push a shape from the surface it met [m] (the shortened change ends
            between touching and this).
        iterations: Most Gauss–Newton steps per frame.
        config: Synthesis configuration (which joints are the upper body; default :class:`SynthConfig`).

    Returns:
        A motion of the same creature, frame rate and length: every frame in which no upper-body shape
        overlaps another or dips below the ground bit-identical to ``motion``'s; in the others only the
        upper body's joints changed.
    """
    if motion.frame_count == 0:
        return motion
    guard = UpperBodyClearance(motion, config=config)
    q, moved = guard.clear(motion.q, clearance=clearance, iterations=iterations)
    return motion.replace(q=q) if moved.any() else motion
