"""Offscreen rendering: analytic projection, turntables, motion videos, writers, the render command.

Every test that draws needs pyrender and a headless OpenGL (EGL or OSMesa) and skips cleanly
without them; the pure-NumPy parts (colours, framing, sync) always run.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import SHIPPED, shipped_morphology

from morphkit.graph import Limit, Morphology, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.render.scene import CHAIN_PALETTE, TRUNK_COLOR, fit_distance, link_colors, look_at, orbit_eye

ROOT = Path(__file__).resolve().parents[2]
SMALL = (160, 120)


@pytest.fixture(scope="module")
def gl() -> None:
    """Skip unless pyrender can open an offscreen OpenGL context here."""
    try:
        from morphkit.render import RenderUnavailableError
        from morphkit.render._gl import offscreen_renderer

        with offscreen_renderer(8, 8):
            pass
    except RenderUnavailableError as exc:
        pytest.skip(f"offscreen rendering unavailable: {exc}")


def silhouette(image: np.ndarray) -> np.ndarray:
    """Pixels that are not the white background, bool [H, W]."""
    return np.abs(image.astype(int) - 255).sum(axis=-1) > 30


def quadruped() -> Morphology:
    """Box body, four two-segment capsule legs with feet, a head sphere with a head end-effector."""
    b = MorphologyBuilder("quad")
    b.add_link("body", shapes=[Shape(ShapeType.BOX, size=(0.8, 0.3, 0.18))])
    b.set_root("body")
    for name, x, y in [("fl", 0.3, 0.12), ("fr", 0.3, -0.12), ("hl", -0.3, 0.12), ("hr", -0.3, -0.12)]:
        seg = Shape(ShapeType.CAPSULE, radius=0.03, length=0.3, origin=Transform((0, 0, -0.15)))
        b.add_link(f"{name}_upper", shapes=[seg])
        b.add_link(f"{name}_lower", shapes=[seg])
        b.add_joint_revolute(
            f"{name}_hip", "body", f"{name}_upper", origin=Transform((x, y, 0)), axis=(0, 1, 0), limit=Limit(-1, 1)
        )
        b.add_joint_revolute(
            f"{name}_knee",
            f"{name}_upper",
            f"{name}_lower",
            origin=Transform((0, 0, -0.3)),
            axis=(0, 1, 0),
            limit=Limit(-2, 2),
        )
        b.add_end_effector(f"{name}_foot", f"{name}_lower", offset=(0, 0, -0.3), role="foot")
    b.add_link("head", shapes=[Shape(ShapeType.SPHERE, radius=0.08)])
    b.add_joint_fixed("neck", "body", "head", origin=Transform((0.45, 0, 0.1)))
    b.add_end_effector("nose", "head", offset=(0.08, 0, 0), role="head")
    return b.build()


# ---- no OpenGL needed ------------------------------------------------------------------------
def test_link_colors_one_per_chain_trunk_shared():
    """Each leg chain gets its own palette colour; the body (on every chain) is trunk grey."""
    m = quadruped()
    colors = link_colors(m)
    np.testing.assert_allclose(colors[m.link_index("body")], TRUNK_COLOR)
    legs = [colors[m.link_index(f"{n}_lower")] for n in ("fl", "fr", "hl", "hr")]
    assert len({tuple(c) for c in legs}) == 4
    for n in ("fl", "fr", "hl", "hr"):  # a chain is one colour from hip to foot
        np.testing.assert_allclose(colors[m.link_index(f"{n}_upper")], colors[m.link_index(f"{n}_lower")])
        assert tuple(colors[m.link_index(f"{n}_lower")]) in CHAIN_PALETTE


def test_fit_distance_matches_pinhole_bound():
    """Two points at ±a sideways, seen head-on: distance = a / tan(half horizontal fov) · margin."""
    a, yfov, aspect, margin = 0.5, 40.0, 4 / 3, 1.1
    pts = np.array([[0.0, a, 0.0], [0.0, -a, 0.0]])
    d = fit_distance(pts, 0.0, 0.0, yfov_deg=yfov, aspect=aspect, margin=margin)
    np.testing.assert_allclose(d, a / (math.tan(math.radians(yfov) / 2) * aspect / margin), rtol=1e-9)


def test_sync_indices_align_clips_by_time():
    """A 30 fps clip and a 10 fps clip of equal length show the same instant at each output frame."""
    from morphkit.render.compare import sync_indices

    idx = sync_indices([30, 10], [30.0, 10.0], 30.0)
    assert idx.shape == (30, 2)
    np.testing.assert_array_equal(idx[:, 0], np.arange(30))
    np.testing.assert_array_equal(idx[:, 1], np.arange(30) // 3)


def test_sync_indices_end_with_the_shorter_clip_unless_asked():
    """A 1 s clip at 30 fps beside a 0.5 s clip at 20 fps: 15 output frames at 30 fps, or 30 with until_longer,
    the short clip then holding its last frame; each column shows the frame at the same instant."""
    from morphkit.render.compare import sync_indices

    short = sync_indices([30, 10], [30.0, 20.0], 30.0)
    assert short.shape == (15, 2)
    t = np.arange(15) / 30.0
    np.testing.assert_array_equal(short[:, 0], np.arange(15))
    np.testing.assert_array_equal(short[:, 1], np.floor(t * 20.0 + 1e-9).astype(int))
    longer = sync_indices([30, 10], [30.0, 20.0], 30.0, until_longer=True)
    assert longer.shape == (30, 2)
    np.testing.assert_array_equal(longer[:15], short)
    assert (longer[15:, 1] == 9).all()


def test_camera_azimuths_turn_with_the_smoothed_heading():
    """A root turning at a constant rate through ±180° (the heading wraps) swaying 2 Hz from side to side: the
    following camera turns with the turn, unwrapped, and not with the sway; a world camera stays put."""
    from morphkit.render.video import HEADING_SMOOTHING_S, camera_azimuths
    from morphkit.rotations import quat_from_yaw

    fps, T = 20.0, 200
    t = np.arange(T) / fps
    turn = 2.5 + 0.4 * t  # rad: passes π at t ≈ 1.6 s
    poses = np.zeros((T, 1, 7))
    poses[:, 0, 3:] = quat_from_yaw(turn + 0.2 * np.sin(2 * np.pi * 2.0 * t))
    az = camera_azimuths(poses, fps, 90.0, follow_heading=True)
    inner = slice(int(3 * HEADING_SMOOTHING_S * fps), T - int(3 * HEADING_SMOOTHING_S * fps))
    np.testing.assert_allclose(az[inner], 90.0 + np.degrees(turn[inner]), atol=0.05)
    assert np.abs(np.diff(az)).max() < 2.0  # no 360° jump where the heading wraps
    np.testing.assert_array_equal(camera_azimuths(poses, fps, 90.0, follow_heading=False), np.full(T, 90.0))


@pytest.fixture
def read_only_dir(tmp_path: Path) -> Path:
    """A folder no file can be created in: a chmod 555 folder, or /sys where chmod does not bind (root)."""
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    for candidate in (folder, Path("/sys")):
        try:
            (candidate / ".probe").touch()
        except OSError:
            return candidate
        (candidate / ".probe").unlink()
    pytest.skip("no read-only folder to write into here")


def test_render_refuses_an_unwritable_output_before_rendering(read_only_dir, tmp_path, monkeypatch, capsys):
    """A read-only, folder or unknown-type output is one error line, exit 2, before any frame is drawn."""
    import morphkit.render.scene as scene
    from morphkit.cli import main

    def drawn(*args, **kwargs):
        raise AssertionError("rendering started")

    monkeypatch.setattr(scene.CreatureScene, "__init__", drawn)
    m = quadruped()
    from morphkit.io import write_morphology

    write_morphology(m, tmp_path / "quad.yaml")
    np.savez(tmp_path / "walk.npz", q=np.repeat(m.rest_q()[None], 3, axis=0), fps=np.float64(10.0))
    out = read_only_dir / "a.png"
    motion = ["--motion", str(tmp_path / "walk.npz")]
    for extra in ([], motion, [*motion, "--compare", str(tmp_path / "walk.npz")]):
        assert main(["render", str(tmp_path / "quad.yaml"), *extra, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith(f"error: {out}: cannot write in {read_only_dir}") and err.count("\n") == 1
    assert main(["render", str(tmp_path / "quad.yaml"), "--out", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err
    assert main(["render", str(tmp_path / "quad.yaml"), "--out", str(tmp_path / "a.txt")]) == 2
    assert "unknown output type" in capsys.readouterr().err
    assert not out.exists()


def test_render_frame_and_option_errors_are_one_line(tmp_path, capsys):
    """Bad --frames values and options that need --motion or --compare are refused before any work."""
    from morphkit.cli import main

    walk = ["--motion", str(tmp_path / "walk.npz")]
    cases = [
        (["--frames", "5:2", *walk], "selects no frame"),
        (["--frames", "a:b", *walk], "expected A:B"),
        (["--frames=-1:", *walk], "count from 0"),
        (["--frames", "2:5"], "a turntable takes a view count"),
        (["--frames", "0"], "at least 1"),
        (["--until-longer", *walk], "--until-longer needs --compare"),
        (["--follow"], "--follow needs --motion"),
    ]
    for args, message in cases:
        assert main(["render", "spot", *args, "--out", str(tmp_path / "x.gif")]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err


def test_select_platform_names_missing_packages_when_no_gl():
    """Without a display, EGL or OSMesa, the error names libegl1 and libosmesa6."""
    code = textwrap.dedent(
        """
        import os
        for k in ("PYOPENGL_PLATFORM", "DISPLAY", "WAYLAND_DISPLAY"):
            os.environ.pop(k, None)
        import morphkit.render._gl as g
        g._egl_works = lambda: False
        g._osmesa_works = lambda: False
        try:
            g.select_platform()
        except g.RenderUnavailableError as exc:
            print("ERR", exc)
        """
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert "ERR" in out.stdout and "libegl1" in out.stdout and "libosmesa6" in out.stdout


def test_import_render_is_light():
    """Importing morphkit.render loads neither pyrender nor OpenGL."""
    code = "import sys, morphkit.render; print([m for m in ('pyrender', 'OpenGL', 'trimesh') if m in sys.modules])"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert out.stdout.strip() == "[]"


# ---- rendering -------------------------------------------------------------------------------
def test_sphere_projects_as_pinhole_predicts(gl):
    """A sphere's silhouette centroid and area match the analytic pinhole projection (an ellipse).

    A sphere of angular radius α whose centre lies θ off the optical axis projects to an ellipse
    centred ρ = f sinθ cosθ / (cos²θ − sin²α) from the principal point (radially), with semi-axes
    a = f sinα cosα / (cos²θ − sin²α) and b = f sinα / √(cos²θ − sin²α); f is the focal length [px].
    """
    from morphkit.render import CreatureScene, RenderStyle
    from morphkit.render._gl import offscreen_renderer

    r, yfov, (W, H) = 0.3, 40.0, (320, 240)
    b = MorphologyBuilder("ball")
    b.add_link("ball", shapes=[Shape(ShapeType.SPHERE, radius=r)])
    b.set_root("ball")
    b.set_base("fixed")
    m = b.build()
    scene = CreatureScene(m, style=RenderStyle(shadows=False, ground=False, markers=False, yfov_deg=yfov))
    f = (H / 2) / math.tan(math.radians(yfov) / 2)
    target, dist, az = np.array([0.1, -0.2, 0.4]), 3.0, 30.0
    with offscreen_renderer(W, H) as renderer:
        for center in (target, target + np.array([0.0, 0.6, 0.3])):
            scene.set_link_poses(np.array([[*center, 0, 0, 0, 1]]))
            scene.set_camera(target, dist, az, W / H)
            mask = silhouette(scene.render(renderer))
            ys, xs = np.nonzero(mask)
            eye = orbit_eye(target, dist, az, scene.style.elevation_deg)
            p = (np.linalg.inv(look_at(eye, target)) @ np.array([*center, 1.0]))[:3]  # camera frame, looks down -z
            theta = math.acos(-p[2] / np.linalg.norm(p))
            alpha = math.asin(r / np.linalg.norm(p))
            k = math.cos(theta) ** 2 - math.sin(alpha) ** 2
            rho = f * math.sin(theta) * math.cos(theta) / k
            radial = p[:2] / np.linalg.norm(p[:2]) if np.linalg.norm(p[:2]) > 1e-12 else np.zeros(2)
            u, v = W / 2 + rho * radial[0], H / 2 - rho * radial[1]  # image y runs down
            np.testing.assert_allclose([xs.mean() + 0.5, ys.mean() + 0.5], [u, v], atol=0.5)
            a_px = f * math.sin(alpha) * math.cos(alpha) / k
            b_px = f * math.sin(alpha) / math.sqrt(k)
            # The icosphere's outline is a polygon inside the circle: its area is up to ~2 % short.
            np.testing.assert_allclose(mask.sum(), math.pi * a_px * b_px, rtol=0.04)


def test_spot_turntable_views_differ_and_frame_the_robot(gl):
    """Spot's turntable at 0° and 90° differ; each shows a whole silhouette of plausible size."""
    from morphkit.render import RenderStyle, turntable_frames

    m = shipped_morphology("spot")
    frames = turntable_frames(m, frames=4, size=SMALL, style=RenderStyle(ground=False, shadows=False))
    assert frames.shape == (4, SMALL[1], SMALL[0], 3) and frames.dtype == np.uint8
    masks = [silhouette(f) for f in frames[:2]]
    for mask in masks:
        fill = mask.mean()
        assert 0.03 < fill < 0.6, fill
        ys, xs = np.nonzero(mask)  # framed: the robot does not touch the image border
        assert xs.min() > 0 and ys.min() > 0 and xs.max() < SMALL[0] - 1 and ys.max() < SMALL[1] - 1
    assert (masks[0] != masks[1]).mean() > 0.02
    assert np.abs(frames[0].astype(int) - frames[1].astype(int)).mean() > 2.0


def test_ground_and_shadows_darken_the_floor(gl):
    """With the default style the floor shows (grid) and the shadow darkens it below the creature."""
    from morphkit.render import RenderStyle, turntable_frames

    m = quadruped()
    lit = turntable_frames(m, frames=1, size=SMALL)[0]
    bare = turntable_frames(m, frames=1, size=SMALL, style=RenderStyle(shadows=False))[0]
    assert silhouette(lit)[-SMALL[1] // 4 :].mean() > 0.5  # the bottom of the image is floor
    assert lit.astype(int).sum() < bare.astype(int).sum()  # shadows only take light away


@pytest.mark.parametrize("suffix", [".gif", ".mp4"])
def test_motion_video_has_requested_frame_count(gl, tmp_path, suffix):
    """A 7-frame clip written as GIF/MP4 reads back with 7 frames."""
    import imageio.v2 as imageio
    import imageio.v3 as iio

    from morphkit.render import ffmpeg_available, render_motion

    if suffix == ".mp4" and not ffmpeg_available():
        pytest.skip("no ffmpeg (pip install imageio-ffmpeg)")
    m = quadruped()
    T = 7
    q = np.repeat(m.rest_q()[None], T, axis=0)
    q[:, 0] = np.linspace(0.0, 0.5, T)
    q[:, 7] = np.linspace(-0.5, 0.5, T)
    out = render_motion(m, q, 10.0, out=tmp_path / f"clip{suffix}", size=(96, 64))
    if suffix == ".gif":
        assert iio.imread(out, index=None).shape == (T, 64, 96, 3)
    else:
        reader = imageio.get_reader(out, format="FFMPEG")
        assert reader.count_frames() == T
        reader.close()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary left behind


def test_motion_object_and_side_by_side(gl, tmp_path):
    """An object with .morphology/.q/.fps renders; a side-by-side PNG sheet pairs both clips."""
    from types import SimpleNamespace

    from morphkit.render import render_side_by_side, side_by_side_frames

    m = quadruped()
    q = np.repeat(m.rest_q()[None], 4, axis=0)
    q[:, 8] = np.linspace(0.0, 1.0, 4)
    clip = SimpleNamespace(morphology=m, q=q, fps=8.0)
    frames = side_by_side_frames([clip, (m, q[:2], 4.0)], size=(64, 48), labels=["a", "b"])
    assert frames.shape == (4, 48, 2 * 64 + 3, 3)
    out = render_side_by_side(clip, clip, out=tmp_path / "cmp.png", size=(64, 48))
    assert out.is_file()


def _capsule(radius: float, length: float, xyz: list[float], rpy: list[float] | None = None) -> dict:
    return {"type": "capsule", "radius": radius, "length": length, "origin": {"xyz": xyz, "rpy": rpy or [0, 0, 0]}}


def _write_yaml_creatures(folder: Path) -> list[Path]:
    """A three-legged creature with one arm and an eight-legged one, written as YAML creature files."""
    import yaml

    tri: dict = {"name": "tripod", "base": "floating", "root": "body", "joints": {}, "end_effectors": {}}
    tri["links"] = {"body": {"shapes": [{"type": "cylinder", "radius": 0.22, "length": 0.1}]}}
    for k in range(3):
        a = 2 * math.pi * k / 3
        tri["links"][f"leg{k}_up"] = {"shapes": [_capsule(0.03, 0.25, [0, 0, -0.125])]}
        tri["links"][f"leg{k}_lo"] = {"shapes": [_capsule(0.02, 0.25, [0, 0, -0.125])]}
        hip_origin = {"xyz": [0.2 * math.cos(a), 0.2 * math.sin(a), 0], "rpy": [0, 0, a]}
        tri["joints"][f"leg{k}_hip"] = {
            "type": "revolute",
            "parent": "body",
            "child": f"leg{k}_up",
            "axis": [0, 1, 0],
            "origin": hip_origin,
            "limit": {"lower": -1, "upper": 1},
        }
        tri["joints"][f"leg{k}_knee"] = {
            "type": "revolute",
            "parent": f"leg{k}_up",
            "child": f"leg{k}_lo",
            "axis": [0, 1, 0],
            "origin": {"xyz": [0, 0, -0.25]},
            "limit": {"lower": -2, "upper": 2},
        }
        tri["end_effectors"][f"foot{k}"] = {"link": f"leg{k}_lo", "offset": [0, 0, -0.25], "role": "foot"}
    tri["links"]["arm_a"] = {"shapes": [_capsule(0.025, 0.3, [0.15, 0, 0], [0, math.pi / 2, 0])]}
    tri["links"]["arm_b"] = {"shapes": [{"type": "box", "size": [0.25, 0.05, 0.05], "origin": {"xyz": [0.125, 0, 0]}}]}
    tri["joints"]["shoulder"] = {
        "type": "revolute",
        "parent": "body",
        "child": "arm_a",
        "axis": [0, 1, 0],
        "origin": {"xyz": [0, 0, 0.05]},
        "limit": {"lower": -1.5, "upper": 1.5},
    }
    tri["joints"]["elbow"] = {
        "type": "revolute",
        "parent": "arm_a",
        "child": "arm_b",
        "axis": [0, 1, 0],
        "origin": {"xyz": [0.3, 0, 0]},
        "limit": {"lower": -2, "upper": 2},
    }
    tri["end_effectors"]["grip"] = {"link": "arm_b", "offset": [0.25, 0, 0], "role": "hand"}

    spider: dict = {"name": "spider", "base": "floating", "root": "body", "joints": {}, "end_effectors": {}}
    spider["links"] = {"body": {"shapes": [{"type": "sphere", "radius": 0.12}]}}
    for k in range(8):
        side, i = (1 if k < 4 else -1), k % 4
        yaw = side * (math.pi / 2 + 0.35 * (i - 1.5))
        spider["links"][f"l{k}_femur"] = {"shapes": [_capsule(0.015, 0.2, [0.1, 0, 0], [0, math.pi / 2, 0])]}
        spider["links"][f"l{k}_tibia"] = {"shapes": [_capsule(0.012, 0.25, [0.125, 0, 0], [0, math.pi / 2, 0])]}
        spider["joints"][f"l{k}_hip"] = {
            "type": "revolute",
            "parent": "body",
            "child": f"l{k}_femur",
            "axis": [0, 0, 1],
            "limit": {"lower": -0.5, "upper": 0.5},
            "origin": {"xyz": [0.15 - 0.1 * i, side * 0.08, 0], "rpy": [0, -0.5, yaw]},
        }
        spider["joints"][f"l{k}_knee"] = {
            "type": "revolute",
            "parent": f"l{k}_femur",
            "child": f"l{k}_tibia",
            "axis": [0, -1, 0],
            "origin": {"xyz": [0.2, 0, 0], "rpy": [0, 1.3, 0]},
            "limit": {"lower": -1, "upper": 1},
        }
        spider["end_effectors"][f"foot{k}"] = {"link": f"l{k}_tibia", "offset": [0.25, 0, 0], "role": "foot"}
    spider["end_effectors"]["eyes"] = {"link": "body", "offset": [0.12, 0, 0.03], "role": "head"}

    paths = [folder / "tripod.yaml", folder / "spider.yaml"]
    for path, creature in zip(paths, (tri, spider), strict=True):
        path.write_text(yaml.safe_dump(creature, sort_keys=False))
    return paths


@pytest.mark.parametrize("name", [*SHIPPED, "tripod", "spider"])
def test_turntables_of_every_creature_render(gl, tmp_path, name):
    """Every shipped creature and two YAML creatures written here render a whole turntable."""
    import imageio.v3 as iio

    from morphkit.io import read_morphology
    from morphkit.render import RenderStyle, turntable

    if name in SHIPPED:
        m = shipped_morphology(name)
    else:
        paths = {p.stem: p for p in _write_yaml_creatures(tmp_path)}
        m = read_morphology(paths[name])
    out = turntable(m, tmp_path / f"{name}.gif", frames=3, size=SMALL, style=RenderStyle(ground=False))
    frames = iio.imread(out, index=None)
    assert frames.shape[0] == 3
    for f in frames:
        assert 0.01 < silhouette(f[..., :3]).mean() < 0.7


def test_contact_sheet_and_still(gl, tmp_path):
    """A one-frame turntable to .png is a still of the frame size; several frames make a grid."""
    from PIL import Image

    from morphkit.render import turntable

    m = quadruped()
    still = turntable(m, tmp_path / "still.png", frames=1, size=SMALL)
    assert Image.open(still).size == SMALL
    sheet = turntable(m, tmp_path / "sheet.png", frames=4, size=SMALL)
    w, h = Image.open(sheet).size
    assert w > SMALL[0] and h > SMALL[1]


def test_bone_geometry_for_shapeless_links(gl):
    """A skeleton without shapes (as read from BVH) is drawn with bones and is not empty."""
    from morphkit.render import RenderStyle, turntable_frames

    b = MorphologyBuilder("stick")
    for n in ("hips", "spine", "head", "leg"):
        b.add_link(n)
    b.set_root("hips")
    b.add_joint_fixed("j_spine", "hips", "spine", origin=Transform((0, 0, 0.5)))
    b.add_joint_fixed("j_head", "spine", "head", origin=Transform((0, 0, 0.4)))
    b.add_joint_fixed("j_leg", "hips", "leg", origin=Transform((0, 0.1, -0.1)))
    b.add_end_effector("foot", "leg", offset=(0, 0, -0.8), role="foot")
    frame = turntable_frames(b.build(), frames=1, size=SMALL, style=RenderStyle(ground=False))[0]
    assert silhouette(frame).mean() > 0.01


def test_follow_keeps_the_same_side_in_view_while_the_creature_turns(gl):
    """A creature walking a circle, seen at two instants half a turn apart: with the camera following its
    heading both views show the same side (the same image), with a world-fixed camera they do not."""
    from morphkit.render import RenderStyle, motion_frames
    from morphkit.rotations import quat_from_yaw

    m = quadruped()
    fps, T = 10.0, 90
    yaw = np.linspace(0.0, 0.9 * np.pi, T)
    q = np.repeat(m.rest_q()[None], T, axis=0)
    q[:, 0], q[:, 1] = 2.0 * np.sin(yaw), 2.0 * (1.0 - np.cos(yaw))  # forward along the circle
    q[:, 3:7] = quat_from_yaw(yaw)
    style = RenderStyle(ground=False, shadows=False, markers=False, azimuth_deg=70.0)
    a, b = 32, 57  # more than 3 σ of heading smoothing from either end: the heading is followed exactly
    kw = {"size": (64, 48), "style": style, "frame_indices": [a, b]}
    turning = motion_frames(m, q, fps, follow_heading=True, **kw).astype(int)
    fixed = motion_frames(m, q, fps, **kw).astype(int)
    assert silhouette(turning[0]).mean() > 0.02
    assert np.abs(turning[0] - turning[1]).mean() < 1.0
    assert np.abs(fixed[0] - fixed[1]).mean() > 5 * max(np.abs(turning[0] - turning[1]).mean(), 0.2)


def test_missing_mesh_is_drawn_as_a_stand_in_with_one_warning(gl, tmp_path):
    """A link whose only mesh is missing is drawn as bones, one whose mesh is missing beside a capsule with the
    capsule; one warning says so for the file, naming the first link's line."""
    from morphkit.io import read_morphology
    from morphkit.render import RenderStyle, turntable_frames

    path = tmp_path / "bot.yaml"
    path.write_text(
        "name: bot\n"
        "links:\n"
        "  body: {shapes: [{type: mesh, file: meshes/body.stl}]}\n"
        "  leg: {shapes: [{type: capsule, radius: 0.03, length: 0.3}, {type: mesh, file: meshes/leg.obj}]}\n"
        "joints:\n"
        "  hip: {type: revolute, parent: body, child: leg, origin: {xyz: [0, 0, -0.3]}, axis: [0, 1, 0],"
        " limit: {lower: -1, upper: 1}}\n"
    )
    with pytest.warns(UserWarning, match="mesh file not found"):
        m = read_morphology(path)
    with pytest.warns(UserWarning) as record:
        frame = turntable_frames(m, frames=1, size=(64, 48), style=RenderStyle(ground=False, shadows=False))[0]
    said = [str(w.message) for w in record]
    assert len(said) == 1
    assert said[0].startswith(f"{path}:3: 2 meshes not found or unreadable on 2 links, e.g. link 'body': mesh file "
                              "not found") and said[0].endswith("1 as stand-ins (bones to their joints)")
    assert silhouette(frame).mean() > 0.01


def test_a_foot_ball_apart_from_its_knee_is_joined_by_a_bone(gl, tmp_path):
    """A shin whose only shape is the foot ball at its far end (MuJoCo Menagerie's Spot read without its meshes)
    is drawn with a bone from the knee to the foot; a shin whose capsule runs there is left as it is. Seen from
    the side, the middle of the shin is drawn only with the bone."""
    from morphkit.io import read_morphology
    from morphkit.render import RenderStyle, turntable_frames
    from morphkit.render.scene import bare_feet, shape_trimesh

    def write(name: str, shin: str) -> Morphology:
        path = tmp_path / f"{name}.yaml"
        path.write_text(
            f"name: {name}\nbase: floating\nroot: body\n"
            "links:\n"
            "  body: {shapes: [{type: box, size: [0.4, 0.2, 0.1]}]}\n"
            f"  shin: {{shapes: [{shin}]}}\n"
            "joints:\n"
            "  knee: {type: revolute, parent: body, child: shin, origin: {xyz: [0, 0, -0.05]}, axis: [0, 1, 0],"
            " limit: {lower: -1, upper: 1}}\n"
            "end_effectors:\n"
            "  foot: {link: shin, offset: [0, 0, -0.44], role: foot}\n"
        )
        return read_morphology(path)

    ball = write("ball", "{type: sphere, radius: 0.04, origin: {xyz: [0, 0, -0.4]}}")
    capsule = write("capsule", "{type: capsule, radius: 0.03, length: 0.4, origin: {xyz: [0, 0, -0.2]}}")
    for m, bare in ((ball, [[0.0, 0.0, -0.44]]), (capsule, [])):
        shin = m.link_index("shin")
        meshes = [shape_trimesh(s) for s in m.links[shin].shapes]
        np.testing.assert_allclose(np.reshape(bare_feet(m, shin, meshes), (-1, 3)), np.reshape(bare, (-1, 3)))
    style = RenderStyle(ground=False, shadows=False, markers=False, azimuth_deg=90.0, elevation_deg=0.0)
    frame = turntable_frames(ball, frames=1, size=(96, 128), style=style)[0]
    rows = np.flatnonzero(silhouette(frame).any(axis=1))
    # body (0.1 m) over knee-to-foot (0.44 m): drawn from the box's top to the ball's bottom without a gap
    drawn = silhouette(frame)[rows.min():rows.max() + 1].any(axis=1)
    assert drawn.all() and len(rows) > 40


# ---- command line ----------------------------------------------------------------------------
def test_cli_turntable_motion_and_errors(gl, tmp_path, capsys):
    """`morphkit render` writes a turntable and a motion clip; bad options exit 2 with one line."""
    import imageio.v3 as iio

    from morphkit.cli import main

    yaml = _write_yaml_creatures(tmp_path)[0]
    gif = tmp_path / "t.gif"
    assert main(["render", str(yaml), "--turntable", "--frames", "2", "--size", "64x48", "--out", str(gif)]) == 0
    assert iio.imread(gif, index=None).shape[:3] == (2, 48, 64)

    from morphkit.io import read_morphology

    m = read_morphology(yaml)
    q = np.repeat(m.rest_q()[None], 5, axis=0)
    q[:, 0] = np.linspace(0.0, 0.4, 5)  # moving: a GIF merges identical consecutive frames
    np.savez(tmp_path / "walk.npz", q=q, fps=np.float64(5.0))
    clip = tmp_path / "walk.gif"
    assert (
        main(["render", str(yaml), "--motion", str(tmp_path / "walk.npz"), "--size", "64x48", "--out", str(clip)]) == 0
    )
    assert iio.imread(clip, index=None).shape[0] == 5
    capsys.readouterr()
    walk = ["--motion", str(tmp_path / "walk.npz"), "--size", "32x24", "--no-shadows"]
    assert main(["render", str(yaml), *walk, "--frames", "1:4", "--follow", "--out", str(clip)]) == 0
    assert iio.imread(clip, index=None).shape[0] == 3
    assert "3 frames at 5 fps" in capsys.readouterr().out
    from morphkit.motion import Motion, write_motion

    long = np.repeat(m.rest_q()[None], 20, axis=0)
    long[:, 0] = np.linspace(0.0, 1.0, 20)
    write_motion(Motion(m, 10.0, long, "long"), tmp_path / "long.npz")  # 2 s beside the creature's 1 s
    compare = [*walk, "--compare", str(tmp_path / "long.npz"), "--out", str(clip)]
    for extra, frames in (([], 10), (["--until-longer"], 20), (["--frames", "2:"], 6)):
        # at the human's 10 fps: 1 s (the shorter), 2 s (the longer), the creature's frames 2..4 (0.6 s)
        assert main(["render", str(yaml), *compare, *extra]) == 0
        assert iio.imread(clip, index=None).shape[0] == frames

    assert main(["render", str(yaml), "--size", "64by48", "--out", str(tmp_path / "x.gif")]) == 2
    assert "--size" in capsys.readouterr().err
    assert main(["render", str(yaml), "--contact-sheet", "--out", str(tmp_path / "x.gif")]) == 2
    assert main(["render", str(yaml), "--out", str(tmp_path / "x.webp")]) == 2
    np.savez(tmp_path / "bad.npz", q=q[:, :3], fps=np.float64(5.0))
    assert main(["render", str(yaml), "--motion", str(tmp_path / "bad.npz"), "--out", str(tmp_path / "b.gif")]) == 2
    err = capsys.readouterr().err
    assert "bad.npz" in err and err.count("\n") <= 3
    assert not (tmp_path / "x.gif").exists() and not (tmp_path / "b.gif").exists()


@pytest.mark.skipif(not os.environ.get("MORPHKIT_DATA"), reason="MORPHKIT_DATA is not set")
def test_cli_compare_human_bvh_with_creature(gl, tmp_path):
    """`--compare` shows a real human BVH clip beside a creature clip, in sync."""
    import imageio.v3 as iio

    from morphkit.cli import main

    clips = sorted(Path(os.environ["MORPHKIT_DATA"]).glob("human/**/*.bvh"))
    if not clips:
        pytest.skip("no BVH clips under MORPHKIT_DATA/human")
    from morphkit.motion import read_motion

    human = read_motion(clips[0])
    human = type(human)(human.morphology, human.fps, human.q[: int(human.fps)], name="h")  # first second
    from morphkit.motion import write_motion

    write_motion(human, tmp_path / "human.npz")
    m = quadruped()
    from morphkit.io import write_morphology

    write_morphology(m, tmp_path / "quad.yaml")
    q = np.repeat(m.rest_q()[None], 10, axis=0)
    q[:, 7] = np.linspace(-0.5, 0.5, 10)
    np.savez(tmp_path / "quad.npz", q=q, fps=np.float64(10.0))
    out = tmp_path / "cmp.gif"
    args = [
        "render",
        str(tmp_path / "quad.yaml"),
        "--motion",
        str(tmp_path / "quad.npz"),
        "--compare",
        str(tmp_path / "human.npz"),
        "--size",
        "64x48",
        "--fps",
        "10",
        "--out",
        str(out),
    ]
    assert main(args) == 0
    frames = iio.imread(out, index=None)
    assert frames.shape[0] == 10 and frames.shape[2] == 2 * 64 + 3
