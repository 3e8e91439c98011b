"""Gaits chosen by leg count and speed, and the gait clock that blends between them.

A gait is a duty factor $\\beta$ (the fraction of a cycle each foot spends on the ground) and a
touchdown phase per leg: leg $l$ is in its stance part while $(\\phi - \\phi_l) \\bmod 1 < \\beta$,
with $\\phi$ the rollout's cycle phase. Gaits by leg count:

- four legs (two left, two right): walk (lateral sequence, $\\beta$ = 0.75), trot and pace (0.5),
  bound (0.4), transverse gallop (0.3);
- six legs (three a side): wave (0.83), ripple (0.67), tripod (0.5);
- two legs: walk (0.6, with double support) and run (0.35, with flight);
- any other count or layout: a rotary wave around the body (one leg swinging at a time,
  $\\beta = 1 - 1/n$) and, for an even count, alternating sets (neighbours around the body in
  antiphase, $\\beta$ = 0.5 — the tetrapod of eight legs); an odd count runs a fast wave instead.

The speed that picks a gait is the *speed fraction* $s \\in [0, 1]$: how much of the creature's
fastest stepping the current command needs (see :mod:`morphkit.synth.legged`). A gait with
duty $\\beta$ can deliver at most a fraction $s_\\beta$ of it at its highest step frequency (see
:func:`gait_bands`), so each band ends at 0.85 $s_\\beta$ of its slowest gait. Within a
band, alternatives (trot or pace; bound or gallop) are picked per command segment.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Gait", "GaitBand", "GaitClock", "gait_bands", "leg_layout"]


@dataclass(frozen=True)
class Gait:
    """A duty factor and one touchdown phase per leg."""

    name: str
    duty: float
    """Stance fraction of the cycle, in (0, 1)."""
    touchdown: tuple[float, ...]
    """Phase in [0, 1) at which each leg's stance begins (legs in body-plan order)."""


@dataclass(frozen=True)
class GaitBand:
    """Gaits used while the speed fraction is below ``upper`` (and above the previous band's)."""

    upper: float
    gaits: tuple[Gait, ...]
    weights: tuple[float, ...]
    """Probability of each alternative (sums to 1)."""


def leg_layout(feet_xy: np.ndarray) -> dict[str, list[int]]:
    """Sort legs by side and front to back from their nominal foot positions [NL, 2] (root frame).

    Returns ``{"left": [...], "right": [...], "ring": [...]}``: the left and right legs front to
    back (only when the legs split evenly across ``y = centroid``), and every leg in order around
    the body (counter-clockwise from the front).
    """
    xy = np.asarray(feet_xy, dtype=float)
    c = xy.mean(axis=0)
    d = xy - c
    angle = np.arctan2(d[:, 1], d[:, 0])  # front = 0, left = +pi/2
    ring = [int(i) for i in np.argsort(angle % (2 * np.pi), kind="stable")]
    left = [i for i in range(len(xy)) if d[i, 1] > 1e-6]
    right = [i for i in range(len(xy)) if d[i, 1] < -1e-6]
    layout = {"ring": ring, "left": [], "right": []}
    if len(left) == len(right) and len(left) + len(right) == len(xy):
        layout["left"] = sorted(left, key=lambda i: -xy[i, 0])
        layout["right"] = sorted(right, key=lambda i: -xy[i, 0])
    return layout


def _gait(name: str, duty: float, n: int, phases: dict[int, float]) -> Gait:
    return Gait(name, duty, tuple(float(phases[i] % 1.0) for i in range(n)))


def _capacity(duty: float, duty_min: float, overhead: float) -> float:
    return (duty_min / (1 - duty_min) + overhead) / (duty / (1 - duty) + overhead)


def gait_bands(feet_xy: np.ndarray, overhead: float = 0.0) -> tuple[GaitBand, ...]:
    """The gait bands of a creature whose legs stand at ``feet_xy`` [NL, 2] (root frame).

    ``overhead`` is the extra stance-like time a stride needs, in units of the shortest swing (the
    frames a swinging foot rises and lands vertically while the body moves on, see
    :mod:`morphkit.synth.legged`): a gait of duty $\beta$ then delivers
    $s_\beta = (\rho_{min} + o) / (\rho_\beta + o)$ with $\rho_\beta = \beta / (1 - \beta)$.
    """
    n = len(feet_xy)
    lay = leg_layout(feet_xy)
    L, Rt = lay["left"], lay["right"]
    bands: list[tuple[list[Gait], list[float]]] = []
    if n == 4 and len(L) == 2:
        lf, lh = L
        rf, rh = Rt
        walk = _gait("walk", 0.75, n, {lh: 0.0, lf: 0.25, rh: 0.5, rf: 0.75})
        trot = _gait("trot", 0.5, n, {lf: 0.0, rh: 0.0, rf: 0.5, lh: 0.5})
        pace = _gait("pace", 0.5, n, {lf: 0.0, lh: 0.0, rf: 0.5, rh: 0.5})
        bound = _gait("bound", 0.4, n, {lf: 0.0, rf: 0.0, lh: 0.5, rh: 0.5})
        gallop = _gait("gallop", 0.3, n, {lh: 0.0, rh: 0.1, lf: 0.5, rf: 0.6})
        bands = [([walk], [1.0]), ([trot, pace], [0.7, 0.3]), ([bound, gallop], [0.4, 0.6]), ([gallop], [1.0])]
    elif n == 6 and len(L) == 3:
        l1, l2, l3 = L
        r1, r2, r3 = Rt
        wave = _gait("wave", 5 / 6, n, {l3: 0, l2: 1 / 6, l1: 2 / 6, r3: 3 / 6, r2: 4 / 6, r1: 5 / 6})
        ripple = _gait("ripple", 2 / 3, n, {l3: 0, l2: 1 / 3, l1: 2 / 3, r3: 0.5, r2: 5 / 6, r1: 1 / 6})
        tripod = _gait("tripod", 0.5, n, {l1: 0, r2: 0, l3: 0, r1: 0.5, l2: 0.5, r3: 0.5})
        bands = [([wave], [1.0]), ([ripple], [1.0]), ([tripod], [1.0])]
    elif n == 2:
        a, b = (L[0], Rt[0]) if L else (0, 1)
        walk = _gait("walk", 0.6, n, {a: 0.0, b: 0.5})
        run = _gait("run", 0.35, n, {a: 0.0, b: 0.5})
        bands = [([walk], [1.0]), ([run], [1.0])]
    elif n == 1:
        bands = [([Gait("hop", 0.5, (0.0,))], [1.0])]
    else:
        ring = lay["ring"]
        wave = _gait("wave", 1.0 - 1.0 / n, n, {leg: k / n for k, leg in enumerate(ring)})
        if n % 2 == 0:
            fast = _gait("alternating", 0.5, n, {leg: 0.5 * (k % 2) for k, leg in enumerate(ring)})
        else:
            fast = _gait("fast_wave", 0.5, n, {leg: k / n for k, leg in enumerate(ring)})
        bands = [([wave], [1.0]), ([fast], [1.0])]
    duty_min = min(g.duty for gs, _ in bands for g in gs)
    out = []
    for i, (gs, ws) in enumerate(bands):
        upper = 0.85 * _capacity(max(g.duty for g in gs), duty_min, overhead) if i < len(bands) - 1 else np.inf
        out.append(GaitBand(float(upper), tuple(gs), tuple(ws)))
    return tuple(out)


class GaitClock:
    """Per-rollout gait state, vectorised over R rollouts: cycle phase, blended touchdown phases and duty.

    Args:
        bands: From :func:`gait_bands`.
        rollouts: R.
        blend_rate: How fast touchdown phases and duty move toward the new gait's [1/s].
    """

    def __init__(self, bands: tuple[GaitBand, ...], rollouts: int, *, blend_rate: float = 1.5) -> None:
        self.bands = bands
        self.gaits = [g for b in bands for g in b.gaits]
        names = []
        for g in self.gaits:
            if g.name not in names:
                names.append(g.name)
        self.gait_names = tuple(names)
        self._gait_code = np.array([names.index(g.name) for g in self.gaits])
        self._touch = np.array([g.touchdown for g in self.gaits])  # [G, NL]
        self._duty = np.array([g.duty for g in self.gaits])
        self._upper = np.array([b.upper for b in bands])
        # cumulative weights per band over the flat gait list
        self._band_first = np.cumsum([0] + [len(b.gaits) for b in bands])[:-1]
        self._band_cum = [np.cumsum(b.weights) for b in bands]
        self.blend_rate = blend_rate
        first = self.gaits[0]
        self.phase = np.zeros(rollouts)
        self.touchdown = np.tile(np.array(first.touchdown), (rollouts, 1))
        self.duty = np.full(rollouts, first.duty)
        self.current = np.zeros(rollouts, dtype=np.int64)
        self.duty_min = float(self._duty.min())

    def select(self, s: np.ndarray, choice: np.ndarray) -> np.ndarray:
        """Index into ``self.gaits`` of the gait for speed fraction ``s`` [R] and segment choice [R]."""
        band = np.minimum(np.searchsorted(self._upper, s, side="right"), len(self.bands) - 1)
        out = np.empty(len(s), dtype=np.int64)
        for b in np.unique(band):
            sel = band == b
            k = np.searchsorted(self._band_cum[b], choice[sel] * self._band_cum[b][-1], side="right")
            out[sel] = self._band_first[b] + np.minimum(k, len(self.bands[b].gaits) - 1)
        return out

    def advance(self, s: np.ndarray, choice: np.ndarray, frequency_of_duty, dt: float) -> np.ndarray:
        """Blend toward the gait for ``s`` and advance the phase; returns each leg's phase [R, NL].

        ``frequency_of_duty(duty [R]) -> [R]`` gives the cycle frequency [Hz] for the blended duty.
        """
        g = self.select(s, choice)
        self.current = g
        step = self.blend_rate * dt
        d = (self._touch[g] - self.touchdown + 0.5) % 1.0 - 0.5
        self.touchdown = (self.touchdown + np.clip(d, -step, step)) % 1.0
        self.duty = self.duty + np.clip(self._duty[g] - self.duty, -step, step)
        f = frequency_of_duty(self.duty)
        self.phase = (self.phase + f * dt) % 1.0
        self.frequency = f
        return (self.phase[:, None] - self.touchdown) % 1.0

    @property
    def gait_code(self) -> np.ndarray:
        """Index into ``gait_names`` of each rollout's target gait [R]."""
        return self._gait_code[self.current]
