"""Network building blocks every trainer may use: activations by name, MLPs, frozen parameters, FLOP counting."""

from __future__ import annotations

import itertools
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from typing import Literal

from torch import nn

__all__ = ["MLP", "Activation", "frozen_parameters", "make_activation", "matmul_flops"]

Activation = Literal["elu", "leaky_relu", "relu", "silu", "tanh"]


def make_activation(name: Activation) -> nn.Module:
    """The activation module called ``name`` (LeakyReLU with PyTorch's slope 0.01)."""
    table = {"elu": nn.ELU, "leaky_relu": nn.LeakyReLU, "relu": nn.ReLU, "silu": nn.SiLU, "tanh": nn.Tanh}
    if name not in table:
        raise ValueError(f"unknown activation {name!r}; expected one of: {', '.join(table)}")
    return table[name]()


@contextmanager
def frozen_parameters(module: nn.Module) -> Iterator[None]:
    """``module``'s parameters out of the autograd graph inside the block (a discriminator while its generator
    learns from it), back in after it, however the block ends."""
    for p in module.parameters():
        p.requires_grad_(False)
    try:
        yield
    finally:
        for p in module.parameters():
            p.requires_grad_(True)


class MLP(nn.Sequential):
    """Linear → activation (→ dropout) per hidden size, then a linear output layer.

    Args:
        in_features: Input size.
        hidden: Hidden layer sizes, e.g. ``(512, 512, 512)``.
        out_features: Output size.
        activation: Nonlinearity after each hidden layer.
        dropout: Dropout probability after each hidden activation.
    """

    def __init__(
        self,
        in_features: int,
        hidden: Sequence[int],
        out_features: int,
        *,
        activation: Activation = "elu",
        dropout: float = 0.0,
    ) -> None:
        layers: list[nn.Module] = []
        sizes = [in_features, *hidden]
        for a, b in itertools.pairwise(sizes):
            layers += [nn.Linear(a, b), make_activation(activation)]
            if dropout > 0:
                layers.append(nn.Dropout(dropout))
        layers.append(nn.Linear(sizes[-1], out_features))
        super().__init__(*layers)


def matmul_flops(module: nn.Module, batch_size: int, *, backward: bool = False) -> int:
    """Matrix-multiply FLOPs (2·m·n·k per product) of one forward pass over ``batch_size`` samples.

    Counts every ``nn.Linear`` (2·B·in·out) and every module with a ``matmul_flops(batch_size)`` method
    of its own (e.g. ACE's :class:`~morphkit.retarget.ace.networks.ExpertLinear`) inside ``module``, the same
    convention as ``torch.utils.flop_counter``; elementwise work (activations, softmax, bias adds)
    is left out. With ``backward``, a training step: 3× the forward (gradients with respect to
    inputs and weights each cost a forward), an upper bound by the first layers' input gradients.
    Divide by a step's seconds and compare with ``torch.mm``'s FLOP/s on the same machine.
    """
    total = 0
    for m in module.modules():
        if isinstance(m, nn.Linear):
            total += 2 * batch_size * m.in_features * m.out_features
        elif callable(getattr(m, "matmul_flops", None)):
            total += int(m.matmul_flops(batch_size))
    return 3 * total if backward else total
