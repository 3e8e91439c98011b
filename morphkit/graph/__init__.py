"""The skeleton graph: Morphology, its builder, elements and enums (pure Python + NumPy)."""

from morphkit.graph.builder import MorphologyBuilder as MorphologyBuilder
from morphkit.graph.elements import EndEffector as EndEffector
from morphkit.graph.elements import Joint as Joint
from morphkit.graph.elements import Limit as Limit
from morphkit.graph.elements import Link as Link
from morphkit.graph.elements import Mimic as Mimic
from morphkit.graph.elements import Shape as Shape
from morphkit.graph.elements import Transform as Transform
from morphkit.graph.elements import Wheels as Wheels
from morphkit.graph.layout import BASE_COORD_WIDTH as BASE_COORD_WIDTH
from morphkit.graph.layout import BASE_DOF_WIDTH as BASE_DOF_WIDTH
from morphkit.graph.layout import JOINT_COORD_WIDTH as JOINT_COORD_WIDTH
from morphkit.graph.layout import JOINT_DOF_WIDTH as JOINT_DOF_WIDTH
from morphkit.graph.morphology import HUMAN_HAND_REACH as HUMAN_HAND_REACH
from morphkit.graph.morphology import Morphology as Morphology
from morphkit.graph.types import BaseType as BaseType
from morphkit.graph.types import BodyLengthRule as BodyLengthRule
from morphkit.graph.types import EndEffectorRole as EndEffectorRole
from morphkit.graph.types import JointType as JointType
from morphkit.graph.types import ShapeType as ShapeType

__all__ = [
    "BASE_COORD_WIDTH",
    "BASE_DOF_WIDTH",
    "HUMAN_HAND_REACH",
    "JOINT_COORD_WIDTH",
    "JOINT_DOF_WIDTH",
    "BaseType",
    "BodyLengthRule",
    "EndEffector",
    "EndEffectorRole",
    "Joint",
    "JointType",
    "Limit",
    "Link",
    "Mimic",
    "Morphology",
    "MorphologyBuilder",
    "Shape",
    "ShapeType",
    "Transform",
    "Wheels",
]
