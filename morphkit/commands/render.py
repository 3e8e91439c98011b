"""``morphkit render CREATURE``: turntables, motion videos, side-by-side comparisons and contact sheets.

Examples::

    morphkit render spot --turntable --frames 72 --out spot.gif
    morphkit render spot --motion walk.npz --out walk.mp4
    morphkit render spot --motion walk.npz --frames 60:180 --follow --azimuth 90 --out side.mp4
    morphkit render spot --motion walk.npz --compare human_walk.bvh --out compare.mp4
    morphkit render crab --turntable --contact-sheet --out crab.png
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.commands import _args
from morphkit.errors import ConfigError, MotionFormatError, SourceLocation


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "render",
        help="render a creature offscreen: turntable, motion video, side by side with a human, contact sheet",
        description=(
            "Render a creature offscreen (EGL or OSMesa; no display needed). Without --motion, a turntable "
            "(360° orbit) at the rest pose. The output suffix picks the format: .gif, .mp4 (needs ffmpeg), "
            ".png (a still of a turntable's first view, or a contact sheet of a motion)."
        ),
    )
    p.add_argument("creature", metavar="CREATURE", help="description file (.yaml/.urdf/.usd[a|c]/.bvh) or shipped name")
    mode = p.add_mutually_exclusive_group()
    mode.add_argument("--turntable", action="store_true", help="orbit the camera around the creature (default)")
    mode.add_argument(
        "--motion", metavar="M", help="motion to play: .npz (morphkit motion, or arrays q [T, C] and fps), .bvh, .usd"
    )
    p.add_argument(
        "--compare", metavar="HUMAN_MOTION",
        help="with --motion: show this (human) motion on the left, aligned by time; ends with the shorter clip",
    )
    p.add_argument("--until-longer", action="store_true",
                   help="with --compare: play until the longer clip ends (the shorter holds its last frame)")
    p.add_argument(
        "--frames", default=None, metavar="N | A:B",
        help="turntable: N views over 360° (default: 72); --motion: frames A to B-1 of the clip (A:, :B and N, "
        "the first N, too; with --compare the human clip shows the same time span)",
    )
    p.add_argument(
        "--fps", type=_args.fps, default=None,
        help="output frame rate, 1 to 1000 (default: 24 for turntables, else the motion's)"
    )
    p.add_argument("--size", default=None, help="image size WxH (default: 640x480; 480x480 per panel with --compare)")
    p.add_argument("--no-shadows", action="store_true", help="skip shadows (faster)")
    p.add_argument("--no-ground", action="store_true", help="no ground plane")
    p.add_argument("--elevation", type=_args.float_in(-90.0, 90.0, unit="deg"), default=20.0,
                   help="camera elevation [deg], -90 to 90 (default: 20)")
    p.add_argument(
        "--azimuth", type=_args.float_in(-360.0, 360.0, unit="deg"), default=45.0,
        help="camera azimuth [deg]; 0 looks at the front, 90 at the left side"
    )
    camera = p.add_mutually_exclusive_group()
    camera.add_argument("--fixed-camera", action="store_true", help="do not follow the root; frame the whole clip")
    camera.add_argument(
        "--follow", action="store_true",
        help="turn the camera with the creature's heading (smoothed over 1 s): --azimuth is then relative to its "
        "front, so --azimuth 90 keeps its left side in view while it turns",
    )
    p.add_argument("--contact-sheet", action="store_true", help="write a PNG grid of 12 evenly spaced frames")
    p.add_argument(
        "--out", type=_args.out_path, metavar="PATH", default=None,
        help="output file (.gif, .mp4, .png); a name is made up if omitted"
    )
    p.set_defaults(run=run)


SIZE_RANGE = (16, 4096)
"""Width and height of a rendered frame [pixels]: 4096 covers 4K video; a 4096² RGB frame is 50 MB."""


def _size(text: str | None, default: tuple[int, int]) -> tuple[int, int]:
    if text is None:
        return default
    parts = text.lower().replace("×", "x").split("x")
    try:
        w, h = (int(v) for v in parts)
    except ValueError:
        raise ConfigError(f"--size: expected WIDTHxHEIGHT such as 640x480, got {text!r}") from None
    lo, hi = SIZE_RANGE
    if not (lo <= w <= hi and lo <= h <= hi):  # a frame is allocated whole, and videos keep many
        raise ConfigError(f"--size: expected a width and height from {lo} to {hi} pixels, got {text!r}")
    return w, h


def _load_motion(path: str, creature: Any | None) -> Any:
    """A motion from ``path``; a bare ``.npz`` of ``q`` and ``fps`` plays on ``creature``."""
    from morphkit.motion import Motion, read_motion

    where = SourceLocation(path)
    if Path(path).suffix.lower() == ".npz" and Path(path).is_file():
        try:
            with np.load(path, allow_pickle=False) as data:
                files = set(data.files)
                if "morphology_yaml" not in files:
                    if not {"q", "fps"} <= files:
                        raise MotionFormatError("expected arrays q [frames, coordinates] and fps", location=where)
                    if creature is None:
                        raise MotionFormatError("holds no morphology: pass its creature", location=where)
                    q, fps = np.asarray(data["q"], dtype=float), float(data["fps"])
                    try:
                        return Motion(creature, fps, q, name=Path(path).stem)
                    except MotionFormatError as exc:
                        raise MotionFormatError(exc.message, location=where) from None
        except (OSError, ValueError) as exc:
            raise MotionFormatError(f"not a readable .npz: {exc}", location=where) from None
    return read_motion(path)


def _on_creature(motion: Any, creature: Any, path: str) -> Any:
    """``motion`` played by ``creature`` (the description asked for), checking the coordinates fit."""
    from morphkit.motion import Motion

    if motion.morphology is creature:
        return motion
    ours, theirs = creature.coordinate_names, motion.morphology.coordinate_names
    if ours != theirs:
        if len(ours) != len(theirs):
            why = f"{len(theirs)} coordinates, {creature.name!r} has {len(ours)}"
        else:
            k = next(k for k, (a, b) in enumerate(zip(theirs, ours, strict=True)) if a != b)
            why = f"coordinate {k} is {theirs[k]!r} in the motion but {ours[k]!r} on {creature.name!r}"
        raise MotionFormatError(
            f"motion is for {motion.morphology.name!r}, not {creature.name!r} ({why}); render it with its own "
            "description (a BVH clip: pass the .bvh as CREATURE too)",
            location=SourceLocation(path),
        )
    return Motion(creature, motion.fps, motion.q, name=getattr(motion, "name", ""))


def _views(text: str | None) -> int:
    """``--frames`` of a turntable: a view count (default 72)."""
    if text is not None and ":" in text:
        raise ConfigError(f"--frames {text}: a range selects frames of a --motion; a turntable takes a view count")
    try:
        n = 72 if text is None else int(text)
    except ValueError:
        raise ConfigError(f"--frames: expected a number of views, got {text!r}") from None
    if n < 1:
        raise ConfigError(f"--frames must be at least 1, got {n}")
    return n


def _frame_range(text: str | None) -> tuple[int | None, int | None]:
    """``--frames`` of a motion: ``A:B`` (``A:``, ``:B``; ``N`` means ``:N``) as Python slice bounds."""
    if text is None:
        return None, None
    a, sep, b = text.partition(":")
    if not sep:
        a, b = "", a
    try:
        start, stop = (int(a) if a.strip() else None), (int(b) if b.strip() else None)
    except ValueError:
        raise ConfigError(f"--frames: expected A:B (frame numbers from 0; A: and :B too), got {text!r}") from None
    if (start is not None and start < 0) or (stop is not None and stop < 0):
        raise ConfigError(f"--frames {text}: frame numbers count from 0")
    if stop is not None and stop <= (start or 0):
        raise ConfigError(f"--frames {text}: selects no frame (B must be greater than A)")
    return start, stop


def _same_span(human: Any, start: int | None, stop: int | None, fps: float) -> Any:
    """The frames of ``human`` that cover the creature's frames ``start:stop`` at ``fps`` (same times)."""
    t0 = (start or 0) / fps
    first = math.floor(t0 * human.fps + 1e-9)
    last = None if stop is None else max(first + 1, math.ceil(stop / fps * human.fps - 1e-9))
    return human.slice(first, last)


def _out(args: argparse.Namespace, name: str, what: str) -> str:
    if args.out is not None:
        if args.contact_sheet and Path(args.out).suffix.lower() != ".png":
            raise ConfigError(f"--contact-sheet writes a PNG; got --out {args.out}")
        return args.out
    from morphkit.output_names import safe_stem

    # the creature's and the clip's names never steer the path (morphkit.output_names)
    stem = safe_stem(f"{safe_stem(name, 'creature')}-{safe_stem(what, 'motion')}")
    return f"{stem}.png" if args.contact_sheet else f"{stem}.gif"


def run(args: argparse.Namespace) -> int:
    from morphkit.io import read_morphology
    from morphkit.render import RenderStyle, render_motion, render_side_by_side, turntable
    from morphkit.render.video import check_output

    if args.compare and not args.motion:
        raise ConfigError("--compare needs --motion (the creature's clip to show beside the human one)")
    if args.until_longer and not args.compare:
        raise ConfigError("--until-longer needs --compare (it says which clip ends the comparison)")
    if args.follow and not args.motion:
        raise ConfigError("--follow needs --motion (a turntable already circles the creature)")
    views = _views(args.frames) if args.motion is None else 0
    start, stop = _frame_range(args.frames) if args.motion else (None, None)
    if args.out is not None:  # before reading anything: a bad output is refused before any work
        _out(args, "", "")
        check_output(args.out)
    creature = read_morphology(args.creature)
    style = RenderStyle(
        shadows=not args.no_shadows,
        ground=not args.no_ground,
        elevation_deg=args.elevation,
        azimuth_deg=args.azimuth,
    )

    if args.motion is None:
        out = _out(args, creature.name, "turntable")
        check_output(out)
        still = Path(out).suffix.lower() == ".png" and not args.contact_sheet
        views = 1 if still else (min(views, 12) if args.contact_sheet else views)
        path = turntable(
            creature, out, frames=views, fps=args.fps or 24.0, size=_size(args.size, (640, 480)), style=style
        )
        print(f"wrote {path} ({creature.name}: {'still' if views == 1 else f'{views} views'})")
        return 0

    motion = _on_creature(_load_motion(args.motion, creature), creature, args.motion)
    follow = not args.fixed_camera
    if args.compare:
        out = _out(args, creature.name, "compare")
        check_output(out)
        human = _load_motion(args.compare, None)
        if args.frames is not None:
            human = _same_span(human, start, stop, motion.fps)
            motion = motion.slice(start, stop)
        path = render_side_by_side(
            human,
            motion,
            out=out,
            labels=(human.morphology.name, creature.name),
            size=_size(args.size, (480, 480)),
            style=style,
            fps=args.fps,
            follow=follow,
            follow_heading=args.follow,
            until_longer=args.until_longer,
        )
        print(f"wrote {path} ({human.morphology.name} | {creature.name})")
        return 0

    out = _out(args, creature.name, Path(args.motion).stem)
    check_output(out)
    if args.frames is not None:
        motion = motion.slice(start, stop)
    q, fps = motion.q, motion.fps
    if args.fps is not None and args.fps != fps:
        from morphkit.render.compare import sync_indices

        q, fps = q[sync_indices([len(q)], [fps], args.fps)[:, 0]], args.fps
    path = render_motion(creature, q, fps, out=out, size=_size(args.size, (640, 480)), style=style, follow=follow,
                         follow_heading=args.follow)
    print(f"wrote {path} ({creature.name}: {len(q)} frames at {fps:g} fps)")
    return 0
