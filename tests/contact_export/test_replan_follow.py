"""Re-planning with a swing schedule (``replan_legs(swing_hint=...)``): a hinted leg lifts and lands when the
schedule says (a biped following the human's feet), its stance feet still planted; no schedule, a still one or a
one-frame flicker leave the planner's own steps."""

from __future__ import annotations

import numpy as np
import pytest
from synth._synth_creatures import read_creature

from morphkit.contact_export import replan_legs
from morphkit.errors import ConfigError
from morphkit.metrics import foot_contact_figures
from morphkit.motion import Motion
from morphkit.synth import prepare

FPS = 30.0
T = 120
FEET = ("l_sole", "r_sole")


@pytest.fixture(scope="module")
def stroll(tmp_path_factory) -> Motion:
    """The six-hinge walker's stance carried straight ahead at 6 cm/s (its fore-aft step ellipse is ~7 cm): slow
    enough that a 20-frame stance never reaches the ellipse's edge."""
    m = read_creature("walker", tmp_path_factory.mktemp("walker"))
    q = np.repeat(prepare(m, fps=FPS).q_stance[None], T, axis=0)
    q[:, 0] += 0.06 * np.arange(T) / FPS
    return Motion(m, FPS, q, "stroll")


def _schedule() -> dict[str, np.ndarray]:
    """Alternating 10-frame swings every 30 frames, the right foot 15 frames after the left (5-frame double
    support), the left's first at frame 10."""
    air = {f: np.zeros(T, dtype=bool) for f in FEET}
    for a in range(10, T - 10, 30):
        air["l_sole"][a:a + 10] = True
        air["r_sole"][a + 15:a + 25] = True
    return air


def _airborne(motion: Motion) -> np.ndarray:
    """[T, 2] feet more than 1 cm above the ground, by FK."""
    names = [e.name for e in motion.morphology.end_effectors]
    return motion.end_effector_positions()[:, [names.index(f) for f in FEET], 2] > 0.01


def test_hinted_feet_lift_and_land_with_the_schedule_and_stay_planted_between(stroll):
    air = _schedule()
    own = _airborne(replan_legs(stroll))
    assert own.any(axis=0).all() and not (own == np.stack([air[f] for f in FEET], axis=1)).all()  # its own steps
    out = replan_legs(stroll, swing_hint=air)
    np.testing.assert_array_equal(out.q[:, :7], stroll.q[:, :7])  # the root path is the motion's
    up = _airborne(out)
    for k, f in enumerate(FEET):
        np.testing.assert_array_equal(up[:, k], air[f], err_msg=f)
    names = [e.name for e in stroll.morphology.end_effectors]
    feet = out.end_effector_positions()[:, [names.index(f) for f in FEET]]
    planted = (feet[1:, :, 2] < 0.005) & (feet[:-1, :, 2] < 0.005)
    speed = np.linalg.norm(np.diff(feet[..., :2], axis=0), axis=-1) * FPS
    assert planted.sum() > 100 and speed[planted].max() < 1e-3  # < 0.1 cm/s
    assert foot_contact_figures(out).sliding_rate == 0.0


def test_a_still_hint_or_a_flicker_leaves_the_planners_own_steps(stroll):
    own = replan_legs(stroll)
    still = {f: np.zeros(T, dtype=bool) for f in FEET}  # a human standing while the body drifts
    np.testing.assert_array_equal(replan_legs(stroll, swing_hint=still).q, own.q)
    flicker = {f: np.zeros(T, dtype=bool) for f in FEET}
    flicker["l_sole"][50] = True  # one frame off the ground: a contact detector's noise, not a step
    np.testing.assert_array_equal(replan_legs(stroll, swing_hint=flicker).q, own.q)


def test_a_hint_names_a_legs_foot_and_has_the_motions_length(stroll):
    with pytest.raises(ConfigError, match="no leg's foot"):
        replan_legs(stroll, swing_hint={"body": np.zeros(T, dtype=bool)})
    with pytest.raises(ConfigError, match="shape"):
        replan_legs(stroll, swing_hint={"l_sole": np.zeros(T - 1, dtype=bool)})
