"""Issue 65: ACE's G chosen among the epochs whose held-out output lies inside the creature's data, and a tail left
out of Ψ (a tail is not a hand)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
import torch

from morphkit.retarget.ace.config import RetargetConfig, preset
from morphkit.retarget.ace.train import BestGenerator, EpochScore, tail_end_effectors


def _offer(scores, rc, data_div=1.0):
    validation = SimpleNamespace(reference=object(), data_div=data_div)
    net, best = torch.nn.Linear(2, 1), BestGenerator()
    for epoch, s in enumerate(scores):
        torch.nn.init.constant_(net.weight, float(epoch))
        best.offer(s.feature_loss, net, epoch, rank=s.rank(validation, rc))
    return best


def test_an_epoch_inside_the_data_beats_a_lower_feature_loss_outside_it():
    rc = RetargetConfig(choose_inside_data=True)
    scores = [EpochScore(0.5, 50.0, 1.0),   # lowest L_fea, FID far above the limit
              EpochScore(0.9, 2.0, 1.0),    # inside
              EpochScore(0.8, 2.5, 3.0),    # DIV 3× the data's: outside
              EpochScore(0.7, 2.9, 0.6)]    # inside, lower L_fea
    best = _offer(scores, rc)
    assert best.epoch == 3 and bool((best.weights["weight"] == 3.0).all())
    again = BestGenerator()
    again.load_state_dict(best.state_dict())  # the rank survives the checkpoint, so a resumed run compares alike
    assert again.rank == best.rank and again.epoch == 3
    # none inside: the epoch nearest the data in units of its bounds, not the lowest L_fea: FID 9 is 3x the limit,
    # DIV 0.45 is 1.11x below the band's lower edge (0.5), FID 30 is 10x
    outside = [EpochScore(0.5, 9.0, 1.0), EpochScore(0.9, 2.0, 0.45), EpochScore(0.6, 30.0, 1.0)]
    assert _offer(outside, rc).epoch == 1
    assert outside[1].outside_by(SimpleNamespace(data_div=1.0), rc) == pytest.approx(0.5 / 0.45)


def test_quick_and_default_choose_inside_the_data_and_hold_clips_out():
    for name in ("quick", "default"):
        rc = preset(name).retarget
        assert rc.choose_inside_data and rc.validation_share > 0
    assert not RetargetConfig().choose_inside_data  # the dataclass keeps the lowest L_fea


def test_a_tail_is_found_by_its_place_or_its_name_and_a_front_tool_is_not(tmp_path):
    from morphkit.io import read_morphology

    yaml = """\
name: roo
base: floating
root: body
links:
  body: {shapes: [{type: box, size: [0.4, 0.2, 0.2]}]}
  leg_l: {shapes: [{type: capsule, radius: 0.03, length: 0.4, origin: {xyz: [0, 0, -0.2]}}]}
  leg_r: {shapes: [{type: capsule, radius: 0.03, length: 0.4, origin: {xyz: [0, 0, -0.2]}}]}
  rear: {shapes: [{type: capsule, radius: 0.03, length: 0.4, origin: {xyz: [-0.2, 0, 0], rpy: [0, 1.5708, 0]}}]}
  front: {shapes: [{type: capsule, radius: 0.02, length: 0.2, origin: {xyz: [0.1, 0, 0], rpy: [0, 1.5708, 0]}}]}
  side: {shapes: [{type: capsule, radius: 0.02, length: 0.2, origin: {xyz: [-0.1, 0, 0], rpy: [0, 1.5708, 0]}}]}
joints:
  hip_l: {type: revolute, parent: body, child: leg_l, origin: {xyz: [0, 0.1, -0.1]}, axis: [0, 1, 0],
          limit: {lower: -1, upper: 1}}
  hip_r: {type: revolute, parent: body, child: leg_r, origin: {xyz: [0, -0.1, -0.1]}, axis: [0, 1, 0],
          limit: {lower: -1, upper: 1}}
  rear_j: {type: revolute, parent: body, child: rear, origin: {xyz: [-0.2, 0, 0]}, axis: [0, 1, 0],
          limit: {lower: -1, upper: 1}}
  front_j: {type: revolute, parent: body, child: front, origin: {xyz: [0.2, 0, 0.1]}, axis: [0, 1, 0],
          limit: {lower: -1, upper: 1}}
  side_j: {type: revolute, parent: body, child: side, origin: {xyz: [-0.1, 0.1, 0.1]}, axis: [0, 1, 0],
          limit: {lower: -1, upper: 1}}
end_effectors:
  foot_l: {link: leg_l, offset: [0, 0, -0.4], role: foot}
  foot_r: {link: leg_r, offset: [0, 0, -0.4], role: foot}
  tip: {link: rear, offset: [-0.4, 0, 0]}
  nozzle: {link: front, offset: [0.2, 0, 0], role: tool}
  tail_sensor: {link: side, offset: [-0.2, 0, 0], role: tool}
"""
    path = tmp_path / "roo.yaml"
    path.write_text(yaml)
    m = read_morphology(path)
    roles = {e.name: e.role.name for e in m.end_effectors}
    assert roles["tip"] == "TOOL"  # an omitted role reads as a tool: what KL then paired with a hand
    # behind on the midline (tip), named like a tail off the midline (tail_sensor); a tool in front is kept
    assert tail_end_effectors(m) == ["tip", "tail_sensor"]
    assert tail_end_effectors(read_morphology("spot")) == []


def test_outside_without_a_reference_is_never_claimed():
    score = EpochScore(1.0, float("nan"), float("nan"))
    assert score.inside(SimpleNamespace(reference=None, data_div=1.0), RetargetConfig())
    assert not score.inside(SimpleNamespace(reference=object(), data_div=1.0), RetargetConfig())  # NaN: not inside
