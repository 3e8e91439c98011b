"""Offscreen rendering speed: frames/s of a Spot turntable at 640x480, with and without shadows.

Run: ``python benchmarks/render.py [--frames 72] [--size 640x480] [--creature spot]``.
Targets (issue 5): ≥ 10 frames/s with shadows and ≥ 15 without, on 2 CPU cores with Mesa's
software rasteriser (llvmpipe). Scene building and framing are excluded: the timed loop is
camera move + draw + read-back, which is what every further frame of a video costs.
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


def bench(m, *, shadows: bool, frames: int, size: tuple[int, int]) -> float:
    """Frames/s of a turntable of ``m`` (after two warm-up frames)."""
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
        t0 = time.perf_counter()
        for k in range(frames):
            scene.set_camera(target, dist, 360.0 * k / frames, aspect)
            scene.render(renderer)
        return frames / (time.perf_counter() - t0)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--creature", default="spot")
    p.add_argument("--frames", type=int, default=72)
    p.add_argument("--size", default="640x480")
    args = p.parse_args()
    size = tuple(int(v) for v in args.size.lower().split("x"))
    platform = select_platform()
    m = read_morphology(resolve_morphology(args.creature))
    from OpenGL import GL

    with offscreen_renderer(8, 8):
        gl = GL.glGetString(GL.GL_RENDERER).decode()
    print(f"{m.name}: {m.link_count} links, {args.size}, platform {platform} ({gl}), {os.cpu_count()} CPUs")
    for shadows in (True, False):
        fps = bench(m, shadows=shadows, frames=args.frames, size=size)  # type: ignore[arg-type]
        target = 10 if shadows else 15
        print(f"  shadows {'on ' if shadows else 'off'}: {fps:6.1f} frames/s (target ≥ {target})")


if __name__ == "__main__":
    main()
