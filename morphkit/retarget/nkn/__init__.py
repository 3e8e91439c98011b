"""NKN (Villegas et al. 2018): skeleton-conditioned retargeting through an FK layer, trained without
paired data by adversarial cycle consistency; and its cross-morphology mode (human → any creature), the
ACE paper's baseline. Torch only; creature-agnostic.

* :mod:`~.config`: :class:`NknConfig` and the presets (``paper`` = the release's README configuration).
* :mod:`~.skeleton`: topology checks, bone offsets, limb groups and bone-length variants.
* :mod:`~.fk`: :class:`SkeletonFK`, morphkit's Warp FK batched over bone offsets (exact, differentiable).
* :mod:`~.features`, :mod:`~.data`: local pose and global motion; characters and their clip windows.
* :mod:`~.model`, :mod:`~.losses`: the GRU encoder/decoder, the discriminator, Eq. 10–16.
* :mod:`~.train`: :func:`train_nkn`; :mod:`~.retarget`: :class:`NknRetargeter`, :func:`copy_rotations`.
* :mod:`~.evaluate`: cycle error, scaled end-effector error, foot contact metrics, Fig.-5-style plots.
"""

from morphkit.retarget.nkn.config import PRESETS as PRESETS
from morphkit.retarget.nkn.config import NknConfig as NknConfig
from morphkit.retarget.nkn.config import NknDataConfig as NknDataConfig
from morphkit.retarget.nkn.config import preset as preset
from morphkit.retarget.nkn.fk import SkeletonFK as SkeletonFK
from morphkit.retarget.nkn.retarget import NknRetargeter as NknRetargeter
from morphkit.retarget.nkn.retarget import copy_rotations as copy_rotations
from morphkit.retarget.nkn.train import train_nkn as train_nkn

__all__ = ["PRESETS", "NknConfig", "NknDataConfig", "NknRetargeter", "SkeletonFK", "copy_rotations", "preset",
           "train_nkn"]
