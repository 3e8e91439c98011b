"""Warp vector, quaternion and transform types of a scalar type (float32 or float64).

Launchers pick the overload of a generic kernel from the scalar type of their inputs; these give
the matching composite types (``wp.vec3`` / ``wp.vec3d`` and so on).
"""

from __future__ import annotations

from typing import Any

import warp as wp

__all__ = ["quat_type", "transform_type", "vec3_type"]


def vec3_type(scalar: Any) -> Any:
    """``wp.vec3d`` for ``wp.float64``, else ``wp.vec3``."""
    return wp.vec3d if scalar == wp.float64 else wp.vec3


def quat_type(scalar: Any) -> Any:
    """``wp.quatd`` for ``wp.float64``, else ``wp.quat``."""
    return wp.quatd if scalar == wp.float64 else wp.quat


def transform_type(scalar: Any) -> Any:
    """``wp.transformd`` for ``wp.float64``, else ``wp.transform``."""
    return wp.transformd if scalar == wp.float64 else wp.transform
