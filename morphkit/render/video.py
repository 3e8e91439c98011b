"""Motion videos (camera follows the root smoothly) and frame writers (GIF, MP4, PNG)."""

from __future__ import annotations

import contextlib
import errno
import itertools
import os
import re
import signal
import sys
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from morphkit._atomic import atomic_path, check_writable
from morphkit.errors import ConfigError, MotionFormatError
from morphkit.graph import Morphology
from morphkit.render._gl import offscreen_renderer
from morphkit.render._pose import as_q, link_poses
from morphkit.render.scene import CreatureScene, RenderStyle, check_size, fit_distance
from morphkit.render.sheet import contact_sheet, sample_indices, write_image
from morphkit.rotations import yaw_from_quat

__all__ = [
    "HEADING_SMOOTHING_S",
    "VIDEO_SUFFIXES",
    "MotionFraming",
    "camera_azimuths",
    "check_output",
    "ffmpeg_available",
    "iter_motion_frames",
    "motion_frames",
    "progress_bar",
    "render_motion",
    "unpack_motion",
    "write_frames",
]

VIDEO_SUFFIXES = (".gif", ".mp4", ".mov", ".mkv", ".webm", ".avi")
"""Suffixes :func:`write_frames` writes as animations (``.png`` writes a still or a contact sheet)."""

SHEET_FRAMES = 12
"""Frames on a contact sheet written for a ``.png`` output of a many-frame render."""


def progress_bar(iterable: Iterable[Any], *, total: int, desc: str, enabled: bool | None) -> Iterable[Any]:
    """Wrap ``iterable`` in a tqdm bar on stderr; ``enabled=None`` shows it for ≥ 24 frames on a terminal."""
    from tqdm.auto import tqdm

    if enabled is None:
        enabled = total >= 24 and sys.stderr.isatty()
    return tqdm(iterable, total=total, desc=desc, unit="frame", leave=False, disable=not enabled)


# ---- writers --------------------------------------------------------------------------------
def ffmpeg_available() -> bool:
    """Whether ``imageio-ffmpeg`` can find an ffmpeg executable (it ships one) to encode videos with."""
    try:
        import imageio_ffmpeg

        imageio_ffmpeg.get_ffmpeg_exe()
    except (ImportError, RuntimeError):
        return False
    return True


def _even(frame: np.ndarray) -> np.ndarray:
    # H.264 with yuv420p needs even sides: pad odd ones with a copied edge row/column.
    h, w = frame.shape[:2]
    if h % 2 or w % 2:
        frame = np.pad(frame, ((0, h % 2), (0, w % 2), (0, 0)), mode="edge")
    return frame


def write_frames(
    frames: Iterable[np.ndarray],
    out: str | os.PathLike[str],
    *,
    fps: float,
    labels: Sequence[str] | None = None,
) -> Path:
    """Write RGB uint8 frames [H, W, 3] to ``out`` atomically; the suffix picks the format.

    ``.gif`` always works (Pillow; identical consecutive frames are merged into one, their
    durations added, so a still clip plays as long but holds fewer frames);
    ``.mp4``/``.mov``/``.mkv``/``.avi`` (H.264) and ``.webm`` (VP9) need ffmpeg (``pip install
    imageio-ffmpeg``) and stream frames to it; ``.png`` writes a still for one
    frame and a contact sheet of up to 12 evenly spaced frames (captioned with ``labels``, one per
    frame, when given) for several.

    Args:
        frames: The frames, consumed once (a generator is fine).
        out: Target path.
        fps: Playback rate [frames/s].
        labels: Captions for contact-sheet tiles.

    Raises:
        ConfigError: Unknown suffix, no ffmpeg for a video suffix, or no frames.
        OSError: ``out`` cannot be written (checked before the first frame is drawn), or writing failed
            (a full disk, an encoder error): nothing is left at ``out``.
    """
    path = Path(out)
    suffix = path.suffix.lower()
    if not fps > 0:
        raise ConfigError(f"fps must be positive, got {fps}")
    check_output(path)

    if suffix == ".png":
        kept = list(frames)
        if not kept:
            raise ConfigError(f"cannot write {path}: no frames")
        if len(kept) == 1:
            return write_image(kept[0], path)
        idx = sample_indices(len(kept), SHEET_FRAMES)
        sheet_labels = [labels[i] for i in idx] if labels is not None else None
        return write_image(contact_sheet([kept[i] for i in idx], labels=sheet_labels), path)

    with atomic_path(path) as tmp:
        if suffix == ".gif":
            _write_gif(frames, tmp, path, fps=fps)
        else:
            _write_video(frames, tmp, path, fps=fps)
    return path


def _write_gif(frames: Iterable[np.ndarray], tmp: Path, path: Path, *, fps: float) -> None:
    """Write an animated GIF with Pillow (a failed write raises at once; imageio's plugin would retry
    it from a destructor and print a second traceback)."""
    from PIL import Image

    # Pillow's GIF writer takes a whole clip; GIF clips are short by nature.
    images = [Image.fromarray(np.ascontiguousarray(f, dtype=np.uint8)) for f in frames]
    if not images:
        raise ConfigError(f"cannot write {path}: no frames")
    images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:], duration=1000.0 / fps, loop=0)


_CODECS = {".webm": ["-c:v", "libvpx-vp9", "-crf", "20", "-b:v", "0", "-row-mt", "1", "-cpu-used", "5"]}
"""ffmpeg encoder options by suffix (WebM holds only VP8/VP9/AV1); every other video is H.264."""
_H264 = ["-c:v", "libx264", "-crf", "10"]


def _write_video(frames: Iterable[np.ndarray], tmp: Path, path: Path, *, fps: float) -> None:
    """Stream frames to ffmpeg (imageio-ffmpeg's binary) writing ``tmp``; raise unless it succeeded.

    imageio's writer ignores ffmpeg's exit status, so a video whose trailer could not be written (a
    full disk) read as written; here any failure is an ``OSError`` naming ``path`` with ffmpeg's reason.
    """
    import subprocess
    import threading
    from fractions import Fraction

    import imageio_ffmpeg

    it = iter(frames)
    first = next(it, None)
    if first is None:
        raise ConfigError(f"cannot write {path}: no frames")
    shape = _even(np.asarray(first)).shape
    cmd = [
        imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-hide_banner", "-loglevel", "error",
        "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{shape[1]}x{shape[0]}",
        "-r", str(Fraction(fps).limit_denominator(1001)), "-i", "-", "-an",
        *_CODECS.get(path.suffix.lower(), _H264), "-pix_fmt", "yuv420p", os.fspath(tmp),
    ]
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    log: list[bytes] = []
    # ffmpeg's messages are drained on a thread: a full stderr pipe would stall it while we write frames.
    reader = threading.Thread(target=lambda: log.append(proc.stderr.read()), daemon=True)  # type: ignore[union-attr]
    reader.start()
    try:
        try:
            for frame in itertools.chain([first], it):
                f = _even(np.ascontiguousarray(frame, dtype=np.uint8))
                if f.shape != shape:
                    raise ConfigError(f"cannot write {path}: frames of sizes {shape} and {f.shape}")
                proc.stdin.write(f.tobytes())  # type: ignore[union-attr]
        except BrokenPipeError:
            pass  # ffmpeg quit early: its exit status and messages below say why
        finally:
            with contextlib.suppress(BrokenPipeError):
                proc.stdin.close()  # type: ignore[union-attr]
        code = proc.wait()
    except BaseException:
        proc.kill()
        proc.wait()
        raise
    finally:
        reader.join()
    if code != 0:
        reason = _ffmpeg_reason(b"".join(log), code).replace(os.fspath(tmp), os.fspath(path))
        raise OSError(errno.EIO, f"ffmpeg could not write the video: {reason}", os.fspath(path))


def _ffmpeg_reason(log: bytes, code: int) -> str:
    """ffmpeg's first error line, without its ``[muxer @ 0x...]`` prefix (else its signal or exit status)."""
    for line in log.decode(errors="replace").splitlines():
        line = re.sub(r"^\s*(\[[^]]*\]\s*)+", "", line).strip()
        if line and not line.startswith("Last message repeated"):
            return line[:200]
    if code < 0:  # killed by a signal: SIGXFSZ where a file-size limit stands in for a full disk
        return signal.strsignal(-code) or f"signal {-code}"
    return f"exit status {code}"


def check_output(out: str | os.PathLike[str]) -> None:
    """Refuse an output the writers cannot write, before anything is drawn.

    Raises:
        ConfigError: Unknown suffix, or a video suffix without ffmpeg.
        OSError: ``out`` is a folder or its folder is not writable
            (:func:`~morphkit._atomic.check_writable`).
    """
    path = Path(out)
    check_writable(path)
    suffix = path.suffix.lower()
    if suffix not in (*VIDEO_SUFFIXES, ".png"):
        raise ConfigError(f"cannot write {path}: unknown output type {suffix!r}; use .gif, .mp4 or .png")
    if suffix not in (".gif", ".png") and not ffmpeg_available():
        raise ConfigError(
            f"cannot write {path}: {suffix} needs ffmpeg (pip install imageio-ffmpeg, or install "
            "morphkit[render]); write a .gif instead"
        )


# ---- motions --------------------------------------------------------------------------------
def unpack_motion(motion: Any, q: Any = None, fps: float | None = None) -> tuple[Morphology, np.ndarray, float]:
    """``(morphology, q [T, coordinate_count], fps)`` from a Morphology plus ``q`` and ``fps``, or
    from a motion object with ``.morphology``, ``.q`` and ``.fps`` (explicit ``q``/``fps`` win).

    Raises:
        MotionFormatError: Missing or malformed ``q``/``fps``.
    """
    if isinstance(motion, Morphology):
        m = motion
    elif hasattr(motion, "morphology") and hasattr(motion, "q"):
        m = motion.morphology
        q = motion.q if q is None else q
        fps = getattr(motion, "fps", None) if fps is None else fps
    else:
        raise MotionFormatError(
            "expected a Morphology (with q and fps) or a motion with .morphology, .q, .fps; "
            f"got {type(motion).__name__}"
        )
    if q is None:
        raise MotionFormatError(f"no coordinates given for {m.name!r}: pass q [frames, {m.coordinate_count}]")
    if fps is None or not np.isfinite(fps) or float(fps) <= 0:
        raise MotionFormatError(f"fps must be a positive number, got {fps!r}")
    return m, as_q(m, q), float(fps)


def _smooth(x: np.ndarray, sigma: float) -> np.ndarray:
    """Zero-phase Gaussian smoothing along axis 0 (edges reflected); ``sigma`` in samples."""
    if sigma <= 0 or len(x) < 2:
        return x.copy()
    radius = int(np.ceil(3 * sigma))
    k = np.exp(-0.5 * (np.arange(-radius, radius + 1) / sigma) ** 2)
    k /= k.sum()
    padded = np.pad(x, [(radius, radius)] + [(0, 0)] * (x.ndim - 1), mode="reflect" if len(x) > radius else "edge")
    return np.stack([np.convolve(padded[:, i], k, mode="valid") for i in range(x.shape[1])], axis=1)


HEADING_SMOOTHING_S = 1.0
"""σ [s] of the Gaussian smoothing of the heading a following camera turns with: it takes a creature's
turns but not the sway of each step."""


def camera_azimuths(poses: np.ndarray, fps: float, azimuth_deg: float, *, follow_heading: bool) -> np.ndarray:
    """Camera azimuth [deg] per frame, shape [T]: ``azimuth_deg`` in the world, or with ``follow_heading``
    relative to the root's heading (its +x on the ground; unwrapped, smoothed with σ =
    :data:`HEADING_SMOOTHING_S`), so 90 keeps looking at the creature's left side while it turns."""
    count = len(poses)
    if not follow_heading:
        return np.full(count, float(azimuth_deg))
    yaw = np.unwrap(np.asarray(yaw_from_quat(np.asarray(poses[:, 0, 3:7], dtype=float)), dtype=float))
    yaw = _smooth(yaw[:, None], HEADING_SMOOTHING_S * fps)[:, 0]
    return float(azimuth_deg) + np.degrees(yaw)


def _rotate_z(points: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """``points`` [T, N, 3] turned about z by ``-angles`` [T] [rad] (world into a frame turned by ``angles``)."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    x, y = points[..., 0], points[..., 1]
    return np.stack([c * x + s * y, -s * x + c * y, points[..., 2]], axis=-1)


class MotionFraming:
    """Camera targets, azimuths, distance and ground for a clip: the target follows the root, and the
    view direction is fixed in the world or turns with the creature's heading.

    Args:
        scene: The creature's scene (gives the framing points).
        poses: Link poses of every frame, shape [T, link_count, 7].
        fps: Frame rate [frames/s] (sets the smoothing window).
        aspect: Image width / height.
        follow: Follow the root (smoothed, σ = 0.5 s); otherwise one fixed view of the whole clip.
        follow_heading: Turn the camera with the creature's heading (:func:`camera_azimuths`): the
            style's azimuth is then relative to the creature's front.
    """

    def __init__(
        self,
        scene: CreatureScene,
        poses: np.ndarray,
        fps: float,
        aspect: float,
        *,
        follow: bool = True,
        follow_heading: bool = False,
    ):
        style = scene.style
        self.azimuths = camera_azimuths(poses, fps, style.azimuth_deg, follow_heading=follow_heading)
        """Camera azimuth of each frame [deg], shape [T]."""
        stride = max(1, len(poses) // 240)  # framing from ≤ ~240 frames is plenty and keeps long clips cheap
        points = scene.world_points(poses)  # [T, N, 3]
        lo, hi = points.min(axis=1), points.max(axis=1)
        centers = (lo + hi) / 2
        root = np.asarray(poses[:, 0, :3], dtype=float)
        turn = np.radians(self.azimuths - style.azimuth_deg)  # how far the camera has turned [rad]
        if follow:
            # The box centre sits at a steady offset from the root (in the camera's turning frame); the
            # root's path is smoothed so the camera glides instead of shaking with every step.
            offset = np.median(_rotate_z((centers - root)[:, None], turn)[:, 0], axis=0)
            offsets = _rotate_z(np.broadcast_to(offset, root.shape)[:, None], -turn)[:, 0]
            self.targets = _smooth(root, 0.5 * fps) + offsets
            self.targets[:, 2] = float(np.median(centers[:, 2]))
        else:
            c = (lo.min(axis=0) + hi.max(axis=0)) / 2
            self.targets = np.repeat(c[None], len(poses), axis=0)
        rel = (points - self.targets[:, None])[::stride]
        # Framing in the camera's turning frame: one distance fits every frame's view.
        rel = _rotate_z(rel, turn[::stride]).reshape(-1, 3)
        self.distance = fit_distance(
            rel, style.azimuth_deg, style.elevation_deg, yfov_deg=style.yfov_deg, aspect=aspect, margin=style.margin
        )
        self.ground_z = float(lo[:, 2].min())
        reach = float(np.linalg.norm(rel[:, :2], axis=1).max())
        radius = scene.ground_radius(reach, float((hi[:, 2] - lo[:, 2]).max()))
        travel = float(np.ptp(self.targets[:, :2], axis=0).max())
        # A clip that travels gets a disc with room to stay put while the creature crosses part of it.
        self.ground_slack = min(0.3 * radius, travel)
        """How far [m] the camera target may drift before the ground disc moves under it again."""
        self.ground_radius = radius + self.ground_slack
        """Radius of the ground disc [m]."""


def iter_motion_frames(
    motion: Any,
    q: Any = None,
    fps: float | None = None,
    *,
    size: tuple[int, int] = (640, 480),
    style: RenderStyle | None = None,
    follow: bool = True,
    follow_heading: bool = False,
    frame_indices: Sequence[int] | None = None,
    progress: bool | None = None,
) -> Iterator[np.ndarray]:
    """Yield the frames of a motion, each RGB uint8 [H, W, 3].

    The camera keeps ``style``'s elevation and azimuth (in the world, or relative to the creature's
    heading with ``follow_heading``) and follows the root smoothly; the ground lies under the clip's
    lowest point.

    Args:
        motion: A Morphology (then ``q`` and ``fps`` are needed) or an object with ``.morphology``,
            ``.q`` [T, coordinate_count] and ``.fps``.
        q: Coordinates per frame [T, coordinate_count].
        fps: Frame rate [frames/s].
        size: Image ``(width, height)`` [px].
        style: Drawing options.
        follow: Follow the root; otherwise one fixed view framing the whole clip.
        follow_heading: Turn the camera with the creature's heading, smoothed (see :class:`MotionFraming`).
        frame_indices: Render only these frames (framing still uses the whole clip).
        progress: Progress bar on stderr; by default only for long renders on a terminal.
    """
    m, q_arr, fps_f = unpack_motion(motion, q, fps)
    width, height = check_size(size)
    style = style or RenderStyle()
    poses = link_poses(m, q_arr)
    scene = CreatureScene(m, style=style)
    framing = MotionFraming(scene, poses, fps_f, width / height, follow=follow, follow_heading=follow_heading)
    idx = np.arange(len(poses)) if frame_indices is None else np.asarray(frame_indices, dtype=int)
    if idx.size and (idx.min() < 0 or idx.max() >= len(poses)):
        raise ConfigError(f"frame indices must lie in [0, {len(poses)}), got {idx.min()}..{idx.max()}")
    with offscreen_renderer(width, height) as renderer:
        for t in progress_bar(idx, total=len(idx), desc=f"render {m.name}", enabled=progress):
            scene.set_link_poses(poses[t])
            scene.place_ground(
                framing.targets[t, :2], framing.ground_z, framing.ground_radius, slack=framing.ground_slack
            )
            scene.set_camera(framing.targets[t], framing.distance, framing.azimuths[t], width / height)
            yield scene.render(renderer)


def motion_frames(motion: Any, q: Any = None, fps: float | None = None, **kwargs: Any) -> np.ndarray:
    """All frames of :func:`iter_motion_frames` (same arguments), shape [T, H, W, 3] uint8."""
    return np.stack(list(iter_motion_frames(motion, q, fps, **kwargs)))


def render_motion(
    motion: Any,
    q: Any = None,
    fps: float | None = None,
    *,
    out: str | os.PathLike[str],
    size: tuple[int, int] = (640, 480),
    style: RenderStyle | None = None,
    follow: bool = True,
    follow_heading: bool = False,
    progress: bool | None = None,
) -> Path:
    """Render a motion to ``out`` (``.gif``, ``.mp4``, or ``.png`` contact sheet) and return the path.

    Arguments as :func:`iter_motion_frames`; videos play at the motion's ``fps``. For a ``.png``
    only the contact sheet's frames are rendered. An output that cannot be written is refused before
    anything is drawn (:func:`check_output`).
    """
    m, q_arr, fps_f = unpack_motion(motion, q, fps)
    check_output(out)
    kw: dict[str, Any] = {"size": size, "style": style, "follow": follow, "follow_heading": follow_heading}
    if Path(out).suffix.lower() == ".png" and len(q_arr) > 1:
        idx = sample_indices(len(q_arr), SHEET_FRAMES)
        frames = list(iter_motion_frames(m, q_arr, fps_f, frame_indices=idx, progress=progress, **kw))
        return write_image(contact_sheet(frames, labels=[f"t = {i / fps_f:.2f} s" for i in idx]), out)
    return write_frames(iter_motion_frames(m, q_arr, fps_f, progress=progress, **kw), out, fps=fps_f)
