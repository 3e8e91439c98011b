"""Offscreen rendering of creatures: turntables, motion videos, side-by-side comparisons, contact sheets.

Headless by default: without a display, EGL is used, else OSMesa (see
:func:`~morphkit.render.select_platform`); a missing library raises
:class:`~morphkit.render.RenderUnavailableError` naming the system package to install.
Importing this package is light: pyrender, PyOpenGL and trimesh load on first render (videos are
encoded by the ffmpeg that ``imageio-ffmpeg`` ships, GIFs by Pillow).

Example:
    >>> from morphkit.io import read_morphology
    >>> from morphkit.render import turntable
    >>> turntable(read_morphology("spot.urdf"), "spot.gif", frames=72)  # doctest: +SKIP
"""

from morphkit.render._gl import RenderUnavailableError as RenderUnavailableError
from morphkit.render._gl import select_platform as select_platform
from morphkit.render.compare import iter_side_by_side_frames as iter_side_by_side_frames
from morphkit.render.compare import render_side_by_side as render_side_by_side
from morphkit.render.compare import side_by_side_frames as side_by_side_frames
from morphkit.render.scene import CreatureScene as CreatureScene
from morphkit.render.scene import RenderStyle as RenderStyle
from morphkit.render.scene import link_colors as link_colors
from morphkit.render.sheet import contact_sheet as contact_sheet
from morphkit.render.sheet import write_image as write_image
from morphkit.render.turntable import iter_turntable_frames as iter_turntable_frames
from morphkit.render.turntable import turntable as turntable
from morphkit.render.turntable import turntable_frames as turntable_frames
from morphkit.render.video import ffmpeg_available as ffmpeg_available
from morphkit.render.video import iter_motion_frames as iter_motion_frames
from morphkit.render.video import motion_frames as motion_frames
from morphkit.render.video import render_motion as render_motion
from morphkit.render.video import write_frames as write_frames

__all__ = [
    "CreatureScene",
    "RenderStyle",
    "RenderUnavailableError",
    "contact_sheet",
    "ffmpeg_available",
    "iter_motion_frames",
    "iter_side_by_side_frames",
    "iter_turntable_frames",
    "link_colors",
    "motion_frames",
    "render_motion",
    "render_side_by_side",
    "select_platform",
    "side_by_side_frames",
    "turntable",
    "turntable_frames",
    "write_frames",
    "write_image",
]
