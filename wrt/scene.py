"""Scene: the host-side (numpy) description of what is rendered, independent of USD.

A :class:`Scene` holds triangle meshes already in world space, the cameras and lights of the stage
and a few stage-level settings. ``wrt.load_usd`` fills one from a USD stage; :meth:`Scene.from_triangles`
wraps raw arrays. Everything downstream (BVH, trace, render) reads only this class.

Triangle order (the meaning of ``Hits.prim``): meshes in the order of :attr:`Scene.meshes` (for USD stages,
the pre-order traversal of the stage), and inside each mesh the triangles of face 0 first, then face 1, and
so on, each face fan-triangulated around its first vertex, so face ``f`` with ``n`` vertices gives
``n - 2`` consecutive triangles.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from .camera import Camera


@wp.struct
class DeviceScene:
    """Per-triangle shading data on the device, indexed by triangle id (``prim``)."""

    points: wp.array[wp.vec3]  # world-space vertex positions
    indices: wp.array2d[wp.int32]  # (T, 3) triangle vertex indices
    normals: wp.array2d[wp.vec3]  # (T, 3) shading normal per corner; zero when the mesh has none
    colors: wp.array2d[wp.vec3]  # (T, 3) linear albedo per corner
    num_prims: int  # number of triangles


@dataclasses.dataclass
class Mesh:
    """One triangle mesh in world space.

    Attributes:
        path: prim path of the source ``UsdGeom.Mesh`` (or a made-up name).
        points: ``(V, 3)`` float32, world space.
        indices: ``(T, 3)`` int32 rows into ``points``. Winding is corrected for ``orientation = leftHanded``
            and for mirroring transforms, so ``cross(p1 - p0, p2 - p0)`` always points to the front side.
        face_ids: ``(T,)`` int32, source face of each triangle.
        normals: ``(T, 3, 3)`` float32 unit world-space shading normal at each triangle corner, or ``None``
            when the mesh authors none (then the face normal is used).
        colors: ``(T, 3, 3)`` float32 linear displayColor at each triangle corner, or ``None``.
        double_sided: the mesh's ``doubleSided`` attribute: when False, camera rays that reach a triangle from its
            back pass through it (back-face culling); bounce and shadow rays still meet it.
        uvs: ``(T, 3, 2)`` float32 texture coordinates at each triangle corner, or ``None``.
        material_ids: ``(T,)`` int32 index into :attr:`Scene.materials` of each triangle (-1: the default material),
            or ``None`` for the default material everywhere.
    """

    path: str
    points: np.ndarray
    indices: np.ndarray
    face_ids: np.ndarray
    normals: np.ndarray | None = None
    colors: np.ndarray | None = None
    double_sided: bool = False
    uvs: np.ndarray | None = None
    material_ids: np.ndarray | None = None

    def __post_init__(self):
        self.points = np.ascontiguousarray(self.points, dtype=np.float32).reshape(-1, 3)
        self.indices = np.ascontiguousarray(self.indices, dtype=np.int32).reshape(-1, 3)
        self.face_ids = np.ascontiguousarray(self.face_ids, dtype=np.int32).reshape(-1)
        if self.normals is not None:
            self.normals = np.ascontiguousarray(self.normals, dtype=np.float32).reshape(-1, 3, 3)
        if self.colors is not None:
            self.colors = np.ascontiguousarray(self.colors, dtype=np.float32).reshape(-1, 3, 3)
        if self.uvs is not None:
            self.uvs = np.ascontiguousarray(self.uvs, dtype=np.float32).reshape(-1, 3, 2)
        if self.material_ids is not None:
            self.material_ids = np.ascontiguousarray(self.material_ids, dtype=np.int32).reshape(-1)


@dataclasses.dataclass
class DistantLight:
    """A light at infinity, as ``UsdLux.DistantLight`` (the other light types live in :mod:`wrt.lights`).

    Attributes:
        direction: ``(3,)`` unit world-space direction the light travels in (the light's -Z axis).
        color: ``(3,)`` linear RGB, ``intensity * 2**exposure * color``. With ``angle = 0`` or ``normalize`` on it is
            the illuminance at normal incidence; otherwise it is the radiance of the sun disc (see :mod:`wrt.lights`).
        path: prim path of the source light, if any.
        angle: angular diameter in degrees; 0 makes a delta light.
        normalize: ``inputs:normalize``.
    """

    direction: np.ndarray
    color: np.ndarray
    path: str = ""
    angle: float = 0.0
    normalize: bool = False

    def __post_init__(self):
        self.direction = np.asarray(self.direction, np.float64).reshape(3)
        self.color = np.asarray(self.color, np.float32).reshape(3)

    @property
    def solid_angle_factor(self) -> float:
        """``pi sin^2(angle / 2)``: illuminance at normal incidence per unit radiance of the sun disc."""
        half = min(math.radians(max(self.angle, 0.0)) / 2.0, math.pi / 2.0)
        return math.pi * math.sin(half) ** 2

    @property
    def illuminance(self) -> np.ndarray:
        """``(3,)`` illuminance ``E`` at normal incidence."""
        if self.normalize or self.angle <= 0.0:
            return self.color.copy()
        return (self.color * self.solid_angle_factor).astype(np.float32)


@dataclasses.dataclass
class Scene:
    """Everything that is rendered, as host arrays.

    Attributes:
        meshes: triangle meshes in world space; their order defines triangle ids (see module docstring).
        cameras: prim path -> :class:`wrt.Camera`, in stage order.
        lights: the stage's lights: :class:`DistantLight` and the classes of :mod:`wrt.lights`.
        materials: :class:`wrt.materials.Material` list that ``Mesh.material_ids`` index.
        textures: ``(H, W, 4)`` float32 linear RGBA images that material textures index.
        up_axis: ``"Y"`` or ``"Z"``, the stage's upAxis.
        meters_per_unit: the stage's metersPerUnit.
        source: the file the scene was read from, if any.
    """

    meshes: list[Mesh] = dataclasses.field(default_factory=list)
    cameras: dict[str, Camera] = dataclasses.field(default_factory=dict)
    lights: list = dataclasses.field(default_factory=list)
    materials: list = dataclasses.field(default_factory=list)
    textures: list = dataclasses.field(default_factory=list)
    up_axis: str = "Y"
    meters_per_unit: float = 0.01
    source: str | None = None

    def __post_init__(self):
        self._cache = {}  # device-side objects (BVHs, wp.Mesh) keyed by (kind, device, options)

    @classmethod
    def from_triangles(cls, points, indices, *, name: str = "/triangles") -> Scene:
        """Wraps raw triangle arrays, no USD involved.

        Args:
            points: ``(V, 3)`` float, world space.
            indices: ``(T, 3)`` or ``(3T,)`` int rows into ``points``.
            name: path reported for the single mesh.
        """
        points = np.asarray(points, dtype=np.float32).reshape(-1, 3)
        indices = np.asarray(indices, dtype=np.int32).reshape(-1, 3)
        if indices.size and (indices.min() < 0 or indices.max() >= len(points)):
            from .errors import SceneError

            raise SceneError(f"triangle indices must lie in [0, {len(points)})", prim=name)
        mesh = Mesh(name, points, indices, np.arange(len(indices), dtype=np.int32), double_sided=True)
        return cls(meshes=[mesh])

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """All triangles in world space, in the documented order.

        Returns:
            ``points`` ``(V, 3)`` float32 and ``indices`` ``(T, 3)`` int32; row ``k`` of ``indices`` is prim ``k``.
        """
        key = ("triangles",)
        if key not in self._cache:
            offsets = np.cumsum([0] + [len(m.points) for m in self.meshes])
            points = [m.points for m in self.meshes] or [np.zeros((0, 3), np.float32)]
            indices = [m.indices + o for m, o in zip(self.meshes, offsets)] or [np.zeros((0, 3), np.int32)]
            self._cache[key] = (
                np.ascontiguousarray(np.concatenate(points), dtype=np.float32),
                np.ascontiguousarray(np.concatenate(indices), dtype=np.int32),
            )
        return self._cache[key]

    def corner_attributes(self) -> tuple[np.ndarray, np.ndarray]:
        """Per-corner shading normals and colours for every triangle, in triangle order.

        Returns:
            ``normals`` ``(T, 3, 3)`` float32 (zero rows where a mesh has no normals: shade with the face normal)
            and ``colors`` ``(T, 3, 3)`` float32 (neutral grey where a mesh has no displayColor).
        """
        key = ("corners",)
        if key not in self._cache:
            normals, colors = [], []
            for m in self.meshes:
                n = len(m.indices)
                normals.append(m.normals if m.normals is not None else np.zeros((n, 3, 3), np.float32))
                colors.append(m.colors if m.colors is not None else np.full((n, 3, 3), 0.5, np.float32))
            empty = np.zeros((0, 3, 3), np.float32)
            self._cache[key] = (np.concatenate(normals or [empty]), np.concatenate(colors or [empty]))
        return self._cache[key]

    def triangle_materials(self) -> np.ndarray:
        """``(T,)`` int32 material of every triangle as a device material index: 0 for the default material,
        ``k + 1`` for ``materials[k]``."""
        key = ("triangle_materials",)
        if key not in self._cache:
            parts = [
                (m.material_ids + 1 if m.material_ids is not None else np.zeros(len(m.indices), np.int32))
                for m in self.meshes
            ]
            ids = np.concatenate(parts or [np.zeros(0, np.int32)]).astype(np.int32)
            self._cache[key] = np.where((ids >= 0) & (ids <= len(self.materials)), ids, 0).astype(np.int32)
        return self._cache[key]

    def triangle_double_sided(self) -> np.ndarray:
        """``(T,)`` bool: each triangle's mesh is double-sided."""
        parts = [np.full(len(m.indices), bool(m.double_sided)) for m in self.meshes]
        return np.concatenate(parts or [np.zeros(0, bool)])

    def corner_uvs(self) -> np.ndarray:
        """``(T, 3, 2)`` float32 texture coordinates per triangle corner (zero where a mesh has none)."""
        key = ("corner_uvs",)
        if key not in self._cache:
            parts = [m.uvs if m.uvs is not None else np.zeros((len(m.indices), 3, 2), np.float32) for m in self.meshes]
            self._cache[key] = np.concatenate(parts or [np.zeros((0, 3, 2), np.float32)]).astype(np.float32)
        return self._cache[key]

    def to_device(self, device) -> DeviceScene:
        """The :class:`DeviceScene` on ``device``, uploaded on first use and cached."""
        device = wp.get_device(device)
        key = ("device_scene", str(device))
        if key not in self._cache:
            points, indices = self.triangles()
            normals, colors = self.corner_attributes()
            n = len(indices)
            if n == 0:  # keep arrays non-empty so kernels can bind them; num_prims = 0 marks the scene empty
                points, indices = np.zeros((1, 3), np.float32), np.zeros((1, 3), np.int32)
                normals = colors = np.zeros((1, 3, 3), np.float32)
            s = DeviceScene()
            s.points = wp.array(points, dtype=wp.vec3, device=device)
            s.indices = wp.array(indices, dtype=wp.int32, device=device)
            s.normals = wp.array(normals, dtype=wp.vec3, device=device)
            s.colors = wp.array(colors, dtype=wp.vec3, device=device)
            s.num_prims = n
            self._cache[key] = s
        return self._cache[key]

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """World-space axis-aligned bounds ``(lower, upper)`` of all points; unit cube around 0 when empty."""
        points, indices = self.triangles()
        if len(indices) == 0:
            return np.full(3, -1.0, np.float32), np.full(3, 1.0, np.float32)
        used = points[indices.reshape(-1)]
        return used.min(axis=0), used.max(axis=0)

    def stats(self) -> dict:
        """Counts describing the scene: ``meshes``, ``points``, ``rendered_triangles``, ``unique_triangles``,
        ``cameras`` and ``lights``. Without instancing, rendered and unique triangle counts are equal."""
        points, indices = self.triangles()
        return {
            "meshes": len(self.meshes),
            "points": int(len(points)),
            "rendered_triangles": int(len(indices)),
            "unique_triangles": int(len(indices)),
            "cameras": len(self.cameras),
            "lights": len(self.lights),
        }
