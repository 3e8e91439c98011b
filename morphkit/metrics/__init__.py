"""Evaluation metrics of ACE (Li et al. 2023, §7): DIV, FID, the feature loss and the unrealistic
frame ratio; pure functions.

=================================  ==================================================================
metric                             what it measures
=================================  ==================================================================
:func:`diversity` (DIV)            mean Ψ distance between two random subsets of S_d = 300 frames;
                                   best when closest to the creature dataset's own DIV
:func:`fid` (FID)                  Fréchet distance between Gaussians fitted to the Ψ of the creature
                                   dataset and of the retargeted motion; lower is better
:func:`feature_loss` (L_fea)       Eq. 9, ‖Ψ(x^h) − Ψ(x̂^r)‖ per frame, averaged; lower is better
:func:`unrealistic_frame_ratio`    fraction of frames with self-collision, foot penetration or foot
(UFR)                              sliding, from the contact kernels; lower is better
=================================  ==================================================================

Ψ is :func:`morphkit.motion.features` / :func:`morphkit.motion.motion_features` (§6.3). DIV, FID
and L_fea take Ψ arrays (NumPy; torch accepted, and L_fea stays differentiable on torch); UFR
takes a :class:`~morphkit.motion.Motion`.
"""

from morphkit.metrics._distribution import DEFAULT_SUBSET_SIZE as DEFAULT_SUBSET_SIZE
from morphkit.metrics._distribution import diversity as diversity
from morphkit.metrics._distribution import fid as fid
from morphkit.metrics._distribution import frechet_distance as frechet_distance
from morphkit.metrics._distribution import gaussian_statistics as gaussian_statistics
from morphkit.metrics._feature_loss import feature_loss as feature_loss
from morphkit.metrics._unrealistic import UnrealisticFrames as UnrealisticFrames
from morphkit.metrics._unrealistic import UnrealisticFrameThresholds as UnrealisticFrameThresholds
from morphkit.metrics._unrealistic import unrealistic_frame_ratio as unrealistic_frame_ratio

__all__ = [
    "DEFAULT_SUBSET_SIZE",
    "UnrealisticFrameThresholds",
    "UnrealisticFrames",
    "diversity",
    "feature_loss",
    "fid",
    "frechet_distance",
    "gaussian_statistics",
    "unrealistic_frame_ratio",
]
