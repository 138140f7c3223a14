"""What the preview draws, checked against oracles that share no code with it: USD's own camera frustum and
transforms, and the accelerator's trees walked in float64 numpy. Guards for cases the other preview tests leave
out: render settings of non-square pixels and other conform policies, an infinite far plane and a camera scaled by
its parent; the SAH colouring of a TLAS; an instance's BLAS where its prototype is traced at another power of two;
lights scaled by their parents in a stage."""

import itertools
import warnings

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from preview_boxes import box_data  # noqa: E402

import wrt  # noqa: E402
from wrt.instancing import Instances, Prototype  # noqa: E402
from wrt.primitives import Shape  # noqa: E402
from wrt.trace import get_accelerator  # noqa: E402

SHOT = """#usda 1.0
(
    upAxis = "Y"
    renderSettingsPrimPath = "/Render/Shot"
)
def Sphere "Ball"
{
    double radius = 2
}
def Xform "Rig"
{
    double3 xformOp:scale = (%(scale)s)
    uniform token[] xformOpOrder = ["xformOp:scale"]
    def Camera "Cam"
    {
        token projection = "%(projection)s"
        float focalLength = 35
        float horizontalAperture = %(aperture)s
        float verticalAperture = 24
        float horizontalApertureOffset = 3
        float verticalApertureOffset = -2
        float2 clippingRange = (%(near)s, %(far)s)
        double3 xformOp:translate = (1, 3, 12)
        float3 xformOp:rotateXYZ = (-10, 5, 3)
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
    }
}
def Scope "Render"
{
    def RenderSettings "Shot"
    {
        rel camera = </Rig/Cam>
        int2 resolution = (80, 40)
        float pixelAspectRatio = %(pixel)s
        token aspectRatioConformPolicy = "%(policy)s"
    }
}
"""


def conformed_window(window, policy: str, aspect: float):
    """``(centre, size)`` of the film window ``(lower, upper)`` conformed to ``aspect`` by UsdRender's ``policy``."""
    lower, upper = (np.array(v, np.float64) for v in window)
    centre, size = (lower + upper) / 2, upper - lower
    if policy == "expandAperture":
        size = np.maximum(size, [size[1] * aspect, size[0] / aspect])
    elif policy == "cropAperture":
        size = np.minimum(size, [size[1] * aspect, size[0] / aspect])
    elif policy == "adjustApertureWidth":
        size = np.array([size[1] * aspect, size[1]])
    elif policy == "adjustApertureHeight":
        size = np.array([size[0], size[0] / aspect])
    return centre, size  # adjustPixelAspectRatio: the window as it is


@pytest.mark.parametrize("case", [
    {"pixel": 2.0, "policy": "cropAperture"},
    {"pixel": 0.5, "policy": "adjustPixelAspectRatio", "far": "inf"},
    {"scale": "1, 3, 0.5", "policy": "adjustApertureWidth"},
    {"projection": "orthographic", "aperture": 300, "near": -2, "far": "inf", "scale": "2, 1, 2", "pixel": 2.0},
], ids=["pixels_2_crop", "pixels_half_far_inf", "parent_scale", "ortho_behind_scaled"])
def test_drawn_frustum_and_near_plane_are_usds_camera_frustum(tmp_path, case):
    """Every drawn frustum rectangle (the eye's, the far end's, the image plane's, the near clipping plane's), moved
    back into the camera's space by the inverse of USD's local-to-world matrix, lies where ``Gf.Frustum`` of
    ``UsdGeom.Camera.GetCamera`` (its window conformed to ``pixelAspectRatio * 80 / 40`` by the policy) puts the
    corners at that camera-space depth. The whole matrix, scale included, places the film (:mod:`wrt.camera`)."""
    from pxr import Gf, Usd, UsdGeom

    values = {"projection": "perspective", "aperture": 36, "near": 0.5, "far": 1000, "scale": "1, 1, 1", "pixel": 1.0,
              "policy": "expandAperture", **case}
    path = tmp_path / "shot.usda"
    path.write_text(SHOT % values)
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetPrimAtPath("/Rig/Cam")
    frustum = UsdGeom.Camera(prim).GetCamera(Usd.TimeCode.Default()).frustum
    centre, size = conformed_window((frustum.window.GetMin(), frustum.window.GetMax()), values["policy"],
                                    float(values["pixel"]) * 80 / 40)
    frustum.window = Gf.Range2d(Gf.Vec2d(*(centre - size / 2)), Gf.Vec2d(*(centre + size / 2)))
    frustum.SetPosition(Gf.Vec3d(0.0))  # in the camera's own space
    frustum.SetRotation(Gf.Rotation(Gf.Vec3d(1.0, 0.0, 0.0), 0.0))
    to_camera = np.linalg.inv(np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0.0)).T)
    plotter = wrt.preview(wrt.load_usd(path), window_size=(32, 24), show_text=False)
    try:
        drawn = [np.asarray(plotter.actors[a].mapper.dataset.points, np.float64) for a in ("frustum", "near_plane")]
    finally:
        plotter.close()
    rectangles = [*drawn[0].reshape(3, 4, 3), drawn[1][:4]]
    for corners in rectangles:  # top-left, top-right, bottom-right, bottom-left
        local = corners @ to_camera[:3, :3].T + to_camera[:3, 3]
        depth = float(np.mean(-local[:, 2]))
        np.testing.assert_allclose(-local[:, 2], depth, atol=1e-6)  # a plane of equal camera-space depth
        if values["projection"] == "perspective" and abs(depth) < 1e-9:
            np.testing.assert_allclose(local, 0.0, atol=1e-6)  # the apex
            continue
        bottom_left, bottom_right, top_left, top_right = (np.array(c) for c in frustum.ComputeCornersAtDistance(depth))
        np.testing.assert_allclose(local, [top_left, top_right, bottom_right, bottom_left], atol=2e-5 * max(depth, 1))
    np.testing.assert_allclose(np.mean(-(rectangles[3] @ to_camera[:3, :3].T + to_camera[:3, 3])[:, 2]),
                               values["near"], atol=1e-6)  # the near clipping plane, at its camera-space depth


def walked_boxes(bvh, depth):
    """``{box: (depth, SAH share)}`` of the cut of ``bvh`` at ``depth`` (``None``: its leaves), walked down from the
    root; the share is ``A N / sum A N`` of the cut's boxes, ``A`` half the surface area in float64 and ``N`` the
    references below the node."""
    found, stack = [], [(0, 0)]
    while stack:
        node, d = stack.pop()
        if bvh.prim_count[node] > 0 or d == depth:
            below, references = [node], 0
            while below:
                n = below.pop()
                if bvh.prim_count[n] > 0:
                    references += int(bvh.prim_count[n])
                else:
                    below += [int(bvh.left_first[n]), int(bvh.left_first[n]) + 1]
            lower, upper = bvh.lowers[node].astype(np.float64), bvh.uppers[node].astype(np.float64)
            e = upper - lower
            found.append((tuple(np.r_[lower, upper]), d, (e[0] * e[1] + e[1] * e[2] + e[2] * e[0]) * references))
        else:
            stack += [(int(bvh.left_first[node]), d + 1), (int(bvh.left_first[node]) + 1, d + 1)]
    total = sum(cost for _, _, cost in found)
    return {box: (d, cost / total) for box, d, cost in found}


def test_tlas_boxes_are_coloured_by_their_depth_and_sah_share_in_the_walked_tree():
    """A TLAS over instances (one mirrored and stretched) and analytic shapes: at each cut the boxes drawn carry the
    depth and the SAH cost share of the node walked to in the tree's arrays, box for box."""
    rng = np.random.default_rng(7)
    soup = wrt.Mesh("/P/M", rng.uniform(-1, 1, (30, 3)).astype(np.float32), np.arange(30).reshape(10, 3),
                    np.arange(10))
    to_world = np.tile(np.eye(4), (7, 1, 1))
    to_world[:, :3, 3] = rng.uniform(-9.0, 9.0, (7, 3))
    to_world[2, :3, :3] = np.diag([-2.0, 0.5, 1.0])
    balls = [Shape(f"/ball{k}", "sphere", np.diag([0.5, 0.5, 0.5, 1.0])) for k in range(3)]
    for k, ball in enumerate(balls):
        ball.to_world[:3, 3] = [12.0, 3.0 * k, 0.0]
    scene = wrt.Scene(shapes=balls, prototypes=[Prototype("/P", [soup])],
                      instances=Instances.from_transforms(np.zeros(7, int), to_world))
    tlas = get_accelerator(scene, "wrt", "sah", "cpu").bvh
    for depth, color in itertools.product([0, 1, 2, None], ["depth", "sah"]):
        options = {"bvh_leaves": True} if depth is None else {"bvh_depth": depth}
        with warnings.catch_warnings():  # a cut past the deepest leaf says it draws the leaves
            warnings.filterwarnings("ignore", message="BVH depth .* is past the tree's deepest leaf")
            plotter = wrt.preview(scene, bvh_color=color, window_size=(32, 24), show_text=False, **options)
        corners, values = box_data(plotter, "depth" if color == "depth" else "sah_share")
        expected = walked_boxes(tlas, depth)
        drawn = {tuple(np.r_[c.min(axis=0), c.max(axis=0)]): v for c, v in zip(corners, values)}
        assert drawn.keys() == expected.keys(), (depth, color)
        for box, value in drawn.items():
            np.testing.assert_allclose(value, expected[box][0 if color == "depth" else 1], rtol=1e-6)


def test_an_instance_traced_at_another_power_of_two_is_drawn_in_its_own_blas():
    """Beside a world mesh and a prototype of a shape alone (no BLAS), instances scaled by 1e35 and 1e-35 are traced
    in copies of their prototype's BLAS scaled by a power of two, which the drawing undoes: the root box drawn for
    each instance is its prototype's triangle bounds moved by the instance's transform (eight corners, float64)."""
    rng = np.random.default_rng(3)

    def soup(path, n, size):
        points = rng.uniform(-size, size, (3 * n, 3)).astype(np.float32)
        return wrt.Mesh(path, points, np.arange(3 * n).reshape(n, 3), np.arange(n))

    prototypes = [Prototype("/S", [], [Shape("/S/ball", "sphere", np.eye(4))]),
                  Prototype("/A", [soup("/A/M", 15, 1.0)]), Prototype("/B", [soup("/B/M", 25, 2.0)])]
    which = np.array([0, 1, 2, 1, 2, 2])
    to_world = np.tile(np.eye(4), (6, 1, 1))
    to_world[:, :3, 3] = rng.uniform(-20.0, 20.0, (6, 3))
    to_world[4, :3, :3] *= 1e35
    to_world[4, :3, 3] *= 1e35
    to_world[5, :3, :3] = np.diag([1e-35, 2e-35, 1e-35])
    scene = wrt.Scene(meshes=[soup("/W", 20, 3.0)], prototypes=prototypes,
                      instances=Instances.from_transforms(which, to_world))
    for row in range(1, 6):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the far and tiny instances are named by the trace's checks
            plotter = wrt.preview(scene, bvh_depth=0, bvh_instance=row, window_size=(32, 24), show_text=False)
        try:
            drawn = np.asarray(plotter.actors["bvh"].mapper.dataset.points, np.float64)
        finally:
            plotter.close()
        points = prototypes[which[row]].meshes[0].points.astype(np.float64)
        corners = np.array([np.where(bits, points.max(axis=0), points.min(axis=0))
                            for bits in itertools.product([0, 1], repeat=3)])
        expected = corners @ to_world[row, :3, :3].T + to_world[row, :3, 3]
        in_order = [a[np.lexsort(a.T[::-1])] for a in (drawn, expected)]
        np.testing.assert_allclose(*in_order, rtol=1e-6, atol=1e-6 * np.abs(expected).max())


LIGHTS = """#usda 1.0
(
    upAxis = "Y"
)
def Xform "Rig"
{
    double3 xformOp:translate = (1, 2, 3)
    float3 xformOp:rotateXYZ = (20, 30, 40)
    double3 xformOp:scale = (2, 1, 0.5)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ", "xformOp:scale"]
    def RectLight "Rect"
    {
        float inputs:width = 3
        float inputs:height = 1.5
        double3 xformOp:translate = (0.5, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def DiskLight "Disk"
    {
        float inputs:radius = 0.75
        double3 xformOp:translate = (0, 4, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def SphereLight "Ball"
    {
        float inputs:radius = 0.6
        double3 xformOp:translate = (0, -4, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
    def CylinderLight "Tube"
    {
        float inputs:radius = 0.3
        float inputs:length = 2
        double3 xformOp:translate = (4, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
def Mesh "Floor"
{
    int[] faceVertexCounts = [3]
    int[] faceVertexIndices = [0, 1, 2]
    point3f[] points = [(-10, -10, -10), (10, -10, -10), (10, -10, 10)]
}
"""


def test_lights_of_a_stage_are_drawn_at_their_size_under_a_parents_uneven_scale(tmp_path):
    """Lights under a parent turned and scaled (2, 1, 0.5): moved back by the inverse of USD's local-to-world matrix,
    the rect light's outline is its ``width x height`` rectangle in z = 0, the disk's its circle of ``radius``, the
    sphere's three circles lie on the sphere of ``radius`` and the cylinder's tube at ``radius`` about x, ``length``
    long (all read from USD's attributes, not wrt's lights)."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "lights.usda"
    path.write_text(LIGHTS)
    stage = Usd.Stage.Open(str(path))
    scene = wrt.load_usd(path)
    plotter = wrt.preview(scene, window_size=(32, 24), show_text=False)
    try:
        mesh = plotter.actors["lights"].mapper.dataset
        flat, points, owners = np.asarray(mesh.lines), np.asarray(mesh.points, np.float64), mesh.cell_data["light"]
    finally:
        plotter.close()
    lines, k = {}, 0
    for owner in owners:
        lines.setdefault(int(owner), []).append(points[flat[k + 1 : k + 1 + flat[k]]])
        k += flat[k] + 1
    for index, light in enumerate(scene.lights):
        prim = stage.GetPrimAtPath(light.path)
        to_local = np.linalg.inv(np.array(UsdGeom.Xformable(prim).ComputeLocalToWorldTransform(0.0)).T)
        local = [p @ to_local[:3, :3].T + to_local[:3, 3] for p in lines[index]]
        read = {name: prim.GetAttribute(f"inputs:{name}").Get() for name in ("width", "height", "radius", "length")}
        outline = local[0]
        if prim.GetTypeName() == "RectLight":
            np.testing.assert_allclose(sorted(map(tuple, outline[:4, :2].round(9))),
                                       sorted((sx * read["width"] / 2, sy * read["height"] / 2)
                                              for sx in (-1, 1) for sy in (-1, 1)), atol=1e-9)
            np.testing.assert_allclose(outline[:, 2], 0.0, atol=1e-9)
        elif prim.GetTypeName() == "DiskLight":
            np.testing.assert_allclose(np.hypot(outline[:, 0], outline[:, 1]), read["radius"], rtol=1e-9)
            np.testing.assert_allclose(outline[:, 2], 0.0, atol=1e-9)
        elif prim.GetTypeName() == "SphereLight":
            everything = np.concatenate(local)
            np.testing.assert_allclose(np.linalg.norm(everything, axis=1), read["radius"], rtol=1e-6)
        else:
            everything = np.concatenate(local)
            np.testing.assert_allclose(np.hypot(everything[:, 1], everything[:, 2]), read["radius"], rtol=1e-6)
            np.testing.assert_allclose([everything[:, 0].min(), everything[:, 0].max()],
                                       [-read["length"] / 2, read["length"] / 2], atol=1e-9)
    assert sorted(prim.GetTypeName() for prim in map(stage.GetPrimAtPath, (li.path for li in scene.lights))) == [
        "CylinderLight", "DiskLight", "RectLight", "SphereLight"]


def test_the_image_hangs_on_the_image_plane_the_right_way_up():
    """A card fills the top-left quarter of the view of a camera at the origin looking down -Z. The rendered image's
    texel at each corner of the drawn image quad (read back from the texture VTK holds, at the corner's texture
    coordinates) is the card's colour exactly where the ray from the eye through that corner meets the card (closed
    form: it reaches z = -5 at x < 0, y > 0), the background's at the other three: the picture is neither flipped nor
    mirrored."""
    points = np.array([[-50, 0, -5], [0, 0, -5], [0, 50, -5], [-50, 50, -5]], np.float32)
    card = wrt.Mesh("/card", points, np.array([[0, 1, 2], [0, 2, 3]]), np.array([0, 0]), double_sided=True)
    plotter = wrt.preview(wrt.Scene(meshes=[card]), camera=wrt.Camera(), image=True, width=16, height=12,
                          window_size=(32, 24), show_text=False)
    try:
        actor = plotter.actors["image"]
        corners = np.asarray(actor.mapper.dataset.points, np.float64)
        coords = np.asarray(actor.mapper.dataset.active_texture_coordinates, np.float64)
        image = actor.texture.to_image()
        w, h = image.dimensions[:2]
        texels = np.asarray(image.point_data.active_scalars).reshape(h, w, -1)  # VTK's rows: t = 0 first
    finally:
        plotter.close()
    at_card = corners[:, :2] * (-5.0 / corners[:, 2:3])  # where each corner's ray reaches z = -5
    meets = (at_card[:, 0] < 0) & (at_card[:, 1] > 0)
    seen = [tuple(texels[round(t * (h - 1)), round(s * (w - 1))]) for s, t in coords]
    assert meets.sum() == 1
    assert len({seen[k] for k in np.flatnonzero(~meets)}) == 1  # the background, alike at three corners
    assert seen[int(np.argmax(meets))] != seen[int(np.argmin(meets))]


def test_sah_shares_of_boxes_wider_than_float32s_range_are_finite():
    """Two triangles near x = -2e38 and x = +2e38 (past the traced reach, which a warning names): the root box is
    4e38 wide, more than float32 holds. Its SAH cost share, the only box of the cut at depth 0, is 1 (the share of a
    cut of one box); the leaves' are their float64 ``A N / sum A N``. Taken in float32, the root's width was inf, its
    share inf / inf = NaN, and the boxes were drawn in no colour of the bar."""
    half = np.array([[-2e38, 0, 0], [-1.9e38, 1e37, 0], [-2e38, 0, 1e37]])
    points = np.concatenate([half, half * [-1, 1, 1]]).astype(np.float32)
    scene = wrt.Scene(meshes=[wrt.Mesh("/Wide", points, np.arange(6).reshape(2, 3), np.arange(2))])
    camera = wrt.Camera.look_at((0.0, 0.0, 1e38), (0.0, 0.0, 0.0))  # the framing camera would stand past float32
    for options in ({"bvh_depth": 0}, {"bvh_leaves": True}):
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*coordinates past")
            warnings.simplefilter("error", RuntimeWarning)  # numpy's 'overflow encountered in subtract'
            plotter = wrt.preview(scene, camera=camera, builder="sweep_sah", bvh_color="sah", window_size=(32, 24),
                                  show_text=False, show_lights=False, **options)
        corners, shares = box_data(plotter, "sah_share")
        extent = corners.max(axis=1) - corners.min(axis=1)  # float64: 4e38 is no overflow there
        area = extent[:, 0] * extent[:, 1] + extent[:, 1] * extent[:, 2] + extent[:, 2] * extent[:, 0]
        expected = area / area.sum()  # one triangle per leaf; the root: 1
        np.testing.assert_allclose(shares, expected, rtol=1e-6, err_msg=str(options))
