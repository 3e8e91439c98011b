"""Motion of one skeleton convention re-expressed on another topology's skeleton (no retargeting involved).

NKN needs characters of one topology. A data set of another convention (another joint list) joins a
run when a *link map* says which of its links each template link is: a source link, or a point
``w`` of the way from link ``a`` to link ``b`` that turns with ``a`` (for a joint the source lacks).
Maps are YAML files in ``morphkit/retarget/data/skeleton_maps/`` (``name``, ``links``); one applies
when its links are exactly the template's and every source name is a link of the clip's skeleton.

The mapped skeleton keeps the template's topology and rest directions, with the source's bone
lengths, so its rest pose is the template's (a T-pose for CMU) whatever the source's rest pose is.
For template link $l$ with source frame $R_l(t)$ (world rotation of its source link), rest
$R_l^0$, and a constant rotation $A_l$ fitted (Kabsch) to carry the template's rest bone
directions from $l$ to its children onto the source's rest bones, the mapped link turns as
$W_l(t) = R_l(t)\\,(R_l^0)^{-1} A_l$; the child offsets are $A_l^{-1} b^0$ ($b^0$ the source's rest
bone vectors), so FK of the mapped skeleton puts every link exactly where the source's is, as long
as each mapped bone is rigid in the source (true for direct children and for interpolated points).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from typing import Any

import numpy as np
import torch
import yaml

import morphkit.torch as mt
from morphkit.errors import ConfigError, MotionFormatError
from morphkit.graph import JointType, Morphology
from morphkit.model import compile_model
from morphkit.motion import Motion
from morphkit.retarget.nkn.skeleton import with_offsets
from morphkit.rotations import matrix_from_quat, quat_between_vectors, quat_from_matrix, quat_multiply

__all__ = ["LinkMap", "find_link_map", "link_maps", "map_motion", "mapped_skeleton"]

Source = str | tuple[str, str, float]


@dataclass(frozen=True)
class LinkMap:
    """Template link → source link name, or ``(a, b, w)``: the point ``w`` of the way from ``a`` to ``b``."""

    name: str
    links: Mapping[str, Source]

    def applies(self, source: Morphology, template: Morphology) -> bool:
        """Whether this map takes ``source``'s links onto ``template``'s."""
        names = set(source.link_names)
        used = {s for v in self.links.values() for s in ((v,) if isinstance(v, str) else v[:2])}
        return set(self.links) == set(template.link_names) and used <= names


def link_maps() -> list[LinkMap]:
    """The link maps shipped in ``morphkit/retarget/data/skeleton_maps/``."""
    out = []
    folder = resources.files("morphkit.retarget").joinpath("data/skeleton_maps")
    for entry in sorted(folder.iterdir(), key=lambda e: e.name):
        if not entry.name.endswith(".yaml"):
            continue
        data = yaml.safe_load(entry.read_text()) or {}
        links: dict[str, Source] = {}
        for k, v in (data.get("links") or {}).items():
            links[str(k)] = str(v) if isinstance(v, str) else (str(v[0]), str(v[1]), float(v[2]))
        out.append(LinkMap(str(data.get("name", entry.name)), links))
    return out


def find_link_map(source: Morphology, template: Morphology) -> LinkMap | None:
    """The first shipped map from ``source``'s convention onto ``template``'s, if any."""
    return next((m for m in link_maps() if m.applies(source, template)), None)


def _kabsch(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Rotation matrix R minimising Σ |R a_i − b_i|² (rows of a, b: [N, 3])."""
    H = a.T @ b
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    return Vt.T @ np.diag([1.0, 1.0, d]) @ U.T


@dataclass(frozen=True)
class _Plan:
    skeleton: Morphology
    align: np.ndarray
    """[L, 4] A_l per template link (xyzw)."""


def _source_points(poses: np.ndarray, source: Morphology, spec: Source) -> tuple[np.ndarray, np.ndarray]:
    """Position [..., 3] and rotation [..., 4] of a mapped link from source link poses [..., Ls, 7]."""
    if isinstance(spec, str):
        T = poses[..., source.link_index(spec), :]
        return T[..., :3], T[..., 3:]
    a, b, w = spec
    Ta, Tb = poses[..., source.link_index(a), :], poses[..., source.link_index(b), :]
    return (1.0 - w) * Ta[..., :3] + w * Tb[..., :3], Ta[..., 3:]


def _plan(source: Morphology, template: Morphology, link_map: LinkMap, name: str) -> _Plan:
    if any(not np.allclose(j.origin.quat, (0, 0, 0, 1), atol=1e-9) for j in template.joints) or any(
            j.type != JointType.SPHERICAL for j in template.joints):
        raise ConfigError(f"skeleton maps need a template of ball joints with unrotated origins; {template.name!r} "
                          "is not one")
    rest = source.rest_link_poses()
    pos, rot = zip(*(_source_points(rest, source, link_map.links[n]) for n in template.link_names), strict=True)
    pos, rot = np.array(pos), np.array(rot)
    L = template.link_count
    parent = [-1] + [template.link_index(j.parent) for j in template.joints]
    children: dict[int, list[int]] = {i: [] for i in range(L)}
    for c in range(1, L):
        children[parent[c]].append(c)
    template_off = np.array([[0.0, 0.0, 0.0], *[j.origin.xyz for j in template.joints]])  # by child link
    align = np.zeros((L, 4))
    for lnk in range(L):
        kids = children[lnk]
        if kids:
            a = template_off[kids]
            b = pos[kids] - pos[lnk]
            if len(kids) == 1:
                q = quat_between_vectors(a[0] / np.linalg.norm(a[0]), b[0] / max(np.linalg.norm(b[0]), 1e-12))
            else:
                q = quat_from_matrix(_kabsch(a, b))
        else:  # a leaf: align its own incoming bone
            a, b = template_off[lnk], pos[lnk] - pos[parent[lnk]]
            q = quat_between_vectors(a / np.linalg.norm(a), b / max(np.linalg.norm(b), 1e-12))
        align[lnk] = q
    # Rest bone b0 of child c, in the frame of its parent's source-rest rotation: R_p^0⁻¹ b0, then A_p⁻¹.
    offsets = np.zeros((template.joint_count, 3))
    for j in range(template.joint_count):
        c, p = j + 1, parent[j + 1]
        b0 = pos[c] - pos[p]
        offsets[j] = matrix_from_quat(align[p]).T @ b0
    # The rest above is the source's rest in world axes; W_l(t) = R_l(t) (R_l^0)^{-1} A_l uses R^0 from rot.
    skeleton = with_offsets(template, offsets, name=name)
    return _Plan(skeleton, np.concatenate([align, rot], axis=1))


def mapped_skeleton(source: Morphology, template: Morphology, link_map: LinkMap, *, name: str) -> Morphology:
    """The template-topology skeleton with ``source``'s bone lengths (see the module docstring)."""
    return _plan(source, template, link_map, name).skeleton


def map_motion(motion: Motion, template: Morphology, link_map: LinkMap, *, skeleton_name: str,
               plan: Any = None) -> Motion:
    """``motion`` re-expressed on the mapped skeleton of ``template``'s topology (same link positions).

    Raises:
        MotionFormatError: the map does not fit the clip's skeleton.
    """
    source = motion.morphology
    if not link_map.applies(source, template):
        raise MotionFormatError(f"skeleton map {link_map.name!r} does not fit clip {motion.name!r}")
    plan = plan or _plan(source, template, link_map, skeleton_name)
    align, rest_rot = plan.align[:, :4], plan.align[:, 4:]
    with torch.no_grad():
        poses = mt.fk(compile_model(source), torch.tensor(motion.q, dtype=torch.float64)).numpy()  # [T, Ls, 7]
    pos, rot = zip(*(_source_points(poses, source, link_map.links[n]) for n in template.link_names), strict=True)
    pos, rot = np.stack(pos, axis=1), np.stack(rot, axis=1)  # [T, L, 3], [T, L, 4]
    inv_rest = rest_rot * np.array([-1.0, -1.0, -1.0, 1.0])
    W = quat_multiply(quat_multiply(rot, np.broadcast_to(inv_rest, rot.shape)), np.broadcast_to(align, rot.shape))
    sk = plan.skeleton
    q = np.zeros((motion.frame_count, sk.coordinate_count))
    q[:, :3] = pos[:, 0]
    q[:, 3:7] = W[:, 0]
    for j, start in zip(sk.joints, sk.joint_q_start[:-1], strict=True):
        c, p = sk.link_index(j.child), sk.link_index(j.parent)
        conj = W[:, p] * np.array([-1.0, -1.0, -1.0, 1.0])
        q[:, start : start + 4] = quat_multiply(conj, W[:, c])
    return Motion(sk, motion.fps, q, motion.name)
