"""The preview's ``bvh_layout`` (``wrt preview --bvh-layout``): the boxes drawn for a wide layout (BVH4, BVH8) are
those of the wide tree that ``wrt.trace`` traces, checked against the node boxes recomputed in float64 numpy from
the triangles below each wide node, found by walking the layout's child links."""

import warnings

import numpy as np
import pytest

pv = pytest.importorskip("pyvista")
pv.OFF_SCREEN = True

from preview_boxes import box_data  # noqa: E402

import wrt  # noqa: E402
from wrt.bvh import convert_layout  # noqa: E402
from wrt.cli import main  # noqa: E402
from wrt.instancing import Instances, Prototype  # noqa: E402
from wrt.trace import get_accelerator  # noqa: E402

BUILDER = "sweep_sah"  # an SAH tree without pre-splits: every leaf box holds its triangles whole
WIDTHS = {"wide": 4, "wide8": 8}


@pytest.fixture(scope="module")
def soup():
    rng = np.random.default_rng(11)
    n = 120
    centres = rng.uniform(-4.0, 4.0, (n, 1, 3))
    points = (centres + rng.uniform(-0.3, 0.3, (n, 3, 3))).reshape(-1, 3).astype(np.float32)
    return wrt.Scene(meshes=[wrt.Mesh("/Soup", points, np.arange(3 * n).reshape(n, 3), np.arange(n))])


def walked_cut(scene, layout: str, depth: int | None) -> list[np.ndarray]:
    """The triangle ids under each box of the cut at ``depth`` (``None``: the leaves) of the wide tree the trace
    traces in ``layout``, found by walking its child links ``(ref, count)`` from the root."""
    wide = convert_layout(get_accelerator(scene, "wrt", BUILDER, "cpu", layout).bvh, layout)
    width = wide.width

    def below(node: int) -> np.ndarray:
        ids = []
        for slot in range(node * width, node * width + width):
            ref, count = int(wide.refs[slot]), int(wide.counts[slot])
            if count > 0:
                ids.append(wide.prim_ids[ref : ref + count])
            elif count == 0:
                ids.append(below(ref))
        return np.concatenate(ids)

    cut, stack = [], [(0, 0)]
    while stack:
        node, d = stack.pop()
        if depth is not None and d == depth:
            cut.append(below(node))
            continue
        for slot in range(node * width, node * width + width):
            ref, count = int(wide.refs[slot]), int(wide.counts[slot])
            if count > 0 and (depth is None or d + 1 <= depth):
                cut.append(wide.prim_ids[ref : ref + count])
            elif count == 0:
                stack.append((ref, d + 1))
    return cut


def drawn_boxes(scene, **options) -> np.ndarray:
    """``(K, 2, 3)`` float64 (lower, upper) of each box the preview drew."""
    plotter = wrt.preview(scene, builder=BUILDER, window_size=(32, 24), show_text=False, **options)
    try:
        corners = np.asarray(plotter.actors["bvh"].mapper.dataset.points, np.float64).reshape(-1, 8, 3)
    finally:
        plotter.close()
    return np.stack([corners.min(axis=1), corners.max(axis=1)], axis=1)


def as_set(boxes: np.ndarray) -> set:
    return {tuple(np.round(b.ravel(), 5)) for b in boxes}


@pytest.mark.parametrize("layout", ["wide", "wide8"])
def test_wide_boxes_sah_share_counts_the_triangles_below_each_wide_node(soup, layout):
    """Coloured by SAH share at depth 2, each box carries A(n) N(n) / sum A N with N the triangles walked below it."""
    points, indices = soup.triangles()
    corners = np.asarray(points, np.float64)[indices]
    plotter = wrt.preview(soup, builder=BUILDER, bvh_depth=2, bvh_layout=layout, bvh_color="sah",
                          window_size=(32, 24), show_text=False)
    drawn, shares = box_data(plotter, "sah_share")
    cut = walked_cut(soup, layout, 2)
    lower = np.array([corners[ids].min(axis=(0, 1)) for ids in cut])
    upper = np.array([corners[ids].max(axis=(0, 1)) for ids in cut])
    e = upper - lower
    cost = (e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]) * np.array([len(ids) for ids in cut])
    match = np.abs(drawn.min(axis=1)[:, None] - lower[None]).max(axis=2).argmin(axis=1)
    np.testing.assert_allclose(shares, (cost / cost.sum())[match], rtol=1e-5)


@pytest.mark.parametrize("layout", ["wide", "wide8"])
def test_wide_cut_boxes_are_the_walked_wide_nodes_boxes(soup, layout):
    """At depths 0 to 3 and for the leaves, the boxes drawn are, as a set (float32 tolerance), the float64 bounds of
    the triangles below each wide node of the cut; each holds its triangles; a cut at depth D has at most width^D
    boxes and, below the root, differs from the binary tree's cut at D."""
    points, indices = soup.triangles()
    corners = np.asarray(points, np.float64)[indices]  # (N, 3, 3)
    for depth in [0, 1, 2, 3, None]:
        options = {"bvh_leaves": True} if depth is None else {"bvh_depth": depth}
        drawn = drawn_boxes(soup, bvh_layout=layout, **options)
        cut = walked_cut(soup, layout, depth)
        expected = np.array([[corners[ids].min(axis=(0, 1)), corners[ids].max(axis=(0, 1))] for ids in cut])
        assert len(drawn) == len(expected), (layout, depth)
        distance = np.abs(drawn[:, None] - expected[None]).max(axis=(2, 3))  # drawn x expected
        match = distance.argmin(axis=1)
        assert sorted(match.tolist()) == list(range(len(expected))), (layout, depth)  # one to one
        np.testing.assert_allclose(drawn, expected[match], rtol=1e-6, atol=1e-6)
        for box, ids in zip(drawn, (cut[m] for m in match)):
            assert (box[0] <= corners[ids].min(axis=(0, 1))).all() and (corners[ids].max(axis=(0, 1)) <= box[1]).all()
        binary = drawn_boxes(soup, **options)
        if depth is None:  # the wide tree keeps the binary leaves
            assert as_set(drawn) == as_set(binary)
        else:
            assert len(drawn) <= WIDTHS[layout] ** depth
            assert (as_set(drawn) != as_set(binary)) == (depth > 0), (layout, depth)


def test_default_layout_is_binary_and_the_summary_names_the_wide_one(soup):
    assert as_set(drawn_boxes(soup, bvh_depth=2)) == as_set(drawn_boxes(soup, bvh_depth=2, bvh_layout="binary"))
    plotter = wrt.preview(soup, builder=BUILDER, bvh_depth=1, bvh_layout="wide", window_size=(640, 480))
    try:
        text = plotter.actors["summary"].GetText(2).replace("\n  ", " ")
    finally:
        plotter.close()
    nodes = convert_layout(get_accelerator(soup, "wrt", BUILDER, "cpu").bvh, "wide").num_nodes
    assert f"BVH4 ({BUILDER}, layout wide) {nodes} nodes" in text


def test_unknown_layout_and_wide_layout_of_instances_are_refused(soup):
    with pytest.raises(ValueError, match="unknown BVH layout 'wide4'.*valid layouts: binary, compact, wide, wide8"):
        wrt.preview(soup, bvh_depth=1, bvh_layout="wide4")
    mesh = soup.meshes[0]
    scene = wrt.Scene(prototypes=[Prototype("/P", [mesh])],
                      instances=Instances.from_transforms(np.zeros(2, int), np.tile(np.eye(4), (2, 1, 1))))
    with pytest.raises(ValueError, match=r"bvh_layout='wide8': .*instances or analytic shapes.*bvh_layout='binary'"):
        wrt.preview(scene, bvh_depth=1, bvh_layout="wide8")


def test_cli_bvh_layout(tmp_path, capsys):
    usda = tmp_path / "tri.usda"
    usda.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3, 3]\n    int[] faceVertexIndices = '
                    '[0, 1, 2, 1, 3, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0)]\n}\n')
    out = tmp_path / "wide.png"
    assert main(["preview", str(usda), "--bvh-depth", "1", "--bvh-layout", "wide8", "-o", str(out), "--window",
                 "64x48", "-q"]) == 0
    assert out.is_file()
    with pytest.raises(SystemExit) as e:
        main(["preview", str(usda), "--bvh-depth", "1", "--bvh-layout", "wide4", "-q"])
    assert e.value.code == 2
    assert "--bvh-layout: invalid choice: 'wide4'" in capsys.readouterr().err


def test_cli_refuses_a_wide_layout_of_analytic_shapes_naming_the_flag(tmp_path, capsys):
    usda = tmp_path / "ball.usda"
    usda.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    double radius = 2\n}\n')
    out = tmp_path / "ball.png"
    assert main(["preview", str(usda), "--bvh-leaves", "--bvh-layout", "wide", "-o", str(out), "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "--bvh-layout wide: " in errors[0] and "use --bvh-layout binary" in errors[0]
    assert not out.exists()


def test_a_layout_without_boxes_is_only_warned_about_in_a_scene_of_shapes(tmp_path, capsys):
    """Without --bvh-depth or --bvh-leaves no boxes are drawn, and --bvh-layout is named in a warning saying so, as
    --bvh-color is: for a scene of analytic shapes the run then failed on that option all the same (the warning
    'none are drawn', then 'error: --bvh-layout wide: ... has instances or analytic shapes', status 2, no PNG), as
    wrt.preview(bvh_layout='wide') with no boxes raised."""
    usda = tmp_path / "ball.usda"
    usda.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    double radius = 2\n}\n')
    out = tmp_path / "ball.png"
    assert main(["preview", str(usda), "--bvh-layout", "wide", "-o", str(out), "--window", "64x48", "-q"]) == 0
    assert out.is_file()
    err = capsys.readouterr().err
    assert "--bvh-layout wide picks the BVH whose boxes are drawn, and none are drawn" in err
    assert "error" not in err
    plotter = wrt.preview(str(usda), bvh_layout="wide8", window_size=(64, 48))
    try:
        assert "bvh" not in plotter.actors
    finally:
        plotter.close()


def test_compact_layout_of_instances_or_shapes_is_refused_as_wide_is(soup, tmp_path, capsys):
    """``compact`` is the binary tree of the flattened triangles where the trace takes it for a scene with instances
    (a BvhAccelerator over the 2 x 120 triangles, not the two-level BVH the preview draws); the preview drew the
    TLAS's boxes for it without a word, where the help says 'only binary' for such a scene."""
    mesh = soup.meshes[0]
    scene = wrt.Scene(prototypes=[Prototype("/P", [mesh])],
                      instances=Instances.from_transforms(np.zeros(2, int), np.tile(np.eye(4), (2, 1, 1))))
    traced = get_accelerator(scene, "wrt", BUILDER, "cpu", "compact")
    assert traced.bvh.num_prims == 2 * len(mesh.indices)  # flattened: not the TLAS over 2 instances
    with pytest.raises(ValueError, match=r"bvh_layout='compact': .*instances or analytic shapes.*bvh_layout='binary'"):
        wrt.preview(scene, bvh_depth=1, bvh_layout="compact")
    usda = tmp_path / "ball.usda"
    usda.write_text('#usda 1.0\ndef Sphere "Ball"\n{\n    double radius = 2\n}\n')
    out = tmp_path / "ball.png"
    assert main(["preview", str(usda), "--bvh-depth", "1", "--bvh-layout", "compact", "-o", str(out), "-q"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if line.startswith("wrt:")]
    assert len(errors) == 1 and "--bvh-layout compact: " in errors[0] and "use --bvh-layout binary" in errors[0]
    assert not out.exists()


def traced_rows(scene, builder: str, layout: str) -> list[tuple]:
    """``(depth, lower, upper, references below, is leaf)`` of each wide node and leaf slot of the tree the trace
    traces on the CPU, read from its device arrays (six runs of ``width`` floats per node, ``(ref, count)`` links)
    and walked from the root in float64: a wide node's box the union of its used slots'."""
    bvh = get_accelerator(scene, "wrt", builder, "cpu", layout).device_bvh
    width, boxes, links = bvh.width, bvh.boxes.numpy().astype(np.float64), bvh.links.numpy()
    rows = []

    def walk(node: int, depth: int) -> int:
        lower, upper, total = np.full(3, np.inf), np.full(3, -np.inf), 0
        for j in range(width):
            ref, count = (int(v) for v in links[node * width + j])
            if count < 0:
                continue
            base = node * 6 * width + j
            lo, hi = boxes[base + np.arange(3) * width], boxes[base + np.arange(3, 6) * width]
            lower, upper = np.minimum(lower, lo), np.maximum(upper, hi)
            if count > 0:
                rows.append((depth + 1, lo, hi, count, True))
            total += count if count > 0 else walk(ref, depth + 1)
        rows.append((depth, lower, upper, total, False))
        return total

    walk(0, 0)
    return rows


@pytest.mark.parametrize("builder", ["sah", "sweep_sah", "median", "middle", "lbvh", "ploc"])
def test_small_and_degenerate_meshes_draw_the_traced_wide_tree(builder):
    """For 1 triangle (a root leaf) and for 3 triangles and a point and a segment (degenerate), at depth 0, past
    the deepest leaf and for the leaves, the boxes drawn are those the trace's wide tree holds for each builder
    (sah pre-splits), and their SAH shares A N / sum A N sum to 1."""
    tri = [[0, 0, 0], [1, 0, 0], [0, 1, 0]]
    point, segment = [[5, 5, 5]] * 3, [[0, 3, 0], [1, 3, 0], [2, 3, 0]]
    degenerate = tri + [[2, 0, 1], [3, 0, 1], [2, 2, 1]] + point + segment
    for corners in (tri, degenerate):
        points = np.array(corners, np.float32)
        n = len(points) // 3
        scene = wrt.Scene(meshes=[wrt.Mesh("/M", points, np.arange(3 * n).reshape(n, 3), np.arange(n))])
        for layout in WIDTHS:
            rows = traced_rows(scene, builder, layout)
            deepest = max(r[0] for r in rows)
            for depth in (0, deepest + 2, None):
                if depth is None:
                    options, cut = {"bvh_leaves": True}, [r for r in rows if r[4]]
                else:
                    options, cut = {"bvh_depth": depth}, [r for r in rows if r[0] == depth or (r[4] and r[0] < depth)]
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")  # past the deepest leaf: said, and checked in test_preview
                    plotter = wrt.preview(scene, builder=builder, bvh_layout=layout, bvh_color="sah",
                                          window_size=(32, 24), show_text=False, **options)
                drawn, shares = box_data(plotter, "sah_share")
                drawn = np.stack([drawn.min(axis=1), drawn.max(axis=1)], axis=1)
                expected = np.array([[r[1], r[2]] for r in cut])
                e = expected[:, 1] - expected[:, 0]
                cost = (e[:, 0] * e[:, 1] + e[:, 1] * e[:, 2] + e[:, 2] * e[:, 0]) * [r[3] for r in cut]
                key = (builder, layout, n, depth)
                assert len(drawn) == len(expected), key
                order = np.lexsort(drawn.reshape(len(drawn), -1).T[::-1])
                oracle = np.lexsort(expected.reshape(len(expected), -1).T[::-1])
                np.testing.assert_array_equal(drawn[order], expected[oracle], err_msg=str(key))
                np.testing.assert_allclose(shares[order], (cost / cost.sum())[oracle], rtol=1e-6, err_msg=str(key))
                assert abs(shares.sum() - 1.0) < 1e-9, key


@pytest.mark.parametrize("options, said, flag", [({"bvh_layout": "wide"}, "bvh_layout='wide'", "--bvh-layout wide"),
                                                 ({"bvh_color": "sah"}, "bvh_color='sah'", "--bvh-color sah"),
                                                 ({"bvh_layout": "wide", "bvh_depth": 1}, None, None)])
def test_a_layout_or_colouring_without_boxes_is_warned_about_as_the_cli_warns(soup, tmp_path, capsys, options, said,
                                                                              flag):
    """``wrt.preview(bvh_layout='wide')`` without ``bvh_depth`` or ``bvh_leaves`` drew no boxes without a word, where
    ``wrt preview --bvh-layout wide`` warns; the CLI says it once, in its flags' names."""
    with warnings.catch_warnings(record=True) as raised:
        warnings.simplefilter("always")
        wrt.preview(soup, window_size=(32, 24), show_text=False, **options).close()
    words = [str(w.message) for w in raised if "only affects the BVH boxes" in str(w.message)]
    assert words == ([] if said is None else [f"{said} only affects the BVH boxes, and none are drawn without "
                                              "bvh_depth or bvh_leaves"])
    if said is None:
        return
    usda = tmp_path / "tri.usda"
    usda.write_text('#usda 1.0\ndef Mesh "M"\n{\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = '
                    '[0, 1, 2]\n    point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n')
    assert main(["preview", str(usda), *flag.split(), "-o", str(tmp_path / "p.png"), "--window", "32x24", "-q"]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if "BVH" in line]
    assert len(warned) == 1 and warned[0].startswith(f"wrt: warning: {flag} "), warned
