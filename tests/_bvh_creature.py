"""A synthetic BVH quadruped for the facing, front-paw and motion-frame tests (tests/io, tests/motion)."""

from __future__ import annotations

import math

import numpy as np

AXES: dict[str, np.ndarray] = {
    "+x": np.array([1.0, 0, 0]),
    "-x": np.array([-1.0, 0, 0]),
    "+z": np.array([0, 0, 1.0]),
    "-z": np.array([0, 0, -1.0]),
}
"""The four candidate facings as skeleton (root-local, Y-up) unit vectors."""


def creature_bvh(
    *,
    head: str = "+z",
    fore: str = "ForeFoot",
    fore_length: float = 40.0,
    frames: int = 40,
    speed: float = 30.0,
    head_names: tuple[str, str] = ("Neck", "Head"),
) -> str:
    """A Y-up quadruped (centimetres) whose trunk and head point along root-local ``head``; it
    walks at ``speed`` [cm/frame] (negative: backwards) while turning 60 degrees about Y.

    Front legs are called ``Left<fore>``/``Right<fore>`` and are ``fore_length`` long (the hind
    legs 40); all feet hang straight down and touch the ground.
    """
    a = AXES[head]
    left = np.cross([0.0, 1.0, 0.0], a)

    def v(x: np.ndarray) -> str:
        return " ".join(f"{c:.12g}" for c in x)

    def leg(name: str, lateral: np.ndarray, length: float, pad: str) -> str:
        return f"""{pad}JOINT {name}_top
{pad}{{
{pad}  OFFSET {v(lateral)}
{pad}  CHANNELS 3 Zrotation Xrotation Yrotation
{pad}  JOINT {name}
{pad}  {{
{pad}    OFFSET 0 {-length:g} 0
{pad}    CHANNELS 3 Zrotation Xrotation Yrotation
{pad}    End Site
{pad}    {{
{pad}      OFFSET 0 -5 0
{pad}    }}
{pad}  }}
{pad}}}
"""

    neck, head_joint = head_names
    text = f"""HIERARCHY
ROOT Hips
{{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation
  JOINT Chest
  {{
    OFFSET {v(40 * a)}
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT {neck}
    {{
      OFFSET {v(10 * a + [0, 10, 0])}
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT {head_joint}
      {{
        OFFSET {v(10 * a)}
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {{
          OFFSET {v(10 * a)}
        }}
      }}
    }}
{leg("Left" + fore, 8 * left, fore_length, "    ")}{leg("Right" + fore, -8 * left, fore_length, "    ")}  }}
{leg("LeftHindFoot", 8 * left, 40.0, "  ")}{leg("RightHindFoot", -8 * left, 40.0, "  ")}}}
MOTION
Frames: {frames}
Frame Time: 0.0333333
"""
    joints = 1 + 3 + 4 + 4
    rows = []
    position = np.array([0.0, 45.0, 0.0])
    for t in range(frames):
        yaw = 60.0 * t / max(frames - 1, 1)
        c, s = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
        heading = np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]) @ a  # Ry(yaw) a
        rows.append(" ".join([v(position), f"{yaw:.12g} 0 0", *["0 0 0"] * (joints - 1)]))
        position = position + speed * heading
    return text + "\n".join(rows) + "\n"
