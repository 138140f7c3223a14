"""Per-instance texture coordinates on PointInstancers: an ``st`` primvar on the instancer (``vertex``, ``varying`` or
``faceVarying``: one value per instance; ``constant``: one for all) is the st of its prototypes' meshes that have none,
as Storm reads an instance primvar in their material's primvar reader (one palette texel per instance). The oracle is
the checker texel at the st USD gives each instance (``UsdGeom.Primvar.ComputeFlattened``), else at the reader's
fallback."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import warp as wp

wp.config.quiet = True

pxr = pytest.importorskip("pxr")
from pxr import Gf, Sdf, Usd, UsdGeom, UsdShade, Vt  # noqa: E402
from test_materials import CHECKER, add_quad, bind, define_tet_or_patch, textured_stage, write_png  # noqa: E402

import wrt  # noqa: E402

XS = (-3.0, 0.0, 3.0)  # the instances' x
STS = [(0.75, 0.25), (0.25, 0.25), (0.75, 0.75)]  # CHECKER's grey, blue and green blocks' middles
FALLBACK = (0.25, 0.75)  # the reader's fallback st: the red block's middle
FALLBACK_TEXEL = CHECKER[int((1.0 - FALLBACK[1]) * 8), int(FALLBACK[0] * 8)] / 255


def instancer_st_stage(tmp_path, interpolation="vertex", beneath=False, values=STS, indices=None, n=3, native=False,
                       type_name=Sdf.ValueTypeNames.TexCoord2fArray):
    """A PointInstancer of ``n`` textured quads without st at x = ``XS``, with ``primvars:st`` of ``values`` (of
    ``type_name``); its prototype under it (``beneath``) or under an invisible /Protos, the quad itself or
    (``native``) a native instance of a class /Asset holding it."""
    png = write_png(tmp_path / "checker.png", CHECKER)
    path = textured_stage(tmp_path, png, wrap="clamp", color_space="raw")
    stage = Usd.Stage.Open(path)
    stage.RemovePrim("/Quad")
    UsdShade.Shader(stage.GetPrimAtPath("/Looks/Tex/St")).CreateInput("fallback", Sdf.ValueTypeNames.Float2).Set(
        Gf.Vec2f(*FALLBACK))
    proto_path = "/PI/Protos/Quad" if beneath else "/Protos/Quad"
    if not beneath:
        UsdGeom.Scope.Define(stage, "/Protos").MakeInvisible()
    pi = UsdGeom.PointInstancer.Define(stage, "/PI")
    quad = add_quad(stage, "/Asset/Quad" if native else proto_path)
    UsdGeom.PrimvarsAPI(quad).RemovePrimvar("st")
    bind(quad, UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    if native:
        stage.GetPrimAtPath("/Asset").SetSpecifier(Sdf.SpecifierClass)
        instance = stage.DefinePrim(proto_path, "Xform")
        instance.GetReferences().AddInternalReference("/Asset")
        instance.SetInstanceable(True)
    pi.CreatePrototypesRel().SetTargets([proto_path])
    pi.CreateProtoIndicesAttr([0] * n)
    pi.CreatePositionsAttr([(XS[k % 3], 3.0 * (k // 3), 0.0) for k in range(n)])
    if values is not None:
        primvar = UsdGeom.PrimvarsAPI(pi).CreatePrimvar("st", type_name, interpolation)
        primvar.Set(values)
        if indices is not None:
            primvar.SetIndices(Vt.IntArray(indices))
    stage.Save()
    return path


def expected_texels(path, n=3):
    """``(n, 3)`` CHECKER texel at the st USD gives each instance of /PI (constant: the one value to all), else (none,
    or one that is not finite in float32) at the reader's fallback."""
    stage = Usd.Stage.Open(path)
    primvar = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/PI")).GetPrimvar("st")
    flattened = primvar.ComputeFlattened() if primvar and primvar.HasValue() else None
    sts = [FALLBACK] * n if flattened is None else [flattened[0 if len(flattened) == 1 else k] for k in range(n)]
    finite = [bool(np.all(np.abs([s, t]) <= np.finfo(np.float32).max)) for s, t in sts]
    return np.array([CHECKER[int((1.0 - t) * 8), int(s * 8)] / 255 if ok else FALLBACK_TEXEL
                     for (s, t), ok in zip(sts, finite)])


def albedo_of_instances(scene, n=3):
    """``(n, 3)`` albedo seen at the middle of each instance's quad."""
    out = []
    for k in range(n):
        x, y = XS[k % 3], 3.0 * (k // 3)
        cam = wrt.Camera.orthographic(eye=(x, y, 5), target=(x, y, 0), height=1.0)
        img = wrt.render(scene, camera=cam, width=2, height=2, device="cpu", integrator="albedo").rgb
        out.append(img.reshape(-1, 3).mean(axis=0))
    return np.array(out)


def load_quietly(path):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene = wrt.load_usd(path)
    return scene, [str(w.message) for w in caught]


@pytest.mark.parametrize("interpolation", ["vertex", "varying", "faceVarying"])
@pytest.mark.parametrize("beneath", [False, True])
def test_per_instance_st_picks_each_instances_texel(tmp_path, interpolation, beneath):
    """Each instance shows the texel at its own st: all showed the reader's fallback (red), with a warning that the
    prototype's mesh had no st. faceVarying is one value per instance too (UsdGeomPointInstancer's primvar rules)."""
    path = instancer_st_stage(tmp_path, interpolation, beneath)
    scene, messages = load_quietly(path)
    assert not [m for m in messages if "fallback st" in m], messages
    np.testing.assert_allclose(albedo_of_instances(scene), expected_texels(path), atol=2e-3)
    assert len(scene.prototypes) == 3  # a copy of the prototype per distinct st


@pytest.mark.parametrize("beneath", [False, True])
def test_per_instance_st_reaches_a_native_instance_prototype(tmp_path, beneath):
    """A prototype that is a native instance hands the instance's st on to its prototype's mesh: it read the fallback
    there (the instancer's st was taken for a blocker)."""
    path = instancer_st_stage(tmp_path, beneath=beneath, native=True)
    scene, messages = load_quietly(path)
    assert not [m for m in messages if "fallback st" in m], messages
    np.testing.assert_allclose(albedo_of_instances(scene), expected_texels(path), atol=2e-3)


@pytest.mark.parametrize("native", [False, True])
@pytest.mark.parametrize("kind", ["TetMesh", "NurbsPatch"])
def test_per_instance_st_reaches_a_tet_mesh_or_nurbs_patch_prototype(tmp_path, kind, native):
    """A TetMesh or NurbsPatch without st in the prototype (or in a native instance's prototype) reads each
    instance's st, as a mesh there does: it read the reader's fallback on every instance, with a warning that it had
    no st."""
    path = instancer_st_stage(tmp_path, native=native)
    stage = Usd.Stage.Open(path)
    quad = "/Asset/Quad" if native else "/Protos/Quad"
    stage.RemovePrim(quad)
    define_tet_or_patch(stage, kind)  # at /Surface, covering each instance's middle (and no other's)
    layer = stage.GetRootLayer()
    Sdf.CopySpec(layer, "/Surface", layer, quad)
    stage.RemovePrim("/Surface")
    bind(stage.GetPrimAtPath(quad), UsdShade.Material(stage.GetPrimAtPath("/Looks/Tex")))
    stage.Save()
    assert stage.GetPrimAtPath(quad).GetTypeName() == kind
    scene, messages = load_quietly(path)
    assert not [m for m in messages if "fallback st" in m], messages
    np.testing.assert_allclose(albedo_of_instances(scene), expected_texels(path), atol=2e-3)


def test_indexed_per_instance_st_is_flattened(tmp_path):
    path = instancer_st_stage(tmp_path, values=STS[:2], indices=[1, 0, 1])
    scene, _ = load_quietly(path)
    np.testing.assert_allclose(albedo_of_instances(scene), expected_texels(path), atol=2e-3)
    assert len(scene.prototypes) == 2  # instances of one st share a copy


@pytest.mark.parametrize("interpolation, beneath", [("constant", False), ("constant", True), ("uniform", False),
                                                    ("uniform", True)])
def test_a_constant_or_uniform_st_on_the_instancer_reaches_every_instance(tmp_path, interpolation, beneath):
    """As a constant displayColor on the instancer does (wrt.usd_instancer_primvars): every instance reads it. A uniform
    one is the same (UsdGeomPointInstancer's primvar rules: its entire value applies to each instance); it was
    ignored with a warning, and every instance read the fallback."""
    path = instancer_st_stage(tmp_path, interpolation, beneath, values=STS[:1])
    scene, messages = load_quietly(path)
    assert not [m for m in messages if "PointInstancer st" in m], messages
    np.testing.assert_allclose(albedo_of_instances(scene), expected_texels(path), atol=2e-3)


def test_too_many_distinct_st_warn_naming_the_instancer(tmp_path, monkeypatch):
    """Past the cap of copies per prototype the instances read the reader's fallback, with a warning naming the
    instancer and the count, not a silent mix."""
    import wrt.usd_instancer_primvars as reader

    monkeypatch.setattr(reader, "MAX_INSTANCE_UVS", 2)
    path = instancer_st_stage(tmp_path)
    scene, messages = load_quietly(path)
    assert [m for m in messages if "3 distinct st" in m and m.endswith("/PI")], messages
    np.testing.assert_allclose(albedo_of_instances(scene), [FALLBACK_TEXEL] * 3, atol=2e-3)


@pytest.mark.parametrize("value", [float("nan"), 1e39])
def test_non_finite_instance_st_reads_the_fallback_with_a_warning(tmp_path, value):
    """An instance st of NaN, or of a double past float32 (1e39, finite in double), reads the reader's fallback st
    with a warning naming the instancer. 1e39 was handed down as it was: the mesh's float32 st held inf there, the
    texture showed its own fallback (black), and only numpy's "overflow encountered in cast" was said."""
    path = instancer_st_stage(tmp_path, values=[STS[0], (value, 0.5), STS[2]],
                              type_name=Sdf.ValueTypeNames.TexCoord2dArray)
    scene, messages = load_quietly(path)
    assert [m for m in messages if "not finite" in m and m.endswith("/PI")], messages
    assert not [m for m in messages if "overflow" in m], messages
    np.testing.assert_allclose(albedo_of_instances(scene), expected_texels(path), atol=2e-3)


@pytest.mark.parametrize("beneath", [False, True])
def test_a_constant_st_on_the_instancer_holding_one_value_rather_than_an_array_reaches_every_instance(tmp_path,
                                                                                                      beneath):
    """A constant ``texCoord2f primvars:st = (0.75, 0.25)`` (one value, not an array of one) is that value, as
    ``ComputeFlattened`` gives it and as it is on a mesh, a gprim or inherited (e151e21): on an instancer whose
    prototypes lie elsewhere it was ignored as "cannot be read", every instance at the reader's fallback."""
    path = instancer_st_stage(tmp_path, "constant", beneath, values=Gf.Vec2f(*STS[0]),
                              type_name=Sdf.ValueTypeNames.TexCoord2f)
    stage = Usd.Stage.Open(path)
    flattened = UsdGeom.PrimvarsAPI(stage.GetPrimAtPath("/PI")).GetPrimvar("st").ComputeFlattened()
    s, t = flattened  # the oracle: USD's value, one st for all
    scene, messages = load_quietly(path)
    assert not [m for m in messages if "PointInstancer st" in m], messages
    np.testing.assert_allclose(albedo_of_instances(scene), [CHECKER[int((1.0 - t) * 8), int(s * 8)] / 255] * 3,
                               atol=2e-3)


def test_unique_rows_groups_instance_st_as_numpy_unique_does():
    """The instancer's st of each instance is grouped by ``wrt.unique.unique_rows`` (one lexsort: np.unique(axis=0)
    took 1.4 s for 1M instances): the same distinct rows, in the same order, and the same group of each row as
    ``np.unique(axis=0, return_inverse=True)``, over repeated rows, infinities (a non-finite st) and one column."""
    from wrt.unique import unique_rows

    rng = np.random.default_rng(123)
    pool = np.array([0.0, 1.0, np.inf, -np.inf, 0.5, 2.0, -3.0, 1e-300])
    for trial in range(100):
        n, k = int(rng.integers(0, 200)), int(rng.integers(1, 4))
        values = rng.choice(pool, (n, k)) if trial % 2 else rng.random((max(n // 3, 1), k))[rng.integers(0, max(
            n // 3, 1), n)]
        expected, expected_group = np.unique(values, axis=0, return_inverse=True)
        distinct, group = unique_rows(values)
        assert distinct.tobytes() == expected.tobytes() and distinct.shape == expected.shape
        assert np.array_equal(group, expected_group.reshape(-1))
