"""Compiled kinematic model: a Morphology flattened into struct-of-arrays for the kernels.

See ``docs/design/q-layout.md`` for the coordinate layout.
"""

from morphkit.model.compile import compile_model as compile_model
from morphkit.model.kinematic_model import KinematicModel as KinematicModel
from morphkit.model.kinematic_model import ModelArrays as ModelArrays
from morphkit.model.kinematic_model import resolve_float_dtype as resolve_float_dtype

__all__ = ["KinematicModel", "ModelArrays", "compile_model", "resolve_float_dtype"]
