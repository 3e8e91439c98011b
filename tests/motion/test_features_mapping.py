"""Ψ (§6.3) and the KL end-effector mapping (§5.3, Eq. 11) on cases whose answer is known."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from morphkit_testing import human_like, random_q

from morphkit.errors import ConfigError
from morphkit.motion import (
    GROUND_MOTION_FEATURES,
    Motion,
    canonical_human,
    character_state_from_motion,
    character_state_layout,
    ee_distributions,
    feature_dim,
    features,
    fit_gaussian,
    human_state_from_motion,
    human_state_layout,
    kl_divergence,
    map_end_effectors,
    measured_body_length,
    motion_features,
    read_override,
)
from morphkit.motion._fk import compiled_model
from morphkit.motion.ee_mapping import Gaussian


def _motion(seed: int = 0) -> Motion:
    m = human_like()
    return Motion(m, 30.0, random_q(compiled_model(m), 10, seed=seed))


def test_features_pick_shared_fields_and_normalise_lengths() -> None:
    motion = _motion()
    m = motion.morphology
    L = measured_body_length(m, motion)  # the default: the standing height measured on the motion
    hl, rl = human_state_layout(m), character_state_layout(m)
    xh, xr = human_state_from_motion(motion), character_state_from_motion(motion)
    fh = features(xh, hl, length=L)
    fr = features(xr, rl, length=L)
    assert fh.shape == (10, feature_dim(len(m.end_effectors)))
    np.testing.assert_allclose(fh, fr, atol=1e-12)  # same motion, either state kind
    np.testing.assert_allclose(fh[:, 0], xh[:, 0] / L)
    np.testing.assert_allclose(fh[:, 1:5], xh[:, 1:5])
    np.testing.assert_allclose(fh[:, 5:8], xh[:, 5:8] / L)
    np.testing.assert_allclose(fh[:, 8:11], xh[:, 8:11])
    names = [e.name for e in m.end_effectors]
    sel = features(xh, hl, length=L, ee_names=[names[2], names[0]])
    ee = xh[:, hl.slice("ee_positions")].reshape(10, -1, 3) / L
    np.testing.assert_allclose(sel[:, 11:], np.concatenate([ee[:, 2], ee[:, 0]], axis=-1))
    np.testing.assert_allclose(motion_features(motion), fr, atol=1e-12)
    with pytest.raises(ConfigError, match="end-effectors:"):
        features(xh, hl, length=L, ee_names=["tail"])
    with pytest.raises(ConfigError, match="length"):
        features(xh, hl, length=0.0)


def test_ground_motion_columns_are_where_the_root_goes_and_turns() -> None:
    # A root that steps forward along its own heading at 0.9 m/s while turning left at 0.6 rad/s: the
    # ground-motion columns read the step / length in the heading frame of the frame it arrives at (turned
    # by w / fps since the step began, so it points a little right) and the yaw rate.
    m = canonical_human()
    fps, T, v, w = 30.0, 12, 0.9, 0.6
    yaw = w * np.arange(T) / fps
    q = np.tile(m.rest_q(), (T, 1))
    step = v / fps * np.stack([np.cos(yaw), np.sin(yaw)], axis=1)
    q[1:, 0:2] = np.cumsum(step[:-1], axis=0)
    q[:, 3:7] = np.stack([np.zeros(T), np.zeros(T), np.sin(yaw / 2), np.cos(yaw / 2)], axis=1)
    motion = Motion(m, fps, q)
    L = 1.3
    psi = motion_features(motion, length=L)[1:, list(GROUND_MOTION_FEATURES)]
    np.testing.assert_allclose(psi[:, 0], v * np.cos(w / fps) / L, rtol=1e-9)
    np.testing.assert_allclose(psi[:, 1], -v * np.sin(w / fps) / L, rtol=1e-9)
    np.testing.assert_allclose(psi[:, 2], w, rtol=1e-9)


def test_features_run_on_torch_and_carry_gradients() -> None:
    import torch

    motion = _motion(1)
    layout = character_state_layout(motion.morphology)
    x = character_state_from_motion(motion)
    xt = torch.tensor(x, requires_grad=True)
    ft = features(xt, layout, length=1.7)
    np.testing.assert_allclose(ft.detach().numpy(), features(x, layout, length=1.7), atol=1e-12)
    ft.sum().backward()
    grad = xt.grad.numpy()
    assert grad[:, 0] == pytest.approx(1 / 1.7)
    assert (grad[:, layout.slice("joint_q")] == 0).all()


def test_kl_divergence_matches_closed_form_and_monte_carlo() -> None:
    p = Gaussian(np.array([0.0, 0.0, 0.0]), np.diag([1.0, 2.0, 0.5]))
    q = Gaussian(np.array([1.0, -1.0, 0.5]), np.diag([2.0, 1.0, 1.0]))
    # Diagonal covariances: a sum of 1-D KLs.
    s0, s1, d = np.diag(p.cov), np.diag(q.cov), q.mean - p.mean
    closed = 0.5 * np.sum(s0 / s1 + d * d / s1 - 1 + np.log(s1 / s0))
    assert kl_divergence(p, q) == pytest.approx(closed, rel=1e-12)
    assert kl_divergence(p, p) == pytest.approx(0.0, abs=1e-12)
    # A full covariance against a Monte-Carlo estimate of E_p[log p - log q].
    rng = np.random.default_rng(0)
    a = rng.normal(size=(3, 3))
    full = Gaussian(np.array([0.2, 0.1, -0.3]), a @ a.T + np.eye(3))
    x = rng.multivariate_normal(full.mean, full.cov, size=200_000)

    def logpdf(g: Gaussian, x: np.ndarray) -> np.ndarray:
        inv = np.linalg.inv(g.cov)
        d = x - g.mean
        return -0.5 * (np.einsum("ni,ij,nj->n", d, inv, d) + np.linalg.slogdet(2 * np.pi * g.cov)[1])

    mc = float(np.mean(logpdf(full, x) - logpdf(q, x)))
    assert kl_divergence(full, q) == pytest.approx(mc, rel=0.02)


def test_mapping_is_forced_by_construction() -> None:
    """Six human end-effectors spread in space; each creature end-effector is sampled from a
    narrower distribution centred on one of them, so Eq. 11 must find it."""
    rng = np.random.default_rng(1)
    centres = {
        "lhand": [0.1, 0.3, 0.0],
        "rhand": [0.1, -0.3, 0.0],
        "lfoot": [0.0, 0.1, -0.55],
        "rfoot": [0.0, -0.1, -0.55],
        "head": [0.0, 0.0, 0.35],
        "tail": [-0.5, 0.0, 0.0],
    }
    human = {n: fit_gaussian(rng.normal(c, 0.08, (4000, 3))) for n, c in centres.items()}
    truth = {"fl": "lfoot", "fr": "rfoot", "hl": "lfoot", "hr": "rfoot", "gripper": "rhand", "cam": "head"}
    creature = {}
    for n, h in truth.items():
        offset = rng.normal(0.0, 0.02, 3)  # a small shift, smaller than the human spread
        creature[n] = fit_gaussian(rng.normal(np.array(centres[h]) + offset, 0.04, (3000, 3)))
    result = map_end_effectors(creature, human)
    assert result.mapping == truth
    assert result.feature_order() == (tuple(truth), tuple(truth.values()))
    for c, row in result.kl.items():
        assert min(row, key=row.get) == truth[c]
    over = map_end_effectors(creature, human, override={"gripper": "lhand"})
    assert over.mapping["gripper"] == "lhand" and over.overridden == {"gripper"}
    assert over.mapping["fl"] == "lfoot"
    js = over.to_json()
    assert js["mapping"]["gripper"] == "lhand" and set(js["kl"]["fl"]) == set(centres)
    table = over.format_table()
    assert "gripper" in table and "* manual override" in table
    with pytest.raises(ConfigError, match="valid: lhand"):
        map_end_effectors(creature, human, override={"gripper": "lhnd"})
    with pytest.raises(ConfigError, match="valid: fl"):
        map_end_effectors(creature, human, override={"wing": "lhand"})


def test_ee_distributions_from_motions_and_override_file(tmp_path: Path) -> None:
    motions = [_motion(s) for s in range(3)]
    dists = ee_distributions(motions)
    names = [e.name for e in motions[0].morphology.end_effectors]
    assert list(dists) == names
    L = measured_body_length(motions[0].morphology, motions)  # one length for the data set, measured on every clip
    psi = np.concatenate([motion_features(m, length=L)[:, 11:] for m in motions]).reshape(-1, len(names), 3)
    np.testing.assert_allclose(dists[names[0]].mean, psi[:, 0].mean(0), atol=1e-12)
    sub = ee_distributions(motions, max_frames_per_clip=5)
    assert sub[names[0]].count == 15
    # Mapping a creature onto itself is the identity.
    assert map_end_effectors(dists, dists).mapping == {n: n for n in names}

    path = tmp_path / "map.yaml"
    path.write_text("mapping:\n  gripper: lwrist_end\n  fl_foot: ltoe_end\n")
    assert read_override(path) == {"gripper": "lwrist_end", "fl_foot": "ltoe_end"}
    path.write_text("gripper: [a, b]\n")
    with pytest.raises(ConfigError) as err:
        read_override(path)
    assert err.value.location.line == 1
    path.write_text("gripper: {\n")
    with pytest.raises(ConfigError, match="malformed YAML"):
        read_override(path)
    with pytest.raises(ConfigError, match="cannot read"):
        read_override(tmp_path / "missing.yaml")


def test_roles_constrain_the_kl_choice() -> None:
    """A broad creature foot next to a narrow human foot and a broad human hand: KL alone picks the hand,
    roles keep it on the foot; a role the human lacks falls back to KL over all."""
    rng = np.random.default_rng(3)
    human = {"lfoot": fit_gaussian(rng.normal([0.0, 0.1, -1.0], 0.01, (3000, 3))),
             "rhand": fit_gaussian(rng.normal([0.0, -0.3, -0.2], 0.4, (3000, 3)))}
    creature = {"foot": fit_gaussian(rng.normal([0.5, 0.1, -1.0], 0.2, (3000, 3))),
                "tail": fit_gaussian(rng.normal([-0.6, 0.0, -0.3], 0.2, (3000, 3)))}
    assert map_end_effectors(creature, human).mapping["foot"] == "rhand"
    roles = ({"foot": "foot", "tail": "tail"}, {"lfoot": "foot", "rhand": "hand"})
    mapped = map_end_effectors(creature, human, roles=roles).mapping
    assert mapped["foot"] == "lfoot"
    assert mapped["tail"] == map_end_effectors(creature, human).mapping["tail"]
    from morphkit.graph import EndEffectorRole as R

    enums = ({"foot": R.FOOT, "tail": R.TOOL}, {"lfoot": R.FOOT, "rhand": R.HAND})
    assert map_end_effectors(creature, human, roles=enums).mapping == {"foot": "lfoot", "tail": "rhand"}


def _brute_force(kl: dict[str, dict[str, float]], members: list[str], candidates: list[str]) -> float:
    """Least total KL over every map of ``members`` onto ``candidates`` that leaves no candidate free
    while another takes two (injective when there are fewer members, onto when there are more)."""
    import itertools

    best = np.inf
    for choice in itertools.product(candidates, repeat=len(members)):
        used = set(choice)
        if len(used) < min(len(members), len(candidates)):
            continue
        best = min(best, sum(kl[c][h] for c, h in zip(members, choice, strict=True)))
    return best


def test_roles_never_stack_two_on_one_while_another_is_free() -> None:
    """Two creature hands that both prefer the right wrist get one wrist each; five feet on two human feet
    use both; each group's total KL is the least such a map allows (brute force over every map)."""
    rng = np.random.default_rng(5)
    human = {"lwrist": fit_gaussian(rng.normal([0.1, 0.3, 0.0], 0.1, (2000, 3))),
             "rwrist": fit_gaussian(rng.normal([0.1, -0.3, 0.0], 0.1, (2000, 3))),
             "lfoot": fit_gaussian(rng.normal([0.0, 0.1, -0.5], 0.05, (2000, 3))),
             "rfoot": fit_gaussian(rng.normal([0.0, -0.1, -0.5], 0.05, (2000, 3))),
             "head": fit_gaussian(rng.normal([0.0, 0.0, 0.4], 0.05, (2000, 3)))}
    creature = {"claw_a": fit_gaussian(rng.normal([0.2, -0.25, 0.0], 0.08, (2000, 3))),
                "claw_b": fit_gaussian(rng.normal([0.3, -0.35, 0.1], 0.08, (2000, 3))),
                **{f"foot{i}": fit_gaussian(rng.normal([0.3 - 0.15 * i, -0.2, -0.5], 0.06, (2000, 3)))
                   for i in range(5)},
                "nose": fit_gaussian(rng.normal([0.2, -0.3, 0.0], 0.05, (2000, 3)))}
    c_roles = {"claw_a": "hand", "claw_b": "tool", "nose": "head", **{f"foot{i}": "foot" for i in range(5)}}
    h_roles = {"lwrist": "hand", "rwrist": "hand", "lfoot": "foot", "rfoot": "foot", "head": "head"}
    paper = map_end_effectors(creature, human)
    assert paper.mapping["claw_a"] == paper.mapping["claw_b"] == "rwrist"  # KL alone stacks them
    assert paper.mapping["nose"] == "rwrist" and "lfoot" not in paper.mapping.values()
    result = map_end_effectors(creature, human, roles=(c_roles, h_roles))
    got = result.mapping
    assert {got["claw_a"], got["claw_b"]} == {"lwrist", "rwrist"}
    assert got["nose"] == "head"
    feet = [f"foot{i}" for i in range(5)]
    assert {got[f] for f in feet} == {"lfoot", "rfoot"}
    for members, candidates in ((["claw_a", "claw_b"], ["lwrist", "rwrist"]), (feet, ["lfoot", "rfoot"])):
        total = sum(result.kl[c][got[c]] for c in members)
        assert total == pytest.approx(_brute_force(result.kl, members, candidates), rel=1e-12)
    # Both rules are kept: the paper's in kl_only, the chosen one names its rule; --kl-only flips them.
    assert result.rule == "roles" and result.kl_only == paper.mapping and result.by_role == got
    flipped = map_end_effectors(creature, human, roles=(c_roles, h_roles), kl_only=True)
    assert flipped.rule == "kl" and flipped.mapping == paper.mapping and flipped.by_role == got
    js = flipped.to_json()
    assert js["mapping"] == paper.mapping and js["by_role"] == got and js["roles"]["claw_b"] == "tool"
    table = result.format_table()
    assert "KL only" in table and "rwrist!" in table.splitlines()[1 + list(creature).index("nose")]
    # An override occupies its human end-effector: the other claw takes the free wrist.
    over = map_end_effectors(creature, human, roles=(c_roles, h_roles), override={"claw_b": "rwrist"})
    assert over.mapping["claw_b"] == "rwrist" and over.mapping["claw_a"] == "lwrist"


def test_roles_map_a_mirror_symmetric_creature_mirror_symmetrically() -> None:
    """A symmetric creature whose claws sit far outside the human's wrists and whose feet are wider than
    the human's narrow left foot: KL alone sends left end-effectors to the broad right ones; within roles,
    centred and side-aware, every left end-effector goes left and every right one right."""
    rng = np.random.default_rng(11)
    human = {"lwrist": fit_gaussian(rng.normal([0.1, 0.3, 0.0], 0.05, (3000, 3))),
             "rwrist": fit_gaussian(rng.normal([0.1, -0.3, 0.0], 0.5, (3000, 3))),
             "lfoot": fit_gaussian(rng.normal([0.0, 0.1, -1.0], 0.02, (3000, 3))),
             "rfoot": fit_gaussian(rng.normal([0.0, -0.1, -1.0], 0.3, (3000, 3)))}
    creature = {f"{side}_{part}": fit_gaussian(rng.normal([x, sign * y, z], s, (3000, 3)))
                for side, sign in (("l", 1.0), ("r", -1.0))
                for part, x, y, z, s in (("claw", 0.9, 0.7, -0.3, 0.08), ("front_foot", 0.5, 0.4, -1.0, 0.05),
                                         ("hind_foot", -0.5, 0.4, -1.0, 0.05))}
    paper = map_end_effectors(creature, human).mapping
    assert paper["l_claw"] == "rwrist" and paper["l_front_foot"] == "rfoot"  # KL alone crosses sides
    roles = ({c: "hand" if "claw" in c else "foot" for c in creature},
             {"lwrist": "hand", "rwrist": "hand", "lfoot": "foot", "rfoot": "foot"})
    got = map_end_effectors(creature, human, roles=roles).mapping
    assert got == {"l_claw": "lwrist", "l_front_foot": "lfoot", "l_hind_foot": "lfoot",
                   "r_claw": "rwrist", "r_front_foot": "rfoot", "r_hind_foot": "rfoot"}


def test_a_centred_pairing_ignores_a_constant_root_height_but_sees_a_crouch() -> None:
    """Each side's Ψ is centred on its own data (:meth:`Pairing.with_centres`): a body whose root always sits
    0.5 m higher (a human against a robot whose root rides on the ground) has the same centred Ψ, while lowering
    the root in one frame lowers that frame's Ψ height by the drop over the body length, as uncentred."""
    from morphkit.motion import Pairing

    clips = [_motion(seed) for seed in range(3)]
    raised = [m.replace(q=m.q + np.eye(m.q.shape[1])[2] * 0.5) for m in clips]
    assert np.allclose(raised[0].root_pose()[:, 2] - clips[0].root_pose()[:, 2], 0.5)
    ees = tuple(e.name for e in clips[0].morphology.end_effectors)
    plain = Pairing(ees, ees, 1.7, 1.7)
    pairing = plain.with_centres(raised, clips)  # the creature side is the raised body
    assert pairing.height_centred and pairing.centred
    for m, r in zip(clips, raised, strict=True):
        np.testing.assert_allclose(pairing.creature_psi(r), pairing.human_psi(m), atol=1e-9)
        assert np.allclose(plain.creature_psi(r)[:, 0] - plain.human_psi(m)[:, 0], 0.5 / 1.7)
    for side in (np.concatenate([pairing.creature_psi(r) for r in raised]),
                 np.concatenate([pairing.human_psi(m) for m in clips])):
        assert abs(side[:, 0].mean()) < 1e-9 and np.abs(side[:, 11:].mean(axis=0)).max() < 1e-9
    crouch = raised[0].q.copy()
    crouch[4, 2] -= 0.2
    moved = pairing.creature_psi(raised[0].replace(q=crouch))[:, 0] - pairing.creature_psi(raised[0])[:, 0]
    np.testing.assert_allclose(moved, np.where(np.arange(len(crouch)) == 4, -0.2 / 1.7, 0.0), atol=1e-9)
