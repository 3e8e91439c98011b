"""BVH (Biovision hierarchy) files: a vectorised parser, a writer, and BVH skeleton -> Morphology.

The package's modules, each importable here: :mod:`~morphkit.io.bvh.file` (:class:`BvhFile`, forward kinematics in
file axes, the unit scale, static roots), :mod:`~morphkit.io.bvh.parser` (text in), :mod:`~morphkit.io.bvh.writer`
(text out), :mod:`~morphkit.io.bvh.analysis` (end-effectors and their roles, the up axis and the facing) and
:mod:`~morphkit.io.bvh.skeleton` (the :class:`~morphkit.graph.Morphology`).

Parsing (:func:`parse_bvh`, :func:`read_bvh`) keeps the file's own units, axes and degrees and
returns a frozen :class:`BvhFile`: the joint tree (names, parents, ``OFFSET`` s, channels in
file order), the End Sites, the frame time and the whole ``MOTION`` section as one float64
array of shape [frame_count, channel_count], parsed in one vectorised pass. Every element
records the line it was declared on. Malformed hierarchies raise
:class:`~morphkit.errors.DescriptionError`, malformed motion
:class:`~morphkit.errors.MotionFormatError`, both with file and line.

BVH semantics assumed throughout (and by :func:`bvh_joint_positions`):

- A joint's rotation in its parent is the product of its rotation channels in file order,
  ``R = R_c1(a1) R_c2(a2) R_c3(a3)`` (intrinsic; angles in degrees), e.g.
  ``Zrotation Xrotation Yrotation`` gives ``R = Rz Rx Ry``.
- Position channels (on any joint) *replace* the joint's ``OFFSET`` as its translation in the
  parent frame; a joint without them sits at its ``OFFSET``. The real files agree: the Bandai
  Namco clips animate every joint and frame 0 repeats the offsets; the dog's and the elephant's
  root positions sit at their root offsets.

Skeletons (:func:`read_bvh_skeleton`, :func:`skeleton_from_bvh`) become a
:class:`~morphkit.graph.Morphology`:

- Axes: BVH files are Y-up; most face +Z (CMU, Daz, Bandai Namco) with the character's left
  at +X. :data:`BVH_TO_MORPHKIT` is the proper rotation ``v_morphkit = BVH_TO_MORPHKIT @ v_bvh``
  that maps BVH +Y (up) to morphkit +Z, BVH +Z (facing) to morphkit +X (forward) and BVH +X
  (left) to morphkit +Y (left). :func:`bvh_frame_rotation` gives the matrix for files that
  face another direction; by default (``facing="auto"``) :func:`detect_bvh_facing` finds it
  from the motion: +Z for every skeleton with hands (the humans), -X for the dog (whose rest
  pose points its head along +X, but whose root frame has the head along -X once it stands),
  +X for the elephants.
- Units: file units times a scale to metres; by default :func:`detect_bvh_scale` (1 when the
  rest skeleton's largest extent is at most 10 file units, else centimetres, 0.01). The real
  files behind this rule (largest rest extent in file units): CMU (AMASS) 1.58 (metres), CMU
  Daz 152.7 and Bandai Namco 184-194 (centimetres), dog 87 (cm), crab 1.1 and elephants 2.84
  (metres). Inches cannot be told from centimetres by size alone: pass ``scale=0.0254``.
- Rest poses: the skeleton's rest pose is the BVH's (all channels zero). CMU and Daz rest in a
  standing T-pose; the Bandai Namco and dog rigs put every bone along its local x, so their
  rest pose is not upright (their motion rotations make it so), and a rest-pose height is
  meaningless for them. Note also that the CMU (AMASS) clips are Z-up in their motion (the root
  rotation stands the Y-up skeleton up along Z), whereas Daz, Bandai Namco and the dog are Y-up.
- Static roots: a root that never rotates over the clip and has a single child with
  translation channels (Bandai Namco's ``joint_Root`` above ``Hips``) is folded away first
  (:func:`fold_static_root`): the child becomes the root. The motion reader folds the same
  root, so :func:`read_bvh_skeleton` and the motion's morphology agree.
- Links and joints: one link per BVH joint (after folding), named after it, in BVH order
  (``links[i]`` is joint ``i`` of the folded file); the root joint is the root link of a
  floating base (its ``OFFSET`` is ignored: the motion places the root). Every other joint
  is a joint of the same name: spherical when it has any rotation channel, fixed otherwise;
  its origin is its ``OFFSET`` (converted, no rotation). Position channels of non-root
  joints have no counterpart in the morphology (their rest value is the ``OFFSET``).
- Shapes: each link gets a capsule from its origin to each child joint and End Site (radius
  8% of the bone length, at least 1 cm); a link with no bone gets a sphere of its incoming
  bone's radius, so renders and self-collision queries work on any BVH skeleton.
- End-effectors, from names (see :func:`skeleton_from_bvh`): hands, feet and head found from
  keywords in joint names, one per limb, at the limb's End Site (named ``<joint>_end``) or,
  where a limb ends in several End Sites (fingers, eyes), at the limb's topmost keyword joint
  (named after that joint, zero offset). Unnamed End Sites become ``tool`` end-effectors.
  Quadrupeds' front paws named hands become feet when they are as long as the legs and move
  at the feet's height; human hands never do (their arms are 67-75% of their legs).
"""

from morphkit.io.bvh.analysis import ROLE_KEYWORDS as ROLE_KEYWORDS
from morphkit.io.bvh.analysis import detect_bvh_facing as detect_bvh_facing
from morphkit.io.bvh.analysis import detect_bvh_up as detect_bvh_up
from morphkit.io.bvh.analysis import keyword_role as keyword_role
from morphkit.io.bvh.file import BVH_CHANNEL_NAMES as BVH_CHANNEL_NAMES
from morphkit.io.bvh.file import BvhEndSite as BvhEndSite
from morphkit.io.bvh.file import BvhFile as BvhFile
from morphkit.io.bvh.file import bvh_joint_positions as bvh_joint_positions
from morphkit.io.bvh.file import detect_bvh_scale as detect_bvh_scale
from morphkit.io.bvh.file import fold_static_root as fold_static_root
from morphkit.io.bvh.parser import parse_bvh as parse_bvh
from morphkit.io.bvh.parser import read_bvh as read_bvh
from morphkit.io.bvh.skeleton import BVH_TO_MORPHKIT as BVH_TO_MORPHKIT
from morphkit.io.bvh.skeleton import bvh_frame_rotation as bvh_frame_rotation
from morphkit.io.bvh.skeleton import read_bvh_skeleton as read_bvh_skeleton
from morphkit.io.bvh.skeleton import skeleton_from_bvh as skeleton_from_bvh
from morphkit.io.bvh.writer import dump_bvh as dump_bvh
from morphkit.io.bvh.writer import write_bvh as write_bvh

__all__ = [
    "BVH_CHANNEL_NAMES",
    "BVH_TO_MORPHKIT",
    "ROLE_KEYWORDS",
    "BvhEndSite",
    "BvhFile",
    "bvh_frame_rotation",
    "bvh_joint_positions",
    "detect_bvh_facing",
    "detect_bvh_scale",
    "detect_bvh_up",
    "dump_bvh",
    "fold_static_root",
    "keyword_role",
    "parse_bvh",
    "read_bvh",
    "read_bvh_skeleton",
    "skeleton_from_bvh",
    "write_bvh",
]
