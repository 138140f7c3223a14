"""Trial (reverted in the next commit): hierarchical clustering per radix-tree node (wrt/bvh/hploc.py) against
wp.Mesh(lbvh), wrt lbvh and the classic PLOC on a displaced sphere; usage: python benchmarks/hploc_trial.py cuda:0 10e6."""
import statistics, sys, time
import numpy as np, warp as wp
wp.config.quiet = True
wp.init()
from wrt.bvh import build_bvh_device, build_bvh
from wrt.bvh.common import BuildInput
from wrt.bvh.hploc import build_hploc
from wrt.bvh.stats import sah_cost
from wrt.procedural import displaced_sphere
dev = sys.argv[1] if len(sys.argv) > 1 else "cuda:0"
N = int(float(sys.argv[2])) if len(sys.argv) > 2 else 10_000_000
pts, idx = displaced_sphere(N)
print(len(idx), "tris on", dev, wp.get_device(dev).name, flush=True)
wpts = wp.array(pts, dtype=wp.vec3, device=dev); widx = wp.array(idx.ravel(), dtype=wp.int32, device=dev)

def t_mesh(kind):
    wp.synchronize_device(dev); t0 = time.perf_counter()
    m = wp.Mesh(points=wpts, indices=widx, bvh_constructor=kind); wp.synchronize_device(dev)
    return (time.perf_counter() - t0) * 1e3

def t_wrt(builder):
    wp.synchronize_device(dev); t0 = time.perf_counter()
    b = build_bvh_device(wpts, widx, builder=builder, leaf_size=8, device=dev); wp.synchronize_device(dev)
    return (time.perf_counter() - t0) * 1e3

def t_h(T, timers=None, variant="local"):
    wp.synchronize_device(dev); t0 = time.perf_counter()
    data = BuildInput(wpts, widx, dev)
    b = build_hploc(data, leaf_size=8, morton_bits=30, threshold=T, timers=timers, variant=variant); wp.synchronize_device(dev)
    return (time.perf_counter() - t0) * 1e3, b

cands = {"wp.Mesh lbvh": lambda: t_mesh("lbvh"), "wrt lbvh": lambda: t_wrt("lbvh"), "wrt ploc": lambda: t_wrt("ploc")}
for T in (3, 4):
    for v in ("local", "global", "pools"):
        cands[f"hploc {v} T={T}"] = (lambda T=T, v=v: t_h(T, variant=v)[0])
for k, f in cands.items():
    f()
res = {k: [] for k in cands}
for r in range(5):
    for k, f in cands.items():
        res[k].append(f())
base = statistics.median(res["wp.Mesh lbvh"])
for k, v in res.items():
    m = statistics.median(v)
    print(f"{k:16s} {m:8.2f} ms  {m/base:5.2f}x   (min {min(v):.2f})", flush=True)
for T in (3, 4):
  for v in ("local", "global", "pools"):
    timers = {}
    t_h(T, timers, v)
    print(T, v, {k: round(v[-1], 2) for k, v in timers.items()})
# quality + determinism vs CPU on 1M
p1, i1 = displaced_sphere(1_000_000)
ref = sah_cost(build_bvh(p1, i1, builder="sah", leaf_size=8))
for T in (3, 4):
  for v in ("local", "global"):
    g = build_hploc(BuildInput(p1, i1, dev), leaf_size=8, morton_bits=30, threshold=T, variant=v).to_host()
    c = build_hploc(BuildInput(p1, i1, "cpu"), leaf_size=8, morton_bits=30, threshold=T, variant=v).to_host()
    g.validate()
    same = all(np.array_equal(getattr(g, f), getattr(c, f)) for f in ("left_first", "prim_count", "prim_ids"))
    print(f"1M {v} T={T}: sah {sah_cost(g)/ref-1:+.2%} gpu==cpu tree: {same}")
