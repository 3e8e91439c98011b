"""A pyrender scene of one creature: link geometry, end-effector markers, ground grid, lights, camera.

Geometry is built once per link, in the link frame; posing a frame only moves nodes
(:meth:`CreatureScene.set_link_poses`), so a video costs one scene build and one draw per frame.
Frames: world z up, x the creature's forward direction (see :mod:`morphkit.conventions`).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from morphkit.conventions import matrix_from_quat
from morphkit.errors import ConfigError, DescriptionError
from morphkit.graph import EndEffectorRole, Morphology, Shape, ShapeType
from morphkit.render._gl import import_pyrender

__all__ = [
    "CHAIN_PALETTE",
    "ROLE_COLORS",
    "TRUNK_COLOR",
    "CreatureScene",
    "RenderStyle",
    "check_size",
    "fit_distance",
    "link_colors",
    "look_at",
    "orbit_eye",
    "shape_trimesh",
]

CHAIN_PALETTE: tuple[tuple[float, float, float], ...] = (
    (0.122, 0.467, 0.706),  # blue
    (1.000, 0.498, 0.055),  # orange
    (0.173, 0.627, 0.173),  # green
    (0.839, 0.153, 0.157),  # red
    (0.580, 0.404, 0.741),  # purple
    (0.549, 0.337, 0.294),  # brown
    (0.890, 0.467, 0.761),  # pink
    (0.737, 0.741, 0.133),  # olive
)
"""Limb colours, one per root → end-effector chain, cycled (Tableau 10 without its grey and cyan)."""

TRUNK_COLOR = (0.50, 0.53, 0.58)
"""Links shared by several chains (body, pelvis, spine) and links on no chain."""

ROLE_COLORS: dict[EndEffectorRole, tuple[float, float, float]] = {
    EndEffectorRole.FOOT: (0.08, 0.08, 0.10),  # near black
    EndEffectorRole.HAND: (1.00, 0.84, 0.00),  # gold
    EndEffectorRole.HEAD: (0.00, 0.90, 0.90),  # cyan
    EndEffectorRole.TOOL: (1.00, 0.00, 1.00),  # magenta
}
"""End-effector marker colours by role (kept out of :data:`CHAIN_PALETTE` so markers stand out)."""


@dataclass(frozen=True)
class RenderStyle:
    """How a creature is drawn and framed."""

    shadows: bool = True
    """Soft shadows of the key light on the ground (pyrender's PCF-filtered shadow map); costs a pass."""
    ground: bool = True
    """Draw a ground plane with a grid under the creature."""
    markers: bool = True
    """Mark end-effectors by role (:data:`ROLE_COLORS`)."""
    background: tuple[float, float, float] = (1.0, 1.0, 1.0)
    """Background colour, RGB in [0, 1]."""
    yfov_deg: float = 40.0
    """Vertical field of view of the camera [deg]."""
    elevation_deg: float = 20.0
    """Camera elevation above the horizon [deg]."""
    azimuth_deg: float = 45.0
    """Camera azimuth about world z [deg]; 0 looks at the creature's front from +x, 90 from its left (+y)."""
    margin: float = 1.12
    """Framing margin: 1 touches the image border, larger leaves more room."""
    ambient: float = 0.3
    """Ambient light level in [0, 1]."""
    light_intensity: float = 2.5
    """Key (directional) light intensity."""


# ---- colours --------------------------------------------------------------------------------
def _chain_ends(m: Morphology) -> list[int]:
    """Link index at the end of each chain: end-effector links (deduplicated), else the leaf links."""
    ends: list[int] = []
    for ee in m.end_effectors:
        i = m.link_index(ee.link)
        if i not in ends:
            ends.append(i)
    if not ends:
        has_child = set(m.link_parent[1:])
        ends = [i for i in range(1, m.link_count) if i not in has_child]
    return ends


def link_colors(m: Morphology) -> np.ndarray:
    """Colour of every link, shape [link_count, 3], RGB in [0, 1].

    Each root → end-effector chain gets its own colour from :data:`CHAIN_PALETTE` (chains ending
    on the same link share one). A link on exactly one chain takes that chain's colour; a link
    shared by several chains (the trunk) takes :data:`TRUNK_COLOR`; a link on no chain takes its
    parent's colour. Creatures without end-effectors use their leaf links as chain ends.
    """
    members: list[set[int]] = [set() for _ in range(m.link_count)]
    for c, end in enumerate(_chain_ends(m)):
        i = end
        while i >= 0:
            members[i].add(c)
            i = m.link_parent[i]
    colors = np.empty((m.link_count, 3))
    for i in range(m.link_count):  # parents come before children
        if len(members[i]) == 1:
            colors[i] = CHAIN_PALETTE[next(iter(members[i])) % len(CHAIN_PALETTE)]
        elif not members[i] and i > 0:
            colors[i] = colors[m.link_parent[i]]
        else:
            colors[i] = TRUNK_COLOR
    return colors


# ---- geometry -------------------------------------------------------------------------------
def _transform_matrix(pose: np.ndarray) -> np.ndarray:
    """4x4 matrices [..., 4, 4] from ``[p, q]`` transforms [..., 7]."""
    pose = np.asarray(pose, dtype=float)
    out = np.zeros((*pose.shape[:-1], 4, 4))
    out[..., :3, :3] = matrix_from_quat(pose[..., 3:])
    out[..., :3, 3] = pose[..., :3]
    out[..., 3, 3] = 1.0
    return out


def _resolve_mesh(name: str, source: str | None) -> Path:
    base = Path(source).resolve().parent if source else Path.cwd()
    if name.startswith("file://"):
        name = name[len("file://") :]
    if name.startswith("package://"):
        package, _, rest = name[len("package://") :].partition("/")
        # ROS packages: look for a folder named after the package above the description, else beside it.
        for folder in (base, *base.parents):
            if folder.name == package and (folder / rest).is_file():
                return folder / rest
            if (folder / package / rest).is_file():
                return folder / package / rest
        return base / rest
    path = Path(name)
    return path if path.is_absolute() else base / path


def shape_trimesh(shape: Shape, *, source: str | None = None) -> Any:
    """The ``trimesh.Trimesh`` of one shape, in its link's frame (``shape.origin`` applied).

    Args:
        shape: The shape (capsule and cylinder along local z, box full extents, mesh scaled).
        source: Path of the description, to resolve relative mesh paths (and ``package://`` URIs).

    Raises:
        DescriptionError: A mesh file is missing or unreadable.
    """
    import trimesh

    if shape.type == ShapeType.SPHERE:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=shape.radius)
    elif shape.type == ShapeType.CAPSULE:
        mesh = trimesh.creation.capsule(height=shape.length, radius=shape.radius, count=[20, 12])
    elif shape.type == ShapeType.CYLINDER:
        mesh = trimesh.creation.cylinder(radius=shape.radius, height=shape.length, sections=24)
    elif shape.type == ShapeType.BOX:
        mesh = trimesh.creation.box(extents=shape.size)
    else:
        path = _resolve_mesh(str(shape.mesh), source)
        if not path.is_file():
            raise DescriptionError(f"mesh file not found: {path}")
        try:
            mesh = trimesh.load(path, force="mesh")
        except Exception as exc:  # trimesh raises assorted errors per format
            raise DescriptionError(f"cannot load mesh {shape.mesh!r} ({path}): {exc}") from None
        if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
            raise DescriptionError(f"mesh {shape.mesh!r} ({path}) holds no triangles")
        mesh = mesh.copy()
        mesh.apply_scale(np.asarray(shape.scale, dtype=float))
    mesh.apply_transform(_transform_matrix(shape.origin.as_array()))
    return mesh


def bare_feet(m: Morphology, link: int, shapes: Sequence[Any]) -> list[np.ndarray]:
    """Points [m, link frame] of the feet on a link, and of its joints to a foot's link, that its shapes (trimeshes,
    link frame) leave apart from the link's origin: the segment to the point is inside no shape's bounding box at a
    quarter, half or three quarters of its length (a shin whose mesh is missing, its foot ball left)."""
    boxes = [np.asarray(s.bounds) for s in shapes]

    def covered(p: np.ndarray) -> bool:
        return any(bool(np.all(p >= lo - 1e-9) and np.all(p <= hi + 1e-9)) for lo, hi in boxes)

    name = m.links[link].name
    foot_links = {e.link for e in m.end_effectors if e.role == EndEffectorRole.FOOT}
    feet = [np.asarray(e.offset, dtype=float) for e in m.end_effectors
            if e.link == name and e.role == EndEffectorRole.FOOT]
    feet += [np.asarray(j.origin.xyz, dtype=float) for j in m.joints if j.parent == name and j.child in foot_links]
    return [p for p in feet if not any(covered(f * p) for f in (0.25, 0.5, 0.75))]


def _joint_and_effector_points(m: Morphology, link: int) -> list[np.ndarray]:
    """Points [m, link frame] of a link's child joints and end-effectors."""
    name = m.links[link].name
    return ([np.asarray(j.origin.xyz, dtype=float) for j in m.joints if j.parent == name]
            + [np.asarray(e.offset, dtype=float) for e in m.end_effectors if e.link == name])


def _bone_trimeshes(targets: Sequence[np.ndarray], radius: float) -> list[Any]:
    """Capsules [link frame] from the link's origin to each of ``targets``."""
    import trimesh

    meshes = []
    for t in targets:
        length = float(np.linalg.norm(t))
        if length < 1e-9:
            continue
        bone = trimesh.creation.capsule(height=length, radius=radius, count=[12, 8])
        T = trimesh.geometry.align_vectors([0.0, 0.0, 1.0], t / length)
        T[:3, 3] = t / 2
        bone.apply_transform(T)
        meshes.append(bone)
    return meshes


# ---- camera ---------------------------------------------------------------------------------
def orbit_eye(target: np.ndarray, distance: float, azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """Camera position [m] on a sphere of ``distance`` around ``target`` at the given azimuth/elevation [deg]."""
    az, el = math.radians(azimuth_deg), math.radians(elevation_deg)
    direction = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    return np.asarray(target, dtype=float) + distance * direction


def look_at(eye: np.ndarray, target: np.ndarray, up: Sequence[float] = (0.0, 0.0, 1.0)) -> np.ndarray:
    """OpenGL camera pose (looks down its -z, y up), shape [4, 4], world from camera."""
    eye, target = np.asarray(eye, dtype=float), np.asarray(target, dtype=float)
    forward = target - eye
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(up, dtype=float))
    if np.linalg.norm(right) < 1e-9:  # looking straight down: any horizontal right vector
        right = np.array([0.0, -1.0, 0.0])
    right /= np.linalg.norm(right)
    pose = np.eye(4)
    pose[:3, 0], pose[:3, 1], pose[:3, 2], pose[:3, 3] = right, np.cross(right, forward), -forward, eye
    return pose


def fit_distance(
    points: np.ndarray, azimuth_deg: float, elevation_deg: float, *, yfov_deg: float, aspect: float, margin: float
) -> float:
    """Smallest camera distance at which every point lies inside the image.

    Args:
        points: Points relative to the look-at target, shape [N, 3] [m].
        azimuth_deg: Camera azimuth [deg] (see :func:`orbit_eye`).
        elevation_deg: Camera elevation [deg].
        yfov_deg: Vertical field of view [deg].
        aspect: Image width / height.
        margin: ≥ 1; scales the distance so points keep clear of the border.

    Returns:
        Distance from target to camera [m] (a pinhole projection of each point lands within
        ``1 / margin`` of the half-image).
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    eye_dir = orbit_eye(np.zeros(3), 1.0, azimuth_deg, elevation_deg)
    pose = look_at(eye_dir, np.zeros(3))
    right, up, back = pose[:3, 0], pose[:3, 1], pose[:3, 2]
    tan_y = math.tan(math.radians(yfov_deg) / 2) / margin
    tan_x = tan_y * aspect
    # depth of p from an eye at distance d along `back` is d - p·back; need |p·right| <= tan_x·depth.
    need = np.concatenate([np.abs(pts @ right) / tan_x + pts @ back, np.abs(pts @ up) / tan_y + pts @ back, [1e-3]])
    return float(need.max())


def check_size(size: Sequence[int]) -> tuple[int, int]:
    """``(width, height)`` [px] as ints, each within 8..8192.

    Raises:
        ConfigError: A side out of range or not two numbers.
    """
    try:
        w, h = (int(v) for v in size)
    except (TypeError, ValueError):
        raise ConfigError(f"image size must be (width, height), got {size!r}") from None
    if not (8 <= w <= 8192 and 8 <= h <= 8192):
        raise ConfigError(f"image size must be between 8 and 8192 pixels a side, got {w}x{h}")
    return w, h


# ---- the scene ------------------------------------------------------------------------------
def _nice_step(x: float) -> float:
    """The largest 1, 2, 5 × 10^k not above ``x`` (grid spacing)."""
    k = math.floor(math.log10(x))
    for f in (5.0, 2.0, 1.0):
        if f * 10**k <= x:
            return f * 10**k
    return 10**k


def _grid_texture(size: int = 64, line: int = 2) -> np.ndarray:
    """One grid cell as an RGB tile (repeated over the ground): light fill, darker border lines."""
    # Dim enough that the key light does not wash the floor out to the white background.
    tile = np.full((size, size, 3), 200, dtype=np.uint8)
    tile[:line] = tile[-line:] = tile[:, :line] = tile[:, -line:] = 160
    return tile


def _warn_unmeshed(unmeshed: Sequence[tuple[Any, list[str], bool]]) -> None:
    """One warning for the links drawn without some of their meshes: the link's own message where there is one,
    a summary where there are several (a URDF from another machine names hundreds of absent paths)."""
    if not unmeshed:
        return
    link, failed, kept = unmeshed[0]
    where = f"{link.location}: " if link.location is not None else ""
    if len(unmeshed) == 1:
        instead = "its other shapes" if kept else "a stand-in (bones to its joints)"
        warnings.warn(f"{where}link {link.name!r}: {'; '.join(failed)}; drawn with {instead}", stacklevel=3)
        return
    count = sum(len(f) for _, f, _ in unmeshed)
    stand_ins = sum(1 for *_, k in unmeshed if not k)
    instead = "their other shapes" + (f", {stand_ins} as stand-ins (bones to their joints)" if stand_ins else "")
    warnings.warn(f"{where}{count} meshes not found or unreadable on {len(unmeshed)} links, e.g. link {link.name!r}: "
                  f"{failed[0]}; drawn with {instead}", stacklevel=3)


class CreatureScene:
    """pyrender scene of one creature, posed by link transforms.

    Args:
        m: The creature.
        style: Drawing and framing options.
    """

    def __init__(self, m: Morphology, *, style: RenderStyle | None = None) -> None:
        import trimesh

        pyrender = import_pyrender()
        self._pyrender = pyrender
        self.morphology = m
        self.style = style or RenderStyle()
        amb = self.style.ambient
        self.scene = pyrender.Scene(bg_color=[*self.style.background, 1.0], ambient_light=[amb, amb, amb])
        length = m.characteristic_length
        colors = link_colors(m)

        # Links: one node and one primitive per link (its shapes merged, split at sharp edges so
        # boxes and cylinder rims shade flat while capsules stay smooth); per-frame cost in pyrender
        # grows with the primitive count. Local AABB corners are kept for framing.
        self._link_nodes: list[tuple[int, Any]] = []
        corners: list[tuple[int, np.ndarray]] = []
        unmeshed: list[tuple[Any, list[str], bool]] = []
        for i, link in enumerate(m.links):
            meshes, failed = [], []
            for shape in link.shapes:
                try:
                    meshes.append(shape_trimesh(shape, source=m.source))
                except DescriptionError as exc:  # a missing or unreadable mesh: draw what there is, say so
                    failed.append(exc.message)
            if failed:
                unmeshed.append((link, failed, bool(meshes)))
            if not meshes:  # a stand-in (BVH skeletons): a ball at the origin, bones to its joints and points
                meshes = [trimesh.creation.icosphere(subdivisions=1, radius=0.0325 * length),
                          *_bone_trimeshes(_joint_and_effector_points(m, i), 0.025 * length)]
            else:
                # a description read without its meshes (MuJoCo Menagerie's Spot keeps only the foot ball of a
                # shin that was a mesh) would show feet apart from their legs: a bone joins them
                meshes += _bone_trimeshes(bare_feet(m, i, meshes), 0.025 * length)
            merged = trimesh.util.concatenate([mesh.smooth_shaded for mesh in meshes])
            material = pyrender.MetallicRoughnessMaterial(
                baseColorFactor=[*colors[i], 1.0], metallicFactor=0.0, roughnessFactor=0.65
            )
            mesh = pyrender.Mesh.from_trimesh(merged, material=material, smooth=True)
            node = self.scene.add(mesh, name=f"link:{link.name}")
            self._link_nodes.append((i, node))
            corners.append((i, trimesh.bounds.corners(merged.bounds)))
        _warn_unmeshed(unmeshed)

        # End-effector markers: small spheres (a cube for tools) coloured by role, drawn on top of
        # the geometry so a foot inside its foot sphere or a head point inside the skull still shows.
        # Sized from the creature's overall extent, so they come out a few pixels wide at any scale.
        self._marker_nodes: list[tuple[int, np.ndarray, Any]] = []
        if self.style.markers and m.end_effectors:
            rest = m.rest_points()
            r = 0.015 * max(float(np.linalg.norm(rest.max(axis=0) - rest.min(axis=0))), 1e-3)
            for ee in m.end_effectors:
                marker = (
                    trimesh.creation.box(extents=[1.6 * r] * 3)
                    if ee.role == EndEffectorRole.TOOL
                    else trimesh.creation.icosphere(subdivisions=2, radius=r)
                )
                material = pyrender.MetallicRoughnessMaterial(
                    baseColorFactor=[*ROLE_COLORS[ee.role], 1.0], metallicFactor=0.0, roughnessFactor=0.4
                )
                mesh = pyrender.Mesh.from_trimesh(
                    marker, material=material, smooth=ee.role != EndEffectorRole.TOOL, always_on_top=True
                )
                node = self.scene.add(mesh, name=f"ee:{ee.name}")
                offset = np.asarray(ee.offset, dtype=float)
                self._marker_nodes.append((m.link_index(ee.link), offset, node))
                corners.append((m.link_index(ee.link), offset + np.array([[-r, -r, -r], [r, r, r]]).repeat(4, 0)))

        # Framing points: per link, the corners of its geometry's box (cheap and conservative).
        self._corner_link = np.concatenate([np.full(len(c), i) for i, c in corners]) if corners else np.zeros(0, int)
        self._corner_local = np.concatenate([c for _, c in corners]) if corners else np.zeros((0, 3))

        self._ground_node: Any = None
        self._grid_step = _nice_step(max(length, 1e-3) / 3)
        self._light_node = self.scene.add(
            pyrender.DirectionalLight(color=np.ones(3), intensity=self.style.light_intensity), name="key"
        )
        # A weak fill light on the other side keeps shadowed sides readable; it casts no shadow
        # (pyrender only shadows directional lights when asked) so it costs no extra pass.
        self._fill_node = self.scene.add(
            pyrender.SpotLight(color=np.ones(3), intensity=0.0, innerConeAngle=0.6, outerConeAngle=1.2), name="fill"
        )
        self.camera = pyrender.PerspectiveCamera(yfov=math.radians(self.style.yfov_deg), aspectRatio=4 / 3)
        self._camera_node = self.scene.add(self.camera, name="camera")

    # ---- posing ---------------------------------------------------------------------------
    def set_link_poses(self, poses: np.ndarray) -> None:
        """Move every link (and marker) to ``poses``, shape [link_count, 7], ``T_world_link``."""
        mats = _transform_matrix(poses)
        for i, node in self._link_nodes:
            self.scene.set_pose(node, mats[i])
        for i, offset, node in self._marker_nodes:
            T = mats[i].copy()
            T[:3, 3] = mats[i, :3, :3] @ offset + mats[i, :3, 3]
            self.scene.set_pose(node, T)

    def world_points(self, poses: np.ndarray) -> np.ndarray:
        """Framing points (corners of each link's geometry box) at ``poses`` [..., link_count, 7] -> [..., N, 3]."""
        poses = np.asarray(poses, dtype=float)
        sel = poses[..., self._corner_link, :]
        rot = matrix_from_quat(sel[..., 3:])
        return np.einsum("...ij,...j->...i", rot, self._corner_local) + sel[..., :3]

    # ---- ground, lights, camera -----------------------------------------------------------
    def place_ground(self, center_xy: Sequence[float], z: float, radius: float, *, slack: float = 0.0) -> None:
        """Put the ground at height ``z``: a disc of ``radius`` [m] near ``center_xy`` with a grid of
        :attr:`grid_step` cells, fading out over its outer quarter.

        The disc is snapped to whole grid cells, so the grid stays fixed in the world. It stays where
        it is while ``center_xy`` is within ``slack`` [m] of its centre, so a disc following a walking
        creature moves now and then rather than stepping under it every few frames. A bounded disc
        rather than an endless plane keeps the shadow map sharp and, since shading a floor pixel with
        soft shadows is the dearest thing in a frame under a software rasteriser, the frame rate up.
        """
        if not self.style.ground:
            return
        step = self._grid_step
        cells = max(2, math.ceil(radius / step))
        want = np.round(np.asarray(center_xy[:2], dtype=float) / step) * step
        if self._ground_node is None or self._ground_cells != cells:
            if self._ground_node is not None:
                self.scene.remove_node(self._ground_node)
            self._ground_node = self.scene.add(self._ground_mesh(cells * step), name="ground")
            self._ground_cells = cells
        else:
            here = self._ground_node.matrix[:2, 3]
            if np.linalg.norm(np.asarray(center_xy[:2], dtype=float) - here) <= slack:
                want = here
        T = np.eye(4)
        T[:2, 3] = want
        T[2, 3] = z - 1e-4 * step  # a hair below contact points so feet do not z-fight with the floor
        self.scene.set_pose(self._ground_node, T)

    def _ground_mesh(self, radius: float) -> Any:
        pyrender = self._pyrender
        n = 72
        angles = np.linspace(0.0, 2 * np.pi, n, endpoint=False)
        ring = np.stack([np.cos(angles), np.sin(angles), np.zeros(n)], axis=1)
        positions = np.concatenate([np.zeros((1, 3)), 0.75 * radius * ring, radius * ring]).astype(np.float32)
        alpha = np.concatenate([np.ones(1 + n), np.zeros(n)])
        colors = np.concatenate([np.ones((2 * n + 1, 3)), alpha[:, None]], axis=1).astype(np.float32)
        i = np.arange(n)
        j = (i + 1) % n
        faces = np.concatenate(
            [
                np.stack([np.zeros(n, int), 1 + i, 1 + j], axis=1),  # inner fan
                np.stack([1 + i, 1 + n + i, 1 + n + j], axis=1),  # fading rim
                np.stack([1 + i, 1 + n + j, 1 + j], axis=1),
            ]
        ).astype(np.uint32)
        material = pyrender.MetallicRoughnessMaterial(
            baseColorTexture=pyrender.Texture(source=_grid_texture(), source_channels="RGB"),
            metallicFactor=0.0,
            roughnessFactor=0.9,
            alphaMode="BLEND",
        )
        prim = pyrender.Primitive(
            positions=positions,
            normals=np.tile(np.array([0, 0, 1], dtype=np.float32), (len(positions), 1)),
            texcoord_0=(positions[:, :2] / self._grid_step).astype(np.float32),
            color_0=colors,
            indices=faces,
            material=material,
        )
        return pyrender.Mesh(primitives=[prim], name="ground")

    def ground_radius(self, reach: float, height: float) -> float:
        """Ground disc radius [m] for a creature reaching ``reach`` [m] sideways from the camera
        target and ``height`` [m] tall: room for its shadow (key light 60° up) before the fade."""
        return max(1.15 * reach + 0.6 * height, 2.0 * self._grid_step)

    @property
    def grid_step(self) -> float:
        """Ground grid spacing [m]."""
        return self._grid_step

    def set_camera(self, target: np.ndarray, distance: float, azimuth_deg: float, aspect: float) -> None:
        """Orbit camera at ``distance`` [m] from ``target`` [m]; the lights keep their place relative to it."""
        style = self.style
        eye = orbit_eye(target, distance, azimuth_deg, style.elevation_deg)
        self.camera.aspectRatio = aspect
        self.camera.znear = max(0.02 * distance, 1e-3)
        self.camera.zfar = 20.0 * distance + 10.0 * self._grid_step
        self.scene.set_pose(self._camera_node, look_at(eye, target))
        # Key light from above, front-left of the camera: like a studio turntable, the lights turn with the view.
        key_dir = orbit_eye(np.zeros(3), 1.0, azimuth_deg + 35.0, 60.0)
        self.scene.set_pose(self._light_node, look_at(key_dir, np.zeros(3)))
        fill_eye = orbit_eye(target, 2.0 * distance, azimuth_deg - 70.0, 25.0)
        self.scene.set_pose(self._fill_node, look_at(fill_eye, target))
        self._fill_node.light.intensity = 0.8 * style.light_intensity * (2.0 * distance) ** 2

    def render(self, renderer: Any) -> np.ndarray:
        """Draw with ``renderer`` (a ``pyrender.OffscreenRenderer``); returns RGB uint8 [H, W, 3]."""
        flags = self._pyrender.RenderFlags.SHADOWS_DIRECTIONAL if self.style.shadows else 0
        color, _ = renderer.render(self.scene, flags=flags)
        return np.ascontiguousarray(color[..., :3])
