"""A float64 numpy path tracer independent of wrt, for scenes of Lambertian parallelograms lit by UsdLux-style lights:
one-sided rect and disk lights (emitting along ``normal``), sphere lights, a constant dome and a distant light's
disc of directions. It uses next-event estimation alone (every light at every vertex, the dome by cosine-weighted
directions, a sphere by its cone of directions, rects, disks and emissive faces by area), so a path's bounce rays
pick up no emission: that is unbiased wherever light sampling reaches every direction a light is seen in, which
holds for these lights. ``max_depth`` counts the surfaces a path scatters at, as wrt's does (1: direct light only).

Lights carry UsdLux's per-light controls as wrt's README describes them: ``diffuse`` scales what the (Lambertian)
surfaces reflect of the light, ``unlit`` lists the faces its lightLink leaves out (it lights them by no path) and
``no_shadow`` the faces its shadowLink leaves out (they block no shadow ray towards it, yet scatter bounce rays)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np


@dataclasses.dataclass
class Face:
    """Parallelogram ``origin + a u + b v`` (``a, b`` in [0, 1]); its front is ``u x v``, emitting ``emission``."""

    origin: tuple
    u: tuple
    v: tuple
    albedo: tuple
    emission: tuple = (0.0, 0.0, 0.0)


@dataclasses.dataclass
class Light:
    """``kind``: ``rect`` (``width`` along ``x_axis``, ``height`` along ``y_axis``), ``disk`` (``radius`` in the plane
    of ``x_axis`` and ``y_axis``) or ``sphere`` (``radius``); rects and disks emit along ``normal`` only."""

    kind: str
    radiance: tuple
    center: tuple
    radius: float = 0.0
    width: float = 0.0
    height: float = 0.0
    x_axis: tuple = (1.0, 0.0, 0.0)
    y_axis: tuple = (0.0, 1.0, 0.0)
    normal: tuple = (0.0, 0.0, -1.0)
    diffuse: float = 1.0
    unlit: tuple = ()
    no_shadow: tuple = ()


@dataclasses.dataclass
class Sky:
    """A constant dome (``axis`` None) or a distant light's disc of directions of half-angle ``half_angle`` (radians)
    around ``axis``, the unit direction towards the light, both of constant ``radiance``."""

    radiance: tuple
    axis: tuple | None = None
    half_angle: float = 0.0
    diffuse: float = 1.0


def _dot(a, b):
    return np.einsum("...k,...k->...", a, b)


def _frame(n):
    """Two unit tangents ``(R, 3)`` completing the unit normals ``n`` ``(R, 3)`` to an orthonormal frame."""
    helper = np.where(np.abs(n[:, :1]) > 0.9, [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
    t = np.cross(n, helper)
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    return t, np.cross(n, t)


def _cone(axis, cos_max, rng):
    """Directions uniform in solid angle within ``acos(cos_max)`` (per row) of the unit ``axis`` rows."""
    t, b = _frame(axis)
    cos_t = 1.0 - rng.random(len(axis)) * (1.0 - cos_max)
    sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
    phi = 2.0 * np.pi * rng.random(len(axis))
    return (sin_t * np.cos(phi))[:, None] * t + (sin_t * np.sin(phi))[:, None] * b + cos_t[:, None] * axis


def _cosine(n, rng):
    """Cosine-weighted directions about the unit normals ``n``."""
    t, b = _frame(n)
    u1, phi = rng.random(len(n)), 2.0 * np.pi * rng.random(len(n))
    r = np.sqrt(u1)
    return (r * np.cos(phi))[:, None] * t + (r * np.sin(phi))[:, None] * b + np.sqrt(1.0 - u1)[:, None] * n


class Faces:
    def __init__(self, faces: list[Face]):
        self.o, self.u, self.v = (np.array([getattr(f, k) for f in faces], float) for k in ("origin", "u", "v"))
        self.albedo = np.array([f.albedo for f in faces], float)
        self.emission = np.array([f.emission for f in faces], float)
        cross = np.cross(self.u, self.v)
        self.area = np.linalg.norm(cross, axis=-1)
        self.n = cross / self.area[:, None]
        # The dual basis: a point's (a, b) on each face are its offsets from the origin dotted with these.
        uu, uv, vv = _dot(self.u, self.u), _dot(self.u, self.v), _dot(self.v, self.v)
        det = uu * vv - uv * uv
        self.du = (vv[:, None] * self.u - uv[:, None] * self.v) / det[:, None]
        self.dv = (uu[:, None] * self.v - uv[:, None] * self.u) / det[:, None]

    def intersect(self, o, d, t_max=None, skip=()):
        """Nearest ``(t, face)`` of rays ``(o, d)`` ``(R, 3)`` short of ``t_max``, faces ``skip`` left out:
        ``(inf, -1)`` where none."""
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (_dot(self.n, self.o)[None] - o @ self.n.T) / (d @ self.n.T)
            p = o[:, None] + t[..., None] * d[:, None] - self.o[None]
            a, b = _dot(p, self.du[None]), _dot(p, self.dv[None])
        ok = (t > 1e-9) & (a >= 0) & (a <= 1) & (b >= 0) & (b <= 1)
        if t_max is not None:
            ok &= t < t_max[:, None]
        ok[:, list(skip)] = False
        t = np.where(ok, t, np.inf)
        k = np.argmin(t, axis=1)
        t = t[np.arange(len(o)), k]
        return t, np.where(np.isfinite(t), k, -1)


def _light_hit(light: Light, o, d):
    """Distance along rays ``(o, d)`` to the emitting side of ``light`` (inf where they miss it)."""
    c = np.asarray(light.center, float)
    if light.kind == "sphere":
        oc = o - c
        b = _dot(oc, d)
        disc = b * b - (_dot(oc, oc) - light.radius**2)
        t = -b - np.sqrt(np.maximum(disc, 0.0))
        return np.where((disc > 0) & (t > 0), t, np.inf)
    n = np.asarray(light.normal, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = ((c - o) @ n) / (d @ n)
    p = o + t[:, None] * d - c
    x, y = p @ np.asarray(light.x_axis, float), p @ np.asarray(light.y_axis, float)
    if light.kind == "rect":
        inside = (np.abs(x) <= light.width / 2) & (np.abs(y) <= light.height / 2)
    else:
        inside = x * x + y * y <= light.radius**2
    return np.where(inside & (t > 0) & (d @ n < 0), t, np.inf)


def _sample_light(light: Light, p, rng):
    """Directions from ``p`` towards ``light``, distances to it and the weights ``G / pdf`` (radiance and BSDF
    apart) of next-event estimation: area sampling of rects and disks, the cone of a sphere."""
    c = np.asarray(light.center, float)
    m = len(p)
    if light.kind == "sphere":
        to_c = c - p
        dist_c = np.linalg.norm(to_c, axis=-1)
        cos_max = np.sqrt(np.maximum(0.0, 1.0 - (light.radius / dist_c) ** 2))
        wi = _cone(to_c / dist_c[:, None], cos_max, rng)
        b = _dot(to_c, wi)
        dist = b - np.sqrt(np.maximum(b * b - (dist_c**2 - light.radius**2), 0.0))
        return wi, dist, 2.0 * np.pi * (1.0 - cos_max)
    x, y = np.asarray(light.x_axis, float), np.asarray(light.y_axis, float)
    if light.kind == "rect":
        a, b = (rng.random(m) - 0.5) * light.width, (rng.random(m) - 0.5) * light.height
        area = light.width * light.height
    else:
        r, phi = light.radius * np.sqrt(rng.random(m)), 2.0 * np.pi * rng.random(m)
        a, b = r * np.cos(phi), r * np.sin(phi)
        area = math.pi * light.radius**2
    to = c + a[:, None] * x + b[:, None] * y - p
    dist = np.linalg.norm(to, axis=-1)
    wi = to / dist[:, None]
    cos_l = -(wi @ np.asarray(light.normal, float))
    return wi, dist, np.where(cos_l > 0, cos_l * area / dist**2, 0.0)


def render(faces: list[Face], lights: list[Light], skies: list[Sky], eye, directions, max_depth, rng):
    """Radiance ``(R, 3)`` along camera rays from ``eye`` in unit ``directions`` ``(R, 3)``."""
    geo = Faces(faces)
    d = np.asarray(directions, float)
    o = np.broadcast_to(np.asarray(eye, float), d.shape).copy()
    radiance = np.zeros(d.shape)
    weight = np.ones(d.shape)
    rows = np.arange(len(d))
    emitters = np.nonzero(geo.emission.max(axis=1) > 0)[0]
    for depth in range(max_depth + 1):
        t, k = geo.intersect(o, d)
        if depth == 0:  # what the camera sees: lights in front of the first surface, the sky, glowing faces
            for light in lights:
                radiance += (_light_hit(light, o, d) < t)[:, None] * np.asarray(light.radiance, float)
            for sky in skies:
                seen = np.ones(len(d), bool) if sky.axis is None else d @ sky.axis >= math.cos(sky.half_angle)
                radiance += ((k < 0) & seen)[:, None] * np.asarray(sky.radiance, float)
            front = (k >= 0) & (_dot(geo.n[k], d) < 0)
            radiance += front[:, None] * geo.emission[k]
        alive = k >= 0
        o, d, t, k, weight, rows = o[alive], d[alive], t[alive], k[alive], weight[alive], rows[alive]
        if depth == max_depth or len(rows) == 0:
            break
        n = geo.n[k] * np.where(_dot(geo.n[k], d) > 0, -1.0, 1.0)[:, None]  # facing the ray
        p = o + t[:, None] * d + 1e-9 * n
        brdf = weight * geo.albedo[k] / np.pi
        # Next-event estimation: every light, glowing face and sky.
        for light in lights:
            wi, dist, g = _sample_light(light, p, rng)
            cos_x = _dot(n, wi)
            blocked = np.isfinite(geo.intersect(p, wi, dist, skip=light.no_shadow)[0])
            lit = (cos_x > 0) & ~blocked & ~np.isin(k, light.unlit)
            radiance[rows] += brdf * np.asarray(light.radiance, float) * (light.diffuse * lit * cos_x * g)[:, None]
        for e in emitters:
            to = geo.o[e] + rng.random(len(p))[:, None] * geo.u[e] + rng.random(len(p))[:, None] * geo.v[e] - p
            dist = np.linalg.norm(to, axis=-1)
            wi = to / dist[:, None]
            cos_x, cos_l = _dot(n, wi), -(wi @ geo.n[e])
            lit = (cos_x > 0) & (cos_l > 0) & ~np.isfinite(geo.intersect(p, wi, dist * (1 - 1e-9))[0])
            radiance[rows] += brdf * geo.emission[e] * (lit * cos_x * cos_l * geo.area[e] / dist**2)[:, None]
        for sky in skies:
            if sky.axis is None:  # cosine-weighted: the Lambertian lobe's cos / pdf is pi
                wi, g = _cosine(n, rng), np.pi
            else:
                cos_max = math.cos(sky.half_angle)
                wi = _cone(np.broadcast_to(np.asarray(sky.axis, float), p.shape), cos_max, rng)
                g = np.maximum(_dot(n, wi), 0.0) * 2.0 * np.pi * (1.0 - cos_max)
            open_sky = ~np.isfinite(geo.intersect(p, wi)[0])
            radiance[rows] += brdf * np.asarray(sky.radiance, float) * (sky.diffuse * open_sky * g)[:, None]
        d = _cosine(n, rng)
        o = p
        weight = weight * geo.albedo[k]
    return radiance
