"""Which prims of a USD stage form the articulation morphkit reads, and their unique names (private).

Used by :mod:`morphkit.io.usd`; ``pxr`` is imported inside functions only.

- **Where joints sit does not matter.** The stage is walked composed (payloads, references,
  sublayers) and through instance proxies, so joints under their child link (Isaac Sim's URDF
  importer), in a ``joints`` scope (Isaac Lab, morphkit's writer), beside the links or inside
  instanced prims are all found; the tree comes from ``physics:body0``/``physics:body1`` alone.
- **Articulation root on a body.** When ``PhysicsArticulationRootAPI`` sits on a rigid body (the
  usual Isaac layout), the articulation is every body reached from it through joints, wherever
  those joints live. When it sits on an ancestor ``Xform``, it is the bodies under that prim and
  the joints under it or attached to them.
- **Nothing left out silently.** A joint of the stage that is not read (not connected to the
  articulation) and a rigid body under the model that no joint reaches are named in one warning.
- **Unique names.** A prim name the file repeats (the MuJoCo USD converter names every fixed
  joint ``PhysicsFixedJoint``) is prefixed with its ancestors' names, as few as make it unique
  (``FL_foot_PhysicsFixedJoint``), with one warning listing the renames.
"""

from __future__ import annotations

import warnings
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["Scope", "find_articulation", "unique_names"]

_SHOW = 6  # paths listed in a warning before "..."


class Scope:
    """What :func:`find_articulation` found.

    Attributes:
        root: The prim with ``PhysicsArticulationRootAPI`` (None: the whole stage is read); it
            carries the ``morphkit:`` creature attributes.
        name_prim: The prim whose name the creature takes (the model prim that holds a root body).
        bodies: Rigid bodies of the articulation (prims, stage order).
        joints: Joint prims of the articulation (stage order).
    """

    def __init__(self, root: Any | None, name_prim: Any | None, bodies: list[Any], joints: list[Any]) -> None:
        self.root = root
        self.name_prim = name_prim
        self.bodies = bodies
        self.joints = joints


def _targets(joint: Any) -> list[Any]:
    out = []
    for rel in ("physics:body0", "physics:body1"):
        r = joint.GetRelationship(rel)
        if r:
            out.extend(r.GetTargets())
    return out


def _listing(paths: Sequence[Any]) -> str:
    shown = ", ".join(str(p) for p in paths[:_SHOW])
    return shown + (f" and {len(paths) - _SHOW} more" if len(paths) > _SHOW else "")


def find_articulation(stage: Any, where: str, error: Callable[[str, Any], Exception]) -> Scope:
    """The articulation of ``stage`` (see the module docstring).

    Args:
        stage: An open ``Usd.Stage`` (payloads loaded).
        where: The file, for warnings.
        error: Builds the exception to raise for a message and the prim it is about.

    Raises:
        The exception ``error`` builds: several articulation roots.
    """
    from pxr import Usd, UsdPhysics

    prims = list(Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimDefaultPredicate)))
    roots = [p for p in prims if p.HasAPI(UsdPhysics.ArticulationRootAPI)]
    default = stage.GetDefaultPrim()
    if len(roots) > 1 and default:
        under = [r for r in roots if r.GetPath().HasPrefix(default.GetPath())]
        roots = under or roots
    if len(roots) > 1:
        paths = ", ".join(str(r.GetPath()) for r in roots)
        raise error(f"several articulation roots ({paths}); morphkit reads one creature per file", roots[1])
    joints_all = [p for p in prims if p.IsA(UsdPhysics.Joint)]
    bodies_all = [p for p in prims if p.HasAPI(UsdPhysics.RigidBodyAPI)]
    if not roots:
        return Scope(None, default or None, bodies_all, joints_all)
    root = roots[0]
    if root.HasAPI(UsdPhysics.RigidBodyAPI):
        scope = _from_root_body(root, default, bodies_all, joints_all)
        model = scope.name_prim.GetPath() if scope.name_prim is not None else root.GetPath()
        chosen = {p.GetPath() for p in scope.bodies}
        unreached = [p.GetPath() for p in bodies_all if p.GetPath().HasPrefix(model) and p.GetPath() not in chosen]
        if unreached:
            warnings.warn(
                f"{where}: {len(unreached)} rigid bod{'y' if len(unreached) == 1 else 'ies'} under {model} "
                f"that no joint connects to the articulation root {root.GetPath()}, left out: {_listing(unreached)}",
                stacklevel=5,
            )
    else:
        # The root on a joint (a fixed base) means its parent; on an Xform, everything under it.
        holder = root.GetParent() if root.IsA(UsdPhysics.Joint) and root.GetParent() else root
        path = holder.GetPath()
        bodies = [p for p in bodies_all if p.GetPath().HasPrefix(path)]
        body_paths = {p.GetPath() for p in bodies}
        joints = [jp for jp in joints_all if jp.GetPath().HasPrefix(path) or any(t in body_paths for t in _targets(jp))]
        scope = Scope(holder, holder, bodies, joints)
    read = {jp.GetPath() for jp in scope.joints}
    left = [jp.GetPath() for jp in joints_all if jp.GetPath() not in read]
    if left:
        warnings.warn(
            f"{where}: {len(left)} joint{'' if len(left) == 1 else 's'} not connected to the articulation "
            f"{scope.root.GetPath()}, left out: {_listing(left)}",
            stacklevel=5,
        )
    return scope


def _from_root_body(root: Any, default: Any, bodies_all: list[Any], joints_all: list[Any]) -> Scope:
    """The bodies reached from the root body through joints (either direction), and those joints."""
    from pxr import UsdPhysics

    edges: dict[Any, list[Any]] = {}
    for jp in joints_all:
        if jp.GetAttribute("physics:excludeFromArticulation").Get():
            continue  # a loop closure: read (and warned about) with the others, never the path to a body
        ts = _targets(jp)
        for a in ts:
            edges.setdefault(a, []).extend(t for t in ts if t != a)
    seen = {root.GetPath()}
    todo = deque([root.GetPath()])
    while todo:
        for n in edges.get(todo.popleft(), []):
            if n not in seen:
                seen.add(n)
                todo.append(n)
    bodies = [p for p in bodies_all if p.GetPath() in seen]
    joints = [jp for jp in joints_all if any(t in seen for t in _targets(jp))]
    # The creature is named by the model prim above the root body: the default prim (Isaac Sim, the MuJoCo
    # converter), else the root body's parent when that is no body itself.
    if default and root.GetPath().HasPrefix(default.GetPath()) and default.GetPath() != root.GetPath():
        name_prim = default
    else:
        parent = root.GetParent()
        pseudo = not parent or parent.IsPseudoRoot()
        name_prim = root if pseudo or parent.HasAPI(UsdPhysics.RigidBodyAPI) else parent
    return Scope(root, name_prim, bodies, joints)


def unique_names(
    prims: Sequence[Any], name_of: Callable[[Any], str], explicit: Callable[[Any], bool], what: str, where: str
) -> list[str]:
    """One name per prim, unique where the file repeats a prim name (see the module docstring).

    Args:
        prims: The prims (links or joints), in order.
        name_of: A prim's own name (``morphkit:name`` or the prim name).
        explicit: Whether the name was set by ``morphkit:name`` (kept as written: a repeat is an error later).
        what: "link" or "joint", for the warning.
        where: The file, for the warning.
    """
    names = [name_of(p) for p in prims]
    groups: dict[str, list[int]] = {}
    for i, n in enumerate(names):
        groups.setdefault(n, []).append(i)
    taken = set(names)
    renamed: list[tuple[str, Any]] = []
    for n, idx in groups.items():
        free = [i for i in idx if not explicit(prims[i])]
        if len(idx) < 2 or not free:
            continue
        comps = {i: [str(c) for c in prims[i].GetPath().GetPrefixes()[:-1]] for i in free}
        ancestors = {i: [p.rsplit("/", 1)[-1] for p in comps[i]] for i in free}
        depth = 1
        while True:
            cand = {i: "_".join([*ancestors[i][len(ancestors[i]) - depth :], n]) for i in free}
            values = list(cand.values())
            clash = len(set(values)) < len(values) or any(v in taken for v in values)
            if not clash or all(depth >= len(a) for a in ancestors.values()):
                break
            depth += 1
        for i in free:
            names[i] = cand[i]
            taken.add(cand[i])
            renamed.append((cand[i], prims[i].GetPath()))
    if renamed:
        listing = _listing([f"{n} ({p})" for n, p in renamed])
        warnings.warn(
            f"{where}: {what} names repeat in the file; each repeated one is prefixed with its parent prims' names: "
            f"{listing}",
            stacklevel=4,
        )
    return names
