"""Signed distances between primitive shapes and to the ground plane (``@wp.func`` helpers).

Every function returns a **signed distance** [m]: positive when the shapes are apart, negative
when they overlap (then ``-distance`` is the penetration depth). All helpers are generic over
the float type (``wp.float32`` or ``wp.float64``; vectors and transforms of the same scalar),
branch-free where they can be and differentiable almost everywhere by Warp's adjoints.

Shapes follow :attr:`morphkit.model.KinematicModel.shape_params`: a pose ``X`` (``T_world_shape``,
a ``wp.transform``) and ``params`` (a vec3): sphere ``(radius, 0, 0)``; capsule and cylinder
``(radius, half_length, 0)`` with the axis along the shape's local z (a capsule's half length is
that of its cylindrical part, without the caps); box ``(hx, hy, hz)`` half extents.

Which pairs are exact and which are approximations (:data:`PAIR_DISTANCE_KIND`):

============================  ==========================================================================
sphere–sphere/capsule/box      exact.
sphere–cylinder                exact (2-D box distance in the cylinder's radial/axial coordinates).
capsule–capsule                exact (segment–segment distance minus both radii).
capsule–box                    exact when apart; when overlapping, the depth of the capsule's deepest
                               axis point below the box surface plus the radius.
box–box                        separating-axis test over the 15 axes: the exact (minimum-translation)
                               depth when overlapping; a lower bound on the distance when apart
                               (exact when the closest features are face–vertex, face–face or
                               edge–edge), so a contact is never missed.
cylinder–capsule/box/cylinder  approximate: the cylinder is replaced by its bounding capsule (same
                               radius and axis segment), which over-reports contact by up to one
                               radius near the flat ends.
anything–ground plane          exact for all four shapes (the lowest point of the shape).
mesh–anything                  unsupported: :func:`pair_distance_kind` raises; kernels return
                               :data:`NO_CONTACT_DISTANCE`.
============================  ==========================================================================

For overlapping sphere-swept shapes (sphere, capsule) the signed distance is the distance
between their core points/segments minus the radii: the test "two crossing capsules whose axes
are ``d`` apart" has depth ``r1 + r2 - d``.
"""

from __future__ import annotations

from typing import Any

import warp as wp

from morphkit.errors import GraphError
from morphkit.graph.types import ShapeType

__all__ = [
    "NO_CONTACT_DISTANCE",
    "PAIR_DISTANCE_KIND",
    "box_box_distance",
    "box_plane_distance",
    "box_sdf",
    "capsule_box_distance",
    "capsule_capsule_distance",
    "capsule_endpoints",
    "capsule_plane_distance",
    "closest_point_on_segment",
    "cylinder_plane_distance",
    "cylinder_sdf",
    "pair_distance_kind",
    "segment_segment_closest",
    "shape_ground_distance",
    "shape_pair_distance",
    "sphere_box_distance",
    "sphere_capsule_distance",
    "sphere_cylinder_distance",
    "sphere_plane_distance",
    "sphere_sphere_distance",
]

SHAPE_SPHERE = wp.constant(int(ShapeType.SPHERE))
SHAPE_CAPSULE = wp.constant(int(ShapeType.CAPSULE))
SHAPE_BOX = wp.constant(int(ShapeType.BOX))
SHAPE_CYLINDER = wp.constant(int(ShapeType.CYLINDER))

NO_CONTACT_DISTANCE = 1.0e6
"""Distance [m] the kernels report for unsupported pairs (meshes): far apart, never in contact."""

_EXACT = "exact"
_APPROX = "approximate"
_SUPPORTED = (ShapeType.SPHERE, ShapeType.CAPSULE, ShapeType.BOX, ShapeType.CYLINDER)

PAIR_DISTANCE_KIND: dict[tuple[ShapeType, ShapeType], str] = {
    (ShapeType.SPHERE, ShapeType.SPHERE): _EXACT,
    (ShapeType.SPHERE, ShapeType.CAPSULE): _EXACT,
    (ShapeType.SPHERE, ShapeType.BOX): _EXACT,
    (ShapeType.SPHERE, ShapeType.CYLINDER): _EXACT,
    (ShapeType.CAPSULE, ShapeType.CAPSULE): _EXACT,
    (ShapeType.CAPSULE, ShapeType.BOX): _EXACT,
    (ShapeType.CAPSULE, ShapeType.CYLINDER): _APPROX,
    (ShapeType.BOX, ShapeType.BOX): _APPROX,
    (ShapeType.BOX, ShapeType.CYLINDER): _APPROX,
    (ShapeType.CYLINDER, ShapeType.CYLINDER): _APPROX,
}
"""How each shape-type pair (in ``ShapeType`` order) is measured: ``"exact"`` or ``"approximate"``
(see the module docstring for what each approximation means)."""


def pair_distance_kind(type_a: ShapeType | int, type_b: ShapeType | int) -> str:
    """``"exact"`` or ``"approximate"`` for a shape-type pair, in either order (symmetric fallback).

    Raises:
        GraphError: naming both types when the pair has no distance function (meshes).
    """
    a, b = ShapeType(int(type_a)), ShapeType(int(type_b))
    kind = PAIR_DISTANCE_KIND.get((a, b)) or PAIR_DISTANCE_KIND.get((b, a))
    if kind is None:
        supported = ", ".join(t.name.lower() for t in _SUPPORTED)
        raise GraphError(
            f"no signed distance between shapes {a.name.lower()} and {b.name.lower()} (supported: {supported})"
        )
    return kind


# ---- points and segments ---------------------------------------------------------------------
@wp.func
def closest_point_on_segment(p: Any, a: Any, b: Any):
    """Closest point to ``p`` on the segment ``[a, b]`` (a degenerate segment is the point ``a``)."""
    ab = b - a
    denom = wp.dot(ab, ab)
    zero = denom * type(denom)(0.0)
    t = zero
    if denom > zero:
        t = wp.clamp(wp.dot(p - a, ab) / denom, zero, type(denom)(1.0))
    return a + ab * t


@wp.func
def segment_segment_closest(p1: Any, q1: Any, p2: Any, q2: Any):
    """Parameters ``(s, t)`` in [0, 1]² of the closest points ``p1 + s (q1 - p1)`` and ``p2 + t (q2 - p2)``.

    Ericson, *Real-Time Collision Detection*, §5.1.9 (clamped closest points of two segments,
    degenerate segments and parallel segments included).
    """
    d1 = q1 - p1
    d2 = q2 - p2
    r = p1 - p2
    a = wp.dot(d1, d1)
    e = wp.dot(d2, d2)
    f = wp.dot(d2, r)
    zero = a * type(a)(0.0)
    one = type(a)(1.0)
    eps = type(a)(1.0e-12)
    s = zero
    t = zero
    if a <= eps and e <= eps:
        s = zero
        t = zero
    elif a <= eps:
        s = zero
        t = wp.clamp(f / e, zero, one)
    else:
        c = wp.dot(d1, r)
        if e <= eps:
            t = zero
            s = wp.clamp(-c / a, zero, one)
        else:
            b = wp.dot(d1, d2)
            denom = a * e - b * b
            # Parallel segments (denom 0): any s works; pick 0 and let the clamps below fix t.
            if denom > eps * a * e:
                s = wp.clamp((b * f - c * e) / denom, zero, one)
            else:
                s = zero
            t = (b * s + f) / e
            if t < zero:
                t = zero
                s = wp.clamp(-c / a, zero, one)
            elif t > one:
                t = one
                s = wp.clamp((b - c) / a, zero, one)
    return wp.vector(s, t)


@wp.func
def capsule_endpoints(X: Any, half_length: Any):
    """World endpoints ``(a, b)`` of a capsule's (or cylinder's) axis segment along its local ±z."""
    c = wp.transform_get_translation(X)
    zero = half_length * type(half_length)(0.0)
    axis = wp.quat_rotate(wp.transform_get_rotation(X), type(c)(zero, zero, half_length))
    return c - axis, c + axis


# ---- signed distance fields of solids (in the solid's frame) ----------------------------------
@wp.func
def box_sdf(p: Any, h: Any):
    """Exact signed distance from ``p`` (box frame) to the box of half extents ``h``."""
    d = wp.abs(p) - h
    zero = d[0] * type(d[0])(0.0)
    outside = wp.length(wp.max(d, type(d)(zero, zero, zero)))
    inside = wp.min(wp.max(d[0], wp.max(d[1], d[2])), zero)
    return outside + inside


@wp.func
def cylinder_sdf(p: Any, radius: Any, half_length: Any):
    """Exact signed distance from ``p`` (cylinder frame, axis z) to a solid cylinder."""
    dr = wp.sqrt(p[0] * p[0] + p[1] * p[1]) - radius
    dz = wp.abs(p[2]) - half_length
    zero = dr * type(dr)(0.0)
    ox = wp.max(dr, zero)
    oz = wp.max(dz, zero)
    return wp.sqrt(ox * ox + oz * oz) + wp.min(wp.max(dr, dz), zero)


# ---- shape pairs ---------------------------------------------------------------------------
@wp.func
def sphere_sphere_distance(c1: Any, r1: Any, c2: Any, r2: Any):
    """Signed distance between two spheres (exact)."""
    return wp.length(c1 - c2) - r1 - r2


@wp.func
def sphere_capsule_distance(c: Any, r: Any, a: Any, b: Any, rc: Any):
    """Signed distance between a sphere and the capsule with axis segment ``[a, b]`` (exact)."""
    return wp.length(c - closest_point_on_segment(c, a, b)) - r - rc


@wp.func
def capsule_capsule_distance(a1: Any, b1: Any, r1: Any, a2: Any, b2: Any, r2: Any):
    """Signed distance between two capsules: segment–segment distance minus both radii."""
    st = segment_segment_closest(a1, b1, a2, b2)
    p1 = a1 + (b1 - a1) * st[0]
    p2 = a2 + (b2 - a2) * st[1]
    return wp.length(p1 - p2) - r1 - r2


@wp.func
def sphere_box_distance(c: Any, r: Any, X_box: Any, h: Any):
    """Signed distance between a sphere and a box of half extents ``h`` posed by ``X_box`` (exact)."""
    return box_sdf(wp.transform_point(wp.transform_inverse(X_box), c), h) - r


@wp.func
def sphere_cylinder_distance(c: Any, r: Any, X_cyl: Any, radius: Any, half_length: Any):
    """Signed distance between a sphere and a cylinder (exact)."""
    return cylinder_sdf(wp.transform_point(wp.transform_inverse(X_cyl), c), radius, half_length) - r


@wp.func
def _box_line_outside_sq(a: Any, u: Any, h: Any, t: Any):
    # Squared distance from a + t u to the box (zero inside): C¹ and convex in t.
    p = a + u * t
    d = wp.abs(p) - h
    zero = t * type(t)(0.0)
    o = wp.max(d, type(d)(zero, zero, zero))
    return wp.dot(o, o)


@wp.func
def _box_line_inside(a: Any, u: Any, h: Any, t: Any):
    # max_i(|p_i| - h_i): equals the box SDF wherever it is <= 0; convex, piecewise linear in t.
    d = wp.abs(a + u * t) - h
    return wp.max(d[0], wp.max(d[1], d[2]))


@wp.func
def _sign_of(k: int, x: Any):
    # +1 for k = 0, -1 for k = 1, in the float type of x.
    return type(x)(1.0) - type(x)(2.0) * type(x)(float(k))


@wp.func
def _pattern_signs(pattern: int, u: Any):
    # Region pattern 0..26 -> per-axis sign in {-1, 0, +1} (below, within, above the slab), as u's type.
    return type(u)(
        type(u[0])(float(pattern // 9 - 1)),
        type(u[0])(float((pattern // 3) % 3 - 1)),
        type(u[0])(float(pattern % 3 - 1)),
    )


@wp.func
def _capsule_box_t(a: Any, u: Any, h: Any, code: int):
    """Line parameter of candidate ``code`` (see :func:`_capsule_box_search`), differentiable in a, u, h."""
    zero = h[0] * type(h[0])(0.0)
    one = type(h[0])(1.0)
    t = zero
    if code == 1 or code == 101:
        t = one
    elif code >= 2 and code < 100:
        c = code - 2
        i = c // 12
        j = (c // 2) % 3
        si = _sign_of((c // 6) % 2, zero)
        sj = _sign_of(c % 2, zero)
        t = ((sj * a[j] - h[j]) - (si * a[i] - h[i])) / (si * u[i] - sj * u[j])
    elif code >= 102:
        g = _pattern_signs(code - 102, u)
        act = wp.cw_mul(g, g)
        num = wp.dot(act, wp.cw_mul(g, wp.cw_mul(u, h)) - wp.cw_mul(u, a))
        den = wp.dot(act, wp.cw_mul(u, u))
        t = wp.clamp(num / den, zero, one)
    return t


@wp.func
def _capsule_box_search(a: wp.vec3d, u: wp.vec3d, h: wp.vec3d) -> int:
    """Which candidate minimises the box SDF along ``a + t u``, t in [0, 1] (an integer: no gradient).

    Codes: 0 / 1 the ends and 2 + 12 i + 6 s_i + 2 j + s_j the crossing of the affine pieces
    ``s_i (a_i + t u_i) - h_i`` and ``s_j (a_j + t u_j) - h_j`` when the line enters the box;
    100 / 101 the ends and 102 + pattern the stationary point of one of the 27 face/edge/vertex
    regions of the squared distance when it stays outside. Searched in float64 whatever the
    caller's precision; its adjoint is a no-op (registered below), so it adds no backward code.
    """
    zero = wp.float64(0.0)
    one = wp.float64(1.0)
    eps = wp.float64(1.0e-12)
    code = wp.int32(0)
    best = _box_line_inside(a, u, h, zero)
    v1 = _box_line_inside(a, u, h, one)
    if v1 < best:
        best = v1
        code = 1
    for c in range(36):
        i = c // 12
        j = (c // 2) % 3
        si = _sign_of((c // 6) % 2, zero)
        sj = _sign_of(c % 2, zero)
        dm = si * u[i] - sj * u[j]
        if wp.abs(dm) > eps:
            t = ((sj * a[j] - h[j]) - (si * a[i] - h[i])) / dm
            if t > zero and t < one:
                v = _box_line_inside(a, u, h, t)
                if v < best:
                    best = v
                    code = 2 + c
    if best > zero:
        code = 100
        best = _box_line_outside_sq(a, u, h, zero)
        v1 = _box_line_outside_sq(a, u, h, one)
        if v1 < best:
            best = v1
            code = 101
        for pattern in range(27):
            g = _pattern_signs(pattern, u)
            if wp.dot(wp.cw_mul(g, g), wp.cw_mul(u, u)) > eps:
                t = _capsule_box_t(a, u, h, 102 + pattern)
                v = _box_line_outside_sq(a, u, h, t)
                if v < best:
                    best = v
                    code = 102 + pattern
    return code


@wp.func_grad(_capsule_box_search)
def _adj_capsule_box_search(a: wp.vec3d, u: wp.vec3d, h: wp.vec3d, adj_ret: int):
    # An argmin: piecewise constant, no gradient.
    pass


@wp.func
def capsule_box_distance(a: Any, b: Any, r: Any, X_box: Any, h: Any):
    """Signed distance between a capsule (axis ``[a, b]``, radius ``r``) and a box.

    The minimum of the box SDF along the axis segment, minus ``r``, found exactly: the SDF
    restricted to a line is convex; inside the box it is the maximum of six affine functions
    of the line parameter (its minimum lies at an end or where two of them cross); outside,
    the squared distance is a C¹ piecewise quadratic (its minimum lies at an end or at the
    stationary point of one of the 27 face/edge/vertex regions). An integer search picks the
    winning candidate, which is then evaluated differentiably (its line parameter included),
    so adjoints flow through the winner only and the generated code stays small.
    """
    X_inv = wp.transform_inverse(X_box)
    al = wp.transform_point(X_inv, a)
    u = wp.transform_point(X_inv, b) - al
    code = _capsule_box_search(wp.vec3d(al), wp.vec3d(u), wp.vec3d(h))
    t = _capsule_box_t(al, u, h, code)
    d = _box_line_inside(al, u, h, t)
    if code >= 100:
        d = wp.sqrt(_box_line_outside_sq(al, u, h, t))
    return d - r


@wp.func
def _sat_axis(L: Any, t: Any, Ra: Any, ha: Any, Rb: Any, hb: Any):
    # Separation of the two boxes' projections on unit axis L (negative: overlap).
    ra = ha[0] * wp.abs(wp.dot(Ra[0], L)) + ha[1] * wp.abs(wp.dot(Ra[1], L)) + ha[2] * wp.abs(wp.dot(Ra[2], L))
    rb = hb[0] * wp.abs(wp.dot(Rb[0], L)) + hb[1] * wp.abs(wp.dot(Rb[1], L)) + hb[2] * wp.abs(wp.dot(Rb[2], L))
    return wp.abs(wp.dot(t, L)) - ra - rb


@wp.func
def _sat_axis_of(code: int, Ra: Any, Rb: Any):
    # Axis ``code``: 0-2 the faces of A, 3-5 the faces of B, 6-14 the edge cross products (unnormalised).
    L = Ra[0]
    if code < 3:
        L = Ra[code]
    elif code < 6:
        L = Rb[code - 3]
    else:
        L = wp.cross(Ra[(code - 6) // 3], Rb[(code - 6) % 3])
    return L


@wp.func
def _sat_search(t: wp.vec3d, Ra: wp.mat33d, ha: wp.vec3d, Rb: wp.mat33d, hb: wp.vec3d, axes: int) -> int:
    """Index of the axis of largest separation among the first ``axes`` (an integer: no gradient).

    Near-parallel edge pairs (|a × b|² ≤ 1e-6) are skipped. Searched in float64; the adjoint is a
    no-op. ``axes`` is a runtime bound so the loop stays compact.
    """
    eps = wp.float64(1.0e-6)
    best_code = wp.int32(0)
    best = _sat_axis(Ra[0], t, Ra, ha, Rb, hb)
    for code in range(1, axes):
        L = _sat_axis_of(code, Ra, Rb)
        n2 = wp.dot(L, L)
        if n2 > eps:
            v = _sat_axis(L / wp.sqrt(n2), t, Ra, ha, Rb, hb)
            if v > best:
                best = v
                best_code = code
    return best_code


@wp.func_grad(_sat_search)
def _adj_sat_search(t: wp.vec3d, Ra: wp.mat33d, ha: wp.vec3d, Rb: wp.mat33d, hb: wp.vec3d, axes: int,
                    adj_ret: int):
    # An argmax: piecewise constant, no gradient.
    pass


@wp.func
def box_box_distance(X_a: Any, ha: Any, X_b: Any, hb: Any):
    """Signed distance estimate between two boxes by the separating-axis test (15 axes).

    Returns the largest separation of the boxes' projections over the face normals of both
    boxes and the normalised cross products of their edge directions (near-parallel pairs
    skipped). When the boxes overlap this is minus the exact minimum-translation depth; when
    they are apart it is a lower bound on the distance (exact for face–vertex, face–face and
    edge–edge closest features). The winning axis is found by an integer search and then
    evaluated differentiably.
    """
    qa = wp.transform_get_rotation(X_a)
    qb = wp.transform_get_rotation(X_b)
    t = wp.transform_get_translation(X_b) - wp.transform_get_translation(X_a)
    zero = ha[0] * type(ha[0])(0.0)
    one = type(ha[0])(1.0)
    ex = type(t)(one, zero, zero)
    ey = type(t)(zero, one, zero)
    ez = type(t)(zero, zero, one)
    # Rows are the boxes' axes in world (row i = axis i).
    Ra = wp.matrix_from_rows(wp.quat_rotate(qa, ex), wp.quat_rotate(qa, ey), wp.quat_rotate(qa, ez))
    Rb = wp.matrix_from_rows(wp.quat_rotate(qb, ex), wp.quat_rotate(qb, ey), wp.quat_rotate(qb, ez))
    code = _sat_search(wp.vec3d(t), wp.mat33d(Ra), wp.vec3d(ha), wp.mat33d(Rb), wp.vec3d(hb), 15)
    L = _sat_axis_of(code, Ra, Rb)
    return _sat_axis(L / wp.length(L), t, Ra, ha, Rb, hb)


# ---- ground plane (z = height, normal +z) ----------------------------------------------------
@wp.func
def _abs_sym(x: Any):
    # |x| whose adjoint at exactly 0 is 0 (not Warp's +1): a box or cylinder resting flat has a
    # kinked lowest point, and the symmetric subgradient keeps it from tilting one way.
    z = x * type(x)(0.0)
    return wp.where(x > z, x, wp.where(x < z, -x, z))


@wp.func
def sphere_plane_distance(c: Any, r: Any, height: Any):
    """Height of a sphere's lowest point above the plane ``z = height``."""
    return c[2] - r - height


@wp.func
def capsule_plane_distance(a: Any, b: Any, r: Any, height: Any):
    """Height of a capsule's lowest point above the plane ``z = height``."""
    return wp.min(a[2], b[2]) - r - height


@wp.func
def box_plane_distance(X: Any, h: Any, height: Any):
    """Height of a box's lowest corner above the plane ``z = height``."""
    q = wp.transform_get_rotation(X)
    c = wp.transform_get_translation(X)
    zero = height * type(height)(0.0)
    one = type(height)(1.0)
    # |R^T e_z| per box axis: how far each half extent reaches down.
    down = wp.quat_rotate_inv(q, type(c)(zero, zero, one))
    return c[2] - h[0] * _abs_sym(down[0]) - h[1] * _abs_sym(down[1]) - h[2] * _abs_sym(down[2]) - height


@wp.func
def cylinder_plane_distance(X: Any, radius: Any, half_length: Any, height: Any):
    """Height of a cylinder's lowest rim point above the plane ``z = height``."""
    q = wp.transform_get_rotation(X)
    c = wp.transform_get_translation(X)
    zero = height * type(height)(0.0)
    one = type(height)(1.0)
    az = wp.quat_rotate(q, type(c)(zero, zero, one))[2]
    # The rim disc reaches down by radius * sin(tilt); the small epsilon keeps the adjoint finite upright.
    rim = wp.sqrt(wp.max(one - az * az, zero) + type(height)(1.0e-12))
    return c[2] - half_length * _abs_sym(az) - radius * rim - height


@wp.func
def shape_ground_distance(shape_type: int, X: Any, params: Any, height: Any):
    """Height of a shape's lowest point above the ground plane ``z = height`` (exact for all four types)."""
    d = height * type(height)(0.0) + type(height)(NO_CONTACT_DISTANCE)
    if shape_type == SHAPE_SPHERE:
        d = sphere_plane_distance(wp.transform_get_translation(X), params[0], height)
    elif shape_type == SHAPE_CAPSULE:
        a, b = capsule_endpoints(X, params[1])
        d = capsule_plane_distance(a, b, params[0], height)
    elif shape_type == SHAPE_BOX:
        d = box_plane_distance(X, params, height)
    elif shape_type == SHAPE_CYLINDER:
        d = cylinder_plane_distance(X, params[0], params[1], height)
    return d


@wp.func
def _posed_sphere_capsule(X_s: Any, p_s: Any, X_c: Any, p_c: Any):
    b0, b1 = capsule_endpoints(X_c, p_c[1])
    return sphere_capsule_distance(wp.transform_get_translation(X_s), p_s[0], b0, b1, p_c[0])


@wp.func
def _posed_sphere_box(X_s: Any, p_s: Any, X_b: Any, p_b: Any):
    return sphere_box_distance(wp.transform_get_translation(X_s), p_s[0], X_b, p_b)


@wp.func
def _posed_sphere_cylinder(X_s: Any, p_s: Any, X_c: Any, p_c: Any):
    return sphere_cylinder_distance(wp.transform_get_translation(X_s), p_s[0], X_c, p_c[0], p_c[1])


@wp.func
def _posed_capsule_box(X_c: Any, p_c: Any, X_b: Any, p_b: Any):
    a0, a1 = capsule_endpoints(X_c, p_c[1])
    return capsule_box_distance(a0, a1, p_c[0], X_b, p_b)


@wp.func
def shape_pair_distance(type_a: int, X_a: Any, params_a: Any, type_b: int, X_b: Any, params_b: Any):
    """Signed distance between two posed shapes, dispatched on their types (symmetric).

    Each unordered type pair has one implementation, called with the shapes in
    :class:`~morphkit.graph.ShapeType` order whichever comes first; cylinders become their
    bounding capsules except against spheres. Unsupported types (meshes) give
    :data:`NO_CONTACT_DISTANCE`.
    """
    ta = type_a
    tb = type_b
    # Cylinder as bounding capsule, except for the exact sphere-cylinder pair.
    if ta == SHAPE_CYLINDER and tb != SHAPE_SPHERE:
        ta = SHAPE_CAPSULE
    if tb == SHAPE_CYLINDER and ta != SHAPE_SPHERE:
        tb = SHAPE_CAPSULE
    d = params_a[0] * type(params_a[0])(0.0) + type(params_a[0])(NO_CONTACT_DISTANCE)
    if ta == SHAPE_SPHERE and tb == SHAPE_SPHERE:
        d = sphere_sphere_distance(wp.transform_get_translation(X_a), params_a[0],
                                   wp.transform_get_translation(X_b), params_b[0])
    elif ta == SHAPE_SPHERE and tb == SHAPE_CAPSULE:
        d = _posed_sphere_capsule(X_a, params_a, X_b, params_b)
    elif ta == SHAPE_CAPSULE and tb == SHAPE_SPHERE:
        d = _posed_sphere_capsule(X_b, params_b, X_a, params_a)
    elif ta == SHAPE_SPHERE and tb == SHAPE_BOX:
        d = _posed_sphere_box(X_a, params_a, X_b, params_b)
    elif ta == SHAPE_BOX and tb == SHAPE_SPHERE:
        d = _posed_sphere_box(X_b, params_b, X_a, params_a)
    elif ta == SHAPE_SPHERE and tb == SHAPE_CYLINDER:
        d = _posed_sphere_cylinder(X_a, params_a, X_b, params_b)
    elif ta == SHAPE_CYLINDER and tb == SHAPE_SPHERE:
        d = _posed_sphere_cylinder(X_b, params_b, X_a, params_a)
    elif ta == SHAPE_CAPSULE and tb == SHAPE_CAPSULE:
        a0, a1 = capsule_endpoints(X_a, params_a[1])
        b0, b1 = capsule_endpoints(X_b, params_b[1])
        d = capsule_capsule_distance(a0, a1, params_a[0], b0, b1, params_b[0])
    elif ta == SHAPE_CAPSULE and tb == SHAPE_BOX:
        d = _posed_capsule_box(X_a, params_a, X_b, params_b)
    elif ta == SHAPE_BOX and tb == SHAPE_CAPSULE:
        d = _posed_capsule_box(X_b, params_b, X_a, params_a)
    elif ta == SHAPE_BOX and tb == SHAPE_BOX:
        d = box_box_distance(X_a, params_a, X_b, params_b)
    return d
