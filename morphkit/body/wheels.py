"""Wheels found from the body: which joints spin wheels, which steer or swivel, and the drive they make.

:func:`find_wheels` is called by :func:`morphkit.body.anatomy.complete_anatomy` before any part is
decided: a body it finds wheeled comes back with a wheeled base and its :class:`~morphkit.graph.Wheels`,
and the links the wheels carry are no limb's (:func:`wheel_carried_links`). A description that declares its
wheels (YAML ``wheels:``) is kept as it is.

A wheel is a joint that spins about a horizontal axis (root frame, at rest) — continuous, unlimited, or a fixed
joint named as a wheel that the file froze — carrying a round shape (a cylinder along the axis, a sphere on it,
or a mesh whose bounds are round about it) that touches the ground, with nothing moving below it. Its radius
comes from the shape, else from the axle's height above the ground (the body's lowest shape at rest). A
vertical revolute or continuous joint above a wheel (through fixed joints) steers it: a limited one is a
steering joint, an unlimited one a caster swivel. The drive follows from the arrangement:

- every wheel swivels, or the wheels are omni / mecanum (by name): **holonomic** (powered casters);
- limited steering joints and wheels on one fixed axle: **ackermann**;
- wheels on one fixed axle (passive casters or ball casters beside them): **differential**;
- wheels on fixed axles at two or more places along the base: **skid_steer**.

The root becomes the drive's reference point on the ground (:func:`drive_centre`): a new root link there
carries the file's root, so that the base's planar coordinates ``[x, y, yaw]`` move the drive without slip.
:func:`drive_of` says what the wheels allow (:class:`Drive`): sideways motion or not, the tightest turn, and the
top speed — the wheels' velocity limit × radius where the description gives one, else one track width per second.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np

from morphkit.body.kinematics import BodyKinematics
from morphkit.graph import BaseType, Joint, JointType, Link, Morphology, ShapeType, Transform, Wheels

__all__ = ["Drive", "FoundWheel", "drive_centre", "drive_of", "find_wheels", "found_wheels", "wheel_carried_links"]

_DEFAULT_MAX_STEER = math.radians(35.0)
"""An Ackermann drive's steering limit [rad] where the description gives none (a typical car's inner wheel)."""

_HORIZONTAL = 0.26
"""Largest |z| of a spin axis (unit, root frame) that still rolls the base: 15°."""
_VERTICAL = 0.9
"""Smallest |z| of a steering axis (unit, root frame)."""
_ROUND = 0.2
"""Largest relative difference of a mesh's two extents across its axle, and of a shape's centre off the axle."""
_SPIN_NAME = re.compile(r"wheel", re.IGNORECASE)
_SWIVEL_NAME = re.compile(r"caster|steer|swivel", re.IGNORECASE)
_OMNI_NAME = re.compile(r"omni|mecanum|swedish", re.IGNORECASE)


@dataclass(frozen=True)
class FoundWheel:
    """One wheel at rest, in the file's root frame."""

    joint: str
    """Its spin joint."""
    centre: tuple[float, float, float]
    """Axle centre [m]."""
    axis: tuple[float, float, float]
    """Spin axis (unit), the joint's positive rotation."""
    radius: float
    """[m]."""
    radius_from: str
    """``"cylinder"``, ``"sphere"``, ``"mesh bounds"`` or ``"axle height"``."""
    swivel: str | None
    """The vertical joint above it (steering or caster swivel), if any."""
    limited: bool
    """Whether that joint has limits narrower than a turn (a steering joint, not a free swivel)."""
    frozen: tuple[str, ...]
    """Fixed joints of the file that this wheel needs to turn (the spin, maybe the swivel)."""
    pivot: tuple[float, float, float] | None = None
    """Where the swivel's axis is [m] (``None`` without a swivel)."""


def _unit(v: np.ndarray) -> np.ndarray:
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else v


@lru_cache(maxsize=256)
def mesh_bounds(path: str) -> tuple[tuple[float, ...], tuple[float, ...]] | None:
    """A mesh file's axis-aligned bounds in its own frame (lower, upper corners [m]), or None where it cannot be
    read (the reader reported it). Cached: the wheel finding and the anatomy ask for the same meshes."""
    try:
        import trimesh

        lo, hi = trimesh.load(path, force="mesh").bounds
        return tuple(float(v) for v in lo), tuple(float(v) for v in hi)
    except Exception:  # an unreadable mesh only loses its points here
        return None


def _shape_frame(shape) -> np.ndarray:
    M = np.eye(4)
    x, y, z, w = shape.origin.quat
    M[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    M[:3, 3] = shape.origin.xyz
    return M


def _round_radius(shape, T: np.ndarray, axis: np.ndarray, centre: np.ndarray) -> tuple[float, str] | None:
    """Radius [m] of ``shape`` (posed by ``T`` in the spin joint's frame) if it is round about the axle through
    ``centre`` along ``axis`` (both in that frame), else ``None``."""
    M = T @ _shape_frame(shape)
    p = M[:3, 3]
    off = p - centre
    off_axle = float(np.linalg.norm(off - axis * (off @ axis)))
    if shape.type == ShapeType.CYLINDER and abs(float(M[:3, 2] @ axis)) > 0.95 and off_axle <= _ROUND * shape.radius:
        return shape.radius, "cylinder"
    if shape.type == ShapeType.SPHERE and off_axle <= _ROUND * shape.radius:
        return shape.radius, "sphere"
    if shape.type == ShapeType.MESH and shape.mesh:
        b = mesh_bounds(shape.mesh)
        if b is None:
            return None
        lo, hi = np.asarray(b[0]) * shape.scale, np.asarray(b[1]) * shape.scale
        mid = M[:3, :3] @ ((hi + lo) / 2) + p
        ext = np.abs(M[:3, :3]) @ ((hi - lo) / 2)
        across = [float(ext[k]) for k in range(3) if abs(axis[k]) < 0.5]
        moff = mid - centre
        if len(across) == 2 and max(across) > 0:
            r = 0.5 * (across[0] + across[1])
            if abs(across[0] - across[1]) <= _ROUND * r and np.linalg.norm(moff - axis * (moff @ axis)) <= _ROUND * r:
                return r, "mesh bounds"
    return None


def _lowest(m: Morphology, poses: np.ndarray) -> float | None:
    """Lowest z [m] of the body's measurable shapes at ``poses`` (root frame), ``None`` without any."""
    low = math.inf
    corners = np.array(list(np.ndindex(2, 2, 2)), dtype=float) - 0.5
    for li, link in enumerate(m.links):
        for s in link.shapes:
            M = poses[li] @ _shape_frame(s)
            if s.type == ShapeType.SPHERE:
                low = min(low, M[2, 3] - s.radius)
            elif s.type in (ShapeType.CYLINDER, ShapeType.CAPSULE):
                a = M[:3, 2]
                cap = s.radius if s.type == ShapeType.CAPSULE else 0.0
                # lowest point of a disc rim: centre - r * sqrt(1 - a_z^2) along z
                rim = s.radius * math.sqrt(max(0.0, 1.0 - a[2] ** 2)) + cap
                low = min(low, M[2, 3] - abs(a[2]) * s.length / 2 - rim)
            elif s.type == ShapeType.BOX:
                low = min(low, float((M[:3, :3] @ (corners * s.size).T)[2].min() + M[2, 3]))
            elif s.type == ShapeType.MESH and s.mesh and (b := mesh_bounds(s.mesh)) is not None:
                lo, hi = np.asarray(b[0]) * s.scale, np.asarray(b[1]) * s.scale
                pts = (corners + 0.5) * (hi - lo) + lo
                low = min(low, float((M[:3, :3] @ pts.T)[2].min() + M[2, 3]))
    return None if low == math.inf else float(low)


def _spins(j: Joint) -> bool:
    if j.type == JointType.CONTINUOUS:
        return True
    if j.type == JointType.REVOLUTE:
        return j.limit is None or j.limit.upper - j.limit.lower >= 2 * math.pi - 1e-6
    return j.type == JointType.FIXED and bool(_SPIN_NAME.search(j.name)) and any(j.axis)


def _swivels(j: Joint) -> bool:
    if j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
        return True
    return j.type == JointType.FIXED and bool(_SWIVEL_NAME.search(j.name)) and any(j.axis)


def found_wheels(m: Morphology) -> tuple[list[FoundWheel], float]:
    """The wheels of ``m``'s body at rest and the ground's height [m] in its root frame.

    Every wheel touches the ground (its lowest point within ``max(0.15 r, 5 mm)`` of it) and, unless it swivels,
    has a partner across the base (the other side of the root's x–z plane, at about the same x and height).
    """
    if not m.joints:
        return [], 0.0
    kin = BodyKinematics(m)
    P = kin.poses(kin.rest[None])[0]
    moving_below = [False] * m.link_count  # whether a non-fixed joint lies below each link
    for ji in range(m.joint_count - 1, -1, -1):
        child = ji + 1
        if m.joints[ji].type != JointType.FIXED or moving_below[child]:
            moving_below[m.link_parent[child]] = True
    kids: dict[int, list[int]] = {}
    for ji in range(m.joint_count):
        kids.setdefault(m.link_parent[ji + 1], []).append(ji)

    def fixed_subtree(li: int) -> list[int]:
        out, todo = [li], [li]
        while todo:
            for ji in kids.get(todo.pop(), []):
                if m.joints[ji].type == JointType.FIXED:
                    out.append(ji + 1)
                    todo.append(ji + 1)
        return out

    cands = []
    for ji, j in enumerate(m.joints):
        child = ji + 1
        if not _spins(j) or moving_below[child]:
            continue  # a wheel carries nothing that moves
        axis_local = _unit(np.asarray(j.axis, dtype=float))
        axis = P[child][:3, :3] @ axis_local
        if abs(axis[2]) > _HORIZONTAL:
            continue
        centre = P[child][:3, 3]
        best: tuple[float, str] | None = None
        Tinv = np.linalg.inv(P[child])
        for li in fixed_subtree(child):
            T = Tinv @ P[li]
            for s in m.links[li].shapes:
                got = _round_radius(s, T, axis_local, np.zeros(3))
                if got is not None and (best is None or got[0] > best[0]):
                    best = got
        shapes_known = any(
            s.type != ShapeType.MESH or (s.mesh and mesh_bounds(s.mesh) is not None)
            for li in fixed_subtree(child) for s in m.links[li].shapes)
        if best is None and shapes_known:
            continue  # it has a body, and that body is not round about the axle: a roll joint, not a wheel
        if best is None and j.type == JointType.FIXED:
            continue
        cands.append((ji, j, centre, axis, best))
    if not cands:
        return [], 0.0
    shaped = [c[2][2] - c[4][0] for c in cands if c[4] is not None]
    low = _lowest(m, P)
    # the ground is under the body's lowest point: a wheel must reach it, not merely be the lowest round thing
    ground = min([*shaped, *([low] if low is not None else [])], default=0.0)
    wheels: list[FoundWheel] = []
    for ji, j, centre, axis, best in cands:
        r, how = best if best is not None else (float(centre[2] - ground), "axle height")
        if r <= 1e-3 or abs(centre[2] - r - ground) > max(0.15 * r, 0.005):
            continue
        swivel, limited, frozen, pivot = None, False, [j.name] if j.type == JointType.FIXED else [], None
        li = m.link_parent[ji + 1]
        while li > 0:
            pj = m.joints[li - 1]
            if pj.type != JointType.FIXED or (_swivels(pj) and _SWIVEL_NAME.search(pj.name)):
                a = P[li][:3, :3] @ _unit(np.asarray(pj.axis, dtype=float))
                if _swivels(pj) and abs(a[2]) >= _VERTICAL:
                    swivel = pj.name
                    pivot = tuple(float(v) for v in P[li][:3, 3])
                    limited = (pj.type == JointType.REVOLUTE and pj.limit is not None
                               and pj.limit.upper - pj.limit.lower < 2 * math.pi - 1e-6)
                    if pj.type == JointType.FIXED:
                        frozen.append(pj.name)
                break
            li = m.link_parent[li]
        wheels.append(FoundWheel(j.name, tuple(float(v) for v in centre), tuple(float(v) for v in axis),  # type: ignore[arg-type]
                                 float(r), how, swivel, limited, tuple(frozen), pivot))  # type: ignore[arg-type]
    # fixed-axle wheels need a partner across the base; a lone one is a roller of something else
    def partnered(w: FoundWheel) -> bool:
        return any(o is not w and o.centre[1] * w.centre[1] < 0
                   and abs(o.centre[0] - w.centre[0]) <= 0.25 * abs(o.centre[1] - w.centre[1])
                   and abs(o.centre[2] - w.centre[2]) <= 0.25 * w.radius for o in wheels)

    kept = [w for w in wheels if w.swivel is not None or partnered(w)]
    if len(kept) < 2 or len({w.swivel for w in kept if w.swivel is not None}) + sum(w.swivel is None for w in kept) < 2:
        return [], ground
    return kept, ground


def _axles(ws: list[FoundWheel], tol: float) -> list[list[FoundWheel]]:
    """Wheels grouped by their x [m] along the base (within ``tol``)."""
    groups: list[list[FoundWheel]] = []
    for w in sorted(ws, key=lambda w: w.centre[0]):
        if groups and w.centre[0] - groups[-1][-1].centre[0] <= tol:
            groups[-1].append(w)
        else:
            groups.append([w])
    return groups


def _classify(m: Morphology, ws: list[FoundWheel]) -> tuple[str, list[FoundWheel], list[FoundWheel], str]:
    """The drive, the fixed-axle wheels, the steered wheels and why."""
    fixed = [w for w in ws if w.swivel is None]
    steered = [w for w in ws if w.swivel is not None]
    size = max(abs(w.centre[1]) for w in ws)
    for w in ws:
        # the rollers of omni and mecanum wheels are not in the file: only names say so (a wheel's, or a mesh
        # of the wheel or of what carries it, e.g. PAL's ``omni_base`` folder)
        li = m.joint_index(w.joint) + 1
        names = [w.joint]
        while li >= 0:
            names += [m.links[li].name, *(s.mesh for s in m.links[li].shapes if s.mesh)]
            li = m.link_parent[li]
        hit = next((n for n in names if _OMNI_NAME.search(n)), None)
        if hit is not None:
            word = next(part for part in re.split(r"[/\\]", hit) if _OMNI_NAME.search(part))
            return "holonomic", ws, [], f"omni / mecanum wheels (named so in the file: {word!r})"
    if not fixed:
        return "holonomic", [], steered, f"every wheel swivels ({len({w.swivel for w in steered})} powered casters)"
    axles = _axles(fixed, 0.1 * size)
    if steered and any(w.limited for w in steered):
        return "ackermann", fixed, steered, (f"steered wheels ({', '.join(sorted({w.swivel for w in steered}))}) "
                                             f"and {len(fixed)} wheels on a fixed axle")
    if len(axles) == 1:
        extra = f", {len({w.swivel for w in steered})} caster swivels" if steered else ""
        return "differential", fixed, steered, f"{len(fixed)} wheels on one fixed axle{extra}"
    return "skid_steer", fixed, steered, f"{len(fixed)} fixed wheels on {len(axles)} axles"


def drive_centre(ws: list[FoundWheel], drive: str, fixed: list[FoundWheel]) -> tuple[float, float]:
    """The drive's reference point [m] (root frame x, y): the fixed axle's middle (differential, Ackermann), the
    wheels' centre otherwise (a caster's by its swivel axis) — the point whose path has no sideways slip."""
    use = fixed if drive in ("differential", "ackermann") and fixed else ws
    c = np.mean([(w.pivot or w.centre)[:2] for w in use], axis=0)
    return float(c[0]), float(c[1])


def _support_balls(m: Morphology, ws: list[FoundWheel], ground: float) -> int:
    """Spheres on no wheel that touch the ground at rest (ball casters)."""
    kin = BodyKinematics(m)
    P = kin.poses(kin.rest[None])[0]
    carried = set()
    names = {w.joint for w in ws}
    for ji, j in enumerate(m.joints):
        if j.name in names or m.link_parent[ji + 1] in carried:
            carried.add(ji + 1)
    n = 0
    for li, link in enumerate(m.links):
        if li in carried:
            continue
        for s in link.shapes:
            if s.type == ShapeType.SPHERE:
                z = (P[li] @ _shape_frame(s))[2, 3] - s.radius
                n += abs(z - ground) <= max(0.15 * s.radius, 0.005)
    return n


def find_wheels(m: Morphology) -> Morphology:
    """``m`` with a wheeled base and its wheels where its body carries them on wheels, else ``m`` unchanged.

    The new root link (``<root>_drive``) sits on the ground at the drive's reference point, with the file's root
    fixed on it; fixed joints the file froze on a wheel or swivel become continuous; a note says what was found.
    """
    if m.wheels is not None:
        return m
    ws, ground = found_wheels(m)
    if not ws:
        return m
    drive, fixed, steered, why = _classify(m, ws)
    cx, cy = drive_centre(ws, drive, fixed)
    radii = [w.radius for w in (fixed or steered)]
    radius = float(np.median(radii))
    track = max(w.centre[1] for w in ws) - min(w.centre[1] for w in ws)
    max_steer = None
    steering = tuple(dict.fromkeys(w.swivel for w in steered if w.swivel is not None))
    if drive == "ackermann":
        lims = [m.joint(s).limit for s in steering if m.joint(s).limit is not None]
        max_steer = min(min(-lim.lower, lim.upper) for lim in lims)  # type: ignore[union-attr]
        max_steer = float(min(max_steer, math.radians(80.0)))
    frozen = {n for w in ws for n in w.frozen}
    joints = tuple(replace(j, type=JointType.CONTINUOUS) if j.name in frozen else j for j in m.joints)
    links = m.links
    root = m.root
    moved = abs(cx) > 1e-4 or abs(cy) > 1e-4 or abs(ground) > 1e-4
    if moved:
        root = f"{m.root}_drive"
        while root in m.link_names:
            root += "_"
        links = (Link(root), *links)
        joints = (Joint(f"{root}_joint", JointType.FIXED, root, m.root, Transform((-cx, -cy, -ground))), *joints)
    how = sorted({w.radius_from for w in ws})
    balls = _support_balls(m, ws, ground)
    reason = (f"{drive}: {why}{f', {balls} ball casters' if balls else ''}; radius {radius:.4g} m "
              f"(from {', '.join(how)}), track {track:.3g} m"
              + (f", steering up to {max_steer:.3g} rad" if max_steer is not None else ""))
    notes = []
    if frozen:
        notes.append(f"wheels: {', '.join(sorted(frozen))} fixed in the file, turned here")
    if moved:
        notes.append(f"base: wheeled — root {root} on the ground at the drive's centre, "
                     f"({cx:+.3f}, {cy:+.3f}, {ground:+.3f}) m in {m.root}")
    else:
        notes.append(f"base: wheeled — it drives on its wheels, root {root} on the ground at the drive's centre")
    radii = tuple(w.radius for w in steered)
    wheels = Wheels(tuple(w.joint for w in fixed), radius, drive, steering, tuple(w.joint for w in steered),
                    radii if any(abs(r - radius) > 1e-9 for r in radii) else (), max_steer, reason)
    kept_notes = tuple(n for n in m.notes if not n.startswith("base: fixed"))
    return replace(m, base=BaseType.WHEELED, root=root, links=links, joints=joints, wheels=wheels,
                   notes=kept_notes + tuple(notes))


@dataclass(frozen=True)
class Drive:
    """What a wheeled base's wheels allow (root frame; the root is the drive's reference point on the ground)."""

    kind: str
    """One of :data:`~morphkit.graph.elements.WHEEL_DRIVES`."""
    top_speed: float
    """Fastest rim speed of any wheel [m/s]: the base's top speed straight ahead."""
    rule: str
    """Where :attr:`top_speed` comes from."""
    half_track: float
    """Half the lateral spread of the fixed-axle wheels [m] (their rim speed while turning)."""
    reach: float
    """Largest horizontal distance of a wheel from the root [m] (a holonomic base's rim speed while turning)."""
    min_turn_radius: float
    """Tightest turn of the root [m] (Ackermann: its inner wheel at the steering limit; 0: turns on the spot)."""
    track: float = 0.0
    """Lateral spread of the fixed-axle wheels' centres [m] (of all wheels where none is on a fixed axle)."""

    def clamp(self, cmd: np.ndarray) -> np.ndarray:
        """Heading-frame velocity commands ``[..., 3]`` (forward, lateral [m/s], yaw rate [rad/s]) scaled and
        clipped into what the wheels allow (a copy): no sideways motion but on a holonomic base, no turn tighter
        than :attr:`min_turn_radius`, no wheel faster than :attr:`top_speed` (the rim speed ``|v| + |ω| · arm``). An
        Ackermann command is scaled as a whole (its curvature kept); other drives keep the yaw rate while it fits
        and give the travel speed what rim speed is left."""
        out = np.array(cmd, dtype=float, copy=True)
        v, w = out[..., 0], out[..., 2]
        if self.kind != "holonomic":
            out[..., 1] = 0.0
        if self.kind == "ackermann":
            # a hair inside the limit: a path measured by chords between frames turns a little tighter than its arcs
            cap = np.abs(v) / (self.min_turn_radius * 1.001)
            w = out[..., 2] = np.clip(w, -cap, cap)
        planar = np.hypot(out[..., 0], out[..., 1])
        arm = self.reach if self.kind == "holonomic" else self.half_track
        if self.kind == "ackermann":
            # one scale for both keeps the curvature, which the steering bounds
            k = np.minimum(1.0, self.top_speed / np.maximum(planar + np.abs(w) * arm, 1e-12))
            return out * k[..., None]
        # The turn first, then what rim speed is left for travel: a base too slow for the commanded motion gives
        # up speed, not heading (a retargeted base then keeps facing where the human faces).
        turn = np.minimum(1.0, self.top_speed / np.maximum(np.abs(w) * arm, 1e-12))
        out[..., 2] = w * turn
        left = np.maximum(self.top_speed - np.abs(out[..., 2]) * arm, 0.0)
        k = np.minimum(1.0, left / np.maximum(planar, 1e-12))
        out[..., :2] *= k[..., None]
        return out

    def clamp_path(self, command: np.ndarray) -> np.ndarray:
        """:meth:`clamp` of each frame of commands ``[..., T, 3]``, and for an Ackermann drive no yaw rate on the
        frames either side of a reversal: the root path between two frames (their mean yaw rate and speed) then
        keeps within :attr:`min_turn_radius` too."""
        out = self.clamp(command)
        if self.kind == "ackermann" and out.shape[-2] > 1:
            flip = np.signbit(out[..., 1:, 0]) != np.signbit(out[..., :-1, 0])
            near = np.zeros(out.shape[:-1], dtype=bool)
            near[..., 1:] |= flip
            near[..., :-1] |= flip
            out[..., 2] = np.where(near, 0.0, out[..., 2])
        return out

    def path_steps(self, path: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
        """A planar root path ``[T, 3]`` (x, y [m], yaw [rad]) sampled at ``fps`` as the drive allows it: each step's
        chord in its mid heading frame per second ``[T - 1, 3]`` (forward, lateral [m/s], yaw rate [rad/s]),
        clipped by :meth:`clamp_path`, and the unwrapped yaw ``[T]`` it started from."""
        yaw = np.unwrap(path[:, 2])
        dxy = np.diff(path[:, :2], axis=0)
        dpsi = np.diff(yaw)
        mid = yaw[:-1] + 0.5 * dpsi
        c, s = np.cos(mid), np.sin(mid)
        chord = np.stack([c * dxy[:, 0] + s * dxy[:, 1], -s * dxy[:, 0] + c * dxy[:, 1], dpsi], axis=1) * fps
        return self.clamp_path(chord), yaw

    def summary(self) -> dict[str, float | str]:
        return {"drive": self.kind, "top_speed_m_s": round(self.top_speed, 4), "top_speed_rule": self.rule,
                "min_turn_radius_m": round(self.min_turn_radius, 4)}


def drive_of(m: Morphology) -> Drive | None:
    """The drive of a wheeled base that names its wheels (``None`` for other bases)."""
    wl = m.wheels
    if m.base != BaseType.WHEELED or wl is None:
        return None
    kin = BodyKinematics(m)
    P = kin.poses(kin.rest[None])[0]
    pos = {n: P[m.joint_index(n) + 1][:3, 3] for n in wl.all_joints}
    rolling = [pos[n] for n in wl.joints + wl.steered]
    fixed = [pos[n] for n in wl.joints] or rolling
    half_track = 0.5 * (max(p[1] for p in fixed) - min(p[1] for p in fixed)) if fixed else 0.0
    reach = max((float(np.hypot(p[0], p[1])) for p in rolling), default=0.0)
    spread = (max(p[1] for p in rolling) - min(p[1] for p in rolling)) if rolling else 0.0
    track = 2.0 * half_track if wl.joints else spread
    limits = [m.joint(n).limit.velocity for n in wl.joints + wl.steered  # type: ignore[union-attr]
              if m.joint(n).limit is not None and m.joint(n).limit.velocity]  # type: ignore[union-attr]
    if limits:
        top = min(limits) * wl.radius
        rule = f"wheels' velocity limit {min(limits):.4g} rad/s × radius {wl.radius:.4g} m"
    elif track > 0:
        top, rule = track, f"one track width per second ({track:.3g} m; the description gives no wheel velocity limit)"
    else:
        top, rule = 20.0 * wl.radius, f"20 wheel radii per second ({wl.radius:.4g} m; no track, no velocity limit)"
    min_turn = 0.0
    if wl.drive == "ackermann":
        steer = [pos[n] for n in wl.steering] or [pos[n] for n in wl.steered]
        base = float(np.mean([p[0] for p in steer])) if steer else 0.0
        steer_half = 0.5 * (max(p[1] for p in steer) - min(p[1] for p in steer)) if steer else 0.0
        delta = wl.max_steer if wl.max_steer is not None else _DEFAULT_MAX_STEER
        min_turn = abs(base) / math.tan(delta) + steer_half  # the inner wheel turns hardest
    return Drive(wl.drive, float(top), rule, float(half_track), float(reach), float(min_turn), float(track))


def wheel_carried_links(m: Morphology) -> frozenset[int]:
    """Indices of the links a wheel joint carries (the wheel, a steered or swivelling wheel and anything fixed on
    it) and of the links that carry nothing but a wheel (a suspension arm between the base and its wheel): no limb
    ends there."""
    wheel_joints = m.wheel_joints | m.wheel_steering_joints
    if not wheel_joints:
        return frozenset()
    out: set[int] = set()
    for ji, j in enumerate(m.joints):
        child = ji + 1
        if j.name in wheel_joints or m.link_parent[child] in out:
            out.add(child)  # joints are in tree order: a parent is seen before its children
    children: dict[int, int] = {}
    for li in range(1, m.link_count):
        children[m.link_parent[li]] = children.get(m.link_parent[li], 0) + 1
    for ji, j in enumerate(m.joints):
        if j.name not in wheel_joints or m.link_parent[ji + 1] in out:
            continue
        li = m.link_parent[ji + 1]
        while li > 0 and children.get(li, 0) == 1 and li not in out:
            out.add(li)  # carries this wheel only
            li = m.link_parent[li]
    return frozenset(out)
