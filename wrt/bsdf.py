"""The UsdPreviewSurface BSDF: Lambert diffuse under a GGX microfacet specular lobe, a clearcoat and a smooth
dielectric for ``opacity < 1``; evaluation, importance sampling and pdfs for the integrators.

Model (an approximation of the UsdPreviewSurface specification, stated once):

- Metallic workflow: ``F0 = mix(((1 - ior) / (1 + ior))^2, diffuseColor, metallic)``, diffuse albedo
  ``diffuseColor * (1 - metallic)``. Specular workflow (``useSpecularWorkflow = 1``): ``F0 = specularColor``,
  diffuse albedo ``diffuseColor``.
- ``f = (1 - C(cos_o)) * [(1 - S(cos_o)) * albedo / pi + D G F(cos_vh) / (4 cos_o cos_i) + f_ms]
  + clearcoat * Dc Gc Fc(cos_vh) / (4 cos_o cos_i)`` with Schlick's Fresnel ``F`` at the half vector, the GGX
  (Trowbridge-Reitz) distribution ``D`` with ``alpha = roughness^2`` and the height-correlated Smith term ``G``
  (Heitz 2014). The grazing reflectance ``F90`` of Schlick's ``F`` follows the UsdPreviewSurface specification
  and Storm's ``previewSurface.glslfx``: white in the specular workflow ("specularColor ... is the color at 0
  incidence. Edge color is assumed to be (1.0, 1.0, 1.0)"), ``mix(1, diffuseColor, metallic)`` in the metallic
  workflow (white for a dielectric, the albedo for a metal). The clearcoat lobe has
  ``F0 = ((1 - ior) / (1 + ior))^2`` (the specification's ``ior`` is the clearcoat's index too, as in Storm and
  MaterialX's UsdPreviewSurface graph; 0.04 at the fallback 1.5), ``F90`` white (the specification's clearcoat
  colour; Storm's and MaterialX's) and ``alpha = clearcoatRoughness^2``. ``Surface.specular_edge`` (white for
  UsdPreviewSurface) stands for that white edge: 0 for the fallback surface (no material bound, or no material
  response), which is Lambertian, and a MaterialX specular weight scales it.
- Energy compensation (Kulla and Conty, "Revisiting Physically Based Shading at Imageworks", 2017): ``f_ms =
  F_ms (1 - E(cos_o)) (1 - E(cos_i)) / (pi (1 - E_avg))`` returns the light the single-scattering GGX lobe loses
  between microfacets, ``E`` being a white lobe's directional albedo and ``F_ms = F_avg^2 E_avg / (1 - F_avg (1 -
  E_avg))`` its colour (tables in :mod:`wrt.microfacet_albedo`). Each layer keeps what the lobes above it do not
  reflect towards the viewer (albedo scaling): ``S`` is the specular lobe's directional albedo with ``f_ms``,
  ``C`` the clearcoat's times ``clearcoat`` (single scattering: what it loses between microfacets is left to the
  layers below, so a white surface under a coat of any index still reflects all the light).
  A white metal, dielectric or clearcoated surface therefore reflects all the light at every roughness and angle
  (within 1%), and no surface of colours in ``[0, 1]`` reflects more; the layering is not reciprocal (it looks at
  ``cos_o`` only). With ``F0 = 0`` and ``specular_edge = 0`` (the fallback surface) the BSDF is exactly Lambertian:
  albedo ``rho`` under illuminance ``E`` shows ``rho * E / pi``.
- Lobes with ``roughness < DELTA_ROUGHNESS`` are perfect mirrors (delta distributions): they are sampled, never
  evaluated, and carry no MIS weight.
- ``opacity < 1`` (with ``opacityThreshold = 0``): a fraction ``1 - opacity`` of the light meets a smooth
  dielectric interface of index ``ior`` (Snell refraction, exact Fresnel reflectance), the rest meets the opaque
  BSDF above. ``opacityThreshold > 0`` is a cut-out instead, handled by the integrators.
- A thin-walled dielectric (``Surface.thin_walled``: a window pane, a soap bubble, a leaf modelled as one sheet) is
  a slab of two parallel smooth interfaces of index ``ior`` and no thickness, as pbrt-v4's ``ThinDielectricBxDF``:
  the light bouncing between its faces sums to a reflectance ``R' = R + T^2 R / (1 - R^2)`` (``R`` the Fresnel
  reflectance at the incident angle, the same at both faces, ``T = 1 - R``), reflected about the normal, and the
  rest, ``1 - R'``, passes straight through (the two refractions cancel: no bend, no inside). It replaces the
  refracting interface in the ``1 - opacity`` share; the opaque BSDF above is unchanged.

Sampling draws one lobe with probability proportional to its albedo and samples GGX through its distribution of
visible normals (Heitz, "Sampling the GGX Distribution of Visible Normals", JCGT 2018), the diffuse lobe by the
cosine and ``f_ms`` from a per-roughness table that follows ``(1 - E(cos_i)) cos_i``
(:func:`wrt.microfacet_albedo.sample_multiple_scattering_cos`): below roughness 0.25 that lobe lives in a narrow band
of grazing directions, where cosine-weighted directions gave single samples 800 times the average (white metal at
roughness 0.05 seen at cos_o 0.01). The pdf of a direction is the mixture over all non-delta lobes, so one-sample MIS
between lobes is implicit.
Directions ``wo`` (towards the viewer) and ``wi`` (towards the light) point away from the surface.
"""

import warp as wp

from .microfacet_albedo import (
    GgxAlbedo,
    lookup_ggx_albedo,
    lookup_ggx_average_loss,
    lookup_multiple_scattering_total,
    multiple_scattering_pdf,
    sample_multiple_scattering_cos,
)
from .sampling import (
    INV_PI,
    PI,
    direction_at_cos,
    luminance,
    sample_cosine_hemisphere,
    sin_cos,
    to_local,
    to_world,
)

DELTA_ROUGHNESS = wp.constant(0.02)  # below this roughness a lobe is a perfect mirror
MIN_ALPHA = wp.constant(4.0e-4)  # smallest GGX alpha evaluated (= DELTA_ROUGHNESS^2)


@wp.struct
class Surface:
    """The UsdPreviewSurface inputs evaluated at one hit (textures already looked up)."""

    base_color: wp.vec3  # diffuseColor, linear RGB
    emission: wp.vec3  # emissiveColor: emitted radiance, linear RGB
    specular_color: wp.vec3  # specularColor: F0 of the specular workflow
    metallic: float  # 0 dielectric .. 1 metal (metallic workflow)
    roughness: float  # perceptual roughness in [0, 1]; GGX alpha = roughness^2
    opacity: float  # 1 opaque; below 1 a smooth dielectric lets 1 - opacity through
    ior: float  # index of refraction of the dielectric interface
    clearcoat: float  # clearcoat weight in [0, 1]
    clearcoat_roughness: float  # roughness of the clearcoat lobe
    clearcoat_ior: float  # index of refraction of the clearcoat layer (UsdPreviewSurface: ior); its F0 follows
    opacity_threshold: float  # > 0: cut-out mode (opacity < threshold is a hole)
    specular_workflow: int  # 1: F0 = specularColor; 0: metallic workflow
    thin_walled: int  # 1: the dielectric is a sheet without thickness (thin_dielectric_reflectance); 0: solid
    specular_edge: float  # F90 of the dielectric (specular workflow) lobe: 1 (UsdPreviewSurface); 0: no lobe


@wp.func
def fresnel_schlick(f0: wp.vec3, f90: wp.vec3, cos_theta: float):
    """Schlick's approximation of the Fresnel reflectance, ``f0`` at normal incidence and ``f90`` at grazing."""
    m = wp.clamp(1.0 - cos_theta, 0.0, 1.0)
    m5 = m * m * m * m * m
    return f0 + (f90 - f0) * m5


@wp.func
def fresnel_schlick_scalar(f0: float, cos_theta: float):
    """Scalar :func:`fresnel_schlick` with a white ``f90`` (the clearcoat's)."""
    m = wp.clamp(1.0 - cos_theta, 0.0, 1.0)
    return f0 + (1.0 - f0) * m * m * m * m * m


@wp.func
def refracted_cos2(cos_i: float, eta: float):
    """``cos^2`` of the refracted direction for incidence ``cos_i`` and ``eta = n_t / n_i`` (Snell): ``1 - sin_i^2 /
    eta^2``, written ``cos_i^2 + sin_i^2 (1 - 1 / eta^2)`` so that it is ``cos_i^2`` exactly at ``eta = 1``, and 1 at
    normal incidence for any ``eta`` (``1 / eta^2`` may overflow). At most 0: total internal reflection. As ``1 -
    sin_i^2 / eta^2``, ``sin_i^2`` rounded to 1 below a cosine of 2.4e-4, where an index-matched interface (ior 1,
    as a MaterialX specular of 0 gives) reflected all the light instead of none."""
    c2 = cos_i * cos_i
    s2 = wp.max(1.0 - c2, 0.0)
    if s2 <= 0.0:
        return 1.0
    return c2 + s2 * (1.0 - 1.0 / (eta * eta))


@wp.func
def fresnel_dielectric(cos_i: float, eta: float):
    """Exact unpolarised Fresnel reflectance of a smooth dielectric interface; ``eta = n_t / n_i``, ``cos_i > 0``
    on the incident side. Returns 1 for total internal reflection."""
    cos2_t = refracted_cos2(cos_i, eta)
    if cos2_t <= 0.0:
        return 1.0
    cos_t = wp.sqrt(cos2_t)
    r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    return 0.5 * (r_parl * r_parl + r_perp * r_perp)


@wp.func
def reflect(wo: wp.vec3, n: wp.vec3):
    """Mirror direction of ``wo`` about ``n`` (both pointing away from the surface)."""
    return 2.0 * wp.dot(wo, n) * n - wo


@wp.func
def mirror_reflection(wo: wp.vec3, n: wp.vec3, ng: wp.vec3):
    """``(wi, lit)``: the mirror direction of ``wo`` about shading normal ``n``, and 1 where it leaves above the
    geometric surface (``dot(ng, wi) > 0``, ``ng`` on the side of ``wo``), else 0: a mirror ray into the surface
    carries no light. (:func:`wrt.shade.keep_reflection_above` bends ``n`` so that it leaves above; this catches
    what rounding at grazing views lets through.) Every mirror ray of ``path`` and ``whitted`` is taken here."""
    wi = reflect(wo, n)
    return wi, wp.where(wp.dot(ng, wi) > 0.0, 1.0, 0.0)


@wp.func
def refract(wo: wp.vec3, n: wp.vec3, eta: float):
    """Snell refraction of ``wo`` (on the side of ``n``) through the interface, ``eta = n_t / n_i``; the result
    points away from the surface on the other side. Zero for total internal reflection."""
    cos_i = wp.dot(n, wo)
    cos2_t = refracted_cos2(cos_i, eta)
    if cos2_t <= 0.0:
        return wp.vec3(0.0)
    cos_t = wp.sqrt(cos2_t)
    return -wo / eta + (cos_i / eta - cos_t) * n


@wp.func
def glass_refraction(n: wp.vec3, ng: wp.vec3, wo: wp.vec3, eta: float):
    """``(fr, wt)``: the Fresnel reflectance of the smooth dielectric seen from ``wo`` about shading normal ``n`` and
    the unit refracted direction (``eta = n_t / n_i``; ``n``, ``ng`` and ``wo`` on one side, ``dot(n, wo) > 0``).

    A refraction that does not cross the geometric surface (``dot(wt, ng) >= 0``) is total internal reflection:
    ``(1, 0)``. Leaving a denser medium about a normal bent far from ``ng`` (an interpolated normal near a glass
    sphere's rim, a normal map), Snell's law sent ``wt`` back to the viewer's side: its ray started behind the
    surface, re-crossed it at once and took up to a third of the light through a window pane to its far side. As
    pbrt-v4 and Mitsuba (a ray continues on the side its direction points to) and Cycles (a transmission must point
    below ``Ng``), the direction is tested against the geometric normal; it is taken as reflected rather than dropped,
    so that the lossless interface still returns all the light it does not transmit."""
    fr = fresnel_dielectric(wp.dot(n, wo), eta)
    wt = wp.vec3(0.0)
    if fr < 1.0:
        wt = wp.normalize(refract(wo, n, eta))
        if wp.dot(wt, ng) >= 0.0:
            fr = 1.0
            wt = wp.vec3(0.0)
    return fr, wt


@wp.func
def thin_dielectric_reflectance(cos_i: float, eta: float):
    """Reflectance ``R' = R + T^2 R / (1 - R^2)`` of a thin-walled smooth dielectric sheet of relative index ``eta``
    seen at ``cos_i > 0``: :func:`fresnel_dielectric` ``R`` at its first face, then the light transmitted into the
    sheet (``T = 1 - R``) bouncing between two faces that each reflect ``R`` (the inner angle is the refracted one,
    where Fresnel's reflectance is the same), a geometric series. 1 where the first face reflects everything (total
    internal reflection of an ``eta`` below 1). The sheet transmits the rest, ``1 - R'``, undeflected."""
    r = fresnel_dielectric(cos_i, eta)
    if r >= 1.0:
        return 1.0
    t = 1.0 - r
    return r + t * t * r / (1.0 - r * r)


@wp.func
def dielectric_interface(s: Surface, n: wp.vec3, ng: wp.vec3, wo: wp.vec3, front: int):
    """``(fr, wt)``: the reflectance of the glass of ``s`` seen from ``wo`` about shading normal ``n`` and the unit
    direction of its transmitted light (``n``, ``ng`` and ``wo`` on one side, ``dot(n, wo) > 0``; ``front``: ``wo``
    on the winding's front side). A solid's boundary refracts (:func:`glass_refraction`, ``eta = ior`` entering from
    the front, ``1 / ior`` leaving through the back); a thin-walled sheet has no inside, so ``eta`` is ``ior`` from
    either side, and it reflects :func:`thin_dielectric_reflectance` and lets the rest through along ``-wo``."""
    if s.thin_walled == 1:
        return thin_dielectric_reflectance(wp.dot(n, wo), s.ior), -wo
    eta = s.ior
    if front == 0:
        eta = 1.0 / s.ior
    return glass_refraction(n, ng, wo, eta)


@wp.func
def ggx_d(cos_h: float, sin2_h: float, alpha: float):
    """GGX normal distribution ``D(h)`` for ``cos_h = n . h`` and ``sin2_h = |n x h|^2``.

    The denominator ``cos_h^2 (a^2 - 1) + 1`` is written ``a^2 cos_h^2 + sin_h^2`` with the sine from the cross
    product: the usual form cancels to rounding noise near the peak of a sharp lobe (it is ``a^2`` = 1.6e-7 at
    roughness 0.02, below float32's resolution of 1 - cos_h^2), and reached zero, an infinite ``D``, where a unit
    ``h`` had ``cos_h`` one ulp above 1."""
    if cos_h <= 0.0:
        return 0.0
    a2 = alpha * alpha
    t = a2 * cos_h * cos_h + sin2_h
    return a2 / (PI * t * t)


@wp.func
def ggx_masking_length(cos_t: float, alpha: float):
    """``sqrt(cos_t^2 + alpha^2 (1 - cos_t^2)) = cos_t (1 + 2 Lambda)`` for a direction at ``cos_t = n . w``, Smith's
    ``Lambda`` for GGX being ``(sqrt(1 + alpha^2 tan^2) - 1) / 2``. The masking terms below are written with it, not
    with ``Lambda``, whose ``tan^2`` divides by ``cos^2``: that was clamped at 1e-12, so below a cosine of 1e-6 the
    masking stopped growing and ``f`` grew as ``1 / (cos_o cos_i)`` (100 times too large at ``cos_o`` 1e-8), and it
    was infinite where ``4 cos_o cos_i`` underflowed (both cosines near 1e-23)."""
    c2 = cos_t * cos_t
    return wp.sqrt(c2 + alpha * alpha * wp.max(1.0 - c2, 0.0))


@wp.func
def ggx_visibility(cos_o: float, cos_i: float, alpha: float):
    """Height-correlated Smith masking-shadowing (Heitz 2014) over the microfacet denominator, ``G2 / (4 cos_o
    cos_i) = 1 / (2 (cos_i m_o + cos_o m_i))`` with ``m`` the :func:`ggx_masking_length` of each direction (as
    Filament's ``V_SmithGGXCorrelated``); finite for any cosines not both 0."""
    return 0.5 / (cos_i * ggx_masking_length(cos_o, alpha) + cos_o * ggx_masking_length(cos_i, alpha))


@wp.func
def ggx_alpha(roughness: float):
    """GGX alpha of a perceptual roughness."""
    return wp.max(roughness * roughness, MIN_ALPHA)


@wp.func
def sample_ggx_vndf(wo: wp.vec3, alpha: float, u1: float, u2: float):
    """A microfacet normal (local frame, +Z up) drawn from GGX's distribution of visible normals (Heitz 2018)."""
    vh = wp.normalize(wp.vec3(alpha * wo[0], alpha * wo[1], wo[2]))
    lensq = vh[0] * vh[0] + vh[1] * vh[1]
    t1 = wp.vec3(1.0, 0.0, 0.0)
    if lensq > 1.0e-12:
        t1 = wp.vec3(-vh[1], vh[0], 0.0) / wp.sqrt(lensq)
    t2 = wp.cross(vh, t1)
    r = wp.sqrt(u1)
    sin_phi, cos_phi = sin_cos(2.0 * PI * u2)
    p1 = r * cos_phi
    p2 = r * sin_phi
    s = 0.5 * (1.0 + vh[2])
    p2 = (1.0 - s) * wp.sqrt(wp.max(0.0, 1.0 - p1 * p1)) + s * p2
    nh = p1 * t1 + p2 * t2 + wp.sqrt(wp.max(0.0, 1.0 - p1 * p1 - p2 * p2)) * vh
    return wp.normalize(wp.vec3(alpha * nh[0], alpha * nh[1], wp.max(1.0e-6, nh[2])))


@wp.func
def ggx_reflection_pdf(cos_o: float, cos_h: float, sin2_h: float, alpha: float):
    """Solid-angle pdf of a reflected direction sampled through :func:`sample_ggx_vndf`: ``G1(wo) D(h) / (4 cos_o)
    = D(h) / (2 (cos_o + m_o))`` (``m_o``: :func:`ggx_masking_length`)."""
    return ggx_d(cos_h, sin2_h, alpha) / (2.0 * (cos_o + ggx_masking_length(cos_o, alpha)))


@wp.func
def surface_f0(s: Surface):
    """Specular reflectance at normal incidence (see the module docstring). The specification fixes metallic 0 and 1
    and says "In between, we interpolate": linearly here. Storm's ``previewSurface.glslfx`` (and MaterialX's
    UsdPreviewSurface graph) interpolates ``R^2 s`` and ``s``, ``s = mix(1, diffuseColor, metallic)``, which for a
    dark half metal leaves the interval between the ends (black, metallic 0.5: 0.26 for ends 0.04 and 0)."""
    if s.specular_workflow == 1:
        return s.specular_color
    r = (1.0 - s.ior) / (1.0 + s.ior)
    return wp.lerp(wp.vec3(r * r), s.base_color, s.metallic)


@wp.func
def surface_f90(s: Surface):
    """Specular reflectance at grazing incidence: white in the specular workflow, ``mix(1, diffuseColor, metallic)``
    in the metallic workflow, as the UsdPreviewSurface specification says and Storm's ``previewSurface.glslfx``
    computes (MaterialX's graph also has a white edge for specularColor). It was ``min(1, 50 max(F0))`` (Filament's
    guess for an unknown edge): a specular-workflow material of the default specularColor 0 had no grazing
    reflection at all, where Storm shows a white rim. The white is ``s.specular_edge`` (see the module docstring)."""
    edge = wp.vec3(s.specular_edge)
    if s.specular_workflow == 1:
        return edge
    return wp.lerp(edge, s.base_color, s.metallic)


@wp.func
def clearcoat_f0(s: Surface):
    """Reflectance of the clearcoat layer at normal incidence: ``((1 - ior) / (1 + ior))^2`` of its index (Storm
    and MaterialX's UsdPreviewSurface graph take the coat's F0 from ``ior``; a fixed 0.04 drew a coat of index 3 at
    0.36 of its reflectance and a coat on an index-matched ``ior = 1``, which reflects nothing)."""
    r = (1.0 - s.clearcoat_ior) / (1.0 + s.clearcoat_ior)
    return r * r


@wp.func
def surface_albedo(s: Surface):
    """Albedo of the diffuse lobe."""
    if s.specular_workflow == 1:
        return s.base_color
    return s.base_color * (1.0 - s.metallic)


@wp.func
def is_glass(s: Surface):
    """True where part of the light is refracted (``opacity < 1`` and no cut-out threshold)."""
    return s.opacity < 1.0 and s.opacity_threshold <= 0.0


@wp.func
def opaque_fraction(s: Surface):
    """Weight of the opaque BSDF (``opacity`` for glass, else 1)."""
    if is_glass(s):
        return wp.clamp(s.opacity, 0.0, 1.0)
    return 1.0


@wp.func
def multiple_scattering_color(f0: wp.vec3, f90: wp.vec3, loss: float):
    """Fresnel colour of the multiple-scattering lobe for an average loss ``1 - E_avg`` (Kulla and Conty 2017):
    ``F_avg^2 E_avg / (1 - F_avg (1 - E_avg))``, ``F_avg = f0 + (f90 - f0) / 21`` the cosine-weighted average of
    Schlick's ``F``. 1 for a white lobe, below ``F_avg`` otherwise: every further bounce keeps ``F_avg`` of the
    light. ``F_avg`` is kept at most 1: a colour above 1 (diffuseColor 2 on a metal) made the denominator 0 or
    negative at roughness 1."""
    f_avg = wp.min(f0 + (f90 - f0) * (1.0 / 21.0), wp.vec3(1.0))
    return wp.cw_div(wp.cw_mul(f_avg, f_avg) * (1.0 - loss), wp.vec3(1.0) - f_avg * loss)


@wp.func
def unreflected(albedo: wp.vec3):
    """What a lobe of directional ``albedo`` leaves to the layer below it, per channel: ``1 - albedo``, at least 0. A
    specularColor above 1, or a metallic-workflow F0 above 1 (diffuseColor 3 at metallic 0.5), made it negative: a
    negative diffuse lobe and sample weights down to -2000 (negative radiance in the image)."""
    return wp.vec3(wp.max(1.0 - albedo[0], 0.0), wp.max(1.0 - albedo[1], 0.0), wp.max(1.0 - albedo[2], 0.0))


@wp.struct
class LobeAlbedos:
    """What the opaque lobes reflect towards one viewer: every value :func:`eval_bsdf` and :func:`sample_bsdf` read
    from the albedo tables for the viewing angle, looked up once per shading point by :func:`lobe_albedos` (a path
    vertex evaluates the BSDF for its light sample and for its BSDF sample; each looked them up again)."""

    spec: wp.vec3  # the specular lobe's single-scattering albedo: F(cos_o) for a mirror, f0 (E - B) + f90 B for GGX
    spec_ms: wp.vec3  # its multiple-scattering lobe's albedo ms_color * loss_o (0 for a mirror)
    ms_color: wp.vec3  # multiple_scattering_color of the specular lobe (0 for a mirror)
    loss_o: float  # 1 - E(cos_o) of the specular lobe (0 for a mirror)
    average_loss: float  # 1 - E_avg of the specular lobe (0 for a mirror)
    ms_total: float  # lookup_multiple_scattering_total of the specular lobe (0 for a mirror; set by lobe_albedos)
    coat: float  # clearcoat_albedo (set by lobe_albedos)
    weights: wp.vec4  # lobe_weights (set by lobe_albedos)


@wp.func
def single_scattering_albedo(tables: GgxAlbedo, f0: wp.vec3, f90: wp.vec3, roughness: float, cos_o: float):
    """``(albedo, E)`` of a specular lobe of reflectance ``f0`` (``f90`` at grazing) for a viewer at ``cos_o``:
    ``F(cos_o)`` and 1 for a mirror; for GGX ``f0 (E - B) + f90 B`` and a white lobe's ``E`` (see
    :mod:`wrt.microfacet_albedo`)."""
    if roughness < DELTA_ROUGHNESS:
        return fresnel_schlick(f0, f90, cos_o), 1.0
    eb = lookup_ggx_albedo(tables, roughness, cos_o)
    return f0 * (eb[0] - eb[1]) + f90 * eb[1], eb[0]


@wp.func
def specular_albedo(tables: GgxAlbedo, f0: wp.vec3, f90: wp.vec3, roughness: float, cos_o: float):
    """Directional albedo of a specular lobe of reflectance ``f0`` (``f90`` at grazing) for a viewer at ``cos_o``:
    the specular fields of :class:`LobeAlbedos` (``spec``: :func:`single_scattering_albedo`; ``spec_ms``: the
    compensation lobe's ``(1 - E) multiple_scattering_color``, 0 for a mirror), the others 0."""
    lobes = LobeAlbedos()
    single, e = single_scattering_albedo(tables, f0, f90, roughness, cos_o)
    lobes.spec = single
    if roughness >= DELTA_ROUGHNESS:
        lobes.loss_o = 1.0 - e
        lobes.average_loss = lookup_ggx_average_loss(tables, roughness)
        lobes.ms_color = multiple_scattering_color(f0, f90, lobes.average_loss)
        lobes.spec_ms = lobes.ms_color * lobes.loss_o
    return lobes


@wp.func
def multiple_scattering(tables: GgxAlbedo, lobes: LobeAlbedos, roughness: float, cos_i: float):
    """The compensation lobe ``f_ms`` (without the cosine) of the GGX lobe of ``lobes``: ``multiple_scattering_color
    (1 - E(cos_o)) (1 - E(cos_i)) / (pi (1 - E_avg))``, which reflects the ``1 - E(cos_o)`` the single-scattering
    lobe loses."""
    e_i = lookup_ggx_albedo(tables, roughness, cos_i)[0]
    k = lobes.loss_o * (1.0 - e_i) / (PI * wp.max(lobes.average_loss, 1.0e-9))
    return lobes.ms_color * k


@wp.func
def clearcoat_albedo(tables: GgxAlbedo, s: Surface, cos_o: float):
    """The share of the light the clearcoat reflects for a viewer at ``cos_o`` (``clearcoat`` times its lobe's
    albedo; single scattering only: at ``F0 = 0.04`` the lost bounces are below 0.5%)."""
    if s.clearcoat <= 0.0:
        return 0.0
    single, e = single_scattering_albedo(tables, wp.vec3(clearcoat_f0(s)), wp.vec3(1.0), s.clearcoat_roughness, cos_o)
    return s.clearcoat * single[0]


@wp.func
def lobe_weights(s: Surface, spec: wp.vec3, spec_ms: wp.vec3, coat: float):
    """Probabilities ``(diffuse, specular, multiple scattering, clearcoat)`` of sampling each opaque lobe, from the
    albedos of :func:`specular_albedo` and :func:`clearcoat_albedo` at the viewing angle: a smooth lobe's
    multiple-scattering lobe, which reflects little, is drawn as rarely."""
    below = 1.0 - coat
    diffuse = wp.cw_mul(unreflected(spec + spec_ms), surface_albedo(s))
    wd = luminance(diffuse) * below
    ws = luminance(spec) * below
    wm = wp.max(luminance(spec_ms), 0.0) * below
    wc = coat
    total = wd + ws + wm + wc
    if total <= 0.0:
        return wp.vec4(1.0, 0.0, 0.0, 0.0)
    return wp.vec4(wd, ws, wm, wc) / total


@wp.func
def lobe_albedos(s: Surface, tables: GgxAlbedo, cos_o: float):
    """The :class:`LobeAlbedos` of ``s`` for a viewer at ``cos_o = dot(n, wo)``, to pass to :func:`eval_bsdf` and
    :func:`sample_bsdf` for that ``n`` and ``wo`` (``tables``: :func:`wrt.microfacet_albedo.ggx_albedo_tables`)."""
    lobes = specular_albedo(tables, surface_f0(s), surface_f90(s), s.roughness, cos_o)
    if s.roughness >= DELTA_ROUGHNESS:
        lobes.ms_total = lookup_multiple_scattering_total(tables, s.roughness)
    lobes.coat = clearcoat_albedo(tables, s, cos_o)
    lobes.weights = lobe_weights(s, lobes.spec, lobes.spec_ms, lobes.coat)
    return lobes


@wp.func
def eval_opaque(s: Surface, tables: GgxAlbedo, lobes: LobeAlbedos, n: wp.vec3, ng: wp.vec3, wo: wp.vec3, wi: wp.vec3):
    """The opaque BSDF's non-delta lobes: ``(f_diffuse, f_specular, pdf)`` for light from ``wi`` seen from ``wo``.

    ``n`` is the shading normal and ``ng`` the geometric normal, both on the side of ``wo``; ``lobes`` is
    :func:`lobe_albedos` for ``dot(n, wo)``. ``f_diffuse`` is the Lambertian lobe and ``f_specular`` the GGX,
    multiple-scattering and clearcoat lobes (what UsdLux's ``diffuse`` and ``specular`` light multipliers scale);
    ``f = f_diffuse + f_specular`` excludes the cosine; ``pdf`` is the solid-angle density with which
    :func:`sample_bsdf` draws ``wi`` from its opaque lobes.
    """
    cos_o = wp.dot(n, wo)
    cos_i = wp.dot(n, wi)
    if cos_o <= 0.0 or cos_i <= 0.0 or wp.dot(ng, wi) <= 0.0:
        return wp.vec3(0.0), wp.vec3(0.0), 0.0
    h = wp.normalize(wo + wi)
    cos_h = wp.dot(n, h)
    sin2_h = wp.length_sq(wp.cross(n, h))
    cos_vh = wp.max(wp.dot(wo, h), 0.0)
    f0 = surface_f0(s)
    # The layers below a lobe keep what the lobe does not reflect towards the viewer: 1 - its albedo at the viewing
    # angle (Kulla and Conty's albedo scaling), so a white surface reflects all the light it receives, no more.
    # At the half vector's Fresnel angle that share stayed near 0.95 at grazing angles, where the lobes' albedo
    # rises towards 0.5: a white surface reflected up to 1.44 times the light it received.
    coat_below = 1.0 - lobes.coat
    w = lobes.weights

    f_diffuse = wp.cw_mul(unreflected(lobes.spec + lobes.spec_ms), surface_albedo(s)) * (INV_PI * coat_below)
    f = wp.vec3(0.0)  # the specular lobes
    pdf = w[0] * cos_i * INV_PI
    if s.roughness >= DELTA_ROUGHNESS:
        a = ggx_alpha(s.roughness)
        dg = ggx_d(cos_h, sin2_h, a) * ggx_visibility(cos_o, cos_i, a)
        single = fresnel_schlick(f0, surface_f90(s), cos_vh) * dg
        f += (single + multiple_scattering(tables, lobes, s.roughness, cos_i)) * coat_below
        pdf += w[1] * ggx_reflection_pdf(cos_o, cos_h, sin2_h, a)
        pdf += w[2] * multiple_scattering_pdf(tables, s.roughness, lobes.ms_total, cos_i)
    if s.clearcoat > 0.0 and s.clearcoat_roughness >= DELTA_ROUGHNESS:
        ac = ggx_alpha(s.clearcoat_roughness)
        fc = s.clearcoat * fresnel_schlick_scalar(clearcoat_f0(s), cos_vh)
        f += wp.vec3(fc * ggx_d(cos_h, sin2_h, ac) * ggx_visibility(cos_o, cos_i, ac))
        pdf += w[3] * ggx_reflection_pdf(cos_o, cos_h, sin2_h, ac)
    return f_diffuse, f, pdf


@wp.func
def eval_bsdf_lobes(
    s: Surface, tables: GgxAlbedo, lobes: LobeAlbedos, n: wp.vec3, ng: wp.vec3, wo: wp.vec3, wi: wp.vec3
):
    """The whole BSDF's non-delta part: ``(f_diffuse, f_specular, pdf)`` with the opaque fraction applied (see
    :func:`eval_opaque`); ``tables`` are :func:`wrt.microfacet_albedo.ggx_albedo_tables` on the kernel's device,
    ``lobes`` is :func:`lobe_albedos` for ``dot(n, wo)``."""
    f_diffuse, f_specular, pdf = eval_opaque(s, tables, lobes, n, ng, wo, wi)
    k = opaque_fraction(s)
    return f_diffuse * k, f_specular * k, pdf * k


@wp.func
def eval_bsdf(s: Surface, tables: GgxAlbedo, lobes: LobeAlbedos, n: wp.vec3, ng: wp.vec3, wo: wp.vec3, wi: wp.vec3):
    """``(f, pdf)`` of :func:`eval_bsdf_lobes`, its two parts added."""
    f_diffuse, f_specular, pdf = eval_bsdf_lobes(s, tables, lobes, n, ng, wo, wi)
    return f_diffuse + f_specular, pdf


@wp.func
def share(part: float, whole: float):
    """``part / whole``, 0 where ``whole`` is not positive."""
    if whole > 0.0:
        return part / whole
    return 0.0


@wp.struct
class BsdfSample:
    """A direction drawn by :func:`sample_bsdf`."""

    wi: wp.vec3  # unit direction towards the light, world space
    weight: wp.vec3  # f * |cos| / pdf: the throughput factor of this bounce (zero: the path ends)
    pdf: float  # solid-angle pdf of ``wi`` (0 for delta events)
    diffuse: wp.vec3  # the diffuse lobe's share of ``weight`` per channel (0 for delta events and where it is 0)
    delta: int  # 1 when a delta lobe (mirror, refraction) was sampled: no MIS on the next hit
    transmitted: int  # 1 when ``wi`` crossed the surface


@wp.func
def sample_bsdf(
    s: Surface,
    tables: GgxAlbedo,
    lobes: LobeAlbedos,
    n: wp.vec3,
    ng: wp.vec3,
    wo: wp.vec3,
    front: int,
    u0: float,
    u1: float,
    u2: float,
    u3: float,
):
    """Draws ``wi`` for viewer ``wo`` from four uniform numbers.

    Args:
        s: the surface.
        tables: :func:`wrt.microfacet_albedo.ggx_albedo_tables` on the kernel's device.
        lobes: :func:`lobe_albedos` for ``dot(n, wo)``.
        n: shading normal on the side of ``wo``.
        ng: geometric normal on the side of ``wo``.
        wo: unit direction towards the viewer.
        front: 1 when ``wo`` is on the front side of the surface (decides ``eta`` for refraction; a thin-walled
            surface has the same two sides).
        u0: picks glass vs opaque.
        u1: picks the lobe (and reflection vs refraction).
        u2: direction.
        u3: direction.
    """
    out = BsdfSample()
    out.wi = wp.vec3(0.0)
    out.weight = wp.vec3(0.0)
    out.pdf = 0.0
    out.diffuse = wp.vec3(0.0)
    out.delta = 0
    out.transmitted = 0
    cos_o = wp.dot(n, wo)
    if cos_o <= 0.0:
        return out

    # Glass: the dielectric interface takes 1 - opacity of the light; reflect or transmit by its Fresnel term (a
    # thin-walled sheet's by its two faces').
    k = opaque_fraction(s)
    if u0 >= k:
        fr, wt = dielectric_interface(s, n, ng, wo, front)
        out.delta = 1
        if u1 < fr:
            wi, lit = mirror_reflection(wo, n, ng)
            out.wi = wi
            out.weight = wp.vec3(lit)
        else:
            out.wi = wt
            # Radiance is compressed by 1 / eta^2 entering a denser medium and expanded again leaving it, which a
            # closed object's two crossings cancel; an open surface (a window pane without thickness) has one
            # crossing only, where the factor dimmed what lay behind a clear pane to 0.47 (ior 1.5). Both drop it.
            out.weight = wp.vec3(1.0)
            out.transmitted = 1
        return out

    # Opaque: pick a lobe, then a direction in it. The weights' rounded sum may fall short of 1: a u1 above it goes
    # to the last lobe of non-zero weight (it took a clearcoat of weight 0, and a mirror coat gave 0 / 0 = NaN).
    w = lobes.weights
    wo_local = to_local(wo, n)
    if u1 < w[0] or (w[1] <= 0.0 and w[2] <= 0.0 and w[3] <= 0.0):
        out.wi = to_world(sample_cosine_hemisphere(u2, u3), n)
    elif u1 < w[0] + w[1] or (w[2] <= 0.0 and w[3] <= 0.0):
        if s.roughness < DELTA_ROUGHNESS:
            wi, lit = mirror_reflection(wo, n, ng)
            out.wi = wi
            out.weight = lobes.spec * ((1.0 - lobes.coat) / w[1] * lit)  # spec = F(cos_o) for a mirror
            out.delta = 1
            return out
        h = to_world(sample_ggx_vndf(wo_local, ggx_alpha(s.roughness), u2, u3), n)
        out.wi = reflect(wo, h)
    elif u1 < w[0] + w[1] + w[2] or w[3] <= 0.0:
        # Only a rough specular lobe has a multiple-scattering lobe (w[2] > 0).
        cos_i = sample_multiple_scattering_cos(tables, s.roughness, lobes.ms_total, u2)
        out.wi = to_world(direction_at_cos(cos_i, u3), n)
    else:
        if s.clearcoat_roughness < DELTA_ROUGHNESS:
            wi, lit = mirror_reflection(wo, n, ng)
            out.wi = wi
            out.weight = wp.vec3(lobes.coat / w[3] * lit)  # coat = clearcoat Fc(cos_o) for a mirror
            out.delta = 1
            return out
        h = to_world(sample_ggx_vndf(wo_local, ggx_alpha(s.clearcoat_roughness), u2, u3), n)
        out.wi = reflect(wo, h)

    f_diffuse, f_specular, pdf = eval_opaque(s, tables, lobes, n, ng, wo, out.wi)
    if pdf > 0.0:
        f = f_diffuse + f_specular
        out.weight = f * (wp.dot(n, out.wi) / pdf)
        out.pdf = pdf * k
        out.diffuse = wp.vec3(share(f_diffuse[0], f[0]), share(f_diffuse[1], f[1]), share(f_diffuse[2], f[2]))
    return out
