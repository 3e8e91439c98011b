"""The skeleton graph every description becomes."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from morphkit.conventions import transform_multiply
from morphkit.errors import GraphError
from morphkit.graph.elements import EndEffector, Joint, Link, Wheels
from morphkit.graph.kinematics import link_poses_of_values
from morphkit.graph.layout import (
    BASE_COORD_NAMES,
    BASE_COORD_WIDTH,
    BASE_DOF_WIDTH,
    JOINT_COORD_WIDTH,
    JOINT_DOF_WIDTH,
)
from morphkit.graph.types import BaseType, BodyLengthRule, EndEffectorRole, JointType

__all__ = ["HUMAN_HAND_REACH", "UPRIGHT_FOOT_SLOPE", "Morphology"]

HUMAN_HAND_REACH = 2.2
"""How high a standing human's hand reaches above the ground, arm raised overhead, in body lengths
(standing root heights): the shipped human's 2.07 m over 0.98 m, CMU clips up to 2.13, plus a margin.
A creature without feet has the body length that puts its highest hand point there."""

UPRIGHT_FOOT_SLOPE = 0.2
"""A rest pose counts as upright when every foot lies below the root by at least this fraction of
its distance from the root (feet at least ~12° below the root's horizontal)."""

_ONE_DOF = (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)
_AXES = np.eye(3)


def _rotation(q: np.ndarray) -> np.ndarray:
    """Rotation matrix [3, 3] of a unit quaternion xyzw."""
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def _axis_rotation(axis: np.ndarray, angle: float) -> np.ndarray:
    """Rotation matrix [3, 3] by ``angle`` [rad] about the unit ``axis`` (Rodrigues)."""
    K = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * (K @ K)


def _matrix(p: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Homogeneous 4x4 matrix of a translation [3] and a rotation [3, 3]."""
    M = np.eye(4)
    M[:3, :3] = R
    M[:3, 3] = p
    return M


def _product(ms: Sequence[np.ndarray]) -> np.ndarray:
    """``ms[0] @ ms[1] @ ...`` folded from the left, starting at the identity."""
    M = np.eye(4)
    for m in ms:
        M = M @ m
    return M


def _tail_products(ms: Sequence[np.ndarray], starts: Sequence[int], tip: np.ndarray) -> dict[int, np.ndarray]:
    """``_product(ms[s:]) @ tip`` for every ``s`` of ``starts`` (ascending), the folds run side by side.

    Each fold multiplies the same matrices in the same order as :func:`_product` (a stacked matmul is
    one small matrix product per item), so the results are the same to the bit, in one pass over ``ms``.
    """
    if not starts:
        return {}
    first = np.asarray(starts)
    acc = np.broadcast_to(np.eye(4), (len(starts), 4, 4)).copy()
    for t in range(starts[0], len(ms)):
        k = int(np.searchsorted(first, t, side="right"))  # the folds that have begun by ms[t]
        acc[:k] = acc[:k] @ ms[t]
    return {s: acc[i] @ tip for i, s in enumerate(starts)}


@dataclass(frozen=True)
class Morphology:
    """A creature's kinematic tree, built and validated by :class:`~morphkit.graph.MorphologyBuilder`.

    Invariants (established by the builder): ``links[0]`` is the root; ``joints`` are in
    depth-first topological order and ``links[j + 1]`` is the child of ``joints[j]``.

    The coordinate vector ``q`` of a pose is ``[base coordinates, joint coordinates]``: the
    base's coordinates first (floating 7, planar 3, wheeled 3, fixed 0), then each
    independent joint's coordinates in joint order (revolute, continuous, prismatic 1;
    spherical 4 as xyzw; fixed 0). Mimic joints and wheel joints have no coordinates of their
    own: their values follow other coordinates.
    """

    name: str
    base: BaseType
    root: str
    links: tuple[Link, ...]
    joints: tuple[Joint, ...]
    end_effectors: tuple[EndEffector, ...] = ()
    wheels: Wheels | None = None
    source: str | None = None
    """Path of the description this was read from, if any."""
    declared_body_length: float | None = None
    """Body length [m] the description declares (YAML ``body_length:``); ``None``: :attr:`body_length`
    follows its rule."""
    rest_pose: tuple[tuple[str, float], ...] = ()
    """Values of 1-DoF joints [rad or m] at the rest pose, where it is not ``q = 0`` (an MJCF keyframe, a
    declared ``rest_pose:``, or a stance found for a file that has none); other joints rest at 0."""
    collision_excludes: tuple[tuple[str, str], ...] = ()
    """Link pairs never checked for self-collision beyond the parent–child rule (MJCF ``<contact><exclude>``)."""
    notes: tuple[str, ...] = field(default=(), compare=False)
    """What a reader decided where the description was silent (base type, rest pose), for ``morphkit info``."""

    # ---- lookups ---------------------------------------------------------------------------
    @property
    def link_count(self) -> int:
        return len(self.links)

    @property
    def joint_count(self) -> int:
        return len(self.joints)

    @cached_property
    def link_names(self) -> tuple[str, ...]:
        return tuple(link.name for link in self.links)

    @cached_property
    def joint_names(self) -> tuple[str, ...]:
        return tuple(j.name for j in self.joints)

    @cached_property
    def _link_index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.link_names)}

    @cached_property
    def _joint_index(self) -> dict[str, int]:
        return {n: i for i, n in enumerate(self.joint_names)}

    def link_index(self, name: str) -> int:
        """Index of link ``name`` in :attr:`links`."""
        try:
            return self._link_index[name]
        except KeyError:
            raise GraphError(f"no link {name!r} (links: {', '.join(self.link_names)})") from None

    def joint_index(self, name: str) -> int:
        """Index of joint ``name`` in :attr:`joints`."""
        try:
            return self._joint_index[name]
        except KeyError:
            raise GraphError(f"no joint {name!r} (joints: {', '.join(self.joint_names)})") from None

    def link(self, name: str) -> Link:
        return self.links[self.link_index(name)]

    def joint(self, name: str) -> Joint:
        return self.joints[self.joint_index(name)]

    def end_effector(self, name: str) -> EndEffector:
        for ee in self.end_effectors:
            if ee.name == name:
                return ee
        names = ", ".join(e.name for e in self.end_effectors)
        raise GraphError(f"no end-effector {name!r} (end-effectors: {names})")

    def parent_joint(self, link: str) -> Joint | None:
        """The joint whose child is ``link`` (``None`` for the root)."""
        i = self.link_index(link)
        return None if i == 0 else self.joints[i - 1]

    @cached_property
    def link_parent(self) -> tuple[int, ...]:
        """Parent link index of every link (-1 for the root), shape [link_count]."""
        return (-1, *(self.link_index(j.parent) for j in self.joints))

    def children(self, link: str) -> tuple[str, ...]:
        """Child links of ``link``, in joint order."""
        return tuple(j.child for j in self.joints if j.parent == link)

    def ee_by_role(self, role: EndEffectorRole) -> tuple[EndEffector, ...]:
        return tuple(e for e in self.end_effectors if e.role == role)

    # ---- coordinate and DoF layout ---------------------------------------------------------
    @cached_property
    def wheel_joints(self) -> frozenset[str]:
        """Rolling joints on fixed axles: turned by the base's path, without coordinates of their own."""
        return frozenset(self.wheels.joints) if self.wheels is not None else frozenset()

    @cached_property
    def wheel_steering_joints(self) -> frozenset[str]:
        """Steering and caster swivel joints and the rolling joints they carry: coordinates that synthesis sets from
        the base's path, no limb's and no arm's."""
        return frozenset(self.wheels.steering + self.wheels.steered) if self.wheels is not None else frozenset()

    def is_driven(self, joint: Joint) -> bool:
        """Whether a joint's value follows others (mimic joints and wheels)."""
        return joint.mimic is not None or joint.name in self.wheel_joints

    @cached_property
    def base_coordinate_count(self) -> int:
        return BASE_COORD_WIDTH[self.base]

    @cached_property
    def base_dof(self) -> int:
        return BASE_DOF_WIDTH[self.base]

    @cached_property
    def joint_q_start(self) -> tuple[int, ...]:
        """Start of each joint's coordinates in ``q``, shape [joint_count + 1] (last = coordinate_count)."""
        starts = [self.base_coordinate_count]
        for j in self.joints:
            starts.append(starts[-1] + (0 if self.is_driven(j) else JOINT_COORD_WIDTH[j.type]))
        return tuple(starts)

    @cached_property
    def joint_qd_start(self) -> tuple[int, ...]:
        """Start of each joint's DoFs in ``qd``, shape [joint_count + 1] (last = base_dof + dof)."""
        starts = [self.base_dof]
        for j in self.joints:
            starts.append(starts[-1] + (0 if self.is_driven(j) else JOINT_DOF_WIDTH[j.type]))
        return tuple(starts)

    @property
    def coordinate_count(self) -> int:
        """Length of ``q``, base coordinates included."""
        return self.joint_q_start[-1]

    @property
    def dof(self) -> int:
        """Independent joint DoFs, without the base and without driven joints (mimic, wheels)."""
        return self.joint_qd_start[-1] - self.base_dof

    @cached_property
    def coordinate_names(self) -> tuple[str, ...]:
        """Name of every entry of ``q``, shape [coordinate_count]."""
        names = list(BASE_COORD_NAMES[self.base])
        for j in self.joints:
            if self.is_driven(j):
                continue
            if j.type == JointType.SPHERICAL:
                names += [f"{j.name}.{c}" for c in ("qx", "qy", "qz", "qw")]
            elif JOINT_COORD_WIDTH[j.type] == 1:
                names.append(j.name)
        return tuple(names)

    @cached_property
    def coordinate_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bound of every entry of ``q`` (±inf where unbounded), each shape [coordinate_count]."""
        lower = np.full(self.coordinate_count, -np.inf)
        upper = np.full(self.coordinate_count, np.inf)
        for j, start in zip(self.joints, self.joint_q_start[:-1], strict=True):
            if self.is_driven(j):
                continue
            if j.type == JointType.SPHERICAL:
                lower[start : start + 4] = -1.0
                upper[start : start + 4] = 1.0
            elif j.limit is not None and j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
                lower[start], upper[start] = j.limit.lower, j.limit.upper
        return lower, upper

    def rest_q(self) -> np.ndarray:
        """The rest pose: base at the origin, identity rotations, joints at :attr:`rest_pose` (else 0) clamped
        into their limits."""
        q = np.zeros(self.coordinate_count)
        if self.base == BaseType.FLOATING:
            q[6] = 1.0
        starts = self.joint_q_start
        for name, value in self.rest_pose:
            ji = self.joint_index(name)
            if starts[ji + 1] - starts[ji] == 1:
                q[starts[ji]] = value
        for j, start in zip(self.joints, self.joint_q_start[:-1], strict=True):
            if j.type == JointType.SPHERICAL and not self.is_driven(j):
                q[start + 3] = 1.0
        lower, upper = self.coordinate_limits
        return np.clip(q, lower, upper)

    # ---- chains and geometry ---------------------------------------------------------------
    def chain(self, link: str) -> tuple[str, ...]:
        """Joint names from the root down to ``link``."""
        names: list[str] = []
        i = self.link_index(link)
        while i > 0:
            names.append(self.joints[i - 1].name)
            i = self.link_parent[i]
        return tuple(reversed(names))

    @cached_property
    def end_effector_chains(self) -> dict[str, tuple[str, ...]]:
        """Joint names from the root to each end-effector's link."""
        return {ee.name: self.chain(ee.link) for ee in self.end_effectors}

    def _rest_values(self) -> np.ndarray:
        """Joint values at :meth:`rest_q`, shape [joint_count, 3]: column 0 for 1-DoF joints; spherical joints 0."""
        q = self.rest_q()
        values = np.zeros((self.joint_count, 3))
        for ji, j in enumerate(self.joints):
            if not self.is_driven(j) and j.type in _ONE_DOF:
                values[ji, 0] = q[self.joint_q_start[ji]]
        return values

    def rest_link_poses(self) -> np.ndarray:
        """Link poses ``T_world_link`` at :meth:`rest_q`, root at the origin, shape [link_count, 7]
        (:func:`~morphkit.graph.kinematics.link_poses_of_values`, for queries only; ball joints rest at identity)."""
        return link_poses_of_values(self, self._rest_values()[None, :, 0])[0]

    def rest_points(self) -> np.ndarray:
        """Link origins and end-effector points at rest, shape [link_count + ee_count, 3] [m]."""
        poses = self.rest_link_poses()
        pts = [poses[:, :3]]
        for ee in self.end_effectors:
            T = poses[self.link_index(ee.link)]
            pts.append(transform_multiply(T, np.array([*ee.offset, 0, 0, 0, 1]))[None, :3])
        return np.concatenate(pts, axis=0)

    @cached_property
    def characteristic_length(self) -> float:
        """The rest pose's size [m], for framing and plausibility checks: its height.

        Height is the vertical extent of the link origins and end-effector points at rest; where
        that is degenerate (a creature lying flat) the largest extent along any axis is used, and
        1.0 for a single point. Features are normalised by :attr:`body_length` instead.
        """
        pts = self.rest_points()
        extent = pts.max(axis=0) - pts.min(axis=0)
        if extent[2] > 1e-6:
            return float(extent[2])
        if extent.max() > 1e-6:
            return float(extent.max())
        return 1.0

    # ---- body length -----------------------------------------------------------------------
    @property
    def body_length(self) -> float:
        """The length [m] Ψ divides by, putting a human and any creature on one scale, from the description alone.

        Trainers measure it on motion instead (:func:`morphkit.motion.measured_body_length`, which falls
        back on this without feet or motion).

        :attr:`declared_body_length` when the description gives one; otherwise, by
        :attr:`body_length_rule`:

        - **feet, upright at rest** (every foot below the root, see :data:`UPRIGHT_FOOT_SLOPE`):
          the root's height above its lowest foot at rest, so a standing creature's root is at
          1 and its feet at -1 in Ψ (human 0.98 m, crab 0.186 m, Spot 0.646 m on straight legs);
        - **feet, rest pose not upright** (BVH rigs posed lying or with paws forward): the mean leg
          length from the hip to the foot point, the height the root would stand at on straight
          legs; :func:`morphkit.motion.measured_body_length` measures the standing height on a motion instead;
        - **no feet, hands or tools** (wheeled and fixed robots): the highest point a hand reaches
          above the ground (:attr:`hand_height_range`) over :data:`HUMAN_HAND_REACH`, so its top
          reach stands for a human's hand raised overhead;
        - **neither**: :attr:`characteristic_length`.
        """
        return self._body_length[0]

    @property
    def body_length_rule(self) -> BodyLengthRule:
        """Which rule :attr:`body_length` followed."""
        return self._body_length[1]

    @cached_property
    def _body_length(self) -> tuple[float, BodyLengthRule]:
        if self.declared_body_length is not None:
            return float(self.declared_body_length), BodyLengthRule.DECLARED
        stance = self.rest_stance_height
        if stance is not None:
            return stance, BodyLengthRule.STANCE
        if self.ee_by_role(EndEffectorRole.FOOT):
            legs = self.leg_length
            if legs > 1e-6:
                return legs, BodyLengthRule.STRAIGHT_LEGS
        reach = self.hand_height_range
        if reach is not None and reach[1] > 1e-6:
            return reach[1] / HUMAN_HAND_REACH, BodyLengthRule.HAND_REACH
        return self.characteristic_length, BodyLengthRule.REST_EXTENT

    @cached_property
    def rest_stance_height(self) -> float | None:
        """The root's height above its lowest foot at rest [m], if the rest pose stands upright.

        ``None`` without feet, or when some foot is not below the root by at least
        :data:`UPRIGHT_FOOT_SLOPE` of its distance from it.
        """
        feet = self._rest_foot_points()
        if feet.shape[0] == 0:
            return None
        depth = -feet[:, 2]  # the root is at the origin
        if not np.all(depth >= UPRIGHT_FOOT_SLOPE * np.linalg.norm(feet, axis=1)) or depth.min() <= 1e-6:
            return None
        return float(depth.max())

    def _rest_foot_points(self) -> np.ndarray:
        pts = self.rest_points()[self.link_count :]
        idx = [i for i, e in enumerate(self.end_effectors) if e.role == EndEffectorRole.FOOT]
        return pts[idx]

    @cached_property
    def leg_length(self) -> float:
        """Mean length [m] of the legs, from the hip (the first joint only that foot's chain uses) to
        the foot point along the bones, the foot included (0 without feet); the canonical human's
        thigh + shank alone is :func:`morphkit.motion.canonical.thigh_shank_length`."""
        chains = self.end_effector_chains
        uses: dict[str, int] = {}
        for chain in chains.values():
            for name in chain:
                uses[name] = uses.get(name, 0) + 1
        lengths = []
        for ee in self.ee_by_role(EndEffectorRole.FOOT):
            own = [n for n in chains[ee.name] if uses[n] == 1]
            # Bones from the hip: every own joint's offset but the first (root to hip), then the foot point.
            bones = [np.linalg.norm(self.joint(n).origin.xyz) for n in own[1:]]
            lengths.append(float(sum(bones) + np.linalg.norm(ee.offset)))
        return float(np.mean(lengths)) if lengths else 0.0

    @cached_property
    def hand_height_range(self) -> tuple[float, float] | None:
        """Lowest and highest height [m] above the ground that any hand or tool end-effector reaches.

        Found by coordinate search over the joints of each hand's chain (1-DoF joints over their
        limits, ball joints over x, y, z rotations), with the base at rest. The ground is under the
        lowest foot at rest for creatures standing upright, ``z = 0`` for wheeled, planar and fixed
        bases (their root frame sits on the ground), the lowest rest point otherwise. ``None``
        without hands or tools.
        """
        hands = [e for e in self.end_effectors if e.role.on_arm]
        if not hands:
            return None
        if self.rest_stance_height is not None:
            ground = -self.rest_stance_height
        elif self.base == BaseType.FLOATING:
            ground = float(self.rest_points()[:, 2].min())
        else:
            ground = 0.0
        lows, highs = [], []
        for ee in hands:
            lows.append(self._extreme_height(ee, -1.0))
            highs.append(self._extreme_height(ee, 1.0))
        return min(lows) - ground, max(highs) - ground

    def _extreme_height(self, ee: EndEffector, sign: float, *, sweeps: int = 3) -> float:
        """Highest (``sign`` 1) or lowest (-1) z of ``ee`` [m], root at the origin, by coordinate search from rest."""
        chain = [self.joint_index(n) for n in self.end_effector_chains[ee.name]]
        # Joints whose value moves the chain: its own 1-DoF and ball joints, and the targets of its mimic joints.
        free: list[int] = []
        for ji in chain:
            j = self.joints[ji]
            target = self.joint_index(j.mimic.joint) if j.mimic is not None else ji
            t = self.joints[target]
            if target not in free and t.name not in self.wheel_joints and t.type in (*_ONE_DOF, JointType.SPHERICAL):
                free.append(target)
        # Chain positions each free joint's value enters (several where mimic joints follow it).
        enters: dict[int, list[int]] = {ji: [] for ji in free}
        for k, c in enumerate(chain):  # one pass: a scan per joint would cost the chain's length squared
            for ji in {c, self._mimic_target(c)}:
                if ji in enters:
                    enters[ji].append(k)
        tip = np.array([*ee.offset, 1.0])
        values = self._rest_values()
        locals_ = [self._local_matrix(c, values) for c in chain]

        best = sign * float((_product(locals_) @ tip)[2])
        for _ in range(sweeps):
            improved = False
            # Products before and after each joint, each the same left fold as multiplying them out (the
            # same floating-point result) but shared between joints: a long chain costs its length per
            # sweep, not its length squared. A head stays valid below the first change of the sweep,
            # a tail above the last.
            heads = [np.eye(4)]
            tails = _tail_products(locals_, sorted({enters[ji][-1] + 1 for ji in free if enters[ji]}), tip)
            changed = -1
            for ji in free:
                ks = enters[ji]
                if not ks:
                    continue
                lo, hi = ks[0], ks[-1] + 1
                while len(heads) <= lo:
                    heads.append(heads[-1] @ locals_[len(heads) - 1])
                head = heads[lo]
                tail = tails[hi] if changed < hi else _product(locals_[hi:]) @ tip
                for col, grid in self._search_grid(self.joints[ji]):
                    for x in grid:
                        trial = values.copy()
                        trial[ji, col] = x
                        middle = [self._local_matrix(chain[k], trial) if k in ks else locals_[k] for k in range(lo, hi)]
                        h = sign * float((head @ _product(middle) @ tail)[2])
                        if h > best + 1e-12:
                            best, values, improved = h, trial, True
                            locals_[lo:hi] = middle
                            del heads[lo + 1:]
                            changed = max(changed, hi - 1)
            if not improved:
                break
        return sign * best

    def _mimic_target(self, ji: int) -> int | None:
        m = self.joints[ji].mimic
        return None if m is None else self.joint_index(m.joint)

    @cached_property
    def _origin_matrices(self) -> np.ndarray:
        """Each joint's origin as a 4x4 matrix, shape [joint_count, 4, 4]."""
        out = np.zeros((self.joint_count, 4, 4))
        for ji, j in enumerate(self.joints):
            out[ji] = _matrix(np.asarray(j.origin.xyz, dtype=float), _rotation(np.asarray(j.origin.quat, dtype=float)))
        return out

    def _local_matrix(self, ji: int, values: np.ndarray) -> np.ndarray:
        """:meth:`_local_transform` as a 4x4 matrix (the search's fast path)."""
        j = self.joints[ji]
        value = j.mimic.multiplier * values[self.joint_index(j.mimic.joint), 0] + j.mimic.offset \
            if j.mimic is not None else values[ji, 0]
        M = self._origin_matrices[ji]
        if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
            return M @ _matrix(np.zeros(3), _axis_rotation(np.asarray(j.axis, dtype=float), value))
        if j.type == JointType.PRISMATIC:
            return M @ _matrix(value * np.asarray(j.axis, dtype=float), np.eye(3))
        if j.type == JointType.SPHERICAL and values[ji].any():
            R = _axis_rotation(_AXES[0], values[ji, 0]) @ _axis_rotation(_AXES[1], values[ji, 1]) \
                @ _axis_rotation(_AXES[2], values[ji, 2])
            return M @ _matrix(np.zeros(3), R)
        return M

    @staticmethod
    def _search_grid(j: Joint) -> list[tuple[int, np.ndarray]]:
        """(column, candidate values) to try for joint ``j`` in :meth:`_extreme_height`."""
        turn = np.linspace(-np.pi, np.pi, 12, endpoint=False)
        if j.type == JointType.SPHERICAL:
            return [(0, turn), (1, turn), (2, turn)]
        if j.limit is not None and j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            return [(0, np.linspace(j.limit.lower, j.limit.upper, 9))]
        return [(0, turn)]
