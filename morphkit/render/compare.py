"""Side-by-side videos: several motions (e.g. human | retargeted creature) in sync, with labels."""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.errors import ConfigError
from morphkit.render._gl import offscreen_renderer
from morphkit.render._pose import link_poses
from morphkit.render.scene import CreatureScene, RenderStyle, check_size
from morphkit.render.sheet import contact_sheet, draw_label, sample_indices, write_image
from morphkit.render.video import SHEET_FRAMES, MotionFraming, check_output, progress_bar, unpack_motion, write_frames

__all__ = ["iter_side_by_side_frames", "render_side_by_side", "side_by_side_frames", "sync_indices"]

_DIVIDER = 3
"""Width of the grey line between panels [px]."""


def sync_indices(
    frame_counts: Sequence[int], fps: Sequence[float], out_fps: float, *, until_longer: bool = False
) -> np.ndarray:
    """Frame of each clip shown at each output frame, shape [T_out, clips].

    Clips are aligned at their first frame and sampled at the same time ``t = k / out_fps``
    (nearest earlier frame). The output ends with the shortest clip, or with ``until_longer`` lasts
    as long as the longest clip while shorter ones hold their last frame.
    """
    durations = [n / f for n, f in zip(frame_counts, fps, strict=True)]
    duration = max(durations) if until_longer else min(durations)
    count = max(1, math.ceil(duration * out_fps - 1e-9))
    t = np.arange(count) / out_fps
    cols = [np.minimum(np.floor(t * f + 1e-9).astype(int), n - 1) for n, f in zip(frame_counts, fps, strict=True)]
    return np.stack(cols, axis=1)


def iter_side_by_side_frames(
    motions: Sequence[Any],
    *,
    labels: Sequence[str] | None = None,
    size: tuple[int, int] = (480, 480),
    style: RenderStyle | None = None,
    fps: float | None = None,
    follow: bool = True,
    follow_heading: bool = False,
    until_longer: bool = False,
    frame_indices: Sequence[int] | None = None,
    progress: bool | None = None,
) -> Iterator[np.ndarray]:
    """Yield frames showing ``motions`` side by side, in sync (aligned at their first frames), each panel
    labelled; the output ends with the shortest clip unless ``until_longer``.

    Args:
        motions: Motion objects (``.morphology``, ``.q``, ``.fps``) or ``(morphology, q, fps)`` tuples,
            left to right (e.g. human then creature).
        labels: One caption per panel; the creatures' names when omitted.
        size: Size of each panel ``(width, height)`` [px]; frames are ``n·width + dividers`` wide.
        style: Drawing options, shared by all panels (each panel frames its own creature).
        fps: Output rate [frames/s]; the first motion's when omitted.
        follow: Each panel's camera follows its root.
        follow_heading: Each panel's camera turns with its creature's heading (``style``'s azimuth is then
            relative to the creature's front; see :class:`~morphkit.render.video.MotionFraming`).
        until_longer: Play until the longest clip ends, shorter ones holding their last frame.
        frame_indices: Render only these output frames.
        progress: Progress bar on stderr; by default only for long renders on a terminal.
    """
    clips, _, sync = _prepare(motions, fps, until_longer)
    if labels is None:
        labels = [m.name for m, _, _ in clips]
    if len(labels) != len(clips):
        raise ConfigError(f"{len(labels)} labels for {len(clips)} motions")
    width, height = check_size(size)
    style = style or RenderStyle()
    panels = []
    for m, q, f in clips:
        poses = link_poses(m, q)
        scene = CreatureScene(m, style=style)
        framing = MotionFraming(scene, poses, f, width / height, follow=follow, follow_heading=follow_heading)
        panels.append((scene, poses, framing))
    idx = np.arange(len(sync)) if frame_indices is None else np.asarray(frame_indices, dtype=int)
    divider = np.full((height, _DIVIDER, 3), 160, dtype=np.uint8)
    with offscreen_renderer(width, height) as renderer:
        for k in progress_bar(idx, total=len(idx), desc="side by side", enabled=progress):
            images = []
            for c, (scene, poses, framing) in enumerate(panels):
                t = sync[k, c]
                scene.set_link_poses(poses[t])
                scene.place_ground(
                    framing.targets[t, :2], framing.ground_z, framing.ground_radius, slack=framing.ground_slack
                )
                scene.set_camera(framing.targets[t], framing.distance, framing.azimuths[t], width / height)
                images.append(draw_label(scene.render(renderer), labels[c]))
                images.append(divider)
            yield np.concatenate(images[:-1], axis=1)


def side_by_side_frames(motions: Sequence[Any], **kwargs: Any) -> np.ndarray:
    """All frames of :func:`iter_side_by_side_frames` (same arguments), shape [T, H, W, 3] uint8."""
    return np.stack(list(iter_side_by_side_frames(motions, **kwargs)))


def render_side_by_side(
    left: Any,
    right: Any,
    *,
    out: str | os.PathLike[str],
    labels: Sequence[str] = ("human", "creature"),
    size: tuple[int, int] = (480, 480),
    style: RenderStyle | None = None,
    fps: float | None = None,
    follow: bool = True,
    follow_heading: bool = False,
    until_longer: bool = False,
    progress: bool | None = None,
) -> Path:
    """Render ``left`` | ``right`` (e.g. a human clip and its retargeted creature clip) to ``out``.

    Both play in sync at ``fps`` (the left clip's by default) until the shorter ends (the longer with
    ``until_longer``). The suffix picks the format as in :func:`~morphkit.render.video.write_frames`; a
    ``.png`` is a contact sheet of synced frames. Other arguments as :func:`iter_side_by_side_frames`.
    An output that cannot be written is refused before anything is drawn.
    """
    _, out_fps, sync = _prepare([left, right], fps, until_longer)
    check_output(out)
    kw: dict[str, Any] = {"labels": labels, "size": size, "style": style, "fps": fps, "follow": follow,
                          "follow_heading": follow_heading, "until_longer": until_longer}
    if Path(out).suffix.lower() == ".png":
        idx = sample_indices(len(sync), SHEET_FRAMES)
        frames = list(iter_side_by_side_frames([left, right], frame_indices=idx, progress=progress, **kw))
        captions = [f"t = {i / out_fps:.2f} s" for i in idx]
        return write_image(contact_sheet(frames, columns=2, labels=captions), out)
    return write_frames(iter_side_by_side_frames([left, right], progress=progress, **kw), out, fps=out_fps)


def _prepare(
    motions: Sequence[Any], fps: float | None, until_longer: bool
) -> tuple[list[tuple[Any, np.ndarray, float]], float, np.ndarray]:
    """Unpacked clips, the output rate and the sync table of :func:`sync_indices`."""
    if not motions:
        raise ConfigError("side by side needs at least one motion")
    clips = [unpack_motion(*mo) if isinstance(mo, tuple) else unpack_motion(mo) for mo in motions]
    out_fps = float(fps) if fps is not None else clips[0][2]
    if not (np.isfinite(out_fps) and out_fps > 0):
        raise ConfigError(f"fps must be positive, got {fps}")
    sync = sync_indices([len(q) for _, q, _ in clips], [f for _, _, f in clips], out_fps, until_longer=until_longer)
    return clips, out_fps, sync
