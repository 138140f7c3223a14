"""Two-level trace A/B on CUDA: wrt (this tree) against ``wrt_old`` (a copy of the package before a TLAS change, in
the folder ``$BASELINE``) on instanced asset scenes (loaded with their instances), the same rays (``wrt.rays.ray_set``:
primary, shadow through the any-hit query, diffuse, incoherent) traced by both, median launch times of 21
interleaved launches, and the share of rays whose prim (or blocked flag) agrees.

    BASELINE=.gpu/base55 WRT_ASSETS=... python benchmarks/gpu_tlas_ab.py   # NRAYS: rays per kind (1M)
"""
import argparse
import importlib
import json
import os
import statistics
import sys


def baseline_folder() -> str:
    """``$BASELINE``, checked (with ``$WRT_ASSETS`` and ``$NRAYS``) before Warp loads: unset, the script stopped with
    a traceback, ``KeyError: 'BASELINE'``."""
    parser = argparse.ArgumentParser(
        description="Two-level trace A/B on CUDA: this tree's wrt against wrt_old, a copy of the package before a TLAS "
        "change.", allow_abbrev=False,
        epilog="environment: BASELINE (required) the folder holding wrt_old; WRT_ASSETS the shared assets' folder; "
        "NRAYS rays per kind (default 1048576)")
    parser.parse_args()
    folder = os.environ.get("BASELINE", "")
    if not os.path.isdir(os.path.join(folder, "wrt_old")):
        parser.error(f"BASELINE={folder!r} names no folder holding wrt_old (the package before the change); e.g. "
                     "BASELINE=.gpu/base55")
    assets = os.environ.get("WRT_ASSETS", "")
    if not os.path.isfile(os.path.join(assets, "manifest.json")):  # each scene was 'skipped: 'WRT_ASSETS''
        parser.error(f"WRT_ASSETS={assets!r} names no folder holding the shared assets' manifest.json")
    if not os.environ.get("NRAYS", "1").isdigit() or int(os.environ.get("NRAYS", "1")) < 1:
        parser.error(f"NRAYS={os.environ['NRAYS']!r} is not a positive integer")
    return folder


sys.path.insert(0, baseline_folder())
import numpy as np  # noqa: E402
import warp as wp  # noqa: E402

import wrt  # noqa: E402
from wrt.rays import ray_set  # noqa: E402

# Warp registers the wrt_stack_* builtins by name: both packages use the new package's stack types (same C++ code).
sys.modules["wrt_old.bvh.stack"] = importlib.import_module("wrt.bvh.stack")
import wrt_old  # noqa: E402

dev = "cuda:0"
NRAYS = int(os.environ.get("NRAYS", 1 << 20))
wp.init()
print(wp.get_device(dev).name)


def scene_of(mod, name):
    root = os.environ["WRT_ASSETS"]
    assets = {a["id"]: a["path"] for a in json.load(open(f"{root}/manifest.json"))["assets"]}
    return mod.load_usd(f"{root}/{assets[name.removeprefix('asset:')]}")


def timed(fn, reps=15):
    for _ in range(3):
        fn()
    times = []
    for _ in range(reps):
        e0, e1 = wp.Event(enable_timing=True), wp.Event(enable_timing=True)
        wp.record_event(e0)
        fn()
        wp.record_event(e1)
        wp.synchronize_device(dev)
        times.append(wp.get_event_elapsed_time(e0, e1, synchronize=True))
    return times


for name in ["asset:teapot_scene_1000", "asset:chess_set", "asset:teapot_layout_1000"]:
    try:
        scenes = {m.__name__: scene_of(m, name) for m in (wrt, wrt_old)}
    except Exception as e:  # noqa: BLE001
        print(name, "skipped:", e)
        continue
    s = scenes["wrt"]
    print(f"\n{name}: {len(s.instances)} instances, {len(s.shapes)} shapes, {len(s.prototypes)} prototypes")
    for kind in ["primary", "shadow", "diffuse", "incoherent"]:
        o, d = ray_set(s, kind, NRAYS)
        res, hits = {}, {}
        for mname, mod in (("wrt", wrt), ("wrt_old", wrt_old)):
            sc = scenes[mname]
            tmod = importlib.import_module(mname + ".trace")
            acc = tmod.get_accelerator(sc, "wrt", "sah", dev)
            rays = tmod.upload_rays(o, d, 1e-4 if kind != "primary" else 0.0, np.inf, acc.device, acc.unit_rays)
            hb = tmod.HitBuffer(len(rays[0]), acc.device)
            if kind == "shadow":
                blocked = wp.zeros(len(rays[0]), dtype=wp.int32, device=dev)
                res[mname] = lambda acc=acc, rays=rays, blocked=blocked: acc.occluded(*rays, blocked)
                res[mname]()
                hits[mname] = blocked.numpy()
            else:
                res[mname] = lambda acc=acc, rays=rays, hb=hb: acc.intersect(*rays, hb, costs=False)
                res[mname]()
                hits[mname] = tmod.read_hits(sc, hb).prim
        t = {m: [] for m in res}
        for _ in range(3):  # interleaved rounds
            for m in res:
                t[m] += timed(res[m], 7)
        med = {m: statistics.median(v) for m, v in t.items()}
        same = float(np.mean(hits["wrt"] == hits["wrt_old"]))
        print(f"  {kind:10s} rays {len(o):8d}  old {med['wrt_old']:.3f} ms  new {med['wrt']:.3f} ms  "
              f"new/old {med['wrt'] / med['wrt_old']:.3f}  same prim/blocked {same:.5f}", flush=True)
