"""A stage's render settings (UsdRender): which camera, how many pixels, how the film meets the image, and which
products (output files of RenderVars) a render makes.

The stage metadata ``renderSettingsPrimPath`` names the default ``RenderSettings`` prim (``load_usd(...,
render_settings=PATH)`` picks another). Its ``camera``, ``resolution``, ``pixelAspectRatio``,
``aspectRatioConformPolicy``, ``dataWindowNDC`` and ``disableDepthOfField`` are read with the schema's fallbacks,
then, for each ``RenderProduct`` of its ``products``, overridden by the values that product authors, as
``UsdRenderComputeSpec`` merges them (one :class:`RenderSettings` per product in ``products``, each with its
``productName``, ``productType`` and ``orderedVars`` RenderVars: ``sourceName``, ``sourceType``, ``dataType``). The
settings object itself is the merge with the first product. ``includedPurposes``, ``materialBindingPurposes`` and
``renderingColorSpace`` are the settings prim's own (they cannot vary per product). Every value is read at the
render's time (``load_usd(..., time=T)``). A product that cannot be read (a
camera that is no camera, a value the schema does not allow) is left out with a warning naming it, the first too. A
render uses the first product's camera and resolution where the caller did not say otherwise (see
:func:`wrt.render.resolve_view`): an explicit camera, width or height wins over the stage's (one size alone keeps the
resolution's aspect), which wins over wrt's defaults (640 x 480, the stage's first camera).
:func:`wrt.render_products.render_products` renders every product and writes its RenderVars into a folder (named after
``productName``, never at its path: a stage must not choose where files go).

The conform policy and pixel aspect become the camera's ``fit`` and ``pixel_aspect_ratio`` (see
:meth:`wrt.Camera.film_size`). The data window crops (or, past [0, 1], overscans) the image as UsdRender's
rasterization rule says: a pixel is rendered when its centre lies in the window, ``(0, 0)`` the lower-left corner
of the conformed film, minimum edges included and maximum edges excluded; the image then holds only those pixels,
rendered exactly where they lie in the full image (a camera of the window's film and pixel count).
``instantaneousShutter`` and ``disableMotionBlur`` need nothing (wrt has no motion blur).
``materialBindingPurposes``, when authored, orders the binding purposes materials are looked up with
(:func:`wrt.materials.bound_material`); ``renderingColorSpace`` other than linear Rec.709 is warned about (wrt renders
in linear Rec.709 and converts nothing).
"""

from __future__ import annotations

import dataclasses
import functools
import math
import os
import warnings

import numpy as np

from .camera import CONFORM_POLICIES, Camera
from .errors import SceneError, did_you_mean, flag, prim_path, user_stacklevel
from .usd_values import schema_typed_value, value_at, value_or_fallback

DEFAULT_WIDTH = 640  # image width without a stage resolution or an explicit one, in pixels
DEFAULT_HEIGHT = 480  # image height, likewise
FULL_WINDOW = (0.0, 0.0, 1.0, 1.0)  # dataWindowNDC of the whole image: (xmin, ymin, xmax, ymax)
# renderingColorSpace names of linear Rec.709 (sRGB primaries), what wrt renders in: Gf's (first), USD's older one,
# and the OCIO names of it in the ACES and default configs.
LINEAR_REC709_NAMES = ("lin_rec709_scene", "lin_rec709", "Linear Rec.709 (sRGB)", "scene-linear Rec.709-sRGB")


@dataclasses.dataclass(frozen=True)
class RenderVar:
    """A ``RenderVar`` of a product: one quantity to write (see :mod:`wrt.render_products` for those wrt has).

    Attributes:
        path: the ``RenderVar`` prim.
        source_name: ``sourceName``, e.g. ``color``, ``depth``, ``normal``, ``C.*``.
        source_type: ``sourceType``: ``raw``, ``primvar``, ``lpe`` or ``intrinsic``.
        data_type: ``dataType``, e.g. ``color3f``, ``float``, ``int``.
        aov_name: ``driver:parameters:aov:name``, the channel (layer) name RenderMan and other renderers write the
            RenderVar under, or ``""`` where it is not authored (or not a string).
    """

    path: str
    source_name: str = ""
    source_type: str = "raw"
    data_type: str = "color3f"
    aov_name: str = ""

# The fields of RenderSettings that hold tuples: an array or a list given for one becomes a tuple.
_TUPLE_FIELDS = ("resolution", "data_window", "included_purposes", "render_vars", "products",
                 "material_binding_purposes")


@dataclasses.dataclass(frozen=True)
class RenderSettings:
    """The render settings of a stage, merged from a ``RenderSettings`` prim and one of its ``RenderProduct`` prims
    (the first, for the settings :func:`read_render_settings` returns; each, for its ``products``).

    Attributes:
        path: the ``RenderSettings`` prim.
        source: the file it was read from (for messages).
        product: the ``RenderProduct`` whose overrides were merged, or ``""``.
        camera: camera prim path (the ``camera`` relationship's first target), or ``None``.
        resolution: ``(width, height)`` in pixels.
        pixel_aspect_ratio: width / height of one pixel.
        conform_policy: ``aspectRatioConformPolicy``, one of :data:`CONFORM_POLICIES`.
        data_window: ``dataWindowNDC`` ``(xmin, ymin, xmax, ymax)``, ``(0, 0)`` the lower-left of the film.
        disable_depth_of_field: render stage cameras as pinholes.
        included_purposes: the purposes drawn besides ``default`` (always drawn, as UsdRender says).
        product_name: the product's ``productName`` (an output file name), or ``""``.
        product_type: the product's ``productType`` (``raster``, ``deepRaster``).
        render_vars: the product's ``orderedVars``, in order.
        products: every product of the settings, each merged as this one is with the first (``()`` on the products
            themselves and without any).
        material_binding_purposes: ``materialBindingPurposes`` when authored (``""``: all-purpose bindings), else
            ``None``: wrt's own rule, ``full`` then a readable ``preview`` (:func:`wrt.materials.bound_material`).
        rendering_color_space: ``renderingColorSpace``, or ``""``.
    """

    path: str
    source: str = ""
    product: str = ""
    camera: str | None = None
    resolution: tuple[int, int] = (2048, 1080)  # the schema's fallback
    pixel_aspect_ratio: float = 1.0
    conform_policy: str = "expandAperture"
    data_window: tuple[float, float, float, float] = FULL_WINDOW
    disable_depth_of_field: bool = False
    included_purposes: tuple[str, ...] = ("default", "render")
    product_name: str = ""
    product_type: str = "raster"
    render_vars: tuple[RenderVar, ...] = ()
    products: tuple[RenderSettings, ...] = ()
    material_binding_purposes: tuple[str, ...] | None = None
    rendering_color_space: str = ""

    def __post_init__(self):
        # Settings made in Python may hold arrays (resolution=np.array([64, 48])), as cameras take them; kept so, the
        # data window's test against the full one and a kept Renderer's check for replaced settings (which compares
        # them field by field) raised numpy's "truth value of an array is ambiguous". Tuples of plain values compare.
        for field in _TUPLE_FIELDS:
            value = getattr(self, field)
            if isinstance(value, np.ndarray):
                value = value.tolist()
            if isinstance(value, list):
                object.__setattr__(self, field, tuple(value))  # frozen: set as dataclasses' own __init__ does
        self._check_fields()

    def _check_fields(self) -> None:
        """Checks settings made in Python when they are made, as a stage's are when read, naming the field and the
        value: a resolution (0, 10) failed only at the render, with "float division by zero", (64,) with "not
        enough values to unpack", and a string for a tuple of names or a flag was taken without a word.

        Raises:
            SceneError: a value the schema does not allow (see :func:`read_render_settings`).
            TypeError: a field of another type.
        """
        where = f"RenderSettings {self.path!r}"
        set_field = functools.partial(object.__setattr__, self)  # frozen: set as dataclasses' own __init__ does
        set_field("path", prim_path(self.path, "RenderSettings"))
        values = {field: getattr(self, field) for field in _FIELD_NAMES}
        _check_values(values, dict(prim=where), _FIELD_NAMES)
        for field, value in values.items():
            set_field(field, value)
        if self.camera is not None:
            set_field("camera", prim_path(self.camera, f"{where}: camera"))
            if not self.camera.strip():  # at the render: "camera  is not among the cameras wrt reads"
                raise SceneError("camera is an empty path; give a camera prim path, or None for the stage's first",
                                 prim=where)
        set_field("disable_depth_of_field", flag(self.disable_depth_of_field, f"{where}: disable_depth_of_field"))
        for field in ("source", "product", "product_name", "product_type", "rendering_color_space"):
            if not isinstance(getattr(self, field), str):
                raise TypeError(f"{where}: {field} must be a str, got {type(getattr(self, field)).__name__} "
                                f"{getattr(self, field)!r}")
        kinds = {"included_purposes": str, "material_binding_purposes": str, "render_vars": RenderVar,
                 "products": RenderSettings}
        for field, kind in kinds.items():
            value = getattr(self, field)
            if value is None and field == "material_binding_purposes":
                continue
            if not (isinstance(value, tuple) and all(isinstance(item, kind) for item in value)):
                # A string of names was taken as its letters.
                raise TypeError(f"{where}: {field} must be a tuple (or list) of {kind.__name__}, got "
                                f"{type(value).__name__} {value!r}")

    def view_fields(self) -> tuple:
        """What of these settings chooses a render's image: the camera, the resolution, the film's fit and pixel
        aspect, the data window and depth of field. Settings that differ elsewhere only (a product's name or path,
        its RenderVars, the purposes and colour space read when the stage was loaded) render the same image."""
        return (self.camera, self.resolution, self.pixel_aspect_ratio, self.conform_policy, self.data_window,
                self.disable_depth_of_field)

    def image_size(self, width: int | None, height: int | None) -> tuple[int, int]:
        """``(width, height)`` before the data window: the given ones; where only one is given, the other keeps the
        ``resolution``'s aspect (as ``usdrecord --imageWidth`` takes the height from the camera: a smaller preview of
        the shot, not a stretched one); where neither is, the ``resolution``."""
        res_w, res_h = self.resolution
        if width is None and height is None:
            return res_w, res_h
        if height is None:
            return width, max(1, round(width * res_h / res_w))
        if width is None:
            return max(1, round(height * res_w / res_h)), height
        return width, height

    def frame(self, camera: Camera, width: int, height: int) -> tuple[Camera, int, int]:
        """A stage camera as these settings render it at ``width x height`` pixels (before the data window):
        ``(camera with the conform policy, pixel aspect and depth of field of the settings, cropped to the data
        window, the cropped image's width and height)``. Under ``adjustPixelAspectRatio`` the camera's pixel aspect
        is the apertures' aspect over the image's pixel counts', as ``UsdRenderComputeSpec`` computes it.

        Raises:
            SceneError: the data window holds no pixel centre of the image, or the conform policy reads an aperture
                of 0 (which the camera's own ``expandAperture`` did not).
        """
        changes = {"fit": self.conform_policy, "pixel_aspect_ratio": self.pixel_aspect_ratio}
        if self.disable_depth_of_field:
            changes["f_stop"] = 0.0
        try:  # Camera.check: a zero aperture the camera's own fit did not read may be one this policy reads
            framed = dataclasses.replace(camera, **changes)
        except ValueError as e:
            raise SceneError(f"{self.product or self.path} renders camera {camera.path} with aspectRatioConformPolicy "
                             f"{self.conform_policy!r}, which it cannot take: {e}", path=self.source or None)
        if self.conform_policy == "adjustPixelAspectRatio":
            # The film is the apertures as they are, so the pixels take their shape; the schema "disregards" the
            # authored value. The rays do not change (the film ignores it); what a product says its pixels are does.
            ratio = camera.horizontal_aperture / camera.vertical_aperture * height / width
            framed = dataclasses.replace(framed, pixel_aspect_ratio=ratio)
        return self.crop(framed, width, height)

    def window_pixels(self, width: int, height: int) -> tuple[int, int, int, int]:
        """``(j0, j1, k0, k1)``: the columns ``j0 <= j < j1`` (from the left) and rows ``k0 <= k < k1`` (from the
        bottom) of a ``width x height`` image that the data window holds, beyond the image where it overscans.

        Raises:
            SceneError: the data window holds no pixel centre of the image.
        """
        # Pixel k (from the left, or from the bottom) has its centre at NDC (k + 0.5) / n: the first one at or past
        # the minimum edge, and the first one at or past the maximum edge, which is left out.
        xmin, ymin, xmax, ymax = self.data_window
        j0, j1 = (math.ceil(v * width - 0.5) for v in (xmin, xmax))
        k0, k1 = (math.ceil(v * height - 0.5) for v in (ymin, ymax))
        if j1 <= j0 or k1 <= k0:
            shown = ", ".join(f"{v:g}" for v in self.data_window)
            raise SceneError(f"dataWindowNDC ({shown}) holds no pixel centre of the {width}x{height} image",
                             path=self.source or None, prim=self.product or self.path)
        return j0, j1, k0, k1

    def placement(self, width: int, height: int) -> tuple[int, int, int, int]:
        """``(width, height, x0, y0)``: a ``width x height`` image and the top-left pixel (counted from its top-left,
        as EXR counts them) of the pixels the data window holds, where they lie in it (:attr:`wrt.Image.window`).

        Raises:
            SceneError: the data window holds no pixel centre of the image.
        """
        j0, _, _, k1 = self.window_pixels(width, height)
        return width, height, j0, height - k1  # rows of the window count up from the bottom, EXR's down from the top

    def crop(self, camera: Camera, width: int, height: int) -> tuple[Camera, int, int]:
        """``(camera, width, height)`` of the pixels of a ``width x height`` image of ``camera`` that the data window
        holds: a camera whose film is exactly theirs, and their count (``camera`` itself without a window).

        Raises:
            SceneError: the data window holds no pixel centre of the image.
        """
        if self.data_window == FULL_WINDOW:
            return camera, width, height
        j0, j1, k0, k1 = self.window_pixels(width, height)
        film_w, film_h = camera.film_size(width, height)
        cropped = dataclasses.replace(
            camera,
            fit="adjustPixelAspectRatio",  # the film is exactly these apertures, whatever the pixel count
            horizontal_aperture=film_w * (j1 - j0) / width,
            vertical_aperture=film_h * (k1 - k0) / height,
            horizontal_aperture_offset=camera.horizontal_aperture_offset + ((j0 + j1) / (2 * width) - 0.5) * film_w,
            vertical_aperture_offset=camera.vertical_aperture_offset + ((k0 + k1) / (2 * height) - 0.5) * film_h,
        )
        return cropped, j1 - j0, k1 - k0


def settings_prims(stage) -> list[str]:
    """The paths of the ``RenderSettings`` prims of ``stage`` (active ones), for a message naming those to choose."""
    from pxr import UsdRender

    return [str(p.GetPath()) for p in stage.Traverse() if p.IsA(UsdRender.Settings)]


def read_render_settings(stage, source: str, path: str | None = None, time=None) -> RenderSettings | None:
    """The render settings at prim ``path``, else those ``renderSettingsPrimPath`` names; ``None`` when neither, or
    (with a warning) when the metadata names no ``RenderSettings`` prim. Their attributes are read at ``time`` (a
    ``Usd.TimeCode``; ``None``: the default time, where a value of time samples only is read at its first, as
    :func:`wrt.usd_values.value_at` reads every attribute), the render's: the schema makes them ``uniform``, yet
    stages do animate them (a ``productName`` per frame), and a render of frame 12 is then frame 12's.

    Raises:
        SceneError: naming the file and prim: no ``RenderSettings`` prim at the ``path`` given, or on the settings
            prim itself (a product's are warnings) a ``camera`` relationship to a prim that is not a camera, or a
            value the schema does not allow (a resolution that is not positive, a pixel aspect ratio that is not a
            finite positive number, an unknown conform policy, a data window that is not finite or empty, a value
            of another type than the schema's).
    """
    from pxr import Sdf, Usd, UsdRender

    time = Usd.TimeCode.Default() if time is None else time
    name = os.path.basename(source)
    given = path is not None
    if not given:
        path = stage.GetMetadata("renderSettingsPrimPath") or None
        if path is None:
            return None
    prim = stage.GetPrimAtPath(path) if Sdf.Path.IsValidPathString(path) and Sdf.Path(path).IsAbsolutePath() else None
    if not (prim and prim.IsActive() and prim.IsA(UsdRender.Settings)):
        found = settings_prims(stage)
        what = f"a {prim.GetTypeName() or 'typeless prim'}" if prim else "nothing"
        what = f"an inactive {prim.GetTypeName()}" if prim and not prim.IsActive() else what
        meant = did_you_mean(path, found) if given else ""  # a stale renderSettingsPrimPath is no typo of the user's
        problem = f"is {what}, not a RenderSettings prim{meant}; RenderSettings prims in the stage: " + (
            ", ".join(found) or "none")
        if given:
            raise SceneError(f"{path} {problem}", path=source)
        # Metadata left behind when the settings were deleted or renamed: the stage still renders (as usdview draws
        # it), with wrt's defaults, rather than failing for settings the user never asked for.
        warnings.warn(f"{name}: {path} (the stage's renderSettingsPrimPath) {problem}; it is ignored",
                      stacklevel=user_stacklevel())
        return None
    path = str(path)
    settings = UsdRender.Settings(prim)
    base, mistyped = _read_base(settings, time, authored_only=False)
    where = dict(path=source, prim=path)
    included = _tokens(settings.GetIncludedPurposesAttr(), value_or_fallback(settings.GetIncludedPurposesAttr(), time),
                       where)
    base["included_purposes"] = ("default", *(t for t in included if t != "default"))  # default: always drawn
    binding_purposes = settings.GetMaterialBindingPurposesAttr()
    if binding_purposes.HasAuthoredValue():
        base["material_binding_purposes"] = _tokens(binding_purposes, value_at(binding_purposes, time), where)
    base["rendering_color_space"] = str(value_at(settings.GetRenderingColorSpaceAttr(), time) or "")
    _check_values(base, where)
    _check_types(mistyped, where)
    # The settings' own camera is checked here, as their other values are: checked in each product that took it, it
    # left that product out with a warning naming the settings as the product, and only then failed the load.
    _check_camera(stage, base.get("camera"), where)
    _warn_color_space(base["rendering_color_space"], f"{name}: {path}")
    products = []
    for prim in _targets(stage, settings.GetProductsRel(), UsdRender.Product, f"{name}: {path}"):
        try:
            products.append(_merged(stage, source, path, base, prim, time))
        except SceneError as error:
            # A product must not keep the stage from loading, the first no more than a later one: a plain render
            # then uses the first product that can be read, or the settings' own values when none can.
            warnings.warn(f"{error}; this RenderProduct is left out", stacklevel=user_stacklevel())
    if not products:
        return _merged(stage, source, path, base, None, time)
    return dataclasses.replace(products[0], products=tuple(products))


def _targets(stage, rel, schema, where: str) -> list:
    """The prims of ``schema`` (``UsdRender.Product`` or ``UsdRender.Var``) that relationship ``rel`` targets
    (forwarded), in order; a target that is not one is left out with a warning, as ``UsdRenderComputeSpec`` skips
    it."""
    prims = []
    for target in rel.GetForwardedTargets():
        prim = stage.GetPrimAtPath(target)
        if prim and prim.IsA(schema):
            prims.append(prim)
        else:
            what = f"a {prim.GetTypeName() or 'typeless prim'}" if prim else "nothing"
            warnings.warn(f"{where}: {rel.GetName()} targets {target}, which is {what}, not a "
                          f"Render{schema.__name__}; it is left out", stacklevel=user_stacklevel())
    return prims


def _merged(stage, source: str, path: str, base: dict, product_prim, time) -> RenderSettings:
    """The settings at ``path`` (``base``: their values) merged with the overrides of ``product_prim`` (or None),
    with the product's name, type and RenderVars at ``time``, as ``UsdRenderComputeSpec`` builds each product."""
    from pxr import UsdRender

    values = dict(base)
    if product_prim is not None:
        product = str(product_prim.GetPath())
        schema = UsdRender.Product(product_prim)
        overrides, mistyped = _read_base(schema, time, authored_only=True)
        _check_camera(stage, overrides.get("camera"), dict(path=source, prim=product))  # (the settings' one: checked)
        values.update(overrides, product=product,
                      product_name=str(_typed(schema.GetProductNameAttr(), time, mistyped) or ""),
                      product_type=str(_typed(schema.GetProductTypeAttr(), time, mistyped) or "raster"))
        where = f"{os.path.basename(source)}: {product}"
        values["render_vars"] = tuple(_read_var(UsdRender.Var(var), time, mistyped)
                                      for var in _targets(stage, schema.GetOrderedVarsRel(), UsdRender.Var, where))
    if product_prim is not None:  # the merged values: a bad one now comes from the product
        _check_values(values, dict(path=source, prim=values["product"]))
        _check_types(mistyped, dict(path=source, prim=values["product"]))
    return RenderSettings(path=path, source=source, **values)


def _check_camera(stage, camera: str | None, where: dict) -> None:
    """SceneError (``where``: file and prim) unless ``camera``, the path a ``camera`` relationship targets (or None),
    is a Camera prim of ``stage``."""
    from pxr import UsdGeom

    if camera is None:
        return
    target = stage.GetPrimAtPath(camera)
    if not (target and target.IsA(UsdGeom.Camera)):
        from .usd_cameras import why_not_read

        what = f"a {target.GetTypeName() or 'typeless prim'}" if target else "no prim"
        why = why_not_read(stage, camera)  # a camera under an inactive prim is none to USD
        what = f"{what} ({why})" if why else what
        raise SceneError(f"camera relationship targets {camera}, which is {what}, not a Camera", **where)


def _read_var(var, time, mistyped: list[str]) -> RenderVar:
    """The :class:`RenderVar` of a ``UsdRender.Var`` at ``time`` (the schema's fallbacks where nothing is
    authored); words for each value of another type than the schema's are added to ``mistyped``, naming the
    RenderVar (:func:`_check_types` names the product)."""
    aov_name = var.GetPrim().GetAttribute("driver:parameters:aov:name")  # a driver parameter: no schema getter
    aov_name = value_at(aov_name, time) if aov_name else None
    wrong = []
    read = RenderVar(path=str(var.GetPath()), source_name=str(_typed(var.GetSourceNameAttr(), time, wrong) or ""),
                     source_type=str(_typed(var.GetSourceTypeAttr(), time, wrong) or "raw"),
                     data_type=str(_typed(var.GetDataTypeAttr(), time, wrong) or "color3f"),
                     aov_name=aov_name.strip() if isinstance(aov_name, str) else "")
    mistyped.extend(f"RenderVar {read.path}: {words}" for words in wrong)
    return read


def _typed(attr, time, mistyped: list[str]):
    """``attr``'s value at ``time`` as USD's typed read gives it (:func:`wrt.usd_values.schema_typed_value`); words
    for a value of another type than the schema's are added to ``mistyped``. Python's ``Get`` handed back a ``string
    productName``, an ``int dataType`` as authored, which ``UsdRenderComputeSpec`` passes over."""
    value, wrong = schema_typed_value(attr, time)
    if wrong is not None:
        mistyped.append(f"{wrong}, not the schema's {attr.GetTypeName()}")
    return value


def _warn_color_space(space: str, where: str) -> None:
    """One warning when ``renderingColorSpace`` names a space other than the linear Rec.709 primaries wrt renders in
    (colours are read and summed as they are, never converted)."""
    if space and space not in LINEAR_REC709_NAMES:
        warnings.warn(f"{where}: renderingColorSpace {space!r} is not linear Rec.709 ({LINEAR_REC709_NAMES[0]}), "
                      "which wrt renders in; colours are not converted", stacklevel=user_stacklevel())


def _read_base(schema, time, authored_only: bool) -> tuple[dict, list[str]]:
    """The ``UsdRenderSettingsBase`` values of ``schema`` at ``time`` as :class:`RenderSettings` fields: every one
    (fallbacks included), or only those authored (a product's overrides); and words for each of them authored with
    another type than the schema's (``float2 resolution = (64, 32)``), for :func:`_check_types`."""
    values, mistyped = {}, []
    targets = schema.GetCameraRel().GetForwardedTargets()
    if targets:
        values["camera"] = str(targets[0])
    attrs = {
        "resolution": schema.GetResolutionAttr(),
        "pixel_aspect_ratio": schema.GetPixelAspectRatioAttr(),
        "conform_policy": schema.GetAspectRatioConformPolicyAttr(),
        "data_window": schema.GetDataWindowNDCAttr(),
        "disable_depth_of_field": schema.GetDisableDepthOfFieldAttr(),
    }
    for field, attr in attrs.items():
        if authored_only and not attr.HasAuthoredValue():  # a blocked value too: it overrides nothing
            continue
        value = value_or_fallback(attr, time)  # as authored: _check_values names a value it cannot read
        _typed(attr, time, mistyped)
        if field in ("resolution", "data_window") and not isinstance(value, str) and hasattr(value, "__len__"):
            value = tuple(value)  # (another type is refused by _check_values, naming the attribute)
        elif field == "conform_policy":
            value = str(value)
        values[field] = value
    return values, mistyped


def _check_types(mistyped: list[str], where: dict) -> None:
    """SceneError (``where``: file and prim) naming the values :func:`_read_base` found authored with another type
    than the schema's. Python's ``Get`` hands them back as they are, and a ``float2 resolution``, a ``double
    pixelAspectRatio`` or a ``string aspectRatioConformPolicy`` was rendered as authored without a word, where USD's
    typed reads (``UsdRenderComputeSpec``'s, Hydra's) pass them over for the schema's fallback: another image."""
    if mistyped:
        raise SceneError(f"{'; '.join(mistyped)}: UsdRenderComputeSpec passes a value of another type over for the "
                         "schema's fallback; author the schema's type", **where)


def _tokens(attr, value, where: dict) -> tuple:
    """``value`` of token-array attribute ``attr`` (``includedPurposes``, ``materialBindingPurposes``) as a tuple of
    str (none for no value), or SceneError (``where``: file and prim) naming it when it is no array of tokens or
    strings: a ``string`` one was read letter by letter ("render" as the purposes r, e, n, d, ...), and one that
    cannot be iterated (an ``asset``) stopped the load with a TypeError. A ``string[]`` reads as the same words in
    Python, but USD's typed read (``Get<VtTokenArray>``, UsdImaging's) fails on it and gives the schema's fallback."""
    from pxr import Sdf

    if value is None:
        return ()
    items = list(value) if not isinstance(value, (str, bytes)) and hasattr(value, "__iter__") else None
    stack = attr.GetPropertyStack()  # the strongest spec holds the authored type; GetTypeName gives the schema's
    if stack and stack[0].typeName == Sdf.ValueTypeNames.StringArray:
        raise SceneError(f"{attr.GetName()} must be an array of tokens, got string[] {list(items)!r}", **where)
    if items is None or not all(isinstance(item, str) for item in items):
        raise SceneError(f"{attr.GetName()} must be an array of tokens, got {value!r}", **where)
    return tuple(items)


def _is_number(value) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


# How messages name the fields _check_values checks: by the attribute a stage authors (the default), or by the field
# of RenderSettings (settings made in Python).
_USD_NAMES = {"resolution": "resolution", "data_window": "dataWindowNDC", "pixel_aspect_ratio": "pixelAspectRatio",
              "conform_policy": "aspectRatioConformPolicy"}
_FIELD_NAMES = {field: field for field in _USD_NAMES}


def _check_values(values: dict, where: dict, names: dict = _USD_NAMES) -> None:
    """Raises SceneError (``where``: file and prim; ``names``: how the message names each field) for values the schema
    does not allow, or of another type than the schema's (a ``string resolution``: it stopped the render with "too
    many values to unpack"). Makes them plain numbers and tuples."""
    for field, count in (("resolution", 2), ("data_window", 4), ("pixel_aspect_ratio", 1)):
        found, name = values[field], names[field]
        numbers = found if count > 1 and isinstance(found, tuple) else (found,)
        if len(numbers) != count or not all(_is_number(v) for v in numbers):
            raise SceneError(f"{name} must be {count} number{'s' * (count > 1)}, got {found!r}", **where)
    w, h = values["resolution"]
    if not (w > 0 and h > 0 and math.isfinite(w) and math.isfinite(h)):  # (a float2 one may hold inf)
        raise SceneError(f"{names['resolution']} {w}x{h} must be positive", **where)
    if w != int(w) or h != int(h):  # (16.5, 12) was cut to 16 pixels without a word
        raise SceneError(f"{names['resolution']} {w}x{h} must be whole numbers of pixels", **where)
    ratio = values["pixel_aspect_ratio"]
    if not (math.isfinite(ratio) and ratio > 0):
        raise SceneError(f"{names['pixel_aspect_ratio']} must be a finite positive number, got {ratio}", **where)
    if values["conform_policy"] not in CONFORM_POLICIES:
        raise SceneError(f"{names['conform_policy']} {values['conform_policy']!r} is none of "
                         f"{', '.join(CONFORM_POLICIES)}{did_you_mean(values['conform_policy'], CONFORM_POLICIES)}",
                         **where)
    window = values["data_window"]
    if not (all(math.isfinite(v) for v in window) and window[0] < window[2] and window[1] < window[3]):
        shown = ", ".join(f"{v:g}" for v in window)
        raise SceneError(f"{names['data_window']} ({shown}) must be finite (xmin, ymin, xmax, ymax) with xmin < xmax "
                         "and ymin < ymax", **where)
    values["data_window"] = tuple(float(v) for v in window)
    values["pixel_aspect_ratio"] = float(ratio)
    values["resolution"] = (int(w), int(h))
