"""What a body is, answered once: its parts and their roles, its stance, its reference kinematics.

Readers (:mod:`morphkit.io`) turn files into a graph; this package answers the questions a file leaves
open — which ends are feet, hands, heads or tools, how the body stands, which names hint at what — with
one rule for descriptions and BVH skeletons alike. It sits above :mod:`morphkit.graph` and below the
readers, and imports neither Warp nor torch.
"""

from __future__ import annotations

from morphkit.body.anatomy import ANATOMY as ANATOMY
from morphkit.body.anatomy import AnatomyConfig as AnatomyConfig
from morphkit.body.anatomy import Frame as Frame
from morphkit.body.anatomy import anatomy_warnings as anatomy_warnings
from morphkit.body.anatomy import complete_anatomy as complete_anatomy
from morphkit.body.anatomy import leg_like_chains as leg_like_chains
from morphkit.body.kinematics import BodyKinematics as BodyKinematics
from morphkit.body.roles import PART_WORDS as PART_WORDS
from morphkit.body.roles import PartWords as PartWords
from morphkit.body.roles import keyword_role as keyword_role
from morphkit.body.roles import name_hint as name_hint

__all__ = [
    "ANATOMY",
    "PART_WORDS",
    "AnatomyConfig",
    "BodyKinematics",
    "Frame",
    "PartWords",
    "anatomy_warnings",
    "complete_anatomy",
    "keyword_role",
    "leg_like_chains",
    "name_hint",
]
