"""Previews with pyvista, rendered off-screen: PNGs from ``wrt preview``, ``to_pyvista`` counts, and the geometry
of what is drawn (frustum, BVH cut, rays) checked against the camera, the tree and the renderer."""

import importlib
import os
import subprocess
import sys
import types
import warnings

import numpy as np
import pytest
from conftest import warp_assets
from PIL import Image as PilImage
from shading_helpers import quad

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

import wrt  # noqa: E402
from wrt.cli import default_scene_path, main  # noqa: E402
from wrt.image import to_srgb8  # noqa: E402
from wrt.instancing import Instances, Prototype  # noqa: E402
from wrt.preview import (  # noqa: E402
    PreviewUnavailable,
    bvh_boxes,
    cluster_vertices,
    frustum_corners,
    import_pyvista,
    sample_rays,
    select_bvh_nodes,
    shape_meshes,
    subtree_prim_counts,
    to_pyvista,
    triangle_colors,
)
from wrt.primitives import Shape  # noqa: E402
from wrt.render import resolve_camera  # noqa: E402
from wrt.trace import get_accelerator  # noqa: E402

preview_module = importlib.import_module("wrt.preview")  # ``wrt.preview`` itself is the function


@pytest.fixture(scope="module")
def room():
    """The bundled default room: 8 meshes with displayColor, one camera."""
    return wrt.load_usd(default_scene_path())


@pytest.fixture(scope="module")
def bunny():
    """warp's bunny: one mesh of 12,200 triangles, no camera."""
    return wrt.load_usd(warp_assets("bunny.usd"))


def scene_path(assets, name):
    return warp_assets("bunny.usd") if name == "bunny" else assets(name)


def summary_text(plotter) -> str:
    """The preview's summary text, its lines unwrapped (a line wrapped to the window goes on indented by two)."""
    return plotter.actors["summary"].GetText(2).replace("\n  ", " ")


def read_png(path) -> np.ndarray:
    with PilImage.open(path) as png:
        return np.asarray(png.convert("RGB")).astype(np.int32)


@pytest.mark.parametrize("name", ["bunny", "cornell_box", "teapot_scene_1000"])
def test_cli_writes_pngs_that_change_with_bvh_depth(assets, tmp_path, name):
    path = scene_path(assets, name)
    pngs = []
    for depth in (1, 5):
        out = tmp_path / f"{name}_{depth}.png"
        args = ["preview", str(path), "--bvh-depth", str(depth), "--rays", "16", "-o", str(out), "--window", "320x240"]
        assert main(args + ["-q"]) == 0
        pngs.append(read_png(out))
    for pixels in pngs:
        assert pixels.shape == (240, 320, 3)
        background = np.all(pixels == 255, axis=-1)  # white
        assert 0.01 < 1.0 - background.mean() < 0.99, "the picture is (nearly) blank"
        assert pixels.std() > 10
    changed = np.any(pngs[0] != pngs[1], axis=-1).mean()
    assert changed > 0.001, "--bvh-depth 1 and 5 drew the same picture"


@pytest.mark.parametrize("name", ["room", "bunny", "cornell_box"])
def test_to_pyvista_counts_match_scene_stats(assets, room, name):
    scene = room if name == "room" else wrt.load_usd(scene_path(assets, name))
    stats = scene.stats()
    blocks = to_pyvista(scene)
    assert isinstance(blocks, pv.MultiBlock)
    assert blocks.n_blocks == stats["meshes"]
    assert sum(b.n_points for b in blocks) == stats["points"]
    assert sum(b.n_cells for b in blocks) == stats["rendered_triangles"]
    assert list(blocks.keys()) == [m.path for m in scene.meshes]
    # Cells are the scene's triangles, in order, with their ids and colours.
    prims = np.concatenate([b.cell_data["prim"] for b in blocks])
    np.testing.assert_array_equal(prims, np.arange(stats["rendered_triangles"]))
    for block, mesh in zip(blocks, scene.meshes):
        np.testing.assert_allclose(block.points, mesh.points)
        np.testing.assert_array_equal(block.regular_faces, mesh.indices)
    np.testing.assert_array_equal(np.concatenate([b.cell_data["color"] for b in blocks]), triangle_colors(scene))


def test_triangle_colors_follow_display_color(room, bunny):
    colors = triangle_colors(room)
    assert colors.shape == (room.stats()["rendered_triangles"], 3) and colors.dtype == np.uint8
    assert len(np.unique(colors, axis=0)) > 3  # the room's meshes differ in colour
    np.testing.assert_array_equal(triangle_colors(bunny), 188)  # no displayColor: the renderer's 0.5 grey in sRGB


def test_triangle_colors_prefer_the_bound_material():
    scene = wrt.Scene.from_triangles(np.eye(3), [[0, 1, 2], [0, 2, 1], [1, 0, 2]])
    scene.meshes[0].colors = np.full((3, 3, 3), 0.5, np.float32)
    scene.meshes[0].material_ids = np.array([0, -1, 1], np.int32)
    red = types.SimpleNamespace(diffuse_color=np.array([1.0, 0.0, 0.0]), diffuse_from_display_color=False)
    display = types.SimpleNamespace(diffuse_color=np.array([0.0, 0.0, 1.0]), diffuse_from_display_color=True)
    scene.materials = [red, display]
    np.testing.assert_array_equal(triangle_colors(scene), [[255, 0, 0], [188, 188, 188], [188, 188, 188]])


def test_frustum_points_where_the_camera_looks_and_holds_the_rays(room):
    cam = resolve_camera(room, None)
    width, height = 64, 48
    eye = cam.to_world[:3, 3]
    view = -cam.to_world[:3, 2] / np.linalg.norm(cam.to_world[:3, 2])  # cameras look down -Z
    corners = frustum_corners(cam, width, height, 5.0)
    centre = corners.mean(axis=0) - eye
    np.testing.assert_allclose(centre / np.linalg.norm(centre), view, atol=1e-6)  # no film offset here
    np.testing.assert_allclose((corners - eye) @ view, 5.0, rtol=1e-6)
    # Every hit lies inside the frustum; ray 0 goes through the top-left of the film.
    origins, directions, t = sample_rays(room, cam, width, height, 48)
    hit = np.isfinite(t)
    assert hit.sum() > 40
    p = origins[hit] + t[hit, None] * directions[hit]
    depth = (p - eye) @ view
    tl, tr, _, bl = (eye + depth[:, None] * (c - eye) / 5.0 for c in corners)
    u = np.einsum("ij,ij->i", p - tl, tr - tl) / np.einsum("ij,ij->i", tr - tl, tr - tl)
    v = np.einsum("ij,ij->i", p - tl, bl - tl) / np.einsum("ij,ij->i", bl - tl, bl - tl)
    assert np.all((u > 0) & (u < 1) & (v > 0) & (v < 1))
    assert u[0] < 0.2 and v[0] < 0.2


def test_sample_rays_are_the_renderers_rays(room):
    """With a ray grid equal to the image, the preview's rays end where the renderer's depth AOV says."""
    width, height = 8, 6
    _, _, t = sample_rays(room, resolve_camera(room, None), width, height, width * height)
    depth = wrt.render(room, width=width, height=height, device="cpu").aovs["depth"].reshape(-1)
    np.testing.assert_array_equal(np.isfinite(t), np.isfinite(depth))
    np.testing.assert_allclose(t[np.isfinite(t)], depth[np.isfinite(depth)], rtol=1e-6)


def test_sample_rays_pass_back_faces_as_the_renderer_does():
    """A single-sided quad seen from behind hides nothing from the renderer, so the preview's rays go on to the
    floor too; they stopped on the quad's back (t = 4 instead of 5)."""
    floor = quad((0, 0, 0), (20, 0, 0), (0, 20, 0), name="/floor")
    back = quad((0, 0, 1), (0, 4, 0), (4, 0, 0), name="/back", double_sided=False)  # faces -Z, away from the camera
    scene = wrt.Scene(meshes=[floor, back])
    cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), up=(0, 1, 0), fov_y_deg=20)
    width, height = 8, 6
    _, _, t = sample_rays(scene, cam, width, height, width * height)
    depth = wrt.render(scene, camera=cam, width=width, height=height, device="cpu").aovs["depth"].reshape(-1)
    assert np.isfinite(depth).all()
    np.testing.assert_allclose(t, depth, rtol=1e-6)


@pytest.mark.parametrize("cut", [0, 3, 8, 100, "leaves"])
def test_bvh_cut_partitions_the_triangles_and_its_boxes_enclose_them(bunny, cut):
    bvh = get_accelerator(bunny, "wrt", "sah", "cpu").bvh
    nodes = select_bvh_nodes(bvh, None if cut == "leaves" else cut, leaves=cut == "leaves")
    depths = bvh.depths()
    if cut == "leaves":
        np.testing.assert_array_equal(nodes, np.flatnonzero(bvh.prim_count > 0))
    elif cut == 0:
        np.testing.assert_array_equal(nodes, [0])
    else:
        assert np.all(depths[nodes] <= cut)
    assert subtree_prim_counts(bvh)[nodes].sum() == bvh.num_prims
    points, indices = bunny.triangles()
    owner = np.full(bvh.num_prims, -1)
    for node in nodes:
        stack = [node]
        while stack:
            n = stack.pop()
            if bvh.prim_count[n] > 0:
                slots = bvh.prim_ids[bvh.left_first[n] : bvh.left_first[n] + bvh.prim_count[n]]
                assert np.all(owner[slots] == -1), "a triangle lies under two shown boxes"
                owner[slots] = node
            else:
                stack += [bvh.left_first[n], bvh.left_first[n] + 1]
    assert np.all(owner >= 0), "a triangle lies under no shown box"
    corners = points[indices]  # (T, 3, 3)
    assert np.all(corners >= bvh.lowers[owner][:, None, :] - 1e-6)
    assert np.all(corners <= bvh.uppers[owner][:, None, :] + 1e-6)


def test_bvh_summary_counts_one_node_in_the_singular():
    """A one-triangle scene's BVH is a single leaf, which the preview's title called "1 nodes"."""
    from wrt.preview import _add_bvh

    scene = wrt.Scene(meshes=[wrt.Mesh("/T", np.eye(3, dtype=np.float32), np.array([[0, 1, 2]], np.int32), [0])])
    bvh = get_accelerator(scene, "wrt", "sah", "cpu").bvh
    assert bvh.num_nodes == 1
    plotter = types.SimpleNamespace(add_mesh=lambda *args, **kwargs: None)
    assert _add_bvh(plotter, bvh, None, "depth", 100)[0].startswith("1 node, depth 0: leaves, 1 box")


def test_preview_title_says_when_the_boxes_are_capped(bunny):
    """Above max_boxes an even subset of the boxes is drawn, said only in the text in the view: the title, which
    wrt preview prints and which a preview with show_text=False still has, said nothing of it."""
    leaves = int((get_accelerator(bunny, "wrt", "sah", "cpu").bvh.prim_count > 0).sum())
    plotter = wrt.preview(bunny, bvh_leaves=True, max_boxes=100, window_size=(64, 48), show_text=False)
    try:
        drawn = plotter.actors["bvh"].mapper.dataset.n_cells // 12
        title = plotter.title
    finally:
        plotter.close()
    assert drawn == 100 < leaves
    assert f"showing 100 of {leaves:,} BVH boxes" in title, title
    plotter = wrt.preview(bunny, bvh_depth=2, max_boxes=100, window_size=(64, 48), show_text=False)
    try:
        assert "boxes" not in plotter.title, plotter.title  # all four drawn: nothing to say
    finally:
        plotter.close()


def test_bvh_boxes_polydata(bunny):
    bvh = get_accelerator(bunny, "wrt", "sah", "cpu").bvh
    nodes = select_bvh_nodes(bvh, 4)
    boxes = bvh_boxes(bvh, nodes, "depth")
    assert boxes.n_cells == 12 * len(nodes) and boxes.n_points == 8 * len(nodes)
    np.testing.assert_allclose(boxes.points.min(axis=0), bvh.lowers[0], atol=1e-6)
    np.testing.assert_allclose(boxes.points.max(axis=0), bvh.uppers[0], atol=1e-6)
    sah = bvh_boxes(bvh, nodes, "sah").cell_data["sah_share"]
    assert np.isclose(sah.sum() / 12, 1.0) and np.all(sah > 0)
    leaves = select_bvh_nodes(bvh, leaves=True)
    few = bvh_boxes(bvh, leaves, "depth", max_boxes=100)
    assert few.n_cells == 1200 and few.field_data["boxes_total"][0] == len(leaves)
    with pytest.raises(ValueError, match="valid: depth, sah"):
        bvh_boxes(bvh, nodes, "rainbow")


def test_bvh_boxes_corners_are_the_tree_boxes_bit_for_bit(bunny):
    """A shown box's upper corner was computed as ``lower + (upper - lower)``, which float32 rounds off ``upper`` by an
    ulp (362 of the bunny's leaf bounds): the preview's boxes did not compare equal to ``FlatBvh.lowers``/``uppers``."""
    bvh = get_accelerator(bunny, "wrt", "sah", "cpu").bvh
    leaves = select_bvh_nodes(bvh, leaves=True)
    corners = np.asarray(bvh_boxes(bvh, leaves, "depth").points).reshape(-1, 8, 3)
    np.testing.assert_array_equal(corners.min(axis=1), bvh.lowers[leaves])
    np.testing.assert_array_equal(corners.max(axis=1), bvh.uppers[leaves])
    # Every corner takes each coordinate from the box's lower or upper bound.
    assert np.all((corners == bvh.lowers[leaves][:, None, :]) | (corners == bvh.uppers[leaves][:, None, :]))


def test_preview_boxes_are_those_of_the_presplit_tree_trace_builds():
    """The README and ``help(wrt.preview)`` name the tree whose boxes are drawn: ``build_bvh`` over
    ``Scene.triangles()``, with ``presplit=6`` for ``sah`` (a UV sphere's pole slivers make it differ from
    ``presplit=0``'s)."""
    from wrt.procedural import displaced_sphere

    points, indices = displaced_sphere(2000)
    plotter = wrt.preview(wrt.Scene.from_triangles(points, indices), bvh_leaves=True, show_text=False)
    corners = np.asarray(plotter.actors["bvh"].mapper.dataset.points).reshape(-1, 8, 3)
    plotter.close()
    shown = {tuple(c) for c in np.hstack([corners.min(axis=1), corners.max(axis=1)])}

    def leaf_boxes(tree):
        leaf = tree.prim_count > 0
        return {tuple(b) for b in np.hstack([tree.lowers[leaf], tree.uppers[leaf]])}

    assert shown == leaf_boxes(wrt.build_bvh(points, indices, "sah", presplit=6))
    assert shown != leaf_boxes(wrt.build_bvh(points, indices, "sah"))


def test_cluster_vertices_meets_the_budget(bunny):
    points, indices = bunny.triangles()
    colors = np.arange(len(indices))[:, None].repeat(3, axis=1)
    p, i, c = cluster_vertices(points, indices, colors, 2000)
    assert 200 < len(i) <= 2000
    assert i.min() >= 0 and i.max() < len(p)
    assert np.all((i[:, 0] != i[:, 1]) & (i[:, 1] != i[:, 2]) & (i[:, 0] != i[:, 2]))
    rotated = np.take_along_axis(i, (np.argmin(i, axis=1)[:, None] + np.arange(3)) % 3, axis=1)
    assert len(np.unique(rotated, axis=0)) == len(i)  # no two alike: the same corners in the same cyclic order
    assert np.all(np.diff(c[:, 0]) > 0)  # surviving triangles keep their attributes, in order
    lower, upper = points.min(axis=0), points.max(axis=0)
    assert np.all(p >= lower - 1e-5) and np.all(p <= upper + 1e-5)


@pytest.mark.parametrize("budget", [1, 3, 7])
def test_cluster_vertices_keeps_some_triangles_on_a_tiny_budget(bunny, budget):
    """Grids coarse enough for a budget of a few triangles collapse every triangle: the preview drew nothing."""
    points, indices = bunny.triangles()
    colors = np.arange(len(indices))[:, None]
    p, i, c = cluster_vertices(points, indices, colors, budget)
    assert 1 <= len(i) <= budget and i.max() < len(p)
    np.testing.assert_array_equal(p[i], points[indices[c[:, 0]]])  # source triangles, with their own attributes


def test_preview_draws_everything_and_says_when_it_simplifies(room):
    plotter = wrt.preview(
        room, bvh_leaves=True, bvh_color="sah", rays=20, image=True, max_triangles=500, width=64, height=48,
        window_size=(320, 240),
    )
    try:
        assert isinstance(plotter, pv.Plotter)
        for actor in ("frustum", "eye", "bvh", "rays_hit", "hits", "image", "summary"):
            assert actor in plotter.actors, actor
        assert "scene" in plotter.actors or "scene_double_sided" in plotter.actors
        assert "simplified for display" in plotter.title and "of 1,070 triangles" in plotter.title
        meshes = [plotter.actors[a].mapper.dataset for a in ("scene", "scene_double_sided") if a in plotter.actors]
        assert sum(m.n_cells for m in meshes) <= 500
        pixels = plotter.screenshot()
        assert pixels.shape == (240, 320, 3) and pixels.std() > 10
    finally:
        plotter.close()


INSTANCED_GROUND = """#usda 1.0
(
    upAxis = "Y"
)
def Xform "World"
{
    def Mesh "Ground"
    {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        point3f[] points = [(-5, 0, -5), (5, 0, -5), (5, 0, 5), (-5, 0, 5)]
        color3f[] primvars:displayColor = [(1, 0, 0)]
    }
    def PointInstancer "Tets"
    {
        rel prototypes = [</World/Tets/Tet>]
        int[] protoIndices = [0, 0, 0]
        point3f[] positions = [(0, 1, 0), (2, 1, 0), (4, 1, 0)]
        def Mesh "Tet"
        {
            int[] faceVertexCounts = [3, 3, 3, 3]
            int[] faceVertexIndices = [0, 1, 2, 0, 1, 3, 0, 2, 3, 1, 2, 3]
            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
        }
    }
}
"""


def test_preview_of_instances_over_the_budget_shows_what_fits(tmp_path):
    """2 ground triangles + 3 instances of 4: over 4x a budget of 3, and not even one instance fits beside the ground.
    The ground alone is drawn, in its colour (preview crashed: per-triangle colours still held the prototype's)."""
    path = tmp_path / "instanced.usda"
    path.write_text(INSTANCED_GROUND)
    scene = wrt.load_usd(path)
    assert scene.stats()["rendered_triangles"] == 14 and len(scene.instances) == 3
    plotter = wrt.preview(scene, max_triangles=3, window_size=(64, 48))
    try:
        assert "showing 0 of 3 instances" in plotter.title
        mesh = plotter.actors["scene"].mapper.dataset
        assert mesh.n_cells == 2
        np.testing.assert_array_equal(mesh.cell_data["color"], [[255, 0, 0]] * 2)
    finally:
        plotter.close()


def test_preview_rejects_bad_arguments(room):
    with pytest.raises(ValueError, match="not both"):
        wrt.preview(room, bvh_depth=2, bvh_leaves=True)
    with pytest.raises(ValueError, match="valid: depth, sah"):
        wrt.preview(room, bvh_depth=2, bvh_color="rainbow")
    for rays in (-1, 10**8, True):  # 10**8 rays: gigabytes of ray buffers and 10**8 lines to draw
        with pytest.raises(ValueError, match="rays must be an integer from 0 to 1,000,000"):
            wrt.preview(room, rays=rays)
    with pytest.raises(ValueError, match="no camera at"):
        wrt.preview(room, camera="/nope")
    with pytest.raises(TypeError, match="wrt.Scene or a USD file path"):
        wrt.preview(42)
    # A negative budget failed with "math domain error" or numpy's "Number of samples, -1", 2.5 with a TypeError,
    # 0 drew nothing; an unknown builder or device passed unless boxes, rays or the image were asked for.
    for options, needle in (
        (dict(max_triangles=-5), "max_triangles must be a positive integer"),
        (dict(max_triangles=2.5), "max_triangles must be a positive integer"),
        (dict(max_triangles=0), "max_triangles must be a positive integer"),
        (dict(max_boxes=-1, bvh_leaves=True), "max_boxes must be a positive integer"),
        (dict(bvh_depth=True), "bvh_depth must be a non-negative integer"),
        (dict(width=True), "width must be a positive integer, got True"),  # a 1-pixel film, where render refuses it
        (dict(builder="octree"), "unknown BVH builder 'octree'"),
        (dict(device="cuda:7"), "unknown or unavailable device 'cuda:7'"),
    ):
        with pytest.raises(ValueError, match=needle):
            wrt.preview(room, **options)
    for window in ((16385, 100), (0, 10), (10,), "64x48", (64.0, 48)):  # 16385 wide: a blank picture before
        with pytest.raises(ValueError, match="window"):
            wrt.preview(room, window_size=window)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--camera", "/nope", "-o", "x.png"], "no camera at '/nope'"),
        (["-o", "x.jpg"], "previews are written as .png"),
        (["--window", "12x"], "is not WIDTHxHEIGHT"),
        (["--bvh-depth", "2", "--bvh-leaves"], "not allowed with"),
        (["--rays", "-3"], "must be an integer from 0 to 1,000,000, got -3"),
        (["--rays", "100000000", "-o", "x.png"], "must be an integer from 0 to 1,000,000"),
        # Refused before the scene is read: the missing file is not reached (a long load was wasted before).
        (["no/such/scene.usda", "--rays", "1000001"], "--rays: must be an integer from 0 to 1,000,000"),
        (["--window", "0x5"], "1 to 16384 pixels per side"),
        (["--window", "100000x100000"], "1 to 16384 pixels per side"),  # VTK aborted allocating the picture
    ],
)
def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, capsys, monkeypatch, args, message):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["preview", *args, "-q"])
    except SystemExit as e:  # argparse errors leave through parser.exit
        code = e.code
    assert code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and message in errors[0]
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("output", ["shots", "shots/"])
def test_cli_output_that_is_a_folder_is_named_as_one(tmp_path, capsys, monkeypatch, output):
    """-o FOLDER said 'cannot write shots: previews are written as .png', as if the name lacked a suffix."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "shots").mkdir()
    try:
        code = main(["preview", "-o", output, "-q"])
    except SystemExit as e:
        code = e.code
    assert code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert errors == ["wrt: error: cannot write shots: it is a directory"]
    assert not list((tmp_path / "shots").iterdir())


def test_cli_bvh_color_without_boxes_is_warned_about(tmp_path, capsys):
    """--bvh-color sah alone drew no boxes to colour, without a word (the boxes come with --bvh-depth or
    --bvh-leaves)."""
    warning = ("wrt: warning: --bvh-color sah colours BVH boxes, and none are drawn without --bvh-depth K or "
               "--bvh-leaves")
    for extra, warns in (([], True), (["--bvh-leaves"], False), (["--bvh-depth", "1"], False)):
        out = tmp_path / f"{len(extra)}.png"
        assert main(["preview", "--bvh-color", "sah", *extra, "-o", str(out), "--window", "64x48", "-q"]) == 0
        warned = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: warning:")]
        assert warned == ([warning] if warns else []), extra
        assert out.exists()


def test_cli_without_a_display_checks_its_default_output_before_the_work(tmp_path, capsys, monkeypatch):
    """Without a display and without -o the preview goes to ./preview.png, chosen only after the load and the drawing
    and never checked: a folder of that name failed at the very end, in Python's words ('[Errno 21] Is a directory:
    '.preview.png.123.0.partial.png' -> 'preview.png''), after all the work."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "preview.png").mkdir()
    monkeypatch.setattr(preview_module, "has_display", lambda: False)
    monkeypatch.setattr(wrt, "load_usd", lambda *a, **k: pytest.fail("the scene was loaded before the output check"))
    assert main(["preview", "--window", "64x48", "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "preview.png: it is a directory" in errors[0] and "-o" in errors[0], errors
    assert [p.name for p in tmp_path.iterdir()] == ["preview.png"]


def test_cli_with_pyvista_off_screen_set_writes_the_png_and_opens_no_window(tmp_path, capsys, monkeypatch):
    """pyvista's own switch for off-screen drawing (PYVISTA_OFF_SCREEN=true, read into pyvista.OFF_SCREEN) was
    overridden: where a display answered, wrt preview asked pyvista for a window (off_screen=False) all the same."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(preview_module, "has_display", lambda: True)
    monkeypatch.setattr(pv, "OFF_SCREEN", True)
    monkeypatch.setattr(pv.Plotter, "show", lambda *a, **k: pytest.fail("a window was opened"))
    path = tmp_path / "tri.usda"
    path.write_text('#usda 1.0\ndef Mesh "Tri"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = '
                    '[0, 1, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    assert main(["preview", str(path), "--window", "64x48"]) == 0
    assert read_png(tmp_path / "preview.png").shape[:2] == (48, 64)
    assert "PYVISTA_OFF_SCREEN" in capsys.readouterr().err


@pytest.mark.parametrize("usda", ["#usda 1.0\n", '#usda 1.0\ndef SphereLight "L"\n{\n}\n'])
def test_preview_of_a_scene_with_nothing_to_draw_says_so_in_its_own_words(tmp_path, usda):
    """An empty stage, or one of lights alone, drew an empty frustum without a word, and with --rays warned in the
    words of a render it never made: 'nothing to render (no triangles, and the depth integrator shows no light); the
    image is background only' (the depth integrator being that of the renderer its sample rays are traced with)."""
    path = tmp_path / "nothing.usda"
    path.write_text(usda)
    scene = wrt.load_usd(path)
    for rays in (0, 5):
        with pytest.warns(UserWarning) as caught:
            plotter = wrt.preview(scene, rays=rays, window_size=(64, 48))
        plotter.close()
        messages = [str(w.message) for w in caught]
        assert len(messages) == 1 and "nothing.usda: nothing to draw" in messages[0], messages
        assert "integrator" not in messages[0] and "image" not in messages[0], messages


def test_missing_pyvista_says_how_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "pyvista", None)
    with pytest.raises(PreviewUnavailable, match=r"pip install 'wrt\[preview\]'"):
        import_pyvista()


@pytest.mark.parametrize("output", [[], ["-o", "view.png"]])
def test_cli_without_pyvista_says_how_to_install_it_with_status_1(tmp_path, capsys, monkeypatch, output):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setitem(sys.modules, "pyvista", None)
    assert main(["preview", "--window", "64x48", "-q", *output]) == 1
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "pip install 'wrt[preview]'" in errors[0], errors
    assert list(tmp_path.iterdir()) == []


def test_no_offscreen_backend_is_a_clear_error_not_a_crash(monkeypatch):
    monkeypatch.setattr(preview_module, "_backend", None)
    monkeypatch.setattr(preview_module, "has_display", lambda: False)
    monkeypatch.setattr(preview_module, "_PROBE", "import sys; sys.exit(3)")  # as if VTK had crashed
    monkeypatch.delenv("VTK_DEFAULT_OPENGL_WINDOW", raising=False)
    with pytest.raises(PreviewUnavailable, match="apt-get install libegl1"):
        preview_module.offscreen_backend()


def test_a_failing_window_class_set_by_the_user_is_named(monkeypatch):
    """With $VTK_DEFAULT_OPENGL_WINDOW set, only that class is tried; where it fails the message told the user to
    install EGL or OSMesa (installed already) and not that their setting was the one tried."""
    monkeypatch.setattr(preview_module, "_backend", None)
    monkeypatch.setattr(preview_module, "has_display", lambda: False)
    monkeypatch.setattr(preview_module, "_PROBE", "import sys; sys.exit(3)")
    monkeypatch.setenv("VTK_DEFAULT_OPENGL_WINDOW", "vtkNoSuchRenderWindow")
    with pytest.raises(PreviewUnavailable, match=r"VTK_DEFAULT_OPENGL_WINDOW=vtkNoSuchRenderWindow \(set in the "
                       r"environment\) does not render .*unset it.*apt-get install"):
        preview_module.offscreen_backend()


def test_import_wrt_does_not_import_pyvista():
    code = "import sys, wrt; assert callable(wrt.preview); sys.exit('pyvista' in sys.modules or 'vtk' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], timeout=300).returncode == 0


def test_cli_without_a_working_backend_fails_cleanly(tmp_path):
    """Force VTK's OSMesa window: where libOSMesa is missing VTK would crash; wrt must answer with one line."""
    env = dict(os.environ, VTK_DEFAULT_OPENGL_WINDOW="vtkOSOpenGLRenderWindow")
    env.pop("DISPLAY", None)
    cmd = [sys.executable, "-m", "wrt.cli", "preview", "-o", str(tmp_path / "p.png"), "--window", "64x48", "-q"]
    result = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
    if result.returncode == 0:  # OSMesa is installed here: then it simply works
        assert (tmp_path / "p.png").is_file()
        return
    assert result.returncode == 1, result.stderr
    errors = [line for line in result.stderr.splitlines() if line.startswith("wrt: error")]
    assert len(errors) == 1 and "apt-get install" in errors[0]


def test_preview_and_to_pyvista_draw_a_mesh_replaced_since_the_last_look(tmp_path):
    """Replacing a mesh is noticed at the next trace or render; a preview and to_pyvista read the scene's cached
    triangles and bounds without that check, and drew a replaced prototype mesh (and the scene's frame) where it had
    been, beside BVH boxes of the new one."""
    import dataclasses

    path = tmp_path / "instanced.usda"
    path.write_text(INSTANCED_GROUND)
    scene = wrt.load_usd(path)
    before = to_pyvista(scene)
    tet = scene.prototypes[0].meshes[0]
    scene.prototypes[0].meshes[0] = dataclasses.replace(tet, points=tet.points + np.float32([0, 10, 0]))
    after = to_pyvista(scene)
    np.testing.assert_allclose(after[1].points, before[1].points + [0, 10, 0])  # the first instance's block
    plotter = wrt.preview(scene, window_size=(64, 48))
    try:
        drawn = plotter.actors["scene"].mapper.dataset
        assert drawn.bounds[3] == pytest.approx(12.0)  # the moved tets reach y = 1 + 10 + 1
    finally:
        plotter.close()


def test_to_pyvista_blocks_own_their_arrays(tmp_path):
    """pyvista wraps numpy arrays without copying: editing a block of to_pyvista in place (``block.points[:, 1] +=
    3``, its ``face_id`` values) wrote through VTK into the scene's points and face ids, read-only since the trace, and
    into its cached triangles (an instance's block), behind the caches, which kept the old tree."""
    path = tmp_path / "instanced.usda"
    path.write_text(INSTANCED_GROUND)
    scene = wrt.load_usd(path)
    wrt.trace(scene, [(0, 5, 0)], [(0, -1, 0)])
    points = [m.points.copy() for m in scene.meshes]
    triangles = scene.triangles()[0].copy()
    blocks = to_pyvista(scene)
    for k in range(blocks.n_blocks):
        blocks[k].points[:, 1] += 3.0
        blocks[k].cell_data["face_id"][:] = 7
    for mesh, before in zip(scene.meshes, points):
        np.testing.assert_array_equal(mesh.points, before)
        assert not (mesh.face_ids == 7).any()
    np.testing.assert_array_equal(scene.triangles()[0], triangles)


def test_preview_draws_points_as_spheres_and_says_when_shapes_are_left_out(tmp_path, monkeypatch):
    """A Points prim is drawn as its spheres (instances of a unit sphere); past the shape budget the title says how
    many of them are shown (they were cut to the budget without a word), spread over the row: the two at its ends."""
    path = tmp_path / "points.usda"
    path.write_text('#usda 1.0\ndef Points "P"\n{\n    point3f[] points = [(0, 0, 0), (2, 0, 0), (4, 0, 0)]\n'
                    '    float[] widths = [1] (interpolation = "constant")\n}\n')
    scene = wrt.load_usd(path)
    monkeypatch.setattr(preview_module, "SHAPE_BUDGET", 2)
    plotter = wrt.preview(scene, window_size=(64, 48))
    try:
        assert "showing 2 of 3 analytic shapes" in plotter.title
        mesh = plotter.actors["shapes"].mapper.dataset
        np.testing.assert_allclose(mesh.bounds, [-0.5, 4.5, -0.5, 0.5, -0.5, 0.5], atol=1e-6)
    finally:
        plotter.close()


def test_to_pyvista_names_blocks_in_linear_work(monkeypatch):
    """Each block's name was checked against ``MultiBlock.keys()``, which asks VTK for every name so far: quadratic in
    the meshes (2,000 meshes took 88 s, 81 s of it in ``keys``; 20k robot links would take hours). Names stay unique:
    a path given twice gets ``#k``."""
    lookups = []
    real = pv.MultiBlock.get_block_name
    monkeypatch.setattr(pv.MultiBlock, "get_block_name", lambda self, i: lookups.append(i) or real(self, i))
    tri = np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]])
    meshes = [wrt.Mesh(points=tri + [k, 0, 0], indices=np.int32([[0, 1, 2]]), face_ids=np.zeros(1, np.int32),
                       path=f"/m{k}" if k != 299 else "/m0") for k in range(300)]
    blocks = to_pyvista(wrt.Scene(meshes=meshes))
    assert len(lookups) < 300  # one lookup per pair of blocks before: 44,850
    monkeypatch.undo()
    assert blocks.keys() == [f"/m{k}" for k in range(299)] + ["/m0#299"]


@pytest.mark.parametrize("scale", [1e-4, 1e3])
def test_frustum_and_image_plane_scale_with_a_scaled_camera(scale):
    """A scene and its camera scaled together (a units change on a common parent) render the same image, so the
    preview must draw the same picture at that scale. The clipping range is camera-space depth and was taken as world
    depth: at 1e-4 the image plane and the frustum's end were drawn 250 times the scene's size away (at the near
    plane, 0.1 world units, instead of 80 % of the way to the hits, 4e-4); at 1e3 the frustum ended at depth 20, a
    250th of the way to the floor."""
    drawn = {}
    for s in (1.0, scale):
        floor = quad((0, 0, 0), (4 * s, 0, 0), (0, 4 * s, 0), name="/floor")
        cam = wrt.Camera.look_at(eye=(0, 0, 5), target=(0, 0, 0), fov_y_deg=30, clipping_range=(0.1, 20))
        cam.to_world = np.diag([s, s, s, 1.0]) @ cam.to_world
        plotter = wrt.preview(wrt.Scene(meshes=[floor]), camera=cam, image=True, rays=9, width=32, height=24,
                              window_size=(64, 48))
        try:
            drawn[s] = {a: np.asarray(plotter.actors[a].mapper.dataset.points, np.float64) / s
                        for a in ("image", "frustum", "rays_hit", "near_plane")}
        finally:
            plotter.close()
    for actor, points in drawn[1.0].items():
        np.testing.assert_allclose(drawn[scale][actor], points, atol=1e-5, err_msg=actor)
    np.testing.assert_allclose(drawn[1.0]["image"][:, 2], 1.0, atol=1e-6)  # 80 % of the way to the floor at depth 5


def test_cli_writes_a_png_named_in_capitals(tmp_path):
    """``-o VIEW.PNG`` passed the .png check, then pyvista's screenshot refused it ("Unsupported extension .PNG")
    after the load, the trace and the drawing: exit 2."""
    out = tmp_path / "VIEW.PNG"
    assert main(["preview", "-o", str(out), "--window", "64x48", "-q"]) == 0
    pixels = read_png(out)
    assert pixels.shape == (48, 64, 3) and pixels.std() > 10
    assert [p.name for p in tmp_path.iterdir()] == ["VIEW.PNG"]  # no temporary file left beside it


def ball(x: float, proto: str = "", **options) -> Shape:
    """A sphere of radius 0.5 at ``(x, 0, 0)``."""
    to_world = np.diag([0.5, 0.5, 0.5, 1.0])
    to_world[0, 3] = x
    return Shape(f"{proto}/ball{x:g}", "sphere", to_world, **options)


def test_shapes_show_the_colour_the_renderer_gives_them():
    """Analytic shapes were drawn in their displayColor, or grey without one, whatever material they were bound to:
    the 1,000 spheres of usd-wg's simpleAssetScene were drawn grey (188) where the render shows their material's
    231. Each shape's drawn colour must be the renderer's albedo at its centre: a material's constant, a material's
    scale on the primvar, an instance's colour under either."""
    materials = [wrt.Material(diffuse_color=(0.8, 0.05, 0.05)),
                 wrt.Material(diffuse_from_display_color=True, color_primvar_scale=(0.5, 0.5, 0.5))]
    blue, green = (0.1, 0.2, 0.9), (0.1, 0.7, 0.2)
    shapes = [ball(-3, material_id=0), ball(-1, color=blue, material_id=0), ball(1, color=blue, material_id=1),
              ball(3, color=blue)]
    prototypes = [Prototype("/P0", [], [ball(0, "/P0")]), Prototype("/P1", [], [ball(0, "/P1", material_id=1)])]
    to_world = np.tile(np.eye(4), (3, 1, 1))
    to_world[:, 0, 3] = (5, 7, 9)
    instances = Instances.from_transforms([0, 1, 1], to_world, colors=[green, green, (np.nan,) * 3])
    scene = wrt.Scene(shapes=shapes, prototypes=prototypes, instances=instances, materials=materials)
    xs = np.array([-3, -1, 1, 3, 5, 7, 9])
    cam = wrt.Camera.orthographic(eye=(3, 0, 10), target=(3, 0, 0), height=1.0)  # 14 units wide
    albedo = wrt.render(scene, camera=cam, width=140, height=10, integrator="albedo").rgb
    expected = to_srgb8(albedo[5, np.int64((xs + 4) * 10)])  # the pixel column at each centre
    drawn = shape_meshes(scene)
    centres = drawn.cell_centers().points[:, 0]
    for x, colour in zip(xs, expected):
        cells = drawn.cell_data["color"][np.abs(centres - x) < 0.5]
        assert len(cells) and np.all(cells == colour), f"x = {x}: drawn {np.unique(cells, axis=0)}, rendered {colour}"
    assert len(np.unique(expected, axis=0)) == 6  # red twice; blue, half blue, green, half green, grey


def test_single_sided_shapes_are_culled_from_behind():
    """A single-sided Plane seen from behind is invisible to the renderer (its rays pass its back) but was drawn: the
    preview showed a wall where the render shows the background. Seen through the camera, the preview is empty too."""
    plane = Shape("/plane", "plane", np.diag([2.0, 2.0, 1.0, 1.0]), double_sided=False)  # faces +Z
    scene = wrt.Scene(shapes=[plane])
    for z, visible in ((5.0, True), (-5.0, False)):
        cam = wrt.Camera.look_at(eye=(0, 0, z), target=(0, 0, 0), fov_y_deg=40)
        depth = wrt.render(scene, camera=cam, width=32, height=24, integrator="depth").aovs["depth"]
        assert np.isfinite(depth).any() == visible
        plotter = wrt.preview(scene, camera=cam, width=32, height=24, window_size=(32, 24), show_text=False)
        try:
            for actor in ("frustum", "eye", "near_plane"):  # the camera's own outlines, seen from the eye
                plotter.remove_actor(actor)
            plotter.camera_position = [(0, 0, z), (0, 0, 0), (0, 1, 0)]
            plotter.camera.view_angle = 40
            drawn = ~np.all(plotter.screenshot() == 255, axis=-1)  # not the white background
        finally:
            plotter.close()
        assert drawn.any() == visible, f"seen from z = {z}"


def test_title_counts_the_shapes_and_instances(tmp_path):
    """The title counted non-instanced meshes alone: "0 triangles in 0 meshes" for a stage of gprims, and for
    instanced scenes (teapotScene: "2,472,000 triangles in 0 meshes")."""
    gprims = wrt.Scene(shapes=[ball(0), ball(2)])
    path = tmp_path / "instanced.usda"
    path.write_text(INSTANCED_GROUND)
    for scene, words in ((gprims, "scene, 2 analytic shapes"),
                         (wrt.load_usd(path), "14 triangles in 1 mesh, 3 instances of 1 prototype")):
        plotter = wrt.preview(scene, window_size=(64, 48))
        try:
            assert plotter.title.endswith(words)
        finally:
            plotter.close()


def test_summary_says_when_the_boxes_are_the_top_level_tree(bunny):
    """With one analytic shape beside the bunny's 12,200 triangles, the boxes drawn are the TLAS's two leaves (the
    bunny's meshes as one entry, the ball); the text called them the BVH's leaves, as if the bunny had two."""
    import dataclasses

    with_ball = dataclasses.replace(bunny, shapes=[ball(0)])
    for scene, words in ((bunny, "BVH (sah) "), (with_ball, "TLAS (sah) ")):
        plotter = wrt.preview(scene, bvh_leaves=True, window_size=(64, 48))
        try:
            summary = summary_text(plotter).splitlines()
            assert any(line.startswith(words) for line in summary), summary
        finally:
            plotter.close()


def test_summary_of_the_top_level_tree_counts_its_entries_and_leaves_as_they_are():
    """A TLAS leaf holds up to two entries, so three balls in one place (and a fourth apart) beside a mesh are five
    entries in four leaves; the text said the boxes were 'a leaf per instance or shape, one for the other meshes',
    five boxes where four were drawn."""
    from wrt.procedural import displaced_sphere

    points, indices = displaced_sphere(100)
    scene = wrt.Scene.from_triangles(points, indices)
    scene.shapes = [ball(5.0), ball(5.0), ball(5.0), ball(9.0)]
    bvh = get_accelerator(scene, "wrt", "sah", "cpu").bvh
    leaves = int((bvh.prim_count > 0).sum())
    entries = len(scene.shapes) + 1  # each shape, and one for the mesh
    assert leaves < entries  # the case at hand: a leaf of two
    plotter = wrt.preview(scene, bvh_leaves=True, window_size=(64, 48))
    try:
        line = next(x for x in summary_text(plotter).splitlines() if x.startswith("TLAS"))
        drawn = plotter.actors["bvh"].mapper.dataset.n_cells // 12
    finally:
        plotter.close()
    assert drawn == leaves
    assert f"leaves, {leaves} boxes" in line and f"{entries} entries" in line, line
    assert "a leaf per instance or shape" not in line, line


def test_summary_of_the_top_level_tree_says_what_its_entries_are():
    """The TLAS line said its entries were 'an instance or shape each, one for the other meshes' whatever they were:
    three instances and nothing else read as two instances and a mesh entry. The counts are those of the scene as
    built here: an entry per instance of a prototype with triangles, per analytic shape (an instanced one once per
    instance) and one for all the non-instanced meshes where there are any."""
    triangle = wrt.Mesh("/P/M", np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), [0])
    to_world = np.tile(np.eye(4), (3, 1, 1))
    to_world[:, 0, 3] = [0.0, 4.0, 8.0]
    only_instances = wrt.Scene(prototypes=[Prototype("/P", [triangle])],
                               instances=Instances.from_transforms([0, 0, 0], to_world))
    with_shape = Prototype("/Q", [triangle], [ball(0.0, "/Q")])
    floor = quad((-5, -2, -5), (10, 0, 0), (0, 0, 10), name="/floor")
    mixed = wrt.Scene(meshes=[floor], prototypes=[with_shape],
                      instances=Instances.from_transforms([0, 0], to_world[:2]))
    cases = ((only_instances, 3, "3 entries: 3 instances;"),
             (mixed, 5, "5 entries: 2 instances, 2 analytic shapes, 1 for the non-instanced meshes;"))
    for scene, entries, words in cases:
        assert get_accelerator(scene, "wrt", "sah", "cpu").num_entries == entries
        plotter = wrt.preview(scene, bvh_leaves=True, window_size=(64, 48))
        try:
            line = next(x for x in summary_text(plotter).splitlines() if x.startswith("TLAS"))
        finally:
            plotter.close()
        assert words in line, line
        if scene is only_instances:
            assert "meshes" not in line, line


def test_summary_of_an_empty_top_level_tree_names_the_instances_left_out():
    """Three instances of a triangle, two scaled to a point (numpy's determinant 0), which the trace leaves out (a
    warning says so when the scene is made); with all three so, the TLAS line said 'empty (no triangles or analytic
    shapes) ... 0 entries: none' of a scene whose title counts 3 triangles. It counts the instances left out."""
    triangle = wrt.Mesh("/P/M", np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), [0])
    to_world = np.tile(np.eye(4), (3, 1, 1))
    to_world[:, 0, 3] = [0.0, 4.0, 8.0]
    for singular in ([0, 1], [0, 1, 2]):
        placed = to_world.copy()
        placed[singular, :3, :3] = 0.0
        assert np.all(np.linalg.det(placed[singular, :3, :3]) == 0)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=".*singular transform")
            scene = wrt.Scene(prototypes=[Prototype("/P", [triangle])], instances=Instances.from_transforms([0] * 3,
                                                                                                          placed))
            plotter = wrt.preview(scene, bvh_depth=0, window_size=(64, 48))
        try:
            line = next(x for x in summary_text(plotter).splitlines() if x.startswith("TLAS"))
        finally:
            plotter.close()
        traced = 3 - len(singular)
        assert f"{traced} entr" in line and f"{len(singular)} instances left out of the trace" in line, line
        assert "no triangles or analytic shapes)" not in line, line


def test_to_pyvista_gives_meshes_and_instances_without_triangles_empty_blocks(tmp_path):
    """A Points prim is read as instances of a sphere prototype, which has no triangles: to_pyvista raised pyvista's
    "Empty arrays are not allowed" for its blocks (usd-wg's simpleAssetScene too), and a mesh of points without faces
    got a vertex cell per point, so the cells no longer added up to the triangles. Each gets a block with its points,
    no cells, and the cell arrays, empty."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "points.usda"
    path.write_text('#usda 1.0\ndef Points "P"\n{\n    point3f[] points = [(0, 0, 0), (2, 0, 0)]\n'
                    '    float[] widths = [1] (interpolation = "constant")\n}\n'
                    'def Mesh "T"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n'
                    '    point3f[] points = [(0, 0, 1), (1, 0, 1), (0, 1, 1)]\n}\n')
    stage = Usd.Stage.Open(str(path))
    triangles = sum(c - 2 for c in UsdGeom.Mesh(stage.GetPrimAtPath("/T")).GetFaceVertexCountsAttr().Get())
    scene = wrt.load_usd(path)
    lone = wrt.Mesh("/lone_points", np.float32([[0, 0, 0], [1, 0, 0], [0, 1, 0]]), np.zeros((0, 3), np.int32),
                    np.zeros(0, np.int32))
    scene.meshes.append(lone)
    blocks = to_pyvista(scene)
    assert sum(b.n_cells for b in blocks) == triangles
    assert blocks["/lone_points"].n_points == 3 and blocks["/lone_points"].n_cells == 0
    assert blocks.n_blocks == len(scene.meshes) + len(scene.instances) == 4
    for block in blocks:
        for name in ("color", "prim", "face_id"):
            assert len(block.cell_data[name]) == block.n_cells


def test_preview_says_so_when_it_both_leaves_out_instances_and_simplifies(tmp_path):
    """Past 4x the budget the instances that do not fit are left out; when the meshes left are still over the budget
    they are simplified too, and that note replaced the first: the title read "showing 1 of 2 triangles" for a scene
    of 14 triangles, without a word about the instances left out."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "instanced.usda"
    path.write_text(INSTANCED_GROUND)
    stage = Usd.Stage.Open(str(path))
    ground = sum(c - 2 for c in UsdGeom.Mesh(stage.GetPrimAtPath("/World/Ground")).GetFaceVertexCountsAttr().Get())
    instances = len(UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Tets")).GetProtoIndicesAttr().Get())
    plotter = wrt.preview(wrt.load_usd(path), max_triangles=1, window_size=(64, 48))
    try:
        assert plotter.actors["scene"].mapper.dataset.n_cells == 1
        assert plotter.title.endswith(f"showing 0 of {instances} instances and 1 of the {ground} triangles left "
                                      "(simplified for display)")
    finally:
        plotter.close()


def test_shapes_are_tessellated_once_per_kind_and_placed_where_usd_puts_them(tmp_path, monkeypatch):
    """Every shape drawn was tessellated on its own: 20 s for the 20,000 spheres of a Points prim (the shape budget).
    Copies of one (kind, parameters) share one tessellation now; each sphere drawn still lies on the sphere USD
    describes (centre a point, radius half its width; the last mirrored by a negative scale)."""
    import wrt.primitives

    rng = np.random.default_rng(123)
    centres = rng.uniform(-10, 10, (40, 3))
    widths = rng.uniform(0.2, 2.0, 40)
    path = tmp_path / "points.usda"
    points = ", ".join(f"({x}, {y}, {z})" for x, y, z in centres)
    path.write_text(f"""#usda 1.0
def Points "P"
{{
    point3f[] points = [{points}]
    float[] widths = [{", ".join(map(str, widths))}] (interpolation = "vertex")
}}
def Sphere "Mirrored"
{{
    double radius = 2
    double3 xformOp:scale = (-1, 1, 1)
    double3 xformOp:translate = (30, 0, 0)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
}}
""")
    scene = wrt.load_usd(path)
    calls = []
    real = wrt.primitives.tessellate
    monkeypatch.setattr(wrt.primitives, "tessellate", lambda *args, **kwargs: calls.append(1) or real(*args, **kwargs))
    drawn = shape_meshes(scene)
    assert len(calls) == 2  # a unit sphere for the points, the radius-2 sphere (one per shape: 41)
    parts = drawn.connectivity("all")
    regions = parts.point_data["RegionId"]
    expected = [(c, w / 2) for c, w in zip(centres, widths)] + [((30, 0, 0), 2.0)]
    assert regions.max() + 1 == len(expected)
    for r in range(len(expected)):
        points = np.asarray(parts.points[regions == r], np.float64)
        centre, radius = min(expected, key=lambda e: np.linalg.norm(points.mean(axis=0) - e[0]))
        np.testing.assert_allclose(np.linalg.norm(points - centre, axis=1), radius, rtol=1e-5)
    # The mirrored sphere's triangles still face outwards (cross(p1 - p0, p2 - p0) away from its centre).
    corners = np.asarray(drawn.points, np.float64)[drawn.regular_faces]
    normals = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    mirrored = np.linalg.norm(corners.mean(axis=1) - (30, 0, 0), axis=1) < 2.5
    assert mirrored.sum() > 0
    assert np.all(np.einsum("ij,ij->i", normals[mirrored], corners[mirrored].mean(axis=1) - (30, 0, 0)) > 0)


def test_shapes_are_drawn_coarser_to_keep_within_the_triangle_budget(tmp_path):
    """max_triangles simplified the meshes only: the 20,000 spheres drawn of a Points prim were 10.6M triangles at 24
    segments per circle. The circles get fewer segments until the shapes fit (the title says so), each sphere's
    vertices still on the sphere USD describes."""
    import re

    rng = np.random.default_rng(7)
    centres = rng.uniform(-10, 10, (40, 3))
    path = tmp_path / "points.usda"
    points = ", ".join(f"({x}, {y}, {z})" for x, y, z in centres)
    path.write_text(f'#usda 1.0\ndef Points "P"\n{{\n    point3f[] points = [{points}]\n'
                    '    float[] widths = [1] (interpolation = "constant")\n}\n')
    budget = 2000
    plotter = wrt.preview(wrt.load_usd(path), max_triangles=budget, window_size=(64, 48))
    try:
        drawn = plotter.actors["shapes"].mapper.dataset
        segments = re.search(r"analytic shapes with (\d+) segments per circle", plotter.title)
    finally:
        plotter.close()
    assert 0 < drawn.n_cells <= budget
    assert segments and int(segments.group(1)) < preview_module.SHAPE_SEGMENTS
    vertices = np.asarray(drawn.points, np.float64)
    nearest = np.linalg.norm(vertices[:, None, :] - centres[None], axis=2).min(axis=1)
    np.testing.assert_allclose(nearest, 0.5, rtol=1e-5)
    assert len(np.unique(np.argmin(np.linalg.norm(vertices[:, None] - centres[None], axis=2), axis=1))) == 40


def test_pre_split_triangles_are_covered_by_the_shown_boxes_of_their_pieces():
    """The docs said every triangle lies in exactly one shown box; in the ``sah`` tree a pre-split triangle has several
    references, each in its own leaf, and no shown box need hold the whole triangle (a UV sphere's pole slivers). What
    holds: each reference lies under exactly one shown box, and the boxes of a triangle's references cover it."""
    from wrt.procedural import displaced_sphere

    points, indices = displaced_sphere(2000)
    scene = wrt.Scene.from_triangles(points, indices)
    plotter = wrt.preview(scene, bvh_leaves=True, window_size=(64, 48), show_text=False)
    try:
        corners = np.asarray(plotter.actors["bvh"].mapper.dataset.points).reshape(-1, 8, 3)
    finally:
        plotter.close()
    lowers, uppers = corners.min(axis=1), corners.max(axis=1)
    bvh = get_accelerator(scene, "wrt", "sah", "cpu").bvh
    assert bvh.num_prims > len(indices)  # some triangles were split
    # The shown box above every slot, found by walking down from the root (an oracle apart from select_bvh_nodes).
    shown = {(tuple(lo), tuple(hi)) for lo, hi in zip(lowers, uppers)}
    box_of_slot = np.full(bvh.num_prims, -1)
    stack = [(0, -1)]
    while stack:
        node, above = stack.pop()
        if above < 0 and (tuple(bvh.lowers[node]), tuple(bvh.uppers[node])) in shown:
            above = node
        if bvh.prim_count[node] > 0:
            box_of_slot[bvh.left_first[node] : bvh.left_first[node] + bvh.prim_count[node]] = above
        else:
            stack += [(bvh.left_first[node], above), (bvh.left_first[node] + 1, above)]
    assert np.all(box_of_slot >= 0)
    split = np.bincount(bvh.prim_ids, minlength=len(indices)) > 1
    whole = np.zeros(len(indices), bool)
    samples = np.array([(a, b, 1 - a - b) for a in np.linspace(0, 1, 7) for b in np.linspace(0, 1 - a, 7)])
    for tri in np.flatnonzero(split):
        boxes = box_of_slot[bvh.prim_ids == tri]
        p = samples @ points[indices[tri]].astype(np.float64)
        inside = np.all((p[:, None] >= bvh.lowers[boxes] - 1e-6) & (p[:, None] <= bvh.uppers[boxes] + 1e-6), axis=2)
        assert inside.any(axis=1).all(), f"triangle {tri}: a point lies in none of its pieces' boxes"
        whole[tri] = inside.all(axis=0).any()
    assert not whole[split].all()  # some split triangle is held by no single shown box


XFORM = """
        double3 xformOp:translate.timeSamples = {{ 0: (1, 2, 3), 10: (11, -2, 3) }}
        float3 xformOp:rotateXYZ = (90, 0, 180)
        float3 xformOp:scale = {scale}
        uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ", "xformOp:scale"]"""
GPRIMS = {
    "sphere": 'Sphere "G"\n    {{\n        double radius = 1.5' + XFORM,
    "cube": 'Cube "G"\n    {{\n        double size = 3' + XFORM,
    "cylinder": 'Cylinder "G"\n    {{\n        double radius = 0.5\n        double height = 3\n'
                '        token axis = "X"' + XFORM,
    "cone": 'Cone "G"\n    {{\n        double radius = 2\n        double height = 1\n        token axis = "Y"' + XFORM,
    "capsule": 'Capsule "G"\n    {{\n        double radius = 0.25\n        double height = 2' + XFORM,
    "capsule_1": 'Capsule_1 "G"\n    {{\n        double radiusTop = 0.25\n        double radiusBottom = 0.5\n'
                 '        double height = 2' + XFORM,
    "cylinder_1": 'Cylinder_1 "G"\n    {{\n        double radiusTop = 0.25\n        double radiusBottom = 1\n'
                  '        double height = 2' + XFORM,
    "mesh": 'Mesh "G"\n    {{\n        int[] faceVertexCounts = [3, 3]\n'
            '        int[] faceVertexIndices = [0, 1, 2, 0, 2, 3]\n'
            '        point3f[] points = [(0, 0, 0), (2, 0, 0), (2, 1, 0), (0, 1, 3)]' + XFORM,
    "points": 'Points "G"\n    {{\n        point3f[] points = [(0, 0, 0), (3, 1, 0), (1, 4, 2)]\n'
              '        float[] widths = [0.5, 1, 2] (interpolation = "vertex")' + XFORM,
    "curves": 'BasisCurves "G"\n    {{\n        uniform token type = "linear"\n        int[] curveVertexCounts = [4]\n'
              '        point3f[] points = [(0, 0, 0), (1, 2, 0), (3, 2, 1), (3, 0, 2)]\n'
              '        float[] widths = [0.4] (interpolation = "constant")' + XFORM,
    "instancer": 'PointInstancer "G"\n    {{\n        rel prototypes = [</World/G/Ball>, </World/G/Tri>]\n'
                 '        int[] protoIndices = [0, 1, 1, 0]\n'
                 '        point3f[] positions = [(0, 0, 0), (4, 0, 0), (0, 4, 0), (0, 0, 4)]\n'
                 '        quath[] orientations = [(1, 0, 0, 0), (0.5, 0.5, 0.5, 0.5), (0, 1, 0, 0), (0, 0, 0, 1)]\n'
                 '        float3[] scales = [(1, 2, 1), (-1, 1, 1), (1, 1, 3), (2, 2, 2)]\n'
                 '        def Sphere "Ball"\n        {{\n            double radius = 0.5\n        }}\n'
                 '        def Mesh "Tri"\n        {{\n            int[] faceVertexCounts = [3]\n'
                 '            int[] faceVertexIndices = [0, 1, 2]\n'
                 '            point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 2, 1)]\n        }}' + XFORM,
}


@pytest.mark.parametrize("kind", list(GPRIMS))
def test_drawn_geometry_is_where_usd_bounds_it(tmp_path, kind):
    """The triangles and shapes drawn for one gprim (analytic shapes, a mesh under a mirroring scale, points, curves,
    a PointInstancer of two prototypes), placed by a transform animated in time and taken at time 5, fill the box
    ``UsdGeom.BBoxCache`` gives the prim at that time: rotations by right angles and an axis-aligned scale keep that
    box exact (uniform for points and curves, whose widths USD does not scale per axis)."""
    from pxr import Usd, UsdGeom

    scale = "(1.5, 1.5, 1.5)" if kind in ("points", "curves") else "(-1, 2, 0.5)"
    path = tmp_path / f"{kind}.usda"
    path.write_text('#usda 1.0\n(\n    upAxis = "Z"\n)\ndef Xform "World"\n{\n    def '
                    + GPRIMS[kind].format(scale=scale) + "\n    }\n}\n")
    stage = Usd.Stage.Open(str(path))
    box = UsdGeom.BBoxCache(5.0, ["default", "render"]).ComputeWorldBound(stage.GetPrimAtPath("/World/G"))
    box = box.ComputeAlignedRange()
    expected = np.array([box.GetMin(), box.GetMax()])
    plotter = wrt.preview(wrt.load_usd(path, time=5.0), window_size=(64, 48), show_text=False)
    try:
        drawn = [np.asarray(plotter.actors[a].mapper.dataset.points, np.float64)
                 for a in ("scene", "scene_double_sided", "shapes", "shapes_double_sided") if a in plotter.actors]
    finally:
        plotter.close()
    # The scene actors carry every point of the scene's meshes; shapes are tessellated with vertices on the surface,
    # every extreme among them at these angles (0.03: a tapered capsule's widest circle lies between two rings).
    drawn = np.concatenate(drawn)
    tolerance = 0.03 if kind == "capsule_1" else 1e-5
    np.testing.assert_allclose(drawn.min(axis=0), expected[0], atol=tolerance)
    np.testing.assert_allclose(drawn.max(axis=0), expected[1], atol=tolerance)


CAMERAS = """#usda 1.0
(
    upAxis = "Y"
)
def Mesh "Floor"
{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-10, 0, -10), (10, 0, -10), (10, 0, 10), (-10, 0, 10)]
    uniform bool doubleSided = 1
}
def Sphere "Ball"
{
    double radius = 2
    double3 xformOp:translate = (1, 2, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Persp"
{
    float focalLength = 35
    float horizontalAperture = 36
    float verticalAperture = 24
    float horizontalApertureOffset = 3
    float verticalApertureOffset = -2
    float2 clippingRange = (0.5, 1000)
    double3 xformOp:translate.timeSamples = { 0: (1, 6, 12), 10: (4, 8, 14) }
    float3 xformOp:rotateXYZ = (-25, 10, 5)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}
def Camera "Ortho"
{
    token projection = "orthographic"
    float horizontalAperture = 300
    float verticalAperture = 200
    float horizontalApertureOffset = 20
    float verticalApertureOffset = 10
    double3 xformOp:translate = (0, 20, 0)
    float3 xformOp:rotateXYZ = (-90, 0, 30)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:rotateXYZ"]
}
"""


def usd_frustum(path, camera: str, width: int, height: int):
    """``Gf.Frustum`` of ``UsdGeom.Camera.GetCamera(5.0)`` of ``camera`` in the stage at ``path``, its window grown to
    the ``width x height`` aspect (UsdRender's ``expandAperture``, the fallback conform policy)."""
    from pxr import Gf, Usd, UsdGeom

    stage = Usd.Stage.Open(str(path))
    frustum = UsdGeom.Camera(stage.GetPrimAtPath(camera)).GetCamera(5.0).frustum
    lower, upper = (np.array(v) for v in (frustum.window.GetMin(), frustum.window.GetMax()))
    centre, size = (lower + upper) / 2, upper - lower
    size = np.maximum(size, [size[1] * width / height, size[0] * height / width])  # expandAperture
    frustum.window = Gf.Range2d(Gf.Vec2d(*(centre - size / 2)), Gf.Vec2d(*(centre + size / 2)))
    return frustum


@pytest.mark.parametrize("camera", ["/Persp", "/Ortho"])
@pytest.mark.parametrize("width, height", [(60, 40), (80, 20)])
def test_frustum_is_the_usd_camera_frustum(tmp_path, camera, width, height):
    """The drawn frustum (eye, far rectangle, image-plane rectangle) lies where ``Gf.Frustum`` of
    ``UsdGeom.Camera.GetCamera(time)`` puts its corners at the same depths: film offsets, an orthographic camera, a
    camera animated in time, and an image aspect other than the apertures' (the window grown to it, UsdRender's
    ``expandAperture``, the fallback conform policy)."""
    path = tmp_path / "cameras.usda"
    path.write_text(CAMERAS)
    frustum = usd_frustum(path, camera, width, height)
    eye, view = np.array(frustum.GetPosition()), np.array(frustum.ComputeViewDirection())
    plotter = wrt.preview(wrt.load_usd(path, time=5.0), camera=camera, width=width, height=height,
                          window_size=(64, 48), show_text=False)
    try:
        drawn = np.asarray(plotter.actors["frustum"].mapper.dataset.points, np.float64).reshape(3, 4, 3)
        np.testing.assert_allclose(plotter.actors["eye"].mapper.dataset.center, eye, atol=1e-5)
    finally:
        plotter.close()
    for corners in drawn:  # at depth 0, the far end and the image plane: top-left, top-right, bottom-right, bottom-left
        depth = float(np.mean((corners - eye) @ view))
        if depth < 1e-9 and camera == "/Persp":
            np.testing.assert_allclose(corners, np.tile(eye, (4, 1)), atol=1e-5)
            continue
        lb, rb, lt, rt = (np.array(c) for c in frustum.ComputeCornersAtDistance(depth))
        np.testing.assert_allclose(corners, [lt, rt, rb, lb], atol=1e-4)


@pytest.mark.parametrize("camera", ["/Persp", "/Ortho"])
def test_drawn_rays_end_at_the_traced_hits_and_misses_at_the_far_end(tmp_path, camera):
    """Each drawn ray runs from its origin to where ``wrt.trace`` of the same ray (from the near plane on) hits, here
    a mesh and an analytic sphere (a two-level BVH); a ray that misses ends on the frustum's far rectangle."""
    path = tmp_path / "cameras.usda"
    path.write_text(CAMERAS)
    scene = wrt.load_usd(path, time=5.0)
    plotter = wrt.preview(scene, camera=camera, rays=120, width=60, height=40, window_size=(64, 48), show_text=False)
    try:
        segments = {a: np.asarray(plotter.actors[a].mapper.dataset.points, np.float64).reshape(2, -1, 3)
                    for a in ("rays_hit", "rays_miss")}
        far = np.asarray(plotter.actors["frustum"].mapper.dataset.points, np.float64)[4:8]
    finally:
        plotter.close()
    cam = scene.cameras[camera]
    near = cam.clipping_range[0]
    for actor, (origins, ends) in segments.items():
        assert len(origins) > 10, actor
        length = np.linalg.norm(ends - origins, axis=1)
        hits = wrt.trace(scene, origins, (ends - origins) / length[:, None], t_min=near)
        if actor == "rays_hit":
            np.testing.assert_allclose(hits.t, length, rtol=1e-5)
        else:
            assert not np.isfinite(hits.t).any()
            normal = np.cross(far[1] - far[0], far[3] - far[0])
            np.testing.assert_allclose((ends - far[0]) @ normal / np.linalg.norm(normal), 0.0, atol=1e-3)


def walked_cut(bvh, depth: int) -> list:
    """Boxes ``(lower..., upper...)`` of the nodes at ``depth`` and the leaves above it, found by walking the tree's
    arrays down from the root (children of inner node ``n``: ``left_first[n]`` and the next)."""
    found, stack = [], [(0, 0)]
    while stack:
        node, d = stack.pop()
        if d == depth or bvh.prim_count[node] > 0:
            found.append(tuple(np.r_[bvh.lowers[node], bvh.uppers[node]]))
        else:
            stack += [(bvh.left_first[node], d + 1), (bvh.left_first[node] + 1, d + 1)]
    return sorted(found)


@pytest.mark.parametrize("builder", wrt.bvh.build.builder_names())
@pytest.mark.parametrize("two_level", [False, True])
def test_drawn_bvh_boxes_are_the_trees_nodes_at_that_depth(builder, two_level):
    """For every builder, of a BVH and of a TLAS (a scene with analytic shapes): the boxes drawn at depth ``d`` are,
    bit for bit and one each, the boxes of the tree's nodes at depth ``d`` and of its leaves above it, past the
    deepest leaf too."""
    from wrt.procedural import displaced_sphere

    points, indices = displaced_sphere(300)
    scene = wrt.Scene.from_triangles(points, indices)
    if two_level:
        scene.shapes = [ball(x) for x in (-3.0, 3.0, 5.0, 7.0)]
    accel = get_accelerator(scene, "wrt", builder, "cpu")
    assert hasattr(accel, "tlas") == two_level
    bvh = accel.bvh
    deepest = int(bvh.depths().max())
    for depth in sorted({0, 1, 3, deepest, deepest + 2}):
        with warnings.catch_warnings():  # past the deepest leaf it says it draws the leaves (tested on its own)
            warnings.filterwarnings("ignore", message="BVH depth .* is past the tree's deepest leaf")
            plotter = wrt.preview(scene, bvh_depth=depth, builder=builder, window_size=(32, 24), show_text=False)
        try:
            corners = np.asarray(plotter.actors["bvh"].mapper.dataset.points).reshape(-1, 8, 3)
        finally:
            plotter.close()
        drawn = sorted(tuple(b) for b in np.hstack([corners.min(axis=1), corners.max(axis=1)]))
        assert drawn == walked_cut(bvh, depth), f"depth {depth}"


def test_cluster_vertices_keeps_every_triangle_facing_as_its_source(bunny):
    """Snapping corners to cluster means turned some triangles over (0.5 % of a simplified sphere's, some of the
    bunny's): a single-sided mesh drew them culled from the side they face, holes in the simplified surface."""
    points, indices = bunny.triangles()
    rows = np.arange(len(indices))[:, None]
    source = points[indices].astype(np.float64)
    source = np.cross(source[:, 1] - source[:, 0], source[:, 2] - source[:, 0])
    for budget in (500, 3000):
        p, i, r = cluster_vertices(points, indices, rows, budget)
        corners = p[i].astype(np.float64)
        facing = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        assert np.all(np.einsum("ij,ij->i", facing, source[r[:, 0]]) >= 0), budget


@pytest.mark.parametrize("scale", [1e21, 1e-21])
def test_cluster_vertices_of_huge_and_tiny_meshes_keeps_every_triangle_facing_as_its_source(bunny, scale):
    """The bunny 1e21 or 1e-21 units tall (float32 points, within wrt's reach): the source normals that wind snapped
    triangles back were float32 products of edges, inf past 1.8e19 units (numpy's 'overflow encountered in cast') and
    0 below 1e-19, and 2 (1e21) and 6 (1e-21) of 372 simplified triangles were left turned over."""
    points, indices = bunny.triangles()
    points = (points.astype(np.float64) * scale).astype(np.float32)
    rows = np.arange(len(indices))[:, None]
    source = points[indices].astype(np.float64) / scale  # float64 oracle, in the bunny's own units
    source = np.cross(source[:, 1] - source[:, 0], source[:, 2] - source[:, 0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        p, i, r = cluster_vertices(points, indices, rows, 500)
    corners = p[i].astype(np.float64) / scale
    facing = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    assert np.all(np.einsum("ij,ij->i", facing, source[r[:, 0]]) >= 0)


@pytest.mark.parametrize("exponent", [-110, 100])
def test_cluster_vertices_of_a_mesh_scaled_by_a_power_of_two_is_the_same_soup_scaled(bunny, exponent):
    """Scaling by a power of two is exact in float32 (the bunny's points stay normal numbers at 2^-110 and 2^100), so
    the simplified soup of the scaled bunny is the unscaled one's scaled: the same triangles, the points times the
    scale. A floor of 1e-30 under the box's size made the grid of the bunny 2^-110 (7.7e-34) units tall 100 times
    coarser: 158 triangles kept of a budget of 1000, where 712 are at scale 1."""
    points, indices = bunny.triangles()
    rows = np.arange(len(indices))[:, None]
    scale = 2.0**exponent
    p, i, r = cluster_vertices(points, indices, rows, 1000)
    scaled_p, scaled_i, scaled_r = cluster_vertices((points * np.float32(scale)).astype(np.float32), indices, rows,
                                                    1000)
    assert len(scaled_i) == len(i), (len(scaled_i), len(i))
    np.testing.assert_array_equal(scaled_i, i)
    np.testing.assert_array_equal(scaled_r, r)
    np.testing.assert_array_equal(scaled_p / scale, p)


@pytest.mark.parametrize("bound", [50, 1 << 40, 1 << 62])
def test_cluster_ids_are_numpys_unique_inverse(bound):
    """The clustering ranks its points' cell keys with one sort of key and row packed together where both fit in 63
    bits (np.unique where they do not): the count and the ranks are np.unique's."""
    from wrt.preview import cluster_ids

    keys = np.random.default_rng(5).integers(0, bound, 3000)
    uniq, inverse = np.unique(keys, return_inverse=True)
    count, ids = cluster_ids(keys, bound)
    assert count == len(uniq)
    np.testing.assert_array_equal(ids, inverse.reshape(-1))


@pytest.mark.parametrize("clusters", [12, 1 << 21])
def test_triangle_keys_are_equal_for_the_same_corners_in_the_same_cyclic_order(clusters):
    """Both forms of the clustering's duplicate keys (one packed int64, or a row of four past 2^21 clusters) group the
    triangles as their corners rotated to start at the smallest do: the same three in the same cyclic order."""
    from wrt.preview import triangle_keys

    rng = np.random.default_rng(11)
    tris = np.array([rng.choice(6, 3, replace=False) for _ in range(400)]) + (clusters - 6)
    rotated = np.take_along_axis(tris, (np.argmin(tris, axis=1)[:, None] + np.arange(3)) % 3, axis=1)
    expected = np.unique(rotated, axis=0, return_inverse=True)[1].reshape(-1)
    found = np.unique(triangle_keys(tris, clusters), axis=0, return_inverse=True)[1].reshape(-1)
    pairs = set(zip(expected.tolist(), found.tolist()))
    assert len(pairs) == len(set(expected.tolist())) == len(set(found.tolist())) == 40  # 20 sets of 3, 2 orders


def test_cluster_vertices_keeps_both_sides_of_a_thin_card():
    """A unit card of two single-sided sheets back to back (1e-3 apart, wound opposite ways), simplified: both sides
    snap to the same clusters, and duplicates in any order were one, so only the first sheet was kept (800 triangles
    facing +z, none -z), and from below, culled, the card vanished. Each side now covers about the card's area, 1."""
    n = 40
    x, y = np.meshgrid(np.linspace(0.0, 1.0, n + 1), np.linspace(0.0, 1.0, n + 1), indexing="ij")
    top = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=1)
    points = np.concatenate([top, top + [0.0, 0.0, 1e-3]]).astype(np.float32)
    i = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None]).ravel()
    up = np.concatenate([np.stack([i, i + n + 1, i + 1], 1), np.stack([i + 1, i + n + 1, i + n + 2], 1)])
    indices = np.concatenate([up, up[:, [0, 2, 1]] + len(top)]).astype(np.int32)
    p, t, _ = cluster_vertices(points, indices, np.zeros((len(indices), 1)), 800)
    normals = np.cross(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]])
    areas = [0.5 * normals[normals[:, 2] * side > 0, 2].sum() * side for side in (1, -1)]
    assert len(t) <= 800
    np.testing.assert_allclose(areas, 1.0, rtol=0.2)


def test_simplified_instances_far_from_the_origin_face_outwards():
    """Instances of a single-sided ball 1e7 from the origin, drawn from float64 points, simplified for display: the
    triangles the snap turned over were wound back by their source's normal, taken from float32 corners, which at 1e7
    (a step of 1) are a 1-unit grid that the ball's 0.1-unit triangles collapse on; 5 % of them faced inwards, holes
    in the culled surface. Oracle: a ball is convex, so each drawn triangle faces away from its instance's centre."""
    from wrt.procedural import displaced_sphere

    points, indices = displaced_sphere(500)
    points = np.asarray(points, np.float32) / np.abs(points).max()
    ball = Prototype("/P", [wrt.Mesh("/P/M", points, indices, np.arange(len(indices)))])
    to_world = np.tile(np.eye(4), (30, 1, 1))
    to_world[:, 0, 3] = 1e7 + 3.0 * np.arange(30)
    scene = wrt.Scene(prototypes=[ball], instances=Instances.from_transforms(np.zeros(30, int), to_world))
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*float32")  # the renderer's words about a scene this far out
        plotter = wrt.preview(scene, max_triangles=len(indices) * 10, window_size=(32, 24), show_text=False)
    try:
        assert "simplified for display" in plotter.title, plotter.title
        drawn = plotter.actors["scene"].mapper.dataset
        corners = np.asarray(drawn.points, np.float64)[drawn.regular_faces]
    finally:
        plotter.close()
    facing = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    middle = corners.mean(axis=1)
    centre = 1e7 + 3.0 * np.round((middle[:, 0] - 1e7) / 3.0)
    outward = middle - np.column_stack([centre, np.zeros((len(middle), 2))])
    inward = np.einsum("ij,ij->i", facing, outward) < 0
    assert inward.mean() < 0.002, f"{inward.sum()} of {len(inward)} triangles face inwards"


def test_sample_rays_of_a_film_above_the_render_pixel_limit(room):
    """--rays with --width 10000 --height 7500 failed on the renderer's pixel limit (75,000,000 pixels; at most
    67,108,864), though the film only gives the rays' aspect: 48 rays are an 8x6 grid, those of an 8x6 render."""
    _, _, t = sample_rays(room, resolve_camera(room, None), 10000, 7500, 48)
    depth = wrt.render(room, width=8, height=6, device="cpu").aovs["depth"].reshape(-1)
    np.testing.assert_array_equal(np.isfinite(t), np.isfinite(depth))
    np.testing.assert_allclose(t[np.isfinite(t)], depth[np.isfinite(depth)], rtol=1e-5)


@pytest.mark.parametrize("command", ["preview", "render"])
def test_cli_image_above_the_pixel_limit_is_refused_naming_the_options(tmp_path, capsys, command):
    """--image renders the film: 10000x10000 was refused naming neither option (after the load: a data window of the
    stage may crop the size given), and inside the preview for wrt preview."""
    argv = [command, "--width", "10000", "--height", "10000", "-o", str(tmp_path / "p.png")]
    assert main(argv + (["--image"] if command == "preview" else [])) == 2
    line = [x for x in capsys.readouterr().err.splitlines() if x.startswith("wrt")][-1]
    assert line.startswith("wrt: error: --width 10000 --height 10000: 10000x10000 is 100,000,000 pixels"), line
    assert not (tmp_path / "p.png").exists()


FAR_BALL = """#usda 1.0
(
    upAxis = "Z"
)
def Sphere "Ball"
{
    double radius = 0.5
    double3 xformOp:translate = (10000000.25, -20000000.5, 3.125)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
def Camera "Cam"
{
    float2 clippingRange = (0.1, 1000)
    double3 xformOp:translate = (10000000, -20000000, 8.25)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""


def test_shapes_and_the_eye_far_from_the_origin_are_drawn_round(tmp_path):
    """1e7 from the origin a float32's step is 1: a ball of radius 0.5 there was drawn as a flat bar (its tessellation
    rounded to float32) and the eye dot as a point, where the renderer draws the ball round. Every drawn vertex of the
    ball lies on the sphere ``UsdGeom`` puts there, and the eye dot is as wide as it is high and deep."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "far.usda"
    path.write_text(FAR_BALL)
    stage = Usd.Stage.Open(str(path))
    prim = stage.GetPrimAtPath("/Ball")
    centre = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(prim).ExtractTranslation())
    radius = UsdGeom.Sphere(prim).GetRadiusAttr().Get()
    plotter = wrt.preview(wrt.load_usd(path), window_size=(64, 48), show_text=False)
    try:
        drawn = np.asarray(plotter.actors["shapes"].mapper.dataset.points, np.float64)
        dot = np.asarray(plotter.actors["eye"].mapper.dataset.points, np.float64)
    finally:
        plotter.close()
    np.testing.assert_allclose(np.linalg.norm(drawn - centre, axis=1), radius, rtol=1e-6)
    extent = dot.max(axis=0) - dot.min(axis=0)
    assert extent.min() > 0, extent
    np.testing.assert_allclose(extent, extent[0], rtol=0.02)  # a UV sphere: 1 % narrower between its rings


def test_to_pyvista_makes_at_most_its_budget_of_instance_blocks(monkeypatch):
    """A block costs about a millisecond of pyvista bookkeeping, and the triangle budget let in up to 2M blocks of
    one-triangle instances (100,000 PointInstancer instances took 105 s): the first ``INSTANCE_BLOCK_BUDGET`` are
    made, each where its transform puts the prototype, and ``instances_left_out`` counts the others."""
    from wrt.scene import Mesh

    monkeypatch.setattr(preview_module, "INSTANCE_BLOCK_BUDGET", 4, raising=False)
    local = np.array([[0, 0, 0], [1, 0, 0], [0, 2, 1]], np.float32)
    prototype = Prototype("/P", [Mesh("/P/M", local, np.array([[0, 1, 2]]), np.arange(1))])
    rng = np.random.default_rng(123)
    to_world = np.tile(np.eye(4), (10, 1, 1))
    to_world[:, :3, :3] = rng.normal(size=(10, 3, 3))
    to_world[:, :3, 3] = rng.normal(size=(10, 3)) * 10
    scene = wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms(np.zeros(10, int), to_world))
    for kwargs, shown in (({}, 4), ({"max_instances": 7}, 7), ({"max_instances": 0}, 0)):
        with pytest.warns(UserWarning, match=f"left out {10 - shown} of 10 instances"):
            blocks = to_pyvista(scene, **kwargs)
        assert blocks.n_blocks == shown, kwargs
        assert blocks.field_data["instances_left_out"][0] == 10 - shown
        for block, matrix in zip(blocks, to_world):
            np.testing.assert_allclose(block.points, local @ matrix[:3, :3].T + matrix[:3, 3], rtol=1e-5, atol=1e-5)
    with pytest.raises(ValueError, match="max_instances"):
        to_pyvista(scene, max_instances=-1)


def test_to_pyvista_warns_once_of_the_instances_past_its_budget_naming_the_file_count_and_budget(tmp_path):
    """Past its instance budget to_pyvista kept the first instances and only counted the others in field_data: the
    blocks looked like the whole scene. One warning names the file, how many of how many (USD's protoIndices) were
    left out, and the budget to raise."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "instanced.usda"
    path.write_text(INSTANCED_GROUND)
    stage = Usd.Stage.Open(str(path))
    instances = len(UsdGeom.PointInstancer(stage.GetPrimAtPath("/World/Tets")).GetProtoIndicesAttr().Get())
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        blocks = to_pyvista(str(path), max_instances=1)
    said = [str(w.message) for w in caught if "left out" in str(w.message)]
    assert len(said) == 1, [str(w.message) for w in caught]
    assert "instanced.usda" in said[0] and f"left out {instances - 1} of {instances} instances" in said[0], said
    assert "max_instances=1" in said[0] and "max_triangles" in said[0], said
    assert blocks.field_data["instances_left_out"][0] == instances - 1
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # all of them fit: nothing said
        assert to_pyvista(str(path)).field_data["instances_left_out"][0] == 0


@pytest.mark.parametrize("budget", [-3, 0, 2.5, True])
def test_to_pyvista_refuses_a_triangle_budget_that_is_no_positive_integer(budget):
    """wrt.preview refuses these; to_pyvista took them and left every instance out without a word."""
    prototype = Prototype("/P", [wrt.Mesh("/P/M", np.eye(3, dtype=np.float32), np.array([[0, 1, 2]]), [0])])
    scene = wrt.Scene(prototypes=[prototype], instances=Instances.from_transforms([0], np.eye(4)[None]))
    with pytest.raises(ValueError, match="max_triangles must be a positive integer"):
        to_pyvista(scene, max_triangles=budget)


FAR_INSTANCES = """#usda 1.0
(
    upAxis = "Z"
)
def PointInstancer "PI"
{
    rel prototypes = [</PI/Tri>]
    int[] protoIndices = [0, 0]
    point3f[] positions = [(0.25, -0.5, 1), (2.75, 3.5, 1)]
    quath[] orientations = [(1, 0, 0, 0), (0.7071068, 0, 0, 0.7071068)]
    double3 xformOp:translate = (10000000, -20000000, 0)
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Mesh "Tri"
    {
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 2]
        point3f[] points = [(-0.3, -0.3, 0), (0.3, -0.3, 0), (0, 0.4, 0.2)]
    }
}
"""


def test_instances_far_from_the_origin_keep_their_shape(tmp_path):
    """wrt traces an instance in its prototype's space, so a triangle of 0.6 placed 1e7 from the origin keeps its
    shape; the preview and ``to_pyvista`` moved its points to the world in float32 (a step of 1 there) and drew it
    as a line. The drawn points are those of ``UsdGeom.PointInstancer``'s instance transforms, in float64."""
    from pxr import Usd, UsdGeom

    path = tmp_path / "far_instances.usda"
    path.write_text(FAR_INSTANCES)
    stage = Usd.Stage.Open(str(path))
    instancer = UsdGeom.PointInstancer(stage.GetPrimAtPath("/PI"))
    local = np.array(UsdGeom.Mesh(stage.GetPrimAtPath("/PI/Tri")).GetPointsAttr().Get(), np.float64)
    parent = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(instancer.GetPrim()))
    placed = [np.array(m) @ parent for m in instancer.ComputeInstanceTransformsAtTime(0, 0)]  # row vectors
    expected = np.concatenate([np.c_[local, np.ones(3)] @ m for m in placed])[:, :3]
    scene = wrt.load_usd(path)
    plotter = wrt.preview(scene, window_size=(64, 48), show_text=False)
    try:
        drawn = np.asarray(plotter.actors["scene"].mapper.dataset.points, np.float64)
    finally:
        plotter.close()
    np.testing.assert_allclose(drawn, expected, rtol=0, atol=1e-6)
    blocks = to_pyvista(scene)
    np.testing.assert_allclose(np.concatenate([np.asarray(b.points, np.float64) for b in blocks]), expected, atol=1e-6)


def test_a_sheared_cameras_far_end_holds_the_scene_and_the_missing_rays(tmp_path):
    """Below a parent scaled along another axis a camera's axes are sheared, and its planes of equal depth (the
    renderer's clipping planes) tilt away from the view direction's normal plane. The display far plane is at the
    deepest corner of the scene's box in camera-space depth (it was measured along the view direction: 0.16 too deep
    here) and missing rays end on the drawn far rectangle (they ended on the untilted plane, up to 5.2 deep off)."""
    floor = quad((0, 0, 0), (10, 0, 0), (0, 10, 0), name="/floor")  # (-5, -5, 0) to (5, 5, 0)
    cam = wrt.Camera.look_at(eye=(0, -6, 4), target=(0, 0, 0), fov_y_deg=60, clipping_range=(0.1, 100))
    shear = np.eye(4)
    shear[0, 0], shear[2, 1] = 1.5, 0.6
    cam.to_world = shear @ cam.to_world
    plotter = wrt.preview(wrt.Scene(meshes=[floor]), camera=cam, rays=60, width=40, height=30, window_size=(64, 48),
                          show_text=False)
    try:
        ends = np.asarray(plotter.actors["rays_miss"].mapper.dataset.points, np.float64).reshape(2, -1, 3)[1]
        far = np.asarray(plotter.actors["frustum"].mapper.dataset.points, np.float64)[4:8]
    finally:
        plotter.close()
    to_camera = np.linalg.inv(cam.to_world)

    def camera_depth(points):  # -z in the camera's own space, float64
        return -(np.c_[points, np.ones(len(points))] @ to_camera.T)[:, 2]

    lower, upper = np.array([-5.0, -5.0, 0.0]), np.array([5.0, 5.0, 0.0])
    box = np.stack(np.meshgrid(*zip(lower, upper), indexing="ij"), axis=-1).reshape(-1, 3)
    assert len(ends) > 10
    np.testing.assert_allclose(camera_depth(far), min(camera_depth(box).max(), 100.0), rtol=1e-6)
    np.testing.assert_allclose(camera_depth(ends), camera_depth(far)[0], rtol=1e-6)


def test_to_pyvista_places_instances_after_one_of_a_prototype_without_triangles():
    """An instance of a prototype whose mesh has points but no faces took the next instance's points (the expanded
    triangles hold no points of such prototypes), and every later block was shifted: the third block had one point
    for its triangle. Each block holds its prototype's points moved by its transform, and its triangles' corners."""
    points_only = Prototype("/E", [wrt.Mesh("/E/M", np.float32([[9, 9, 9], [8, 8, 8]]), np.zeros((0, 3), np.int32),
                                            np.zeros(0, np.int32))])
    local = np.float32([[0, 0, 0], [1, 0, 0], [0, 2, 1]])
    triangle = Prototype("/T", [wrt.Mesh("/T/M", local, np.array([[0, 1, 2]]), [0])])
    to_world = np.tile(np.eye(4), (4, 1, 1))
    to_world[:, :3, 3] = [[0, 0, 0], [10, 0, 0], [20, 0, 0], [30, 5, 0]]
    to_world[3, :3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 2]]
    scene = wrt.Scene(prototypes=[points_only, triangle], instances=Instances.from_transforms([0, 1, 0, 1], to_world))
    blocks = to_pyvista(scene)
    assert blocks.n_blocks == 4
    for block, k, matrix in zip(blocks, [0, 1, 0, 1], to_world):
        source = scene.prototypes[k].meshes[0]
        expected = source.points.astype(np.float64) @ matrix[:3, :3].T + matrix[:3, 3]
        np.testing.assert_allclose(block.points, expected, atol=1e-6)
        assert block.n_cells == len(source.indices)
        if block.n_cells:
            np.testing.assert_allclose(block.points[block.regular_faces], expected[source.indices], atol=1e-6)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a display is assumed off Linux")
def test_a_window_asked_for_without_a_display_is_refused_saying_how_to_draw_off_screen(monkeypatch):
    """``wrt.preview(off_screen=False)`` without a display returned a plotter anyway: VTK warned 'bad X server
    connection' and nothing was drawn. Where ``wrt preview`` writes preview.png, the API says what is wrong and how
    to draw off-screen; ``off_screen=None`` still falls back to off-screen."""
    monkeypatch.delenv("DISPLAY", raising=False)
    scene = wrt.Scene.from_triangles(np.eye(3), [[0, 1, 2]])
    for value in (False, 0):
        with pytest.raises(PreviewUnavailable, match=r"off_screen=False asks for a window, and there is no display "
                           r"\(DISPLAY is not set\): pass off_screen=True .*\.screenshot"):
            wrt.preview(scene, off_screen=value, window_size=(32, 24)).close()
    plotter = wrt.preview(scene, window_size=(32, 24))
    try:
        assert plotter.off_screen
    finally:
        plotter.close()


def test_a_bvh_depth_past_the_trees_depth_says_it_draws_the_leaves(tmp_path, capsys):
    """A cut deeper than the tree's deepest leaf draws the leaves, as bvh_leaves does; the preview drew them as if the
    tree went that deep, without a word. The tree's depth is walked from its arrays here (walked_cut), not taken from
    the preview."""
    from wrt.procedural import displaced_sphere

    scene = wrt.Scene.from_triangles(*displaced_sphere(60))
    bvh = get_accelerator(scene, "wrt", "sah", "cpu").bvh
    deepest = next(d for d in range(64) if walked_cut(bvh, d) == walked_cut(bvh, d + 1) == walked_cut(bvh, 64))
    for depth, past in ((deepest - 1, False), (deepest, False), (deepest + 3, True)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            plotter = wrt.preview(scene, bvh_depth=depth, window_size=(32, 24))
        try:
            text = summary_text(plotter)
        finally:
            plotter.close()
        said = [str(w.message) for w in caught if "deepest leaf" in str(w.message)]
        expected = f"BVH depth {depth} is past the tree's deepest leaf (depth {deepest}): the boxes drawn are its " \
                   "leaves"
        assert said == ([expected] if past else []), (depth, said)
        assert (f"cut at depth {depth}, past the deepest leaf (depth {deepest}): the leaves" in text) == past, text
    out = tmp_path / "deep.png"
    assert main(["preview", "--bvh-depth", "60", "--window", "32x24", "-o", str(out), "-q"]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt: warning:")]
    assert len(warned) == 1 and "BVH depth 60 is past the tree's deepest leaf" in warned[0], warned
    assert out.is_file()


def test_near_clipping_plane_behind_an_orthographic_camera_is_drawn_where_usd_puts_it(tmp_path):
    """An orthographic camera of clippingRange (-5, 100) sees from 5 behind its plane, where its rays start; that
    near plane's rectangle was not drawn (only a near plane in front of the eye was), so the preview showed a box
    from the camera's plane, leaving out what the render sees behind it. Oracle: the near corners of
    ``Gf.Frustum``'s ``ComputeCorners``."""
    path = tmp_path / "cameras.usda"
    behind = CAMERAS[CAMERAS.index('def Camera "Ortho"'):].replace('"Ortho"', '"OrthoBehind"')
    path.write_text(CAMERAS + behind.replace("{", "{\n    float2 clippingRange = (-5, 100)", 1))
    lb, rb, lt, rt = (np.array(c) for c in usd_frustum(path, "/OrthoBehind", 60, 40).ComputeCorners()[:4])
    scene = wrt.load_usd(path, time=5.0)
    plotter = wrt.preview(scene, camera="/OrthoBehind", width=60, height=40, window_size=(32, 24), show_text=False)
    try:
        drawn = np.asarray(plotter.actors["near_plane"].mapper.dataset.points, np.float64)
    finally:
        plotter.close()
    np.testing.assert_allclose(drawn, [lt, rt, rb, lb], atol=1e-5)


@pytest.mark.parametrize("camera", ["/Persp", "/Ortho"])
def test_near_clipping_plane_is_drawn_where_usd_puts_it(tmp_path, camera):
    """The frustum was drawn from the eye, and the near clipping plane, where rays start, was not drawn. Its
    rectangle's corners (top-left, top-right, bottom-right, bottom-left) are the near corners of ``Gf.Frustum``'s
    ``ComputeCorners`` (the clipping range's near: 0.5 for /Persp, USD's fallback 1 for /Ortho); a camera whose near
    plane is at the eye draws none."""
    path = tmp_path / "cameras.usda"
    path.write_text(CAMERAS)
    lb, rb, lt, rt = (np.array(c) for c in usd_frustum(path, camera, 60, 40).ComputeCorners()[:4])
    scene = wrt.load_usd(path, time=5.0)
    plotter = wrt.preview(scene, camera=camera, width=60, height=40, window_size=(32, 24), show_text=False)
    try:
        drawn = np.asarray(plotter.actors["near_plane"].mapper.dataset.points, np.float64)
        lines = plotter.actors["near_plane"].mapper.dataset.lines
    finally:
        plotter.close()
    np.testing.assert_allclose(drawn, [lt, rt, rb, lb], atol=1e-5)
    np.testing.assert_array_equal(lines, [5, 0, 1, 2, 3, 0])  # a closed outline
    at_eye = wrt.Camera.look_at(eye=(0, 5, 30), target=(0, 0, 0), fov_y_deg=30, clipping_range=(0.0, 100.0))
    plotter = wrt.preview(scene, camera=at_eye, window_size=(32, 24), show_text=False)
    try:
        assert "near_plane" not in plotter.actors and "frustum" in plotter.actors
    finally:
        plotter.close()


def transform(angles, scale, translate) -> np.ndarray:
    """``(4, 4)`` column-vector matrix: scale, then turn about X, Y, Z by ``angles`` (radians), then translate."""
    m = np.diag(np.r_[np.asarray(scale, np.float64), 1.0])
    for axis, a in enumerate(angles):
        turn = np.eye(4)
        i, j = [k for k in range(3) if k != axis]
        turn[[i, i, j, j], [i, j, i, j]] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a)
        m = turn @ m
    m[:3, 3] = translate
    return m


def drawn_lines(mesh, light: int) -> list:
    """The polylines (``(n, 3)`` float64 points each) of ``mesh``'s cells whose ``"light"`` is ``light``."""
    flat, points, lines, k = np.asarray(mesh.lines), np.asarray(mesh.points, np.float64), [], 0
    for owner in mesh.cell_data["light"]:
        n = flat[k]
        if owner == light:
            lines.append(points[flat[k + 1 : k + 1 + n]])
        k += n + 1
    return lines


def test_lights_are_drawn_with_their_world_space_shapes():
    """Lights were not drawn at all. Each is now outlined where the renderer puts it, checked here against its own
    fields in float64 numpy: a rect light's corners ``to_world @ (+-w/2, +-h/2, 0, 1)`` and a tick to its lit (-Z)
    side, a disk's ellipse (uneven scale) and a cylinder's tube (radius uneven across it) in their local frames, a
    sphere's points at its radius, a point light's star on its position, a distant light's arrow along its
    direction; a dome is named in the summary, not drawn; show_lights=False draws none."""
    from wrt.lights import CylinderLight, DiskLight, DomeLight, RectLight, SphereLight

    white = np.ones(3)
    rect = RectLight(transform((0.3, -0.5, 1.0), (1.0, 2.0, 1.0), (1, 4, 2)), 3.0, 1.5, white, path="/Rect")
    disk = DiskLight(transform((1.2, 0.1, -0.4), (2.0, 0.5, 1.0), (-3, 2, 1)), 0.75, white, path="/Disk")
    tube = CylinderLight(transform((0.2, 0.9, 0.0), (1.0, 1.0, 3.0), (2, -1, 3)), 4.0, 0.5, white, path="/Tube")
    ball = SphereLight(np.array([0.5, 6.0, -2.0]), 1.25, white, path="/Ball")
    point = SphereLight(np.array([-4.0, 3.0, 0.0]), 0.5, white, treat_as_point=True, path="/Point")
    sun_direction = np.array([1.0, -3.0, 0.5]) / np.linalg.norm([1.0, -3.0, 0.5])
    sun = wrt.DistantLight(sun_direction, white, path="/Sun")
    lights = [rect, disk, tube, ball, point, sun, DomeLight(white, path="/Dome")]
    floor = quad((-5, 0, -5), (10, 0, 0), (0, 0, 10), name="/floor")
    scene = wrt.Scene(meshes=[floor], lights=lights)
    plotter = wrt.preview(scene, window_size=(32, 24))
    try:
        mesh = plotter.actors["lights"].mapper.dataset
        text = summary_text(plotter)
    finally:
        plotter.close()

    def local(light, p):  # points in the light's own space
        return (np.linalg.inv(light.to_world) @ np.c_[p, np.ones(len(p))].T).T[:, :3]

    outline, tick = drawn_lines(mesh, 0)
    corners = (rect.to_world @ np.array([[sx * 1.5, sy * 0.75, 0.0, 1.0] for sx in (-1, 1) for sy in (-1, 1)]).T).T
    assert len(outline) == 5
    np.testing.assert_allclose(outline[0], outline[-1])  # closed
    np.testing.assert_allclose(sorted(map(tuple, outline[:4])), sorted(map(tuple, corners[:, :3])), atol=1e-9)
    np.testing.assert_allclose(tick[0], rect.to_world[:3, 3], atol=1e-12)
    assert local(rect, tick)[1, 2] < 0  # towards -Z, the side it lights

    ring = np.concatenate(drawn_lines(mesh, 1)[:1])
    q = local(disk, ring)
    np.testing.assert_allclose(q[:, 2], 0.0, atol=1e-9)
    np.testing.assert_allclose(np.hypot(q[:, 0], q[:, 1]), 0.75, rtol=1e-9)
    assert local(disk, drawn_lines(mesh, 1)[1])[1, 2] < 0

    q = local(tube, np.concatenate(drawn_lines(mesh, 2)))
    np.testing.assert_allclose(np.hypot(q[:, 1], q[:, 2]), 0.5, rtol=1e-9)
    assert np.all(np.abs(q[:, 0]) <= 2.0 + 1e-9)
    np.testing.assert_allclose([q[:, 0].min(), q[:, 0].max()], [-2.0, 2.0], atol=1e-9)

    p = np.concatenate(drawn_lines(mesh, 3))
    np.testing.assert_allclose(np.linalg.norm(p - ball.position, axis=1), 1.25, rtol=1e-9)
    for axis in range(3):  # its three great circles span it
        np.testing.assert_allclose([p[:, axis].min(), p[:, axis].max()], ball.position[axis] + np.array([-1.25, 1.25]),
                                   atol=1e-9)

    star = drawn_lines(mesh, 4)
    assert len(star) == 3
    for segment in star:
        np.testing.assert_allclose(segment.mean(axis=0), point.position, atol=1e-9)

    shaft = drawn_lines(mesh, 5)[0]
    np.testing.assert_allclose((shaft[1] - shaft[0]) / np.linalg.norm(shaft[1] - shaft[0]), sun_direction, atol=1e-9)
    lower, upper = scene.bounds()
    centre = (np.asarray(lower, np.float64) + np.asarray(upper, np.float64)) / 2
    to_centre = centre - shaft[1]
    np.testing.assert_allclose(to_centre / np.linalg.norm(to_centre), sun_direction, atol=1e-9)  # it points there

    assert drawn_lines(mesh, 6) == []
    assert "7 lights: 6 drawn, 1 dome not drawn (light from every direction)" in text, text
    plotter = wrt.preview(scene, window_size=(32, 24), show_lights=False)
    try:
        assert "lights" not in plotter.actors
        assert "7 lights" not in summary_text(plotter)
    finally:
        plotter.close()


def test_light_summary_counts_what_is_not_drawn_and_what_is_left_out():
    """Beyond the budget of lights drawn, the summary says how many were left out; a mesh light is drawn as its mesh
    (with the scene), a dome not at all."""
    from wrt.lights import MeshLight, SphereLight
    from wrt.preview_lights import light_glyphs

    balls = [SphereLight(np.array([float(k), 0.0, 0.0]), 0.25, np.ones(3)) for k in range(5)]
    mesh, note = light_glyphs([MeshLight("/M", np.ones(3))] + balls, np.zeros(3), np.ones(3), max_lights=3)
    assert sorted(set(mesh.cell_data["light"])) == [1, 3, 5]  # indices in the list given: the row's ends and middle
    assert note == "6 lights: 3 drawn, 2 left out, 1 mesh light drawn as its mesh", note
    assert light_glyphs([MeshLight("/M", np.ones(3))], np.zeros(3), np.ones(3)) == (
        None, "1 light: 1 mesh light drawn as its mesh")


def test_missing_rays_of_a_very_wide_lens_end_on_the_far_rectangle():
    """A focal length of 1e-9 over a 20-unit film: the corner rays advance 1e-10 of camera depth per unit of length.
    A missing ray's end was its far depth over that rate clamped to 1e-6, so it stopped at depth 6e-4, near the eye,
    where the drawn far rectangle (and the summary's promise) lies 6 deep; it ends on that rectangle now."""
    scene = wrt.Scene(shapes=[ball(0.0)])
    scene.shapes[0].to_world[2, 3] = -5.0
    cam = wrt.Camera(focal_length=1e-9, horizontal_aperture=20.0, vertical_aperture=15.0)
    plotter = wrt.preview(scene, camera=cam, rays=4, width=40, height=30, window_size=(32, 24), show_text=False)
    try:
        assert "rays_hit" not in plotter.actors
        origins, ends = np.asarray(plotter.actors["rays_miss"].mapper.dataset.points, np.float64).reshape(2, -1, 3)
        frame = np.asarray(plotter.actors["frustum"].mapper.dataset.points, np.float64)
    finally:
        plotter.close()
    np.testing.assert_allclose(origins, 0.0, atol=1e-12)  # from the eye
    far = frame[4:8]
    assert np.allclose(far[:, 2], -5.5)  # the ball's deepest corner, 5.5 along -Z (camera-space depth)
    np.testing.assert_allclose(ends[:, 2], -5.5, rtol=1e-6)  # the far rectangle's plane, z = -5.5


@pytest.mark.parametrize("x, message", [
    (np.nan, r"instance 1 \(/instances\[1\]\) has a NaN or infinite transform"),
    (1e39, r"instance 1 \(/instances\[1\]\) .*(beyond|past) float32's range"),
])
def test_an_instance_the_renderer_cannot_place_is_refused_by_the_previews_in_its_words(x, message):
    """An instance whose transform holds a NaN (or lies past float32's range, where rays are traced) was drawn by
    ``wrt.preview`` without sample rays, and made a block by ``to_pyvista``, with NaN points (or at 1e39) without a
    word, where a trace or a render refuses the scene naming the instance. Both previews refuse it so too."""
    triangle = wrt.Mesh("/P/M", np.float32([[-1, -1, 0], [1, -1, 0], [0, 1, 0]]), np.array([[0, 1, 2]]), [0])
    to_world = np.tile(np.eye(4), (2, 1, 1))
    to_world[1, 0, 3] = x
    scene = wrt.Scene(prototypes=[Prototype("/P", [triangle])], instances=Instances.from_transforms([0, 0], to_world))
    with pytest.raises(ValueError, match=message):
        wrt.trace(scene, np.zeros((1, 3), np.float32), np.float32([[0, 0, -1]]))  # the renderer's words
    with pytest.raises(ValueError, match=message):
        wrt.preview(scene, window_size=(32, 24)).close()
    with pytest.raises(ValueError, match=message):
        to_pyvista(scene)
