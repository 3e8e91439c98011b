"""Shared pieces of the ACE tests: a quadruped written in YAML only, and a small human data folder."""

from __future__ import annotations

from pathlib import Path

QUADRUPED_YAML = """\
name: testdog
base: floating
root: body
links:
  body: {shapes: [{type: box, size: [0.5, 0.2, 0.12]}]}
  neck: {shapes: [{type: capsule, radius: 0.03, length: 0.12, origin: {xyz: [0.06, 0, 0], rpy: [0, 1.5708, 0]}}]}
{legs_links}
joints:
  neck_pitch: {type: revolute, parent: body, child: neck, origin: {xyz: [0.25, 0, 0.04]}, axis: [0, 1, 0],
               limit: {lower: -0.6, upper: 0.6}}
{legs_joints}
end_effectors:
  head: {link: neck, offset: [0.14, 0, 0], role: head}
{legs_ees}
"""


_DOWN = "origin: {xyz: [0, 0, -0.09]}"


def quadruped_yaml() -> str:
    """A 13-DoF quadruped (hip roll, hip pitch, knee per leg; a neck) with a head and four feet."""
    links, joints, ees = [], [], []
    for n, x, y in (("fl", 0.2, 0.09), ("fr", 0.2, -0.09), ("hl", -0.2, 0.09), ("hr", -0.2, -0.09)):
        links += [
            f"  {n}_hip: {{shapes: [{{type: sphere, radius: 0.03}}]}}",
            f"  {n}_upper: {{shapes: [{{type: capsule, radius: 0.025, length: 0.18, {_DOWN}}}]}}",
            f"  {n}_lower: {{shapes: [{{type: capsule, radius: 0.02, length: 0.18, {_DOWN}}}]}}",
        ]
        joints += [
            f"  {n}_roll: {{type: revolute, parent: body, child: {n}_hip, origin: {{xyz: [{x}, {y}, 0]}}, "
            "axis: [1, 0, 0], limit: {lower: -0.5, upper: 0.5}}",
            f"  {n}_pitch: {{type: revolute, parent: {n}_hip, child: {n}_upper, axis: [0, 1, 0], "
            "limit: {lower: -1.2, upper: 1.2}}",
            f"  {n}_knee: {{type: revolute, parent: {n}_upper, child: {n}_lower, origin: {{xyz: [0, 0, -0.18]}}, "
            "axis: [0, 1, 0], limit: {lower: -2.4, upper: -0.2}}",
        ]
        ees.append(f"  {n}_foot: {{link: {n}_lower, offset: [0, 0, -0.18], role: foot}}")
    text = QUADRUPED_YAML.replace("{legs_links}", "\n".join(links)).replace("{legs_joints}", "\n".join(joints))
    return text.replace("{legs_ees}", "\n".join(ees))


def write_quadruped(folder: Path) -> Path:
    path = folder / "testdog.yaml"
    path.write_text(quadruped_yaml())
    return path


def write_human_clips(folder: Path, *, clips: int = 3, frames: int = 90) -> Path:
    """``clips`` synthesised clips of the shipped human as .npz files in ``folder`` (a human data folder)."""
    from dataclasses import replace

    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology
    from morphkit.motion import write_motion
    from morphkit.synth import SynthConfig, synthesize

    human = read_morphology(resolve_morphology("human"))
    cfg = replace(SynthConfig(), rollout_seconds=frames / 30.0)
    folder.mkdir(parents=True, exist_ok=True)
    for i, m in enumerate(synthesize(human, frames=clips * frames, seed=7, config=cfg, progress=False).motions):
        write_motion(m, folder / f"human_{i}.npz")
    return folder
