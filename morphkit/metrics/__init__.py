"""Evaluation metrics: those of ACE (Li et al. 2023, §7) — DIV, FID, the feature loss and the unrealistic
frame ratio — and foot-contact and follow figures from other papers; pure functions.

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
:data:`UFR_SETTINGS`               UFR thresholds ``strict`` (the default), ``medium`` and ``loose``
:func:`foot_contact_figures`       UFR's sliding and penetration per foot-frame (rates overall and
                                   per foot); lower is better
:func:`skating_ratio`              GMD's (Karunratanakul et al. 2023) fraction of frame transitions
                                   with a foot skating in contact; lower is better
:func:`physdiff_figures`           PhysDiff's (Yuan et al. 2023) Penetrate, Float, Skate of the feet
                                   [mm]; lower is better
:func:`floating_frames`            frames of flights (no foot in contact) longer than the creature's
                                   own :func:`longest_flight`; lower is better
:func:`follow_score`               Pearson correlation of paired human and creature 1-D series
                                   (:func:`pearson_follow`), per pair and mean; higher is better
:func:`follow_gain`                how much of a human series the creature's does (least-squares
                                   slope through the origin); 1 is best
:func:`reachable_gain`             the follow gain of a copy bounded at a rate (the human's yaw
                                   rate against the creature data's fastest turn): its scale
:func:`data_envelope`              a per-clip distance to the creature data's Ψ Gaussian and the data's
                                   own largest (:class:`DataEnvelope`): a clip outside the data, flagged
:func:`matched_reference`          the creature's Ψ rows resampled so that root speed and yaw rate
                                   (:func:`motion_content`) match the evaluated clips'
                                   (:func:`matched_indices`): a content-matched reference for FID, DIV
=================================  ==================================================================

Ψ is :func:`morphkit.motion.features` / :func:`morphkit.motion.motion_features` (§6.3). DIV, FID
and L_fea take Ψ arrays (NumPy; torch accepted, and L_fea stays differentiable on torch); UFR
takes a :class:`~morphkit.motion.Motion`, as do the foot-contact figures (feet: end-effectors whose
role is ``foot``); the follow score takes NumPy series.
"""

from morphkit.metrics._contact import UFR_LOOSE as UFR_LOOSE
from morphkit.metrics._contact import UFR_MEDIUM as UFR_MEDIUM
from morphkit.metrics._contact import UFR_SETTINGS as UFR_SETTINGS
from morphkit.metrics._contact import UFR_STRICT as UFR_STRICT
from morphkit.metrics._contact import FootContactFigures as FootContactFigures
from morphkit.metrics._contact import PhysDiffFigures as PhysDiffFigures
from morphkit.metrics._contact import floating_frames as floating_frames
from morphkit.metrics._contact import foot_contact_figures as foot_contact_figures
from morphkit.metrics._contact import longest_flight as longest_flight
from morphkit.metrics._contact import physdiff_figures as physdiff_figures
from morphkit.metrics._contact import skating_ratio as skating_ratio
from morphkit.metrics._distribution import DEFAULT_SUBSET_SIZE as DEFAULT_SUBSET_SIZE
from morphkit.metrics._distribution import diversity as diversity
from morphkit.metrics._distribution import fid as fid
from morphkit.metrics._distribution import frechet_distance as frechet_distance
from morphkit.metrics._distribution import gaussian_statistics as gaussian_statistics
from morphkit.metrics._envelope import DataEnvelope as DataEnvelope
from morphkit.metrics._envelope import data_envelope as data_envelope
from morphkit.metrics._feature_loss import feature_loss as feature_loss
from morphkit.metrics._follow import CONSTANT_SERIES_RTOL as CONSTANT_SERIES_RTOL
from morphkit.metrics._follow import FollowScore as FollowScore
from morphkit.metrics._follow import follow_gain as follow_gain
from morphkit.metrics._follow import follow_score as follow_score
from morphkit.metrics._follow import pearson_follow as pearson_follow
from morphkit.metrics._follow import reachable_gain as reachable_gain
from morphkit.metrics._matched import MatchedSample as MatchedSample
from morphkit.metrics._matched import matched_indices as matched_indices
from morphkit.metrics._matched import matched_reference as matched_reference
from morphkit.metrics._matched import motion_content as motion_content
from morphkit.metrics._unrealistic import UnrealisticFrames as UnrealisticFrames
from morphkit.metrics._unrealistic import UnrealisticFrameThresholds as UnrealisticFrameThresholds
from morphkit.metrics._unrealistic import unrealistic_frame_ratio as unrealistic_frame_ratio

__all__ = [
    "CONSTANT_SERIES_RTOL",
    "DEFAULT_SUBSET_SIZE",
    "UFR_LOOSE",
    "UFR_MEDIUM",
    "UFR_SETTINGS",
    "UFR_STRICT",
    "DataEnvelope",
    "FollowScore",
    "FootContactFigures",
    "MatchedSample",
    "PhysDiffFigures",
    "UnrealisticFrameThresholds",
    "UnrealisticFrames",
    "data_envelope",
    "diversity",
    "feature_loss",
    "fid",
    "floating_frames",
    "follow_gain",
    "follow_score",
    "foot_contact_figures",
    "frechet_distance",
    "gaussian_statistics",
    "longest_flight",
    "matched_indices",
    "matched_reference",
    "motion_content",
    "pearson_follow",
    "physdiff_figures",
    "reachable_gain",
    "skating_ratio",
    "unrealistic_frame_ratio",
]
