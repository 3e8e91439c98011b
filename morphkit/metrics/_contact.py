"""Foot-contact figures of a motion: per-foot UFR rates, UFR at three settings, GMD's skating ratio,
PhysDiff's Penetrate / Float / Skate and flight detection.

All functions read the motion's end-effector positions (:meth:`~morphkit.motion.Motion.end_effector_positions`,
world frame, z up, metres). Feet are the end-effectors whose role is ``foot``
(:func:`~morphkit.kernels.foot_indices`) unless ``feet=`` names them; the ground is the plane
$z = z_g$ (``ground_height``). A foot is *in contact* when its height $h = p_z - z_g$ is strictly
below a contact height. A creature without feet scores 0 everywhere (nothing to measure).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np

from morphkit.contact_rules import GMD_SKATING, PHYSDIFF, UFR
from morphkit.errors import ConfigError
from morphkit.metrics._unrealistic import UnrealisticFrameThresholds, contact_over_difference, feet_of

if TYPE_CHECKING:
    from morphkit.motion import Motion

__all__ = [
    "UFR_LOOSE",
    "UFR_MEDIUM",
    "UFR_SETTINGS",
    "UFR_STRICT",
    "FootContactFigures",
    "PhysDiffFigures",
    "floating_frames",
    "foot_contact_figures",
    "longest_flight",
    "physdiff_figures",
    "skating_ratio",
]

UFR_STRICT = UnrealisticFrameThresholds()
"""UFR's default thresholds: contact below 2 cm, sliding above 0.2 m/s, penetration beyond 5 mm."""
UFR_MEDIUM = UnrealisticFrameThresholds(contact_height=GMD_SKATING.height, sliding_speed=GMD_SKATING.speed,
                                        penetration_depth=0.01)
"""Contact below 5 cm, sliding above 0.5 m/s (GMD's skating thresholds), penetration beyond 1 cm."""
UFR_LOOSE = UnrealisticFrameThresholds(contact_height=0.05, sliding_speed=1.0, penetration_depth=0.02)
"""Contact below 5 cm, sliding above 1 m/s, penetration beyond 2 cm."""
UFR_SETTINGS: Mapping[str, UnrealisticFrameThresholds] = MappingProxyType(
    {"strict": UFR_STRICT, "medium": UFR_MEDIUM, "loose": UFR_LOOSE}
)
"""The three settings by name (read-only mapping; self-collision thresholds are the defaults in all three)."""


def _feet(motion: Motion, feet: Sequence[str] | None, who: str) -> tuple[np.ndarray, tuple[str, ...]]:
    """Indices [F] into the motion's end-effectors of the feet, and their names."""
    return feet_of(motion, feet, who)


def _check_number(who: str, name: str, value: float, *, positive: bool = False) -> float:
    if not isinstance(value, (int, float, np.number)) or not np.isfinite(value):
        raise ConfigError(f"{who}: {name} must be a finite number, got {value!r}")
    if value < 0 or (positive and value == 0):
        raise ConfigError(f"{who}: {name} must be {'> 0' if positive else '>= 0'}, got {value!r}")
    return float(value)


def _check_ground(who: str, ground_height: float) -> float:
    if not isinstance(ground_height, (int, float, np.number)) or not np.isfinite(ground_height):
        raise ConfigError(f"{who}: ground_height must be a finite number, got {ground_height!r}")
    return float(ground_height)


def _frozen(a: np.ndarray, dtype: type = bool) -> np.ndarray:
    a = np.asarray(a, dtype=dtype)
    a.setflags(write=False)
    return a


# ---------------------------------------------------------------------------------------------
# UFR per foot-frame
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class FootContactFigures:
    """Sliding and penetration of each foot at each frame (:func:`foot_contact_figures`).

    A *foot-frame* is one foot at one frame; rates are fractions of foot-frames in [0, 1] (0 when
    there are none). The flags are read-only boolean arrays [T, F].
    """

    sliding: np.ndarray
    """Foot f slides at frame t, shape [T, F] (UFR's sliding test, per foot)."""
    penetration: np.ndarray
    """Foot f is deeper below the ground than the threshold at frame t, shape [T, F]."""
    foot_names: tuple[str, ...] = ()
    """The F feet, in column order."""

    @property
    def frame_count(self) -> int:
        """T."""
        return int(self.sliding.shape[0])

    @property
    def foot_frame_count(self) -> int:
        """T × F."""
        return int(self.sliding.size)

    @property
    def sliding_rate(self) -> float:
        """Sliding foot-frames / all foot-frames."""
        return float(self.sliding.mean()) if self.sliding.size else 0.0

    @property
    def penetration_rate(self) -> float:
        """Penetrating foot-frames / all foot-frames."""
        return float(self.penetration.mean()) if self.penetration.size else 0.0

    @property
    def sliding_rate_per_foot(self) -> np.ndarray:
        """Fraction of frames each foot slides, shape [F] (zeros for no frames)."""
        return self.sliding.mean(axis=0) if self.frame_count else np.zeros(len(self.foot_names))

    @property
    def penetration_rate_per_foot(self) -> np.ndarray:
        """Fraction of frames each foot penetrates, shape [F] (zeros for no frames)."""
        return self.penetration.mean(axis=0) if self.frame_count else np.zeros(len(self.foot_names))

    @staticmethod
    def concatenate(results: Sequence[FootContactFigures]) -> FootContactFigures:
        """Several motions' flags end to end (rates then pool their foot-frames); all must have the same feet.

        Raises:
            ConfigError: the results name different feet.
        """
        if not results:
            return FootContactFigures(_frozen(np.zeros((0, 0))), _frozen(np.zeros((0, 0))))
        feet = results[0].foot_names
        for r in results[1:]:
            if r.foot_names != feet:
                raise ConfigError(f"FootContactFigures.concatenate: feet {r.foot_names} differ from {feet}")
        return FootContactFigures(
            _frozen(np.concatenate([r.sliding for r in results])),
            _frozen(np.concatenate([r.penetration for r in results])),
            feet,
        )


def foot_contact_figures(
    motion: Motion,
    thresholds: UnrealisticFrameThresholds | None = None,
    *,
    feet: Sequence[str] | None = None,
) -> FootContactFigures:
    """UFR's foot sliding and foot penetration per foot-frame instead of per frame.

    The tests are exactly :func:`~morphkit.metrics.unrealistic_frame_ratio`'s, kept per foot:

    - **sliding**: the foot is in contact ($h <$ ``contact_height``) at frame t and at every frame
      its velocity is measured from (t - 1 and t; frame 0 from frames 0 and 1, as
      :data:`morphkit.conventions.VELOCITY_DIFFERENCE`), and its horizontal speed
      (:func:`~morphkit.kernels.eval_sliding_speed`, backward differences times ``motion.fps``)
      exceeds ``sliding_speed``;
    - **penetration**: its depth $\\max(0, z_g - p_z)$ exceeds ``penetration_depth``.

    So UFR's frame flags are these flags' ``any`` over feet: one foot of four sliding at every
    frame is a UFR frame-sliding ratio of 1 but a sliding rate of 0.25 here.

    Args:
        motion: The motion.
        thresholds: What counts as unrealistic (default :data:`UFR_STRICT`; self-collision and
            ``rest_margin`` are not used).
        feet: End-effector names to check as feet (default: role ``foot``).

    Returns:
        The flags [T, F] and their rates (:class:`FootContactFigures`).

    Raises:
        ConfigError: an unknown foot name.
    """
    from morphkit.kernels import eval_foot_heights, eval_penetration_depth, eval_sliding_speed

    thr = UFR_STRICT if thresholds is None else thresholds
    idx, names = _feet(motion, feet, "foot_contact_figures")
    T, F = motion.frame_count, len(idx)
    sliding = np.zeros((T, F), dtype=bool)
    penetration = np.zeros((T, F), dtype=bool)
    if T and F:
        pos = motion.end_effector_positions()  # [T, E, 3] world [m]
        g = thr.ground_height
        penetration = eval_penetration_depth(pos, feet=idx, ground_height=g).numpy() > thr.penetration_depth
        height = eval_foot_heights(pos, feet=idx, ground_height=g).numpy()  # [T, F] [m]
        speed = eval_sliding_speed(
            pos, motion.fps, feet=idx, height_threshold=thr.contact_height, ground_height=g
        ).numpy()  # [T, F] [m/s]
        sliding = (speed > thr.sliding_speed) & contact_over_difference(height < thr.contact_height)
    return FootContactFigures(_frozen(sliding), _frozen(penetration), names)


# ---------------------------------------------------------------------------------------------
# GMD: skating ratio
# ---------------------------------------------------------------------------------------------
def _centred_moving_average(x: np.ndarray, size: int) -> np.ndarray:
    """Mean over ``size`` rows around each row of ``x`` [N, ...], rows outside counting as 0.

    Row k averages rows ``k - size // 2 .. k - size // 2 + size - 1``: SciPy's
    ``uniform_filter1d(x, size, axis=0, mode="constant", origin=0)``.
    """
    left = size // 2
    pad = [(left, size - 1 - left)] + [(0, 0)] * (x.ndim - 1)
    c = np.cumsum(np.pad(x, pad), axis=0)
    c = np.concatenate([np.zeros_like(c[:1]), c])
    return (c[size:] - c[:-size]) / size


def skating_ratio(
    motion: Motion,
    height: float = GMD_SKATING.height,
    speed: float = GMD_SKATING.speed,
    *,
    window: int = 5,
    ground_height: float = 0.0,
    feet: Sequence[str] | None = None,
) -> float:
    """GMD's skating ratio (Karunratanakul et al. 2023, guided motion diffusion), on the creature's feet.

    Over the T - 1 *transitions* k = 0 .. T - 2 (from frame k to frame k + 1), foot f skates at k
    when all of:

    - it is in contact at both ends: $h_{k,f} <$ ``height`` and $h_{k+1,f} <$ ``height``;
    - its horizontal speed $s_{k,f} = \\lVert (p_{k+1} - p_k)_{xy} \\rVert \\cdot \\mathrm{fps}$
      exceeds ``speed``;
    - the mean of $s_{\\cdot,f}$ over ``window`` transitions centred on k (k - window // 2 ..
      k - window // 2 + window - 1; transitions beyond the clip count as speed 0, so the ends
      are diluted) also exceeds ``speed``.

    The ratio is the number of transitions at which *some* foot skates, divided by T - 1 (0 for
    fewer than two frames or no feet). This follows GMD's released evaluation code
    (``calculate_skating_ratio``: 5 cm, 0.5 m/s and a 5-transition zero-padded moving average,
    on the SMPL feet joints of y-up data); ours are z up, the feet are the end-effectors whose
    role is ``foot``, the fps is the motion's, and ``window=1`` drops the moving average (the
    plain definition: contact at both frames and speed above ``speed``).

    Args:
        motion: The motion.
        height: Contact height [m] (GMD: 5 cm).
        speed: Skating speed [m/s] (GMD: 0.5 m/s).
        window: Moving-average length in transitions, >= 1 (GMD: 5).
        ground_height: Ground plane height $z_g$ [m].
        feet: End-effector names to check as feet (default: role ``foot``).

    Returns:
        The skating ratio in [0, 1].

    Raises:
        ConfigError: a negative or non-finite threshold, ``window`` < 1, an unknown foot.
    """
    who = "skating_ratio"
    height = _check_number(who, "height", height)
    speed = _check_number(who, "speed", speed)
    if isinstance(window, bool) or not isinstance(window, (int, np.integer)) or window < 1:
        raise ConfigError(f"{who}: window must be an integer >= 1, got {window!r}")
    g = _check_ground(who, ground_height)
    idx, _ = _feet(motion, feet, who)
    T = motion.frame_count
    if T < 2 or not len(idx):
        return 0.0
    p = motion.end_effector_positions()[:, idx]  # [T, F, 3] [m]
    s = np.linalg.norm(p[1:, :, :2] - p[:-1, :, :2], axis=-1) * motion.fps  # [T-1, F] [m/s]
    h = p[:, :, 2] - g  # [T, F] [m]
    contact = (h[:-1] < height) & (h[1:] < height)  # [T-1, F]
    skating = contact & (s > speed) & (_centred_moving_average(s, int(window)) > speed)
    return float(skating.any(axis=1).mean())


# ---------------------------------------------------------------------------------------------
# PhysDiff: Penetrate, Float, Skate
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PhysDiffFigures:
    """PhysDiff's physics figures of a motion (:func:`physdiff_figures`), in millimetres; lower is better."""

    penetrate_mm: float
    """Mean over frames of the deepest foot's depth below the ground [mm]."""
    float_mm: float
    """Mean over frames of the lowest foot's height above the ground, 0 when it is below [mm]."""
    skate_mm: float
    """Mean horizontal displacement between consecutive frames of feet in contact at both [mm]."""


def physdiff_figures(
    motion: Motion,
    *,
    ground_height: float = 0.0,
    contact_height: float = PHYSDIFF.height,
    feet: Sequence[str] | None = None,
) -> PhysDiffFigures:
    """PhysDiff's Penetrate, Float and Skate (Yuan et al. 2023), on the creature's feet.

    PhysDiff measures them on the SMPL body; here the points are the feet, the end-effectors whose
    role is ``foot``. With heights $h_{t,f} = p_{t,f,z} - z_g$ over T frames and F feet:

    - **Penetrate** $= \\frac{1}{T}\\sum_t \\max_f \\max(0, -h_{t,f})$: per frame the deepest
      foot's depth (0 when no foot is below the ground), averaged over all frames;
    - **Float** $= \\frac{1}{T}\\sum_t \\max(0, \\min_f h_{t,f})$: per frame the lowest foot's
      height when it is above the ground (0 otherwise), averaged over all frames; no tolerance;
    - **Skate**: over the T - 1 transitions between consecutive frames, the pairs (k, f) with
      foot f in contact at both ends ($h_{k,f} <$ ``contact_height`` and
      $h_{k+1,f} <$ ``contact_height``); Skate is the mean over those pairs of the horizontal
      displacement $\\lVert (p_{k+1,f} - p_{k,f})_{xy} \\rVert$ (per frame, not per second; 0 when
      there is no such pair). The contact height is ours (5 cm, as GMD's skating ratio).

    All three are 0 for a creature without feet or an empty motion (Skate also for one frame).

    Args:
        motion: The motion.
        ground_height: Ground plane height $z_g$ [m].
        contact_height: A foot lower than this is in contact, for Skate [m].
        feet: End-effector names to use as feet (default: role ``foot``).

    Returns:
        The three figures in millimetres.

    Raises:
        ConfigError: a negative or non-finite ``contact_height``, a non-finite ground, an unknown foot.
    """
    who = "physdiff_figures"
    g = _check_ground(who, ground_height)
    ch = _check_number(who, "contact_height", contact_height)
    idx, _ = _feet(motion, feet, who)
    T = motion.frame_count
    if not T or not len(idx):
        return PhysDiffFigures(0.0, 0.0, 0.0)
    p = motion.end_effector_positions()[:, idx]  # [T, F, 3] [m]
    h = p[:, :, 2] - g  # [T, F]
    penetrate = float(np.maximum(-h, 0.0).max(axis=1).mean())
    floating = float(np.maximum(h.min(axis=1), 0.0).mean())
    contact = (h[:-1] < ch) & (h[1:] < ch)  # [T-1, F]
    disp = np.linalg.norm(p[1:, :, :2] - p[:-1, :, :2], axis=-1)  # [T-1, F] [m]
    skate = float(disp[contact].mean()) if contact.any() else 0.0
    return PhysDiffFigures(1000.0 * penetrate, 1000.0 * floating, 1000.0 * skate)


# ---------------------------------------------------------------------------------------------
# flights
# ---------------------------------------------------------------------------------------------
def _airborne(
    motion: Motion, contact_height: float, ground_height: float, feet: Sequence[str] | None, who: str
) -> np.ndarray | None:
    """Frames with no foot in contact, shape [T]; None for a creature without feet."""
    ch = _check_number(who, "contact_height", contact_height)
    g = _check_ground(who, ground_height)
    idx, _ = _feet(motion, feet, who)
    if not len(idx):
        return None
    h = motion.end_effector_positions()[:, idx, 2] - g  # [T, F]
    return ~(h < ch).any(axis=1)


def _runs(flags: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs ``[start, stop)`` of True in a boolean array [T]."""
    edges = np.diff(np.concatenate([[0], flags.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(), strict=True))


def longest_flight(
    motion: Motion,
    contact_height: float = UFR.height,
    *,
    ground_height: float = 0.0,
    feet: Sequence[str] | None = None,
) -> int:
    """The longest run of consecutive frames with no foot in contact ($h \\ge$ ``contact_height`` for every foot).

    Meant to be measured on a creature's own data set (the max over its clips; a flight does not
    run across clips) and passed to :func:`floating_frames`. 0 for a creature without feet.

    Args:
        motion: The motion.
        contact_height: A foot lower than this above the ground is in contact [m] (2 cm, as UFR).
        ground_height: Ground plane height $z_g$ [m].
        feet: End-effector names to use as feet (default: role ``foot``).

    Returns:
        The longest flight, in frames.

    Raises:
        ConfigError: a negative or non-finite height, an unknown foot.
    """
    air = _airborne(motion, contact_height, ground_height, feet, "longest_flight")
    if air is None:
        return 0
    return max((stop - start for start, stop in _runs(air)), default=0)


def floating_frames(
    motion: Motion,
    longest_flight_frames: int,
    contact_height: float = UFR.height,
    *,
    ground_height: float = 0.0,
    feet: Sequence[str] | None = None,
) -> np.ndarray:
    """Frames of flights longer than a legged creature can make: the creature floats.

    A flight is a maximal run of consecutive frames with no foot in contact (every foot at
    $h \\ge$ ``contact_height``); every frame of a flight longer than ``longest_flight_frames``
    frames is flagged (the whole run, not only its excess). The limit is the creature's own, e.g.
    :func:`longest_flight` over its data set. A creature without feet is never flagged.

    Args:
        motion: The motion.
        longest_flight_frames: The longest flight allowed, in frames (>= 0).
        contact_height: A foot lower than this above the ground is in contact [m] (2 cm, as UFR).
        ground_height: Ground plane height $z_g$ [m].
        feet: End-effector names to use as feet (default: role ``foot``).

    Returns:
        Floating frames, boolean [T].

    Raises:
        ConfigError: a negative limit, a negative or non-finite height, an unknown foot.
    """
    who = "floating_frames"
    if (
        isinstance(longest_flight_frames, bool)
        or not isinstance(longest_flight_frames, (int, np.integer))
        or longest_flight_frames < 0
    ):
        raise ConfigError(f"{who}: longest_flight_frames must be an integer >= 0, got {longest_flight_frames!r}")
    air = _airborne(motion, contact_height, ground_height, feet, who)
    out = np.zeros(motion.frame_count, dtype=bool)
    if air is not None:
        for start, stop in _runs(air):
            if stop - start > longest_flight_frames:
                out[start:stop] = True
    return out
