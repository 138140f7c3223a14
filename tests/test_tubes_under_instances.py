"""Points and curves under an instance's non-uniform, sheared or mirrored transform draw as their flattened copies
(the same stage with ``instanceable = false``, or a PointInstancer's instances written out as xformed copies):
spheres and tubes stay round, as under the prim's own transform, and hits, uv and the depth and normal AOVs agree
ray by ray, through wrt's TLAS and through ``accel='warp'``, which traces the tessellated scene flattened."""

import numpy as np
import pytest
from pxr import Gf
from usda_text import load, write

import wrt

# Points of vertex widths; a linear curve of vertex widths (cone frustums between joint spheres); a cubic bspline;
# under a rotated non-uniform scale of their own, which an instance's transform then composes with.
CONTENT = '''
    def Xform "Inner"
    {
        float xformOp:rotateZ = 30
        float3 xformOp:scale = (1, 1.5, 0.75)
        uniform token[] xformOpOrder = ["xformOp:rotateZ", "xformOp:scale"]
        def Points "Cloud"
        {
            point3f[] points = [(0, 0, 0), (1.5, 0.3, -0.2), (-1, 0.4, 0.6)]
            float[] widths = [0.8, 0.5, 0.3] (interpolation = "vertex")
        }
        def BasisCurves "Wire"
        {
            uniform token type = "linear"
            int[] curveVertexCounts = [3]
            point3f[] points = [(0, 1.5, 0), (1, 2, 0.5), (2, 1.5, -0.3)]
            float[] widths = [0.4, 0.6, 0.3] (interpolation = "vertex")
        }
        def BasisCurves "Cubic"
        {
            uniform token type = "cubic"
            uniform token basis = "bspline"
            int[] curveVertexCounts = [5]
            point3f[] points = [(0, -1.5, 0), (1, -1, 0.8), (2, -2, -0.3), (3, -1.2, 0.4), (3.5, -2, 0)]
            float[] widths = [0.3] (interpolation = "constant")
        }
    }
'''

# Column-vector linear parts (USD rows are their transposes) placed above the content.
TRANSFORMS = {
    "scale_2_1_half": np.diag([2.0, 1.0, 0.5]),
    "shear": np.array([[1.0, 0.8, 0.3], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
    "mirror": np.diag([-1.5, 1.0, 1.0]),
    "rotated_uniform": np.array([[0.0, -2.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 2.0]]),  # round either way
}


def usd_matrix(linear, translate) -> str:
    """A column-vector affine transform as USDA ``matrix4d`` text (USD's row-vector layout)."""
    m = np.eye(4)
    m[:3, :3] = linear
    m[:3, 3] = translate
    return "(" + ", ".join("(" + ", ".join(repr(float(v)) for v in row) + ")" for row in m.T) + ")"


def native_stage(linear, instanceable: bool) -> str:
    """Two instances of one prototype (one placed by ``linear``, one by a translation), or their flattened copies."""
    flag = "true" if instanceable else "false"
    body = f'class Xform "Proto"\n{{{CONTENT}}}\n'
    for name, lin, move in (("A", linear, (0.3, 0.2, 0.1)), ("B", np.eye(3), (0.0, 5.0, 0.0))):
        body += (f'def Xform "{name}" (\n    instanceable = {flag}\n    prepend references = </Proto>\n)\n{{\n'
                 f'    matrix4d xformOp:transform = {usd_matrix(lin, move)}\n'
                 '    uniform token[] xformOpOrder = ["xformOp:transform"]\n}\n')
    return body


def instancer_stage(instancer: bool) -> str:
    """A PointInstancer scaling its two instances of a prototype non-uniformly (the second rotated too), or the same
    instances written out as xformed copies of the prototype."""
    # Numbers float32 holds exactly, so the copies' float64 matrices are the instancer's.
    scales = [(2.0, 1.0, 0.5), (1.0, 0.75, 1.25)]
    quats = [(0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.375, 0.875)]  # (i, j, k, real) as Gf.Quatf stores them
    positions = [(0.0, 0.0, 0.0), (0.0, 5.0, 0.0)]
    proto = f'class Xform "Proto"\n{{{CONTENT}}}\n'
    if instancer:
        rows = lambda values: "[" + ", ".join("(" + ", ".join(repr(float(v)) for v in r) + ")" for r in values) + "]"  # noqa: E731
        quat_text = "[" + ", ".join(f"({float(q[3])!r}, {float(q[0])!r}, {float(q[1])!r}, {float(q[2])!r})"
                                    for q in quats) + "]"
        return proto + (f'def PointInstancer "PI"\n{{\n    rel prototypes = [</PI/Protos/P>]\n'
                        f'    int[] protoIndices = [0, 0]\n    point3f[] positions = {rows(positions)}\n'
                        f'    float3[] scales = {rows(scales)}\n    quatf[] orientations = {quat_text}\n'
                        '    def Scope "Protos"\n    {\n        def Xform "P" (prepend references = </Proto>)\n'
                        '        {\n        }\n    }\n}\n')
    body = proto
    for k, (s, q, p) in enumerate(zip(scales, quats, positions)):
        # As ComputeInstanceTransformsAtTime turns instances: GfMatrix4d::SetRotate of the quaternion as stored (this
        # one is not of unit length), transposed to column vectors.
        rotation = np.array(Gf.Matrix4d().SetRotate(Gf.Quatd(q[3], *q[:3])))[:3, :3].T
        body += (f'def Xform "Copy{k}" (prepend references = </Proto>)\n{{\n'
                 f'    matrix4d xformOp:transform = {usd_matrix(rotation @ np.diag(s), p)}\n'
                 '    uniform token[] xformOpOrder = ["xformOp:transform"]\n}\n')
    return body


def rays(scene, n: int = 2000):
    """Rays from above, most of them oblique, at random points near the centres of the scene's spheres and tube
    segments."""
    rng = np.random.default_rng(123)
    centres = scene.instances.to_world[:, :3, 3]
    targets = centres[rng.integers(0, len(centres), n)] + rng.normal(0.0, 0.4, (n, 3))
    origins = np.column_stack([targets[:, :2] + rng.normal(0.0, 3.0, (n, 2)), np.full(n, 10.0)])
    return origins.astype(np.float32), (targets - origins).astype(np.float32)


def assert_same_hits(instanced, flattened, accel="wrt"):
    """Hit or miss, t, u and v of every ray agree; enough rays hit points and tubes for that to mean something."""
    origins, directions = rays(flattened)
    a = wrt.trace(instanced, origins, directions, accel=accel)
    b = wrt.trace(flattened, origins, directions, accel=accel)
    hit = np.isfinite(b.t)
    assert hit.sum() > 400
    np.testing.assert_array_equal(np.isfinite(a.t), hit)
    np.testing.assert_allclose(a.t[hit], b.t[hit], rtol=1e-5)
    np.testing.assert_allclose(a.u[hit], b.u[hit], atol=1e-5)
    np.testing.assert_allclose(a.v[hit], b.v[hit], atol=1e-5)


@pytest.mark.parametrize("name", TRANSFORMS)
def test_native_instance_draws_as_its_flattened_copy(tmp_path, name):
    """Before, the instanced spheres and tubes were squashed by a (2, 1, 0.5) scale, a shear or a stretching mirror:
    hundreds of rays of 3000 hit or missed differently or hit up to 0.034 off."""
    linear = TRANSFORMS[name]
    instanced = load(write(tmp_path, native_stage(linear, True), "instanced.usda"))
    flattened = load(write(tmp_path, native_stage(linear, False), "flattened.usda"))
    assert len(instanced.instances) == len(flattened.instances) > 0  # the points and tubes are instances either way
    assert len(instanced.prototypes) < len(flattened.prototypes)  # drawn through /A and /B
    # Each point and curve named by its prim's instance-proxy path, as the flattened copy names it.
    names = [[s.instances.path(i) for i in range(len(s.instances))] for s in (instanced, flattened)]
    assert sorted(names[0]) == sorted(names[1])
    assert_same_hits(instanced, flattened)


def test_point_instancer_draws_as_xformed_copies(tmp_path):
    """A PointInstancer's non-uniform scales (one under a rotation) leave its prototype's points and curves round, as
    in copies xformed by each instance's transform."""
    instanced = load(write(tmp_path, instancer_stage(True), "instanced.usda"))
    flattened = load(write(tmp_path, instancer_stage(False), "flattened.usda"))
    assert "/PI" in instanced.instances.sources
    assert_same_hits(instanced, flattened)


@pytest.mark.parametrize("name", ["scale_2_1_half", "shear", "mirror"])
def test_depth_and_normal_aovs_agree(tmp_path, name):
    """The depth and shading normal a render reports at each pixel agree between the instanced and flattened
    stages (the normals are the round shapes' in both)."""
    linear = TRANSFORMS[name]
    camera = wrt.Camera.look_at((0.5, 0.0, 7.0), (0.5, 0.0, 0.0), fov_y_deg=60.0)  # on instance /A
    images = [wrt.render(load(write(tmp_path, native_stage(linear, flag), f"{flag}.usda")), camera=camera,
                         width=64, height=64, integrator="normals") for flag in (True, False)]
    a, b = (img.aovs for img in images)
    hit = np.isfinite(b["depth"]) & (b["depth"] > 0)
    assert hit.sum() > 200
    np.testing.assert_allclose(a["depth"], b["depth"], rtol=1e-5)
    np.testing.assert_allclose(a["normal"][hit], b["normal"][hit], atol=1e-4)


@pytest.mark.parametrize("name", ["scale_2_1_half", "shear", "mirror"])
def test_warp_accel_agrees_on_the_tessellated_stage(tmp_path, name):
    """``accel='warp'`` flattens the instances of tessellated spheres and tubes into one mesh: the instanced stage
    hits as its flattened copy there too."""
    linear = TRANSFORMS[name]
    instanced = load(write(tmp_path, native_stage(linear, True), "instanced.usda"), tessellate_gprims=24)
    flattened = load(write(tmp_path, native_stage(linear, False), "flattened.usda"), tessellate_gprims=24)
    assert_same_hits(instanced, flattened, accel="warp")


def test_points_of_a_zero_scale_instance_are_skipped_with_it(tmp_path):
    """The meshes and gprims of a PointInstancer instance of scale (0, 1, 1) are skipped with a warning naming it,
    but a Points prim in its prototype was drawn, without a word: its spheres, placed round, kept their size at the
    squashed centres (hits at t = 4.59). They go with the instance now, under the same warning, which names the
    instance once (each sphere is an instance row of its own: it read '2 prim(s): /PI[1], /PI[1]')."""
    path = write(tmp_path, '''def PointInstancer "PI"
{
    rel prototypes = [</PI/Protos/P>]
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0, 0, 0), (5, 0, 0)]
    float3[] scales = [(1, 1, 1), (0, 1, 1)]
    def Scope "Protos"
    {
        def Points "P"
        {
            point3f[] points = [(0, 0, 0), (0, 2, 0)]
            float[] widths = [1, 1] (interpolation = "vertex")
        }
    }
}
''')
    with pytest.warns(UserWarning, match=r"singular transform.*/PI\[1\]") as record:
        scene = wrt.load_usd(path)
    named = [str(w.message).split("skipped: ")[1] for w in record if "singular" in str(w.message)]
    assert named == ["1 prim(s): /PI[1]"]
    assert {scene.instances.path(i) for i in range(len(scene.instances))} == {"/PI[0]"}
    # Down onto the spheres' centres (x = 5: the squashed instance; x = 0: the other one).
    origins = np.array([[5, 0, 5], [5, 2, 5], [0, 0, 5], [0, 2, 5]], np.float32)
    hits = wrt.trace(scene, origins, [0, 0, -1])
    np.testing.assert_array_equal(hits.t, [np.inf, np.inf, 4.5, 4.5])
