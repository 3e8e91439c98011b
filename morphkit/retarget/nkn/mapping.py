"""Motion of one skeleton convention re-expressed on another topology's skeleton (no retargeting involved).

NKN needs characters of one topology. A data set of another convention (another joint list) joins a
run when a *link map* says which of its links each template link is: a source link, or a point
``w`` of the way from link ``a`` to link ``b`` that turns with ``a`` (for a joint the source lacks).
Maps are YAML files in ``morphkit/retarget/data/skeleton_maps/`` (``name``, ``links``); one applies
when its links are exactly the template's and every source name is a link of the clip's skeleton.

The machinery is the canonical human's (:mod:`morphkit.motion.canonical`, step 1, with every bone
aligned): the mapped skeleton keeps the template's topology and rest directions, with the source's bone
lengths, so its rest pose is the template's (a T-pose for CMU) whatever the source's rest pose is, and
FK of the mapped skeleton puts every link exactly where the source's is.
"""

from __future__ import annotations

from importlib import resources
from typing import Any

from morphkit.graph import Morphology
from morphkit.motion import Motion
from morphkit.motion.canonical import SkeletonMap, map_skeleton_motion, plan_skeleton_map, skeleton_maps

__all__ = ["LinkMap", "find_link_map", "link_maps", "map_motion", "mapped_skeleton"]

LinkMap = SkeletonMap
"""A link map is a convention table (:class:`~morphkit.motion.canonical.SkeletonMap`)."""


def link_maps() -> list[LinkMap]:
    """The link maps shipped in ``morphkit/retarget/data/skeleton_maps/``."""
    folder = resources.files("morphkit.retarget").joinpath("data/skeleton_maps")
    with resources.as_file(folder) as path:
        return skeleton_maps(path)


def find_link_map(source: Morphology, template: Morphology) -> LinkMap | None:
    """The first shipped map from ``source``'s convention onto ``template``'s, if any."""
    return next((m for m in link_maps() if m.applies(source, template)), None)


def mapped_skeleton(source: Morphology, template: Morphology, link_map: LinkMap, *, name: str) -> Morphology:
    """The template-topology skeleton with ``source``'s bone lengths (see the module docstring)."""
    return plan_skeleton_map(source, template, link_map, name=name).skeleton


def map_motion(motion: Motion, template: Morphology, link_map: LinkMap, *, skeleton_name: str,
               plan: Any = None) -> Motion:
    """``motion`` re-expressed on the mapped skeleton of ``template``'s topology (same link positions).

    Raises:
        MotionFormatError: the map does not fit the clip's skeleton.
    """
    return map_skeleton_motion(motion, template, link_map, skeleton_name=skeleton_name, plan=plan)
