"""Warp kernels and their launchers (Warp only, never torch).

Every launcher takes the compiled :class:`~morphkit.model.KinematicModel`, batched inputs with
any leading shape, an optional ``out=`` and ``device=``; see ``docs/design/fk-kernels.md``.
"""

from morphkit.kernels.end_effectors import eval_end_effector_velocities as eval_end_effector_velocities
from morphkit.kernels.end_effectors import eval_end_effectors as eval_end_effectors
from morphkit.kernels.end_effectors import eval_end_effectors_adjoint as eval_end_effectors_adjoint
from morphkit.kernels.end_effectors import eval_finite_difference as eval_finite_difference
from morphkit.kernels.end_effectors import eval_heading_transforms as eval_heading_transforms
from morphkit.kernels.fk import cpu_thread_count as cpu_thread_count
from morphkit.kernels.fk import eval_fk as eval_fk
from morphkit.kernels.fk import eval_fk_adjoint as eval_fk_adjoint
from morphkit.kernels.fk import eval_link_positions as eval_link_positions
from morphkit.kernels.fk import eval_link_positions_adjoint as eval_link_positions_adjoint
from morphkit.kernels.fk import eval_wheel_angles as eval_wheel_angles
from morphkit.kernels.fk import fk_module as fk_module
from morphkit.kernels.fk import set_cpu_thread_count as set_cpu_thread_count

__all__ = [
    "cpu_thread_count",
    "eval_end_effector_velocities",
    "eval_end_effectors",
    "eval_end_effectors_adjoint",
    "eval_finite_difference",
    "eval_fk",
    "eval_fk_adjoint",
    "eval_heading_transforms",
    "eval_link_positions",
    "eval_link_positions_adjoint",
    "eval_wheel_angles",
    "fk_module",
    "set_cpu_thread_count",
]
