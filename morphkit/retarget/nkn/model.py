"""NKN's networks (§4.1, App. E): the GRU encoder/decoder with its FK layer, and the discriminator.

Notation (§4.1): source motion $x_{1:T} = [p, v]$ normalised, target skeleton offsets $\\bar s$,
encoder state $h^{enc}_t = \\mathrm{RNN}^{enc}(x_t, h^{enc}_{t-1})$ (Eq. 2), decoder state
$h^{dec}_t = \\mathrm{RNN}^{dec}([\\bar s, \\hat x_{t-1}, h^{enc}_t], h^{dec}_{t-1})$ (Eq. 3), one linear head
$W h^{dec}_t$ giving the target's coordinates (quaternions, Eq. 4) and the global motion $\\hat v_t$
(Eq. 6), and $\\hat p_t = \\mathrm{FK}(\\hat q_t, \\bar s)$ (Eq. 5) through :class:`~.fk.SkeletonFK`.

The head has one output block per coordinate of the **target** morphology (:class:`CoordinateHead`),
so the target may have another joint count than the source (the cross-morphology mode): a ball
joint or a floating base's orientation is a raw quaternion (bias: identity; the FK normalises it),
a limited 1-DoF joint is $m + h \\tanh(a)$ inside its limits (bias: the data's mean value), an unlimited
revolute joint an angle $\\operatorname{atan2}(s, c)$, a floating base's height an affine output. Root
height and root velocity are scaled by the target's leg length over the mean training skeleton's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from morphkit.graph import BaseType, EndEffectorRole, JointType, Morphology
from morphkit.motion import NormStats
from morphkit.retarget.nkn.config import NknConfig
from morphkit.retarget.nkn.features import GLOBAL_DIM
from morphkit.retarget.nkn.fk import SkeletonFK
from morphkit.retarget.nkn.skeleton import twist_axes

__all__ = ["CoordinateHead", "GeneratorOutput", "NknDiscriminator", "NknGenerator", "Side", "motion_differences"]


class CoordinateHead(nn.Module):
    """Maps raw head outputs [..., raw_dim] to a morphology's local coordinates ``q`` [..., C].

    Local: the base sits at the ground frame's origin (:mod:`~.features`) (x = y = 0, no yaw for planar and wheeled
    bases); a floating base keeps its height and its orientation in the heading axes.

    Args:
        morphology: The target skeleton.
        height: ``(mean, std)`` of the floating base's height [m] (its output is normalised by them).
        joint_init: Initial joint coordinates [C] for the bias of 1-DoF joints (default: rest).
    """

    def __init__(self, morphology: Morphology, *, height: tuple[float, float] = (0.0, 1.0),
                 joint_init: np.ndarray | None = None) -> None:
        super().__init__()
        m = morphology
        init = np.asarray(joint_init if joint_init is not None else m.rest_q(), dtype=float)
        raw = 0
        bias: list[float] = []
        quat_raw, quat_q = [], []
        lim_raw, lim_q, lim_mid, lim_half = [], [], [], []
        circ_raw, circ_q = [], []
        free_raw, free_q, free_init = [], [], []
        height_raw = -1
        if m.base == BaseType.FLOATING:
            quat_raw.append(list(range(0, 4)))
            quat_q.append(list(range(3, 7)))
            bias += [0.0, 0.0, 0.0, 1.0]
            height_raw = 4
            bias.append(0.0)
            raw = 5
        twist_joint = []
        for j, start in zip(m.joints, m.joint_q_start[:-1], strict=True):
            if m.is_driven(j):
                continue
            if j.type == JointType.SPHERICAL:
                quat_raw.append(list(range(raw, raw + 4)))
                quat_q.append(list(range(start, start + 4)))
                twist_joint.append(m.joint_index(j.name))
                bias += [0.0, 0.0, 0.0, 1.0]
                raw += 4
            elif j.type in (JointType.REVOLUTE, JointType.PRISMATIC) and j.limit is not None:
                mid, half = 0.5 * (j.limit.lower + j.limit.upper), max(0.5 * (j.limit.upper - j.limit.lower), 1e-6)
                lim_raw.append(raw)
                lim_q.append(start)
                lim_mid.append(mid)
                lim_half.append(half)
                bias.append(float(np.arctanh(np.clip((init[start] - mid) / half, -0.95, 0.95))))
                raw += 1
            elif j.type in (JointType.REVOLUTE, JointType.CONTINUOUS):
                circ_raw.append([raw, raw + 1])
                circ_q.append(start)
                bias += [float(np.cos(init[start])), float(np.sin(init[start]))]
                raw += 2
            elif j.type == JointType.PRISMATIC:
                free_raw.append(raw)
                free_q.append(start)
                free_init.append(float(init[start]))
                bias.append(0.0)
                raw += 1
        self.coordinate_count = m.coordinate_count
        self.raw_dim = raw
        """Raw outputs for the coordinates (the head adds :data:`~.features.GLOBAL_DIM` for the global motion)."""
        self.height_raw = height_raw
        self.spherical_quat_count = len(twist_joint)
        self.register_buffer("bias_init", torch.tensor(bias, dtype=torch.float32), persistent=False)
        long = torch.long
        self.register_buffer("quat_raw", torch.tensor(quat_raw, dtype=long).reshape(-1, 4), persistent=False)
        self.register_buffer("quat_q", torch.tensor(quat_q, dtype=long).reshape(-1, 4), persistent=False)
        self.register_buffer("lim_raw", torch.tensor(lim_raw, dtype=long), persistent=False)
        self.register_buffer("lim_q", torch.tensor(lim_q, dtype=long), persistent=False)
        self.register_buffer("lim_mid", torch.tensor(lim_mid, dtype=torch.float32), persistent=False)
        self.register_buffer("lim_half", torch.tensor(lim_half, dtype=torch.float32), persistent=False)
        self.register_buffer("circ_raw", torch.tensor(circ_raw, dtype=long).reshape(-1, 2), persistent=False)
        self.register_buffer("circ_q", torch.tensor(circ_q, dtype=long), persistent=False)
        self.register_buffer("free_raw", torch.tensor(free_raw, dtype=long), persistent=False)
        self.register_buffer("free_q", torch.tensor(free_q, dtype=long), persistent=False)
        self.register_buffer("free_init", torch.tensor(free_init, dtype=torch.float32), persistent=False)
        self.register_buffer("height", torch.tensor(height, dtype=torch.float32), persistent=False)
        axes = twist_axes(m)[twist_joint] if twist_joint else np.zeros((0, 3))
        self.register_buffer("twist_axes", torch.tensor(axes, dtype=torch.float32), persistent=False)
        """Bone axes [S, 3] of the ball joints, in their joint frames (for the twist loss)."""
        # Where the ball joints' quaternions sit among quat_raw (the floating base's comes first).
        self._joint_quats = slice(1, None) if m.base == BaseType.FLOATING else slice(None)

    def decode(self, raw: torch.Tensor, height_scale: torch.Tensor | None = None) -> torch.Tensor:
        """Local coordinates ``q`` [..., C] of raw outputs [..., raw_dim] (height times ``height_scale`` [...])."""
        q = raw.new_zeros((*raw.shape[:-1], self.coordinate_count))
        dt = raw.dtype
        if self.quat_raw.numel():
            q = q.index_copy(-1, self.quat_q.flatten(), raw[..., self.quat_raw.flatten()])
        if self.height_raw >= 0:
            h = self.height[0].to(dt) + self.height[1].to(dt) * raw[..., self.height_raw : self.height_raw + 1]
            if height_scale is not None:
                h = h * height_scale[..., None]
            q = q.index_copy(-1, torch.tensor([2], device=raw.device), h)
        if self.lim_raw.numel():
            values = self.lim_mid.to(dt) + self.lim_half.to(dt) * torch.tanh(raw[..., self.lim_raw])
            q = q.index_copy(-1, self.lim_q, values)
        if self.circ_raw.numel():
            cs = raw[..., self.circ_raw]  # [..., M, 2]
            q = q.index_copy(-1, self.circ_q, torch.atan2(cs[..., 1], cs[..., 0]))
        if self.free_raw.numel():
            q = q.index_copy(-1, self.free_q, self.free_init.to(dt) + raw[..., self.free_raw])
        return q

    def joint_quaternions(self, raw: torch.Tensor) -> torch.Tensor:
        """Unit quaternions [..., S, 4] (xyzw) of the ball joints (the base excluded, as the release)."""
        quats = raw[..., self.quat_raw[self._joint_quats]]
        return quats / quats.norm(dim=-1, keepdim=True).clamp_min(1e-8)


class Side(nn.Module):
    """One skeleton topology as seen by the networks: FK, coordinate head and normalisation.

    Buffers (saved with the networks): ``x_mean``/``x_std`` [3L + 4] of the features $[p, v]$ and
    ``offset_mean``/``offset_std`` [3J] of the bone offsets.
    """

    def __init__(self, template: Morphology, features: NormStats, offsets: NormStats, *,
                 fk_backend: str = "warp", joint_init: np.ndarray | None = None) -> None:
        super().__init__()
        self.template = template
        self.link_count = template.link_count
        self.joint_count = template.joint_count
        self.fk = SkeletonFK(template, backend=fk_backend)  # type: ignore[arg-type]
        height = (float(features.mean[2]), float(features.std[2]))  # the root link's local z
        self.head = CoordinateHead(template, height=height, joint_init=joint_init)
        self.register_buffer("x_mean", torch.tensor(features.mean, dtype=torch.float32))
        self.register_buffer("x_std", torch.tensor(features.std, dtype=torch.float32))
        self.register_buffer("offset_mean", torch.tensor(offsets.mean, dtype=torch.float32))
        self.register_buffer("offset_std", torch.tensor(offsets.std, dtype=torch.float32))
        # Leg length as a weighted sum of bone lengths: the bones Morphology.leg_length adds up, per foot, averaged.
        weights = np.zeros(template.joint_count)
        feet = template.ee_by_role(EndEffectorRole.FOOT)
        chains = template.end_effector_chains
        uses: dict[str, int] = {}
        for chain in chains.values():
            for n in chain:
                uses[n] = uses.get(n, 0) + 1
        for ee in feet:
            own = [n for n in chains[ee.name] if uses[n] == 1]
            for n in own[1:]:
                weights[template.joint_index(n)] += 1.0 / len(feet)
        self.register_buffer("leg_weights", torch.tensor(weights, dtype=torch.float32), persistent=False)
        mean_offsets = torch.tensor(offsets.mean, dtype=torch.float32).reshape(-1, 3)
        reference = float((self.leg_weights * mean_offsets.norm(dim=-1)).sum())
        self.leg_reference = reference if reference > 1e-9 else 0.0
        """Leg length [m] of the mean training skeleton (0: no legs, no scaling)."""

    @property
    def feature_dim(self) -> int:
        """3L + 4."""
        return 3 * self.link_count + GLOBAL_DIM

    def normalize(self, p: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
        """$[p, v]$ normalised, [..., 3L + 4], from local positions [..., L, 3] [m] and global motion [..., 4]."""
        x = torch.cat([p.flatten(-2), v], dim=-1)
        return (x - self.x_mean.to(x.dtype)) / self.x_std.to(x.dtype)

    def normalize_features(self, x: torch.Tensor) -> torch.Tensor:
        """Features $[p, v]$ [..., 3L + 4] (flattened, [m], [m/s], [rad/s]) normalised."""
        return (x - self.x_mean.to(x.dtype)) / self.x_std.to(x.dtype)

    def split(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(p [..., L, 3], v [..., 4])`` of features [..., 3L + 4] that are not normalised."""
        return x[..., :-GLOBAL_DIM].unflatten(-1, (self.link_count, 3)), x[..., -GLOBAL_DIM:]

    def denormalize(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """``(p [..., L, 3], v [..., 4])`` from normalised features [..., 3L + 4]."""
        x = x * self.x_std.to(x.dtype) + self.x_mean.to(x.dtype)
        return x[..., :-GLOBAL_DIM].unflatten(-1, (self.link_count, 3)), x[..., -GLOBAL_DIM:]

    def leg_scale(self, offsets: torch.Tensor) -> torch.Tensor:
        """Leg length of skeletons with bone offsets [..., J, 3] over the mean training skeleton's, shape [...]."""
        if self.leg_reference <= 0.0:
            return offsets.new_ones(offsets.shape[:-2])
        return (self.leg_weights.to(offsets.dtype) * offsets.norm(dim=-1)).sum(-1) / self.leg_reference

    def normalize_offsets(self, offsets: torch.Tensor) -> torch.Tensor:
        """Bone offsets [..., J, 3] [m] → normalised [..., 3J] (the decoder's and D's condition)."""
        o = offsets.flatten(-2)
        return (o - self.offset_mean.to(o.dtype)) / self.offset_std.to(o.dtype)


@dataclass(frozen=True)
class GeneratorOutput:
    """What one pass of :class:`NknGenerator` gives, each [B, T, ...]."""

    x: torch.Tensor
    """Normalised features $\\hat x = [\\hat p, \\hat v]$ [B, T, 3L + 4]."""
    p: torch.Tensor
    """Local link positions $\\hat p$ [B, T, L, 3] [m] (FK of the target skeleton)."""
    v: torch.Tensor
    """Global motion $\\hat v$ [B, T, 4] (denormalised: m/s, rad/s)."""
    q: torch.Tensor
    """Local coordinates $\\hat q$ [B, T, C] of the target morphology."""
    quats: torch.Tensor
    """Unit quaternions of the ball joints [B, T, S, 4] (the twist loss's input)."""


class NknGenerator(nn.Module):
    """The neural kinematic network $f(x^A, \\bar s^B)$ (Fig. 3): source motion in, the target's motion out.

    Args:
        source_dim: Size of the normalised source features (3L + 4 of the source topology).
        side: The target topology (its FK, head and normalisation).
        cfg: Sizes and dropout (``hidden``, ``layers``, ``keep_prob``, ``head_init_std``).
    """

    def __init__(self, source_dim: int, side: Side, cfg: NknConfig) -> None:
        super().__init__()
        self.side = side
        drop = 1.0 - cfg.keep_prob
        H = cfg.hidden
        self.input_dropout = nn.Dropout(drop)
        # nn.GRU's dropout acts on the inputs of layers 2.. ; with input_dropout every layer's input drops.
        self.encoder = nn.GRU(source_dim, H, cfg.layers, batch_first=True, dropout=drop if cfg.layers > 1 else 0.0)
        dec_in = 3 * side.joint_count + side.feature_dim + H
        self.decoder = nn.ModuleList([nn.GRUCell(dec_in if i == 0 else H, H) for i in range(cfg.layers)])
        self.decoder_dropout = nn.Dropout(drop)
        self.head = nn.Linear(H, side.head.raw_dim + GLOBAL_DIM)
        with torch.no_grad():
            self.head.weight.normal_(0.0, cfg.head_init_std)
            self.head.bias.zero_()
            self.head.bias[: side.head.raw_dim] = side.head.bias_init

    def encode(self, x: torch.Tensor) -> torch.Tensor:
        """$h^{enc}_{1:T}$ of the top layer [B, T, H] from normalised source features [B, T, D_s]."""
        return self.encoder(self.input_dropout(x))[0]

    def forward(self, x: torch.Tensor, offsets: torch.Tensor) -> GeneratorOutput:
        """Retarget normalised source features ``x`` [B, T, D_s] onto skeletons with bone offsets [B, J, 3] [m]."""
        B, T, _ = x.shape
        side = self.side
        h_enc = self.encode(x)
        cond = side.normalize_offsets(offsets)  # [B, 3J]
        fk_offsets = offsets[:, None]  # [B, 1, J, 3]
        # Root height and root velocity are predicted per unit of the target's leg length (morphkit's choice).
        scale = side.leg_scale(offsets)  # [B]
        v_mean, v_std = side.x_mean[-GLOBAL_DIM:].to(x.dtype), side.x_std[-GLOBAL_DIM:].to(x.dtype)
        v_scale = torch.stack([scale, scale, scale, torch.ones_like(scale)], dim=-1)  # yaw rate unscaled
        hidden = [x.new_zeros(B, cell.hidden_size) for cell in self.decoder]
        prev = x.new_zeros(B, side.feature_dim)
        raws, xs, ps, qs = [], [], [], []
        for t in range(T):
            inp = torch.cat([cond, prev, h_enc[:, t]], dim=-1)
            for i, cell in enumerate(self.decoder):
                hidden[i] = cell(self.decoder_dropout(inp), hidden[i])
                inp = hidden[i]
            raw = self.head(inp)  # [B, raw_dim + 4]
            q = side.head.decode(raw[:, : side.head.raw_dim], scale)
            p = side.fk(q[:, None], fk_offsets)[:, 0]  # [B, L, 3]
            v_norm = ((v_mean + v_std * raw[:, side.head.raw_dim :]) * v_scale - v_mean) / v_std
            x_t = torch.cat([side.normalize(p, x.new_zeros(B, GLOBAL_DIM))[:, :-GLOBAL_DIM], v_norm], dim=-1)
            raws.append(raw)
            xs.append(x_t)
            ps.append(p)
            qs.append(q)
            prev = x_t
        raw = torch.stack(raws, 1)
        x_hat = torch.stack(xs, 1)
        _, v = side.denormalize(x_hat)
        return GeneratorOutput(x_hat, torch.stack(ps, 1), v, torch.stack(qs, 1),
                               side.head.joint_quaternions(raw[..., : side.head.raw_dim]))


def _same_pad(x: torch.Tensor, kernel: int, stride: int) -> torch.Tensor:
    """TensorFlow's "SAME" padding for a 1-D convolution (output length ceil(L / stride))."""
    length = x.shape[-1]
    out = -(-length // stride)
    total = max((out - 1) * stride + kernel - length, 0)
    return F.pad(x, (total // 2, total - total // 2))


class NknDiscriminator(nn.Module):
    """The realism score $g$ (Eq. 11–12, App. E) of motion differences, conditioned on the skeleton.

    Input per clip: $[p_{2:T} - p_{1:T-1}, v_{1:T-1}]$ (denormalised) [B, T − 1, 3L + 4] and the
    normalised bone offsets [B, 3J], tiled over time and concatenated after layers 2, 3 and 4 (as the
    release). Four convolutions (kernel 4, stride 2, "same", LeakyReLU 0.2; norm after 2–4), then a
    one-channel "valid" convolution averaged over the remaining frames: one logit per clip.

    Args:
        motion_dim: 3L + 4.
        offset_dim: 3J.
        frames: Frames of the difference sequence (T − 1); sets the last kernel.
        cfg: ``d_channels``, ``d_norm``, ``d_keep_prob``.
    """

    def __init__(self, motion_dim: int, offset_dim: int, frames: int, cfg: NknConfig) -> None:
        super().__init__()
        c = tuple(cfg.d_channels)
        if len(c) != 4:
            raise ValueError(f"d_channels must list 4 widths, got {c}")
        self.convs = nn.ModuleList([
            nn.Conv1d(motion_dim, c[0], 4, stride=2),
            nn.Conv1d(c[0], c[1], 4, stride=2),
            nn.Conv1d(c[1] + offset_dim, c[2], 4, stride=2),
            nn.Conv1d(c[2] + offset_dim, c[3], 4, stride=2),
        ])
        if cfg.d_norm == "batch":
            self.norms = nn.ModuleList([nn.BatchNorm1d(w, momentum=0.1, eps=1e-5) for w in c[1:]])
        else:
            self.norms = nn.ModuleList([nn.InstanceNorm1d(w, affine=True) for w in c[1:]])
        length = frames
        for _ in range(4):
            length = -(-length // 2)
        self.final = nn.Conv1d(c[3] + offset_dim, 1, min(4, length))
        self.input_drop = 1.0 - cfg.d_keep_prob if cfg.d_norm != "instance" else 0.0

    def forward(self, motion: torch.Tensor, offsets: torch.Tensor, *, input_dropout: bool = False) -> torch.Tensor:
        """Logits [B] of motion differences [B, T − 1, 3L + 4] on skeletons with normalised offsets [B, 3J]."""
        h = motion.transpose(1, 2)  # [B, D, T-1]
        if input_dropout and self.input_drop > 0:
            h = F.dropout(h, self.input_drop, training=True)
        for i, conv in enumerate(self.convs):
            h = conv(_same_pad(h, 4, 2))
            if i > 0:
                h = self.norms[i - 1](h)
            h = F.leaky_relu(h, 0.2)
            if i > 0:
                h = torch.cat([h, offsets[:, :, None].expand(-1, -1, h.shape[-1])], dim=1)
        return self.final(h).mean(dim=(1, 2))


def motion_differences(p: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """D's input $[p_{2:T} - p_{1:T-1}, v_{1:T-1}]$ [B, T − 1, 3L + 4] from $p$ [B, T, L, 3] and $v$ [B, T, 4]."""
    return torch.cat([(p[:, 1:] - p[:, :-1]).flatten(-2), v[:, :-1]], dim=-1)
