"""``nn.Module`` wrappers over the kinematics: the forward-kinematics layer of NKN."""

from __future__ import annotations

from typing import Any

import torch
from torch import nn

from morphkit.errors import GraphError
from morphkit.graph.morphology import Morphology
from morphkit.model.compile import compile_model
from morphkit.model.kinematic_model import KinematicModel
from morphkit.torch import functions as F
from morphkit.torch import reference as R

__all__ = ["ForwardKinematics"]

BACKENDS = ("warp", "reference")


class ForwardKinematics(nn.Module):
    """Forward kinematics as a layer: coordinates in, link transforms out.

    This is the FK layer of NKN (Villegas et al. 2018, §3.1): given joint rotations (and the root
    motion) it returns the world pose of every joint, differentiably. Two backends compute the
    same thing:

    - ``"warp"`` (default): the generated Warp kernels through :mod:`morphkit.torch.functions`,
      gradients with respect to ``q`` only, once differentiable; the fast path.
    - ``"reference"``: the pure-torch FK of :mod:`morphkit.torch.reference`: plain autograd, so
      double backward works and gradients reach the joint origins ("bone offsets").

    ``differentiable_offsets=True`` selects the reference backend and holds the joint origin
    translations as a learnable ``nn.Parameter`` ``joint_offsets`` [J, 3]. Per-sample offsets
    (NKN's skeleton input) can also be passed to :meth:`forward` as ``joint_offsets`` [..., J, 3];
    gradients flow to them.

    Args:
        morphology: A :class:`~morphkit.graph.Morphology` or an already compiled
            :class:`~morphkit.model.KinematicModel`.
        device: Device of the module's parameters (Warp mirrors follow the input's device).
        backend: ``"warp"`` or ``"reference"``.
        differentiable_offsets: Learnable joint origin translations (implies ``"reference"``).
        dtype: dtype of ``joint_offsets`` when it is a parameter.
    """

    def __init__(
        self,
        morphology: Morphology | KinematicModel,
        *,
        device: Any = None,
        backend: str = "warp",
        differentiable_offsets: bool = False,
        dtype: torch.dtype = torch.float32,
    ) -> None:
        super().__init__()
        if backend not in BACKENDS:
            raise GraphError(f"unknown backend {backend!r}; expected one of: {', '.join(BACKENDS)}")
        self.model = morphology if isinstance(morphology, KinematicModel) else compile_model(morphology)
        self.backend = "reference" if differentiable_offsets else backend
        self.differentiable_offsets = differentiable_offsets
        if differentiable_offsets:
            self.joint_offsets = nn.Parameter(
                torch.tensor(self.model.joint_X_parent[:, :3], dtype=dtype, device=device)
            )
            """Joint origin translations ("bone offsets") in the parent link frame, shape [J, 3] [m]."""
        else:
            self.joint_offsets = None

    def extra_repr(self) -> str:
        return f"{self.model.name!r}, links={self.model.link_count}, backend={self.backend!r}"

    def _use_reference(self, joint_offsets: torch.Tensor | None) -> bool:
        return self.backend == "reference" or joint_offsets is not None

    def _offsets(self, joint_offsets: torch.Tensor | None, q: torch.Tensor) -> torch.Tensor | None:
        offsets = joint_offsets if joint_offsets is not None else self.joint_offsets
        return None if offsets is None else offsets.to(q.dtype)

    def forward(
        self,
        q: torch.Tensor,
        *,
        joint_offsets: torch.Tensor | None = None,
        wheel_q: torch.Tensor | None = None,
        time_series: bool = False,
    ) -> torch.Tensor:
        """Link transforms ``Ts_world_link``, shape [..., L, 7] (position [m], xyzw quaternion).

        Args:
            q: Coordinates [..., C] (layout: ``docs/design/q-layout.md``).
            joint_offsets: Per-sample joint origin translations [..., J, 3] (uses the reference backend).
            wheel_q: Wheel angles [..., W] [rad].
            time_series: ``q`` is a motion [..., T, C]; wheels follow the base.
        """
        if self._use_reference(joint_offsets):
            if wheel_q is None and time_series and self.model.wheel_count:
                wheel_q = R.wheel_angles_reference(self.model, q.detach())
            return R.fk_reference(self.model, q, wheel_q=wheel_q, joint_offsets=self._offsets(joint_offsets, q))
        return F.fk(self.model, q, wheel_q=wheel_q, time_series=time_series)

    def link_positions(
        self,
        q: torch.Tensor,
        *,
        joint_offsets: torch.Tensor | None = None,
        wheel_q: torch.Tensor | None = None,
        time_series: bool = False,
    ) -> torch.Tensor:
        """World positions of the link origins, shape [..., L, 3] [m]."""
        if self._use_reference(joint_offsets):
            return self.forward(q, joint_offsets=joint_offsets, wheel_q=wheel_q, time_series=time_series)[..., :3]
        return F.link_positions(self.model, q, wheel_q=wheel_q, time_series=time_series)

    def end_effector_positions(
        self,
        q: torch.Tensor,
        *,
        frame: str = "world",
        joint_offsets: torch.Tensor | None = None,
        wheel_q: torch.Tensor | None = None,
        time_series: bool = False,
    ) -> torch.Tensor:
        """End-effector points [..., E, 3] [m] in the ``"world"`` or ``"heading"`` frame."""
        if self._use_reference(joint_offsets):
            Ts = self.forward(q, joint_offsets=joint_offsets, wheel_q=wheel_q, time_series=time_series)
            return R.end_effectors_reference(self.model, Ts, frame=frame)[..., :3]
        return F.end_effector_positions(self.model, q, frame=frame, wheel_q=wheel_q, time_series=time_series)
