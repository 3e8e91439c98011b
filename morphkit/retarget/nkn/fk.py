"""NKN's forward-kinematics layer: link positions of many skeletons of one topology at once.

Per-sample bone offsets (every batch item may retarget to another character, §4.1.1) are exact on
morphkit's Warp FK because the rotations of the links never depend on the joint origin
translations, and the translations enter the link positions linearly. For link $l$,

$$P_l(q, o) = P_l(q, \\bar o) + \\sum_{j \\in \\mathrm{path}(l)} R_{\\mathrm{parent}(j)}(q)\\,(o_j - \\bar o_j),$$

where $\\bar o$ are the template's offsets, $R_{\\mathrm{parent}(j)}$ the world rotation of joint
$j$'s parent link and the sum runs over the joints from the root to $l$. :class:`SkeletonFK` takes
$P(q, \\bar o)$ and the rotations from :func:`morphkit.torch.fk` (Warp; gradients w.r.t. ``q``) and
adds the correction in torch, so gradients reach the offsets too. ``backend="reference"`` runs
:class:`morphkit.torch.ForwardKinematics`'s pure-torch FK with the offsets instead (the oracle).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import torch
from torch import nn

import morphkit.torch as mt
from morphkit.graph import Morphology
from morphkit.model import compile_model
from morphkit.rotations import quat_rotate

__all__ = ["SkeletonFK"]


class SkeletonFK(nn.Module):
    """Link positions [..., L, 3] [m] of coordinates ``q`` [..., C] on skeletons with bone offsets [..., J, 3].

    Args:
        template: Any skeleton of the topology (its offsets are the $\\bar o$ above).
        backend: ``"warp"`` (Warp FK plus the offset correction) or ``"reference"`` (pure torch).
    """

    def __init__(self, template: Morphology, *, backend: Literal["warp", "reference"] = "warp") -> None:
        super().__init__()
        self.model = compile_model(template)
        self.backend = backend
        m = self.model
        parents = np.asarray(m.joint_parent, dtype=np.int64)  # [J] parent link of each joint
        self.register_buffer("joint_parent", torch.as_tensor(parents), persistent=False)
        self.register_buffer("template_offsets", torch.as_tensor(np.array(m.joint_X_parent)[:, :3]),
                             persistent=False)
        # ancestors[l, j] = 1 where joint j lies on the path from the root to link l (link j + 1 is l or above it).
        ancestors = np.zeros((m.link_count, m.joint_count))
        for link in range(1, m.link_count):
            i = link
            while i > 0:  # link i is the child of joint i - 1, whose parent link is joint_parent[i - 1]
                ancestors[link, i - 1] = 1.0
                i = int(parents[i - 1])
        self.register_buffer("ancestors", torch.as_tensor(ancestors), persistent=False)
        self._reference = mt.ForwardKinematics(self.model, backend="reference") if backend == "reference" else None

    def extra_repr(self) -> str:
        return f"{self.model.name!r}, links={self.model.link_count}, backend={self.backend!r}"

    def forward(self, q: torch.Tensor, offsets: torch.Tensor | None = None) -> torch.Tensor:
        """World link positions [..., L, 3] [m] of ``q`` [..., C] on bone offsets [..., J, 3] (default: template's)."""
        if self._reference is not None:
            return self._reference.link_positions(q, joint_offsets=offsets)
        Ts = mt.fk(self.model, q)  # [..., L, 7]
        P = Ts[..., :3]
        if offsets is None:
            return P
        delta = offsets.to(q.dtype) - self.template_offsets.to(q.dtype)  # [..., J, 3]
        R_parent = Ts[..., self.joint_parent, 3:]  # [..., J, 4]
        lead = torch.broadcast_shapes(R_parent.shape[:-2], delta.shape[:-2])
        world = quat_rotate(R_parent.expand(*lead, -1, -1), delta.expand(*lead, -1, -1))  # [..., J, 3]
        return P + torch.matmul(self.ancestors.to(q.dtype), world)  # [L, J] @ [..., J, 3]
