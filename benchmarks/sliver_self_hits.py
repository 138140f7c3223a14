"""How far off its plane a ray leaving a thin triangle must start so that the triangle test cannot report the
triangle it leaves (or a coplanar neighbour) again: the measurement behind ``wrt.shade.corner_reach`` (no sliver
factor) and the instance factor of ``wrt.shade.hit_point``.

Rays leave random points of slivers (fan slices, strip halves, caps) of aspect 1 to 65536, each traced with its
coplanar neighbours (``wrt.trace``, CPU), with no offset and ``t`` allowed on both sides of the origin, so that every
ray reports the plane crossing the test computes. Oracle (float64 numpy, on the float32 corners, origins and
directions the trace reads; through an instance, its float64 transform of the prototype's corners): the exact
crossing ``t*`` and the origin's signed distance from the plane on the side the ray leaves to. Per ray, the offset
along the normal it asks for is ``(t - t*) |cos| - distance``: the test puts the plane that far ahead of the float32
origin. Printed per shape and aspect, the largest: in units of ``REACH_OFFSET`` (2^-20) times the corner reach (the
sliver scale a triangle would need, before a safety factor), and as a share of the offset ``offset_ray_origin`` now
gives (emulated in float32 numpy, without the pull to the centroid); then the self-hits left when the rays start
there (``t_min = 0``).

    python benchmarks/sliver_self_hits.py [--accel wrt|warp] [--instanced] [--rays 1000] [--turns 8] [--far 1]
"""

import argparse

import numpy as np

import wrt

REACH_OFFSET = 2.0**-20  # wrt.geometry.REACH_OFFSET (and ERROR_OFFSET)
ASPECTS = [4**k for k in range(9)]  # 1 .. 65536: ordinary triangles for comparison, then slivers
SHAPES = ("fan", "strip", "cap")


def aspect_of(a, b, c):
    """``1 / twice area`` with the edges scaled by the longest one's largest component (``shade.sliver_scale``)."""
    edges = [b - a, c - a, c - b]
    longest = max(np.abs(e).max() for e in edges)
    return 1.0 / np.linalg.norm(np.cross(edges[0] / longest, edges[1] / longest))


def sliver_scale(aspect):
    """``shade.sliver_scale`` of a triangle of ``aspect``: a quarter of it, between 1 and 16384."""
    return 16384.0 if 1.0 / aspect * 16384.0 <= 0.25 else max(0.25 * aspect, 1.0)


def configuration(shape, aspect, rng):
    """``(corners (T, 3, 3) float64 in the plane z = 0, own)``: the triangle rays leave (row ``own``) among its
    coplanar neighbours, longest edge about 1."""
    w = 1.0 / aspect
    if shape == "fan":  # slices of a disc about its centre: apex angle ~ 1 / aspect
        angles = np.arange(-1, 3) * w
        rim = np.stack([np.cos(angles), np.sin(angles), np.zeros(4)], -1)
        tris = [[np.zeros(3), rim[k], rim[k + 1]] for k in range(3)]
        return np.array(tris), 1
    if shape == "strip":  # a 1 x w quad of two triangles, halves of it across its diagonal
        q = np.array([[0, 0, 0], [1, 0, 0], [1, w, 0], [0, w, 0]], float)
        return np.array([q[[0, 1, 2]], q[[0, 2, 3]]]), int(rng.integers(2))
    r = rng.uniform(0.1, 0.9)  # a cap: the third corner near the middle of the long edge, and its mirror image
    a, b = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
    return np.array([[a, b, [r, w, 0]], [b, a, [r, -w, 0]]]), 0


def random_rotation(rng):
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def plane(corners):
    """Unit normal and a point of each float64 triangle ``(T, 3, 3)``."""
    n = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    return n / np.linalg.norm(n, axis=1, keepdims=True), corners[:, 0]


def leaving_rays(world, own, n_rays, rng):
    """Float32 origins on triangle ``own`` (``shade.point_in_triangle`` in float32) and unit float32 directions
    leaving its plane to a random side, from grazing (cos 1e-4) to along the normal."""
    a, b, c = world[own]
    u, v = rng.uniform(0, 1, (2, n_rays))
    flip = u + v > 1
    u[flip], v[flip] = 1 - u[flip], 1 - v[flip]
    u, v = u.astype(np.float32)[:, None], v.astype(np.float32)[:, None]
    p = a + (u * (b - a) + v * (c - a))  # float32 throughout
    normal = plane(world[own : own + 1].astype(np.float64))[0][0]
    cos = np.where(rng.uniform(size=n_rays) < 0.5, rng.uniform(0, 1, n_rays), 10.0 ** rng.uniform(-4, 0, n_rays))
    side = np.where(rng.uniform(size=n_rays) < 0.5, -1.0, 1.0)
    t = rng.normal(size=(n_rays, 3))
    t -= np.outer(t @ normal, normal)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    d = (side * cos)[:, None] * normal + np.sqrt(1 - cos**2)[:, None] * t
    return p.astype(np.float32), d.astype(np.float32)


def corner_reach(corners, p):
    return np.abs(corners[None] - p[:, None]).max(axis=(1, 2))


def offset_origins(p, n, reach, err):
    """``geometry.offset_ray_origin`` without the pull to the centroid (float32 numpy), ``n`` the leaving side."""
    least = np.maximum(REACH_OFFSET * (np.abs(n) @ err), REACH_OFFSET * reach).astype(np.float32)
    step = least[:, None] * n.astype(np.float32)
    moved = p + step
    same = (moved == p) & (step != 0)
    moved[same] = np.nextafter(p, np.where(step > 0, np.inf, -np.inf).astype(np.float32))[same]
    return moved


def measure(shape, aspect, rng, n_rays, accel, instanced, far):
    """``(test, needed, self_hits)`` of rays leaving one random placement: the largest offset the test asks for in
    units of ``REACH_OFFSET`` times the corner reach, and as a share of the offset ``shade.hit_point`` gives; the
    self-hits of the rays lifted by that offset."""
    flat, own = configuration(shape, aspect, rng)
    rot = random_rotation(rng)
    shift = rng.uniform(-1, 1, 3) * far
    if instanced:  # prototype space: turned; the instance scales it by 0.03 to 30 along random axes
        proto = (flat @ rot.T + shift).astype(np.float32)
        linear = random_rotation(rng) @ np.diag(10.0 ** rng.uniform(-1.5, 1.5, 3)) @ random_rotation(rng)
        to_world = np.eye(4)
        to_world[:3, :3], to_world[:3, 3] = linear, rng.uniform(-1, 1, 3)
        world = (proto.astype(np.float64) @ linear.T + to_world[:3, 3]).astype(np.float32)
        protos = [wrt.Prototype("/P", [wrt.Mesh("/P/m", proto.reshape(-1, 3), np.arange(3 * len(proto)).reshape(-1, 3),
                                                np.zeros(len(proto), int), double_sided=True)])]
        scene = wrt.Scene(meshes=[], prototypes=protos,
                          instances=wrt.instancing.Instances.from_transforms([0], to_world[None]))
        exact = proto.astype(np.float64) @ linear.T + to_world[:3, 3]  # the surface the trace tests, in the world
        thinning = max(sliver_scale(aspect_of(*world[own].astype(np.float64)))
                       / sliver_scale(aspect_of(*proto[own].astype(np.float64))), 1.0)
        err = np.abs(linear) @ np.abs(proto[own]).max(axis=0) + np.abs(to_world[:3, 3])  # inverse_transform_magnitude
    else:
        world = (flat @ rot.T + shift).astype(np.float32)
        scene = wrt.Scene.from_triangles(world.reshape(-1, 3), np.arange(3 * len(world)).reshape(-1, 3))
        exact = world.astype(np.float64)
        thinning = 1.0
        err = np.abs(world[own]).max(axis=0).astype(np.float64)
    p, d = leaving_rays(world, own, n_rays, rng)
    normals, points = plane(exact)
    reach = corner_reach(world[own].astype(np.float64), p.astype(np.float64))
    hits = wrt.trace(scene, p, d, t_min=-4.0, t_max=4.0, accel=accel)
    ok = hits.hit & (hits.prim >= 0)
    k = np.where(ok, hits.prim, own)
    n = normals[k]
    cos = np.einsum("ij,ij->i", n, d.astype(np.float64))
    t_exact = np.einsum("ij,ij->i", n, points[k] - p) / cos
    ahead = np.where(ok, (hits.t - t_exact) * np.abs(cos), -np.inf)  # the test's plane ahead of the exact one
    own_n = normals[own] * np.sign(d.astype(np.float64) @ normals[own])[:, None]  # towards the leaving side
    distance = np.einsum("ij,ij->i", p - points[own], own_n)  # origin already on the leaving side by this much
    asked = ahead - distance
    least = REACH_OFFSET * np.maximum(np.abs(own_n) @ err, reach * thinning)  # offset_ray_origin's
    lifted = offset_origins(p, own_n, reach * thinning, err)
    again = wrt.trace(scene, lifted, d, t_min=0.0, t_max=4.0, accel=accel)
    return (asked / (REACH_OFFSET * reach)).max(), (asked / least).max(), int(again.hit.sum())


def main():
    parser = argparse.ArgumentParser(allow_abbrev=False, description=__doc__.split("\n\n")[0])
    parser.add_argument("--accel", default="wrt", choices=["wrt", "warp"])
    parser.add_argument("--instanced", action="store_true", help="the triangles drawn through a stretching instance")
    parser.add_argument("--rays", type=int, default=1000, help="rays per placement")
    parser.add_argument("--turns", type=int, default=8, help="random placements per shape and aspect")
    parser.add_argument("--far", type=float, default=1.0, help="placements up to this far from the origin")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    print(f"accel {args.accel}, {'instanced' if args.instanced else 'flat'}, {args.rays} rays x {args.turns} turns")
    print("shape  aspect  asked/(2^-20 reach)  asked/offset  self-hits")
    for shape in SHAPES:
        for aspect in ASPECTS:
            rows = [measure(shape, aspect, rng, args.rays, args.accel, args.instanced, args.far)
                    for _ in range(args.turns)]
            test, needed, hits = (max(r[0] for r in rows), max(r[1] for r in rows), sum(r[2] for r in rows))
            print(f"{shape:6s} {aspect:6d}  {test:19.3g}  {needed:12.3g}  {hits} of {args.rays * args.turns}",
                  flush=True)


if __name__ == "__main__":
    main()
