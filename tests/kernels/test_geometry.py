"""Shape-pair signed distances against hand-computed answers and a NumPy brute-force oracle."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
import warp as wp

from morphkit.conventions import quat_from_axis_angle, quat_from_rpy, quat_rotate
from morphkit.errors import GraphError
from morphkit.graph.types import ShapeType
from morphkit.kernels import geometry as geo

SPHERE, CAPSULE, BOX, CYLINDER, MESH = (int(t) for t in ShapeType)


@wp.kernel
def _pair_kernel(
    ta: wp.array[wp.int32],
    Xa: wp.array[Any],
    pa: wp.array[Any],
    tb: wp.array[wp.int32],
    Xb: wp.array[Any],
    pb: wp.array[Any],
    out: wp.array[Any],
):
    i = wp.tid()
    out[i] = geo.shape_pair_distance(ta[i], Xa[i], pa[i], tb[i], Xb[i], pb[i])


@wp.kernel
def _ground_kernel(t: wp.array[wp.int32], X: wp.array[Any], p: wp.array[Any], h: Any, out: wp.array[Any]):
    i = wp.tid()
    out[i] = geo.shape_ground_distance(t[i], X[i], p[i], h)


def _types(dtype):
    if dtype == np.float64:
        return wp.float64, wp.vec3d, wp.transformd
    return wp.float32, wp.vec3f, wp.transformf


def pair_distance(ta, Xa, pa, tb, Xb, pb, dtype=np.float64) -> np.ndarray:
    """Evaluate the Warp dispatch on lists of shapes (one row per pair)."""
    s, v, t = _types(dtype)
    Xa, pa, Xb, pb = (np.atleast_2d(np.asarray(x, dtype=dtype)) for x in (Xa, pa, Xb, pb))
    n = len(Xa)
    ta = np.broadcast_to(np.asarray(ta, dtype=np.int32), (n,)).copy()
    tb = np.broadcast_to(np.asarray(tb, dtype=np.int32), (n,)).copy()
    out = wp.zeros(n, dtype=s, device="cpu")
    wp.launch(
        _pair_kernel,
        dim=n,
        inputs=[
            wp.array(ta, dtype=wp.int32, device="cpu"),
            wp.array(Xa, dtype=t, device="cpu"),
            wp.array(pa, dtype=v, device="cpu"),
            wp.array(tb, dtype=wp.int32, device="cpu"),
            wp.array(Xb, dtype=t, device="cpu"),
            wp.array(pb, dtype=v, device="cpu"),
        ],
        outputs=[out],
        device="cpu",
    )
    return out.numpy()


def ground_distance(ty, X, p, height=0.0) -> np.ndarray:
    X, p = np.atleast_2d(np.asarray(X, float)), np.atleast_2d(np.asarray(p, float))
    n = len(X)
    out = wp.zeros(n, dtype=wp.float64, device="cpu")
    wp.launch(
        _ground_kernel,
        dim=n,
        inputs=[
            wp.array(np.broadcast_to(np.int32(ty), (n,)).copy(), dtype=wp.int32, device="cpu"),
            wp.array(X, dtype=wp.transformd, device="cpu"),
            wp.array(p, dtype=wp.vec3d, device="cpu"),
            wp.float64(height),
        ],
        outputs=[out],
        device="cpu",
    )
    return out.numpy()


def pose(xyz=(0, 0, 0), rpy=(0, 0, 0)) -> np.ndarray:
    return np.array([*xyz, *quat_from_rpy(np.asarray(rpy, float))])


# ---- NumPy oracle ------------------------------------------------------------------------------
def np_box_sdf(p_local: np.ndarray, h: np.ndarray) -> np.ndarray:
    d = np.abs(p_local) - h
    return np.linalg.norm(np.maximum(d, 0.0), axis=-1) + np.minimum(d.max(axis=-1), 0.0)


def np_to_local(X: np.ndarray, p: np.ndarray) -> np.ndarray:
    q_inv = np.array([-X[3], -X[4], -X[5], X[6]])
    return quat_rotate(q_inv, p - X[:3])


def np_axis_points(X: np.ndarray, half: float, n: int = 20001) -> np.ndarray:
    s = np.linspace(-half, half, n)
    axis = quat_rotate(X[3:], np.array([0.0, 0.0, 1.0]))
    return X[:3] + s[:, None] * axis


def np_point_set_distance(P: np.ndarray, Q: np.ndarray) -> float:
    """Brute-force minimum distance between two point sets."""
    return float(np.sqrt(((P[:, None, :] - Q[None, :, :]) ** 2).sum(-1)).min())


def np_points_to_segment(P: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from each point of P to the segment [a, b] (projection, clamped)."""
    ab = b - a
    t = np.clip(((P - a) @ ab) / max(ab @ ab, 1e-300), 0.0, 1.0)
    return np.linalg.norm(P - (a + t[:, None] * ab), axis=-1)


def np_cylinder_sdf(p: np.ndarray, radius: float, half: float) -> np.ndarray:
    dr = np.hypot(p[..., 0], p[..., 1]) - radius
    dz = np.abs(p[..., 2]) - half
    return np.hypot(np.maximum(dr, 0), np.maximum(dz, 0)) + np.minimum(np.maximum(dr, dz), 0)


def random_pose(rng: np.random.Generator, spread: float) -> np.ndarray:
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    return np.array([*rng.uniform(-spread, spread, 3), *quat_from_axis_angle(axis, rng.uniform(0, np.pi))])


# ---- hand-computed cases -----------------------------------------------------------------------
def test_sphere_sphere_apart_and_overlapping():
    """Sphere pairs give |c1 - c2| - r1 - r2, positive apart and negative overlapping."""
    d = pair_distance(SPHERE, [pose((0, 0, 0)), pose((0, 0, 0))], [[0.5, 0, 0]] * 2,
                      SPHERE, [pose((2, 0, 0)), pose((0.6, 0, 0))], [[0.3, 0, 0]] * 2)
    np.testing.assert_allclose(d, [1.2, -0.2], atol=1e-12)


def test_crossing_perpendicular_capsules_depth():
    """Perpendicular capsules whose axes are d apart overlap by r1 + r2 - d."""
    r1, r2, d = 0.1, 0.07, 0.05
    along_x = pose((0, 0, 0), (0, np.pi / 2, 0))  # local z -> world x
    along_y = pose((0, 0, d), (np.pi / 2, 0, 0))  # local z -> world -y
    dist = pair_distance(CAPSULE, along_x, [r1, 0.5, 0], CAPSULE, along_y, [r2, 0.4, 0])
    np.testing.assert_allclose(-dist, [r1 + r2 - d], atol=1e-12)


def test_parallel_capsules_and_end_to_end():
    """Parallel capsules side by side and capsules end to end along one line."""
    side = pair_distance(CAPSULE, pose((0, 0, 0)), [0.1, 0.5, 0], CAPSULE, pose((0.5, 0, 0.3)), [0.2, 0.5, 0])
    np.testing.assert_allclose(side, [0.2], atol=1e-12)
    ends = pair_distance(CAPSULE, pose((0, 0, 0)), [0.1, 0.5, 0], CAPSULE, pose((0, 0, 1.5)), [0.1, 0.2, 0])
    np.testing.assert_allclose(ends, [1.5 - 0.5 - 0.2 - 0.2], atol=1e-12)


def test_sphere_capsule():
    """A sphere beside a capsule's side and beyond its cap."""
    d = pair_distance(SPHERE, [pose((1, 0, 0.2)), pose((0, 0, 2))], [[0.25, 0, 0]] * 2,
                      CAPSULE, [pose(), pose()], [[0.1, 0.5, 0]] * 2)
    np.testing.assert_allclose(d, [1 - 0.25 - 0.1, 1.5 - 0.25 - 0.1], atol=1e-12)


def test_sphere_box_face_edge_inside():
    """Sphere against a unit-half box: face region, edge region and centre inside the box."""
    h = [0.5, 0.5, 0.5]
    centres = [(1.0, 0, 0), (1.0, 1.0, 0), (0.3, 0, 0)]
    d = pair_distance(SPHERE, [pose(c) for c in centres], [[0.3, 0, 0]] * 3, BOX, [pose()] * 3, [h] * 3)
    np.testing.assert_allclose(d, [0.2, np.sqrt(0.5) - 0.3, -0.2 - 0.3], atol=1e-12)
    # The same with the box posed: rotated 90 degrees about z and moved.
    d2 = pair_distance(SPHERE, pose((3.0, 1.0, 0)), [0.3, 0, 0], BOX, pose((2, 1, 0), (0, 0, np.pi / 2)),
                       [0.25, 0.5, 0.5])
    np.testing.assert_allclose(d2, [1.0 - 0.5 - 0.3], atol=1e-12)  # local y (0.5) now along world x


def test_box_box_overlap_separated_and_vertex_face():
    """SAT: depth of axis-aligned overlap, face gap, and a 45-degree box pointing a vertex edge at a face."""
    a = pose()
    ha = [1.0, 1.0, 1.0]
    overlap = pair_distance(BOX, a, ha, BOX, pose((1.3, 0.2, 0)), [0.5, 0.5, 0.5])
    np.testing.assert_allclose(overlap, [-0.2], atol=1e-12)
    gap = pair_distance(BOX, a, ha, BOX, pose((0, 1.8, 0.1)), [0.5, 0.5, 0.5])
    np.testing.assert_allclose(gap, [0.3], atol=1e-12)
    tilted = pair_distance(BOX, a, ha, BOX, pose((2, 0, 0), (0, 0, np.pi / 4)), [0.5, 0.5, 0.5])
    np.testing.assert_allclose(tilted, [1.0 - 0.5 * np.sqrt(2)], atol=1e-12)
    # Crossed beams, edge against edge: two long thin boxes at right angles, 0.05 apart in z.
    beam_x = pair_distance(BOX, pose(), [2, 0.1, 0.1], BOX, pose((0, 0, 0.25)), [0.1, 2, 0.1])
    np.testing.assert_allclose(beam_x, [0.05], atol=1e-12)


def test_capsule_box_cases():
    """Capsule above a box, crossing through it, and lying along an edge."""
    h = [1.0, 1.0, 1.0]
    above = pair_distance(CAPSULE, pose((0.2, 0.3, 1.6)), [0.1, 0.4, 0], BOX, pose(), h)
    np.testing.assert_allclose(above, [1.2 - 1.0 - 0.1], atol=1e-12)
    # Horizontal capsule through the box at z = 0.8: deepest axis point 0.2 below the top face.
    through = pair_distance(CAPSULE, pose((0, 0, 0.8), (0, np.pi / 2, 0)), [0.1, 3.0, 0], BOX, pose(), h)
    np.testing.assert_allclose(through, [-0.2 - 0.1], atol=1e-12)
    # Parallel to the box's z edge at (1, 1), offset diagonally by 0.3 in x and y.
    edge = pair_distance(CAPSULE, pose((1.3, 1.3, 0)), [0.05, 0.5, 0], BOX, pose(), h)
    np.testing.assert_allclose(edge, [0.3 * np.sqrt(2) - 0.05], atol=1e-12)
    # Symmetric fallback: box first gives the same.
    swapped = pair_distance(BOX, pose(), h, CAPSULE, pose((1.3, 1.3, 0)), [0.05, 0.5, 0])
    np.testing.assert_allclose(swapped, edge, atol=1e-12)


def test_sphere_cylinder_exact():
    """Sphere beside the curved side, above the flat end, and off the rim."""
    cyl = pose()
    p = [0.5, 1.0, 0]
    d = pair_distance(SPHERE, [pose((1.0, 0, 0)), pose((0, 0, 1.5)), pose((0.8, 0, 1.4))], [[0.1, 0, 0]] * 3,
                      CYLINDER, [cyl] * 3, [p] * 3)
    np.testing.assert_allclose(d, [0.4, 0.4, 0.5 - 0.1], atol=1e-12)


def test_cylinder_pairs_use_bounding_capsule():
    """Cylinder against a box is measured as its bounding capsule (documented approximation)."""
    d_cyl = pair_distance(CYLINDER, pose((0, 0, 2.0)), [0.2, 0.5, 0], BOX, pose(), [1, 1, 1])
    d_cap = pair_distance(CAPSULE, pose((0, 0, 2.0)), [0.2, 0.5, 0], BOX, pose(), [1, 1, 1])
    np.testing.assert_allclose(d_cyl, d_cap, atol=1e-12)
    np.testing.assert_allclose(d_cyl, [2.0 - 0.5 - 0.2 - 1.0], atol=1e-12)
    assert geo.pair_distance_kind(ShapeType.CYLINDER, ShapeType.BOX) == "approximate"
    assert geo.pair_distance_kind(ShapeType.BOX, ShapeType.SPHERE) == "exact"


def test_mesh_pairs_rejected_on_host_and_far_in_kernels():
    """Meshes have no distance function: the host names both types; kernels report no contact."""
    with pytest.raises(GraphError, match="mesh and box"):
        geo.pair_distance_kind(ShapeType.MESH, ShapeType.BOX)
    d = pair_distance(MESH, pose(), [1, 1, 1], BOX, pose(), [1, 1, 1])
    assert d[0] == pytest.approx(geo.NO_CONTACT_DISTANCE)


def test_dispatch_is_symmetric_for_every_type_pair():
    """d(a, b) == d(b, a) for all supported type pairs at random poses."""
    rng = np.random.default_rng(3)
    params = {SPHERE: [0.3, 0, 0], CAPSULE: [0.2, 0.4, 0], BOX: [0.3, 0.2, 0.4], CYLINDER: [0.25, 0.3, 0]}
    for ta, pa in params.items():
        for tb, pb in params.items():
            Xa = np.stack([random_pose(rng, 0.6) for _ in range(16)])
            Xb = np.stack([random_pose(rng, 0.6) for _ in range(16)])
            d_ab = pair_distance(ta, Xa, [pa] * 16, tb, Xb, [pb] * 16)
            d_ba = pair_distance(tb, Xb, [pb] * 16, ta, Xa, [pa] * 16)
            np.testing.assert_allclose(d_ab, d_ba, atol=1e-12, err_msg=f"types {ta}, {tb}")


def test_float32_matches_float64():
    """The float32 instantiation agrees with float64 to single precision."""
    rng = np.random.default_rng(5)
    Xa = np.stack([random_pose(rng, 0.6) for _ in range(32)])
    Xb = np.stack([random_pose(rng, 0.6) for _ in range(32)])
    for ta, tb, pa, pb in [(CAPSULE, BOX, [0.1, 0.3, 0], [0.3, 0.2, 0.4]), (BOX, BOX, [0.3] * 3, [0.2, 0.4, 0.3])]:
        d64 = pair_distance(ta, Xa, [pa] * 32, tb, Xb, [pb] * 32)
        d32 = pair_distance(ta, Xa, [pa] * 32, tb, Xb, [pb] * 32, dtype=np.float32)
        np.testing.assert_allclose(d32, d64, atol=2e-5)


# ---- brute-force oracle ------------------------------------------------------------------------
def test_random_sphere_and_capsule_pairs_match_brute_force():
    """Capsule–capsule and sphere–capsule agree with densely sampled axis segments."""
    rng = np.random.default_rng(0)
    for _ in range(20):
        Xa, Xb = random_pose(rng, 0.5), random_pose(rng, 0.5)
        ra, ha, rb, hb = 0.1, rng.uniform(0.05, 0.5), 0.08, rng.uniform(0.05, 0.5)
        got = pair_distance(CAPSULE, Xa, [ra, ha, 0], CAPSULE, Xb, [rb, hb, 0])[0]
        pb = np_axis_points(Xb, hb, 2)
        want = np_points_to_segment(np_axis_points(Xa, ha), pb[0], pb[1]).min() - ra - rb
        assert got == pytest.approx(want, abs=1e-6)
        got_s = pair_distance(SPHERE, Xa, [ra, 0, 0], CAPSULE, Xb, [rb, hb, 0])[0]
        want_s = np_point_set_distance(Xa[None, :3], np_axis_points(Xb, hb)) - ra - rb
        assert got_s == pytest.approx(want_s, abs=1e-4)


def test_random_capsule_box_matches_brute_force():
    """Capsule–box (apart and overlapping) equals the minimum box SDF along the sampled axis minus r."""
    rng = np.random.default_rng(1)
    for _ in range(60):
        Xc, Xb = random_pose(rng, 0.8), random_pose(rng, 0.3)
        r, half = 0.05, rng.uniform(0.0, 0.6)
        h = rng.uniform(0.1, 0.5, 3)
        got = pair_distance(CAPSULE, Xc, [r, half, 0], BOX, Xb, h)[0]
        pts = np_to_local(Xb, np_axis_points(Xc, half, 4001))
        want = np_box_sdf(pts, h).min() - r
        assert got == pytest.approx(want, abs=2e-4)
        assert got <= want + 1e-9  # exact minimum: never above any sampled point


def test_random_sphere_box_and_sphere_cylinder_match_sdf():
    """Sphere–box and sphere–cylinder equal the NumPy SDF at the centre minus the radius."""
    rng = np.random.default_rng(2)
    for _ in range(30):
        Xs, Xb = random_pose(rng, 0.8), random_pose(rng, 0.3)
        h = rng.uniform(0.1, 0.5, 3)
        got = pair_distance(SPHERE, Xs, [0.1, 0, 0], BOX, Xb, h)[0]
        assert got == pytest.approx(np_box_sdf(np_to_local(Xb, Xs[:3]), h) - 0.1, abs=1e-12)
        got_c = pair_distance(SPHERE, Xs, [0.1, 0, 0], CYLINDER, Xb, [h[0], h[1], 0])[0]
        assert got_c == pytest.approx(np_cylinder_sdf(np_to_local(Xb, Xs[:3]), h[0], h[1]) - 0.1, abs=1e-12)


def _box_surface_points(X: np.ndarray, h: np.ndarray, n: int = 10) -> np.ndarray:
    g = np.linspace(-1, 1, n)
    u, v = np.meshgrid(g, g)
    faces = []
    for axis in range(3):
        for sign in (-1, 1):
            p = np.zeros((n * n, 3))
            others = [k for k in range(3) if k != axis]
            p[:, axis] = sign
            p[:, others[0]] = u.ravel()
            p[:, others[1]] = v.ravel()
            faces.append(p)
    local = np.concatenate(faces) * h
    return X[:3] + quat_rotate(X[3:], local)


def test_random_box_box_sat_is_a_lower_bound_and_detects_overlap():
    """Apart: SAT ≤ the brute-force surface distance; overlapping points force SAT < 0."""
    rng = np.random.default_rng(4)
    for _ in range(25):
        Xa, Xb = random_pose(rng, 0.7), random_pose(rng, 0.7)
        ha, hb = rng.uniform(0.1, 0.4, 3), rng.uniform(0.1, 0.4, 3)
        got = pair_distance(BOX, Xa, ha, BOX, Xb, hb)[0]
        pa, pb = _box_surface_points(Xa, ha), _box_surface_points(Xb, hb)
        inside_b = np_box_sdf(np_to_local(Xb, pa), hb)
        if (inside_b < 0).any():
            assert got < 0
        else:
            assert got <= np_point_set_distance(pa, pb) + 1e-9


# ---- ground plane ------------------------------------------------------------------------------
def test_ground_distances_of_every_shape():
    """Lowest points: sphere, tilted capsule, tilted box (corner), tilted cylinder (rim), with a raised ground."""
    tilt = np.pi / 4
    X = pose((0.1, 0.2, 1.0), (tilt, 0, 0))
    c, s = np.cos(tilt), np.sin(tilt)
    np.testing.assert_allclose(ground_distance(SPHERE, X, [0.3, 0, 0]), [0.7], atol=1e-12)
    np.testing.assert_allclose(ground_distance(CAPSULE, X, [0.1, 0.4, 0]), [1.0 - 0.4 * c - 0.1], atol=1e-12)
    np.testing.assert_allclose(ground_distance(BOX, X, [0.3, 0.2, 0.4]), [1.0 - 0.2 * s - 0.4 * c], atol=1e-12)
    np.testing.assert_allclose(ground_distance(CYLINDER, X, [0.2, 0.4, 0]), [1.0 - 0.4 * c - 0.2 * s], atol=1e-9)
    np.testing.assert_allclose(ground_distance(SPHERE, X, [0.3, 0, 0], height=0.5), [0.2], atol=1e-12)


def test_random_ground_distances_match_sampled_lowest_points():
    """Box corners and cylinder rims sampled in NumPy give the same lowest point."""
    rng = np.random.default_rng(6)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    ang = np.linspace(0, 2 * np.pi, 20001)
    for _ in range(20):
        X = random_pose(rng, 1.0)
        h = rng.uniform(0.1, 0.5, 3)
        want_box = (X[:3] + quat_rotate(X[3:], corners * h))[:, 2].min()
        assert ground_distance(BOX, X, h)[0] == pytest.approx(want_box, abs=1e-12)
        rim = np.concatenate([np.stack([h[0] * np.cos(ang), h[0] * np.sin(ang), np.full_like(ang, z)], -1)
                              for z in (-h[1], h[1])])
        want_cyl = (X[:3] + quat_rotate(X[3:], rim))[:, 2].min()
        assert ground_distance(CYLINDER, X, [h[0], h[1], 0])[0] == pytest.approx(want_cyl, abs=1e-7)


# ---- gradients ---------------------------------------------------------------------------------
@wp.kernel
def _pair_sum_kernel(
    ta: int, Xa: wp.array[wp.transformd], pa: wp.vec3d, tb: int, Xb: wp.array[wp.transformd], pb: wp.vec3d,
    out: wp.array[wp.float64],
):
    out[0] = geo.shape_pair_distance(ta, Xa[0], pa, tb, Xb[0], pb)


def _grad_and_fd(ta, Xa, pa, tb, Xb, pb, eps=1e-6):
    xa = wp.array([Xa], dtype=wp.transformd, device="cpu", requires_grad=True)
    xb = wp.array([Xb], dtype=wp.transformd, device="cpu", requires_grad=True)
    out = wp.zeros(1, dtype=wp.float64, device="cpu", requires_grad=True)
    tape = wp.Tape()
    with tape:
        wp.launch(_pair_sum_kernel, 1, inputs=[ta, xa, wp.vec3d(*pa), tb, xb, wp.vec3d(*pb)], outputs=[out],
                  device="cpu")
    tape.backward(grads={out: wp.array([1.0], dtype=wp.float64, device="cpu")})
    grad = np.concatenate([xa.grad.numpy()[0, :3], xb.grad.numpy()[0, :3]])
    fd = np.zeros(6)
    for k in range(6):
        for sgn in (1, -1):
            A, B = np.array(Xa, float), np.array(Xb, float)
            (A if k < 3 else B)[k % 3] += sgn * eps
            fd[k] += sgn * pair_distance(ta, A, pa, tb, B, pb)[0] / (2 * eps)
    return grad, fd


@pytest.mark.parametrize(
    ("ta", "pa", "tb", "pb", "Xb"),
    [
        (SPHERE, [0.3, 0, 0], BOX, [0.5, 0.4, 0.3], pose((0.6, 0.5, 0.2), (0.3, 0.2, 0.1))),
        (CAPSULE, [0.1, 0.4, 0], CAPSULE, [0.2, 0.3, 0], pose((0.1, 0.2, 0.15), (1.2, 0.3, 0))),
        (CAPSULE, [0.1, 0.4, 0], BOX, [0.3, 0.2, 0.5], pose((0.5, 0.1, 0.2), (0.4, 0.7, 0.2))),
        (CAPSULE, [0.1, 0.6, 0], BOX, [0.3, 0.2, 0.5], pose((0.1, 0.05, 0.1), (0.4, 0.7, 0.2))),
        (BOX, [0.3, 0.2, 0.4], BOX, [0.3, 0.2, 0.5], pose((0.4, 0.3, 0.2), (0.4, 0.7, 0.2))),
        (SPHERE, [0.2, 0, 0], CYLINDER, [0.3, 0.2, 0], pose((0.45, 0.1, 0.3), (0.2, 0.1, 0))),
    ],
)
def test_distance_gradient_wrt_positions_matches_central_differences(ta, pa, tb, pb, Xb):
    """Warp adjoints of the signed distance w.r.t. both shape positions equal central differences."""
    Xa = pose((0.0, 0.0, 0.0), (0.1, -0.2, 0.3))
    grad, fd = _grad_and_fd(ta, Xa, pa, tb, Xb, pb)
    np.testing.assert_allclose(grad, fd, atol=1e-6)
    np.testing.assert_allclose(grad[:3], -grad[3:], atol=1e-9)  # translation invariance
