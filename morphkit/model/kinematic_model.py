"""The compiled kinematic model: a Morphology flattened into arrays that kernels read.

Everything here is NumPy on the host; :meth:`KinematicModel.arrays` mirrors the arrays on a
Warp device (cached per device and dtype). The q layout is documented in
``docs/design/q-layout.md``.
"""

from __future__ import annotations

import dataclasses
import threading
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from morphkit.errors import GraphError
from morphkit.graph.types import BaseType

if TYPE_CHECKING:
    import warp as wp

__all__ = ["KinematicModel", "ModelArrays", "resolve_float_dtype"]


class ModelArrays:
    """Warp mirrors of a :class:`KinematicModel`'s arrays on one device, in one float dtype.

    Attribute names match the model's fields. Integer arrays are ``int32``; float arrays use the
    scalar type ``dtype`` (``wp.float32`` or ``wp.float64``); transforms are ``wp.transform``
    (or ``wp.transformd``), vectors ``wp.vec3`` (or ``wp.vec3d``).
    """

    def __init__(self, model: KinematicModel, device: wp.context.Device, dtype: Any) -> None:
        import warp as wp

        vec3 = wp.vec3d if dtype == wp.float64 else wp.vec3
        transform = wp.transformd if dtype == wp.float64 else wp.transform
        np_float = np.float64 if dtype == wp.float64 else np.float32

        def ints(a: np.ndarray) -> wp.array:
            return wp.array(np.ascontiguousarray(a, dtype=np.int32), dtype=wp.int32, device=device)

        def floats(a: np.ndarray, wtype: Any) -> wp.array:
            return wp.array(np.ascontiguousarray(a, dtype=np_float), dtype=wtype, device=device)

        self.device = device
        self.dtype = dtype
        self.link_parent = ints(model.link_parent)
        self.joint_type = ints(model.joint_type)
        self.joint_parent = ints(model.joint_parent)
        self.joint_X_parent = floats(model.joint_X_parent, transform)
        self.joint_axis = floats(model.joint_axis, vec3)
        self.joint_q_start = ints(model.joint_q_start)
        self.joint_qd_start = ints(model.joint_qd_start)
        self.joint_mimic_target = ints(model.joint_mimic_target)
        self.joint_mimic_multiplier = floats(model.joint_mimic_multiplier, dtype)
        self.joint_mimic_offset = floats(model.joint_mimic_offset, dtype)
        self.joint_wheel = ints(model.joint_wheel)
        self.joint_limit_lower = floats(model.joint_limit_lower, dtype)
        self.joint_limit_upper = floats(model.joint_limit_upper, dtype)
        self.coordinate_lower = floats(model.coordinate_lower, dtype)
        self.coordinate_upper = floats(model.coordinate_upper, dtype)
        self.ee_link = ints(model.ee_link)
        self.ee_offset = floats(model.ee_offset, vec3)
        self.ee_role = ints(model.ee_role)
        self.shape_link = ints(model.shape_link)
        self.shape_type = ints(model.shape_type)
        self.shape_X_link = floats(model.shape_X_link, transform)
        self.shape_params = floats(model.shape_params, vec3)
        self.wheel_joint = ints(model.wheel_joint)
        self.wheel_lateral = floats(model.wheel_lateral, dtype)
        self.wheel_sign = floats(model.wheel_sign, dtype)


@dataclass(frozen=True, eq=False)
class KinematicModel:
    """A :class:`~morphkit.graph.Morphology` compiled to flat arrays (build with :func:`compile_model`).

    Links are in topological (depth-first) order: link 0 is the root and link ``j + 1`` is the
    child of joint ``j``. ``J`` is ``joint_count``, ``L = J + 1`` is ``link_count``, ``C`` is
    ``coordinate_count``, ``E`` is ``ee_count``, ``S`` is ``shape_count``, ``W`` is
    ``wheel_count``. Transforms are ``[px, py, pz, qx, qy, qz, qw]`` (metres, xyzw quaternion).
    All host arrays are read-only NumPy arrays (float64 for reals, int32 for indices).
    """

    name: str
    """Creature name."""
    base_type: BaseType
    """How the root moves: floating (7 coordinates), planar / wheeled (3), fixed (0)."""
    link_names: tuple[str, ...]
    """Link names, shape [L]."""
    joint_names: tuple[str, ...]
    """Joint names, shape [J]."""
    ee_names: tuple[str, ...]
    """End-effector names, shape [E]."""
    coordinate_names: tuple[str, ...]
    """Name of every entry of ``q``, shape [C]."""

    link_parent: np.ndarray
    """Parent link of every link (-1 for the root), shape [L], int32."""
    joint_type: np.ndarray
    """:class:`~morphkit.graph.JointType` value of every joint, shape [J], int32."""
    joint_parent: np.ndarray
    """Parent link index of every joint (its child is link ``j + 1``), shape [J], int32."""
    joint_X_parent: np.ndarray
    """Joint frame in the parent link frame (``T_parent_joint``), shape [J, 7], [m] and xyzw."""
    joint_axis: np.ndarray
    """Unit joint axis in the joint frame, shape [J, 3] (meaningless for fixed and spherical)."""
    joint_q_start: np.ndarray
    """Start of each joint's coordinates in ``q``, shape [J + 1], int32; the last entry is C.
    Driven joints (mimic, wheel) have width 0."""
    joint_qd_start: np.ndarray
    """Start of each joint's DoFs in ``qd``, shape [J + 1], int32; the last entry is the DoF count."""
    joint_mimic_target: np.ndarray
    """Joint a mimic joint follows (-1 if not a mimic), shape [J], int32."""
    joint_mimic_multiplier: np.ndarray
    """Mimic multiplier (value = multiplier * q[target] + offset), shape [J]."""
    joint_mimic_offset: np.ndarray
    """Mimic offset [rad or m], shape [J]."""
    joint_wheel: np.ndarray
    """Wheel index of a wheel joint (-1 otherwise), shape [J], int32."""
    joint_limit_lower: np.ndarray
    """Lower joint limit [rad or m] (-inf where unbounded or not 1-DoF), shape [J]."""
    joint_limit_upper: np.ndarray
    """Upper joint limit [rad or m] (+inf where unbounded or not 1-DoF), shape [J]."""
    coordinate_lower: np.ndarray
    """Lower bound of every entry of ``q`` (-inf where unbounded; -1 for quaternion entries), shape [C]."""
    coordinate_upper: np.ndarray
    """Upper bound of every entry of ``q`` (+inf where unbounded; 1 for quaternion entries), shape [C]."""
    rest_q: np.ndarray
    """Rest pose (identity rotations, joints at 0 clamped into their limits), shape [C]."""

    ee_link: np.ndarray
    """Link of every end-effector, shape [E], int32."""
    ee_offset: np.ndarray
    """End-effector point in its link frame, shape [E, 3], [m]."""
    ee_role: np.ndarray
    """:class:`~morphkit.graph.EndEffectorRole` value of every end-effector, shape [E], int32."""

    shape_link: np.ndarray
    """Link each collision/visual shape is attached to, shape [S], int32."""
    shape_type: np.ndarray
    """:class:`~morphkit.graph.ShapeType` value of every shape, shape [S], int32."""
    shape_X_link: np.ndarray
    """Shape frame in its link frame (``T_link_shape``), shape [S, 7]."""
    shape_params: np.ndarray
    """Shape size, shape [S, 3], [m]: sphere ``(radius, 0, 0)``; capsule and cylinder
    ``(radius, half_length, 0)`` with the axis along the shape's local z (capsule: half length of
    the cylindrical part, without the caps); box ``(hx, hy, hz)`` half extents; mesh the per-axis
    ``scale`` (meshes are for rendering; contact queries skip them)."""

    wheel_joint: np.ndarray
    """Joint index of every drive wheel, shape [W], int32."""
    wheel_radius: float
    """Wheel radius [m] (0 when there are no wheels)."""
    wheel_lateral: np.ndarray
    """Lateral (root-frame y, left positive) position of each wheel's joint at rest, shape [W], [m]."""
    wheel_sign: np.ndarray
    """+1 where a positive wheel angle rolls the wheel forward, -1 where its axis points right, shape [W]."""

    collision_exclude: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int32))
    """Link pairs never checked for self-collision (MJCF ``<contact><exclude>``), shape [X, 2], int32."""
    device: str | None = None
    """Default Warp device for :meth:`arrays` and launchers (``None``: Warp's default device)."""
    _cache: dict = field(default_factory=dict, repr=False, compare=False)
    _lock: Any = field(default_factory=threading.Lock, repr=False, compare=False)

    def __repr__(self) -> str:
        return (
            f"KinematicModel({self.name!r}, base={self.base_type.name.lower()}, links={self.link_count}, "
            f"coordinates={self.coordinate_count}, end_effectors={self.ee_count}, shapes={self.shape_count}, "
            f"wheels={self.wheel_count})"
        )

    # ---- sizes -----------------------------------------------------------------------------
    @property
    def link_count(self) -> int:
        """Number of links L (the root included)."""
        return len(self.link_names)

    @property
    def joint_count(self) -> int:
        """Number of joints J = L - 1."""
        return len(self.joint_names)

    @property
    def coordinate_count(self) -> int:
        """Length C of ``q`` (base coordinates included)."""
        return int(self.joint_q_start[-1])

    @property
    def base_coordinate_count(self) -> int:
        """Coordinates the base occupies at the start of ``q`` (floating 7, planar/wheeled 3, fixed 0)."""
        return int(self.joint_q_start[0])

    @property
    def dof(self) -> int:
        """Independent joint DoFs (no base, no driven joints)."""
        return int(self.joint_qd_start[-1] - self.joint_qd_start[0])

    @property
    def ee_count(self) -> int:
        """Number of end-effectors E."""
        return len(self.ee_names)

    @property
    def shape_count(self) -> int:
        """Number of shapes S."""
        return len(self.shape_type)

    @property
    def wheel_count(self) -> int:
        """Number of drive wheels W."""
        return len(self.wheel_joint)

    # ---- lookups ---------------------------------------------------------------------------
    def link_index(self, name: str) -> int:
        """Index of link ``name``."""
        return _lookup(self.link_names, name, "link")

    def joint_index(self, name: str) -> int:
        """Index of joint ``name``."""
        return _lookup(self.joint_names, name, "joint")

    def ee_index(self, name: str) -> int:
        """Index of end-effector ``name``."""
        return _lookup(self.ee_names, name, "end-effector")

    def coordinate_index(self, name: str) -> int:
        """Index in ``q`` of coordinate ``name`` (see :attr:`coordinate_names`)."""
        return _lookup(self.coordinate_names, name, "coordinate")

    # ---- device mirrors --------------------------------------------------------------------
    def to(self, device: Any) -> KinematicModel:
        """The same model with another default device (device arrays are shared and cached)."""
        import warp as wp

        name = str(wp.get_device(device))
        if name == self.device:
            return self
        return dataclasses.replace(self, device=name, _cache=self._cache, _lock=self._lock)

    def arrays(self, device: Any = None, dtype: Any = None) -> ModelArrays:
        """Warp mirrors of the arrays on ``device`` (default: :attr:`device`), built once and cached.

        Args:
            device: A Warp device or its name.
            dtype: ``wp.float32`` (default) or ``wp.float64``.
        """
        import warp as wp

        dev = wp.get_device(device if device is not None else self.device)
        dt = resolve_float_dtype(dtype)
        key = (dev.alias, dt.__name__)
        arrays = self._cache.get(key)
        if arrays is None:
            with self._lock:
                arrays = self._cache.get(key)
                if arrays is None:
                    arrays = ModelArrays(self, dev, dt)
                    self._cache[key] = arrays
        return arrays

    def kernel_cache(self) -> dict:
        """Per-model cache used by the kernel launchers (generated kernels, reusable buffers)."""
        return self._cache.setdefault("kernels", {})


def resolve_float_dtype(dtype: Any) -> Any:
    """``wp.float32`` or ``wp.float64`` from a Warp, NumPy, PyTorch or string dtype (``None``: float32).

    Raises:
        GraphError: for any other dtype.
    """
    import warp as wp

    if dtype is None:
        return wp.float32
    name = str(getattr(dtype, "__name__", dtype)).rsplit(".", 1)[-1]
    if name in ("float32", "float"):
        return wp.float32
    if name in ("float64", "double"):
        return wp.float64
    raise GraphError(f"unsupported dtype {dtype!r}; expected float32 or float64")


def _lookup(names: tuple[str, ...], name: str, what: str) -> int:
    try:
        return names.index(name)
    except ValueError:
        raise GraphError(f"no {what} {name!r} ({what}s: {', '.join(names)})") from None
