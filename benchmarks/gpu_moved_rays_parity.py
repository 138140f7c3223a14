"""CUDA check of the TLAS's moved rays (wrt/tlas.py moved_ray, shifted_limit): on 40 sheared and 40 squashed
octahedra instances and analytic spheres, rays from 1, 30 and 900 away (a tenth with a zero x component) under
random limits hit the same on cuda:0 as on the CPU, bit for bit (the modules compile with fuse_fp off), and the
any-hit query agrees with the closest hit on both. Exits 1 on a difference. Run from the repository root:
``PYTHONPATH=. python benchmarks/gpu_moved_rays_parity.py``."""
import sys

import numpy as np
import warp as wp

sys.path.insert(0, "tests")  # the stretched octahedra of tests/test_instancing.py
from test_instancing import octahedra_scene, stretched_octahedra  # noqa: E402

import wrt  # noqa: E402
from wrt.primitives import Shape  # noqa: E402

print(wp.get_cuda_device_count(), "cuda devices")
bad = 0
for stretch in ("sheared", "squashed"):
    rng = np.random.default_rng(7)
    to_world = stretched_octahedra(rng, stretch, 40)
    scenes = {"instances": octahedra_scene(to_world),
              "spheres": wrt.Scene(shapes=[Shape(f"/B{k}", "sphere", m) for k, m in enumerate(to_world)])}
    n = 50000
    targets = to_world[rng.integers(0, 40, n), :3, 3] + rng.normal(size=(n, 3))
    origins = (targets + rng.normal(size=(n, 3)) * rng.choice([1, 30, 900], (n, 1))).astype(np.float32)
    directions = (targets - origins).astype(np.float32)
    directions[rng.random(n) < 0.1, 0] = 0.0
    t_min = np.where(rng.random(n) < 0.5, 0.0, rng.uniform(0, 1.2, n)).astype(np.float32)
    t_max = np.where(rng.random(n) < 0.5, np.inf, t_min + rng.uniform(0, 1, n)).astype(np.float32)
    for name, scene in scenes.items():
        limits = {"t_min": t_min, "t_max": t_max}
        h = {dev: wrt.trace(scene, origins, directions, device=dev, **limits) for dev in ("cpu", "cuda:0")}
        o = {dev: wrt.occluded(scene, origins, directions, device=dev, **limits) for dev in ("cpu", "cuda:0")}
        same = (np.array_equal(h["cpu"].t, h["cuda:0"].t) and np.array_equal(h["cpu"].prim, h["cuda:0"].prim)
                and np.array_equal(o["cpu"], o["cuda:0"]) and np.array_equal(o["cpu"], h["cpu"].hit))
        print(stretch, name, "hits", int(h["cpu"].hit.sum()), "cpu == cuda and occluded == hit:", same)
        bad += not same
sys.exit(int(bad > 0))
