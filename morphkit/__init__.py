"""morphkit: differentiable kinematics for creatures of any morphology.

``import morphkit`` loads NumPy only; Warp, PyTorch, USD and pyrender are imported by the
subpackages that need them.
"""

from morphkit._version import __version__ as __version__
from morphkit.errors import MorphkitError as MorphkitError
from morphkit.errors import SourceLocation as SourceLocation
from morphkit.graph import Morphology as Morphology
from morphkit.graph import MorphologyBuilder as MorphologyBuilder

__all__ = ["MorphkitError", "Morphology", "MorphologyBuilder", "SourceLocation", "__version__"]
