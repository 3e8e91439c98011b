"""Quality report of synthesised (or any) motions, measured with the contact kernels.

Figures (the ``morphkit synth --report --json`` keys first):

- ``frames``, ``frames_per_s``: how much was generated and how fast (calibration included).
- ``foot_sliding_cm_s``: mean horizontal speed of feet in contact (lower than ``height_threshold``
  above the ground; the feet of the legs that carry the body, or every ``foot`` end-effector of plain
  motions), by :func:`~morphkit.kernels.contact.eval_sliding_speed` (backward differences).
- ``penetration_mm``: deepest penetration below the ground of anything: the feet's end-effector points
  (:func:`~morphkit.kernels.contact.eval_penetration_depth`), every other end-effector point, and every
  link shape (:func:`~morphkit.kernels.contact.eval_shape_ground_distance`). A foot's own shapes (on its
  link, the links fixed to it, and below) count only beyond how far they reach below the foot point at rest (Spot's foot
  sphere is centred on its foot point); wheels roll on the ground and are not counted.
  ``foot_penetration_mm`` is the feet alone: their points and every shape of each foot (a sole of several
  spheres, as the G1's, is all of it on the ground, not its toe sphere alone); ``deepest_link`` names where the
  deepest shape was, unless a foot's point was as deep.
- ``self_collision_frac``: fraction of frames where any candidate shape pair overlaps by more than
  ``collision_tolerance`` (:func:`~morphkit.kernels.contact.eval_self_collision_distance`; pairs from
  :func:`~morphkit.kernels.contact.self_collision_pairs` with ``rest_margin``: shapes that touch at
  rest by design, like neighbours across a joint, are not counted).
- ``limit_violation_frac``: fraction of frames with any 1-DoF coordinate outside its limits.
- ``tracking_error``: mean relative error of the root's planar velocity
  (:func:`~morphkit.motion.heading.heading_velocity`: backward differences in the heading frame; on a
  turn the chord lags the heading by half a frame's turn, ``w / (2 fps)`` of the speed) against the
  commanded target, over frames where the command has settled:
  $\\lVert v - v^* \\rVert / \\max(\\lVert v^* \\rVert, v_{floor})$ (``None`` without commands or a moving base).

Extra keys: ``yaw_rate_error`` (same for the yaw rate, floor 0.1 rad/s), ``foot_sliding_p95_cm_s``,
``penetration_mean_mm``, ``command_clamped_frac`` (frames whose velocity target was scaled down to
what the legs can do; tracking is measured against the scaled target), ``swing_clearance_frac``
(fraction of airborne swing frames — not the lift-off and touchdown frames — with the foot above
1 cm), ``step_length_m`` (mean horizontal distance from a foot's last stance frame before a swing to its
first after it, over swings the clip does not cut), ``step_height_m`` (mean highest foot point of those
swings), ``legs`` (per leg: ``step_length_m``, ``step_height_m``, ``sliding_cm_s``, ``swings``),
``contact_frac``, ``gait_frac``, the calibration summary and ``warnings`` (one line per limb that
cannot be moved well: the calibration's, and legs that slide more than 1 cm/s, step less than a tenth
of their reach or lift their feet less than 2 cm, links more than 5 mm below the ground).

The root follows the (scaled) command by construction, so ``tracking_error`` checks the pipeline
(integration, heading frames, finite differences) rather than a controller's skill.
"""

from __future__ import annotations

from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from morphkit.contact_rules import UFR
from morphkit.graph import JointType, Morphology
from morphkit.model import compile_model
from morphkit.motion.motion import Motion
from morphkit.synth.analysis import Limb

__all__ = ["REPORT_KEYS", "format_report", "limit_advice", "quality_report"]

WARN_SLIDING_CM_S = 1.0
"""A leg whose stance foot slides faster than this on average [cm/s] is named in the warnings."""
WARN_STEP_FRACTION = 0.1
"""A leg whose mean step is shorter than this fraction of its reach is named in the warnings."""
WARN_STEP_HEIGHT_M = 0.02
"""A leg whose mean swing apex is lower than this [m] is named in the warnings."""
WARN_PENETRATION_M = 0.005
"""A link deeper than this below the ground [m] is named in the warnings."""

REPORT_KEYS = ("frames", "frames_per_s", "foot_sliding_cm_s", "penetration_mm", "self_collision_frac",
               "limit_violation_frac", "tracking_error")
"""The keys ``morphkit synth --report --json`` always prints."""


def _groups(motions: Sequence[Motion]) -> dict[int, list[int]]:
    groups: dict[int, list[int]] = {}
    for i, m in enumerate(motions):
        groups.setdefault(m.frame_count, []).append(i)
    return groups


def _ground_allowance(m, model, feet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per shape [S]: how far below the ground [m] it may reach without penetrating: a foot's own shapes
    (on the foot's rigid body — its link and the links fixed to it, as a URDF toe fixed to its calf — and below)
    as far below the foot point as at rest, wheels without limit, others 0; and which shapes are a foot's own
    [S] (bool): on the foot's link and below it."""
    from morphkit.kernels import eval_end_effectors, eval_fk
    from morphkit.kernels.contact import eval_shape_ground_distance, rigid_bodies

    allow = np.zeros(model.shape_count)
    own = np.zeros(model.shape_count, dtype=bool)
    if not model.shape_count:
        return allow, own
    shape_link = np.asarray(model.shape_link)
    for name in m.wheel_joints:
        allow[shape_link == m.link_index(m.joint(name).child)] = np.inf
    if len(feet):
        q = m.rest_q()[None]
        X = eval_fk(model, q, device="cpu")
        low = eval_shape_ground_distance(model, X).numpy()[0]
        pos, _ = eval_end_effectors(model, q, Ts_world_link=X)
        ee_z = pos.numpy()[0, :, 2]
        body = rigid_bodies(model)
        for e in feet:
            e = int(e)
            below = {model.link_names[i] for i in np.flatnonzero(body == body[int(model.ee_link[e])])}
            for j in m.joints:  # topological order: parents first
                if j.parent in below:
                    below.add(j.child)
            on = np.isin(shape_link, [m.link_index(n) for n in below])
            allow[on] = np.maximum(allow[on], np.maximum(ee_z[e] - low[on], 0.0))
            # the foot itself: its link and what hangs below it (not a shin it is fixed to, nor a body)
            foot = {model.link_names[int(model.ee_link[e])]}
            for j in m.joints:
                if j.parent in foot:
                    foot.add(j.child)
            own |= np.isin(shape_link, [m.link_index(n) for n in foot])
    own &= np.isfinite(allow)  # a wheel rolls on the ground: no foot's sole
    return allow, own


def limit_advice(m: Morphology, leg: Limb, held: Collection[str] = ()) -> str:
    """The fix for a leg that cannot reach: widen the limits it has, else (joints that turn freely) its geometry.
    ``held``: joints the synthesis holds at rest (a redundant hip's turn), whose limits are not what stops it."""
    limited = [m.joint(n).name for n in leg.joints
               if m.joint(n).type in (JointType.REVOLUTE, JointType.PRISMATIC) and m.joint(n).name not in held]
    if limited:
        return f"widen the limits of {', '.join(limited)} or lengthen the leg's segments in the description"
    return ("its joints turn freely, so the segments are what limit it: lengthen them, or give a rest pose with the "
            "knees bent (YAML rest_pose, URDF <rest_pose>, an MJCF keyframe 'home')")


def _swings(h: np.ndarray, xy: np.ndarray, contact: np.ndarray) -> list[tuple[int, float, float]]:
    """``(leg, step length [m], apex [m])`` of every swing a clip does not cut: feet heights [T, L], feet
    positions [T, L, 2], planned contact [T, L]."""
    out = []
    for leg in range(contact.shape[1]):
        air = ~contact[:, leg]
        edges = np.flatnonzero(np.diff(np.concatenate([[0], air.astype(np.int8), [0]])))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            if start == 0 or stop == len(air):
                continue
            out.append((leg, float(np.linalg.norm(xy[stop, leg] - xy[start - 1, leg])),
                        float(h[start:stop, leg].max())))
    return out


class _KinematicTally:
    """Per-frame measures of motions of one creature, summed over groups of equally long motions (:meth:`add`):
    limit violations, feet's sliding [m/s] and penetration [m] in contact, every link's depth below the ground
    [m], self-collision; feet heights [T, F] and positions [T, F, 2] [m] per motion."""

    def __init__(self, m: Morphology, model: Any, feet: np.ndarray, motion_count: int, *, height_threshold: float,
                 collision_tolerance: float, rest_margin: float) -> None:
        from morphkit.kernels.contact import self_collision_pairs

        self.m, self.model, self.feet = m, model, feet
        self.height_threshold, self.collision_tolerance = height_threshold, collision_tolerance
        self.pairs = self_collision_pairs(model, rest_margin=rest_margin)
        self.allow, self.foot_shapes = _ground_allowance(m, model, feet)
        self.others = np.array([e for e in range(model.ee_count) if e not in set(feet.tolist())], dtype=np.int64)
        self.deepest = 0.0
        self.deepest_link: str | None = None
        self.link_depth: dict[str, float] = {}
        self.foot_xy: list[np.ndarray | None] = [None] * motion_count
        self.lower, self.upper = m.coordinate_limits
        self.finite = np.isfinite(self.lower) | np.isfinite(self.upper)
        self.slide_sum = 0.0
        self.slide_n = 0
        self.slides: list[np.ndarray] = []
        self.leg_slides: list[np.ndarray] = []
        """Per group: sliding speed [N*T, F] [m/s], NaN out of contact."""
        self.pen_max = 0.0
        """Deepest foot [m]: its point, or any of its own shapes (a sole of several spheres is all of it the foot)."""
        self.point_pen_max = 0.0
        """Deepest foot point [m]."""
        self.pen_sum = 0.0
        self.pen_n = 0
        self.coll_frames = 0
        self.limit_frames = 0
        self.frames = 0
        self.heights_all: list[np.ndarray | None] = [None] * motion_count

    def add(self, idx: list[int], q: np.ndarray, fps: float) -> None:
        """Measure motions ``idx`` of coordinates ``q`` [N, T, C]."""
        from morphkit.kernels import eval_fk, eval_wheel_angles
        from morphkit.kernels.contact import eval_self_collision_distance

        model, lower, upper, finite = self.model, self.lower, self.upper, self.finite
        self.frames += q.shape[0] * q.shape[1]
        bad = ((q[..., finite] < lower[finite] - 1e-6) | (q[..., finite] > upper[finite] + 1e-6)).any(axis=-1)
        self.limit_frames += int(bad.sum())
        wheel_q = eval_wheel_angles(model, q) if model.wheel_count else None
        X = eval_fk(model, q, wheel_q=wheel_q, device="cpu")
        if len(self.feet):
            self._add_feet(idx, q, X, fps)
        self._add_depths(q, X)
        if self.pairs.pair_count:
            d = eval_self_collision_distance(model, self.pairs, X).numpy()
            self.coll_frames += int((d < -self.collision_tolerance).any(axis=-1).sum())

    def _add_feet(self, idx: list[int], q: np.ndarray, X: Any, fps: float) -> None:
        """Feet's heights, sliding and penetration of motions ``idx`` (``q`` [N, T, C], link transforms ``X``)."""
        from morphkit.kernels import eval_end_effectors
        from morphkit.kernels.contact import eval_foot_heights, eval_penetration_depth, eval_sliding_speed

        feet = self.feet
        pos, _ = eval_end_effectors(self.model, q, Ts_world_link=X)
        h = eval_foot_heights(pos, feet=feet).numpy()  # [N, T, F]
        sl = eval_sliding_speed(pos, fps, feet=feet, height_threshold=self.height_threshold).numpy()
        contact = h < self.height_threshold
        self.leg_slides.append(np.where(contact, sl, np.nan).reshape(-1, sl.shape[-1]))
        self.slide_sum += float(sl[contact].sum())
        self.slide_n += int(contact.sum())
        self.slides.append(sl[contact])
        pen = eval_penetration_depth(pos, feet=feet).numpy()
        self.point_pen_max = max(self.point_pen_max, float(pen.max()))
        self.pen_max = max(self.pen_max, self.point_pen_max)
        self.pen_sum += float(pen.sum())
        self.pen_n += pen.size
        fpos = pos.numpy()[..., feet, :2]
        for k, i in enumerate(idx):
            self.heights_all[i] = h[k]
            self.foot_xy[i] = fpos[k]

    def _add_depths(self, q: np.ndarray, X: Any) -> None:
        """Everything else: every shape (a foot's own beyond its rest reach below the foot point), every other
        end-effector point; the deepest per link."""
        from morphkit.kernels import eval_end_effectors
        from morphkit.kernels.contact import eval_shape_ground_distance

        model, others = self.model, self.others
        depth = {}
        if model.shape_count:
            d = eval_shape_ground_distance(model, X).numpy()  # [N, T, S]
            below = np.maximum(-(d + self.allow), 0.0).max(axis=(0, 1))
            if self.foot_shapes.any():
                self.pen_max = max(self.pen_max, float(below[self.foot_shapes].max()))
            for sh in range(model.shape_count):
                name = model.link_names[int(model.shape_link[sh])]
                depth[name] = max(depth.get(name, 0.0), float(below[sh]))
        if others.size:
            pe, _ = eval_end_effectors(model, q, Ts_world_link=X)
            z = pe.numpy()[..., others, 2].min(axis=(0, 1))
            for e, zz in zip(others, z, strict=True):
                name = model.link_names[int(model.ee_link[int(e)])]
                depth[name] = max(depth.get(name, 0.0), float(-zz))
        for name, dd in depth.items():
            self.link_depth[name] = max(self.link_depth.get(name, 0.0), dd)
            if dd > self.deepest:
                self.deepest, self.deepest_link = dd, name

    def summary(self, result: Any) -> dict[str, Any]:
        """The report's first entries (:data:`REPORT_KEYS`; ``tracking_error`` left None)."""
        frames, slide_n, pen_n = self.frames, self.slide_n, self.pen_n
        return {
            "frames": int(frames),
            "frames_per_s": round(float(result.frames_per_s), 1) if hasattr(result, "frames_per_s") else None,
            "foot_sliding_cm_s": round(100.0 * self.slide_sum / slide_n, 4) if slide_n else 0.0,
            "penetration_mm": round(1000.0 * max(self.pen_max, self.deepest), 4),
            "self_collision_frac": round(self.coll_frames / frames, 6),
            "limit_violation_frac": round(self.limit_frames / frames, 6),
            "tracking_error": None,
            "foot_sliding_p95_cm_s": round(100.0 * float(np.percentile(np.concatenate(self.slides), 95)), 4)
            if slide_n else 0.0,
            "penetration_mean_mm": round(1000.0 * self.pen_sum / pen_n, 4) if pen_n else 0.0,
            "foot_penetration_mm": round(1000.0 * self.pen_max, 4),
            "deepest_link": self.deepest_link if self.deepest > self.point_pen_max + 1e-6 else None,
        }


def _tracking(result: Any, motions: list[Motion], speed_floor: float | None, frames: int) -> dict[str, Any]:
    """How well the root follows its settled commands: mean relative velocity and yaw-rate errors, and the
    fraction of frames measured."""
    from morphkit.motion.heading import heading_velocity
    from morphkit.motion.motion import base_pose_from_q
    from morphkit.synth.locomotion_commands import CMD_VX, CMD_VY, CMD_WZ

    m, fps = motions[0].morphology, motions[0].fps
    scale = getattr(getattr(result, "rig", None), "scale", 1.0)
    floor = 0.1 * scale if speed_floor is None else speed_floor
    lin_err, yaw_err = [], []
    for i, mo in enumerate(motions):
        if mo.frame_count < 3:
            continue
        vel = heading_velocity(base_pose_from_q(m, mo.q), fps)
        v, w = vel.linear[:, :2], vel.yaw_rate
        tgt = result.target[i]
        ok = result.settled[i].copy()
        ok[0] = ok[-1] = False
        vt = tgt[:, [CMD_VX, CMD_VY]]
        lin_err.append((np.linalg.norm(v - vt, axis=1) / np.maximum(np.linalg.norm(vt, axis=1), floor))[ok])
        yaw_err.append((np.abs(w - tgt[:, CMD_WZ]) / np.maximum(np.abs(tgt[:, CMD_WZ]), 0.1))[ok])
    le = np.concatenate(lin_err) if lin_err else np.zeros(0)
    ye = np.concatenate(yaw_err) if yaw_err else np.zeros(0)
    return {"tracking_error": round(float(le.mean()), 6) if le.size else None,
            "yaw_rate_error": round(float(ye.mean()), 6) if ye.size else None,
            "settled_frac": round(float(le.size / frames), 4)}


def _steps(result: Any, tally: _KinematicTally, warnings: list[str]) -> dict[str, Any]:
    """Swing clearance, contact fraction, step lengths and heights overall and per leg (feet are the legs in
    body-plan order); warnings for legs that slide, step short or lift low are appended to ``warnings``."""
    m, rig, feet, heights_all = tally.m, result.rig, tally.feet, tally.heights_all
    out: dict[str, Any] = {}
    swing_ok, swing_n, contact_n = 0, 0, 0
    fidx = list(range(len(feet)))  # feet are the legs in body-plan order here
    for i, h in enumerate(heights_all):
        if h is None:
            continue
        c = result.contact[i]
        contact_n += int(c.sum())
        airborne = ~c
        airborne[1:] &= ~c[:-1]
        airborne[:-1] &= ~c[1:]
        hh = h[:, fidx]
        swing_ok += int((hh[airborne] > 0.01).sum())
        swing_n += int(airborne.sum())
    out["swing_clearance_frac"] = round(swing_ok / swing_n, 6) if swing_n else None
    out["contact_frac"] = round(contact_n / (tally.frames * len(feet)), 4)
    swings = [sw for i, h in enumerate(heights_all) if h is not None
              for sw in _swings(h, tally.foot_xy[i], result.contact[i])]  # type: ignore[arg-type]
    sl = np.array([sw[1] for sw in swings])
    ap = np.array([sw[2] for sw in swings])
    out["step_length_m"] = round(float(sl.mean()), 4) if sl.size else 0.0
    out["step_height_m"] = round(float(ap.mean()), 4) if ap.size else 0.0
    legs = {}
    held = {m.joints[j].name for j in rig.solver.held_joints}
    for li, leg in enumerate(rig.plan.legs):
        mine = np.array([sw[0] == li for sw in swings], dtype=bool)
        speed = np.concatenate([s_[:, li] for s_ in tally.leg_slides]) if tally.leg_slides else np.zeros(0)
        speed = speed[np.isfinite(speed)]  # frames in contact
        entry = {
            "step_length_m": round(float(sl[mine].mean()), 4) if mine.any() else 0.0,
            "step_height_m": round(float(ap[mine].mean()), 4) if mine.any() else 0.0,
            "sliding_cm_s": round(100.0 * float(speed.mean()), 4) if speed.size else 0.0,
            "swings": int(mine.sum()),
        }
        legs[leg.end_effector] = entry
        if entry["sliding_cm_s"] > WARN_SLIDING_CM_S:
            warnings.append(f"leg {leg.end_effector}: its stance foot slides {entry['sliding_cm_s']:.2g} cm/s "
                            "on average: IK cannot hold it where it stands at the body's dips and tilts (a joint "
                            f"at its limit, or the foot out of reach): {limit_advice(m, leg, held)}")
        if entry["swings"] and entry["step_length_m"] < WARN_STEP_FRACTION * leg.reach:
            warnings.append(f"leg {leg.end_effector}: steps {100 * entry['step_length_m']:.2g} cm on average, "
                            f"under a tenth of its {100 * leg.reach:.3g} cm reach: {limit_advice(m, leg, held)}"
                            ", or space the legs further apart if they would collide")
        if entry["swings"] and entry["step_height_m"] < WARN_STEP_HEIGHT_M:
            warnings.append(f"leg {leg.end_effector}: lifts its foot {100 * entry['step_height_m']:.2g} cm "
                            "on average: a higher foot is out of reach (bend the knee in the rest pose, or "
                            f"{limit_advice(m, leg, held)})")
    out["legs"] = legs
    return out


def quality_report(result: Any, *, height_threshold: float = UFR.height, collision_tolerance: float = 0.001,
                   rest_margin: float = 0.005, speed_floor: float | None = None) -> dict[str, Any]:
    """Measure a :class:`~morphkit.synth.SynthResult` (or any sequence of motions of one creature).

    Args:
        result: The motions (with commands and timing when a ``SynthResult``).
        height_threshold: A foot lower than this is in contact [m] (the contact rule's ``ufr`` preset).
        collision_tolerance: Overlap [m] beyond which a shape pair collides.
        rest_margin: Shape pairs closer than this at rest [m] are not checked.
        speed_floor: Smallest commanded speed the relative tracking error divides by [m/s]
            (default 0.1 m/s times the creature's size scale).

    Returns:
        A JSON-friendly dict (see the module docstring).
    """
    from morphkit.kernels.contact import foot_indices

    motions: list[Motion] = list(result)
    if not motions:
        return dict.fromkeys(REPORT_KEYS, 0)
    m = motions[0].morphology
    fps = motions[0].fps
    model = compile_model(m, device="cpu")
    rig = getattr(result, "rig", None)
    if rig is not None:
        # only feet that carry the body: a wheeled or fixed base moves foot end-effectors like arms
        feet = np.array([model.ee_index(leg.end_effector) for leg in rig.plan.legs], dtype=np.int32)
    else:
        feet = foot_indices(model)
    tally = _KinematicTally(m, model, feet, len(motions), height_threshold=height_threshold,
                            collision_tolerance=collision_tolerance, rest_margin=rest_margin)
    for idx in _groups(motions).values():
        tally.add(idx, np.stack([motions[i].q for i in idx]), fps)  # [N, T, C]
    out = tally.summary(result)
    warnings: list[str] = list(getattr(result, "warnings", ()))
    if hasattr(result, "target") and m.base_coordinate_count:
        out.update(_tracking(result, motions, speed_floor, tally.frames))
    if rig is not None and len(feet) and result.contact and result.contact[0].shape[1] == len(feet):
        out.update(_steps(result, tally, warnings))
    if hasattr(result, "gait") and getattr(result, "gait_names", ()):
        g = np.concatenate(result.gait)
        out["gait_frac"] = {n: round(float((g == k).mean()), 4) for k, n in enumerate(result.gait_names)}
    if hasattr(result, "rig"):
        out["calibration"] = result.rig.summary()
    if hasattr(result, "clamped") and result.clamped:
        out["command_clamped_frac"] = round(float(np.concatenate(result.clamped).mean()), 4)
    for name, dd in sorted(tally.link_depth.items(), key=lambda kv: -kv[1]):
        if dd > WARN_PENETRATION_M:
            warnings.append(f"link {name}: goes {100 * dd:.2g} cm below the ground")
    out["base"] = m.base.name.lower()
    out["warnings"] = list(dict.fromkeys(warnings))
    return out


def format_report(r: dict[str, Any]) -> str:
    """Human-readable lines of a :func:`quality_report` dict."""
    def fmt(v: Any) -> str:
        return "n/a" if v is None else (f"{v:.4g}" if isinstance(v, float) else str(v))

    def pct(v: Any) -> str:
        # a fraction printed as 1 or 0 reads like a count of frames
        return "n/a" if v is None else f"{100 * float(v):.3g} %"

    moves = r.get("base") != "fixed"  # a bolted arm has no feet on the ground and no path to track
    lines = [
        f"frames                 {r['frames']}"
        + (f"  ({fmt(r['frames_per_s'])} frames/s)" if r.get("frames_per_s") else ""),
        *([f"foot sliding           {fmt(r['foot_sliding_cm_s'])} cm/s mean in contact"
           f" (p95 {fmt(r.get('foot_sliding_p95_cm_s'))})"] if moves else []),
        f"penetration            {fmt(r['penetration_mm'])} mm max over every shape"
        + (f" ({r['deepest_link']})" if r.get("deepest_link") else "")
        + (f"; feet {fmt(r.get('foot_penetration_mm'))} mm max, mean {fmt(r.get('penetration_mean_mm'))}"
           if moves else ""),
        f"self-collision         {pct(r['self_collision_frac'])} of frames",
        f"limit violations       {pct(r['limit_violation_frac'])} of frames",
        *([f"tracking error         {fmt(r['tracking_error'])} (relative, settled commands;"
           f" yaw {fmt(r.get('yaw_rate_error'))})"] if moves else []),
    ]
    if r.get("swing_clearance_frac") is not None:
        lines.append(f"swing clearance        {pct(r['swing_clearance_frac'])} of airborne frames above 1 cm")
    if r.get("legs"):
        lines.append(f"steps                  {fmt(r['step_length_m'])} m long, {fmt(r['step_height_m'])} m high"
                     " (mean)")
        for name, leg in r["legs"].items():
            lines.append(f"  {name:<20} {fmt(leg['step_length_m'])} m long, {fmt(leg['step_height_m'])} m high, "
                         f"sliding {fmt(leg['sliding_cm_s'])} cm/s, {leg['swings']} swings")
    if r.get("command_clamped_frac") is not None and moves:
        lines.append(f"commands clamped       {pct(r['command_clamped_frac'])} of frames (to the creature's top speed)")
    if r.get("gait_frac"):
        lines.append("gaits                  " + ", ".join(f"{k} {v:.0%}" for k, v in r["gait_frac"].items()))
    if r.get("calibration"):
        c = r["calibration"]
        lines.append("calibration            " + ", ".join(f"{k}={v}" for k, v in c.items()))
    return "\n".join(lines)
