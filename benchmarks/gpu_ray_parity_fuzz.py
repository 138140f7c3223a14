"""Traces the same rays on two devices with every wrt builder and layout and every ``wp.Mesh`` constructor, and
counts the rays whose answers differ (prim, hit, t, u/v, instance, any-hit). wrt's trace kernels round alike on
every device, so every count is expected to be 0 for wrt; ``wp.Mesh`` builds other trees on CUDA (lbvh, cubql),
which may break edge ties otherwise.

The cases are the ones the CPU's metamorphic checks use (README, "Robustness"): a triangle soup scaled from 1e-6
to 1e6 and moved up to 1e7 from the origin, directions scaled from 1e-30 to 1e20, ``t_min``/``t_max`` set to each
ray's own hit distance (and the next float), duplicated triangles, a closed icosphere hit from inside through its
vertices and edge midpoints (a miss there is a leak, counted per device), and instances under non-uniform,
mirrored, sheared and huge transforms.

Usage: python benchmarks/gpu_ray_parity_fuzz.py [--devices cpu,cuda:0] [--rays 3000]
"""

import argparse
import sys
import time
from pathlib import Path

import numpy as np

import wrt
from wrt.bvh.build import Builder
from wrt.bvh.layout import LAYOUTS
from wrt.instancing import Instances, Prototype
from wrt.scene import Mesh, Scene
from wrt.trace import WARP_BUILDERS

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_robustness import icosphere  # noqa: E402

ACCELERATORS = [("wrt", b.value, layout) for b in Builder for layout in LAYOUTS] + [
    ("warp", b, "binary") for b in WARP_BUILDERS]


def soup(n: int, seed: int):
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-1, 1, (n, 1, 3))
    points = (centres + rng.normal(0, 0.15, (n, 3, 3))).reshape(-1, 3).astype(np.float32)
    return points, np.arange(3 * n, dtype=np.int32).reshape(-1, 3)


def rays_at_box(n: int, seed: int, radius: float = 3.0):
    """Origins on a sphere of ``radius`` aimed at random points of the box [-0.8, 0.8]^3."""
    rng = np.random.default_rng(seed)
    origins = rng.normal(size=(n, 3))
    origins = origins / np.linalg.norm(origins, axis=1, keepdims=True) * radius
    return origins.astype(np.float32), (rng.uniform(-0.8, 0.8, (n, 3)) - origins).astype(np.float32)


def differing_rays(scene, origins, directions, devices, t_min=0.0, t_max=np.inf):
    """{accelerator: {what: number of rays}} for the accelerators whose answers differ between the two devices."""
    out = {}
    for accel, builder, layout in ACCELERATORS:
        kw = dict(t_min=t_min, t_max=t_max, accel=accel, builder=builder, layout=layout)
        a, b = (wrt.trace(scene, origins, directions, device=d, **kw) for d in devices)
        blocked_a, blocked_b = (wrt.occluded(scene, origins, directions, device=d, **kw) for d in devices)
        same_hit = a.hit & b.hit & (a.prim == b.prim)
        counts = {
            "prim": int((a.prim != b.prim).sum()),
            "hit": int((a.hit != b.hit).sum()),
            "t": int((a.t[same_hit] != b.t[same_hit]).sum()),
            "uv": int(((a.u != b.u) | (a.v != b.v))[same_hit].sum()),
            "instance": int((a.instance != b.instance).sum()),
            "any_hit": int((blocked_a != blocked_b).sum()),
        }
        if any(counts.values()):
            out[(accel, builder, layout)] = counts
    return out


def report(label, differing, n_rays, log):
    own = {k: v for k, v in differing.items() if k[0] == "wrt"}
    warp = {k: v for k, v in differing.items() if k[0] == "warp"}
    n_own = sum(k[0] == "wrt" for k in ACCELERATORS)
    log(f"{label}: {n_rays} rays; wrt accelerators differing {len(own)}/{n_own}, "
        f"wp.Mesh {len(warp)}/{len(WARP_BUILDERS)}")
    for key, counts in list(own.items()) + list(warp.items()):
        log(f"    {':'.join(key)} {counts}")


def leaks(scene, origins, directions, devices, log):
    """Rays from inside a closed mesh that miss it, per accelerator and device (each is a hole in the surface)."""
    for accel, builder, layout in ACCELERATORS:
        missed = [int((~wrt.trace(scene, origins, directions, device=d, accel=accel, builder=builder,
                                  layout=layout).hit).sum()) for d in devices]
        if any(missed):
            log(f"    leaks {accel}:{builder}:{layout} " + ", ".join(f"{d} {m}" for d, m in zip(devices, missed)))


def instanced_scene(kind: str, rng, n: int = 30) -> Scene:
    sphere_points, sphere_faces = icosphere(3)
    soup_points, soup_faces = soup(40, 3)
    prototypes = [Prototype("/Sphere", [Mesh("/Sphere/m", sphere_points, sphere_faces, np.arange(len(sphere_faces)))]),
                  Prototype("/Soup", [Mesh("/Soup/m", soup_points * 0.5, soup_faces, np.arange(len(soup_faces)))])]
    to_world = np.tile(np.eye(4), (n, 1, 1))
    for j in range(n):
        rotation = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        stretch = {"nonuniform": np.diag(rng.uniform(0.05, 20, 3)), "mirror": np.diag(rng.choice([-1.0, 1.0], 3)),
                   "shear": np.array([[1, rng.uniform(-50, 50), 0], [0, 1, 0], [0, 0, 1.0]]),
                   "huge": np.eye(3) * 10 ** rng.uniform(3, 6)}[kind]
        to_world[j, :3, :3] = rotation @ stretch
        to_world[j, :3, 3] = rng.uniform(-3, 3, 3) * (1e5 if kind == "huge" else 1)
    return Scene(prototypes=prototypes, instances=Instances.from_transforms(np.arange(n) % 2, to_world))


def main(argv=None):
    parser = argparse.ArgumentParser(
        allow_abbrev=False, description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--devices", default="cpu,cuda:0", help="the two devices to compare (default: cpu,cuda:0)")
    parser.add_argument("--rays", type=int, default=3000, help="rays per case (default: 3000)")
    args = parser.parse_args(argv)
    devices = args.devices.split(",")
    if len(devices) != 2:
        parser.error(f"--devices takes two devices separated by a comma, not {args.devices!r}")
    start = time.time()

    def log(line):
        print(line, flush=True)

    def case(label, scene, origins, directions, **ranges):
        report(label, differing_rays(scene, origins, directions, devices, **ranges), len(origins), log)

    points, faces = soup(300, 1)
    origins, directions = rays_at_box(args.rays, 2)
    wide = lambda a: a.astype(np.float64)  # noqa: E731
    for scale in (1e-6, 1e-3, 1.0, 7.77, 1e3, 1e6):
        case(f"soup scaled by {scale:g}", Scene.from_triangles((wide(points) * scale).astype(np.float32), faces),
             (wide(origins) * scale).astype(np.float32), directions)
    for offset in (1e4, 1e6, 1e7):
        case(f"soup moved by {offset:g}", Scene.from_triangles((wide(points) + offset).astype(np.float32), faces),
             (wide(origins) + offset).astype(np.float32), directions)
    scene = Scene.from_triangles(points, faces)
    for factor in (1e-30, 3.3e-17, 7.1e-3, 13.0, 1e20):
        case(f"directions scaled by {factor:g}", scene, origins, (wide(directions) * factor).astype(np.float32))
    first = wrt.trace(scene, origins, directions)
    hit_t = first.t[first.hit].astype(np.float32)
    hit_origins, hit_directions = origins[first.hit], directions[first.hit]
    case("t_min = own hit t", scene, hit_origins, hit_directions, t_min=hit_t)
    case("t_max = own hit t", scene, hit_origins, hit_directions, t_max=hit_t)
    case("t_min = next float past the hit", scene, hit_origins, hit_directions,
         t_min=np.nextafter(hit_t, np.float32(np.inf)))
    case("t_min negative", scene, origins, directions, t_min=-3.0)
    case("soup drawn twice", Scene.from_triangles(np.concatenate([points, points]),
                                                  np.concatenate([faces, faces + len(points)])), origins, directions)

    rng = np.random.default_rng(11)
    sphere_points, sphere_faces = icosphere(3)
    edges = np.unique(np.sort(np.concatenate([sphere_faces[:, [0, 1]], sphere_faces[:, [1, 2]],
                                              sphere_faces[:, [2, 0]]]), axis=1), axis=0)
    for scale, offset in ((1.0, 0.0), (7.3e-5, 0.0), (1.0, 1e4)):
        placed = (wide(sphere_points) * scale + offset).astype(np.float32)
        midpoints = placed[edges[:, 0]] + np.float32(0.5) * (placed[edges[:, 1]] - placed[edges[:, 0]])
        targets = np.concatenate([placed, midpoints])  # every vertex and edge midpoint
        inside = (offset + 0.3 * scale * rng.uniform(-1, 1, targets.shape)).astype(np.float32)
        on_axes = targets.copy()  # rays along a coordinate plane through the centre
        on_axes[np.arange(len(targets)), rng.integers(0, 3, len(targets))] = np.float32(offset)
        closed = Scene.from_triangles(placed, sphere_faces)
        for name, starts in (("from inside", inside), ("in a coordinate plane", on_axes)):
            aims = (targets - starts).astype(np.float32)
            keep = (aims != 0).any(axis=1) & (np.linalg.norm(wide(starts) - offset, axis=1) < 0.9 * scale)
            case(f"icosphere x {scale:g} at {offset:g}, {name}", closed, starts[keep], aims[keep])
            leaks(closed, starts[keep], aims[keep], devices, log)

    for kind in ("nonuniform", "mirror", "shear", "huge"):
        scene = instanced_scene(kind, rng)
        lower, upper = scene.bounds()
        case(f"instances, {kind}", scene,
             *rays_at_box(args.rays, 9, radius=float(np.linalg.norm(np.asarray(upper) - np.asarray(lower)))))
    log(f"done in {time.time() - start:.0f} s")


if __name__ == "__main__":
    main()
