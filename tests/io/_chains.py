"""Long serial chains for the big-body tests: built in code, never stored."""

from __future__ import annotations

import numpy as np

from morphkit.graph import Limit, Morphology, MorphologyBuilder, Transform


def chain_morphology(n: int) -> tuple[Morphology, np.ndarray]:
    """A fixed-base chain of ``n`` hinges at random offsets (no rotation) with a hand at its tip, and the offsets
    [n, 3] [m]: at rest the tip sits at their sum."""
    offsets = np.random.default_rng(n).uniform([0.0, -0.01, -0.01], [0.02, 0.01, 0.01], (n, 3))
    b = MorphologyBuilder("chain")
    b.set_base("fixed")
    b.add_link("l0")
    for i, xyz in enumerate(offsets.tolist()):
        b.add_link(f"l{i + 1}")
        b.add_joint_revolute(f"j{i}", f"l{i}", f"l{i + 1}", origin=Transform(tuple(xyz)), axis=(0, 1, 0),
                             limit=Limit(-1.0, 1.0))
    b.add_end_effector("tip", f"l{n}", role="hand")
    return b.build(), offsets
