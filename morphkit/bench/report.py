"""The FK benchmark's report: markdown tables, and the check against the project's speed targets.

The targets are data, not code: ``benchmarks/fk_targets.yaml`` beside the benchmark scripts (read
with :func:`load_targets`) lists each one as a kind, what it measures and a bound:

- ``rate``: poses/s of ``impl`` on ``creature`` in ``mode`` at the file's ``batch``;
- ``speedup``: that rate over the rate of the implementation ``over``;
- ``bridge_overhead``: µs the torch bridge adds to one B = 1 call, for every creature measured;
- ``cold_compile``: seconds of the first FK call on an empty kernel cache, for every creature measured.

Each has ``at_least`` or ``at_most``. A target the run did not measure is left out of the check.
"""

from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.bench.fk import IMPLS, MODES, BenchResult
from morphkit.errors import ConfigError
from morphkit.yaml_loader import load_yaml_file

__all__ = [
    "TARGET_KINDS",
    "FKTargets",
    "Target",
    "TargetCheck",
    "check_targets",
    "checkout_targets",
    "load_targets",
    "markdown_report",
]

TARGET_KINDS = ("rate", "speedup", "bridge_overhead", "cold_compile")
"""The kinds of target a targets file may list."""
_UNITS = {"rate": "poses/s", "speedup": "×", "bridge_overhead": "µs", "cold_compile": "s"}
_MODE_LABELS = {"fwd": "fwd", "fwd_bwd": "fwd+bwd"}


@dataclass(frozen=True)
class Target:
    """One speed target of a targets file (see the module docstring for the kinds)."""

    kind: str
    """One of :data:`TARGET_KINDS`."""
    bound: float
    """The threshold, in the kind's unit (poses/s, ×, µs or s)."""
    at_least: bool
    """``True`` for ``at_least`` (higher is better), ``False`` for ``at_most``."""
    creature: str | None = None
    """``rate`` and ``speedup``: the creature key (``spot``, ``human``)."""
    mode: str | None = None
    """``rate`` and ``speedup``: ``fwd`` or ``fwd_bwd``."""
    impl: str | None = None
    """``rate`` and ``speedup``: the implementation measured."""
    over: str | None = None
    """``speedup``: the implementation it is compared with."""


@dataclass(frozen=True)
class FKTargets:
    """The targets of one file and the batch size their rates refer to."""

    batch: int
    """Batch size [poses] of the ``rate`` and ``speedup`` targets."""
    targets: tuple[Target, ...]
    source: Path | None = None
    """The file they were read from."""


@dataclass(frozen=True)
class TargetCheck:
    """One target: the measured value against its threshold."""

    name: str
    value: float
    threshold: float
    unit: str
    higher_is_better: bool = True

    @property
    def passed(self) -> bool:
        return self.value >= self.threshold if self.higher_is_better else self.value <= self.threshold

    @property
    def margin(self) -> float:
        """Measured over threshold (≥ 1 passes) for higher-is-better targets, threshold over measured otherwise."""
        if self.higher_is_better:
            return self.value / self.threshold
        return self.threshold / self.value if self.value > 0 else float("inf")


def checkout_targets() -> Path | None:
    """``benchmarks/fk_targets.yaml`` of the source checkout this morphkit runs from (``None`` when installed
    from a wheel, which ships no benchmarks)."""
    path = Path(__file__).resolve().parents[2] / "benchmarks" / "fk_targets.yaml"
    return path if path.is_file() else None


def load_targets(path: str | Path) -> FKTargets:
    """Read a targets file (YAML: ``batch`` and a list ``targets``; see the module docstring).

    Raises:
        ConfigError: naming the file and the entry when it is unreadable or an entry is malformed.
    """
    path = Path(path)
    data = load_yaml_file(path, what="the benchmark targets")
    if not isinstance(data, dict) or not isinstance(data.get("batch"), int) or data["batch"] < 1:
        raise ConfigError(f"{path}: expected a mapping with a positive integer 'batch' and a list 'targets'")
    entries = data.get("targets")
    if not isinstance(entries, list):
        raise ConfigError(f"{path}: 'targets' must be a list")
    return FKTargets(int(data["batch"]), tuple(_target(e, f"{path}: targets[{i}]") for i, e in enumerate(entries)),
                     path)


def _target(entry: Any, where: str) -> Target:
    if not isinstance(entry, dict):
        raise ConfigError(f"{where}: expected a mapping, got {entry!r}")
    kind = entry.get("kind")
    if kind not in TARGET_KINDS:
        raise ConfigError(f"{where}: unknown kind {kind!r}; expected one of: {', '.join(TARGET_KINDS)}")
    bounds = [k for k in ("at_least", "at_most") if k in entry]
    if len(bounds) != 1 or not isinstance(entry[bounds[0]], (int, float)):
        hint = ""
        if len(bounds) == 1 and isinstance(entry[bounds[0]], str):
            hint = f" ({entry[bounds[0]]!r} is text, not a number)"
        raise ConfigError(f"{where}: give exactly one number, at_least or at_most{hint}")
    needed = {"rate": ("creature", "mode", "impl"), "speedup": ("creature", "mode", "impl", "over")}.get(kind, ())
    allowed = {"kind", bounds[0], *needed}
    extra = sorted(set(entry) - allowed)
    missing = [k for k in needed if k not in entry]
    if extra or missing:
        raise ConfigError(f"{where}: {kind} takes {', '.join(sorted(allowed))}"
                          + (f"; missing {', '.join(missing)}" if missing else "")
                          + (f"; unexpected {', '.join(extra)}" if extra else ""))
    if "mode" in entry and entry["mode"] not in MODES:
        raise ConfigError(f"{where}: unknown mode {entry['mode']!r}; expected one of: {', '.join(MODES)}")
    for k in ("impl", "over"):
        if k in entry and entry[k] not in IMPLS:
            raise ConfigError(f"{where}: unknown {k} {entry[k]!r}; expected one of: {', '.join(IMPLS)}")
    return Target(kind, float(entry[bounds[0]]), bounds[0] == "at_least", creature=entry.get("creature"),
                  mode=entry.get("mode"), impl=entry.get("impl"), over=entry.get("over"))


def check_targets(result: BenchResult, targets: FKTargets) -> list[TargetCheck]:
    """The ``targets`` this run measured, in the file's order, with their measured values."""
    checks: list[TargetCheck] = []
    for t in targets.targets:
        unit, better = _UNITS[t.kind], t.at_least
        if t.kind in ("rate", "speedup"):
            assert t.creature is not None and t.impl is not None and t.mode is not None
            value = result.rate(t.creature, t.impl, t.mode, targets.batch)
            name = f"{t.creature} {_MODE_LABELS[t.mode]}, {t.impl}"
            if value is None:
                continue
            if t.kind == "speedup":
                assert t.over is not None
                other = result.rate(t.creature, t.over, t.mode, targets.batch)
                if not other:
                    continue
                value, name = value / other, f"{name} / {t.over}"
            checks.append(TargetCheck(name, value, t.bound, unit, better))
        elif t.kind == "bridge_overhead":
            checks += [TargetCheck(f"{key} torch bridge overhead at B=1", lat["overhead"], t.bound, unit, better)
                       for key, lat in result.bridge.items()]
        else:
            checks += [TargetCheck(f"{key} first-call compile (cold cache)", tm["cold"], t.bound, unit, better)
                       for key, tm in result.compile.items() if "cold" in tm]
    return checks


def _fmt_rate(r: float | None) -> str:
    if r is None:
        return "—"
    for scale, suffix in ((1e6, " M"), (1e3, " k")):
        if r >= scale:
            return f"{r / scale:.3g}{suffix}"
    return f"{r:.3g}"



def markdown_report(result: BenchResult, targets: FKTargets | None = None) -> str:
    """The run as markdown: per creature and mode, poses/s per implementation with morphkit's speedup.

    With ``targets`` (:func:`load_targets`), a last section checks the ones this run measured.
    """
    cfg = result.config
    impls = [i for i in cfg.impls if any(r["impl"] == i for r in result.records)]
    lines = [
        f"FK throughput, poses/s (float32 unless noted; {cfg.threads} threads, "
        f"OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY', 'unset')}; best of {cfg.repeats}); "
        "`(×N)` = morphkit is N× faster than that implementation.",
        "",
        f"Machine: {platform.platform()}, {_cpu_name()}, {os.cpu_count()} CPUs; "
        f"date {time.strftime('%Y-%m-%d')}"
        + (f"; load average {result.load[0]:.1f} at start, {result.load[-1]:.1f} at end." if result.load else "."),
        "",
    ]
    for key, note in result.creatures.items():
        lines.append(f"- **{key}**: {note}")
    lines.append("")
    for key in result.creatures:
        for mode in cfg.modes:
            title = "forward" if mode == "fwd" else "forward + backward (∂ Σ link positions / ∂ q)"
            lines += [f"### {key}, {title}", ""]
            lines.append("| B | " + " | ".join(impls) + " |")
            lines.append("|---:|" + "---:|" * len(impls))
            for batch in cfg.batches:
                ref = result.rate(key, "morphkit", mode, batch)
                cells = []
                for impl in impls:
                    r = result.rate(key, impl, mode, batch)
                    cell = _fmt_rate(r)
                    if r and ref and impl != "morphkit":
                        cell += f" (×{ref / r:.3g})"
                    cells.append(cell)
                lines.append(f"| {batch} | " + " | ".join(cells) + " |")
            lines.append("")
    lines += ["### Agreement with the torch reference (max |Δ link position| at 8 random poses)", ""]
    lines.append("| creature | " + " | ".join(impls) + " |")
    lines.append("|---|" + "---:|" * len(impls))
    for key, errs in result.agreement.items():
        lines.append(f"| {key} | " + " | ".join(f"{errs[i]:.1e} m" if i in errs else "—" for i in impls) + " |")
    lines.append("")
    if result.compile:
        lines += ["### First call (fresh subprocess; excludes interpreter start and `import warp`)", ""]
        lines.append(
            "| creature | FK, cold kernel cache | FK, warm cache | torch fwd+bwd, cold | torch fwd+bwd, warm |"
        )
        lines.append("|---|---:|---:|---:|---:|")
        for key, t in result.compile.items():
            cells = [t.get(k) for k in ("cold", "warm_cache", "cold_torch", "warm_cache_torch")]
            lines.append(f"| {key} | " + " | ".join("—" if v is None else f"{v:.2f} s" for v in cells) + " |")
        lines.append("")
    if result.bridge:
        lines += [
            f"### Torch bridge at B = 1 (median of {cfg.bridge_calls} interleaved calls)",
            "",
            "| creature | raw `eval_fk` call | `ForwardKinematics` call | bridge overhead |",
            "|---|---:|---:|---:|",
        ]
        for key, lat in result.bridge.items():
            lines.append(f"| {key} | {lat['raw']:.1f} µs | {lat['torch']:.1f} µs | {lat['overhead']:.1f} µs |")
        lines.append("")
    checks = check_targets(result, targets) if targets is not None else []
    if checks:
        lines += [f"### Targets (B = {targets.batch})", ""]
        for c in checks:
            verdict = "PASS" if c.passed else "MISS"
            cmp = "≥" if c.higher_is_better else "≤"
            lines.append(
                f"- {verdict} {c.name}: {_fmt_value(c.value, c.unit)} (target {cmp} {_fmt_value(c.threshold, c.unit)}; "
                f"margin {_fmt_margin(c.margin)})"
            )
        lines.append("")
    for note in result.notes:
        lines.append(f"Note: {note}")
    for what, why in result.skipped.items():
        lines.append(f"Skipped {what}: {why}")
    return "\n".join(lines).rstrip() + "\n"


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _fmt_margin(margin: float) -> str:
    return "—" if not np.isfinite(margin) or margin <= 0 else f"{margin:.2f}×"


def _fmt_value(v: float, unit: str) -> str:
    if unit == "poses/s":
        return f"{_fmt_rate(v)} poses/s"
    if unit == "×":
        return f"{v:.3g}×"
    return f"{v:.3g} {unit}"


def _cpu_name() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _fmt_margin(margin: float) -> str:
    return "—" if not np.isfinite(margin) or margin <= 0 else f"{margin:.2f}×"


def _fmt_value(v: float, unit: str) -> str:
    if unit == "poses/s":
        return f"{_fmt_rate(v)} poses/s"
    if unit == "×":
        return f"{v:.3g}×"
    return f"{v:.3g} {unit}"
