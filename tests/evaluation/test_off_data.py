"""Issue 65: a clip whose output leaves the creature's motion is flagged, by a per-clip distance whose threshold is the
data's own: it fires on a random generator's clips and stays quiet on the creature's own data."""

from __future__ import annotations

import numpy as np
import pytest
from morphkit_testing import random_q

from morphkit.errors import ConfigError
from morphkit.evaluation.table import off_data_warnings, outside_clips, reference_data
from morphkit.metrics import data_envelope
from morphkit.motion import Motion, Pairing
from morphkit.motion._fk import compiled_model
from morphkit.retarget.training_data import DataConfig, character_motions
from morphkit.synth.creatures import CreatureFamily, random_creature


def test_the_distance_is_the_mahalanobis_distance_and_the_data_never_exceeds_its_threshold():
    from scipy.spatial.distance import mahalanobis

    rng = np.random.default_rng(0)
    a = rng.normal(size=(5, 5))
    clips = [rng.normal(size=(n, 5)) @ a + 3.0 for n in (130, 75, 200)]
    env = data_envelope(clips, segment=40)
    x = np.concatenate(clips)
    vi = np.linalg.inv(np.cov(x, rowvar=False) + 0.1**2 * np.eye(5))
    probe = rng.normal(size=(7, 5))
    want = [mahalanobis(p, x.mean(0), vi) for p in probe]  # scipy's, independent of ours
    np.testing.assert_allclose(env.frame_distances(probe), want, rtol=1e-9)
    assert env.segments == 4 + 2 + 5 and env.threshold == pytest.approx(
        max(np.mean(env.frame_distances(c[i:i + 40])) for c in clips for i in range(0, len(c), 40)))
    assert not any(env.outside(c) for c in clips)  # a clip's mean is a weighted mean of its segments'
    assert env.outside(probe * 10.0)
    with pytest.raises(ConfigError, match="quantile"):
        data_envelope(clips, quantile=0.0)
    with pytest.raises(ConfigError, match="features"):
        env.distance(probe[:, :4])


@pytest.fixture(scope="module")
def creature_data(tmp_path_factory):
    m = random_creature(CreatureFamily(legs=4, arm=True), seed=2)
    data = DataConfig(character_frames=1_200)
    motions = character_motions(m, data, cache_dir=tmp_path_factory.mktemp("cache"), progress=False)
    pairing = Pairing.from_mapping({e.name: e.name for e in m.end_effectors}, 0.6, 1.7)
    return m, motions, pairing


def test_the_flag_fires_on_a_random_generator_and_stays_quiet_on_the_data(creature_data):
    m, motions, pairing = creature_data
    ref = reference_data(motions, pairing)
    assert outside_clips(motions, ref, pairing) == []
    # A broken retargeter: joint values and root poses drawn at random each frame.
    model = compiled_model(m)
    broken = []
    for seed in range(3):
        q = random_q(model, 90, seed=seed)
        q[:, 2] = np.abs(q[:, 2]) + 0.3
        broken.append(Motion(m, 30.0, q, f"random{seed}"))
    flagged = outside_clips(broken, ref, pairing)
    assert [name for name, _ in flagged] == ["random0", "random1", "random2"]
    assert all(d > ref.envelope.threshold for _, d in flagged)
    # Data clips cut to the evaluated clips' length stay inside too, and the table says both.
    pieces = [mo.replace(q=mo.q[i:i + 90], name=f"{mo.name}_{i}") for mo in motions for i in (0, 90)]
    assert outside_clips(pieces, ref, pairing) == []


def test_the_table_has_the_column_and_the_warnings_name_each_clip(creature_data):
    from morphkit.evaluation.table import TableRow, format_table

    row = TableRow("ACE", 1.0, 2.0, 0.5, 0.0, 100, off_data=0.5, off_data_clips=(("walk", 9.5),),
                   off_data_threshold=4.0)
    assert "off data" in format_table([row]) and "50.000%" in format_table([row])
    (line,) = off_data_warnings(row)
    assert "'walk'" in line and "9.50 > 4.00" in line
    assert off_data_warnings(TableRow("ACE", 1.0, 2.0, 0.5, 0.0, 100)) == []
