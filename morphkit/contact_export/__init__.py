"""The contact-aware export of a retargeted motion (``--contacts``, Table 1's ``+replan`` / ``+lock`` rows).

A retargeter decides where the body goes; nothing in it keeps a stance foot still or an arm out of the
torso. This package makes a retargeted motion's contacts right with the synthesis' rig
(:mod:`morphkit.synth`: its footstep planner, its IK, its upper body), one mode by name
(:func:`apply_contacts`, :mod:`.modes`): legs re-stepped by the planner along the motion's root path
(:mod:`.replan`) or stance feet locked at their touchdown points (:mod:`.lock`), then the upper body moved
out of the body and the ground (:mod:`.clearance`).

It sits above the synthesis (which knows nothing of it) and below the retarget layer, the evaluation and the
CLI that call it.

Example::

    from morphkit.contact_export import apply_contacts
    from morphkit.motion import read_motion

    planted = apply_contacts(read_motion("walk_spot.npz"), "replan")
"""

from morphkit.contact_export.clearance import clear_upper_body as clear_upper_body
from morphkit.contact_export.lock import lock_feet as lock_feet
from morphkit.contact_export.lock import stance_flags as stance_flags
from morphkit.contact_export.modes import CONTACT_MODES as CONTACT_MODES
from morphkit.contact_export.modes import apply_contacts as apply_contacts
from morphkit.contact_export.replan import replan_legs as replan_legs

__all__ = [
    "CONTACT_MODES",
    "apply_contacts",
    "clear_upper_body",
    "lock_feet",
    "replan_legs",
    "stance_flags",
]
