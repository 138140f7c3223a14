"""UsdGeom.Points traced by wrt against a float64 oracle written from the schema (:mod:`points_oracle`): each point a
sphere of diameter ``widths[i]`` from every way widths are authored, placed by USD's own transforms (native instances,
PointInstancer prototypes, non-uniform scale keeping spheres round) and moved by USD's ``ComputePointsAtTime``. Seeded
random rays are compared where they are clear of silhouettes: hit or miss, ``t``, normal, prim path
(``scene.hit_paths``) and the point hit, ``wrt.occluded``, and the render's depth AOV."""

from __future__ import annotations

import warnings

import numpy as np
import points_oracle as oracle
import pytest
from gprim_compare import hit_normals
from points_stages import write_stage
from pxr import Usd

import wrt
from wrt.rays import camera_rays

CLEAR = 1e-3  # relative distance from a silhouette below which hit or miss is a rounding decision


def load(path, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return wrt.load_usd(path, **kwargs)


def aimed_rays(centres, radii, rng, n):
    """``(origins, directions)`` float64 holding float32 values: from 4-10 away, aimed within 1.5 radii of random
    spheres, and from inside random spheres."""
    k = rng.integers(len(centres), size=n)
    targets = centres[k] + rng.normal(size=(n, 3)) * radii[k, None] * 0.9
    away = rng.normal(size=(n, 3))
    away /= np.linalg.norm(away, axis=1, keepdims=True)
    origins = targets + away * rng.uniform(4, 10, (n, 1))
    inside = rng.uniform(size=n) < 0.15
    origins[inside] = centres[k[inside]] + rng.normal(size=(int(inside.sum()), 3)) * radii[k[inside], None] * 0.3
    directions = targets - origins
    directions[inside] = rng.normal(size=(int(inside.sum()), 3))
    directions *= rng.uniform(0.2, 5, (n, 1))  # t is in units of the direction's length
    return origins.astype(np.float32).astype(np.float64), directions.astype(np.float32).astype(np.float64)


def check_rays(scene, centres, radii, paths, instances, origins, directions):
    ref = oracle.trace(centres, radii, origins, directions)
    clear = ref["clearance"] > CLEAR
    hits = wrt.trace(scene, origins.astype(np.float32), directions.astype(np.float32))
    got_hit = hits.prim >= 0
    want_hit = ref["sphere"] >= 0
    bad = np.flatnonzero(clear & (got_hit != want_hit))
    assert len(bad) == 0, f"{len(bad)} of {clear.sum()} clear rays differ on hit or miss, first {bad[:5]}"
    both = clear & want_hit
    assert both.sum() > 0.3 * len(origins)
    length = np.linalg.norm(directions, axis=1)  # compared as distances: float32 rounds positions, not t
    np.testing.assert_allclose((hits.t * length)[both], (ref["t"] * length)[both], rtol=2e-5, atol=2e-5)
    prim_paths, instance_paths = scene.hit_paths(hits)
    want_paths = np.where(want_hit, paths[np.maximum(ref["sphere"], 0)], "")
    np.testing.assert_array_equal(np.asarray(prim_paths, object)[both], want_paths[both])
    # The point hit, "/Points[i]", or the PointInstancer instance, "/Instancer[j]".
    np.testing.assert_array_equal(np.asarray(instance_paths, object)[both], instances[ref["sphere"][both]])
    normals = hit_normals(scene, hits, origins, directions)
    np.testing.assert_allclose(normals[both], ref["normal"][both], atol=2e-3)
    # Any hit agrees with the closest hit on clear rays.
    np.testing.assert_array_equal(np.asarray(wrt.occluded(scene, origins.astype(np.float32),
                                                          directions.astype(np.float32)))[clear], want_hit[clear])


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_points_against_the_schema_oracle(tmp_path, seed):
    path = str(tmp_path / "points.usda")
    stage = write_stage(path, seed)
    centres, radii, paths, instances = oracle.spheres(stage)
    scene = load(path)
    rng = np.random.default_rng(seed)
    origins, directions = aimed_rays(centres, radii, rng, 3000)
    check_rays(scene, centres, radii, paths, instances, origins, directions)


@pytest.mark.parametrize("seed", [4, 5])
@pytest.mark.parametrize("time", [0.5, 1.5, 3.0, 4.0])
def test_moving_points_against_compute_points_at_time(tmp_path, seed, time):
    """Points with velocities and accelerations at samples 1 and 3, read before, between, at and past them, where USD's
    ``ComputePointsAtTime`` puts them."""
    path = str(tmp_path / "points.usda")
    stage = write_stage(path, seed, animated=True)
    t = Usd.TimeCode(time)
    centres, radii, paths, instances = oracle.spheres(stage, t)
    scene = load(path, time=time)
    rng = np.random.default_rng(seed)
    origins, directions = aimed_rays(centres, radii, rng, 1500)
    check_rays(scene, centres, radii, paths, instances, origins, directions)


@pytest.mark.parametrize("seed", [6])
def test_points_depth_aov_against_the_oracle(tmp_path, seed):
    """The render's depth AOV, pixel by pixel away from silhouettes, is the oracle's distance along the camera ray."""
    path = str(tmp_path / "points.usda")
    stage = write_stage(path, seed)
    centres, radii, _, _ = oracle.spheres(stage)
    scene = load(path)
    lower, upper = centres.min(axis=0), centres.max(axis=0)
    mid = 0.5 * (lower + upper)
    camera = wrt.Camera.look_at(tuple(mid + (upper - lower).max() * np.array([0.3, 0.4, 1.5])), tuple(mid),
                                fov_y_deg=50.0)
    width, height = 64, 48
    o, d = camera_rays(scene, camera, width, height)
    o, d = o.astype(np.float64), d.astype(np.float64)
    ref = oracle.trace(centres, radii, o, d)
    image = wrt.render(scene, camera=camera, width=width, height=height, spp=1, integrator="depth")
    depth = image.aovs["depth"].reshape(-1)
    clear = ref["clearance"] > CLEAR
    found = np.isfinite(depth) & (depth > 0)
    np.testing.assert_array_equal(found[clear], (ref["sphere"] >= 0)[clear])
    both = clear & found
    assert both.sum() > 100
    np.testing.assert_allclose(depth[both], (ref["t"] * np.linalg.norm(d, axis=1))[both], rtol=2e-5, atol=1e-5)



@pytest.mark.parametrize("seed", [7, 8])
def test_points_inside_usds_compute_extent(tmp_path, seed):
    """Under rotations and uniform scales (where a sphere's box is the transformed box of the prim's one) the spheres
    wrt draws for a Points prim with per-point widths, moved back into the prim's space, span exactly the extent
    ``UsdGeom.Points.ComputeExtent`` gives it. USD computes no extent for a single (constant) width, and one without
    widths for the points alone (wrt draws them 1 wide, UsdImaging's fallback); under a non-uniform scale the
    spheres stay round (the README), so they are not inside the transformed box: neither is checked here."""
    from points_stages import define_points, random_matrix, set_matrix
    from pxr import UsdGeom

    rng = np.random.default_rng(seed)
    path = str(tmp_path / "extent.usda")
    stage = Usd.Stage.CreateNew(path)
    for k in range(3):
        set_matrix(UsdGeom.Xform.Define(stage, f"/G{k}").GetPrim(), random_matrix(rng, stretch=False))
        define_points(stage, f"/G{k}/Cloud", rng, 6, ("vertex", "varying")[k % 2])
    stage.GetRootLayer().Save()
    scene = load(path)
    rows = np.arange(len(scene.instances.to_world))
    for k in range(3):
        prim = stage.GetPrimAtPath(f"/G{k}/Cloud")
        extent = np.array(UsdGeom.Boundable.ComputeExtentFromPlugins(UsdGeom.Boundable(prim), Usd.TimeCode.Default()))
        m = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(prim))  # row vectors
        mine = [i for i in rows if scene.instances.path(int(i)).startswith(f"/G{k}/Cloud[")]
        to_world = scene.instances.to_world[mine]  # column vectors: the unit sphere to each placed sphere
        inv = np.linalg.inv(m)
        centres = to_world[:, :3, 3] @ inv[:3, :3] + inv[3, :3]
        radii = np.linalg.norm(to_world[:, :3, 0], axis=1) / np.linalg.norm(np.ones(3) / np.sqrt(3.0) @ m[:3, :3])
        np.testing.assert_allclose((centres - radii[:, None]).min(axis=0), extent[0], atol=2e-6)
        np.testing.assert_allclose((centres + radii[:, None]).max(axis=0), extent[1], atol=2e-6)


INHERITED_WIDTHS = '''
class Xform "Proto"
{
    def Points "Cloud"
    {
        point3f[] points = [(0, 0, 0), (3, 0, 0)]
    }
    def Points "Own"
    {
        point3f[] points = [(6, 0, 0)]
        float[] widths = [0.8] (interpolation = "vertex")
    }
    def BasisCurves "Wire"
    {
        uniform token type = "linear"
        int[] curveVertexCounts = [2]
        point3f[] points = [(9, -1, 0), (9, 1, 0)]
    }
}
class Xform "Outer"
{
    def Xform "Inner" (
        instanceable = true
        prepend references = </Proto>
    )
    {
    }
    def PointInstancer "PI"
    {
        rel prototypes = [</Outer/PI/Protos/Root>]
        int[] protoIndices = [0]
        point3f[] positions = [(0, 3, 0)]
        def Scope "Protos"
        {
            def Xform "Root"
            {
                def Points "Cloud"
                {
                    point3f[] points = [(0, 0, 0)]
                }
            }
        }
    }
}
def Xform "I1" (
    instanceable = true
    prepend references = </Proto>
)
{
    float[] primvars:widths = [0.5] (interpolation = "constant")
    double3 xformOp:translate = (0, 5, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "I2" (
    instanceable = true
    prepend references = </Proto>
)
{
    float[] primvars:widths = [1.5] (interpolation = "constant")
    double3 xformOp:translate = (0, 10, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "I3" (
    instanceable = true
    prepend references = </Proto>
)
{
    double3 xformOp:translate = (0, 15, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Xform "Above"
{
    float[] primvars:widths = [0.25] (interpolation = "constant")
    def Xform "I4" (
        instanceable = true
        prepend references = </Proto>
    )
    {
        double3 xformOp:translate = (0, 20, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
def Xform "Nest" (
    instanceable = true
    prepend references = </Outer>
)
{
    float[] primvars:widths = [0.4] (interpolation = "constant")
    double3 xformOp:translate = (0, 30, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
'''


def test_widths_handed_down_by_native_instances(tmp_path):
    """A constant ``primvars:widths`` on a native instance (or above it) is the width of the prototype's points and
    curves that have no widths primvar of their own, one width per instance, as USD's primvar inheritance gives it
    through the instance proxies (``FindPrimvarWithInheritance``): over their ``widths`` attribute too, and through
    a nested instance and a PointInstancer inside the prototype."""
    from usda_text import write

    path = write(tmp_path, INHERITED_WIDTHS)
    stage = Usd.Stage.Open(path)
    centres, radii, paths, instances = oracle.spheres(stage)
    assert len(set(np.round(radii, 6))) >= 4  # the instances' widths differ
    scene = load(path)
    o = centres + [0.0, 0.0, 10.0]
    d = np.tile([0.0, 0.0, -1.0], (len(centres), 1))
    check_rays(scene, centres, radii, paths, instances, o, d)
    # The wire's tube has the width its instance hands down (radius 0.5 without one).
    wire = np.array([(9.0, y, 10.0) for y in (5, 10, 15, 20, 30)])
    hits = wrt.trace(scene, wire.astype(np.float32), d[:5].astype(np.float32))
    np.testing.assert_allclose(hits.t, 10.0 - np.array([0.25, 0.75, 0.5, 0.125, 0.2]), rtol=1e-6)
