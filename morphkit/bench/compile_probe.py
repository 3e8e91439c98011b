"""First-call (kernel compile) time of morphkit's FK, measured in fresh subprocesses.

``python -m morphkit.bench.compile_probe PATH DEVICE`` is the subprocess: it prints one JSON line of
timings for the creature description at ``PATH``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from morphkit.bench.fk import random_q
from morphkit.cache import CACHE_ENV
from morphkit.errors import ConfigError

__all__ = ["compile_probe", "probe_main"]


def compile_probe(path: Path, *, device: str = "cpu", timeout: float = 300.0) -> dict[str, float]:
    """First-call timings [s] of morphkit's FK for the creature at ``path``, in fresh subprocesses.

    Runs :func:`probe_main` twice with new, empty Warp and morphkit kernel caches for the first run
    (``cold``: code generation + C++ compile + load + launch) and the same caches for the second
    (``warm_cache``: the cached binary is loaded). Both include compiling the torch bridge's kernels
    when they differ (``torch_*``). Process start-up and ``import warp`` are excluded.
    """
    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory(prefix="morphkit-bench-") as tmp:
        env = dict(os.environ, WARP_CACHE_PATH=str(Path(tmp) / "warp"), **{CACHE_ENV: str(Path(tmp) / "mk")})
        for label in ("cold", "warm_cache"):
            proc = subprocess.run(
                [sys.executable, "-m", "morphkit.bench.compile_probe", str(path), device],
                capture_output=True,
                text=True,
                env=env,
                timeout=timeout,
                check=False,
            )
            if proc.returncode != 0:
                raise ConfigError(f"compile probe failed for {path}: {proc.stderr.strip()[-2000:]}")
            timings = json.loads(proc.stdout.strip().splitlines()[-1])
            for k, v in timings.items():
                out[f"{label}{k}"] = v
    return out


def probe_main(path: str, device: str) -> None:
    """Body of the compile probe subprocess: prints ``{"": fk_first_call, "_torch": torch_first_call}``."""
    import warp as wp

    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    from morphkit.io import read_morphology
    from morphkit.kernels.fk import eval_fk

    p = Path(path)
    if p.suffix.lower() == ".bvh":
        from morphkit.io.bvh import read_bvh_skeleton

        m = read_bvh_skeleton(p)
    else:
        m = read_morphology(p)
    from morphkit.model import compile_model

    q = random_q(m, 4, np.random.default_rng(0)).astype(np.float32)
    t0 = time.perf_counter()
    model = compile_model(m, device=device)
    eval_fk(model, q, device=device)
    wp.synchronize_device(device)
    timings = {"": time.perf_counter() - t0}
    try:
        import torch

        from morphkit.torch import ForwardKinematics
    except ImportError:
        pass
    else:
        t0 = time.perf_counter()
        qt = torch.as_tensor(q).requires_grad_(True)
        ForwardKinematics(m, device=device)(qt)[..., :3].sum().backward()
        timings["_torch"] = time.perf_counter() - t0
    sys.stdout.write(json.dumps(timings) + "\n")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit("usage: python -m morphkit.bench.compile_probe PATH DEVICE")
    probe_main(sys.argv[1], sys.argv[2])
