"""The MJCF reader and writer, checked against MuJoCo's own kinematics on dm_control's models."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

mujoco = pytest.importorskip("mujoco")
dm_control = pytest.importorskip("dm_control")

from morphkit.errors import DescriptionError  # noqa: E402
from morphkit.graph import BaseType, JointType, Morphology  # noqa: E402
from morphkit.io import read_morphology, write_morphology  # noqa: E402
from morphkit.io.mjcf import link_offsets, qpos_from_q, read_mjcf  # noqa: E402

SUITE = Path(dm_control.__file__).parent / "suite"
MODELS = ["dog.xml", "quadruped.xml", "humanoid_CMU.xml"]


def _read(path: Path) -> Morphology:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the skipped ball and tendon couplings
        return read_mjcf(path)


def _random_qpos(model, rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` MuJoCo poses within joint limits, every free and ball joint at a random rotation."""
    out = np.tile(model.qpos0, (n, 1))
    for j in range(model.njnt):
        a = model.jnt_qposadr[j]
        t = model.jnt_type[j]
        if t in (0, 1):  # free, ball: a random unit quaternion (wxyz); a free joint also moves
            k = a + 3 if t == 0 else a
            q = rng.normal(size=(n, 4))
            out[:, k : k + 4] = q / np.linalg.norm(q, axis=1, keepdims=True)
            if t == 0:
                out[:, a : a + 3] = rng.uniform(-1, 1, size=(n, 3))
        else:
            lo, hi = model.jnt_range[j] if model.jnt_limited[j] else (-np.pi, np.pi)
            out[:, a] = rng.uniform(lo, hi, size=n)
    return out


def _morphkit_q(model, m: Morphology, qpos: np.ndarray) -> np.ndarray:
    """morphkit coordinates of MuJoCo poses: names matched, ``q = qpos - ref``, quaternions wxyz → xyzw."""
    q = np.zeros((len(qpos), m.coordinate_count))
    if m.base == BaseType.FLOATING:
        # The root link is the root body turned back by the body's initial rotation R0: L = B R0⁻¹.
        root = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, m.root)
        a = model.jnt_qposadr[model.body_jntadr[root]]
        q[:, :3] = qpos[:, a : a + 3]
        r0_inv = np.zeros(4)
        mujoco.mju_negQuat(r0_inv, model.body_quat[root])
        for t in range(len(qpos)):
            wxyz = np.zeros(4)
            mujoco.mju_mulQuat(wxyz, qpos[t, a + 3 : a + 7], r0_inv)
            q[t, 3:6], q[t, 6] = wxyz[1:], wxyz[0]
    for jt, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
        if jt.type == JointType.FIXED or m.is_driven(jt):  # a mimic has no coordinate of its own
            continue
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, jt.name)
        a = model.jnt_qposadr[j]
        if jt.type == JointType.SPHERICAL:
            q[:, start : start + 3], q[:, start + 3] = qpos[:, a + 1 : a + 4], qpos[:, a]
        else:
            q[:, start] = qpos[:, a] - model.qpos0[a]
    return q


def _morphkit_positions(m: Morphology, q: np.ndarray) -> np.ndarray:
    """World link positions [B, L, 3] from morphkit's Warp FK (float64)."""
    import warp as wp

    from morphkit.kernels import eval_link_positions
    from morphkit.model import compile_model

    return eval_link_positions(compile_model(m, device="cpu"), wp.array(q, dtype=wp.float64, device="cpu")).numpy()


def _mujoco_positions(model, m: Morphology, qpos: np.ndarray) -> tuple[np.ndarray, list[int]]:
    """MuJoCo's positions of the morphkit links that are MuJoCo bodies (at the link's anchor), [B, n, 3]."""
    data = mujoco.MjData(model)
    offsets = link_offsets(model, m)
    cols = [i for i, link in enumerate(m.links) if link.name in offsets]
    bodies = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, m.links[i].name) for i in cols]
    anchors = np.array([offsets[m.links[i].name] for i in cols])
    out = np.zeros((len(qpos), len(cols), 3))
    for b, qp in enumerate(qpos):
        data.qpos[:] = qp
        mujoco.mj_kinematics(model, data)
        out[b] = data.xpos[bodies] + np.einsum("nij,nj->ni", data.xmat[bodies].reshape(-1, 3, 3), anchors)
    return out, cols


def _fk_error(path: Path, m: Morphology | None = None, poses: int = 50) -> tuple[float, int]:
    """Max |morphkit - MuJoCo| link position [m] at random poses of the model at ``path``, and bodies compared.

    ``m`` (default: read from ``path``) must have the model's joint names; MuJoCo poses are mapped to it.
    """
    model = mujoco.MjModel.from_xml_path(str(path))
    m = m or _read(path)
    qpos = _random_qpos(model, np.random.default_rng(0), poses)
    expected, cols = _mujoco_positions(model, m, qpos)
    got = _morphkit_positions(m, _morphkit_q(model, m, qpos))[:, cols]
    return float(np.abs(got - expected).max()), len(cols)


@pytest.mark.parametrize("name", MODELS)
def test_fk_matches_mujoco(name: str) -> None:
    """Link positions of morphkit's FK equal MuJoCo's mj_kinematics to 1e-5 m at 50 random poses within limits."""
    err, bodies = _fk_error(SUITE / name)
    print(f"{name}: {bodies} bodies, max |morphkit - MuJoCo| = {err:.2e} m over 50 poses")
    nbody = mujoco.MjModel.from_xml_path(str(SUITE / name)).nbody
    assert bodies >= nbody - 2  # every body but the world and the skipped ball
    assert err < 1e-5


_EVERY_JOINT = """<mujoco model="every_joint">
  <compiler angle="degree"/>
  <default><geom size="0.05"/></default>
  <worldbody>
    <geom type="plane" size="5 5 0.1"/>
    <body name="base" pos="0.1 0.2 0.5" euler="0 0 30">
      <geom type="box" size="0.2 0.1 0.05"/>
      <body name="upper" pos="0.2 0 0">
        <joint name="swing" type="hinge" axis="0 1 1" pos="0 0.03 0" range="-60 45" ref="20" springref="10"/>
        <joint name="twist" type="hinge" axis="1 0 0" pos="0.02 0 0" range="-30 30"/>
        <geom type="capsule" fromto="0 0 0 0.3 0 0"/>
        <body name="lower" pos="0.3 0 0">
          <joint name="slide" type="slide" axis="1 0 0" range="-0.1 0.1" ref="0.05"/>
          <joint name="spin" type="hinge" axis="0 0 1" pos="0.01 0 0" limited="false"/>
          <geom type="ellipsoid" size="0.1 0.03 0.02" pos="0.1 0 0"/>
          <body name="hand" pos="0.2 0 0" quat="0.9 0.1 0.3 0.2">
            <joint name="wrist" type="ball" pos="0 0 0.02"/>
            <geom type="cylinder" size="0.02 0.05"/>
            <site name="hand_tip" pos="0.05 0 0"/>
          </body>
        </body>
        <body name="follower" pos="0 0.1 0">
          <joint name="follow" type="hinge" axis="0 0 1" range="-90 90" ref="5"/>
          <geom type="sphere"/>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="follow" joint2="twist" polycoef="0.1 -0.5 0 0 0"/>
  </equality>
</mujoco>
"""


def test_every_joint_kind_matches_mujoco(tmp_path: Path) -> None:
    """Fixed base off the world origin, hinges with ref off the body origin, slide, unlimited hinge, ball, mimic."""
    path = tmp_path / "every_joint.xml"
    path.write_text(_EVERY_JOINT)
    m = read_mjcf(path)
    assert m.base == BaseType.FIXED and m.root == "world"
    types = {j.name: j.type for j in m.joints}
    assert types == {
        "base_fixed": JointType.FIXED, "swing": JointType.REVOLUTE, "twist": JointType.REVOLUTE,
        "slide": JointType.PRISMATIC, "spin": JointType.CONTINUOUS, "wrist": JointType.SPHERICAL,
        "follow": JointType.REVOLUTE,
    }  # fmt: skip
    swing = m.joint("swing")
    assert np.allclose([swing.limit.lower, swing.limit.upper], np.radians([-80, 25]))  # range - ref
    mimic = m.joint("follow").mimic
    assert mimic.joint == "twist" and mimic.multiplier == -0.5
    assert np.isclose(mimic.offset, 0.1 - np.radians(5))  # c0 + c1 ref2 - ref1, ref2 = 0
    assert [e.name for e in m.end_effectors] == ["hand_tip"]
    assert [s.type.name for s in m.link("lower").shapes] == ["CAPSULE"]  # the ellipsoid's nearest shape
    # The mimic ties 'follow' to 'twist': give MuJoCo the same relation so both sides see one pose.
    model = mujoco.MjModel.from_xml_path(str(path))
    qpos = _random_qpos(model, np.random.default_rng(1), 50)
    f, t = (model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in ("follow", "twist"))
    qpos[:, f] = 0.1 - 0.5 * qpos[:, t]
    expected, cols = _mujoco_positions(model, m, qpos)
    got = _morphkit_positions(m, _morphkit_q(model, m, qpos))[:, cols]
    assert len(cols) == model.nbody and float(np.abs(got - expected).max()) < 1e-5  # the world too


def test_dog_structure() -> None:
    """The suite dog: floating torso, the ball skipped, off-origin joints and multi-joint bodies as chains, 4 feet."""
    with pytest.warns(UserWarning, match="skipping ball"):
        m = read_mjcf(SUITE / "dog.xml")
    assert m.base == BaseType.FLOATING and m.root == "torso" and "ball" not in m.link_names
    model = mujoco.MjModel.from_xml_path(str(SUITE / "dog.xml"))
    assert m.dof == model.nv - 12  # both free joints (torso's is the base, the ball's is skipped)
    assert "L_1__L_1_extend" in m.link_names  # two hinges in body L_1: one intermediate link
    roles = sorted(e.role.name for e in m.end_effectors)
    assert roles == ["FOOT"] * 4 + ["HEAD"]  # the palms rest on the ground: front paws
    assert {e.name for e in m.end_effectors} == {"sole_L", "sole_R", "palm_L", "palm_R", "head"}


def test_dog_links_sit_at_off_origin_joints() -> None:
    """Most dog hinges sit off their body's origin; the links sit at those anchors (what the FK test compares)."""
    model = mujoco.MjModel.from_xml_path(str(SUITE / "dog.xml"))
    offsets = link_offsets(model, _read(SUITE / "dog.xml"))
    assert sum(bool(np.any(v != 0)) for v in offsets.values()) >= 30


_BAD = {
    "unknown joint type": (
        '<mujoco>\n  <worldbody>\n    <body name="a">\n      <joint name="j" type="twist"/>\n'
        '      <geom type="sphere" size="0.1"/>\n    </body>\n  </worldbody>\n</mujoco>\n',
        4,
        "invalid keyword: 'twist'",
    ),
    "bad number": (
        '<mujoco>\n  <worldbody>\n    <body name="a" pos="0 0 zero">\n      <geom type="sphere" size="0.1"/>\n'
        "    </body>\n  </worldbody>\n</mujoco>\n",
        3,
        "bad format in attribute 'pos'",
    ),
    "malformed XML": ("<mujoco>\n  <worldbody>\n    <body>\n</mujoco>\n", 3, "malformed XML"),
}


@pytest.mark.parametrize("case", sorted(_BAD))
def test_malformed_file_names_line(tmp_path: Path, case: str) -> None:
    """MuJoCo's compiler message becomes one DescriptionError at the file and line of the culprit."""
    text, line, words = _BAD[case]
    path = tmp_path / "bad.xml"
    path.write_text(text)
    with pytest.raises(DescriptionError, match=words) as info:
        read_morphology(path)
    assert info.value.location.path == str(path) and info.value.location.line == line


def test_missing_mesh_files_are_left_out_with_one_warning(tmp_path: Path) -> None:
    """Issue 46: files shipped without their visual meshes (Playground's robots) read, the primitives kept,
    one warning naming the count and the first file; a mesh that is present stays a mesh."""
    import trimesh

    trimesh.creation.box((0.1, 0.1, 0.1)).export(tmp_path / "here.stl")
    (tmp_path / "robot.xml").write_text(
        '<mujoco>\n  <asset>\n    <mesh name="m" file="nope.stl"/>\n    <mesh name="h" file="here.stl"/>\n'
        '  </asset>\n  <worldbody>\n    <body name="a"><freejoint/><geom type="box" size="0.1 0.1 0.1"/>\n'
        '      <geom type="mesh" mesh="m" contype="0" conaffinity="0"/>\n'
        '      <body name="b" pos="0.3 0 0"><joint name="j"/><geom type="mesh" mesh="h"/></body>\n'
        "    </body>\n  </worldbody>\n</mujoco>\n")
    with pytest.warns(UserWarning, match=r"1 mesh file\(s\) not found \(first: nope.stl\)") as record:
        m = read_mjcf(tmp_path / "robot.xml")
    assert len([w for w in record if "not found" in str(w.message)]) == 1
    assert [s.type.name for s in m.link("a").shapes] == ["BOX"]
    assert [s.type.name for s in m.link("b").shapes] == ["MESH"]


_TELESCOPE = """<mujoco model="telescope">
  <worldbody>
    <body name="mast">
      <geom type="box" size="0.05 0.05 0.5"/>
      <body name="s0" pos="0.1 0 0.4"><joint name="l0" type="slide" axis="1 0 0" range="0 0.2" ref="0.01"/>
        <geom type="box" size="0.1 0.02 0.02"/>
        <body name="s1" pos="0.05 0 0"><joint name="l1" type="slide" axis="1 0 0" range="0 0.2"/>
          <geom type="box" size="0.1 0.02 0.02"/>
          <body name="s2" pos="0.05 0 0"><joint name="l2" type="slide" axis="1 0 0" range="0 0.2" ref="0.02"/>
            <geom type="box" size="0.1 0.02 0.02"/>
            <body name="tip" pos="0.1 0 0"><joint name="wrist" type="hinge" axis="0 0 1" range="-1 1"/>
              <geom type="sphere" size="0.03"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="l0" joint2="l1" polycoef="0.01 0.5 0 0 0"/>
    <joint joint1="l1" joint2="l2" polycoef="-0.02 2 0 0 0"/>
  </equality>
</mujoco>
"""


def test_a_chain_of_joint_equalities_is_driven_by_its_last_joint(tmp_path: Path) -> None:
    """Menagerie's Stretch ties its telescope's stages one to the next (l0 to l1, l1 to l2): each stage is a mimic
    of the joint that drives the chain, its coefficients composed, and FK matches MuJoCo with the chain applied."""
    path = tmp_path / "telescope.xml"
    path.write_text(_TELESCOPE)
    m = read_mjcf(path)
    # qpos_l1 = -0.02 + 2 qpos_l2 and qpos_l0 = 0.01 + 0.5 qpos_l1, with q = qpos - ref on each side
    ref = {"l0": 0.01, "l1": 0.0, "l2": 0.02}
    l1, l0 = m.joint("l1").mimic, m.joint("l0").mimic
    assert (l1.joint, l0.joint) == ("l2", "l2")
    assert l1.multiplier == pytest.approx(2.0) and l1.offset == pytest.approx(-0.02 + 2 * ref["l2"] - ref["l1"])
    assert l0.multiplier == pytest.approx(1.0)
    assert l0.offset == pytest.approx(0.01 + 0.5 * (-0.02 + 2 * ref["l2"]) - ref["l0"])
    model = mujoco.MjModel.from_xml_path(str(path))
    qpos = _random_qpos(model, np.random.default_rng(2), 20)
    adr = {n: model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, n)] for n in ref}
    qpos[:, adr["l1"]] = -0.02 + 2 * qpos[:, adr["l2"]]
    qpos[:, adr["l0"]] = 0.01 + 0.5 * qpos[:, adr["l1"]]
    expected, cols = _mujoco_positions(model, m, qpos)
    got = _morphkit_positions(m, _morphkit_q(model, m, qpos))[:, cols]
    assert len(cols) == model.nbody - 1 and float(np.abs(got - expected).max()) < 1e-9  # all but the world


def test_missing_textures_and_massless_bodies_read(tmp_path: Path) -> None:
    """A model folder copied without its ``assets`` (Menagerie's Stretch): a missing texture is drawn flat (one
    warning), a moving body whose only geom was a missing mesh still reads (MuJoCo wants it to have mass); the
    kinematics are those of the same model without the missing files."""
    body = ('<body name="arm" pos="0 0 0.3"><joint name="j" axis="0 1 0"/>{geom}\n'
            '  <body name="hand" pos="0.3 0 0"><joint name="k" axis="0 1 0"/><geom type="sphere" size="0.05"/></body>'
            "</body>")
    meshed = body.format(geom='<geom type="mesh" mesh="m"/>')
    massive = body.format(geom='<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/>')
    text = ('<mujoco>\n  <asset>\n    <texture name="t" type="2d" file="nope.png"/>\n'
            '    <material name="skin" texture="t"/>\n    <mesh name="m" file="gone.obj"/>\n  </asset>\n'
            '  <worldbody>\n    <body name="base"><geom type="box" size="0.1 0.1 0.1" material="skin"/>\n'
            f"      {meshed}\n    </body>\n  </worldbody>\n</mujoco>\n")
    (tmp_path / "robot.xml").write_text(text)
    with pytest.warns(UserWarning) as record:
        m = read_mjcf(tmp_path / "robot.xml")
    said = [str(w.message) for w in record if "not found" in str(w.message)]
    assert len(said) == 2 and "1 texture file(s) not found (first: nope.png); drawn flat" in said[1]
    assert "1 mesh file(s) not found (first: gone.obj)" in said[0]
    plain = ('<mujoco>\n  <worldbody>\n    <body name="base"><geom type="box" size="0.1 0.1 0.1"/>\n'
             f"      {massive}\n"
             "    </body>\n  </worldbody>\n</mujoco>\n")
    (tmp_path / "plain.xml").write_text(plain)
    err, bodies = _fk_error(tmp_path / "plain.xml", m)
    assert bodies == 3 and err < 1e-9 and m.link("arm").shapes == ()  # base, arm, hand


def test_include_loop_and_error_inside_include(tmp_path: Path) -> None:
    """An include loop names the include that closes it; a bad number inside an included file names that file."""
    (tmp_path / "a.xml").write_text('<mujoco>\n  <include file="b.xml"/>\n  <worldbody/>\n</mujoco>\n')
    (tmp_path / "b.xml").write_text('<mujoco>\n\n  <include file="a.xml"/>\n</mujoco>\n')
    with pytest.raises(DescriptionError, match="already included") as info:
        read_mjcf(tmp_path / "a.xml")
    assert info.value.location == type(info.value.location)(str(tmp_path / "b.xml"), 3)

    (tmp_path / "main.xml").write_text(
        '<mujoco>\n  <worldbody>\n    <include file="part.xml"/>\n  </worldbody>\n</mujoco>\n'
    )
    (tmp_path / "part.xml").write_text(
        '<mujoco>\n  <body name="a">\n    <geom type="sphere" size="0.1"/>\n'
        '    <joint type="hinge" range="0 x"/>\n  </body>\n</mujoco>\n'
    )
    with pytest.raises(DescriptionError, match="range") as info:
        read_mjcf(tmp_path / "main.xml")
    assert info.value.location.path == str(tmp_path / "part.xml") and info.value.location.line == 4


def test_cli_error_exit_code(tmp_path: Path, capsys) -> None:
    """``morphkit info bad.xml``: one line on stderr with file and line, exit code 2, no traceback."""
    from morphkit.cli import main

    path = tmp_path / "bad.xml"
    path.write_text(_BAD["unknown joint type"][0])
    assert main(["info", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"error: {path}:4: MuJoCo: invalid keyword" in err and "Traceback" not in err


@pytest.mark.parametrize("name", MODELS)
def test_round_trip_through_mujoco(tmp_path: Path, name: str) -> None:
    """MJCF → morphkit → MJCF (write_morphology) → MuJoCo puts every body where the original model does."""
    original = mujoco.MjModel.from_xml_path(str(SUITE / name))
    m = _read(SUITE / name)
    out = tmp_path / f"again_{name}"
    write_morphology(m, out)
    written = mujoco.MjModel.from_xml_path(str(out))
    qpos = _random_qpos(original, np.random.default_rng(2), 20)
    q = _morphkit_q(original, m, qpos)
    expected, cols = _mujoco_positions(original, m, qpos)
    data = mujoco.MjData(written)
    bodies = [mujoco.mj_name2id(written, mujoco.mjtObj.mjOBJ_BODY, m.links[i].name) for i in cols]
    got = np.zeros_like(expected)
    for b, qp in enumerate(qpos_from_q(m, q, written)):
        data.qpos[:] = qp
        mujoco.mj_kinematics(written, data)
        got[b] = data.xpos[bodies]
    err = float(np.abs(got - expected).max())
    print(f"{name}: round trip, max body position difference {err:.2e} m")
    assert err < 1e-5
    again = read_mjcf(out)  # and it reads back as the same graph
    assert again.link_names == m.link_names and [j.type for j in again.joints] == [j.type for j in m.joints]
    assert sorted(e.name for e in again.end_effectors) == sorted(e.name for e in m.end_effectors)
    assert np.allclose(again.rest_link_poses()[:, :3], m.rest_link_poses()[:, :3], atol=1e-9)


def test_qpos_export_replays_in_the_original_model() -> None:
    """qpos_from_q inverts the reader's coordinates: morphkit q of MuJoCo poses maps back to the same qpos."""
    model = mujoco.MjModel.from_xml_path(str(SUITE / "dog.xml"))
    m = _read(SUITE / "dog.xml")
    qpos = _random_qpos(model, np.random.default_rng(3), 10)
    ball = model.jnt_qposadr[model.body_jntadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "ball")]]
    qpos[:, ball : ball + 7] = model.qpos0[ball : ball + 7]  # the skipped ball stays put
    back = qpos_from_q(m, _morphkit_q(model, m, qpos), model)
    np.testing.assert_allclose(back, qpos, atol=1e-12)


def test_cli_convert_motion_to_qpos_replays_in_mujoco(tmp_path: Path) -> None:
    """``morphkit convert clip.npz clip.qpos.npy --mjcf model.xml``: MuJoCo puts the bodies where morphkit's FK does."""
    from morphkit.cli import main
    from morphkit.motion import Motion, write_motion

    path = tmp_path / "every_joint.xml"
    path.write_text(_EVERY_JOINT)
    m = read_mjcf(path)
    model = mujoco.MjModel.from_xml_path(str(path))
    qpos = _random_qpos(model, np.random.default_rng(4), 12)
    q = _morphkit_q(model, m, qpos)
    write_motion(Motion(m, 30.0, q, name="clip"), tmp_path / "clip.npz")
    assert main(["convert", str(tmp_path / "clip.npz"), str(tmp_path / "clip.qpos.npy"), "--mjcf", str(path)]) == 0
    replay = np.load(tmp_path / "clip.qpos.npy")
    assert replay.shape == (12, model.nq)
    expected = _morphkit_positions(m, q)
    got, cols = _mujoco_positions(model, m, replay)
    assert float(np.abs(got - expected[:, cols]).max()) < 1e-5


def test_cli_convert_yaml_to_mjcf_compiles(tmp_path: Path) -> None:
    """``morphkit convert spot spot.xml`` writes MJCF that MuJoCo compiles, one body per link."""
    from morphkit.cli import main

    out = tmp_path / "spot.xml"
    assert main(["convert", "spot", str(out)]) == 0
    model = mujoco.MjModel.from_xml_path(str(out))
    spot = read_morphology("spot")
    assert model.nbody == spot.link_count + 1 and model.nq == spot.coordinate_count
