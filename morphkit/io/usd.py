"""USD (UsdPhysics articulations) <-> skeleton graph. ``pxr`` is imported inside functions only.

Reading (:func:`read_usd`)
--------------------------
- **Which prims.** The stage is read composed (sublayers, references, payloads) and through instance proxies.
  The articulation's root is the prim with ``PhysicsArticulationRootAPI`` (the one under the default prim when
  there are several; more than one left is an error). On a rigid body (Isaac Sim's layout) the articulation is
  every body reached from it through joints, wherever the joints sit (under their child link, in a ``joints``
  scope, in another layer); on an ancestor ``Xform`` it is the rigid bodies under it, plus any prim a joint
  names as ``physics:body0``/``physics:body1``, and the ``Physics{Revolute,Prismatic,Spherical,Fixed}Joint``
  prims under it or attached to its bodies. Without an articulation root the whole stage is read (it must hold
  one connected tree). Joints with ``physics:excludeFromArticulation`` (loop closures) are skipped with a
  warning, and so are a stage's joints and bodies the articulation does not reach; a loop a joint closes
  without it is an error (two parents). A prim name the file repeats (the MuJoCo USD converter's
  ``PhysicsFixedJoint`` on every foot) is prefixed with its parents' names (``FL_foot_PhysicsFixedJoint``),
  with a warning. The creature is named by the articulation root, or by the default prim when the root is a
  body inside it.
- **Frames.** ``body0`` is the parent, ``body1`` the child. A joint's frame is
  ``(localPos0, localRot0)`` in ``body0`` and ``(localPos1, localRot1)`` in ``body1``; its axis
  token (X, Y or Z) is in that frame. morphkit's child link frame sits at the joint's pivot with
  ``body1``'s orientation, so a non-identity ``localPos1``/``localRot1`` is folded in exactly:
  ``origin = T_parent_body0 · (localPos0, localRot0) · localRot1⁻¹``,
  ``axis = localRot1 · e_token``, and everything attached to ``body1`` (shapes, end-effectors,
  its own child joints) moves by ``-localPos1``.
- **Joint types.** Revolute with finite limits -> revolute (limits in **degrees** in USD,
  radians in morphkit); revolute without limits (unauthored or ±inf) -> continuous;
  prismatic -> prismatic (limits in stage units); spherical -> spherical (cone limits are not
  kept); fixed -> fixed. A fixed joint with an empty ``body0`` attaches the root to the world:
  a fixed base. Any other joint to the world gets a ``world`` root link and a fixed base.
- **Shapes.** Collision gprims under each link (``PhysicsCollisionAPI`` not switched off by
  ``physics:collisionEnabled = false``); a link without any keeps all its gprims (its visuals),
  posed relative to the link: ``Cube`` -> box of extents
  ``size × scale``; ``Sphere`` -> sphere; ``Capsule``/``Cylinder`` (``radius``, ``height``,
  ``axis``) -> capsule/cylinder along local z (rotated from the USD axis); ``Mesh`` -> mesh:
  the file in ``morphkit:meshPath`` when present (resolved against the USD file), otherwise the
  inline mesh itself, named ``"<usd file>#<prim path>"`` (:func:`load_usd_mesh` reads it).
- **Units and axes.** Lengths are multiplied by the stage's ``metersPerUnit``; a Y-up stage is
  turned Z-up by rotating the root link's contents +90° about x.
- **Errors.** Unreadable or malformed files (garbage bytes, a syntax error: the line pxr
  reports), a joint without ``body1``, a target that does not exist, an unsupported joint or a
  bad ``morphkit:`` value raise :class:`~morphkit.errors.DescriptionError` naming the file and,
  for ``.usda`` text, the line where the prim is defined (the layer that defines it: a payload's
  or a reference's own file when the prim comes from there).

Writing (:func:`write_usd`)
---------------------------
``.usda`` (text), ``.usdc`` and ``.usd`` (binary crate), atomically. The stage is Z-up,
1 metre per unit; the default prim ``/<name>`` carries ``PhysicsArticulationRootAPI``; each
link is an ``Xform`` child of it with ``PhysicsRigidBodyAPI``, placed at its rest pose, holding
its shapes (``PhysicsCollisionAPI`` gprims ``collision_<k>``; boxes as a unit ``Cube`` scaled to
the extents) and its end-effectors (``Xform`` prims at the offset); joints live under
``/<name>/joints``. A 1-DoF joint's frame is rotated so that its axis is the token axis
(``localRot1`` holds that rotation, ``localPos1`` is zero), so arbitrary axes survive a round
trip to float precision (~1e-7). A fixed base adds a world ``PhysicsFixedJoint`` (empty
``body0``). Mesh shapes are written as a ``Mesh`` prim with ``morphkit:meshPath`` (relative to
the USD file) and the mesh's points when the file can be loaded.

``morphkit:`` attributes (custom, ignored by other tools)
---------------------------------------------------------
On the articulation root prim:
  ``morphkit:name`` (string, the creature name), ``morphkit:base`` (token: floating, planar,
  wheeled, fixed; wins over the world-joint rule), ``morphkit:wheelJoints`` (string[],
  joint names) and ``morphkit:wheelRadius`` (double, metres); optionally ``morphkit:wheelDrive`` (token),
  ``morphkit:wheelSteering`` / ``wheelSteered`` (string[]), ``wheelSteeredRadii`` (double[]) and
  ``wheelMaxSteer`` (double, rad), as YAML's ``wheels:``.
On link and joint prims:
  ``morphkit:name`` (string): the morphkit name when it is not a valid prim name.
On joint prims:
  ``morphkit:jointType`` (token: fixed, revolute, continuous, prismatic, spherical; for a
  revolute prim it tells continuous from revolute), ``morphkit:mimicJoint`` (string),
  ``morphkit:mimicMultiplier`` and ``morphkit:mimicOffset`` (double),
  ``morphkit:velocityLimit`` and ``morphkit:effortLimit`` (double).
On end-effector prims (an ``Xform`` under a link, posed by its translation):
  ``morphkit:endEffectorRole`` (token: foot, hand, head, tool) marks the prim as an
  end-effector; ``morphkit:name`` (string) as above.
On mesh prims:
  ``morphkit:meshPath`` (asset): the mesh file.
"""

from __future__ import annotations

import bisect
import math
import os
import re
import warnings
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from morphkit._atomic import atomic_path
from morphkit.body.anatomy import complete_anatomy
from morphkit.conventions import quat_conjugate, quat_multiply, quat_rotate, transform_multiply
from morphkit.errors import DescriptionError, MorphkitError, SourceLocation
from morphkit.graph import (
    BaseType,
    EndEffectorRole,
    JointType,
    Limit,
    Mimic,
    Morphology,
    MorphologyBuilder,
    Shape,
    ShapeType,
    Transform,
)
from morphkit.graph.types import parse_enum
from morphkit.io._source import relative_mesh_path, resolve_mesh_path
from morphkit.io._usd_scope import Scope, find_articulation, unique_names
from morphkit.rotations import quat_between_vectors

__all__ = ["USD_SUFFIXES", "build_stage", "export_stage", "load_usd_mesh", "read_usd", "write_usd"]

USD_SUFFIXES = (".usd", ".usda", ".usdc")
"""File suffixes of USD layers morphkit reads and writes."""

_NS = "morphkit:"
_IDENTITY7 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
_AXIS_TOKENS = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}
# Quaternions (xyzw) that turn local z onto a USD gprim's X / Y / Z axis.
_Z_TO_AXIS = {
    "X": np.array([0.0, math.sqrt(0.5), 0.0, math.sqrt(0.5)]),  # +90° about y
    "Y": np.array([-math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)]),  # -90° about x
    "Z": np.array([0.0, 0.0, 0.0, 1.0]),
}
_Y_UP_TO_Z_UP = np.array([math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)])  # +90° about x: +y -> +z


# ---------------------------------------------------------------------------------------------
# small helpers
# ---------------------------------------------------------------------------------------------
def _quat_xyzw(q: Any) -> np.ndarray:
    """xyzw array from a Gf quaternion (``(real, imaginary)``)."""
    im = q.GetImaginary()
    return np.array([im[0], im[1], im[2], q.GetReal()], dtype=float)


def _pose(xyz: Iterable[float], quat: Iterable[float]) -> np.ndarray:
    return np.array([*xyz, *quat], dtype=float)


def _inverse(T: np.ndarray) -> np.ndarray:
    qi = quat_conjugate(T[3:])
    return np.concatenate([-quat_rotate(qi, T[:3]), qi])


def _transform(T: np.ndarray) -> Transform:
    q = T[3:] / np.linalg.norm(T[3:])
    return Transform(tuple(float(v) for v in T[:3]), tuple(float(v) for v in q))  # type: ignore[arg-type]


class _Names:
    """Valid, unique USD prim names for arbitrary morphkit names."""

    def __init__(self, reserved: Iterable[str] = ()) -> None:
        from pxr import Tf

        self._make = Tf.MakeValidIdentifier
        self.used = set(reserved)

    def get(self, name: str) -> str:
        base = self._make(name) if name else "_"
        out, k = base, 1
        while out in self.used:
            out, k = f"{base}_{k}", k + 1
        self.used.add(out)
        return out


# ---------------------------------------------------------------------------------------------
# writing
# ---------------------------------------------------------------------------------------------
def _set_custom(prim: Any, name: str, type_name: Any, value: Any) -> None:
    prim.CreateAttribute(_NS + name, type_name, custom=True).Set(value)


def _set_pose_ops(xformable: Any, xyz: Iterable[float], quat: Iterable[float], scale: Iterable[float] | None) -> None:
    """Author translate, orient and (optionally) scale ops in double precision."""
    from pxr import Gf, UsdGeom

    x, y, z = (float(v) for v in xyz)
    qx, qy, qz, qw = (float(v) for v in quat)
    xformable.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(x, y, z))
    xformable.AddOrientOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Quatd(qw, qx, qy, qz))
    if scale is not None:
        xformable.AddScaleOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*(float(v) for v in scale)))


def _mesh_arrays(mesh: str) -> tuple[np.ndarray, np.ndarray] | None:
    """Vertices [V, 3] and triangles [F, 3] of a mesh file or ``usd#prim`` reference, if loadable."""
    try:
        if "#" in mesh and Path(mesh.split("#", 1)[0]).suffix.lower() in USD_SUFFIXES:
            return load_usd_mesh(mesh)
        if not Path(mesh).is_file():
            return None
        import trimesh

        loaded = trimesh.load(mesh, force="mesh")
        if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0:
            return None
        return np.asarray(loaded.vertices, dtype=float), np.asarray(loaded.faces, dtype=np.int64)
    except (MorphkitError, ValueError, OSError, ImportError, IndexError, KeyError, AttributeError, TypeError):
        # A mesh that cannot be inlined is still written by reference.
        return None


def _write_shape(stage: Any, path: Any, s: Shape, target: str) -> None:
    from pxr import Sdf, Usd, UsdGeom, UsdPhysics

    xyz, quat = s.origin.xyz, s.origin.quat
    if s.type == ShapeType.BOX:
        g = UsdGeom.Cube.Define(stage, path)
        g.CreateSizeAttr(1.0)
        _set_pose_ops(g, xyz, quat, s.size)
    elif s.type == ShapeType.SPHERE:
        g = UsdGeom.Sphere.Define(stage, path)
        g.CreateRadiusAttr(float(s.radius))
        _set_pose_ops(g, xyz, quat, None)
    elif s.type in (ShapeType.CAPSULE, ShapeType.CYLINDER):
        g = (UsdGeom.Capsule if s.type == ShapeType.CAPSULE else UsdGeom.Cylinder).Define(stage, path)
        g.CreateRadiusAttr(float(s.radius))
        g.CreateHeightAttr(float(s.length))
        g.CreateAxisAttr(UsdGeom.Tokens.z)
        _set_pose_ops(g, xyz, quat, None)
    else:
        g = UsdGeom.Mesh.Define(stage, path)
        mesh = s.mesh or ""
        is_usd_ref = "#" in mesh and Path(mesh.split("#", 1)[0]).suffix.lower() in USD_SUFFIXES
        if not is_usd_ref:
            _set_custom(g.GetPrim(), "meshPath", Sdf.ValueTypeNames.Asset, relative_mesh_path(mesh, target))
        arrays = _mesh_arrays(mesh)
        if arrays is not None:
            verts, faces = arrays
            g.CreatePointsAttr([tuple(map(float, v)) for v in verts])
            g.CreateFaceVertexCountsAttr([3] * len(faces))
            g.CreateFaceVertexIndicesAttr([int(i) for i in faces.reshape(-1)])
        _set_pose_ops(g, xyz, quat, s.scale)
    UsdPhysics.CollisionAPI.Apply(g.GetPrim())
    extent = UsdGeom.Boundable.ComputeExtentFromPlugins(g, Usd.TimeCode.Default())
    if extent is not None and len(extent) == 2:
        g.CreateExtentAttr(extent)


def _axis_frame(axis: tuple[float, float, float]) -> tuple[str, np.ndarray]:
    """Axis token and the rotation (xyzw) of the USD joint frame within morphkit's joint frame."""
    a = np.asarray(axis, dtype=float)
    for token, e in _AXIS_TOKENS.items():
        if np.allclose(a, e, rtol=0.0, atol=1e-12):
            return token, _IDENTITY7[3:].copy()
    return "X", quat_between_vectors(_AXIS_TOKENS["X"], a / np.linalg.norm(a))


def build_stage(m: Morphology, target: str | None = None) -> Any:
    """Build the in-memory ``Usd.Stage`` of ``m`` (what :func:`write_usd` exports).

    Args:
        m: The morphology.
        target: Path the stage will be saved as; mesh paths are written relative to it.
    """
    from pxr import Gf, Sdf, Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.CreateInMemory()
    UsdGeom.SetStageUpAxis(stage, UsdGeom.Tokens.z)
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    UsdPhysics.SetStageKilogramsPerUnit(stage, 1.0)
    robot_path = Sdf.Path.absoluteRootPath.AppendChild(_Names().get(m.name))
    robot = UsdGeom.Xform.Define(stage, robot_path).GetPrim()
    stage.SetDefaultPrim(robot)
    UsdPhysics.ArticulationRootAPI.Apply(robot)
    _set_custom(robot, "name", Sdf.ValueTypeNames.String, m.name)
    _set_custom(robot, "base", Sdf.ValueTypeNames.Token, m.base.name.lower())
    if m.wheels is not None:
        _set_custom(robot, "wheelJoints", Sdf.ValueTypeNames.StringArray, list(m.wheels.joints))
        _set_custom(robot, "wheelRadius", Sdf.ValueTypeNames.Double, float(m.wheels.radius))
        _set_custom(robot, "wheelDrive", Sdf.ValueTypeNames.Token, m.wheels.drive)
        if m.wheels.steering:
            _set_custom(robot, "wheelSteering", Sdf.ValueTypeNames.StringArray, list(m.wheels.steering))
        if m.wheels.steered:
            _set_custom(robot, "wheelSteered", Sdf.ValueTypeNames.StringArray, list(m.wheels.steered))
        if m.wheels.steered_radii:
            _set_custom(robot, "wheelSteeredRadii", Sdf.ValueTypeNames.DoubleArray, list(m.wheels.steered_radii))
        if m.wheels.max_steer is not None:
            _set_custom(robot, "wheelMaxSteer", Sdf.ValueTypeNames.Double, float(m.wheels.max_steer))

    target_str = os.fspath(target) if target is not None else None
    names = _Names(reserved={"joints"})
    link_paths: dict[str, Any] = {}
    poses = m.rest_link_poses()
    ees_by_link: dict[str, list[Any]] = {}
    for ee in m.end_effectors:
        ees_by_link.setdefault(ee.link, []).append(ee)
    for i, link in enumerate(m.links):
        prim_name = names.get(link.name)
        path = robot_path.AppendChild(prim_name)
        link_paths[link.name] = path
        x = UsdGeom.Xform.Define(stage, path)
        _set_pose_ops(x, poses[i, :3], poses[i, 3:], None)
        UsdPhysics.RigidBodyAPI.Apply(x.GetPrim())
        if prim_name != link.name:
            _set_custom(x.GetPrim(), "name", Sdf.ValueTypeNames.String, link.name)
        child_names = _Names()
        for k, s in enumerate(link.shapes):
            _write_shape(stage, path.AppendChild(child_names.get(f"collision_{k}")), s, target_str or "")
        for ee in ees_by_link.get(link.name, []):
            ee_name = child_names.get(ee.name)
            e = UsdGeom.Xform.Define(stage, path.AppendChild(ee_name))
            e.AddTranslateOp(UsdGeom.XformOp.PrecisionDouble).Set(Gf.Vec3d(*(float(v) for v in ee.offset)))
            _set_custom(e.GetPrim(), "endEffectorRole", Sdf.ValueTypeNames.Token, ee.role.name.lower())
            if ee_name != ee.name:
                _set_custom(e.GetPrim(), "name", Sdf.ValueTypeNames.String, ee.name)

    joints_path = robot_path.AppendChild("joints")
    UsdGeom.Scope.Define(stage, joints_path)
    joint_names = _Names()
    for j in m.joints:
        prim_name = joint_names.get(j.name)
        path = joints_path.AppendChild(prim_name)
        origin = j.origin.as_array()
        q_frame = _IDENTITY7[3:].copy()
        if j.type == JointType.FIXED:
            uj = UsdPhysics.FixedJoint.Define(stage, path)
        elif j.type == JointType.SPHERICAL:
            uj = UsdPhysics.SphericalJoint.Define(stage, path)
            uj.CreateAxisAttr(UsdPhysics.Tokens.x)
        else:
            token, q_frame = _axis_frame(j.axis)
            if j.type == JointType.PRISMATIC:
                uj = UsdPhysics.PrismaticJoint.Define(stage, path)
            else:
                uj = UsdPhysics.RevoluteJoint.Define(stage, path)
            uj.CreateAxisAttr(token)
            if j.limit is not None and j.type in (JointType.REVOLUTE, JointType.PRISMATIC):
                to_usd = math.degrees if j.type == JointType.REVOLUTE else float
                uj.CreateLowerLimitAttr(to_usd(j.limit.lower))
                uj.CreateUpperLimitAttr(to_usd(j.limit.upper))
        prim = uj.GetPrim()
        uj.CreateBody0Rel().SetTargets([link_paths[j.parent]])
        uj.CreateBody1Rel().SetTargets([link_paths[j.child]])
        rot0 = quat_multiply(origin[3:], q_frame)
        uj.CreateLocalPos0Attr(Gf.Vec3f(*(float(v) for v in origin[:3])))
        uj.CreateLocalRot0Attr(Gf.Quatf(float(rot0[3]), Gf.Vec3f(*(float(v) for v in rot0[:3]))))
        uj.CreateLocalPos1Attr(Gf.Vec3f(0.0, 0.0, 0.0))
        uj.CreateLocalRot1Attr(Gf.Quatf(float(q_frame[3]), Gf.Vec3f(*(float(v) for v in q_frame[:3]))))
        if prim_name != j.name:
            _set_custom(prim, "name", Sdf.ValueTypeNames.String, j.name)
        _set_custom(prim, "jointType", Sdf.ValueTypeNames.Token, j.type.name.lower())
        if j.mimic is not None:
            _set_custom(prim, "mimicJoint", Sdf.ValueTypeNames.String, j.mimic.joint)
            _set_custom(prim, "mimicMultiplier", Sdf.ValueTypeNames.Double, float(j.mimic.multiplier))
            _set_custom(prim, "mimicOffset", Sdf.ValueTypeNames.Double, float(j.mimic.offset))
        if j.limit is not None and j.limit.velocity is not None:
            _set_custom(prim, "velocityLimit", Sdf.ValueTypeNames.Double, float(j.limit.velocity))
        if j.limit is not None and j.limit.effort is not None:
            _set_custom(prim, "effortLimit", Sdf.ValueTypeNames.Double, float(j.limit.effort))
    if m.base == BaseType.FIXED:
        anchor = UsdPhysics.FixedJoint.Define(stage, joints_path.AppendChild(joint_names.get("world_fixed")))
        anchor.CreateBody1Rel().SetTargets([link_paths[m.root]])
    return stage


def write_usd(m: Morphology, path: str | os.PathLike[str]) -> None:
    """Write ``m`` as a UsdPhysics articulation to ``.usda``, ``.usdc`` or ``.usd``, atomically.

    See the module docstring for the layout and the ``morphkit:`` attributes.

    Raises:
        DescriptionError: unsupported suffix, or USD could not write the file.
    """
    target = os.fspath(path)
    suffix = Path(target).suffix.lower()
    if suffix not in USD_SUFFIXES:
        raise DescriptionError(
            f"not a USD file suffix {suffix or '(none)'!r}; expected one of: {', '.join(USD_SUFFIXES)}",
            location=SourceLocation(target),
        )
    export_stage(build_stage(m, target), target)


def export_stage(stage: Any, path: str | os.PathLike[str]) -> None:
    """Export ``stage``'s root layer to ``path`` atomically (the suffix picks text or crate).

    Raises:
        DescriptionError: USD could not write the file (a full disk, say): one line with pxr's reasons,
            each once; nothing is left at ``path``.
    """
    from pxr import Tf

    target = os.fspath(path)
    # The temporary file keeps the suffix, so Sdf picks the same file format (text or crate).
    with atomic_path(target) as tmp:
        try:
            ok = stage.GetRootLayer().Export(str(tmp))
        except Tf.ErrorException as exc:
            detail = _pxr_message(exc, most=2).replace(str(tmp), target)
            raise DescriptionError(f"USD could not write the file: {detail}", location=SourceLocation(target)) from None
        if not ok:
            raise DescriptionError("USD could not write the file", location=SourceLocation(target))


# ---------------------------------------------------------------------------------------------
# reading
# ---------------------------------------------------------------------------------------------
def _pxr_message(exc: BaseException, most: int | None = None) -> str:
    """The useful part of a pxr error: the quoted messages (each once, the first ``most``) without C++
    names and source lines."""
    text = str(exc)
    # A failed write posts one error per buffer flush (thousands on a full disk): each message once.
    quoted = list(dict.fromkeys(q.strip() for q in re.findall(r" : '(.*?)'(?=\n|$)", text, flags=re.S)))
    msg = "; ".join(quoted[:most]) if quoted else text.strip()
    return re.sub(r"pxrInternal_v\w+::", "", msg)


def _open_stage(src: str) -> Any:
    from pxr import Sdf, Tf, Usd

    where = SourceLocation(src)
    p = Path(src)
    if not p.exists():
        raise DescriptionError(f"USD file not found: {src}", location=where)
    if not p.is_file():
        raise DescriptionError(f"USD path is not a file: {src}", location=where)
    try:
        layer = Sdf.Layer.Find(src)
        if layer is not None:
            layer.Reload(force=True)  # the registry may hold an older version of this file
        else:
            layer = Sdf.Layer.FindOrOpen(src)
        if layer is None:
            raise DescriptionError("not a readable USD layer", location=where)
        return Usd.Stage.Open(layer, Usd.Stage.LoadAll)
    except Tf.ErrorException as exc:
        msg = _pxr_message(exc)
        m = re.search(r":(\d+):\d+: ([^\n]*)", msg)
        if m is not None:
            detail = re.sub(r"\s*\(?Sdf_TextFileFormatParser::", " ", m.group(2)).strip()
            raise DescriptionError(f"USD syntax error: {detail}", location=where.at_line(int(m.group(1)))) from None
        raise DescriptionError(f"cannot read USD file: {msg}", location=where) from None


class _PrimLines:
    """Line numbers of ``def`` statements in a ``.usda`` text layer, for error locations."""

    def __init__(self, src: str) -> None:
        self.lines: list[str] = []
        try:
            with open(src, "rb") as f:
                head = f.read(8)
                if head.startswith(b"#usda"):
                    self.lines = (head + f.read()).decode("utf-8", errors="replace").split("\n")
        except OSError:
            pass
        self._cache: dict[str, int | None] = {}
        # Rows of each prim name's def/over/class statements, found in one pass: a scan of the text per prim
        # cost a 1,500-link chain 30 s.
        self._rows: dict[str, list[int]] = {}
        pat = re.compile(r'^\s*(def|over|class)\b[^"]*"([^"]*)"')
        for i, text in enumerate(self.lines):
            if (m := pat.search(text)) is not None:
                self._rows.setdefault(m.group(2), []).append(i)

    def line(self, path: Any) -> int | None:
        """Line of the prim's ``def``/``over``/``class`` (searching each path component in turn)."""
        key = str(path)
        if not self.lines or not key.startswith("/"):
            return None
        if key not in self._cache:
            row = 0
            found: int | None = None
            for comp in key.strip("/").split("/"):
                rows = self._rows.get(comp, [])
                k = bisect.bisect_left(rows, row)  # the first statement naming it at or below ``row``
                found = rows[k] if k < len(rows) else None
                if found is None:
                    break
                row = found + 1
            self._cache[key] = None if found is None else found + 1
        return self._cache[key]


class _Reader:
    def __init__(self, stage: Any, src: str, lines: _PrimLines) -> None:
        from pxr import UsdGeom

        self.stage = stage
        self.src = src
        self.lines = lines
        self.mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
        self.y_up = UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.y
        self.xform_cache = UsdGeom.XformCache()
        self._layer_lines: dict[str, _PrimLines] = {}

    def loc(self, prim_or_path: Any) -> SourceLocation:
        path = prim_or_path.GetPath() if hasattr(prim_or_path, "GetPath") else prim_or_path
        line = self.lines.line(path)
        if line is None and hasattr(prim_or_path, "GetPrimStack"):
            other = self._layer_loc(prim_or_path)
            if other is not None:
                return other
        return SourceLocation(self.src, line)

    def _layer_loc(self, prim: Any) -> SourceLocation | None:
        """The file and line of the layer that defines ``prim`` when that is not the file read (a payload,
        a reference, a sublayer)."""
        from pxr import Sdf

        stack = list(prim.GetPrimStack())
        spec = next((s for s in stack if s.specifier == Sdf.SpecifierDef), stack[0] if stack else None)
        if spec is None or spec.layer == self.stage.GetRootLayer():
            return None
        file = spec.layer.realPath or spec.layer.identifier
        if not file or not os.path.isfile(file):
            return None
        if file not in self._layer_lines:
            self._layer_lines[file] = _PrimLines(file)
        return SourceLocation(file, self._layer_lines[file].line(spec.path))

    def error(self, message: str, prim: Any) -> DescriptionError:
        return DescriptionError(message, location=self.loc(prim))

    # ---- typed access to morphkit: attributes ---------------------------------------------
    def custom(self, prim: Any, name: str, kind: type | tuple[type, ...]) -> Any:
        attr = prim.GetAttribute(_NS + name)
        if not attr or not attr.HasAuthoredValue():
            return None
        value = attr.Get()
        if kind is float:
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise self.error(f"{_NS}{name} of {prim.GetPath()} must be a finite number, got {value!r}", prim)
            return float(value)
        if kind is list:
            if isinstance(value, str) or not hasattr(value, "__iter__"):
                raise self.error(f"{_NS}{name} of {prim.GetPath()} must be a list of names, got {value!r}", prim)
            items = [str(v) for v in value]
            return items
        if not isinstance(value, str) or not value:
            raise self.error(f"{_NS}{name} of {prim.GetPath()} must be a non-empty string, got {value!r}", prim)
        return value

    def name_of(self, prim: Any) -> str:
        return self.custom(prim, "name", str) or prim.GetName()

    def has_name(self, prim: Any) -> bool:
        """Whether ``morphkit:name`` names the prim (such a name is kept as written)."""
        return self.custom(prim, "name", str) is not None

    # ---- scope ---------------------------------------------------------------------------
    def articulation(self) -> Scope:
        """The articulation root prim (or None), the prim naming the creature, its bodies and its joints."""
        return find_articulation(self.stage, self.src, self.error)

    # ---- geometry --------------------------------------------------------------------------
    def relative(self, prim: Any, ancestor: Any) -> tuple[np.ndarray, np.ndarray]:
        """Pose [7] (metres) and absolute scale [3] of ``prim`` in ``ancestor``'s frame."""
        from pxr import Gf

        matrix, _ = self.xform_cache.ComputeRelativeTransform(prim, ancestor)
        t = Gf.Transform(matrix)
        rot = _quat_xyzw(t.GetRotation().GetQuat())
        scale = np.abs(np.array(t.GetScale(), dtype=float))
        return _pose(np.array(t.GetTranslation(), dtype=float) * self.mpu, rot / np.linalg.norm(rot)), scale

    def shape(self, prim: Any, link_prim: Any) -> Shape | None:
        from pxr import UsdGeom

        pose, scale = self.relative(prim, link_prim)
        where = self.loc(prim)
        mpu = self.mpu

        def attr(name: str, default: float) -> float:
            a = prim.GetAttribute(name)
            value = a.Get() if a else None
            value = default if value is None else value
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise DescriptionError(
                    f"{prim.GetPath()}: {name} must be a finite number, got {value!r}", location=where
                )
            return float(value)

        def uniform(what: str) -> float:
            if scale.max() - scale.min() > 1e-9 * max(1.0, scale.max()):
                warnings.warn(
                    f"{where}: {what} {prim.GetPath()} has a non-uniform scale {scale.tolist()}; using the largest",
                    stacklevel=4,
                )
            return float(scale.max())

        if prim.IsA(UsdGeom.Cube):
            size = attr("size", 2.0) * mpu * scale
            return Shape(ShapeType.BOX, _transform(pose), size=tuple(float(v) for v in size))  # type: ignore[arg-type]
        if prim.IsA(UsdGeom.Sphere):
            return Shape(ShapeType.SPHERE, _transform(pose), radius=attr("radius", 1.0) * mpu * uniform("sphere"))
        if prim.IsA(UsdGeom.Capsule) or prim.IsA(UsdGeom.Cylinder):
            kind = ShapeType.CAPSULE if prim.IsA(UsdGeom.Capsule) else ShapeType.CYLINDER
            axis_attr = prim.GetAttribute("axis")
            axis = str(axis_attr.Get()) if axis_attr and axis_attr.Get() else "Z"
            if axis not in _AXIS_TOKENS:
                raise DescriptionError(f"{prim.GetPath()}: axis must be X, Y or Z, got {axis!r}", location=where)
            k = "XYZ".index(axis)
            perp = [scale[i] for i in range(3) if i != k]
            if abs(perp[0] - perp[1]) > 1e-9 * max(1.0, perp[0]):
                warnings.warn(
                    f"{where}: {prim.GetPath()} is scaled non-uniformly across its axis; using the larger radius",
                    stacklevel=3,
                )
            radius = float(attr("radius", 1.0) * mpu * max(perp))
            length = float(attr("height", 2.0) * mpu * scale[k])
            origin = _pose(pose[:3], quat_multiply(pose[3:], _Z_TO_AXIS[axis]))
            return Shape(kind, _transform(origin), radius=radius, length=length)
        if prim.IsA(UsdGeom.Mesh):
            raw = prim.GetAttribute(_NS + "meshPath")
            value = raw.Get() if raw and raw.HasAuthoredValue() else None
            if value is not None:
                text = getattr(value, "path", value)
                if not isinstance(text, str) or not text:
                    raise DescriptionError(
                        f"{_NS}meshPath of {prim.GetPath()} must be a file path, got {value!r}", location=where
                    )
                mesh = resolve_mesh_path(text, self.src, loc=where)
            else:
                mesh = f"{os.path.abspath(self.src)}#{prim.GetPath()}"
            scale_m = tuple(float(v) * mpu for v in scale)
            if min(abs(v) for v in scale_m) <= 0:  # negative mirrors (as the graph reads it); zero collapses
                raise DescriptionError(
                    f"{prim.GetPath()}: mesh scale must be non-zero on every axis, got {list(scale_m)}", location=where
                )
            return Shape(ShapeType.MESH, _transform(pose), mesh=mesh, scale=scale_m)  # type: ignore[arg-type]
        return None

    # ---- joints ------------------------------------------------------------------------------
    def target(self, joint: Any, rel: str) -> Any | None:
        targets = joint.GetRelationship(rel).GetTargets() if joint.GetRelationship(rel) else []
        if len(targets) > 1:
            raise self.error(f"joint {joint.GetPath()}: {rel} names {len(targets)} prims; expected one", joint)
        if not targets:
            return None
        prim = self.stage.GetPrimAtPath(targets[0])
        if not prim or not prim.IsValid():
            raise self.error(f"joint {joint.GetPath()}: {rel} target {targets[0]} does not exist", joint)
        return prim

    def local_pose(self, joint: Any, k: int) -> np.ndarray:
        pos = joint.GetAttribute(f"physics:localPos{k}").Get()
        rot = joint.GetAttribute(f"physics:localRot{k}").Get()
        p = np.zeros(3) if pos is None else np.array(pos, dtype=float) * self.mpu
        q = np.array([0.0, 0.0, 0.0, 1.0]) if rot is None else _quat_xyzw(rot)
        n = float(np.linalg.norm(q))
        if not np.isfinite(p).all() or not np.isfinite(q).all() or n < 1e-9:
            raise self.error(f"joint {joint.GetPath()}: localPos{k}/localRot{k} must be finite, non-zero", joint)
        return _pose(p, q / n)


def _joint_kind(prim: Any) -> str | None:
    from pxr import UsdPhysics

    for cls, kind in (
        (UsdPhysics.RevoluteJoint, "revolute"),
        (UsdPhysics.PrismaticJoint, "prismatic"),
        (UsdPhysics.SphericalJoint, "spherical"),
        (UsdPhysics.FixedJoint, "fixed"),
    ):
        if prim.IsA(cls):
            return kind
    return None


def read_usd(path: str | os.PathLike[str]) -> Morphology:
    """Read a UsdPhysics articulation from ``.usda``, ``.usdc`` or ``.usd`` (see the module docstring).

    Raises:
        DescriptionError: missing/unreadable/malformed file (with the line pxr reports for text
            syntax errors), no articulation, a joint without ``body1`` or with a missing target,
            an unsupported joint type, a bad ``morphkit:`` value.
        GraphError: the joints do not form one tree (cycle, two parents, disconnected link, ...).
    """
    src = os.fspath(path)
    stage = _open_stage(src)
    return _read_stage(_Reader(stage, src, _PrimLines(src)))


def _read_stage(r: _Reader) -> Morphology:

    scope = r.articulation()
    bodies, joint_prims = scope.bodies, scope.joints
    # The morphkit: creature attributes sit on the articulation root (the default prim without one).
    info = scope.root if scope.root is not None else scope.name_prim
    named = scope.name_prim
    name = (r.custom(info, "name", str) if info is not None else None) or (
        r.name_of(named) if named is not None else Path(r.src).stem
    )
    b = MorphologyBuilder(name, source=r.src)

    # Links: rigid bodies, then prims the joints name.
    link_prims: dict[Any, Any] = {p.GetPath(): p for p in bodies}
    parsed = []
    for jp in joint_prims:
        if jp.GetAttribute("physics:excludeFromArticulation").Get():
            warnings.warn(f"{r.loc(jp)}: skipping joint {jp.GetPath()} (excluded from the articulation)", stacklevel=3)
            continue
        kind = _joint_kind(jp)
        if kind is None:
            raise r.error(
                f"unsupported joint type {jp.GetTypeName() or 'PhysicsJoint'!r} at {jp.GetPath()}; expected one of: "
                "PhysicsRevoluteJoint, PhysicsPrismaticJoint, PhysicsSphericalJoint, PhysicsFixedJoint",
                jp,
            )
        body0 = r.target(jp, "physics:body0")
        body1 = r.target(jp, "physics:body1")
        if body1 is None:
            raise r.error(f"joint {jp.GetPath()} has no body1 (the child link)", jp)
        for body in (body0, body1):
            if body is not None and body.GetPath() not in link_prims:
                link_prims[body.GetPath()] = body
        parsed.append((jp, kind, body0, body1))
    if not link_prims:
        raise DescriptionError(
            "no articulation: no prim with PhysicsArticulationRootAPI, PhysicsRigidBodyAPI or physics joints",
            location=SourceLocation(r.src),
        )
    link_name = dict(
        zip(
            link_prims,
            unique_names(list(link_prims.values()), r.name_of, r.has_name, "link", r.src),
            strict=True,
        )
    )
    joint_name = dict(
        zip(
            (jp.GetPath() for jp, *_ in parsed),
            unique_names([jp for jp, *_ in parsed], r.name_of, r.has_name, "joint", r.src),
            strict=True,
        )
    )

    # Base type: morphkit:base wins; else a fixed joint to the world means a fixed base.
    base_attr = r.custom(info, "base", str) if info is not None else None
    base = parse_enum(BaseType, base_attr, what="base type", location=r.loc(info)) if base_attr is not None else None
    world_joints = [(jp, kind, b1) for jp, kind, b0, b1 in parsed if b0 is None]
    world_link: str | None = None
    if any(kind != "fixed" for _, kind, _ in world_joints):
        world_link = "world"
        while world_link in link_name.values():
            world_link = "_" + world_link
    if base is None:
        base = BaseType.FIXED if world_joints else BaseType.FLOATING
    b.set_base(base, location=r.loc(info) if info is not None else None)

    # morphkit frame of each body: at the pivot of its parent joint, Y-up stages turned Z-up at the root.
    body_to_morph: dict[Any, np.ndarray] = {p: _IDENTITY7.copy() for p in link_prims}
    for jp, kind, b0, b1 in parsed:
        if b0 is not None or kind != "fixed":
            p1 = r.local_pose(jp, 1)
            body_to_morph[b1.GetPath()] = _pose(-p1[:3], [0.0, 0.0, 0.0, 1.0])
    children = {b1.GetPath() for _, _, b0, b1 in parsed if b0 is not None}
    if r.y_up:
        for p in link_prims:
            if p not in children:
                body_to_morph[p] = _pose(quat_rotate(_Y_UP_TO_Z_UP, body_to_morph[p][:3]), _Y_UP_TO_Z_UP)

    link_paths = set(link_prims)

    if world_link is not None:
        b.add_link(world_link, location=SourceLocation(r.src))
    for p, prim in link_prims.items():
        _add_body_link(r, b, prim, link_name[p], body_to_morph[p], _descendants(prim, link_paths))
    if base == BaseType.FIXED and world_joints and world_link is None:
        b.set_root(link_name[world_joints[0][2].GetPath()], location=r.loc(world_joints[0][0]))

    for jp, kind, b0, b1 in parsed:
        if b0 is None and kind == "fixed" and world_link is None:
            continue  # the world anchor of a fixed base
        _add_joint(r, b, jp, joint_name[jp.GetPath()], kind, b0, b1, link_name, body_to_morph, world_link)

    if info is not None:
        _read_wheels(r, b, info)
    return complete_anatomy(b.build(), base_declared=base_attr is not None or bool(world_joints))


def _add_body_link(r: _Reader, b: MorphologyBuilder, prim: Any, name: str, T: np.ndarray, below: list[Any]) -> None:
    """A rigid body as the link ``name`` (its morphkit frame ``T`` in the body's [7]): its enabled colliders, or its
    visual gprims where it has none (the URDF and MJCF readers' rule), and the end-effectors under it."""
    from pxr import UsdGeom

    shapes, ees = [], []
    colliders = [d for d in below if d.IsA(UsdGeom.Gprim) and _is_collider(d)]
    for d in below:
        if d.GetAttribute(_NS + "endEffectorRole"):
            ees.append(d)
        elif d.IsA(UsdGeom.Gprim):
            if colliders and not _is_collider(d):
                continue
            s = r.shape(d, prim)
            if s is None:
                continue
            o = transform_multiply(T, s.origin.as_array())
            shapes.append(Shape(s.type, _transform(o), s.radius, s.length, s.size, s.mesh, s.scale))
    b.add_link(name, shapes=shapes, location=r.loc(prim))
    for d in ees:
        role = r.custom(d, "endEffectorRole", str)
        role_enum = parse_enum(EndEffectorRole, role, what="end-effector role", location=r.loc(d))
        pose, _ = r.relative(d, prim)
        offset = transform_multiply(T, pose)[:3]
        b.add_end_effector(r.name_of(d), name, offset=tuple(float(v) for v in offset), role=role_enum,
                           location=r.loc(d))


def _read_wheels(r: _Reader, b: MorphologyBuilder, info: Any) -> None:
    """The ``morphkit:wheel*`` attributes of the creature prim ``info``, where it has them."""
    wheel_joints = r.custom(info, "wheelJoints", list)
    if wheel_joints is None:
        return
    radius = r.custom(info, "wheelRadius", float)
    if radius is None:
        raise r.error(f"{_NS}wheelJoints needs {_NS}wheelRadius", info)
    kw: dict[str, Any] = {"steering": r.custom(info, "wheelSteering", list) or (),
                          "steered": r.custom(info, "wheelSteered", list) or ()}
    if (drive := r.custom(info, "wheelDrive", str)) is not None:
        kw["drive"] = drive
    if (radii := r.custom(info, "wheelSteeredRadii", list)) is not None:
        kw["steered_radii"] = [float(v) for v in radii]
    if (max_steer := r.custom(info, "wheelMaxSteer", float)) is not None:
        kw["max_steer"] = max_steer
    b.set_wheels(wheel_joints, radius, location=r.loc(info), **kw)


def _is_collider(prim: Any) -> bool:
    """``PhysicsCollisionAPI`` applied and not switched off (Isaac Sim marks visual meshes
    ``physics:collisionEnabled = false``)."""
    from pxr import UsdPhysics

    enabled = prim.GetAttribute("physics:collisionEnabled").Get()
    return bool(prim.HasAPI(UsdPhysics.CollisionAPI) and enabled is not False)


def _descendants(prim: Any, links: set[Any]) -> list[Any]:
    """Prims under ``prim`` that belong to it: not inside another link (nested rigid bodies)."""
    from pxr import Usd

    out = []
    # Through instance proxies: Isaac Sim instances its collision and visual prims.
    it = iter(Usd.PrimRange(prim, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    next(it)  # the link prim itself
    for d in it:
        if d.GetPath() in links:
            it.PruneChildren()
            continue
        out.append(d)
    return out


def _add_joint(
    r: _Reader,
    b: MorphologyBuilder,
    jp: Any,
    name: str,
    kind: str,
    b0: Any | None,
    b1: Any,
    link_name: dict[Any, str],
    body_to_morph: dict[Any, np.ndarray],
    world_link: str | None,
) -> None:
    where = r.loc(jp)
    declared = r.custom(jp, "jointType", str)
    jtype = parse_enum(JointType, declared, what="joint type", location=where) if declared else None
    pose0 = r.local_pose(jp, 0)
    pose1 = r.local_pose(jp, 1)
    if b0 is not None:
        parent_T = body_to_morph[b0.GetPath()]
    else:  # the world link: the stage's frame, turned Z-up like the roots
        parent_T = _pose([0.0, 0.0, 0.0], _Y_UP_TO_Z_UP) if r.y_up else _IDENTITY7
    # origin = T_parent_body0 · local0 · rot1⁻¹ (the child link frame at the pivot, oriented as body1).
    origin = transform_multiply(transform_multiply(parent_T, pose0), _pose([0, 0, 0], quat_conjugate(pose1[3:])))
    axis = (1.0, 0.0, 0.0)
    limit = None
    if kind in ("revolute", "prismatic"):
        token = str(jp.GetAttribute("physics:axis").Get() or "X")
        if token not in _AXIS_TOKENS:
            raise DescriptionError(f"joint {jp.GetPath()}: axis must be X, Y or Z, got {token!r}", location=where)
        axis = tuple(float(v) for v in quat_rotate(pose1[3:], _AXIS_TOKENS[token]))  # type: ignore[assignment]
        lo = jp.GetAttribute("physics:lowerLimit").Get()
        hi = jp.GetAttribute("physics:upperLimit").Get()
        lo = -math.inf if lo is None else float(lo)
        hi = math.inf if hi is None else float(hi)
        if math.isnan(lo) or math.isnan(hi):
            raise DescriptionError(f"joint {jp.GetPath()}: limit is NaN", location=where)
        finite = (math.isfinite(lo), math.isfinite(hi))
        if finite == (True, True):
            scale = math.radians(1.0) if kind == "revolute" else r.mpu
            velocity = r.custom(jp, "velocityLimit", float)
            effort = r.custom(jp, "effortLimit", float)
            limit = Limit(lo * scale, hi * scale, velocity, effort)
        elif finite != (False, False):
            raise DescriptionError(
                f"joint {jp.GetPath()}: only one limit is finite ({lo}, {hi}); give both or neither", location=where
            )
        if jtype is None:
            jtype = (
                JointType.PRISMATIC
                if kind == "prismatic"
                else (JointType.REVOLUTE if limit is not None else JointType.CONTINUOUS)
            )
    if jtype is None:
        jtype = JointType.SPHERICAL if kind == "spherical" else JointType.FIXED
    expected = {
        "revolute": (JointType.REVOLUTE, JointType.CONTINUOUS),
        "prismatic": (JointType.PRISMATIC,),
        "spherical": (JointType.SPHERICAL,),
        "fixed": (JointType.FIXED,),
    }[kind]
    if jtype not in expected:
        raise DescriptionError(
            f"joint {jp.GetPath()}: {_NS}jointType {jtype.name.lower()!r} does not fit a {jp.GetTypeName()}",
            location=where,
        )
    mimic = None
    target = r.custom(jp, "mimicJoint", str)
    if target is not None:
        multiplier = r.custom(jp, "mimicMultiplier", float)
        offset = r.custom(jp, "mimicOffset", float)
        mimic = Mimic(target, 1.0 if multiplier is None else multiplier, 0.0 if offset is None else offset)
    parent = link_name[b0.GetPath()] if b0 is not None else world_link
    b.add_joint(
        name,
        jtype,
        parent,  # type: ignore[arg-type]
        link_name[b1.GetPath()],
        origin=_transform(origin),
        axis=axis,
        limit=limit,
        mimic=mimic,
        location=where,
    )


def load_usd_mesh(ref: str) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of an inline USD mesh named ``"<usd file>#<prim path>"``.

    Polygons are fan-triangulated. Points are in the mesh prim's own frame (the shape's origin
    and scale apply on top, as for mesh files).

    Returns:
        Vertices [V, 3] (stage units) and triangle indices [F, 3].

    Raises:
        DescriptionError: the file or prim is missing, or the prim is not a mesh with faces.
    """
    from pxr import Sdf, UsdGeom

    file, _, prim_path = ref.partition("#")
    stage = _open_stage(file)
    where = SourceLocation(file)
    prim = stage.GetPrimAtPath(Sdf.Path(prim_path)) if Sdf.Path.IsValidPathString(prim_path) else None
    if not prim or not prim.IsA(UsdGeom.Mesh):
        raise DescriptionError(f"no mesh prim {prim_path!r} in {file}", location=where)
    mesh = UsdGeom.Mesh(prim)
    points = np.asarray(mesh.GetPointsAttr().Get() or [], dtype=float).reshape(-1, 3)
    counts = list(mesh.GetFaceVertexCountsAttr().Get() or [])
    indices = list(mesh.GetFaceVertexIndicesAttr().Get() or [])
    tris: list[tuple[int, int, int]] = []
    k = 0
    for c in counts:
        face = indices[k : k + c]
        k += c
        tris.extend((face[0], face[i], face[i + 1]) for i in range(1, len(face) - 1))
    faces = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    if len(faces) == 0 or k != len(indices) or (faces.size and (faces.min() < 0 or faces.max() >= len(points))):
        raise DescriptionError(f"mesh prim {prim_path!r} in {file} has no valid faces", location=where)
    return points, faces
