"""Glowing round tubes are sampled as lights (wrt.glowing_spheres, wrt.glowing_tubes): a ``wrt.Shape`` cylinder
(capped or open), cone (a capped frustum, an open cone to its apex), capsule or tapered capsule bound to an emissive
material lights a white floor as a float64 quadrature of its radiance over the floor's hemisphere says, under
whitted (it lit nothing before, with a warning) and path (MIS against BSDF-sampled hits: the same floor as path
finding the tube only by the rays that hit it); the straight segments of a glowing curve are sampled too, cones where
its width changes."""

import math

import numpy as np
import pytest
import warp as wp
from test_glowing_spheres import (
    GLOW_AND_FLOOR,
    PATCH,
    RADIANCE,
    RES,
    UNSAMPLED,
    floor_mesh,
    materials,
    no_glowing_spheres,
    render_floor,
    sphere_shape,
)

import wrt
from wrt import light_table
from wrt.glowing_tubes import sample_tube, tube_area

AXIS = np.array([1.0, 0.5, 0.3]) / np.linalg.norm([1.0, 0.5, 0.3])  # world direction of every tube's axis
CENTRE = np.array([0.1, -0.05, 0.8])
RADIUS = 0.15
HALF = 0.4  # a cylinder's half length; a capsule's between its hemispheres' centres


def frame(axis):
    """``(3, 3)`` rotation whose third column is unit ``axis``."""
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    x = np.cross(helper, axis)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(axis, x), axis], axis=1)


# A cone is squat (its half-angle 49 degrees for a cone to its apex), its narrow end tilted down to the floor: the
# floor lies past its apex (its extension's, for a frustum), where more of its side faces a point than the half a
# cylinder shows, all of it under the tip. A tapered capsule (spheres of radius 0.25 and 0.25 taper, 0.4 apart)
# points its small sphere down too.
CONE_AXIS = -np.array([0.3, 0.2, 1.0]) / np.linalg.norm([0.3, 0.2, 1.0])
DIMS = {"cone": (CONE_AXIS, 0.35, 0.15), "tapered": (CONE_AXIS, 0.25, 0.2)}


def dims(kind):
    """``(axis, radius, half)``: the world direction of a tube of ``kind``'s canonical +Z (a cone's narrow end, a
    tapered capsule's small sphere), its radius (at -Z) and half length (to a capsule's spheres' centres)."""
    return DIMS.get(kind, (AXIS, RADIUS, HALF))


def tube_shape(kind, capped=True, taper=1.0):
    """A glowing ``wrt.Shape`` of ``kind`` ``cylinder`` or ``cone`` (``capped`` or open; a cone of its radius
    narrowing to ``taper`` times it), ``capsule`` or ``tapered`` (capsule) at CENTRE (:func:`dims`)."""
    axis, radius, half = dims(kind)
    to_world = np.eye(4)
    rot = frame(axis)
    if kind in ("cylinder", "cone"):
        to_world[:3, :3] = rot @ np.diag([radius, radius, half])
        params = np.array([1.0 if capped else 0.0, taper if kind == "cone" else 0.0, 0.0, 1.0], np.float32)
    else:
        to_world[:3, :3] = rot * radius
        params = np.array([half / radius, taper if kind == "tapered" else 0.0, 0.0, 1.0], np.float32)
    to_world[:3, 3] = CENTRE
    return wrt.Shape("/Tube", kind, to_world, material_id=1, params=params)


def surface_quadrature(kind, capped, taper=1.0, n=64):
    """``(points, normals, areas)``: float64 midpoint quadrature of the tube's surface (unit outward normals)."""
    axis, radius, half = dims(kind)
    rot = frame(axis)
    bx, by, w = rot[:, 0], rot[:, 1], rot[:, 2]
    pts, nrm, area = [], [], []
    # Side: midpoints in (z, phi) from z0 to z1; a cone's radius falls linearly from r0 to r1, its normal leaning up
    # the axis by that slope and its area element longer by the slant. A tapered capsule's touches its spheres (radii
    # radius and taper radius) at latitude lat, where their normals lean up the axis as much.
    lat = math.asin(radius * (1.0 - taper) / (2.0 * half)) if kind == "tapered" else 0.0
    z0, z1 = -half + radius * math.sin(lat), half + taper * radius * math.sin(lat)
    r0 = radius * math.cos(lat)
    slope = r0 * (1.0 - taper) / (z1 - z0)
    z = (np.arange(n) + 0.5) / n * (z1 - z0) + z0
    phi = (np.arange(2 * n) + 0.5) / (2 * n) * 2.0 * math.pi
    zz, pp = np.meshgrid(z, phi, indexing="ij")
    r = r0 - slope * (zz - z0)
    radial = np.cos(pp)[..., None] * bx + np.sin(pp)[..., None] * by
    pts.append((CENTRE + zz[..., None] * w + r[..., None] * radial).reshape(-1, 3))
    nrm.append(((radial + slope * w) / math.hypot(1.0, slope)).reshape(-1, 3))
    area.append((((z1 - z0) / n) * math.hypot(1.0, slope) * r * (2.0 * math.pi / (2 * n))).reshape(-1))
    for s in (1.0, -1.0):
        if kind in ("cylinder", "cone") and capped:  # a disk: midpoints in (rho, phi)
            cap_radius = radius * (taper if s > 0 else 1.0)
            rho = (np.arange(n // 2) + 0.5) / (n // 2) * cap_radius
            rr, pp = np.meshgrid(rho, phi, indexing="ij")
            off = rr[..., None] * (np.cos(pp)[..., None] * bx + np.sin(pp)[..., None] * by)
            pts.append((CENTRE + s * half * w + off).reshape(-1, 3))
            nrm.append(np.broadcast_to(s * w, off.shape).reshape(-1, 3))
            area.append((rr * (cap_radius / (n // 2)) * (2.0 * math.pi / (2 * n))).reshape(-1))
        elif kind in ("capsule", "tapered"):  # a sphere's zone: midpoints in (polar angle from s w, phi)
            top = math.pi / 2 - s * lat  # a hemisphere's quarter turn, past the latitude the side touches it at
            sphere = radius * (taper if s > 0 else 1.0)
            th = (np.arange(n // 2) + 0.5) / (n // 2) * top
            tt, pp = np.meshgrid(th, phi, indexing="ij")
            d = (np.cos(tt)[..., None] * s * w
                 + np.sin(tt)[..., None] * (np.cos(pp)[..., None] * bx + np.sin(pp)[..., None] * by))
            pts.append((CENTRE + s * half * w + sphere * d).reshape(-1, 3))
            nrm.append(d.reshape(-1, 3))
            area.append((sphere**2 * np.sin(tt) * (top / (n // 2)) * (2.0 * math.pi / (2 * n))).reshape(-1))
    return np.concatenate(pts), np.concatenate(nrm), np.concatenate(area)


def oracle(kind, capped=True, taper=1.0, sub=6):
    """``(RES, RES)`` float64 radiance of the white floor (albedo 1: E / pi) under the tube, each pixel averaged over
    ``sub`` x ``sub`` floor points (row 0 at +Y): E = sum of L cos_floor cos_light / d^2 dA over the surface points
    that face the floor point, every one of which it sees (the tube is convex, wholly above the floor)."""
    q, nq, dA = surface_quadrature(kind, capped, taper)
    xs = ((np.arange(RES * sub) + 0.5) / (RES * sub) - 0.5) * PATCH
    gx, gy = np.meshgrid(xs, -xs)
    p = np.stack([gx, gy, np.zeros_like(gx)], axis=-1).reshape(-1, 3)
    out = np.empty(len(p))
    for i in range(0, len(p), 64):
        v = q[None] - p[i : i + 64, None]  # (P, Q, 3) floor point to surface point
        d2 = (v * v).sum(-1)
        cos_l = -(v * nq[None]).sum(-1) / np.sqrt(d2)
        cos_p = v[..., 2] / np.sqrt(d2)
        out[i : i + 64] = (RADIANCE * np.clip(cos_l, 0.0, None) * cos_p / d2 * dA[None]).sum(-1) / math.pi
    return out.reshape(RES, sub, RES, sub).mean(axis=(1, 3))


def seed_images(scene, integrator, spp, seeds=range(3, 11)):
    """``(K, RES, RES)`` float64 floor radiance rendered at each of ``seeds``, and the warnings the renders gave."""
    images, messages = zip(*[render_floor(scene, integrator, spp, seed=s) for s in seeds])
    return np.stack(images), [m for ms in messages for m in ms]


def standard_error(images):
    """The standard error of the mean of ``images`` over their first axis (one independent render each)."""
    return images.std(axis=0, ddof=1) / math.sqrt(len(images))


CASES = [("cylinder", True, 1.0), ("cylinder", False, 1.0), ("capsule", True, 1.0), ("cone", True, 0.4),
         ("cone", False, 0.0), ("tapered", True, 0.4)]
CASE_IDS = ["capped-cylinder", "open-cylinder", "capsule", "capped-frustum", "open-cone", "tapered-capsule"]


@pytest.mark.parametrize("kind,capped,taper", CASES, ids=CASE_IDS)
def test_a_glowing_tube_lights_the_floor_under_whitted_as_the_quadrature(kind, capped, taper):
    """Whitted lights the floor from the sampled tube as the quadrature says, every pixel within five standard errors
    (over eight seeds) plus 0.5% for the quadrature and float32; it drew the floor black before and named the tube
    as unsampled."""
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[tube_shape(kind, capped, taper)], materials=materials())
    images, messages = seed_images(scene, "whitted", spp=128)
    assert not [m for m in messages if UNSAMPLED in m], messages
    expected = oracle(kind, capped, taper)
    error = np.abs(images.mean(axis=0) - expected)
    assert (error < 5 * standard_error(images) + 0.005 * expected).all(), (images.mean(axis=0), expected)
    mean_se = images.mean(axis=(1, 2)).std(ddof=1) / math.sqrt(len(images))
    assert abs(images.mean() - expected.mean()) < 4 * mean_se + 0.005 * expected.mean(), (images.mean(), mean_se)


@pytest.mark.parametrize("kind,capped,taper", CASES, ids=CASE_IDS)
def test_path_with_and_without_sampling_the_tube_agree_with_the_quadrature(kind, capped, taper, monkeypatch):
    """MIS consistency: path with the tube sampled (its BSDF-sampled hits weighted against the same area density) and
    path finding it only by the rays that hit it both give the quadrature's floor mean, each within four standard
    errors (over eight seeds) plus 0.5% for the quadrature and float32."""
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[tube_shape(kind, capped, taper)], materials=materials())
    expected = oracle(kind, capped, taper).mean()
    sampled = seed_images(scene, "path", spp=64)[0].mean(axis=(1, 2))
    monkeypatch.setattr(light_table, "glowing_spheres", no_glowing_spheres)
    hit_only = seed_images(scene, "path", spp=128)[0].mean(axis=(1, 2))
    for means in (sampled, hit_only):
        se = means.std(ddof=1) / math.sqrt(len(means))
        assert abs(means.mean() - expected) < 4 * se + 0.005 * expected, (means, expected)
    assert sampled.std() < hit_only.std(), (sampled, hit_only)  # sampling the tube is what makes it less noisy


CURVE = ('def BasisCurves "Wire" (\n    prepend apiSchemas = ["MaterialBindingAPI"]\n)\n{\n'
         '    uniform token type = "linear"\n    int[] curveVertexCounts = [3]\n'
         "    point3f[] points = [(-0.6, 0, 1), (0, 0.1, 0.9), (0.6, 0, 1.1)]\n{widths}"
         "    rel material:binding = </Glow>\n}\n")


WIDTHS = {"even": '    float[] widths = [0.2] (\n        interpolation = "constant"\n    )\n',
          "tapered": '    float[] widths = [0.2, 0.3, 0.05] (\n        interpolation = "vertex"\n    )\n'}


@pytest.mark.parametrize("widths", WIDTHS.values(), ids=WIDTHS.keys())
def test_a_glowing_curve_samples_its_segments_even_or_tapered(widths, tmp_path, monkeypatch):
    """The straight segments of a glowing curve are sampled with its joints: open cylinders where its width is
    constant, open cones where it changes (they were named as unsampled and lit nothing under whitted). Whitted
    (light sampling alone) lights the floor as path finding the curve only by the rays that hit it does, within four
    standard errors (over eight seeds)."""
    path = tmp_path / "wire.usda"
    path.write_text(GLOW_AND_FLOOR + CURVE.replace("{widths}", widths))
    scene = wrt.load_usd(str(path))
    images, messages = seed_images(scene, "whitted", spp=32)
    assert not [m for m in messages if UNSAMPLED in m], messages
    monkeypatch.setattr(light_table, "glowing_spheres", no_glowing_spheres)
    hit_only = seed_images(scene, "path", spp=64)[0].mean(axis=(1, 2))
    sampled = images.mean(axis=(1, 2))
    se = math.hypot(sampled.std(ddof=1), hit_only.std(ddof=1)) / math.sqrt(len(sampled))
    assert sampled.mean() > 0.0 and abs(sampled.mean() - hit_only.mean()) < 4 * se, (sampled, hit_only)


@pytest.mark.parametrize("squeeze", ["across", "inwards"])
def test_a_squeezed_or_inward_glowing_cylinder_is_sampled_as_a_hull(squeeze):
    """A cylinder squeezed across its axis (an elliptic tube) or emitting inwards (``leftHanded``) is sampled as a
    glowing hull (wrt.glowing_hulls; it was left unsampled, named, lighting nothing under whitted): whitted names
    neither; the elliptic tube lights the floor, the inward one, closed, sends it nothing (its inside glows)."""
    shape = tube_shape("cylinder")
    if squeeze == "across":
        shape.to_world[:3, :3] = frame(AXIS) @ np.diag([RADIUS, 0.7 * RADIUS, HALF])
    else:
        shape.params = np.array([1.0, 0.0, 0.0, -1.0], np.float32)
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[shape], materials=materials())
    rendered, messages = render_floor(scene, "whitted", spp=4)
    assert not [m for m in messages if "emissive analytic primitive" in m], messages
    assert rendered.min() > 0.0 if squeeze == "across" else rendered.max() == 0.0


@pytest.mark.parametrize("kind,capped", [("cylinder", 0.0), ("cone", 0.0), ("cone", 1.0)],
                         ids=["open-cylinder", "open-frustum", "capped-frustum"])
def test_a_double_sided_tube_lights_alike_under_every_estimate(kind, capped, monkeypatch):
    """A double-sided open cylinder or frustum (narrowing to half its radius) standing over the floor glows inside
    too, seen through its bottom end: drawn over its whole surface (both sides; a capped frustum's caps in proportion
    to their areas), its shadow rays stopped by its own near wall, its BSDF hits weighed by the same density. Whitted
    (light sampling alone: the floor's light is all direct, the tube reflecting nothing), path and path finding it
    only by the rays that hit it agree within four standard errors (over eight seeds)."""
    tilted = np.array([0.3, 0.1, 1.0]) / np.linalg.norm([0.3, 0.1, 1.0])
    to_world = np.eye(4)
    to_world[:3, :3] = frame(tilted) @ np.diag([0.2, 0.2, 0.3])
    to_world[:3, 3] = (0.0, 0.0, 0.8)
    shape = wrt.Shape("/Tube", kind, to_world, material_id=1, double_sided=True,
                      params=np.array([capped, 0.5 if kind == "cone" else 0.0, 0.0, 1.0], np.float32))
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[shape], materials=materials())
    results = [seed_images(scene, "whitted", spp=128)[0].mean(axis=(1, 2)),
               seed_images(scene, "path", spp=64)[0].mean(axis=(1, 2))]
    monkeypatch.setattr(light_table, "glowing_spheres", no_glowing_spheres)
    results.append(seed_images(scene, "path", spp=128)[0].mean(axis=(1, 2)))
    means = np.array([r.mean() for r in results])
    ses = np.array([r.std(ddof=1) / math.sqrt(len(r)) for r in results])
    for a in range(3):
        for b in range(a + 1, 3):
            assert abs(means[a] - means[b]) < 4 * math.hypot(ses[a], ses[b]), (means, ses)


@pytest.mark.parametrize("kind", ["capsule", "sphere"])
def test_a_cut_out_glowing_shape_lights_nothing(kind):
    """A glowing tube or sphere whose material is cut out (opacity 0 under an opacityThreshold) is a hole: rays pass
    it and see no emission, so the floor gets no light from it, as an emissive triangle's hole sends none. Light
    sampling drew its glow all the same (a floor 0.22-0.25 bright under whitted and path, 0 by the hits alone)."""
    mats = materials()
    mats[1] = wrt.Material("/Glow", diffuse_color=(0.0, 0.0, 0.0), emissive_color=(RADIANCE,) * 3, ior=1.0,
                           specular_edge=0.0, opacity=0.0, opacity_threshold=0.5)
    shape = tube_shape("capsule") if kind == "capsule" else sphere_shape((0.0, 0.0, 1.0), 0.3)
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[shape], materials=mats)
    for integrator in ("whitted", "path"):
        rendered, _ = render_floor(scene, integrator, spp=4)
        assert rendered.max() == 0.0, (integrator, rendered)


@pytest.mark.parametrize("integrator", ["whitted", "path"])
def test_a_cut_out_glowing_shape_takes_no_light_picks(integrator):
    """A wholly cut-out glowing capsule (opacity 0 under an opacityThreshold) beside a glowing sphere lights nothing,
    and the light picks it took were all wasted (their samples zero): the floor renders as with the sphere alone,
    sample for sample (same seed). It took picks before, so the two differed by their noise."""
    mats = materials()
    mats.append(wrt.Material("/CutGlow", diffuse_color=(0.0, 0.0, 0.0), emissive_color=(RADIANCE,) * 3, ior=1.0,
                             specular_edge=0.0, opacity=0.0, opacity_threshold=0.5))
    capsule = tube_shape("capsule")
    capsule.material_id = 2
    capsule.to_world[:3, 3] = (2.0, 1.5, 0.6)  # off the patch, away from its shadow rays to the sphere
    sphere = sphere_shape((0.0, 0.0, 1.0), 0.3)
    alone = wrt.Scene(meshes=[floor_mesh()], shapes=[sphere], materials=mats)
    beside = wrt.Scene(meshes=[floor_mesh()], shapes=[sphere, capsule], materials=mats)
    expected, _ = render_floor(alone, integrator, spp=16)
    rendered, _ = render_floor(beside, integrator, spp=16)
    assert expected.min() > 0.0
    np.testing.assert_allclose(rendered, expected, rtol=1e-6)


@wp.kernel
def draw_tube_kernel(row: wp.vec4, axis: wp.vec4, taper: float, ps: wp.array[wp.vec3], us: wp.array[wp.vec2],
                     qs: wp.array[wp.vec3], ns: wp.array[wp.vec3], drawn: wp.array[wp.vec3]):
    """A single-sided tube's draw from each ``ps[i]``: the point, its normal and ``(area, down, arc)``."""
    i = wp.tid()
    q, n, area, down = sample_tube(row, axis, taper, ps[i], 1, us[i][0], us[i][1])
    c = wp.vec3(row[0], row[1], row[2])
    area2, side, arc = tube_area(row, axis, taper, down, 1, (ps[i] - c) * down)
    qs[i] = q
    ns[i] = n
    drawn[i] = wp.vec3(area, down, arc)


def draw_tube(kind, code, taper, ps, us):
    """``(q, n, area, arc)`` float64 of :func:`draw_tube_kernel` for the tube of :func:`dims` (world area)."""
    axis, radius, half = dims(kind)
    out = [wp.zeros(len(ps), dtype=wp.vec3, device="cpu") for _ in range(3)]
    wp.launch(draw_tube_kernel, len(ps), inputs=[wp.vec4(*CENTRE, radius), wp.vec4(*(axis * half), code), taper,
                                                 wp.array(ps, dtype=wp.vec3, device="cpu"),
                                                 wp.array(us, dtype=wp.vec2, device="cpu")],
              outputs=out, device="cpu")
    q, n, drawn = (a.numpy().astype(np.float64) for a in out)
    return q, n, drawn[:, 0] / drawn[:, 1] ** 2, drawn[:, 2]


TUBES = [("cone", 1, 0.0), ("cone", 2, 0.4), ("tapered", 4, 0.4)]  # (kind, GLOW_* code, taper)


@pytest.mark.parametrize("kind,code,taper", TUBES, ids=["open-cone", "capped-frustum", "tapered-capsule"])
def test_a_single_sided_cone_draws_from_an_arc_holding_all_the_side_facing_the_point(kind, code, taper):
    """From points above, below and beside a single-sided cone, on its axis, inside it and past its apex, every
    point of its side whose front faces the point (float64, brute force over the side) lies in the arc drawn from;
    and the draw integrates a smooth weight over the surface the point sees as a float64 quadrature does (uniform by
    area over a region holding it, the area right)."""
    axis, radius, half = dims(kind)
    w = axis
    bx = np.cross(w, (0.0, 0.0, 1.0))
    bx /= np.linalg.norm(bx)
    by = np.cross(w, bx)
    zs, rhos = np.meshgrid(np.linspace(-4.0, 4.0, 17) * half, np.linspace(0.0, 3.0, 13) * radius, indexing="ij")
    ps = CENTRE + zs.reshape(-1, 1) * w + rhos.reshape(-1, 1) * (0.6 * bx + 0.8 * by)
    _, _, _, arcs = draw_tube(kind, code, taper, ps, np.full((len(ps), 2), 0.5))
    q, nq, _ = surface_quadrature(kind, False, taper, n=96)
    side = np.abs(nq @ w) < 0.999  # the side (and, for a tapered capsule, its spheres' zones: filtered below)
    if kind == "tapered":
        lat = math.asin(radius * (1.0 - taper) / (2.0 * half))
        along = (q - CENTRE) @ w
        side &= (along > -half + radius * math.sin(lat)) & (along < half + taper * radius * math.sin(lat))
    q, nq = q[side], nq[side]
    for p, arc in zip(ps, arcs):
        to_p = p - CENTRE
        facing = ((p - q) * nq).sum(-1) > 1e-9
        off = np.angle(np.exp(1j * (np.arctan2((q - CENTRE) @ by, (q - CENTRE) @ bx)
                                    - np.arctan2(to_p @ by, to_p @ bx))))
        assert (np.abs(off[facing]) <= arc + 1e-4).all(), (p, arc, np.abs(off[facing]).max())

    rng = np.random.default_rng(7)
    q_all, n_all, dA = surface_quadrature(kind, code == 2, taper, n=256)
    count = 200_000
    for z, rho in [(3.0, 0.0), (-3.0, 0.5), (0.5, 3.0), (5.0, 0.2)]:
        p = CENTRE + z * half * w + rho * radius * bx
        weight = lambda x: 1.0 / (1.0 + ((x - p) ** 2).sum(-1))  # noqa: E731 (smooth, to integrate)
        seen = ((p - q_all) * n_all).sum(-1) > 0.0
        expected = (weight(q_all) * dA * seen).sum()
        qs, ns, area, _ = draw_tube(kind, code, taper, np.tile(p, (count, 1)), rng.uniform(size=(count, 2)))
        est = area * weight(qs) * (((p - qs) * ns).sum(-1) > 0.0)
        se = est.std() / math.sqrt(count)
        assert abs(est.mean() - expected) <= 4.0 * se + 0.005 * expected, (z, rho, est.mean(), expected, se)


def test_a_capped_cone_sunk_to_its_centre_in_the_floor_lights_it_as_the_quadrature_under_path():
    """A single-sided capped frustum standing with its centre's plane 1e-8 above the floor (sunk half into it): path
    weighs a BSDF hit on its side by the density drawn from the ray's origin, the floor point moved up off the floor,
    above that plane, while light sampling drew from the floor point itself, below it. The draw took the cap on the
    point's side of the centre, a cone's two caps of different areas, so the two densities differed by the caps'
    difference and the floor came out 7% dark; drawn from both caps, the area is the same on either side. Path's
    floor mean matches a float64 quadrature of the side above the floor within four standard errors (over eight
    seeds) plus 0.5%."""
    radius, half, taper, centre = 0.3, 0.2, 0.4, np.array([0.8, 0.0, 1e-8])  # beside the patch seen
    to_world = np.diag([radius, radius, half, 1.0])
    to_world[:3, 3] = centre
    shape = wrt.Shape("/Cone", "cone", to_world, material_id=1, params=np.array([1.0, taper, 0.0, 1.0], np.float32))
    scene = wrt.Scene(meshes=[floor_mesh()], shapes=[shape], materials=materials())
    means = seed_images(scene, "path", spp=256)[0].mean(axis=(1, 2))
    # The side above the floor (z in [0, half]), midpoints in (z, phi); nothing else of it faces the floor. The rule
    # converges as 1/n^2 (relative steps 2.4e-4, 6.1e-5, 1.4e-5 from n = 32 to 64, 128, 256): n = 128 is within 2e-5
    # of the integral, far inside the 0.5% margin (n = 256 took 48 s of this test's 69 s).
    n = 128
    slope = radius * (1.0 - taper) / (2.0 * half)
    zz, pp = np.meshgrid((np.arange(n) + 0.5) / n * half, (np.arange(2 * n) + 0.5) / (2 * n) * 2.0 * math.pi,
                         indexing="ij")
    r = 0.5 * radius * (1.0 + taper) - slope * zz
    radial = np.stack([np.cos(pp), np.sin(pp), np.zeros_like(pp)], axis=-1)
    q = (centre + zz[..., None] * np.array([0.0, 0.0, 1.0]) + r[..., None] * radial).reshape(-1, 3)
    nq = ((radial + slope * np.array([0.0, 0.0, 1.0])) / math.hypot(1.0, slope)).reshape(-1, 3)
    dA = ((half / n) * math.hypot(1.0, slope) * r * (2.0 * math.pi / (2 * n))).reshape(-1)
    xs = ((np.arange(48) + 0.5) / 48 - 0.5) * PATCH
    gx, gy = np.meshgrid(xs, xs)
    p = np.stack([gx, gy, np.zeros_like(gx)], axis=-1).reshape(-1, 3)
    total = 0.0
    for i in range(0, len(p), 32):
        v = q[None] - p[i : i + 32, None]
        d2 = (v * v).sum(-1)
        cos_l = np.clip(-(v * nq[None]).sum(-1) / np.sqrt(d2), 0.0, None)
        total += (RADIANCE * cos_l * v[..., 2] / np.sqrt(d2) / d2 * dA[None]).sum()
    expected = total / len(p) / math.pi
    se = means.std(ddof=1) / math.sqrt(len(means))
    assert abs(means.mean() - expected) < 4.0 * se + 0.005 * expected, (means, expected, se)
