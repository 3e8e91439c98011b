"""Humanoid legs of any ankle (issue 66): a biped whose ankle is one pitch hinge (five-hinge legs) and one whose ankle
pitches and rolls, both with a sole of four small spheres (as the G1's), synthesised. Every shape of each foot is
measured here from the coordinates by a NumPy FK of its own (not the synthesis report, not the Warp kernels): no
sphere of a foot under the ground, planted feet still and flat; and the report's feet figure equals the deepest foot
shape measured here."""

from __future__ import annotations

import numpy as np
import pytest

from morphkit.graph import ShapeType
from morphkit.graph.kinematics import link_poses
from morphkit.rotations import quat_from_axis_angle, quat_multiply, quat_rotate

FRAMES = 900
SOLE_Z = -0.05
"""Height of the sole spheres' centres in the foot link frame [m] (radius :data:`SOLE_R`)."""
SOLE_R = 0.01


def _biped_urdf(ankle: str) -> str:
    """Pelvis, then per leg hip yaw-roll-pitch, knee and an ankle pitch hinge (``"hinge"``) or pitch and roll
    (``"pitch_roll"``); the last link carries four sole spheres (heel and toe, either side). Legs straight at rest."""
    sole = "".join(f'<collision><origin xyz="{x} {y} {SOLE_Z}"/><geometry><sphere radius="{SOLE_R}"/></geometry>'
                   "</collision>" for x in (-0.06, 0.14) for y in (-0.03, 0.03))
    rows = [f'<robot name="biped_{ankle}">',
            '<link name="pelvis"><collision><geometry><box size="0.2 0.3 0.15"/></geometry></collision></link>']
    for side, y in (("l", 0.1), ("r", -0.1)):
        joints = [("hip_yaw", "0 0 1", f"0 {y} -0.1", (-0.8, 0.8)), ("hip_roll", "1 0 0", "0 0 0", (-0.5, 0.5)),
                  ("hip_pitch", "0 1 0", "0 0 0", (-2.0, 1.5)), ("knee", "0 1 0", "0 0 -0.4", (0.0, 2.4)),
                  ("ankle_pitch", "0 1 0", "0 0 -0.4", (-0.9, 0.7))]
        if ankle == "pitch_roll":
            joints.append(("ankle_roll", "1 0 0", "0 0 0", (-0.4, 0.4)))
        parent = "pelvis"
        for k, (name, axis, xyz, (lo, hi)) in enumerate(joints):
            child = f"{side}_{name}_link"
            shape = ""
            if name in ("hip_pitch", "knee"):  # thigh and shin
                shape = ('<collision><origin xyz="0 0 -0.2"/><geometry><cylinder radius="0.035" length="0.3"/>'
                         "</geometry></collision>")
            elif k == len(joints) - 1:
                shape = sole
            rows.append(f'<link name="{child}">{shape}</link>')
            rows.append(f'<joint name="{side}_{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
                        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
                        f'<limit lower="{lo}" upper="{hi}" effort="1" velocity="1"/></joint>')
            parent = child
    rows.append("</robot>")
    return "\n".join(rows)


def _sole_lowest_points(m, q: np.ndarray, foot_links: list[str]) -> np.ndarray:
    """World lowest point of every sphere of each foot link [T, F, S, 3] at coordinates ``q`` [T, C]."""
    X = link_poses(m, q)
    out = []
    for name in foot_links:
        T = X[:, m.link_index(name)]
        spheres = [sh for sh in m.link(name).shapes if sh.type == ShapeType.SPHERE]
        pts = []
        for sh in spheres:
            c = T[:, :3] + quat_rotate(T[:, 3:], np.broadcast_to(np.asarray(sh.origin.xyz, dtype=float), (len(q), 3)))
            pts.append(c - np.array([0.0, 0.0, sh.radius]))
        out.append(np.stack(pts, axis=1))
    return np.stack(out, axis=1)


@pytest.fixture(scope="module", params=["hinge", "pitch_roll"])
def walked(request, tmp_path_factory):
    from morphkit.io import read_morphology
    from morphkit.synth import SynthConfig, synthesize

    path = tmp_path_factory.mktemp("biped") / f"biped_{request.param}.urdf"
    path.write_text(_biped_urdf(request.param))
    m = read_morphology(path)
    res = synthesize(m, frames=FRAMES, seed=0, config=SynthConfig(rollout_seconds=10.0), progress=False)
    return request.param, m, res


def test_every_sole_sphere_stays_on_the_ground_still_and_flat(walked):
    """Planted feet (every sphere within 5 mm of the ground): they slide < 1 cm/s on average, measured at every
    sphere; no sphere of any foot is more than 5 mm under in any frame; a planted sole is flat (its spheres' lowest
    points within 2 mm of each other, about 0.6 degrees over the 20 cm sole); and the feet do step."""
    ankle, m, res = walked
    feet = [m.end_effector(leg.end_effector).link for leg in res.rig.plan.legs]
    assert len(feet) == 2
    step = []
    for motion in res:
        p = _sole_lowest_points(m, motion.q, feet)  # [T, F, S, 3]
        z = p[..., 2]
        assert z.min() > -0.005, (ankle, float(z.min()))
        planted = (z < 0.005).all(axis=-1)  # [T, F]
        both = planted[1:] & planted[:-1]
        speed = np.linalg.norm(np.diff(p[..., :2], axis=0), axis=-1).max(axis=-1) * motion.fps  # [T-1, F]
        assert both.sum() > 0.3 * both.size, ankle
        assert speed[both].mean() < 0.01, (ankle, float(speed[both].mean()))
        spread = z.max(axis=-1) - z.min(axis=-1)
        assert spread[planted].max() < 0.002, (ankle, float(spread[planted].max()))
        step.append(np.ptp(p[..., 0, :2], axis=0).max())
    assert max(step) > 0.2  # a foot travelled: the biped walks


def test_the_reports_feet_figure_is_the_deepest_foot_shape(walked):
    """``foot_penetration_mm`` (the headline's "feet") equals the deepest sphere of any foot measured here, and
    counts a sole sphere that goes under while the foot point stays on the ground (a heel pushed down)."""
    from morphkit.motion import Motion
    from morphkit.synth.report import quality_report

    _, m, res = walked
    feet = [m.end_effector(leg.end_effector).link for leg in res.rig.plan.legs]
    deepest = max(max(0.0, -float(_sole_lowest_points(m, mo.q, feet)[..., 2].min())) for mo in res)
    r = quality_report(res)
    assert r["foot_penetration_mm"] == pytest.approx(1000.0 * deepest, abs=1e-3)
    # the same clip with the root pitched 10 degrees toe-up about the first planted foot point: the toe sphere
    # holding the foot point stays on the ground, the heel spheres go under
    q = res[0].q[:30].copy()
    leg = res.rig.plan.legs[0]
    ee = m.end_effector(leg.end_effector)
    X = link_poses(m, q)
    T = X[:, m.link_index(ee.link)]
    point = T[:, :3] + quat_rotate(T[:, 3:], np.broadcast_to(np.asarray(ee.offset, dtype=float), (len(q), 3)))
    # about the foot's own sideways axis (a rollout starts at a random heading)
    side = quat_rotate(T[:, 3:], np.broadcast_to(np.array([0.0, 1.0, 0.0]), (len(q), 3)))
    turn = quat_from_axis_angle(side, np.full(len(q), np.radians(-10.0)))
    q[:, 3:7] = quat_multiply(turn, q[:, 3:7])
    q[:, :3] = point + quat_rotate(turn, q[:, :3] - point)
    heel = max(0.0, -float(_sole_lowest_points(m, q, feet)[..., 2].min()))
    assert heel > 0.01
    r2 = quality_report([Motion(m, res[0].fps, q, "tilted")])
    assert r2["foot_penetration_mm"] == pytest.approx(1000.0 * heel, abs=1e-3)
