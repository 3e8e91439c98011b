"""ACE's configuration (Li et al. 2023, §4–7): one frozen dataclass per stage, and the presets.

Every size, loss and weight the paper gives is its value at ``paper``; everything the paper leaves
open is named here as morphkit's choice (see ``docs/guides/train-ace.md``):

* the VAE's β, rollout length and teacher/ramp/student schedule (MotionVAE's 8-step scheduled
  sampling, its β = 1 with the KL averaged per latent element);
* learning rates, batch sizes, epochs, Adam betas (ASE-style 0.5/0.999 for the GAN stage);
* ``w_adv`` and ``w_fea`` (not given in the paper: 0.3 and 1 here), the D:G step ratio (1:1);
* the human window length of a retargeting rollout and where truncated backpropagation cuts it;
* the character start state of a rollout (a random frame of the character's data in training; the
  data frame nearest the human's first frame in Ψ when retargeting).

Beyond the paper, on by default because they keep planted feet planted (measured, see their
docstrings): the prior's foot term (``PriorConfig.foot_weight``) and a discriminator that judges the
exported motion (``RetargetConfig.discriminate_exported``). ``--set prior.foot_weight=0 --set
retarget.discriminate_exported=false --set retarget.w_gp=0.1`` trains the paper's ACE exactly (``w_adv`` is ours:
the paper gives none).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

from morphkit.errors import ConfigError
from morphkit.retarget.training_data import DataConfig

__all__ = [
    "CONTACT_WEIGHT", "PRESETS", "AceConfig", "AceVariant", "DataConfig", "PriorConfig", "RetargetConfig", "preset",
]


@dataclass(frozen=True)
class PriorConfig:
    """The motion prior: encoder c(x_{t-1}, x_t) → z and MANN π(z, x_{t-1}) → x_t (§4, §6.4)."""

    latent: int = 32
    encoder_hidden: tuple[int, ...] = (512, 512, 512, 512)
    prior_hidden: tuple[int, ...] = (512, 512)
    experts: int = 8
    gate_hidden: tuple[int, ...] = (64, 64)
    dropout: float = 0.3
    kl_beta: float = 0.1
    """β of the VAE's KL term (averaged per latent element, as MotionVAE). MotionVAE's 1.0 collapses the
    posterior on these states (measured on a synthesised quadruped: π's reconstruction is the same for
    any z, KL 0.002 per element), and G can only steer the character through z; 0.1 keeps z
    informative (KL 0.5 per element)."""
    residual: bool = False
    """π predicts x_t − x_{t-1} (ours; the paper and MotionVAE predict x_t). Off by default: measured on
    a quadruped (``default`` preset, CMU), a residual π halves the one-step error but its retargeting rollouts
    diverge beyond the 32-frame training windows (18 of 23 held-out clips left the data's range)."""
    foot_weight: float = 30.0
    """Beyond the paper (0 gives the paper's prior): weight of the prior's foot term — the feet's
    ground-frame step between x_{t-1} and π's x_t, through morphkit's FK of the predicted joints and
    the integrated root path, against the data's step, and their height, in body lengths. It is what makes π's
    outputs keep a planted foot planted once decoded and exported. Measured on a quadruped (``default``
    preset, CMU held-out clips, with ``discriminate_exported``): replaying real transitions through π
    slides in 4.6 % and penetrates in 7.2 % of frames (without it: 53 % and 35 %), and ACE's UFR falls
    from 97 % to 78 %."""
    foot_planted_boost: float = 10.0
    """Extra weight of the foot term's step error on feet the data has planted (ours, as the contact
    losses of motion-diffusion models: a planted foot's step must be 0, a swing foot's only close)."""
    planted_step: float = 0.002
    """A data foot is planted over a transition when its ground step is below this [m] and it is below
    the contact height (2 cm, the contact kernels' default)."""
    contact_flags: bool = False
    """Beyond the paper, off (False: its states): both states end with per-foot stance flags
    (``foot_contacts``, :mod:`morphkit.motion.states`) — the synthesis' plan on the character's data, height
    and speed (:func:`~morphkit.motion.foot_contact_flags`) on the human's. π predicts them (its output in
    those slots is a logit, trained by ``contact_weight`` × a logistic loss; the state carries the 0/1 flag,
    with a straight-through gradient), G reads the human's, D sees the character's, and the ``lock`` export
    holds π's flags. Measured with the main job (``quick``, the shipped quadruped with an arm, the embedded
    human), off / on, seeds 0 and 1: hand-height follow 0.35 / 0.05 and 0.00 / −0.03; raw UFR 27.9 / 45.9 %
    and 58.3 / 0.5 % (but 99 % of its frames floating); ACE+lock UFR 2.4 / 2.1 % and 3.9 / 6.1 %; matched FID
    1.90 / 1.84 and 2.55 / 3.08. π learns the flags (logistic loss 0.02 per foot); D then tells G's
    transitions apart on 97–100 % of them and the arm follows less, so it stays off."""
    contact_weight: float = 1.0
    """Weight of the logistic loss on π's stance flags (ours)."""
    derive_slots: bool = False
    """Beyond the paper, off (False: π predicts every slot): π's output is completed inside the forward pass —
    end-effector positions by morphkit's FK of its tilt and joints, the previous orientation's tilt from the
    previous state, end-effector and root velocities from its root step, height and orientations and the
    previous state (:func:`~morphkit.motion.derive_character_state`) — so π's loss, the feature loss, D and
    the export read the numbers the exported motion has; π's reconstruction loss then weighs FK's
    end-effector positions and not the velocities (a derived velocity's error is 30× its positions'; weighed,
    it kept π from learning: reconstruction 1.35 against 0.37). Measured as ``contact_flags``, off / on,
    seeds 0 and 1: matched FID 1.90 / 1.59 and 2.55 / 2.52, L_fea 1.01 / 0.88 and 1.27 / 1.47, ACE+lock UFR
    2.4 / 1.9 % and 3.9 / 1.7 %, raw UFR 27.9 / 80.8 % and 58.3 / 14.9 %, hand-height follow 0.35 / −0.18 and
    0.00 / −0.23; both options together: hand 0.35 / −0.04 and 0.00 / −0.24, ACE+replan UFR 0 / 19.6 % and
    0 / 0. The main job takes 1.5× as long (FK at every rollout step). Off until the arm follows."""
    root_height_from_feet: bool = False
    """Beyond the paper (False: π predicts the root height): π's root height is derived inside the forward pass
    so that its lowest foot stands on the ground (z = 0) — the height is minus the lowest heading-frame foot
    height of FK of π's tilt and joints. The synthesised data hold it exactly wherever a foot is in stance
    (99.2 % of a quadruped's frames, every frame of a six-legged one's; the rest are a gallop's flight), so π
    loses nothing it was taught, and no exported foot can go into the ground or hover above it. A no-op on a
    creature without feet. Measured (``default``, seeds 0 / 1 / 2, 23 held-out CMU clips, priors and G trained
    with it, against without): a quadruped with an arm — raw UFR 71.1 / 41.4 / 80.3 → 42.7 / 49.3 / 43.6 %
    (penetration → 0, sliding 38 / 31 / 41 → 43 / 49 / 43 %), forward follow 0.73 / 0.55 / 0.65 → 0.63 / 0.66 /
    0.74, shipped FID 0.688 / 1.004 / 0.639 → 0.921 / 1.715 / 0.665; six legs and two claws — raw UFR 76.3 / 37.3 /
    32.5 → 41.2 / 34.8 / 38.6 %, forward 0.66 / 0.44 / 0.62 → 0.60 / 0.61 / 0.70, shipped FID 1.137 / 1.240 /
    1.107 → 1.133 / 1.215 / 0.914, hand follow within ±0.08. Sliding is then all of raw UFR, and the
    quadruped's FID rises on two seeds, so it stays off. With G's contact term too (``--contact-weight 2``, the
    ACE+contact row, same priors): raw UFR 35.8 / 43.1 / 31.9 % (quadruped; seed 1 self-collision 11.6 %) and
    22.7 / 25.0 / 24.3 % (six legs), forward follow 0.66 / 0.66 / 0.68 and 0.51 / 0.54 / 0.51, the six-legged
    one's turn gain 0.50 → 0.30–0.36. With ``retarget.ground_drift_weight = 1`` instead (seed 0): raw UFR 43.7 % and
    44.9 %, shipped FID 0.921 → 1.396 and 1.133 → 1.340, forward 0.61 and 0.45 — worse on every figure."""
    root_step_from_feet: bool = False
    """Beyond the paper (False: π predicts the root step): π's root step over the ground is derived inside the
    forward pass so that the feet on the ground stay where they are — the mean over feet of the step that holds
    each where it was at t − 1, weighed by how surely it is within 1 cm of the ground at both frames
    (:class:`~morphkit.retarget.ace.model.StateCompletion`); π's own step only where no foot is down. The root's
    linear velocity (which Ψ reads) is then that step times the frame rate. The synthesised data hold it: feet
    within 2 cm of the ground at both frames of a transition moved more than 2 mm in 0.2 % of them. Measured
    with ``root_height_from_feet`` (``default``, seeds 0 / 1 / 2, 23 held-out CMU clips): raw UFR 14.3 / 14.7 /
    13.6 % on a quadruped with an arm and 16.7 / 22.5 / 9.5 % on six legs and two claws (sliding is nearly
    all of it), but forward follow falls to 0.00 / 0.00 / 0.04 and 0.19 / 0.03 / 0.24 and yaw follow by
    0.04–0.35: the root goes only where the legs push it, and G does not learn to make π's legs walk with the
    human. It is D that holds them (seed 0, same priors): without D (ACEwoAdv) forward follow is 0.59 and 0.40
    (raw UFR 37.6 % with 17.7 % self-collision, 35.5 %); ``retarget.w_adv = 0.1``: 0.25 and 0.08 (raw UFR 22.1 /
    22.6 %); backpropagating through the whole 32-frame window (``retarget.tbptt = 32``): 0.12 and 0.07. Even
    without D it follows less than today's 0.64 and 0.57. Off."""
    rollout: int = 8
    """Steps of a scheduled-sampling rollout (MotionVAE: 8)."""
    teacher_fraction: float = 0.15
    """Fraction of the epochs with teacher forcing only (MotionVAE: 20 of 140)."""
    ramp_fraction: float = 0.15
    """Fraction of the epochs over which the own-prediction probability ramps 0 → 1."""
    epochs: int = 140
    steps_per_epoch: int = 400
    batch_size: int = 64
    lr: float = 1e-3
    lr_final: float = 1e-5
    """Learning rate at the last epoch (linear decay, as MotionVAE's 1e-4 → 1e-7; ten times higher here
    because our presets train for far fewer steps)."""


@dataclass(frozen=True)
class RetargetConfig:
    """The adversarial correspondence embedding: G(x^h_t, x^r_{t-1}) → ẑ, D(x^r_{t-1}, x^r_t) (§5, §6.4)."""

    generator_hidden: tuple[int, ...] = (512, 512, 512)
    discriminator_hidden: tuple[int, ...] = (512, 512, 512)
    w_adv: float = 0.3
    """Weight of G's adversarial term (the paper gives none; ours, with ``w_gp`` below: see there)."""
    w_fea: float = 1.0
    ground_motion_weight: float = 1.0
    """Factor on Ψ's root motion over the ground — heading-frame forward and sideways velocity and yaw rate,
    ``morphkit.motion.GROUND_MOTION_FEATURES`` — in G's feature term, ‖w ⊙ (Ψ^h − Ψ^r)‖ (ours; 1: Eq. 9 as written;
    the logged and evaluated L_fea stay Eq. 9). Why: a one-armed creature's tool dominates Eq. 9 (the gripper was
    83 % of the squared Ψ error of the main job's G, the yaw rate 8 %), and G learnt to follow the hand and to walk
    but hardly to turn. Measured with 3 on the main job (``quick``, seeds 0–3, shipped rows, against 1): yaw follow
    0.53 / 0.26 / 0.47 / 0.35 → 0.91 / 0.72 / 0.78 / 0.89, turn gain 0.18 / 0.10 / 0.09 / 0.28 →
    0.72 / 0.75 / 0.72 / 0.71, FID 0.73 / 0.93 / 0.95 / 1.20 → 0.96 / 1.04 / 0.90 / 0.73, hand follow within ±0.04,
    forward −0.06 to +0.11, UFR ≤ 2.5 % (11 % on seed 2 before). All six root-velocity rows weighed 3 (vertical
    speed and roll and pitch rates too, a biped's gait bob) turned seeds 0 and 1 as much but not seeds 2 and 3 (yaw
    0.42, 0.33), and on a quadruped with an arm at ``default`` drove the arm into the body (14.7 % of frames
    self-colliding); 10 on the six rows lost the hand (follow 0.55 / 0.06). At ``default``, seed 0, the same priors
    (CMU, 23 held-out clips), forward / yaw follow and shipped FID against 1: a quadruped with an arm 0.57 / 0.93 →
    0.71 / 0.97, 0.826 → 0.948; six legs and two claws 0.62 / 0.87 → 0.69 / 0.93, 1.138 → 0.883; a wheeled robot
    with a lift 0.54 / 0.76 → 0.62 / 0.86, 0.174 → 0.119; but the hand or tool follows less (0.86 → 0.78, 0.76 →
    0.58, 0.88 → 0.66), and over three seeds on the quadruped the shipped FID rises 0.776 → 0.901, above
    ACE+contact's 0.883. With 2 (three seeds on the quadruped, one on the others): shipped FID 0.776 → 0.840 (still
    the lowest row), 1.138 → 1.084, 0.174 → 0.163; hand or tool 0.86 → 0.83, 0.76 → 0.70, 0.88 → 0.85; forward
    0.57 → 0.66, 0.62 → 0.69, 0.54 → 0.60; drift (where the creature goes that the human does not) 0.159 → 0.061,
    0.409 → 0.139, 0.075 → 0.051 body lengths/s; six floating frames on the quadruped (seed 0, of 29,046;
    none since the re-planned legs keep a foot on the ground).
    ``quick`` uses 4 (with ``hand_weight`` 2; 3 before), ``default`` 2 (docs/guides/train-ace.md, evaluate.md)."""
    hand_weight: float = 1.0
    """Factor on Ψ's hand and tool end-effector blocks in G's feature term, as ``ground_motion_weight`` on the root's
    motion (ours; 1: Eq. 9 as written). Why: D pulls a creature's arm towards its data's arm motion, whose tool rises
    as it goes back (a quadruped's arm: x–z correlation −0.36 over its data) where a person's hand rises as it goes
    forward. On the main job (``quick``, seeds 0–2) with 1 the gripper rose where the human reached forward (reach
    follow −0.38 / −0.46 / 0.04; ACEwoAdv on the same prior, seed 0: 0.57) and rose twice as far as the hand. With 2
    and ``ground_motion_weight`` 4 (against 3): reach 0.55 / 0.62 / 0.43, hand 0.93 / 0.88 / 0.94 → 0.97 / 0.94 /
    0.94, shipped FID 0.96 / 1.04 / 0.90 → 0.87 / 0.83 / 0.91, but yaw follow 0.91 / 0.72 / 0.78 → 0.73 / 0.66 /
    0.66 and turn gain 0.72 / 0.75 / 0.72 → 0.70 / 0.58 / 0.61. 3 (with 3 or 5 on the ground motion) turned less
    still (turn gain down to 0.13). ``quick`` uses 2; ``default`` 1: there the reach is 0.54 / 0.57 / 0.43 on the
    quadruped's three seeds already, and 2 (seed 0) gave 0.61 at a higher FID (0.786 → 0.803, with ground motion 3
    0.856) and, with 2 on the ground motion, 5.3 % of frames self-colliding. docs/guides/train-ace.md has the tables."""
    ground_drift_weight: float = 0.0
    """Weight (times ``w_fea``) of a term on the root's motion over the ground averaged over each training window,
    ‖mean_t Ψ^h_g − mean_t Ψ^r_g‖ over ``morphkit.motion.GROUND_MOTION_FEATURES`` (ours; 0: off): where the
    character goes over the window, not the human gait's sway frame by frame. Measured on a quadruped with an arm
    (``default``, seed 0, the same prior, CMU, 23 held-out clips), 1 against 0: drift 0.131 → 0.052 body
    lengths/s (it no longer walks backwards where the human stands), raw UFR 67.5 → 45.4 %, but shipped FID
    0.826 → 0.904, hand / forward / yaw follow 0.83 / 0.57 / 0.94 → 0.80 / 0.56 / 0.87 and 2.9 % of frames
    self-colliding; ``ground_motion_weight`` 2 alone drifts 0.061 on three seeds at FID 0.840. On the main job
    (``quick``, seeds 0–3) raw UFR 70 / 41 / 33 / 52 → 39 / 37 / 37 / 34 % and FID lower on three seeds, but
    seed 2's shipped UFR 2.5 → 6.0 % (self-collision). Off (docs/guides/evaluate.md)."""
    w_gp: float = 1.0
    """Gradient-penalty weight on real transitions (Eq. 5 gives 0.1; ``paper`` keeps it). Ours with ``w_adv`` = 0.3:
    with the paper's 0.1 and ``w_adv`` = 1, G's two gradients (adversarial, feature) on its parameters pointed
    against each other (cosine −0.75, the adversarial 1.4× the longer; a quadruped, ``default``, seed 0) and the
    arm did not follow the hand. Measured on a quadruped with an arm (``default``, CMU, 23 held-out clips, one
    prior; raw output): 1 / 0.1 → hand-height follow 0.45, forward 0.45, yaw 0.76, FID 1.13, L_fea 1.10, UFR 68 %;
    0.3 / 0.1 → 0.71, 0.48, 0.89, 1.09, 0.98, 76 %; 1 / 1 → 0.78, 0.49, 0.79, 1.08, 1.15, 82 %; 0.3 / 1 → 0.86,
    0.59, 0.92, 1.01, 0.82, 54 % (ACEwoAdv: 0.89, 0.76, 0.97, 1.01, 0.49, 21 %). Seeds in train-ace.md."""
    discriminate_exported: bool = True
    """D judges the exported motion (ours; False gives the paper's D): the generated transitions it
    sees carry the end-effectors of morphkit's FK of their joints instead of π's own ee slots, and G's
    adversarial gradient flows through that FK."""
    discriminator_feet: bool = False
    """Beyond the paper, off: D also sees each foot's ground step and height over the transition, ``tanh(step / 1 cm)``
    (x, y) and ``tanh(height / 5 cm)`` per foot, in the transition's ground frame, from the states' end-effectors
    placed on their root path (False: the paper's D input). Measured with the main job (``quick``, the shipped
    quadruped with an arm, seeds 0 and 1): D's logit moves 0.022 for a planted foot's 7 mm slide against 0.010
    without it (``benchmarks/ace_discriminator_feet.py``), FID 4.61 → 4.25 and 1.75 → 1.43, but G answers by lifting
    the feet off the ground: Float 0.01 → 14.3 mm and 1.5 → 8.4 mm, skating ratio 4.4 → 90.9 % and 4.2 → 33.9 %,
    hand-height follow 0.35 → 0.28 and 0.32 → 0.22. So it stays off."""
    w_contact: float = 0.0
    """Beyond the paper: foot sliding + ground penetration of the FK'd motion (0: off, as ACE)."""
    latent_bound: float = 3.0
    """Beyond the paper (0 gives the paper's unbounded G): G's output is squashed into the encoder's
    latent range, ẑ = μ + b·σ·tanh(G/b) with b this bound and μ, σ the mean and standard deviation of
    the encoder's posterior means on the character's data. Unbounded, G drives the frozen prior off its
    manifold: measured on a quadruped (``default``, CMU held-out), 27 % of ẑ's dimensions lay beyond 4σ
    (p99 |z-score| 20, data 2.7), one front foot stood 15 mm below the ground and the other 57 mm above,
    and 94 % of frames penetrated; b = 3 alone gave UFR 97.3 → 32.8 % at the same L_fea."""
    feature_loss: bool = True
    """Train with w_fea·L_fea (False: the paper's ACEwoFea ablation)."""
    adversarial: bool = True
    """Train with w_adv·L_adv and the discriminator (False: the paper's ACEwoAdv ablation)."""
    validation_share: float = 0.0
    """Share of the human training clips held out to choose G by (ours; 0: off, the last step's G, as the paper):
    after every epoch G (its weight average, where kept) retargets 256 fixed windows of those clips and the G of the
    epoch with the lowest feature loss L_fea (Eq. 9) on them is the one that retargets. A clip's mirror image is held
    out with it. Why: how many steps G needs differs by creature and seed. Trained 40 epochs instead of 20
    (``default``, CMU, 23 held-out clips, shipped rows), a wheeled robot with a lift learnt to turn (yaw follow
    0.13 / 0.11 → 0.65 / 0.72 on seeds 1 / 2) while a quadruped with an arm lost the hand on seed 0 (follow 0.84 →
    0.41) and its FID on seed 2 (0.684 → 1.801). Chosen on 5 % of the clips from 40 epochs, the robot's G came from
    epoch 39 on seeds 1 and 2 (yaw 0.70 / 0.70, FID 0.414 / 0.225 → 0.168 / 0.165) and the quadruped's from epochs
    31 / 20 / 15 (FID 0.792 / 0.956 / 0.684 → 0.688 / 1.004 / 0.639, hand 0.84 / 0.86 / 0.80 → 0.83 / 0.82 / 0.82).
    ``default`` uses 0.05 with 40 epochs (docs/guides/evaluate.md). ACEwoFea keeps its last epoch (not chosen by the
    loss it ablates)."""
    window: int = 32
    """Human frames per training rollout."""
    tbptt: int = 8
    """Truncated backpropagation: the carried character state is detached every this many frames."""
    epochs: int = 60
    steps_per_epoch: int = 200
    batch_size: int = 64
    lr_generator: float = 1e-4
    lr_discriminator: float = 1e-4
    lr_final_fraction: float = 1.0
    """G's and D's learning rates at the last step, as a fraction of the first: linear decay over the
    stage (ours; 1: constant, as the paper's Adam at 1e-4 and AMP's). Measured with the main job (``quick``),
    seeds 0 / 1, 0.1 against 1: L_fea 0.78 / 0.80 against 0.70 / 0.98, but the motion collapses towards the mean
    (raw DIV 0.31 / 0.33 against 0.61 / 0.63, matched data 1.53) and matched FID 1.67 / 1.56 against 1.13 / 1.70;
    with twice the G steps, DIV 0.67 / 0.48 and hand follow 0.43 / 0.27 against 0.66 / 0.55 and 0.44 / 0.28 without:
    no gain. So it stays 1."""
    generator_average: float = 0.0
    """Decay of an exponential moving average of G's weights, the G that retargets (ours; 0: off, the last
    step's G as the paper). A GAN's G wanders about its best point while D keeps up (StyleGAN's and BigGAN's
    generator averages); the average is G's mean over the last ~1/(1 − decay) steps. Measured with 0.95 and 0.98 on
    the main job (``quick``, seeds 0 / 1) and 0.98 at ``default`` (a quadruped with an arm, seeds 0–2): at ``quick``
    raw UFR 68 / 49 % → 27 / 20 % and forward follow up, but DIV 0.69 / 0.88 → 0.64 / 0.54; at ``default`` the same
    follow, DIV 1.20 → 1.42 (data 1.85), shipped FID 1.016 → 1.111 and 7.8 % self-collision on one seed
    (docs/guides/train-ace.md). So off in the dataclass; ``quick`` and ``default`` use 0.95 with arms that mostly
    hang (``data.arm_hang_share``) and mirrored human clips, measured together: at ``quick`` the last-step G fell off
    its best point on one of two seeds, at ``default`` (three seeds) shipped FID 1.016 → 0.776 and DIV 1.197 → 1.509
    (data 1.854 → 1.936)."""
    betas: tuple[float, float] = (0.5, 0.999)
    discriminator_steps: int = 1
    """Discriminator updates per generator update."""


@dataclass(frozen=True)
class AceConfig:
    """Everything one ACE run needs; saved as ``config.yaml`` in its run folders."""

    seed: int = 0
    kl_only_mapping: bool = False
    """Map end-effectors by KL alone (the paper's Eq. 11). Default: KL chooses among human end-effectors
    of a compatible role (foot → foot, head → head, hand/tool → hand), ours: KL alone maps a quadruped's
    feet to the synthesised human's hands, whose positions are more spread than its feet's."""
    active_hand: bool = True
    """A creature's lone hand or tool follows whichever of the human's hands moves (ours; the mapping's
    :data:`~morphkit.motion.ACTIVE_HAND`); False: the one hand KL prefers. With one hand fixed, a human who waves
    with the other is not followed at all (the main job's clips: the left hand waves to 1.85 m, the right one,
    KL's choice, stays within 2 cm)."""
    centre_features: bool = True
    """Centre each side's Ψ end-effector block on its own data set's mean (ours; False gives the paper's
    Ψ). Uncentred, Ψ compares end-effectors measured from the root: a quadruped's feet stand 0.8 body
    lengths ahead of and 0.35 behind its root where a human's toes stand under it, so L_fea has a
    floor no motion goes under (1.86 on a quadruped for the nearest data frame of every human frame)
    and its gradient pulls the creature's feet towards where a human's would be. The root height is centred
    the same way: Ψ divides lengths by the standing root height, so a legged creature's root stands near 1 as a
    human's does (0.94 for the quadruped with an arm and the six-legged creature, 0.99 for the CMU humans), but a
    wheeled robot's root rides on the ground at 0. Uncentred, that constant was 62 % of the wheeled robot's squared
    Ψ distance, and in L_fea's unsquared norm it shrank G's gradient on every other feature: its gripper's rare
    overhead frames were regressed to the mean (12 / 14 / 13 of 14 overhead clips above 0.8 m on seeds 0 / 1 / 2,
    against 14 / 14 / 14 centred; docs/guides/evaluate.md)."""
    data: DataConfig = field(default_factory=DataConfig)
    prior: PriorConfig = field(default_factory=PriorConfig)
    retarget: RetargetConfig = field(default_factory=RetargetConfig)


def _small(width: int, experts: int) -> tuple[PriorConfig, RetargetConfig]:
    return (
        PriorConfig(encoder_hidden=(width,) * 3, prior_hidden=(width, width), experts=experts,
                    gate_hidden=(32, 32)),
        RetargetConfig(generator_hidden=(width,) * 3, discriminator_hidden=(width,) * 3),
    )


_SMOKE_PRIOR, _SMOKE_RET = _small(64, 2)
_QUICK_PRIOR, _QUICK_RET = _small(128, 4)
_DEFAULT_PRIOR, _DEFAULT_RET = _small(256, 4)

PRESETS: dict[str, AceConfig] = {
    # ≤ 60 s on 2 cores: for tests.
    "smoke": AceConfig(
        data=DataConfig(character_frames=1_200, human_frames=600),
        prior=replace(_SMOKE_PRIOR, epochs=3, steps_per_epoch=10, batch_size=32, rollout=4),
        retarget=replace(_SMOKE_RET, epochs=3, steps_per_epoch=6, batch_size=8, window=8, tbptt=4),
    ),
    # The whole main job ≤ 5 min on 2 cores, from a cold cache. Arms that mostly hang, G's weight average and the
    # human clips mirrored (docs/guides/train-ace.md), as `default`; G's learning rate doubled for its 240 steps
    # (default's takes up to 1,600): its feature loss was still falling when D took over; G's feature term weighs the
    # root's motion over the ground four times, so the creature turns with the human, and the hand or tool twice, so
    # the arm reaches forward where the hand does (with the hand at 1 it rose instead: docs/guides/train-ace.md).
    "quick": AceConfig(
        data=DataConfig(character_frames=12_000, human_frames=3_000, arm_hang_share=0.3, human_mirror=True),
        prior=replace(_QUICK_PRIOR, epochs=8, steps_per_epoch=60, batch_size=64),
        retarget=replace(_QUICK_RET, epochs=8, steps_per_epoch=30, batch_size=32, window=24, generator_average=0.95,
                         lr_generator=2e-4, ground_motion_weight=4.0, hand_weight=2.0),
    ),
    # Quality runs: prior + one retargeter ≤ 20 min on 2 cores. Arms that mostly hang, G's weight average and the
    # human clips mirrored: Table 1 on the quadruped with an arm over three seeds (docs/guides/evaluate.md). The
    # ground motion weighed twice: three times (as `quick`) followed the hand less on all three shipped creatures;
    # twice keeps most of the hand and stops the creature walking off where the human stands (drift 0.159 → 0.061
    # body lengths/s on three seeds; ground_motion_weight's docstring). G trains up to 40 epochs and the epoch that
    # retargets is chosen on 5 % of the human clips held out (validation_share's docstring).
    "default": AceConfig(
        data=DataConfig(character_frames=60_000, arm_hang_share=0.3, human_mirror=True),
        prior=replace(_DEFAULT_PRIOR, epochs=16, steps_per_epoch=100, batch_size=128),
        retarget=replace(_DEFAULT_RET, epochs=40, steps_per_epoch=40, batch_size=64, generator_average=0.95,
                         ground_motion_weight=2.0, validation_share=0.05),
    ),
    # The paper's sizes (§6.4, §7.1).
    "paper": AceConfig(prior=PriorConfig(lr=1e-4, lr_final=1e-7), retarget=RetargetConfig(w_gp=0.1)),
}


def preset(name: str) -> AceConfig:
    """The preset ``name`` (one of :data:`PRESETS`).

    Raises:
        ConfigError: an unknown name, listing the known ones.
    """
    from morphkit.retarget.config import preset_config

    return preset_config(PRESETS, name)


CONTACT_WEIGHT = 2.0
"""``retarget.w_contact`` of ACE+contact where the config leaves it 0 (Table 1's ``--contact-weight``: on Spot 1 gave
UFR 12.1 %, 2 gave 4.4 %; docs/guides/evaluate.md)."""


class AceVariant(str, Enum):
    """A retargeter of Table 1: its trainer name (the value), stage folder, label and ablation flags.

    ``ACE_CONTACT`` is ACE with ``retarget.w_contact > 0`` (beyond the paper); every other variant trains with 0.
    """

    ACE = "ace"
    WO_FEA = "ace-wofea"
    WO_ADV = "ace-woadv"
    ACE_CONTACT = "ace-contact"

    @property
    def folder(self) -> str:
        """Its stage folder inside an ACE run."""
        return {"ace": "retarget", "ace-wofea": "retarget_wofea", "ace-woadv": "retarget_woadv",
                "ace-contact": "retarget_contact"}[self.value]

    @property
    def label(self) -> str:
        """Its name in Table 1."""
        labels = {"ace": "ACE", "ace-wofea": "ACEwoFea", "ace-woadv": "ACEwoAdv", "ace-contact": "ACE+contact"}
        return labels[self.value]

    @property
    def feature_loss(self) -> bool:
        """Whether it trains with the feature loss."""
        return self is not AceVariant.WO_FEA

    @property
    def adversarial(self) -> bool:
        """Whether it trains with the adversarial loss."""
        return self is not AceVariant.WO_ADV

    @property
    def contact(self) -> bool:
        """Whether it trains with G's contact term (``retarget.w_contact``)."""
        return self is AceVariant.ACE_CONTACT

    def configure(self, cfg: RetargetConfig) -> RetargetConfig:
        """``cfg`` with every flag of this variant, so its ``config.yaml`` records what was trained.

        ACE+contact keeps ``cfg.w_contact`` where it is > 0, else takes :data:`CONTACT_WEIGHT`.

        Raises:
            ConfigError: ``cfg`` turns off a loss this variant trains with (``--set retarget.adversarial=false``
                asks for ACEwoAdv, a variant of its own, and was silently trained as ACE), or turns on the
                contact term in a variant without it.
        """
        for flag, option in (("feature_loss", "--no-feature-loss"), ("adversarial", "--no-adversarial")):
            if getattr(self, flag) and not getattr(cfg, flag):
                other = AceVariant.of_flags(**{flag: False})
                raise ConfigError(f"retarget.{flag}=false is the {other.label} ablation, not {self.label}: train it "
                                  f"as its own variant ({option} in morphkit train ace, variant={other.value!r})")
        if cfg.w_contact < 0:
            raise ConfigError(f"retarget.w_contact must be >= 0, got {cfg.w_contact}")
        if cfg.w_contact > 0 and not self.contact:
            raise ConfigError(f"retarget.w_contact={cfg.w_contact} is {AceVariant.ACE_CONTACT.label}, not "
                              f"{self.label}: train it as its own variant (--contact-weight in morphkit train ace, "
                              f"variant={AceVariant.ACE_CONTACT.value!r})")
        w_contact = (cfg.w_contact or CONTACT_WEIGHT) if self.contact else 0.0
        # ACEwoFea's G is not chosen by the feature loss it ablates (it would borrow what it leaves out): its last epoch
        share = cfg.validation_share if self.feature_loss else 0.0
        return replace(cfg, feature_loss=self.feature_loss, adversarial=self.adversarial, w_contact=w_contact,
                       validation_share=share)

    @staticmethod
    def parse(name: str | AceVariant) -> AceVariant:
        """The variant of a trainer name, stage folder or Table-1 label.

        Raises:
            ConfigError: none of them.
        """
        if isinstance(name, AceVariant):
            return name
        for v in AceVariant:
            if name in (v.value, v.folder, v.label):
                return v
        raise ConfigError(f"unknown ACE variant {name!r}; expected one of: {', '.join(v.value for v in AceVariant)}")

    @staticmethod
    def of_flags(*, feature_loss: bool = True, adversarial: bool = True, contact_weight: float = 0.0) -> AceVariant:
        """The variant of a set of ablation flags (one ablation at a time).

        Raises:
            ConfigError: both losses off, or the contact term combined with an ablation.
        """
        if not feature_loss and not adversarial:
            raise ConfigError("--no-feature-loss and --no-adversarial together leave nothing to train")
        if contact_weight > 0 and not (feature_loss and adversarial):
            raise ConfigError("--contact-weight combines with full ACE only")
        if not feature_loss:
            return AceVariant.WO_FEA
        if not adversarial:
            return AceVariant.WO_ADV
        return AceVariant.ACE_CONTACT if contact_weight > 0 else AceVariant.ACE
