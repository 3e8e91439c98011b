"""The one contact rule: presets, the difference convention, and the kernels that use it."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from morphkit import contact_rules as cr
from morphkit.conventions import backward_difference


def test_backward_difference_matches_the_written_out_rule_in_numpy_and_torch() -> None:
    """x[t] - x[t-1], frame 0 copying frame 1 (causal: zero); zeros for one frame; torch gives the same."""
    x = np.array([[0.0, 1.0], [1.0, 3.0], [4.0, 2.0], [4.5, 2.5]])
    expected = np.array([[1.0, 2.0], [1.0, 2.0], [3.0, -1.0], [0.5, 0.5]])
    np.testing.assert_array_equal(backward_difference(x, 0), expected)
    causal = expected.copy()
    causal[0] = 0.0
    np.testing.assert_array_equal(backward_difference(x, 0, causal=True), causal)
    np.testing.assert_array_equal(backward_difference(x.T, -1), expected.T)
    np.testing.assert_array_equal(backward_difference(torch.tensor(x), 0).numpy(), expected)
    np.testing.assert_array_equal(backward_difference(x[:1], 0), np.zeros((1, 2)))


def _naive_flags(p: np.ndarray, fps: float, height: float, speed: float | None, ground: float, causal: bool):
    T, F, _ = p.shape
    out = np.zeros((T, F), dtype=bool)
    for t in range(T):
        for f in range(F):
            if T < 2:
                s = 0.0
            elif t == 0:
                s = 0.0 if causal else np.hypot(*(p[1, f, :2] - p[0, f, :2])) * fps
            else:
                s = np.hypot(*(p[t, f, :2] - p[t - 1, f, :2])) * fps
            out[t, f] = p[t, f, 2] - ground < height and (speed is None or s < speed)
    return out


@pytest.mark.parametrize("rule", list(cr.PRESETS.values()), ids=list(cr.PRESETS))
def test_every_preset_flags_as_a_loop_over_frames_does(rule: cr.ContactRule) -> None:
    rng = np.random.default_rng(3)
    p = rng.normal(scale=[0.01, 0.01, 0.03], size=(40, 3, 3))
    p[..., 2] = np.abs(p[..., 2])
    got = cr.contact_flags(p, 30.0, rule, ground=0.004)
    want = _naive_flags(p, 30.0, rule.height, rule.speed, 0.004, rule.causal)
    np.testing.assert_array_equal(got, want)
    assert 0 < got.sum() < got.size  # the random feet exercise both answers


def test_the_contact_kernel_follows_the_rule_horizontal_speed_only() -> None:
    """The Warp kernel and the NumPy rule agree at the UFR preset; a low foot moving only vertically at
    0.6 m/s (landing) is in contact, one sliding at 0.6 m/s is not."""
    from morphkit.kernels import eval_contact_flags

    T = 12
    p = np.zeros((T, 3, 3))
    p[:, 0, 2] = 0.001 + 0.0005 * np.arange(T)  # rises 0.5 mm a frame: 15 mm/s vertically, still low
    p[:, 1, 2] = 0.019 - 0.0015 * np.minimum(np.arange(T), 12)  # comes down from 19 mm: 45 mm/s
    p[:, 1, 2] = np.maximum(p[:, 1, 2], 0.0)
    p[:, 2, 0] = 0.02 * np.arange(T)  # slides 2 cm a frame: 0.6 m/s
    vertical = np.zeros((T, 1, 3))
    vertical[:, 0, 2] = 0.0199 * (np.arange(T) % 2)  # up and down 2 cm a frame: 0.6 m/s, always below 2 cm
    p = np.concatenate([p, vertical], axis=1)
    flags = eval_contact_flags(p, 30.0).numpy()
    np.testing.assert_array_equal(flags, cr.contact_flags(p, 30.0, cr.UFR))
    assert flags[:, :2].all() and not flags[:, 2].any() and flags[:, 3].all()


def test_callers_default_to_their_presets() -> None:
    """Each caller's defaults are its preset's numbers (a preset changed once changes every caller)."""
    import inspect

    from morphkit.contact_export.lock import lock_feet, stance_flags
    from morphkit.kernels import eval_contact_flags, eval_sliding_speed
    from morphkit.metrics import UnrealisticFrameThresholds, skating_ratio
    from morphkit.motion.states import foot_contact_flags

    def default(fn, name):
        return inspect.signature(fn).parameters[name].default

    assert default(eval_contact_flags, "height_threshold") == cr.UFR.height
    assert default(eval_contact_flags, "speed_threshold") == cr.UFR.speed
    assert default(eval_sliding_speed, "height_threshold") == cr.UFR.height
    thr = UnrealisticFrameThresholds()
    assert (thr.contact_height, thr.sliding_speed) == (cr.UFR.height, cr.UFR.speed)
    assert (default(skating_ratio, "height"), default(skating_ratio, "speed")) == (0.05, 0.5)
    assert default(foot_contact_flags, "rule") is cr.STANCE_FLAGS
    assert default(lock_feet, "rule") is cr.LOCK and default(stance_flags, "rule") is cr.LOCK
