"""Turntables: a 360° camera orbit around a creature at rest or at a given pose."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from morphkit.errors import ConfigError
from morphkit.graph import Morphology
from morphkit.render._gl import offscreen_renderer
from morphkit.render._pose import link_poses
from morphkit.render.scene import CreatureScene, RenderStyle, check_size, fit_distance
from morphkit.render.video import check_output, progress_bar, write_frames

__all__ = ["iter_turntable_frames", "turntable", "turntable_frames"]


def iter_turntable_frames(
    m: Morphology,
    *,
    q: np.ndarray | None = None,
    frames: int = 72,
    size: tuple[int, int] = (640, 480),
    style: RenderStyle | None = None,
    start_deg: float | None = None,
    progress: bool | None = None,
) -> Iterator[np.ndarray]:
    """Yield the frames of a turntable, each RGB uint8 [H, W, 3].

    Frame ``k`` looks from azimuth ``start_deg + 360 k / frames`` [deg] (0 = the creature's front,
    90 = its left); the distance is fixed for the whole orbit, fitted so the creature stays in view
    at every angle. The creature stands on the ground: the plane touches its lowest point.

    Args:
        m: The creature.
        q: A pose [coordinate_count]; the rest pose (:meth:`Morphology.rest_q`) when omitted.
        frames: Number of views over the full circle.
        size: Image ``(width, height)`` [px].
        style: Drawing options (shadows, ground, markers, elevation, field of view).
        start_deg: Azimuth of the first frame [deg]; ``style.azimuth_deg`` when omitted.
        progress: Show a progress bar on stderr; by default only for long renders on a terminal.
    """
    if frames < 1:
        raise ConfigError(f"a turntable needs at least one frame, got {frames}")
    width, height = check_size(size)
    style = style or RenderStyle()
    poses = link_poses(m, m.rest_q() if q is None else q)[0]
    scene = CreatureScene(m, style=style)
    scene.set_link_poses(poses)
    start = style.azimuth_deg if start_deg is None else float(start_deg)
    azimuths = start + 360.0 * np.arange(frames) / frames

    points = scene.world_points(poses)
    lo, hi = points.min(axis=0), points.max(axis=0)
    target = (lo + hi) / 2
    aspect = width / height
    # One distance for the whole orbit (no zooming): the largest any view needs, checked every 10°.
    probe = np.concatenate([azimuths, start + np.arange(0.0, 360.0, 10.0)])
    distance = max(
        fit_distance(
            points - target, az, style.elevation_deg, yfov_deg=style.yfov_deg, aspect=aspect, margin=style.margin
        )
        for az in probe
    )
    reach = float(np.linalg.norm(points[:, :2] - target[:2], axis=1).max())
    scene.place_ground(target[:2], float(lo[2]), scene.ground_radius(reach, float(hi[2] - lo[2])))

    with offscreen_renderer(width, height) as renderer:
        for az in progress_bar(azimuths, total=frames, desc="turntable", enabled=progress):
            scene.set_camera(target, distance, float(az), aspect)
            yield scene.render(renderer)


def turntable_frames(m: Morphology, **kwargs: object) -> np.ndarray:
    """All frames of :func:`iter_turntable_frames` (same arguments), shape [frames, H, W, 3] uint8."""
    return np.stack(list(iter_turntable_frames(m, **kwargs)))  # type: ignore[arg-type]


def turntable(
    m: Morphology,
    out: str | os.PathLike[str],
    *,
    q: np.ndarray | None = None,
    frames: int = 72,
    fps: float = 24.0,
    size: tuple[int, int] = (640, 480),
    style: RenderStyle | None = None,
    start_deg: float | None = None,
    progress: bool | None = None,
) -> Path:
    """Render a turntable of ``m`` to ``out`` and return the path.

    The format follows the suffix: ``.gif`` (always available), ``.mp4`` (needs ffmpeg, e.g. the
    ``imageio-ffmpeg`` package), ``.png`` (one frame: a still; several: a contact sheet). The file
    is written atomically; one that cannot be written is refused before anything is drawn. Other
    arguments as :func:`iter_turntable_frames`; ``fps`` is the playback rate of videos [frames/s].
    """
    check_output(out)
    it = iter_turntable_frames(m, q=q, frames=frames, size=size, style=style, start_deg=start_deg, progress=progress)
    labels = [f"{(i * 360.0 / frames):.0f}°" for i in range(frames)]
    return write_frames(it, out, fps=fps, labels=labels if frames > 1 else None)
