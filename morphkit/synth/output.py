"""Writing synthesised motions: a folder of one NPZ per rollout with a manifest, or one NPZ file.

- **Where**: a path with a suffix is a file — ``.npz`` holds every rollout end to end; another suffix is
  refused (synthesis writes NPZ, where commands and contacts ride along; ``morphkit convert`` turns an
  NPZ motion into BVH or USD). A path without a suffix, ending in a separator, or naming an existing
  folder is a folder with one ``<name>.npz`` per rollout (the name through
  :func:`~morphkit.output_names.safe_stem`).
- **Only this run's files**: a folder gets ``manifest.json`` (:mod:`morphkit.motion.manifest`), written
  as "not finished" before the first rollout, updated as rollouts are written and completed after the
  last; the files an earlier run listed there and this run does not write are deleted then. Readers of
  the folder read what the manifest lists, so stale rollouts are never mixed in, even beside files a user
  put there.
- **One data set per folder**: a folder holding the finished data set of another creature is refused
  unless ``force`` (then replaced); the same creature's earlier data set is replaced (a re-run with other
  ``--frames`` or ``--seed``). What a killed run left (its rollouts, the atomic writer's temporary
  ``.<stem>.XXXXXXXX.npz`` files) is removed when the next run starts, and a warning names it. The
  command holds the folder's lock (:mod:`morphkit._folder_lock`) for the whole run, so no second writer
  runs there meanwhile.
- **File names**: ``<stem>.npz`` where ``stem`` is the motion's name through
  :func:`~morphkit.output_names.safe_stem` (a ``name: ../../x`` writes ``x_synth_0_0000.npz`` inside the
  folder); the name itself stays in the file's ``name`` field and the manifest's ``creature``.
- **Checked before any work** (:func:`check_output`): the target can be written (a probe file is created
  and removed), and the estimated size (:func:`estimate_output_bytes`: the arrays' exact sizes plus the
  per-file header and embedded description) fits the free disk space.
- **Flat memory**: :class:`SynthWriter` takes the rollouts a batch at a time
  (:func:`~morphkit.synth.core.iter_synthesize`) and writes a folder's files as they come; a single
  ``.npz`` file is assembled in memory, so it is for data sets that fit there.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from morphkit._memory import available_memory
from morphkit.errors import ConfigError
from morphkit.graph import Morphology
from morphkit.motion.manifest import read_manifest, write_manifest
from morphkit.motion.motion import Motion
from morphkit.output_names import safe_stem
from morphkit.synth.actions import ACTION_NAMES
from morphkit.synth.locomotion_commands import COMMAND_NAMES

__all__ = ["SynthWriter", "available_memory", "check_folder", "check_output", "estimate_output_bytes",
           "format_bytes", "output_kind"]

_MOTION_SUFFIXES = (".npz", ".bvh", ".usd", ".usda", ".usdc", ".csv")


def output_kind(path: str | os.PathLike[str]) -> str:
    """``"file"`` (a ``.npz`` path) or ``"folder"`` for an output path (see the module docstring).

    Raises:
        ConfigError: a file suffix other than ``.npz``.
    """
    raw = os.fspath(path)
    p = Path(raw)
    if raw.endswith(("/", os.sep)) or p.is_dir() or not p.suffix:
        return "folder"
    if p.suffix.lower() == ".npz":
        return "file"
    if p.suffix.lower() in _MOTION_SUFFIXES:
        raise ConfigError(f"--out {raw}: synth writes NPZ motions (commands and contacts ride along): give a .npz "
                          f"file or a folder, then `morphkit convert` a motion to {p.suffix}")
    raise ConfigError(f"--out {raw}: {p.suffix} is not a motion format: give a .npz file (every rollout end to end) "
                      "or a folder (one .npz per rollout; end the name with / if it has a dot)")


def format_bytes(n: float) -> str:
    """``n`` bytes in the largest unit that keeps it >= 1 (1000-based: kB, MB, GB, TB)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(n) < 1000 or unit == "TB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.3g} {unit}"
        n /= 1000.0
    return f"{n:.3g} TB"  # pragma: no cover - the loop returns


def _array_bytes(shape_bytes: int, name: str) -> int:
    # an .npy member: data, a header padded to 64 bytes (128 with the magic), the zip entry's local and
    # central headers (30 + 46 bytes plus the name twice, the zip64 extras)
    return shape_bytes + 128 + 2 * len(name) + 4 + 30 + 46 + 40


def estimate_output_bytes(m: Morphology, frames: int, count: int, legs: int, *, single_file: bool) -> int:
    """Bytes the NPZ output of ``frames`` frames in ``count`` rollouts of ``m`` with ``legs`` stance legs
    takes (an upper bound: the ``action`` arrays are counted whether or not the creature acts)."""
    from morphkit.io.yaml_format import dump_yaml

    per_frame = 8 * m.coordinate_count + 2 * 4 * len(COMMAND_NAMES) + 1 + legs + 1 + 1  # q, commands, flags
    names = 4 * (sum(len(n) for n in COMMAND_NAMES) + 8 * 8 + sum(len(n) for n in ACTION_NAMES))
    per_file = (4 * len(dump_yaml(m)) + 4 * 64 + names + 8 + 8  # morphology, name, names, fps, version
                + sum(_array_bytes(0, k) for k in ("q", "fps", "name", "morphology_yaml", "format_version", "command",
                                                    "command_target", "command_settled", "command_names", "contact",
                                                    "gait", "gait_names", "action", "action_names", "clip_starts"))
                + 22)  # end of the central directory
    if single_file:
        return frames * per_frame + per_file + 8 * count
    return frames * per_frame + count * per_file


def _existing_ancestor(p: Path) -> Path:
    p = p.absolute()
    while not p.exists() and p.parent != p:
        p = p.parent
    return p


def check_output(path: str | os.PathLike[str], estimate: int) -> None:
    """Refuse an output that cannot be written or would not fit on its disk, before any work.

    Creates and removes a probe file where the output goes (creating no folder), and compares
    ``estimate`` [bytes] with the free space of the disk it lands on.

    Raises:
        ConfigError: the output is not writable, or ``estimate`` exceeds the free space (both numbers said).
    """
    raw = os.fspath(path)
    p = Path(raw)
    kind = output_kind(raw)
    if kind == "file" and p.is_dir():
        raise ConfigError(f"--out {raw}: is a folder (give a folder without the .npz suffix, or another file name)")
    if kind == "folder" and p.exists() and not p.is_dir():
        raise ConfigError(f"--out {raw}: exists and is not a folder (use a .npz name for a single file)")
    where = p.parent if kind == "file" else p
    base = _existing_ancestor(where)
    if not base.is_dir():
        raise ConfigError(f"--out {raw}: {base} is not a folder")
    try:
        fd, probe = tempfile.mkstemp(prefix=".morphkit-probe.", dir=base)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise ConfigError(f"--out {raw}: cannot write in {base}: {exc.strerror or exc}") from None
    free = shutil.disk_usage(base).free
    if estimate > free:
        raise ConfigError(f"--out {raw}: the motions would take about {format_bytes(estimate)} and only "
                          f"{format_bytes(free)} are free on the disk of {base}: ask for fewer --frames")


def check_folder(path: str | os.PathLike[str], creature: str, *, force: bool = False) -> None:
    """Refuse a folder holding the finished data set of another creature than ``creature`` (unless ``force``).

    Raises:
        ConfigError: naming the folder's creature and how to go on.
    """
    if not Path(path).is_dir():
        return
    old = read_manifest(path)
    if old is not None and old.get("complete") and old["files"] and not force and old.get("creature") != creature:
        raise ConfigError(
            f"--out {os.fspath(path)}: holds the synth data set of {old.get('creature')!r} ({len(old['files'])} "
            f"file(s) listed in its manifest.json), not one of {creature!r}; a folder holds one data set: give "
            "--force to replace it, or another folder")


class SynthWriter:
    """Writes synthesised rollouts as they come (see the module docstring).

    Args:
        path: A ``.npz`` file or a folder (:func:`output_kind`).
        force: Replace a folder's finished data set of another creature (else refused).
        info: What the folder's manifest records about the run (creature, frames, fps, seed, ...).

    Raises:
        ConfigError: the folder holds another creature's finished data set and ``force`` is not given.
    """

    def __init__(self, path: str | os.PathLike[str], *, force: bool = False, **info: Any) -> None:
        self.path = Path(path)
        self.kind = output_kind(path)
        self.info = info
        self.files: list[Path] = []
        self._parts: list[Any] = []
        self._stale: list[str] = []
        if self.kind == "folder":
            if self.path.exists() and not self.path.is_dir():
                raise ConfigError(f"--out {self.path}: exists and is not a folder (use a .npz name for a single file)")
            self.path.mkdir(parents=True, exist_ok=True)
            old = read_manifest(self.path)
            if "creature" in info:
                check_folder(self.path, info["creature"], force=force)
            self._stale = list(old["files"]) if old is not None else []
            self._remove_leftovers(old)
            write_manifest(self.path, [], complete=False, **info)

    def _remove_leftovers(self, old: dict[str, Any] | None) -> None:
        """Remove what a killed run left: the rollouts it wrote that its manifest (never completed) does not
        list, and the atomic writer's temporary files of any run here. Called under the folder's lock, so no
        writer is alive to own them."""
        stems = {safe_stem(c) for c in (self.info.get("creature"), old and old.get("creature")) if c}
        temp = re.compile(r"\.(?P<stem>.+)\.[A-Za-z0-9_]{8}\.(npz|json)")
        unfinished = old is not None and not old.get("complete")
        rollout = re.compile(r"(?P<stem>.+)_synth_\d+_\d{4,}\.npz")
        gone = []
        for f in sorted(self.path.iterdir()):
            m = temp.fullmatch(f.name)
            if m is not None and f.is_file() and (m["stem"] == "manifest" or any(
                    m["stem"].startswith(f"{s}_synth_") for s in stems)):
                f.unlink(missing_ok=True)
                gone.append(f.name)
            elif unfinished and f.name not in self._stale and f.is_file() and \
                    (r := rollout.fullmatch(f.name)) is not None and r["stem"] in stems:
                self._stale.append(f.name)  # an unlisted rollout of the killed run: removed at close
        if gone:
            shown = ", ".join(gone[:3]) + (f" and {len(gone) - 3} more" if len(gone) > 3 else "")
            warnings.warn(f"{self.path}: removed {len(gone)} temporary file(s) a stopped run left: {shown}",
                          stacklevel=2)

    def write(self, part: Any) -> list[Path]:
        """Write the rollouts of ``part`` (a :class:`~morphkit.synth.SynthResult`); returns the files written
        (none yet for a single file, which is written by :meth:`close`)."""
        from morphkit.motion.io_npz import write_npz_motion

        if self.kind == "file":
            self._parts.append(part)
            return []
        out = []
        for i, m in enumerate(part.motions):
            f = self.path / f"{safe_stem(m.name, default='synth')}.npz"  # the name itself stays inside the file
            write_npz_motion(m, f, **part.extras(i))
            out.append(f)
        self.files += out
        # listed as they come: a run stopped here leaves a manifest naming its files, which the next removes
        write_manifest(self.path, [f.name for f in self.files], complete=False, **self.info)
        return out

    def close(self) -> list[Path]:
        """Finish: the single file, or the folder's complete manifest and the stale files removed; returns
        every file of this run."""
        if self.kind == "file":
            self._write_single()
            return self.files
        names = [f.name for f in self.files]
        mine = set(names)
        for name in self._stale:
            if name not in mine and Path(name).name == name:  # only files directly in the folder
                (self.path / name).unlink(missing_ok=True)
        write_manifest(self.path, names, complete=True, **self.info)
        return self.files

    def _write_single(self) -> None:
        from morphkit.motion.io_npz import write_npz_motion
        from morphkit.synth.core import SynthResult

        if not self._parts:
            raise ConfigError("nothing to save: no motion was synthesised")
        res = SynthResult.concatenate(self._parts)
        joined = Motion.concatenate(res.motions, name=self.path.stem)
        starts = np.cumsum([0] + [m.frame_count for m in res.motions[:-1]]).astype(np.int64)
        per_frame = ("command", "command_target", "command_settled", "contact", "gait") + (
            ("action",) if res.action else ())
        ex = {k: np.concatenate([res.extras(i)[k] for i in range(len(res))], axis=0) for k in per_frame}
        ex.update(command_names=np.array(COMMAND_NAMES), gait_names=res.extras(0)["gait_names"], clip_starts=starts)
        if res.action:
            ex["action_names"] = np.array(ACTION_NAMES)
        write_npz_motion(joined, self.path, **ex)
        self.files = [self.path]
