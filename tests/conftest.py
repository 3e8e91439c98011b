"""Shared fixtures: the ``device`` fixture (CPU, plus CUDA when a GPU is present).

Test creatures built in code live in ``tests/morphkit_testing.py``.
"""

from __future__ import annotations

import pytest


def _cuda_available() -> bool:
    try:
        import warp as wp

        wp.init()
        return wp.is_cuda_available()
    except Exception:  # pragma: no cover - Warp missing or broken: CPU only
        return False


DEVICES = ["cpu", *(["cuda"] if _cuda_available() else [])]


@pytest.fixture(params=DEVICES)
def device(request: pytest.FixtureRequest) -> str:
    """Warp device name: ``cpu``, plus ``cuda`` when a GPU is available."""
    return request.param
