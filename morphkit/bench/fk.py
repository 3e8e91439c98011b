"""Forward-kinematics throughput of morphkit against its peers, in one run (``morphkit bench fk``).

Measures poses per second for every (creature, implementation, mode, batch size):

- creatures: ``spot`` (the shipped URDF) and ``human`` (a CMU BVH skeleton read from
  ``$MORPHKIT_DATA/human/cmu``: 22 joints, spherical; the shipped ``human`` when the variable is unset);
- implementations: ``morphkit`` (raw Warp kernels), ``morphkit_torch`` (through the autograd bridge),
  ``pytorch_kinematics``, ``pinocchio`` and ``mujoco`` (Python loops over poses; :mod:`.peers`) and
  ``torch`` (plain batched torch FK, :mod:`morphkit.torch.reference`);
- modes: ``fwd`` (world transforms of every link) and ``fwd_bwd`` (the gradient of the sum of link
  positions with respect to the coordinates; Pinocchio's and MuJoCo's Jacobians as their analogue).

Every implementation is built from the same :class:`~morphkit.graph.Morphology` and checked against
the reference FK at random poses before it is timed. Inputs are prepared outside the timed region;
each implementation is warmed up, then timed in rounds interleaved with the others and the best round
kept. Python-loop peers time at most ``loop_poses`` poses per call (their rate does not depend on the
batch size). :mod:`.report` turns a run into markdown and checks it against the project's targets
(``benchmarks/fk_targets.yaml``); ``benchmarks/README.md`` holds the method and results.
This module imports torch, Warp and the peer libraries inside functions only, so ``morphkit --help`` stays
light.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.bench.peers import MujocoFK, PinocchioFK, PytorchKinematicsFK, Workload
from morphkit.errors import ConfigError
from morphkit.graph import BaseType, JointType, Morphology

__all__ = [
    "BATCHES",
    "IMPLS",
    "MODES",
    "QUICK_BATCHES",
    "BenchConfig",
    "BenchResult",
    "Creature",
    "bridge_latency",
    "load_creature",
    "make_impl",
    "random_q",
    "run_fk_benchmark",
    "time_calls",
]

IMPLS: tuple[str, ...] = ("morphkit", "morphkit_torch", "pytorch_kinematics", "pinocchio", "mujoco", "torch")
"""Implementation names, as they appear in the JSON records."""
MODES: tuple[str, ...] = ("fwd", "fwd_bwd")
BATCHES: tuple[int, ...] = (1, 64, 1024, 16384, 131072)
QUICK_BATCHES: tuple[int, ...] = (1, 64, 1024)
LOOP_PEERS = frozenset({"pinocchio", "mujoco"})
HUMAN_BVH = "01_01.bvh"
"""CMU take whose skeleton is the benchmark human (any CMU file has the same 22-joint skeleton)."""


@dataclass(frozen=True)
class BenchConfig:
    """What ``morphkit bench fk`` measures and how long it tries."""

    creatures: tuple[str, ...] = ("spot", "human")
    """``spot``, ``human`` or any description path / shipped name."""
    impls: tuple[str, ...] = IMPLS
    modes: tuple[str, ...] = MODES
    batches: tuple[int, ...] = BATCHES
    loop_poses: int = 2000
    """Poses per timed call at most for the Python-loop peers (Pinocchio, MuJoCo)."""
    repeats: int = 5
    """Timed repeats per measurement (the best is kept), after one warm-up call."""
    min_time: float = 0.03
    """Each repeat calls the workload until this many seconds [s] have passed."""
    threads: int = 2
    """``torch.set_num_threads`` and morphkit's CPU launch threads."""
    seed: int = 0
    bridge_calls: int = 400
    """B = 1 forward calls timed one by one for the torch bridge overhead."""
    compile_probe: bool = True
    """Measure first-call kernel compile time in fresh subprocesses (cold and warm cache)."""
    device: str = "cpu"


@dataclass(frozen=True)
class Creature:
    """A benchmark creature and where it came from."""

    key: str
    """Name in the records (``spot``, ``human``)."""
    morphology: Morphology
    path: Path
    note: str


@dataclass
class BenchResult:
    """Everything one run measured."""

    records: list[dict[str, Any]] = field(default_factory=list)
    """``{"creature", "impl", "mode", "batch", "poses_per_s"}`` per measurement."""
    creatures: dict[str, str] = field(default_factory=dict)
    """Creature key → description of its source and size."""
    agreement: dict[str, dict[str, float]] = field(default_factory=dict)
    """Creature → impl → max |Δp| [m] of link positions against the reference at random poses."""
    skipped: dict[str, str] = field(default_factory=dict)
    """Impl (or ``creature/impl``) → why it was not measured."""
    bridge: dict[str, dict[str, float]] = field(default_factory=dict)
    """Creature → median µs per B = 1 forward call: ``raw`` (Warp launcher), ``torch`` (bridge), ``overhead``."""
    compile: dict[str, dict[str, float]] = field(default_factory=dict)
    """Creature → first-call timings [s] (``cold``, ``warm_cache``, ``torch_cold``...)."""
    notes: list[str] = field(default_factory=list)
    load: list[float] = field(default_factory=list)
    """1-minute load average at the start and end of the run (above the core count: other work competed)."""
    config: BenchConfig = field(default_factory=BenchConfig)

    def rate(self, creature: str, impl: str, mode: str, batch: int) -> float | None:
        for r in self.records:
            if (r["creature"], r["impl"], r["mode"], r["batch"]) == (creature, impl, mode, batch):
                return float(r["poses_per_s"])
        return None


# ---------------------------------------------------------------------------------------------
# creatures and poses
# ---------------------------------------------------------------------------------------------
def load_creature(key: str) -> Creature:
    """The benchmark creature ``key``: ``human`` is a CMU BVH skeleton when ``MORPHKIT_DATA`` is set.

    Raises:
        MorphkitError: when the description cannot be found or read.
    """
    from morphkit.io import read_morphology
    from morphkit.io.shipped import resolve_morphology

    if key == "human":
        data = os.environ.get("MORPHKIT_DATA")
        cmu = Path(data) / "human" / "cmu" if data else None
        if cmu is not None and cmu.is_dir():
            path = cmu / HUMAN_BVH
            if not path.is_file():
                candidates = sorted(cmu.glob("*.bvh"))
                if not candidates:
                    raise ConfigError(f"{cmu}: no .bvh file")
                path = candidates[0]
            from morphkit.io.bvh import read_bvh_skeleton

            m = read_bvh_skeleton(path)
            note = f"CMU BVH skeleton {path.name} ($MORPHKIT_DATA/human/cmu)"
        else:
            path = resolve_morphology("human")
            m = read_morphology(path)
            note = "shipped human (MORPHKIT_DATA unset: no CMU skeleton)"
    else:
        path = resolve_morphology(key)
        m = read_morphology(path)
        note = f"{path.name}"
    counts = {t: sum(j.type == t for j in m.joints) for t in JointType}
    kinds = ", ".join(f"{n} {t.name.lower()}" for t, n in counts.items() if n)
    note += f": {m.base.name.lower()} base, {m.link_count} links, {m.joint_count} joints ({kinds}), "
    note += f"{m.coordinate_count} coordinates"
    return Creature(key, m, Path(path), note)


def random_q(m: Morphology, batch: int, rng: np.random.Generator) -> np.ndarray:
    """Random valid coordinates [batch, coordinate_count] (float64).

    Base position ~ N(0, 0.5²) [m], rotations uniform unit quaternions, bounded joints uniform within
    their limits, unbounded ones uniform in [-π, π].
    """
    lower, upper = m.coordinate_limits
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    q = rng.uniform(lo, hi, size=(batch, m.coordinate_count))
    quat_starts = []
    if m.base == BaseType.FLOATING:
        q[:, :3] = rng.normal(scale=0.5, size=(batch, 3))
        quat_starts.append(3)
    quat_starts += [
        s
        for j, s in zip(m.joints, m.joint_q_start[:-1], strict=True)
        if j.type == JointType.SPHERICAL and not m.is_driven(j)
    ]
    for s in quat_starts:
        v = rng.normal(size=(batch, 4))
        q[:, s : s + 4] = v / np.linalg.norm(v, axis=1, keepdims=True)
    return q


# ---------------------------------------------------------------------------------------------
# implementations
# ---------------------------------------------------------------------------------------------
class MorphkitFK:
    """morphkit's raw Warp kernels (float32).

    ``fwd`` is :func:`~morphkit.kernels.eval_fk` (every link transform); ``fwd_bwd`` is the positions
    fast path :func:`~morphkit.kernels.eval_link_positions` and its adjoint with a seed of ones (the
    gradient of the sum of link positions), outputs and gradients preallocated and reused.
    """

    name = "morphkit"

    def __init__(self, m: Morphology, *, device: str = "cpu") -> None:
        from morphkit.model import compile_model

        self.m, self.device = m, device
        self.model = compile_model(m, device=device)

    def link_positions(self, q: np.ndarray) -> np.ndarray:
        from morphkit.kernels.fk import eval_fk

        return eval_fk(self.model, np.asarray(q, dtype=np.float32), device=self.device).numpy()[..., :3].astype(float)

    def workload(self, q: np.ndarray) -> Any:
        import warp as wp

        from morphkit.kernels.fk import eval_fk, eval_link_positions, eval_link_positions_adjoint

        model, device = self.model, self.device
        B, L = q.shape[0], self.m.link_count
        qw = wp.array(np.ascontiguousarray(q, dtype=np.float32), dtype=wp.float32, device=device)
        T = wp.empty((B, L), dtype=wp.transform, device=device)
        p = wp.empty((B, L), dtype=wp.vec3, device=device)
        seed = wp.array(np.ones((B, L, 3), dtype=np.float32), dtype=wp.vec3, device=device)
        grad = wp.zeros_like(qw)

        def fwd() -> Any:
            eval_fk(model, qw, out=T, device=device)
            wp.synchronize_device(device)
            return T

        def fwd_bwd() -> Any:
            eval_link_positions(model, qw, out=p, device=device)
            grad.zero_()
            eval_link_positions_adjoint(model, qw, seed, adj_q=grad, device=device)
            wp.synchronize_device(device)
            return grad

        return Workload(fwd, fwd_bwd, B)


class MorphkitTorchFK:
    """morphkit through its torch autograd bridge (:class:`morphkit.torch.ForwardKinematics`, float32).

    ``fwd`` calls the module (every link transform) under ``torch.no_grad``; ``fwd_bwd`` calls its
    positions fast path :meth:`~morphkit.torch.ForwardKinematics.link_positions` and backpropagates
    the sum through the Warp adjoint.
    """

    name = "morphkit_torch"

    def __init__(self, m: Morphology, *, device: str = "cpu") -> None:
        from morphkit.torch import ForwardKinematics

        self.m, self.device = m, device
        self.module = ForwardKinematics(m, device=device)

    def _positions(self, q: Any) -> Any:
        return self.module.link_positions(q)

    def link_positions(self, q: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            return self._positions(torch.as_tensor(q, dtype=torch.float32)).double().numpy()

    def workload(self, q: np.ndarray) -> Any:
        import torch


        qt = torch.as_tensor(np.ascontiguousarray(q), dtype=torch.float32)
        qg = qt.clone().requires_grad_(True)

        def fwd() -> Any:
            with torch.no_grad():
                return self.module(qt)

        def fwd_bwd() -> Any:
            qg.grad = None
            self._positions(qg).sum().backward()
            return qg.grad

        return Workload(fwd, fwd_bwd, q.shape[0])


class TorchReferenceFK:
    """Plain batched torch FK: :func:`morphkit.torch.reference.fk_reference` (float32 when timed, float64 as oracle)."""

    name = "torch"

    def __init__(self, m: Morphology, *, device: str = "cpu") -> None:
        from morphkit.model import compile_model
        from morphkit.torch.reference import fk_reference

        self.m, self.device = m, device
        self.model = compile_model(m, device=device)
        self.fk = fk_reference

    def link_positions(self, q: np.ndarray) -> np.ndarray:
        import torch

        with torch.no_grad():
            return self.fk(self.model, torch.as_tensor(q, dtype=torch.float64))[..., :3].numpy()

    def workload(self, q: np.ndarray) -> Any:
        import torch


        qt = torch.as_tensor(np.ascontiguousarray(q), dtype=torch.float32)
        qg = qt.clone().requires_grad_(True)
        model, fk = self.model, self.fk

        def fwd() -> Any:
            with torch.no_grad():
                return fk(model, qt)

        def fwd_bwd() -> Any:
            qg.grad = None
            fk(model, qg)[..., :3].sum().backward()
            return qg.grad

        return Workload(fwd, fwd_bwd, q.shape[0])


def make_impl(name: str, m: Morphology, *, device: str = "cpu", loop_poses: int = 2000) -> Any:
    """Build implementation ``name`` for ``m``.

    Raises:
        ImportError: when the peer library is not installed.
        ConfigError: for an unknown name or a creature the peer cannot express.
    """
    if name == "morphkit":
        return MorphkitFK(m, device=device)
    if name == "morphkit_torch":
        return MorphkitTorchFK(m, device=device)
    if name == "torch":
        return TorchReferenceFK(m, device=device)
    if name == "pytorch_kinematics":
        return PytorchKinematicsFK(m)
    if name == "pinocchio":
        return PinocchioFK(m, max_poses=loop_poses)
    if name == "mujoco":
        return MujocoFK(m, max_poses=loop_poses)
    raise ConfigError(f"unknown implementation {name!r}; expected one of: {', '.join(IMPLS)}")


# ---------------------------------------------------------------------------------------------
# measurement
# ---------------------------------------------------------------------------------------------
SLOW_CALL = 0.5
"""A warm-up call slower than this [s] is timed once more instead of ``repeats`` times (keeps runs short)."""


def _seconds_per_call(fn: Callable[[], Any], min_time: float) -> float:
    """One repeat: call ``fn`` until ``min_time`` [s] has passed; mean seconds per call."""
    calls = 0
    t0 = time.perf_counter()
    while True:
        fn()
        calls += 1
        elapsed = time.perf_counter() - t0
        if elapsed >= min_time:
            return elapsed / calls


def time_calls(fns: dict[str, tuple[Callable[[], Any], int]], *, repeats: int, min_time: float) -> dict[str, float]:
    """Poses per second of each ``name → (fn, poses per call)``: one warm-up each, then the best of ``repeats``.

    Repeats run in rounds over all functions (A, B, C, A, B, C, ...) rather than back to back, so
    a burst of load from other processes hits every implementation alike instead of one of them.
    A function whose warm-up took longer than :data:`SLOW_CALL` is timed in the first round only.
    """
    rounds: dict[str, int] = {}
    for name, (fn, _poses) in fns.items():
        t0 = time.perf_counter()
        fn()
        rounds[name] = 1 if time.perf_counter() - t0 > SLOW_CALL else max(1, repeats)
    best = dict.fromkeys(fns, float("inf"))
    for r in range(max(rounds.values(), default=0)):
        for name, (fn, _poses) in fns.items():
            if r < rounds[name]:
                best[name] = min(best[name], _seconds_per_call(fn, min_time))
    return {name: poses / best[name] for name, (_fn, poses) in fns.items()}


def bridge_latency(raw: Callable[[], Any], bridged: Callable[[], Any], *, calls: int = 400) -> dict[str, float]:
    """Median µs per call of the raw launcher and of the torch bridge, timed call by call, interleaved.

    Alternating the two calls exposes both to the same machine load, so the difference of the
    medians (``overhead``) stays meaningful on a busy machine.
    """
    raw()
    bridged()
    t_raw, t_bridged = [], []
    for _ in range(calls):
        t0 = time.perf_counter()
        raw()
        t1 = time.perf_counter()
        bridged()
        t2 = time.perf_counter()
        t_raw.append(t1 - t0)
        t_bridged.append(t2 - t1)
    med_raw, med_bridged = float(np.median(t_raw)) * 1e6, float(np.median(t_bridged)) * 1e6
    return {"raw": med_raw, "torch": med_bridged, "overhead": med_bridged - med_raw}


def _set_threads(n: int) -> None:
    import torch

    torch.set_num_threads(n)
    try:
        from morphkit.kernels import set_cpu_thread_count

        set_cpu_thread_count(n)
    except ImportError:  # pragma: no cover - the kernels are part of morphkit
        pass


def _agreement(impls: dict[str, Any], reference: Any, m: Morphology, rng: np.random.Generator) -> dict[str, float]:
    q = random_q(m, 8, rng)
    ref = reference.link_positions(q)
    return {name: float(np.abs(impl.link_positions(q) - ref).max()) for name, impl in impls.items()}


def _load_average() -> float:
    try:
        return os.getloadavg()[0]
    except OSError:  # pragma: no cover - not available on every platform
        return float("nan")


def run_fk_benchmark(config: BenchConfig, *, log: Callable[[str], None] | None = None) -> BenchResult:
    """Run every measurement of ``config``; peers that are not installed are skipped (and listed).

    Args:
        config: What to measure.
        log: Called with one line of progress per measurement (e.g. ``print`` to stderr).
    """
    log = log or (lambda _line: None)
    result = BenchResult(config=config)
    result.load.append(_load_average())
    _set_threads(config.threads)
    rng = np.random.default_rng(config.seed)
    for key in config.creatures:
        creature = load_creature(key)
        m = creature.morphology
        result.creatures[key] = creature.note
        impls: dict[str, Any] = {}
        for name in config.impls:
            try:
                impls[name] = make_impl(name, m, device=config.device, loop_poses=config.loop_poses)
            except ImportError as exc:
                result.skipped[name] = f"not installed ({exc.name or exc})"
            except ConfigError as exc:
                result.skipped[f"{key}/{name}"] = str(exc)
        reference = impls.get("torch") or TorchReferenceFK(m, device=config.device)
        result.agreement[key] = _agreement(impls, reference, m, rng)
        if config.compile_probe and "morphkit" in impls:
            from morphkit.bench.compile_probe import compile_probe

            log(f"{key}: compile probe (fresh subprocesses)")
            result.compile[key] = compile_probe(creature.path, device=config.device)
        if "morphkit" in impls and "morphkit_torch" in impls and "fwd" in config.modes:
            q1 = random_q(m, 1, rng)
            result.bridge[key] = bridge_latency(
                impls["morphkit"].workload(q1).fwd, impls["morphkit_torch"].workload(q1).fwd, calls=config.bridge_calls
            )
        q_all = random_q(m, max(config.batches), rng)
        for mode in config.modes:
            for batch in config.batches:
                fns: dict[str, tuple[Callable[[], Any], int]] = {}
                for name, impl in impls.items():
                    work = impl.workload(q_all[:batch])
                    fn = work.fwd if mode == "fwd" else work.fwd_bwd
                    if fn is None:
                        result.skipped[f"{key}/{name}/{mode}"] = "no gradient analogue"
                    else:
                        fns[name] = (fn, work.poses)
                rates = time_calls(fns, repeats=config.repeats, min_time=config.min_time)
                del fns
                for name, rate in rates.items():
                    result.records.append(
                        {"creature": key, "impl": name, "mode": mode, "batch": batch, "poses_per_s": round(rate, 1)}
                    )
                    log(f"{key:6s} {mode:7s} B={batch:<7d} {name:19s} {rate:14,.0f} poses/s")
    result.load.append(_load_average())
    if any(n in LOOP_PEERS for n in config.impls):
        result.notes.append(
            f"pinocchio and mujoco run one pose per call in a Python loop: each timed call covers "
            f"min(B, {config.loop_poses}) poses."
        )
    return result


