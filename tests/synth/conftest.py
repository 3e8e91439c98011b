"""Shared fixtures of the synth tests: short synthesised datasets, built once per session."""

from __future__ import annotations

from dataclasses import replace

import pytest
from _synth_creatures import SYNTH_FRAMES, read_creature


@pytest.fixture(scope="session")
def synth_cache(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """``name -> SynthResult`` of :data:`SYNTH_FRAMES` frames (seed 0), built on first use."""
    return {"_dir": tmp_path_factory.mktemp("synth_creatures")}


@pytest.fixture(scope="session")
def synthesized(synth_cache: dict):
    """A function ``name -> (morphology, SynthResult)`` over the shared cache."""
    from morphkit.synth import SynthConfig, synthesize

    def get(name: str):
        if name not in synth_cache:
            m = read_creature(name, synth_cache["_dir"])
            cfg = replace(SynthConfig(), rollout_seconds=10.0)
            synth_cache[name] = (m, synthesize(m, frames=SYNTH_FRAMES, seed=0, config=cfg, progress=False))
        return synth_cache[name]

    return get


@pytest.fixture(scope="session")
def synth_creature(synth_cache: dict):
    """A function ``name -> Morphology`` (shipped names, ``tripod``, ``spider``)."""
    return lambda name: read_creature(name, synth_cache["_dir"])
