"""Offscreen rendering speed: frames/s of a Spot turntable at 640x480, with and without shadows.

Run: ``python benchmarks/render.py [--frames 72] [--size 640x480] [--creature spot]``.
Targets (issue 5): ≥ 10 frames/s with shadows and ≥ 15 without, on 2 CPU cores with Mesa's
software rasteriser (llvmpipe). Scene building and framing are excluded: the timed loop is
camera move + draw + read-back, which is what every further frame of a video costs. Each line
also times issue 5's yardstick scene (30 capsules on a ground box, one shadowed light) and gives
CPU time per frame, so a run on a busy machine can still be read relatively.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from morphkit.io import read_morphology
from morphkit.io.shipped import resolve_morphology
from morphkit.render import CreatureScene, RenderStyle, select_platform
from morphkit.render._gl import offscreen_renderer
from morphkit.render._pose import link_poses
from morphkit.render.scene import fit_distance


def bench(m, *, shadows: bool, frames: int, size: tuple[int, int]) -> tuple[float, float]:
    """Frames/s of a turntable of ``m`` (after two warm-up frames) and CPU time per frame [ms]."""
    style = RenderStyle(shadows=shadows)
    scene = CreatureScene(m, style=style)
    poses = link_poses(m, m.rest_q())[0]
    scene.set_link_poses(poses)
    pts = scene.world_points(poses)
    target = (pts.min(0) + pts.max(0)) / 2
    aspect = size[0] / size[1]
    dist = max(
        fit_distance(pts - target, a, style.elevation_deg, yfov_deg=style.yfov_deg, aspect=aspect, margin=style.margin)
        for a in range(0, 360, 30)
    )
    reach = float(np.linalg.norm(pts[:, :2] - target[:2], axis=1).max())
    scene.place_ground(target[:2], float(pts[:, 2].min()), scene.ground_radius(reach, float(np.ptp(pts[:, 2]))))
    with offscreen_renderer(*size) as renderer:
        for az in (0.0, 5.0):  # warm-up: shader compilation, shadow-map allocation
            scene.set_camera(target, dist, az, aspect)
            scene.render(renderer)
        t0, c0 = time.perf_counter(), time.process_time()
        for k in range(frames):
            scene.set_camera(target, dist, 360.0 * k / frames, aspect)
            scene.render(renderer)
        return frames / (time.perf_counter() - t0), 1000 * (time.process_time() - c0) / frames


def bench_reference(*, shadows: bool, frames: int, size: tuple[int, int]) -> tuple[float, float]:
    """Frames/s of issue 5's yardstick: 30 capsules over a 10 m ground box, one directional light.

    Printed beside Spot's figures so a run on a busy or different machine can be read relatively.
    """
    import trimesh

    from morphkit.render._gl import import_pyrender
    from morphkit.render.scene import look_at

    pyrender = import_pyrender()
    scene = pyrender.Scene(bg_color=[1, 1, 1, 1], ambient_light=[0.3, 0.3, 0.3])
    material = pyrender.MetallicRoughnessMaterial(baseColorFactor=[0.8, 0.3, 0.2, 1.0])
    for i in range(30):
        T = np.eye(4)
        T[:3, 3] = [np.cos(i) * 0.5, np.sin(i) * 0.5, 0.3]
        capsule = trimesh.creation.capsule(height=0.3, radius=0.04, count=[16, 16])
        scene.add(pyrender.Mesh.from_trimesh(capsule, material=material), pose=T)
    scene.add(pyrender.Mesh.from_trimesh(trimesh.creation.box([10, 10, 0.01])))
    camera = scene.add(pyrender.PerspectiveCamera(yfov=0.8, aspectRatio=size[0] / size[1]))
    scene.add(pyrender.DirectionalLight(intensity=3.0), pose=look_at(np.array([1.0, 1.0, 3.0]), np.zeros(3)))
    flags = pyrender.RenderFlags.SHADOWS_DIRECTIONAL if shadows else pyrender.RenderFlags.NONE
    with offscreen_renderer(*size) as renderer:
        for k in range(frames + 2):
            if k == 2:  # after two warm-up frames
                t0, c0 = time.perf_counter(), time.process_time()
            a = 2 * np.pi * k / frames
            scene.set_pose(camera, look_at(np.array([2.8 * np.cos(a), 2.8 * np.sin(a), 1.5]), np.zeros(3)))
            renderer.render(scene, flags=flags)
        return frames / (time.perf_counter() - t0), 1000 * (time.process_time() - c0) / frames


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--creature", default="spot")
    p.add_argument("--frames", type=int, default=72)
    p.add_argument("--size", default="640x480")
    p.add_argument("--repeats", type=int, default=2, help="alternate Spot and the reference this often; best of each")
    args = p.parse_args()
    size = tuple(int(v) for v in args.size.lower().split("x"))
    platform = select_platform()
    m = read_morphology(resolve_morphology(args.creature))
    from OpenGL import GL

    with offscreen_renderer(8, 8):
        gl = GL.glGetString(GL.GL_RENDERER).decode()
    print(f"{m.name}: {m.link_count} links, {args.size}, platform {platform} ({gl}), {os.cpu_count()} CPUs")
    for shadows in (True, False):
        runs, ref_runs = [], []
        for _ in range(max(1, args.repeats)):  # interleaved, so both see the same machine load
            runs.append(bench(m, shadows=shadows, frames=args.frames, size=size))  # type: ignore[arg-type]
            ref_runs.append(bench_reference(shadows=shadows, frames=args.frames, size=size))  # type: ignore[arg-type]
        (fps, cpu), (ref, ref_cpu) = max(runs), max(ref_runs)
        target = 10 if shadows else 15
        print(
            f"  shadows {'on ' if shadows else 'off'}: {fps:5.1f} frames/s "
            f"(target ≥ {target}, CPU {cpu:.0f} ms/frame); "
            f"reference scene of 30 capsules: {ref:.1f} frames/s (CPU {ref_cpu:.0f} ms/frame)"
        )


if __name__ == "__main__":
    main()
