"""Ground contact, foot sliding and self-collision kernels on constructed cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
import warp as wp
from morphkit_testing import random_q, shipped_morphology, spot_like

from morphkit.errors import GraphError
from morphkit.graph import Limit, MorphologyBuilder, Shape, ShapeType, Transform
from morphkit.kernels import contact as ck
from morphkit.kernels.fk import eval_fk
from morphkit.model import compile_model

# ---- ground: heights and penetration ---------------------------------------------------------


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_foot_one_centimetre_below_ground_penetrates_one_centimetre(dtype, device):
    """A foot 1 cm below the ground gives penetration 0.01; feet above give 0."""
    pts = np.array([[[0.3, 0.1, -0.01], [0.0, 0.0, 0.2], [1.0, 2.0, 0.0]]], dtype=dtype)
    depth = ck.eval_penetration_depth(pts, device=device).numpy()
    tol = 1e-7 if dtype == np.float32 else 1e-15
    np.testing.assert_allclose(depth, [[0.01, 0.0, 0.0]], atol=tol)
    # The same foot over a raised ground (z = 0.1) at z = 0.09.
    pts[0, 0, 2] = 0.09
    depth = ck.eval_penetration_depth(pts, ground_height=0.1, device=device).numpy()
    np.testing.assert_allclose(depth[0, 0], 0.01, atol=tol)
    heights = ck.eval_foot_heights(pts, feet=[2, 0], ground_height=0.1, device=device).numpy()
    np.testing.assert_allclose(heights, [[-0.1, -0.01]], atol=tol)


def test_foot_indices_pick_role_foot():
    """foot_indices returns the end-effectors whose role is foot (Spot-like: four legs, not the gripper)."""
    model = compile_model(spot_like())
    feet = ck.foot_indices(model)
    assert [model.ee_names[i] for i in feet] == ["fl_foot", "fr_foot", "hl_foot", "hr_foot"]


def test_penetration_of_fk_end_effectors_batched_leading_shape():
    """Leading shape [2, 3] is kept; out= is reused; a bad foot index and a bad shape are reported."""
    pts = np.zeros((2, 3, 4, 3))
    pts[1, 2, 3, 2] = -0.05
    out = wp.zeros((2, 3, 2), dtype=wp.float64, device="cpu")
    res = ck.eval_penetration_depth(pts, feet=[0, 3], out=out)
    assert res is out
    assert out.numpy()[1, 2, 1] == pytest.approx(0.05)
    assert out.numpy().sum() == pytest.approx(0.05)
    with pytest.raises(GraphError, match="out of range"):
        ck.eval_penetration_depth(pts, feet=[4])
    with pytest.raises(GraphError, match=r"expected shape \[\.\.\., 3\]"):
        ck.eval_penetration_depth(np.zeros((2, 4)))


# ---- motions: sliding and contact flags ------------------------------------------------------


def _walk(T: int = 12, dtype=np.float64) -> np.ndarray:
    """[1, T, 3, 3]: foot 0 slides 1 cm/frame along x on the ground, foot 1 planted, foot 2 in the air moving."""
    p = np.zeros((1, T, 3, 3), dtype=dtype)
    p[0, :, 0, 0] = 0.01 * np.arange(T)
    p[0, :, 0, 2] = 0.005
    p[0, :, 1] = [0.3, -0.2, 0.0]
    p[0, :, 2, 1] = 0.02 * np.arange(T)
    p[0, :, 2, 2] = 0.3
    return p


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_sliding_one_centimetre_per_frame_at_30_fps_is_0_3_m_per_s(dtype, device):
    """A foot moving 1 cm per frame at 30 fps while in contact slides at 0.3 m/s; a planted or airborne foot at 0."""
    s = ck.eval_sliding_speed(_walk(dtype=dtype), 30.0, device=device).numpy()
    assert s.shape == (1, 12, 3)
    np.testing.assert_allclose(s[0, :, 0], 0.3, rtol=1e-5 if dtype == np.float32 else 1e-12)
    np.testing.assert_allclose(s[0, :, 1:], 0.0, atol=0)


def test_sliding_ignores_vertical_motion_and_gates_on_height():
    """Sliding is horizontal only; the gate is the height at that frame."""
    p = np.zeros((5, 1, 3))
    p[:, 0, 2] = [0.0, 0.01, 0.0, 0.05, 0.0]  # bobbing up and down in place
    p[:, 0, 1] = 0.02 * np.arange(5)  # and 2 cm/frame along y
    s = ck.eval_sliding_speed(p, 10.0, height_threshold=0.02).numpy()[:, 0]
    np.testing.assert_allclose(s, [0.2, 0.2, 0.2, 0.0, 0.2], atol=1e-12)
    single = ck.eval_sliding_speed(p[:1], 10.0).numpy()
    np.testing.assert_allclose(single, 0.0)


def test_sliding_uses_the_project_finite_difference_convention():
    """Sliding equals the horizontal norm of eval_finite_difference (backward differences) on the ground."""
    from morphkit.kernels.end_effectors import eval_finite_difference

    rng = np.random.default_rng(4)
    p = rng.normal(scale=0.1, size=(2, 7, 3, 3))
    p[..., 2] = 0.0
    v = eval_finite_difference(wp.array(p, dtype=wp.vec3d, device="cpu"), dt=1 / 30).numpy()
    s = ck.eval_sliding_speed(p, 30.0).numpy()
    np.testing.assert_allclose(s, np.linalg.norm(v[..., :2], axis=-1), atol=1e-12)
    # An accelerating foot: x = 0, 0, 1, 3 cm -> backward speeds (0, 0, 1, 2) cm/frame.
    x = np.zeros((4, 1, 3))
    x[:, 0, 0] = [0.0, 0.0, 0.01, 0.03]
    np.testing.assert_allclose(ck.eval_sliding_speed(x, 30.0).numpy()[:, 0], [0.0, 0.0, 0.3, 0.6], atol=1e-12)


def test_contact_flags_thresholds():
    """Flags need both low height and low speed: planted foot yes, sliding foot depends on the speed threshold."""
    p = _walk()
    flags = ck.eval_contact_flags(p, 30.0, height_threshold=0.02, speed_threshold=0.2).numpy()
    assert flags.dtype == np.bool_
    assert not flags[0, :, 0].any()  # 0.3 m/s > 0.2 m/s
    assert flags[0, :, 1].all()
    assert not flags[0, :, 2].any()
    loose = ck.eval_contact_flags(p, 30.0, speed_threshold=0.31).numpy()
    assert loose[0, :, 0].all()
    with pytest.raises(GraphError, match="fps"):
        ck.eval_contact_flags(p, 0.0)


# ---- gradients against central differences ---------------------------------------------------


def _fd(f, x: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Jacobian of f(x) (flattened) by central differences, shape [f.size, x.size]."""
    cols = []
    for k in range(x.size):
        xp, xm = x.copy(), x.copy()
        xp.flat[k] += eps
        xm.flat[k] -= eps
        cols.append((f(xp) - f(xm)).ravel() / (2 * eps))
    return np.stack(cols, axis=1)


def _vjp_rows(adjoint, x: np.ndarray, out_size: int) -> np.ndarray:
    """Jacobian rows from the adjoint launcher, one one-hot output gradient at a time."""
    rows = []
    for i in range(out_size):
        g = np.zeros(out_size)
        g[i] = 1.0
        rows.append(np.asarray(adjoint(g)).reshape(-1)[: x.size])
    return np.stack(rows)


def test_penetration_gradient_matches_central_differences():
    """d(depth)/d(points) from the Warp adjoint equals central differences (float64)."""
    rng = np.random.default_rng(0)
    pts = rng.uniform(-0.05, 0.05, size=(2, 3, 3))
    pts[..., 2] = [[-0.02, 0.03, -0.004], [0.01, -0.03, 0.02]]
    feet = [0, 2]

    def f(x):
        return ck.eval_penetration_depth(x.reshape(pts.shape), feet=feet).numpy()

    def adj(g):
        gw = wp.array(g.reshape(2, 2), dtype=wp.float64, device="cpu")
        return ck.eval_penetration_depth_adjoint(pts, gw, feet=feet).numpy()

    J = _vjp_rows(adj, pts, 4)
    np.testing.assert_allclose(J, _fd(f, pts), atol=1e-8)
    assert J[0, 2] == J[1, 8] == -1.0 and J[2, 11] == 0.0  # below ground: -1 on z; above: 0


def test_sliding_gradient_matches_central_differences():
    """d(sliding)/d(points) from the Warp adjoint equals central differences (float64, random motion)."""
    rng = np.random.default_rng(1)
    T, E = 6, 2
    pts = rng.normal(scale=0.05, size=(1, T, E, 3))
    pts[..., 2] = rng.uniform(-0.01, 0.015, size=(1, T, E))  # mostly in contact
    pts[0, 3, 1, 2] = 0.2  # one frame lifted: gate off

    def f(x):
        return ck.eval_sliding_speed(x.reshape(pts.shape), 30.0).numpy()

    def adj(g):
        gw = wp.array(g.reshape(1, T, E), dtype=wp.float64, device="cpu")
        return ck.eval_sliding_speed_adjoint(pts, gw, 30.0).numpy()

    np.testing.assert_allclose(_vjp_rows(adj, pts, T * E), _fd(f, pts), atol=1e-6)


# ---- self-collision --------------------------------------------------------------------------


def small_creature():
    """Torso (box) with a fixed sensor, two legs (hip sphere + thigh capsule) and a tail with a mesh.

    At rest each thigh's capsule dips into the torso box (1 cm): a designed overlap.
    """
    b = MorphologyBuilder("small")
    b.set_base("floating")
    b.add_link("torso", shapes=[Shape(ShapeType.BOX, size=(0.4, 0.2, 0.1))])
    b.add_link("sensor", shapes=[Shape(ShapeType.SPHERE, radius=0.03)])
    b.add_joint_fixed("sensor_mount", "torso", "sensor", origin=Transform((0.25, 0.0, 0.1)))
    lim = Limit(-1.5, 1.5)
    for side, y in (("l", 0.12), ("r", -0.12)):
        b.add_link(f"{side}_hip", shapes=[Shape(ShapeType.SPHERE, radius=0.04)])
        b.add_link(f"{side}_thigh",
                   shapes=[Shape(ShapeType.CAPSULE, radius=0.03, length=0.2, origin=Transform((0, 0, -0.1)))])
        b.add_joint_revolute(f"{side}_hx", "torso", f"{side}_hip", origin=Transform((0.15, y, 0.0)), axis=(1, 0, 0),
                             limit=lim)
        b.add_joint_revolute(f"{side}_hy", f"{side}_hip", f"{side}_thigh", origin=Transform((0, 0, -0.05)),
                             axis=(0, 1, 0), limit=lim)
    tail = Transform.from_xyz_rpy((-0.1, 0, 0), (0, math.pi / 2, 0))
    b.add_link("tail", shapes=[Shape(ShapeType.CAPSULE, radius=0.02, length=0.2, origin=tail),
                               Shape(ShapeType.MESH, mesh="tail.obj")])
    b.add_joint_revolute("tail_joint", "torso", "tail", origin=Transform((-0.25, 0, 0)), axis=(0, 0, 1), limit=lim)
    return b.build()


def test_pair_filter_skips_same_body_adjacent_rest_overlap_and_meshes():
    """On a small creature: fixed-joint links are one body, parent–child and rest-overlapping pairs are skipped."""
    model = compile_model(small_creature())
    pairs = ck.self_collision_pairs(model)
    assert pairs.skipped == {"same_body": 1, "adjacent": 8, "excluded": 0, "rest_overlap": 2, "unsupported": 7}
    names = model.link_names
    kept = {tuple(sorted((names[a], names[b]))) for a, b in zip(pairs.link_a, pairs.link_b, strict=True)}
    assert len(kept) == pairs.pair_count == 10
    assert ("l_thigh", "r_thigh") in kept and ("l_hip", "tail") in kept and ("l_thigh", "sensor") in kept
    assert ("torso", "l_thigh") not in kept  # overlapping at rest by design (thigh top dips 1 cm into the torso)
    assert ("l_hip", "torso") not in kept and ("l_hip", "sensor") not in kept  # adjacent (sensor is torso's body)
    assert (pairs.rest_distance > 0).all()
    # Without the adjacency filter the hips' pairs with the torso are measured (and overlap at rest).
    loose = ck.self_collision_pairs(model, skip_adjacent=False)
    assert loose.skipped["adjacent"] == 0
    assert loose.skipped["rest_overlap"] > pairs.skipped["rest_overlap"]
    # A margin skips pairs that are merely close at rest: the hip spheres are 0.24 - 2 * 0.04 = 0.16 apart, the
    # sensor and each thigh's top |(0.1, 0.12, 0.15)| - 0.06 = 0.1566.
    rest = dict(zip(pairs.names, pairs.rest_distance, strict=True))
    assert rest["l_hip[0] / r_hip[0]"] == pytest.approx(0.16)
    assert rest["sensor[0] / l_thigh[0]"] == pytest.approx(math.sqrt(0.1**2 + 0.12**2 + 0.15**2) - 0.06)
    close = ck.self_collision_pairs(model, rest_margin=0.165)
    assert set(pairs.names) - set(close.names) == {"l_hip[0] / r_hip[0]", "sensor[0] / l_thigh[0]",
                                                   "sensor[0] / r_thigh[0]"}


def test_pairs_touching_links_keep_order_and_every_field():
    """``touching`` keeps exactly the pairs with a shape on one of the links, in order, with their fields."""
    model = compile_model(small_creature())
    pairs = ck.self_collision_pairs(model)
    tail = model.link_index("tail")
    sub = pairs.touching({tail})
    keep = (pairs.link_a == tail) | (pairs.link_b == tail)
    assert 0 < sub.pair_count < pairs.pair_count
    assert sub.names == tuple(n for n, k in zip(pairs.names, keep, strict=True) if k)
    for f in ("shape_a", "shape_b", "link_a", "link_b", "rest_distance"):
        np.testing.assert_array_equal(getattr(sub, f), getattr(pairs, f)[keep])
    assert sub.skipped == pairs.skipped
    assert pairs.touching([]).pair_count == 0


def crossing_arms(r1: float = 0.05, r2: float = 0.04):
    """Two sibling links off a fixed root: arm A (capsule along x, yawing) and arm B (capsule along y) lifted by a
    prismatic joint of travel [0.3, 1] m, so the rest pose (the lower limit) keeps them apart."""
    b = MorphologyBuilder("crossing")
    b.set_base("fixed")
    b.add_link("root")
    along_x = Transform.from_xyz_rpy((0, 0, 0), (0, math.pi / 2, 0))
    along_y = Transform.from_xyz_rpy((0, 0, 0), (math.pi / 2, 0, 0))
    b.add_link("arm_a", shapes=[Shape(ShapeType.CAPSULE, radius=r1, length=1.0, origin=along_x)])
    b.add_link("arm_b", shapes=[Shape(ShapeType.CAPSULE, radius=r2, length=0.8, origin=along_y)])
    b.add_joint_revolute("yaw_a", "root", "arm_a", axis=(0, 0, 1), limit=Limit(-1.0, 1.0))
    b.add_joint_prismatic("lift_b", "root", "arm_b", axis=(0, 0, 1), limit=Limit(0.3, 1.0))
    return b.build()


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_crossing_capsules_self_collision_depth(dtype, device):
    """Perpendicular capsules whose axes are d apart: penetration r1 + r2 - d, signed distance d - r1 - r2."""
    r1, r2 = 0.05, 0.04
    model = compile_model(crossing_arms(r1, r2))
    pairs = ck.self_collision_pairs(model)
    assert pairs.pair_count == 1 and pairs.names == ("arm_a[0] / arm_b[0]",)
    np.testing.assert_allclose(pairs.rest_distance, [0.3 - r1 - r2], atol=1e-12)
    d = np.array([0.05, 0.02, 0.5])
    q = np.stack([np.full(3, 0.4), d], axis=-1).astype(dtype)  # arm A yawed by 0.4 rad, B lifted by d
    X = eval_fk(model, q, device=device)
    pen = ck.eval_self_collision_penetration(model, pairs, X).numpy()[:, 0]
    dist = ck.eval_self_collision_distance(model, pairs, X).numpy()[:, 0]
    tol = 1e-6 if dtype == np.float32 else 1e-12
    # Crossing (non-parallel) capsules: the axes' closest distance is the vertical offset d whatever the yaw.
    np.testing.assert_allclose(dist, d - r1 - r2, atol=tol)
    np.testing.assert_allclose(pen, np.maximum(r1 + r2 - d, 0.0), atol=tol)


def test_self_collision_gradient_matches_central_differences():
    """Adjoint of the pair distances w.r.t. link positions equals central differences (posed small creature)."""
    model = compile_model(small_creature())
    pairs = ck.self_collision_pairs(model)
    q = np.array(model.rest_q, dtype=np.float64)
    q[[model.coordinate_index("l_hx"), model.coordinate_index("r_hx")]] = [-0.6, 0.6]  # legs swing inward: cross
    q[model.coordinate_index("tail_joint")] = 0.3
    X = eval_fk(model, q[None], device="cpu").numpy().reshape(1, model.link_count, 7)
    pen = ck.eval_self_collision_penetration(model, pairs, X).numpy()
    assert pen.max() > 0.01  # the thighs interpenetrate

    P = pairs.pair_count
    for fn, adj in ((ck.eval_self_collision_distance, ck.eval_self_collision_distance_adjoint),
                    (ck.eval_self_collision_penetration, ck.eval_self_collision_penetration_adjoint)):

        def f(pos, fn=fn):
            Y = X.copy()
            Y[..., :3] = pos.reshape(1, -1, 3)
            return fn(model, pairs, Y).numpy()

        def vjp(g, adj=adj):
            gw = wp.array(g.reshape(1, P), dtype=wp.float64, device="cpu")
            return adj(model, pairs, X, gw).numpy()[..., :3]

        pos = X[..., :3].copy()
        np.testing.assert_allclose(_vjp_rows(vjp, pos, P), _fd(f, pos), atol=1e-6)


def test_self_collision_checks_its_inputs():
    """Wrong link count and a transform array of another model are reported with the expected shape."""
    model = compile_model(crossing_arms())
    pairs = ck.self_collision_pairs(model)
    with pytest.raises(GraphError, match=r"link_X: expected shape \[\.\.\., 3\]"):
        ck.eval_self_collision_distance(model, pairs, np.zeros((2, 5, 7)))


def test_shape_ground_distance_on_creature():
    """Lowest points of the small creature's shapes at rest, with the torso lifted 0.3 m."""
    model = compile_model(small_creature())
    q = np.array(model.rest_q)
    q[2] = 0.3
    X = eval_fk(model, q[None], device="cpu")
    h = ck.eval_shape_ground_distance(model, X).numpy()[0]
    # torso box bottom 0.3 - 0.05; thigh capsule bottom 0.3 - 0.05 - 0.2 - 0.03; mesh: far.
    assert h[0] == pytest.approx(0.25)
    thigh = next(i for i in range(model.shape_count) if model.link_names[model.shape_link[i]] == "l_thigh")
    assert h[thigh] == pytest.approx(0.3 - 0.05 - 0.2 - 0.03)
    assert h[-1] > 1e3


@pytest.mark.parametrize("name", ["spot", "crab", "stretch", "human"])
def test_shipped_creatures_self_collision(name):
    """Shipped creatures: pairs build, nothing penetrates at rest, float32 agrees with float64 at random poses."""
    model = compile_model(shipped_morphology(name))
    pairs = ck.self_collision_pairs(model)
    assert pairs.pair_count > 0 and sum(pairs.skipped.values()) + pairs.pair_count == math.comb(model.shape_count, 2)
    rest = eval_fk(model, np.asarray(model.rest_q)[None], device="cpu")
    np.testing.assert_allclose(ck.eval_self_collision_distance(model, pairs, rest).numpy()[0], pairs.rest_distance,
                               atol=1e-12)
    assert (ck.eval_self_collision_penetration(model, pairs, rest).numpy() == 0).all()
    q = random_q(model, 64, seed=1)
    d64 = ck.eval_self_collision_distance(model, pairs, eval_fk(model, q, device="cpu")).numpy()
    d32 = ck.eval_self_collision_distance(model, pairs, eval_fk(model, q.astype(np.float32), device="cpu")).numpy()
    assert np.isfinite(d64).all()
    np.testing.assert_allclose(d32, d64, atol=5e-5)


def test_recorded_self_collision_matches_the_launch_and_pair_selections_partition():
    """:class:`RecordedSelfCollision` gives :func:`eval_self_collision_distance`'s numbers bit for bit on new
    poses each call; ``touching`` and ``apart_from`` the same links split the pairs between them."""
    model = compile_model(shipped_morphology("spot"))
    pairs = ck.self_collision_pairs(model)
    arm = [i for i, n in enumerate(model.link_names) if n.startswith("arm")]
    near, far = pairs.touching(arm), pairs.apart_from(arm)
    assert near.pair_count and far.pair_count and near.pair_count + far.pair_count == pairs.pair_count
    assert set(near.names).isdisjoint(far.names)
    check = ck.RecordedSelfCollision(model, near, 16)
    for seed in (2, 3):
        X = eval_fk(model, random_q(model, 16, seed=seed), device="cpu")
        np.testing.assert_array_equal(check(X.numpy().reshape(16, model.link_count, 7)),
                                      ck.eval_self_collision_distance(model, near, X).numpy())
