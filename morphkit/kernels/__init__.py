"""Warp kernels and their launchers (Warp only, never torch).

Every launcher takes the compiled :class:`~morphkit.model.KinematicModel`, batched inputs with
any leading shape, an optional ``out=`` and ``device=``; see ``docs/design/fk-kernels.md``.
"""

import os as _os

import warp as _wp

if _os.environ.get("MORPHKIT_QUIET_WARP"):
    # Set by the CLI, which owns stdout: Warp's banner and module-load lines would break --json output.
    _wp.config.log_level = _wp.LOG_WARNING

from morphkit.kernels.contact import SelfCollisionPairs as SelfCollisionPairs
from morphkit.kernels.contact import eval_contact_flags as eval_contact_flags
from morphkit.kernels.contact import eval_foot_heights as eval_foot_heights
from morphkit.kernels.contact import eval_penetration_depth as eval_penetration_depth
from morphkit.kernels.contact import eval_self_collision_distance as eval_self_collision_distance
from morphkit.kernels.contact import eval_self_collision_penetration as eval_self_collision_penetration
from morphkit.kernels.contact import eval_shape_ground_distance as eval_shape_ground_distance
from morphkit.kernels.contact import eval_sliding_speed as eval_sliding_speed
from morphkit.kernels.contact import foot_indices as foot_indices
from morphkit.kernels.contact import self_collision_pairs as self_collision_pairs
from morphkit.kernels.end_effectors import eval_end_effector_velocities as eval_end_effector_velocities
from morphkit.kernels.end_effectors import eval_end_effectors as eval_end_effectors
from morphkit.kernels.end_effectors import eval_end_effectors_adjoint as eval_end_effectors_adjoint
from morphkit.kernels.end_effectors import eval_finite_difference as eval_finite_difference
from morphkit.kernels.end_effectors import eval_heading_transforms as eval_heading_transforms
from morphkit.kernels.fk import eval_fk as eval_fk
from morphkit.kernels.fk import eval_fk_adjoint as eval_fk_adjoint
from morphkit.kernels.fk import eval_link_positions as eval_link_positions
from morphkit.kernels.fk import eval_link_positions_adjoint as eval_link_positions_adjoint
from morphkit.kernels.fk import eval_wheel_angles as eval_wheel_angles
from morphkit.kernels.fk import fk_module as fk_module
from morphkit.kernels.ik import IKResult as IKResult
from morphkit.kernels.ik import eval_ee_jacobian as eval_ee_jacobian
from morphkit.kernels.ik import ik_dof_mask as ik_dof_mask
from morphkit.kernels.ik import ik_solve as ik_solve
from morphkit.kernels.ik import ik_step as ik_step
from morphkit.kernels.launch import cpu_thread_count as cpu_thread_count
from morphkit.kernels.launch import init_warp_quietly as _init_quietly
from morphkit.kernels.launch import set_cpu_thread_count as set_cpu_thread_count

# Warp's note that no CUDA driver was found reads like an error on a CPU machine, where morphkit runs
# as meant: Warp is initialised here without it, for Python users too (its own banner stays theirs).
_init_quietly()

__all__ = [
    "IKResult",
    "SelfCollisionPairs",
    "cpu_thread_count",
    "eval_contact_flags",
    "eval_ee_jacobian",
    "eval_end_effector_velocities",
    "eval_end_effectors",
    "eval_end_effectors_adjoint",
    "eval_finite_difference",
    "eval_fk",
    "eval_fk_adjoint",
    "eval_foot_heights",
    "eval_heading_transforms",
    "eval_link_positions",
    "eval_link_positions_adjoint",
    "eval_penetration_depth",
    "eval_self_collision_distance",
    "eval_self_collision_penetration",
    "eval_shape_ground_distance",
    "eval_sliding_speed",
    "eval_wheel_angles",
    "fk_module",
    "foot_indices",
    "ik_dof_mask",
    "ik_solve",
    "ik_step",
    "self_collision_pairs",
    "set_cpu_thread_count",
]
