"""Structural comparison of two morphologies, for round-trip tests across description formats.

Elements are matched by name (not by position), so formats that list siblings in another order
still compare equal; rotations are compared as quaternions up to sign.
"""

from __future__ import annotations

import os

import numpy as np

from morphkit.graph import JointType, Morphology, Shape, ShapeType, Transform

__all__ = ["assert_morphology_equal"]

_ONE_DOF = (JointType.REVOLUTE, JointType.CONTINUOUS, JointType.PRISMATIC)


def _close(a: object, b: object, tol: float, what: str) -> None:
    a_arr = np.asarray(a, dtype=float)
    b_arr = np.asarray(b, dtype=float)
    assert a_arr.shape == b_arr.shape, f"{what}: shapes differ {a_arr.shape} vs {b_arr.shape}"
    err = float(np.abs(a_arr - b_arr).max()) if a_arr.size else 0.0
    assert err <= tol, f"{what}: {a_arr.tolist()} vs {b_arr.tolist()} (max error {err:.3g} > {tol:g})"


def _transform(a: Transform, b: Transform, tol: float, what: str) -> None:
    _close(a.xyz, b.xyz, tol, f"{what} xyz")
    qa = np.asarray(a.quat, dtype=float)
    qb = np.asarray(b.quat, dtype=float)
    err = min(float(np.abs(qa - qb).max()), float(np.abs(qa + qb).max()))
    assert err <= tol, f"{what} rotation: quat {qa.tolist()} vs {qb.tolist()} (max error {err:.3g} > {tol:g})"


def _mesh_path(p: str | None) -> str | None:
    return None if p is None else os.path.normpath(p)


def _shape(a: Shape, b: Shape, tol: float, what: str) -> None:
    assert a.type == b.type, f"{what}: type {a.type.name} vs {b.type.name}"
    _transform(a.origin, b.origin, tol, f"{what} origin")
    if a.type in (ShapeType.SPHERE, ShapeType.CAPSULE, ShapeType.CYLINDER):
        _close(a.radius, b.radius, tol, f"{what} radius")
    if a.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
        _close(a.length, b.length, tol, f"{what} length")
    if a.type == ShapeType.BOX:
        _close(a.size, b.size, tol, f"{what} size")
    if a.type == ShapeType.MESH:
        assert _mesh_path(a.mesh) == _mesh_path(b.mesh), f"{what}: mesh {a.mesh!r} vs {b.mesh!r}"
        _close(a.scale, b.scale, tol, f"{what} scale")


def assert_morphology_equal(a: Morphology, b: Morphology, tol: float = 1e-6, *, check_name: bool = True) -> None:
    """Assert that two morphologies describe the same creature, to ``tol`` on every number.

    Compares: name (unless ``check_name`` is false), base type, root, link names and each
    link's shapes (in order: type, origin, dimensions, mesh path and scale), joints by name
    (type, parent, child, origin with quaternions up to sign, axis for 1-DoF joints, limits
    lower/upper for revolute and prismatic joints, velocity/effort where both sides know them,
    mimic), end-effectors by name (link, offset, role) and wheels (joints, radius).

    Raises:
        AssertionError: naming the first element and field that differ.
    """
    if check_name:
        assert a.name == b.name, f"name: {a.name!r} vs {b.name!r}"
    assert a.base == b.base, f"base: {a.base.name} vs {b.base.name}"
    assert a.root == b.root, f"root: {a.root!r} vs {b.root!r}"

    assert sorted(a.link_names) == sorted(b.link_names), f"links: {a.link_names} vs {b.link_names}"
    for la in a.links:
        lb = b.link(la.name)
        what = f"link {la.name!r}"
        assert len(la.shapes) == len(lb.shapes), f"{what}: {len(la.shapes)} shapes vs {len(lb.shapes)}"
        for i, (sa, sb) in enumerate(zip(la.shapes, lb.shapes, strict=True)):
            _shape(sa, sb, tol, f"{what} shape {i}")

    assert sorted(a.joint_names) == sorted(b.joint_names), f"joints: {a.joint_names} vs {b.joint_names}"
    for ja in a.joints:
        jb = b.joint(ja.name)
        what = f"joint {ja.name!r}"
        assert ja.type == jb.type, f"{what}: type {ja.type.name} vs {jb.type.name}"
        assert (ja.parent, ja.child) == (jb.parent, jb.child), (
            f"{what}: {ja.parent}->{ja.child} vs {jb.parent}->{jb.child}"
        )
        _transform(ja.origin, jb.origin, tol, f"{what} origin")
        if ja.type in _ONE_DOF:
            _close(ja.axis, jb.axis, tol, f"{what} axis")
        if ja.type in (JointType.REVOLUTE, JointType.PRISMATIC):
            assert (ja.limit is None) == (jb.limit is None), f"{what}: limit {ja.limit} vs {jb.limit}"
            if ja.limit is not None and jb.limit is not None:
                _close([ja.limit.lower, ja.limit.upper], [jb.limit.lower, jb.limit.upper], tol, f"{what} limit")
                for field in ("velocity", "effort"):
                    va, vb = getattr(ja.limit, field), getattr(jb.limit, field)
                    if va is not None and vb is not None:
                        _close(va, vb, tol, f"{what} limit {field}")
        assert (ja.mimic is None) == (jb.mimic is None), f"{what}: mimic {ja.mimic} vs {jb.mimic}"
        if ja.mimic is not None and jb.mimic is not None:
            assert ja.mimic.joint == jb.mimic.joint, f"{what}: mimics {ja.mimic.joint!r} vs {jb.mimic.joint!r}"
            _close([ja.mimic.multiplier, ja.mimic.offset], [jb.mimic.multiplier, jb.mimic.offset], tol,
                   f"{what} mimic multiplier/offset")

    ees_a = {e.name: e for e in a.end_effectors}
    ees_b = {e.name: e for e in b.end_effectors}
    assert sorted(ees_a) == sorted(ees_b), f"end-effectors: {sorted(ees_a)} vs {sorted(ees_b)}"
    for name, ea in ees_a.items():
        eb = ees_b[name]
        what = f"end-effector {name!r}"
        assert ea.link == eb.link, f"{what}: link {ea.link!r} vs {eb.link!r}"
        assert ea.role == eb.role, f"{what}: role {ea.role.name} vs {eb.role.name}"
        _close(ea.offset, eb.offset, tol, f"{what} offset")

    assert (a.wheels is None) == (b.wheels is None), f"wheels: {a.wheels} vs {b.wheels}"
    if a.wheels is not None and b.wheels is not None:
        assert a.wheels.joints == b.wheels.joints, f"wheel joints: {a.wheels.joints} vs {b.wheels.joints}"
        _close(a.wheels.radius, b.wheels.radius, tol, "wheel radius")
