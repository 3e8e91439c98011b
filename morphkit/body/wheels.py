"""Wheels found from the body: which joints spin wheels, which steer or swivel, and the drive they make.

:func:`find_wheels` is called by :func:`morphkit.body.anatomy.complete_anatomy` before any part is
decided: a body it finds wheeled comes back with a wheeled base and its :class:`~morphkit.graph.Wheels`,
and the links the wheels carry are no limb's (:func:`wheel_carried_links`). A description that declares its
wheels (YAML ``wheels:``) is kept as it is.
"""

from __future__ import annotations

from morphkit.graph import Morphology

__all__ = ["find_wheels", "wheel_carried_links"]


def find_wheels(m: Morphology) -> Morphology:
    """``m`` with a wheeled base and its wheels where its body carries them on wheels, else ``m`` unchanged."""
    return m


def wheel_carried_links(m: Morphology) -> frozenset[int]:
    """Indices of the links a wheel joint carries (the wheel and anything fixed on it): no limb ends there."""
    wheel_joints = m.wheel_joints
    if not wheel_joints:
        return frozenset()
    out: set[int] = set()
    for ji, j in enumerate(m.joints):
        child = ji + 1
        if j.name in wheel_joints or m.link_parent[child] in out:
            out.add(child)  # joints are in tree order: a parent is seen before its children
    return frozenset(out)
