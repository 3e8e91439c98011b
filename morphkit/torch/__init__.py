"""PyTorch bridge: autograd over the Warp kernels, the FK layer, and the pure-torch reference FK.

The only layer importing both torch and Warp. ``morphkit.torch.reference`` is the escape hatch
(plain autograd: double backward, gradients with respect to joint origins); see
``docs/design/fk-kernels.md``.
"""

from morphkit.torch.contact import contact_flags as contact_flags
from morphkit.torch.contact import foot_heights as foot_heights
from morphkit.torch.contact import penetration_depth as penetration_depth
from morphkit.torch.contact import self_collision_distance as self_collision_distance
from morphkit.torch.contact import self_collision_penetration as self_collision_penetration
from morphkit.torch.contact import shape_ground_distance as shape_ground_distance
from morphkit.torch.contact import sliding_speed as sliding_speed
from morphkit.torch.functions import EndEffectorFunction as EndEffectorFunction
from morphkit.torch.functions import FKFunction as FKFunction
from morphkit.torch.functions import end_effector_positions as end_effector_positions
from morphkit.torch.functions import end_effector_velocities as end_effector_velocities
from morphkit.torch.functions import end_effectors as end_effectors
from morphkit.torch.functions import fk as fk
from morphkit.torch.functions import link_positions as link_positions
from morphkit.torch.functions import wheel_angles as wheel_angles
from morphkit.torch.layers import ForwardKinematics as ForwardKinematics

__all__ = [
    "EndEffectorFunction",
    "FKFunction",
    "ForwardKinematics",
    "contact_flags",
    "end_effector_positions",
    "end_effector_velocities",
    "end_effectors",
    "fk",
    "foot_heights",
    "link_positions",
    "penetration_depth",
    "self_collision_distance",
    "self_collision_penetration",
    "shape_ground_distance",
    "sliding_speed",
    "wheel_angles",
]
