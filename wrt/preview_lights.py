"""Outlines of the lights of a scene for :func:`wrt.preview`: where each light is and the shape it emits from.

Each light is drawn as lines, with the shape the renderer gives it (:mod:`wrt.light_table`):

- ``RectLight``: its rectangle (corners ``to_world @ (+-width/2, +-height/2, 0)``), ``DiskLight``: its circle (an
  ellipse under an uneven scale), both with a tick from the centre along the emitting normal (their -Z side);
- ``SphereLight``: three great circles of the sphere (or ellipsoid) in its frame's planes, and a point light
  (``drawn_as_point``) a small three-axis star;
- ``CylinderLight``: its two end circles and four lines along the tube, or its axis alone as a line light
  (``drawn_as_line``);
- ``DistantLight``: an arrow along the direction the light travels, ending at the scene's bounding sphere and
  pointing at its centre;
- ``DomeLight`` and ``MeshLight`` are not drawn (a dome lights from every direction; a mesh light's mesh is drawn
  with the scene); the summary names them.
"""

from __future__ import annotations

import numpy as np

from .light_table import _emitting_normal
from .lights import CylinderLight, DiskLight, DomeLight, MeshLight, RectLight, SphereLight, light_axes, round_tube
from .preview_subsets import even_rows
from .scene import DistantLight
from .tubes import perpendicular_frames
from .wording import counted

LIGHT_SEGMENTS = 48  # segments per circle of a light's outline
LIGHT_BUDGET = 10_000  # most lights drawn; a note says how many were left out
GLYPH_FRACTION = 0.05  # point-light stars and distant-light arrowheads, as a fraction of the scene's diagonal
ARROW_FRACTION = 0.25  # length of a distant light's arrow, as a fraction of the scene's diagonal


def _circle(centre, a, b, segments: int) -> np.ndarray:
    """``(segments, 3)`` points ``centre + cos(t) a + sin(t) b``."""
    t = np.linspace(0.0, 2.0 * np.pi, segments, endpoint=False)
    return centre + np.cos(t)[:, None] * a + np.sin(t)[:, None] * b


def _unit(v) -> np.ndarray:
    v = np.asarray(v, np.float64)
    length = float(np.linalg.norm(v))
    return v / length if length > 0.0 else v


def _outline(light, focus, diagonal: float, segments: int) -> list[tuple[np.ndarray, bool]]:
    """Polylines ``(points, closed)`` drawing one light; empty for those not drawn."""
    glyph = GLYPH_FRACTION * diagonal
    if isinstance(light, RectLight):
        u, v = light.edges()
        _, _, z, origin = light_axes(light.to_world)
        corners = origin + np.array([[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]]) @ np.stack([u, v])
        tick = 0.5 * max(np.linalg.norm(u), np.linalg.norm(v)) * _emitting_normal(u, v, z)
        return [(corners, True), (np.stack([origin, origin + tick]), False)]
    if isinstance(light, DiskLight):
        x, y, z, origin = light_axes(light.to_world)
        u, v = x * light.radius, y * light.radius
        tick = max(np.linalg.norm(u), np.linalg.norm(v)) * _emitting_normal(u, v, z)
        return [(_circle(origin, u, v, segments), True), (np.stack([origin, origin + tick]), False)]
    if isinstance(light, SphereLight):
        centre = np.asarray(light.position, np.float64)
        if light.drawn_as_point:
            return [(np.stack([centre - d, centre + d]), False) for d in glyph * np.eye(3)]
        m = light.ellipsoid()
        m = light.world_radius * np.eye(3) if m is None else m  # round: the renderer's sphere of world_radius
        return [(_circle(centre, m[:, i], m[:, j], segments), True) for i, j in ((0, 1), (0, 2), (1, 2))]
    if isinstance(light, CylinderLight):
        origin = light_axes(light.to_world)[3]
        axis, radius = light.world_shape()
        if light.drawn_as_line:
            return [(np.stack([origin - 0.5 * axis, origin + 0.5 * axis]), False)]
        m3 = np.asarray(light.to_world, np.float64)[:3, :3]
        m = light.tube()
        if m is None and round_tube(m3):
            m = m3 * np.array([light.length, light.radius, light.radius])
        elif m is None:  # flattened: the renderer's round tube of the mean scaled radius about the axis
            e1, e2 = perpendicular_frames(_unit(axis)[None])
            m = np.column_stack([axis, radius * e1[0], radius * e2[0]])
        if not np.linalg.norm(m[:, 0]) > 0.0:  # no length: a ring
            return [(_circle(origin, m[:, 1], m[:, 2], segments), True)]
        ends = [(_circle(origin + s * m[:, 0], m[:, 1], m[:, 2], segments), True) for s in (-0.5, 0.5)]
        sides = [(np.stack([origin - 0.5 * m[:, 0] + d, origin + 0.5 * m[:, 0] + d]), False)
                 for d in (m[:, 1], m[:, 2], -m[:, 1], -m[:, 2])]
        return ends + sides
    if isinstance(light, DistantLight):
        direction = _unit(light.direction)
        tip = focus - 0.5 * diagonal * direction  # on the scene's bounding sphere
        tail = tip - ARROW_FRACTION * diagonal * direction
        e1, e2 = perpendicular_frames(direction[None])
        heads = [(np.stack([tip, tip - glyph * direction + 0.5 * glyph * d]), False)
                 for d in (e1[0], e2[0], -e1[0], -e2[0])]
        return [(np.stack([tail, tip]), False)] + heads
    return []


def light_glyphs(lights, lower, upper, segments: int = LIGHT_SEGMENTS, max_lights: int = LIGHT_BUDGET):
    """The outlines of ``lights`` (``Scene.lights``) as one ``pyvista.PolyData`` of lines, or None where none is
    drawn, and a note for the summary (``""`` without lights). Cell array ``"light"``: the index in ``lights`` of the
    light each line draws. At most ``max_lights`` of the lights that are drawn (domes and mesh lights are not) are,
    an even stride through them (the first ones were the lamps of one corner of a big grid of them); the note counts
    the others. ``lower``, ``upper``: the scene's bounds, which size the glyphs of point and distant lights and place
    the latter's arrows."""
    lower, upper = np.asarray(lower, np.float64), np.asarray(upper, np.float64)
    focus = 0.5 * (lower + upper)
    diagonal = float(np.linalg.norm(upper - lower))
    diagonal = diagonal if diagonal > 0.0 else 1.0
    points, cells, owners, base = [], [], [], 0
    drawable = [k for k, light in enumerate(lights) if not isinstance(light, (DomeLight, MeshLight))]
    for k in np.asarray(drawable, np.int64)[even_rows(len(drawable), max_lights)]:
        light = lights[k]
        for line, closed in _outline(light, focus, diagonal, segments):
            ids = base + np.arange(len(line))
            ids = np.append(ids, base) if closed else ids
            cells.append(np.concatenate([[len(ids)], ids]))
            points.append(line)
            owners.append(k)
            base += len(line)
    drawn = len(set(owners))
    domes = sum(isinstance(light, DomeLight) for light in lights)
    meshes = sum(isinstance(light, MeshLight) for light in lights)
    parts = [f"{drawn:,} drawn"] if drawn else []
    if len(drawable) > max_lights:
        parts.append(f"{len(drawable) - max_lights:,} left out")
    if domes:
        parts.append(f"{counted(domes, 'dome')} not drawn (light from every direction)")
    if meshes:
        parts.append(f"{counted(meshes, 'mesh light')} drawn as {'its mesh' if meshes == 1 else 'their meshes'}")
    note = f"{counted(len(lights), 'light')}: {', '.join(parts)}" if lights else ""
    if not points:
        return None, note
    from .preview import import_pyvista

    pv = import_pyvista()
    mesh = pv.PolyData(np.concatenate(points), lines=np.concatenate(cells))
    mesh.cell_data["light"] = np.array(owners, np.int64)
    return mesh, note
