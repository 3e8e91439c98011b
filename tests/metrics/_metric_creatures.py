"""The tiny YAML creature the metric tests move (built from text in the test, no file)."""

from __future__ import annotations

import numpy as np

from morphkit.graph import Morphology
from morphkit.io.yaml_format import parse_yaml
from morphkit.motion import Motion

# A biped standing with its feet on the ground when the pelvis is at z = 0.65: hips 5 cm below the
# pelvis, thigh and shin 0.3 m each, feet at the shin tips; a tail (role tool) touching the ground.
# Hips swing about x (sideways), knees about y.
BIPED_YAML = """
name: metric_biped
base: floating
root: pelvis
links:
  pelvis:
    shapes: [{type: box, size: [0.2, 0.3, 0.1]}]
  l_thigh:
    shapes: [{type: capsule, radius: 0.03, length: 0.24, origin: {xyz: [0, 0, -0.15]}}]
  l_shin:
    shapes: [{type: capsule, radius: 0.03, length: 0.24, origin: {xyz: [0, 0, -0.15]}}]
  r_thigh:
    shapes: [{type: capsule, radius: 0.03, length: 0.24, origin: {xyz: [0, 0, -0.15]}}]
  r_shin:
    shapes: [{type: capsule, radius: 0.03, length: 0.24, origin: {xyz: [0, 0, -0.15]}}]
joints:
  l_hip: {type: revolute, parent: pelvis, child: l_thigh, origin: {xyz: [0, 0.1, -0.05]}, axis: [1, 0, 0],
          limit: {lower: -1.5, upper: 1.5}}
  l_knee: {type: revolute, parent: l_thigh, child: l_shin, origin: {xyz: [0, 0, -0.3]}, axis: [0, 1, 0],
           limit: {lower: -2.0, upper: 2.0}}
  r_hip: {type: revolute, parent: pelvis, child: r_thigh, origin: {xyz: [0, -0.1, -0.05]}, axis: [1, 0, 0],
          limit: {lower: -1.5, upper: 1.5}}
  r_knee: {type: revolute, parent: r_thigh, child: r_shin, origin: {xyz: [0, 0, -0.3]}, axis: [0, 1, 0],
           limit: {lower: -2.0, upper: 2.0}}
end_effectors:
  l_foot: {link: l_shin, offset: [0, 0, -0.3], role: foot}
  r_foot: {link: r_shin, offset: [0, 0, -0.3], role: foot}
  tail: {link: pelvis, offset: [-0.3, 0, -0.65], role: tool}
"""
STAND_Z = 0.65
FPS = 30.0


def metric_biped() -> Morphology:
    """The biped of :data:`BIPED_YAML`."""
    return parse_yaml(BIPED_YAML, source="metric_biped.yaml")


def biped_motion(m, T: int, **coords: np.ndarray | float) -> Motion:
    """T frames of the biped standing at the origin, with coordinates overridden by name (arrays [T] or scalars)."""
    q = np.tile(m.rest_q(), (T, 1))
    q[:, 2] = STAND_Z
    names = list(m.coordinate_names)
    for name, value in coords.items():
        q[:, names.index(name)] = value
    return Motion(m, FPS, q, name="constructed")
