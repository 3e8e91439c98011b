"""Procedural character motion for any creature, from its graph alone (``morphkit synth``).

ACE learns each character's motion prior from ~200k frames of that character's own motion, made
by rolling out a kinematic controller under random commands (ACE paper §7.1). This package does
that for any morphology: it finds legs, arms, head and wheels (:mod:`.analysis`), calibrates a
stance and step region (:mod:`.legged`; upright bipeds stand tall and ride over their legs), draws
random smoothed commands (:mod:`.locomotion_commands`), picks gaits by leg count and speed
(:mod:`.gait`), plans footsteps and swing arcs with stance feet fixed on the ground, moves arms and
other joints (:mod:`.arms`), swings the arms of upright bipeds and mixes in reaching, waving,
pointing and pushing (:mod:`.actions`), or drives wheeled bases (:mod:`.wheeled`), and solves every
limb with the morphkit DLS IK kernel, many rollouts at once (:mod:`.core`), lifting arms, tails and
heads that would go below the ground (:mod:`.ground`). :mod:`.report` measures what came out with the
contact kernels; :mod:`.output` writes it (a folder with a manifest, or one file, batch by batch with
:func:`iter_synthesize`); :mod:`.human` is the embedded default human motion
(:func:`default_human_motion`). The contact-aware export of retargeted motion, which uses this rig, is
the package above it, :mod:`morphkit.contact_export`.

Example::

    from morphkit.io import read_morphology
    from morphkit.synth import synthesize

    result = synthesize(read_morphology("crab.yaml"), frames=20_000, seed=0)
    result.save("crab_motions/")  # one NPZ per rollout, readable by morphkit.motion.read_motion
"""

from morphkit.synth.actions import ACTION_NAMES as ACTION_NAMES
from morphkit.synth.actions import ActionConfig as ActionConfig
from morphkit.synth.actions import ActionSpan as ActionSpan
from morphkit.synth.analysis import BodyPlan as BodyPlan
from morphkit.synth.analysis import Limb as Limb
from morphkit.synth.analysis import analyse as analyse
from morphkit.synth.arms import ArmConfig as ArmConfig
from morphkit.synth.core import SynthConfig as SynthConfig
from morphkit.synth.core import SynthResult as SynthResult
from morphkit.synth.core import SynthRig as SynthRig
from morphkit.synth.core import iter_synthesize as iter_synthesize
from morphkit.synth.core import prepare as prepare
from morphkit.synth.core import source_digest as source_digest
from morphkit.synth.core import synthesize as synthesize
from morphkit.synth.human import HumanClip as HumanClip
from morphkit.synth.human import default_human_clips as default_human_clips
from morphkit.synth.human import default_human_config as default_human_config
from morphkit.synth.human import default_human_motion as default_human_motion
from morphkit.synth.legged import LegConfig as LegConfig
from morphkit.synth.locomotion_commands import COMMAND_NAMES as COMMAND_NAMES
from morphkit.synth.locomotion_commands import CommandConfig as CommandConfig

__all__ = [
    "ACTION_NAMES",
    "COMMAND_NAMES",
    "ActionConfig",
    "ActionSpan",
    "ArmConfig",
    "BodyPlan",
    "CommandConfig",
    "HumanClip",
    "LegConfig",
    "Limb",
    "SynthConfig",
    "SynthResult",
    "SynthRig",
    "analyse",
    "default_human_clips",
    "default_human_config",
    "default_human_motion",
    "iter_synthesize",
    "prepare",
    "source_digest",
    "synthesize",
]
