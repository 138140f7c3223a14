"""USD's ``UsdShade`` and ``UsdGeom.PrimvarsAPI`` as an oracle for the material and colours of every triangle that
``wrt.load_usd`` draws.

For each rendered triangle and analytic shape (instances expanded) :func:`compare` finds the prim that draws it and
its face (:meth:`wrt.Scene.hit_prims`: a native instance's part by its instance-proxy path, a PointInstancer's
prototype part by its own path) and checks:

- its material against ``UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial`` under the rule the README gives
  (``full``, which falls back to all-purpose bindings; where that binds nothing or an MDL look, a ``preview`` binding
  to a UsdPreviewSurface), a ``materialBind`` subset's (the subset prim's own ``ComputeBoundMaterial``) on its faces;
- where that material reads a colour primvar (the default material ``displayColor``, ``/Looks/Tint`` ``tint``),
  the triangle's corner colours against ``FindPrimvarWithInheritance`` of that primvar on the prim (every
  interpolation and indices), the reader's fallback (or none) where the prim has none;
- on the default material, its ``displayOpacity`` likewise (1 where none).
"""

from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdShade

READABLE_IDS = ("UsdPreviewSurface",)
MATERIAL_PRIMVARS = {"Tint": ("tint", (0.1, 0.2, 0.3))}  # material name -> (colour primvar it reads, fallback)


def surface_id(material: UsdShade.Material) -> str | None:
    """The ``info:id`` of the shader ``material``'s universal surface output leads to (None for MDL looks)."""
    for output in material.GetSurfaceOutputs():
        for attr in output.GetValueProducingAttributes():
            shader = UsdShade.Shader(attr.GetPrim())
            if shader and shader.GetShaderId():
                return str(shader.GetShaderId())
    return None


def bound(prim: Usd.Prim) -> UsdShade.Material | None:
    """The material wrt's rule binds to ``prim`` (README, Materials): ``full`` (all-purpose as its fallback), else
    where that is nothing or unreadable, a ``preview`` binding to a UsdPreviewSurface."""
    api = UsdShade.MaterialBindingAPI(prim)
    full = api.ComputeBoundMaterial(UsdShade.Tokens.full)[0]
    if full and surface_id(full) in READABLE_IDS:
        return full
    preview = api.ComputeBoundMaterial(UsdShade.Tokens.preview)[0]
    if preview and surface_id(preview) in READABLE_IDS:
        return preview
    return full if full else None


def drawn_as(material: UsdShade.Material | None) -> UsdShade.Material | None:
    """``material`` as wrt draws it: an MDL look without a constant base colour is the default material (README)."""
    return material if material and surface_id(material) in READABLE_IDS else None


def face_material(prim: Usd.Prim, face: int, cache: dict | None = None) -> UsdShade.Material | None:
    """The material of face ``face`` of mesh ``prim``: that of the last ``materialBind`` face subset holding it that
    binds one, else the mesh's. ``cache``: each mesh's bindings kept by path."""
    key = prim.GetPath()
    if cache is None or key not in cache:
        subsets = []
        for subset in UsdShade.MaterialBindingAPI(prim).GetMaterialBindSubsets():
            if subset.GetElementTypeAttr().Get() == UsdGeom.Tokens.face:
                subsets.append((set(subset.GetIndicesAttr().Get() or []), bound(subset.GetPrim())))
        facts = (bound(prim), subsets)
        if cache is None:
            return _face_material(facts, face)
        cache[key] = facts
    return _face_material(cache[key], face)


def _face_material(facts, face: int):
    mesh_material, subsets = facts
    found = None
    for indices, material in subsets:
        if face in indices and material:
            found = material
    return found if found else mesh_material


def material_key(material: UsdShade.Material | None) -> str:
    """A name for ``material`` that does not depend on how a stage names its prototypes: its path, or inside a native
    instance its path below the prototype root (``*/Looks/M``); ``""`` for none."""
    if material is None:
        return ""
    prim = material.GetPrim()
    if prim.IsInstanceProxy():
        prim = prim.GetPrimInPrototype()
    return prototype_free(str(prim.GetPath()))


def scene_material_key(stage: Usd.Stage, path: str) -> str:
    """:func:`material_key` of the material wrt names ``path``: inside a native instance wrt names it by a proxy in
    the prototype's first instance (``/A/Looks/M``), USD by the instance's own proxy or its prototype path."""
    prim = stage.GetPrimAtPath(path) if Sdf.Path.IsValidPathString(path) else None
    return material_key(UsdShade.Material(prim)) if prim else prototype_free(path)


def prototype_free(path: str) -> str:
    return "*" + path[path.index("/", 1):] if path.startswith("/__Prototype_") else path


def corner_values(primvar: UsdGeom.Primvar, mesh: UsdGeom.Mesh) -> tuple:
    """``(values (K, k) float64 flattened through the indices, interpolation, first corner of each face, counts,
    faceVertexIndices)`` of ``primvar`` on ``mesh``: what :func:`face_corners` reads."""
    values = np.asarray(primvar.ComputeFlattened(), np.float64)
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get())
    starts = np.concatenate([[0], np.cumsum(counts)])
    return (values.reshape(len(values), -1), primvar.GetInterpolation(), starts, counts,
            np.asarray(mesh.GetFaceVertexIndicesAttr().Get()))


def face_corners(facts: tuple, face: int) -> np.ndarray:
    """``(n, k)`` the values at the corners of ``face`` (``facts``: :func:`corner_values`)."""
    values, interpolation, starts, counts, indices = facts
    corners = np.arange(starts[face], starts[face] + counts[face])
    if interpolation == UsdGeom.Tokens.constant:
        return values[np.zeros(len(corners), int)]
    if interpolation == UsdGeom.Tokens.uniform:
        return values[np.full(len(corners), face)]
    if interpolation == UsdGeom.Tokens.faceVarying:
        return values[corners]
    return values[indices[corners]]


def expected_corners(prim: Usd.Prim, face: int, name: str, cache: dict | None = None) -> np.ndarray | None:
    """The values of primvar ``name`` found with USD's inheritance at the corners of ``face``, or None (``cache``:
    each mesh's kept by path and name)."""
    key = (prim.GetPath(), name)
    if cache is None or key not in cache:
        primvar = UsdGeom.PrimvarsAPI(prim).FindPrimvarWithInheritance(name)
        facts = None
        if primvar and primvar.HasValue():
            facts = corner_values(primvar, UsdGeom.Mesh(prim)) if prim.IsA(UsdGeom.Mesh) else _gprim_values(primvar)
        if cache is None:
            return None if facts is None else face_corners(facts, face)
        cache[key] = facts
    return None if cache[key] is None else face_corners(cache[key], face)


def _gprim_values(primvar: UsdGeom.Primvar) -> tuple:
    """A gprim's one value, as :func:`corner_values` gives a mesh's: the mean of its values (README: gprims take the
    mean of a primvar that is not constant), for its one face."""
    values = np.asarray(primvar.ComputeFlattened(), np.float64)
    mean = values.reshape(len(values), -1).mean(axis=0)[None]
    return mean, UsdGeom.Tokens.constant, np.array([0, 1]), np.array([1]), np.zeros(1, int)


def within(got: np.ndarray, allowed: np.ndarray, tol: float = 1e-5) -> bool:
    """Every row of ``got`` is one of the rows of ``allowed``."""
    return all(np.any(np.all(np.abs(allowed - row) <= tol, axis=1)) for row in got)


def rendered_rows(scene):
    """Per rendered triangle, then per rendered analytic shape (a gprim): ``(prim path, face, geometry id, instance
    id)`` (face 0 for a shape)."""
    _, indices = scene.triangles()
    rows = np.arange(len(indices) + scene.stats()["rendered_shapes"], dtype=np.int64)
    geometry, instance = scene.split_ids(rows)
    prim_ids, faces = scene.hit_prims(geometry, instance)
    paths = scene.prim_paths()
    return [(paths[p], int(f), int(g), int(i)) for p, f, g, i in zip(prim_ids, faces, geometry, instance)]


def compare(stage: Usd.Stage, scene) -> list[str]:
    """The disagreements between USD and ``scene`` (loaded from ``stage``'s file), as lines; empty when none."""
    problems = []
    tri_materials = scene.triangle_materials()
    colors = scene.corner_attributes()[1]
    opacities = scene.corner_opacities()
    inst_colors = scene.instances.colors if len(scene.instances.colors) else None
    inst_opacities = scene.instances.opacities if len(scene.instances.opacities) else None
    names = [scene_material_key(stage, m.path) for m in scene.materials]
    seen = set()
    cache, prims = {}, {}
    for path, face, geometry, instance in rendered_rows(scene):
        if path not in prims:
            prims[path] = stage.GetPrimAtPath(path)
        prim = prims[path]
        if not prim or not prim.IsA(UsdGeom.Gprim):
            continue
        expected = drawn_as(face_material(prim, face, cache))
        k = int(tri_materials[geometry]) - 1
        got = names[k] if k >= 0 else ""
        want = material_key(expected)
        key = (path, face, instance)
        if got != want and key not in seen:
            problems.append(f"{path} face {face}: material {got or 'default'}, USD {want or 'none'}")
        # Colours: the primvar the material reads.
        mat_name = want.rsplit("/", 1)[-1] if want else ""
        if not want or want.startswith("/Looks/NotAMaterial"):
            color_name, fallback = "displayColor", None
        elif mat_name in MATERIAL_PRIMVARS:
            color_name, fallback = MATERIAL_PRIMVARS[mat_name]
        else:
            color_name = None
        if got == want and color_name is not None:
            corners = colors[geometry].astype(np.float64)
            if np.isnan(corners).any() and inst_colors is not None and instance >= 0:
                corners = np.broadcast_to(inst_colors[instance], (3, 3)).astype(np.float64)
            allowed = expected_corners(prim, face, color_name, cache)
            if allowed is None:
                ok = np.isnan(corners).all() or (fallback is not None and within(corners, np.array([fallback])))
                want_text = "none"
            else:
                ok = not np.isnan(corners).any() and within(corners, allowed)
                want_text = str(np.unique(allowed, axis=0).round(3).tolist())
            if not ok and key not in seen:
                problems.append(f"{path} face {face}: {color_name} {corners.round(3).tolist()}, USD {want_text}")
        if got == want and not want:
            got_opacity = (np.full(3, np.nan) if opacities is None else opacities[geometry]).astype(np.float64)
            if np.isnan(got_opacity).any() and inst_opacities is not None and instance >= 0:
                got_opacity = np.full(3, inst_opacities[instance], np.float64)
            got_opacity = np.where(np.isnan(got_opacity), 1.0, got_opacity)
            allowed = expected_corners(prim, face, "displayOpacity", cache)
            allowed = np.ones((1, 1)) if allowed is None else np.clip(allowed, 0.0, 1.0)
            if not within(got_opacity[:, None], allowed) and key not in seen:
                problems.append(f"{path} face {face}: displayOpacity {got_opacity.round(3).tolist()}, USD "
                                f"{np.unique(allowed).round(3).tolist()}")
        seen.add(key)
    return problems
