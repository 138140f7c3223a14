"""Render products: every ``RenderProduct`` of a stage's render settings rendered at its own camera and resolution,
its ``RenderVar``\\ s taken from wrt's image and AOVs, and written into one folder.

A RenderVar's ``sourceName`` (``sourceType`` ``raw`` or ``intrinsic``) is looked up in :data:`SOURCES`: the names
of Hydra's ``HdAovTokens``, RenderMan's and wrt's own AOV names. ``sourceType = "lpe"`` knows the full beauty
expressions of :data:`BEAUTY_LPES` only, and wrt has no primvar AOVs (``sourceType = "primvar"``). A RenderVar wrt
has no output for is left out with one warning naming it; a product left with nothing is skipped.

Files: ``OUTDIR/<last component of productName>`` (the product's prim name without one, or before a name
that begins with a dot, such as ``.png`` or ``.beauty.png``, which would hide the file); the folder is the
caller's, never the stage's, so ``../x.png`` and ``/abs/x.png`` both become ``OUTDIR/x.png``. A product of the
beauty alone may be a ``.png`` (8-bit sRGB, RGBA where its dataType has four components, alpha the ``coverage``
AOV, the colour unpremultiplied by it); every other product is an OpenEXR file of float32 channels (ids too: exact
up to 2^24), the name's extension replaced with a warning where it is another image format's (:data:`IMAGE_EXTENSIONS`;
``shot.beauty`` is ``shot.beauty.exr``), and a name past 255 bytes shortened.
The first beauty RenderVar of a product fills ``R, G, B`` (``A``), the others a layer named after their
``driver:parameters:aov:name`` where it is authored, else after their prim: ``depth`` (one channel), ``N.X, N.Y,
N.Z``, ``albedo.R, albedo.G, albedo.B``, ... (``_2`` where an earlier layer has the name or writes one of its
channels; shortened past 237 bytes). Two products of one file name get ``_2``, ``_3`` suffixes, with a warning. An
EXR's header places it in its shot (``displayWindow``: the whole resolution; ``dataWindow``: the pixels of
``dataWindowNDC``) and names the prims of its id layers: ``<layer>/paths``, a JSON object ``{id: path}`` of the ids
in the image, for ``primId`` (:meth:`wrt.Scene.prim_paths`) and ``instanceId``
(:meth:`wrt.instancing.Instances.path`).
"""

from __future__ import annotations

import dataclasses
import json
import os
import re
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from .animation import MAX_NAME_BYTES
from .image import (
    DATA_EXPOSURE_WARNING,
    check_exposure,
    check_exr_pixel_aspect,
    check_folder_path,
    data_to_8bit,
    to_srgb8,
    write_atomically,
    write_exr,
    write_srgb_png,
)
from .image import exr_windows as image_exr_windows
from .rays import camera_rays
from .render import DATA_INTEGRATORS, MAX_PATHS_PER_LAUNCH, Renderer, check_pixels, resolve_view

BEAUTY = "rgb"  # Image.rgb: the integrator's image, linear radiance
# sourceName -> what wrt writes for it: BEAUTY, an Image.aovs key, or one made from them ("Neye", "P", "Peye",
# "primId", "elementId").
SOURCES = {
    "color": BEAUTY, "Ci": BEAUTY, "lpe:C.*": BEAUTY,  # Hydra's beauty, RenderMan's, Hydra's LPE spelling
    "depth": "depth",  # wrt's depth: distance along the camera ray (not Hydra's [0, 1] depth buffer)
    # Hydra's cameraDepth: camera-space depth, -Peye.z; wrt's z: world distance along the view axis (the two differ
    # under a scaled or sheared camera).
    "cameraDepth": "cameraDepth", "z": "z",
    "P": "P",  # world-space position of the camera ray's hit (0 on a miss)
    "Peye": "Peye",  # the same in camera space
    "normal": "normal", "N": "normal",  # world-space shading normal
    "Neye": "Neye",  # the shading normal in camera space (the camera looks down -Z)
    "Ng": "geometric_normal", "geometric_normal": "geometric_normal",
    "albedo": "albedo",
    "primId": "primId",  # the prim drawn, at its instance-proxy path in a native instance: Scene.prim_paths()
    "elementId": "elementId",  # the face of a mesh, the point or curve of a Points or curves prim (Scene.hit_prims)
    "prim": "prim",  # wrt's triangle id: a row of Scene.triangles()
    "instanceId": "instance", "instance": "instance",
    "material": "material",
    "cost": "cost",
}
BEAUTY_LPES = ("C.*", "C.*[<L.>O]")  # lpe sourceNames of the whole image
# Channel names in a layer, by what is written; one name: the layer's name alone.
CHANNELS = {BEAUTY: ("R", "G", "B"), "albedo": ("R", "G", "B"), "normal": ("X", "Y", "Z"), "Neye": ("X", "Y", "Z"),
            "geometric_normal": ("X", "Y", "Z"), "P": ("X", "Y", "Z"), "Peye": ("X", "Y", "Z"),
            "cost": ("nodes", "triangles")}
NAMED_IDS = ("primId", "instance")  # ids whose prim paths the EXR header names (attribute "<layer>/paths")
EXACT_FLOAT_INTS = 1 << 24  # ids up to this are exact in a float32 channel
NUMBER_BYTES = 8  # room left in a long file name for the "_k" that tells products of one name apart
# Extensions of image formats a productName may end in: PNG and EXR, which wrt writes, those of OpenImageIO (the image
# library of USD's renderers), replaced by the one wrt writes (".tif" by ".png"), and wrt's own .npy. Any other dotted
# word is part of the name: "shot.beauty" and "shot.diffuse" were both taken for "shot" in another format, and
# written as shot.png and shot_2.png. OpenImageIO's words that name a pass as well as a format (.env, .int, .bw,
# .sm, .vsm) are left to the name.
IMAGE_EXTENSIONS = frozenset(
    ".png .exr .sxr .mxr .bmp .cin .dds .dpx .gif .hdr .heic .heif .heics .hif .avif .iff .jpg .jpeg .jpe .jif .jfif "
    ".jfi .jp2 .j2k .j2c .pbm .pgm .ppm .pnm .pfm .psd .psb .pdd .pic .rla .rgbe .sgi .rgb .rgba .tga .tif .tiff .tx "
    ".webp .npy".split())
# Longest layer name: its channels (".triangles" the longest) and its "/paths" attribute within the 255 bytes of an
# EXR name, where OpenEXR cut channel names (two long layers wrote one channel) and dropped attributes without a word.
MAX_LAYER_BYTES = MAX_NAME_BYTES - len(".triangles") - NUMBER_BYTES


@dataclasses.dataclass(frozen=True)
class _Output:
    """A RenderVar resolved: what it writes (a key of :data:`SOURCES`' values) and its layer name."""

    kind: str
    layer: str
    alpha: bool = False  # a beauty of four components: alpha is the coverage AOV


def source_of(var) -> str | None:
    """What wrt writes for RenderVar ``var`` (:class:`wrt.render_settings.RenderVar`), or None when it has nothing."""
    if var.source_type in ("raw", "intrinsic"):
        return SOURCES.get(var.source_name)
    if var.source_type == "lpe":
        return BEAUTY if var.source_name.replace(" ", "") in BEAUTY_LPES else None
    return None


def _has_alpha(data_type: str) -> bool:
    """Whether a beauty RenderVar of ``dataType`` ``data_type`` has four components (``color4f``, ``float4``...)."""
    return re.fullmatch(r"(color|float|half|double)4[fhd]?", data_type) is not None


def product_outputs(product, where: str) -> list[_Output]:
    """The outputs of ``product``'s RenderVars (just the beauty without any), with one warning per RenderVar wrt has
    no output for (``where``: the file, for messages)."""
    if not product.render_vars:
        return [_Output(BEAUTY, "")]
    # Layers, and the channels they write: not the beauty's names, and no channel twice (a layer "N.X" of depth beside
    # the normal's layer "N" wrote the channel N.X twice, the later over the earlier, without a word).
    outputs, layers, channels, seen = [], TakenNames({"r", "g", "b", "a"}), {"r", "g", "b", "a"}, set()
    for var in product.render_vars:
        if var.path in seen:  # listed twice: written once
            continue
        seen.add(var.path)
        kind = source_of(var)
        if kind is None:
            warnings.warn(f"{where}: RenderVar {var.path} ({var.source_type} {var.source_name!r}) has no wrt output "
                          f"and is left out; wrt writes the raw sourceNames {', '.join(SOURCES)} and the lpe "
                          f"{' and '.join(BEAUTY_LPES)}", stacklevel=3)
            continue
        beauty = kind == BEAUTY and not any(o.kind == BEAUTY and not o.layer for o in outputs)
        output = _Output(kind, "", alpha=kind == BEAUTY and _has_alpha(var.data_type))
        if not beauty:
            name = var.aov_name or var.path.rsplit("/", 1)[-1]
            if len(name.encode()) > MAX_LAYER_BYTES:  # OpenEXR cuts longer channel names, and drops such attributes
                name = name.encode()[:MAX_LAYER_BYTES].decode(errors="ignore")
                warnings.warn(f"{where}: RenderVar {var.path}: its layer name is longer than the {MAX_NAME_BYTES} "
                              f"bytes an EXR channel or attribute name may have with its channel; written as {name}",
                              stacklevel=3)
            output = dataclasses.replace(output, layer=layers.unique(name))
            while not channels.isdisjoint(c.casefold() for c in channel_names(output)):
                output = dataclasses.replace(output, layer=layers.unique(name))
        channels.update(c.casefold() for c in channel_names(output))
        outputs.append(output)
    return outputs


def channel_names(output: _Output) -> list[str]:
    """The EXR channels ``output`` writes: its layer's name and each of :data:`CHANNELS` (``A`` too for alpha)."""
    names = (*CHANNELS.get(output.kind, ("",)), *(("A",) if output.alpha else ()))
    return [".".join(p for p in (output.layer, name) if p) for name in names]


class TakenNames:
    """Names used in one folder or one file, compared without case (``names``: the first ones), made unique by
    :meth:`unique`."""

    def __init__(self, names=()):
        self.names = {name.casefold() for name in names}
        # Each name asked for -> the k of the last ``name_k`` given for it: the next one starts there (all below are
        # taken), where thousands of products of one productName tried _2, _3, ... from the start each (quadratic).
        self.last = {}

    def unique(self, name: str) -> str:
        """``name``, or ``name_2``, ``name_3``... (the first not taken); recorded as taken."""
        stem, suffix = os.path.splitext(name)
        key = name.casefold()
        k = self.last.get(key, 1)
        candidate = name if k == 1 else f"{stem}_{k}{suffix}"
        while candidate.casefold() in self.names:
            k += 1
            candidate = f"{stem}_{k}{suffix}"
        self.names.add(candidate.casefold())
        self.last[key] = k
        return candidate


def product_file_name(product, png: bool, where: str, taken: TakenNames) -> str:
    """The file name of ``product`` in the output folder: the last component of ``productName`` (else the product
    prim's name), with ``.png`` (``png``: the beauty alone) or ``.exr``; ``taken`` (file names already used) makes it
    unique. A name that changes on the way is named in a warning."""
    name = re.split(r"[\\/]", product.product_name)[-1].strip()
    name = re.sub(r"[\x00-\x1f]", "_", name)  # a NUL cannot be in a file name
    name = name.rstrip(".")  # "shot.": the dot before the extension wrt adds, not "shot..png"; ".", "..": no name
    # A leading dot hides the file: ".png" was the hidden ".png.png", ".beauty.png" the hidden ".beauty.png" (an empty
    # shot variable in a templated name). The prim's name goes before it, as where there is no name.
    hidden = name.startswith(".")
    alone = name.lower() in IMAGE_EXTENSIONS  # ".beauty" is a name that would hide the file, not an extension
    hides = "is an extension alone, no file name" if alone else "begins with a dot, which hides the file"
    if not name or hidden:
        name = product.product.rsplit("/", 1)[-1] + "." * hidden + name.lstrip(".")
    stem, suffix = os.path.splitext(name)
    wanted = ".exr" if not png or suffix.lower() == ".exr" else ".png"
    if suffix.lower() != wanted:
        if suffix.lower() in IMAGE_EXTENSIONS:  # another format's (".tif", or ".png" of more than the beauty): replaced
            # Not 'several channels': a product of depth alone is one channel, and still no PNG (8-bit colour).
            what = "PNG or EXR" if png else "PNG for a product of the beauty alone, EXR for any other RenderVar"
            warnings.warn(f"{where}: {product.product} productName {product.product_name!r}: wrt writes {what}; "
                          f"written as {stem}{wanted}", stacklevel=3)
            name = stem
        name += wanted  # none, or a dot that is part of the name ("shot.0001", "shot.beauty"): appended
    if hidden:
        warnings.warn(f"{where}: {product.product} productName {product.product_name!r} {hides}; written as "
                      f"{name}, after the prim", stacklevel=3)
    stem, suffix = os.path.splitext(name)
    # Room for the suffix and a _k of unique(): a longer name failed the write after every render, other products
    # written, as "File name too long".
    room = MAX_NAME_BYTES - len(os.fsencode(suffix)) - NUMBER_BYTES
    if len(os.fsencode(stem)) > room:
        name = os.fsencode(stem)[:room].decode(errors="ignore") + suffix
        warnings.warn(f"{where}: {product.product} productName {product.product_name!r}: its file name is longer "
                      f"than the {MAX_NAME_BYTES} bytes a file system takes; written as {name}", stacklevel=3)
    unique = taken.unique(name)
    if unique != name:
        warnings.warn(f"{where}: {product.product} writes {name}, as an earlier product does; written as {unique}",
                      stacklevel=3)
    return unique


def _values(kind: str, image, camera, scene) -> np.ndarray:
    """``(H, W, ...)`` values of output ``kind`` from ``image`` (a :class:`wrt.Image` of ``camera`` and ``scene``)."""
    aovs, shape = image.aovs, image.rgb.shape[:2]
    if kind == BEAUTY:
        return image.rgb
    if kind == "Neye":
        # Normals go to camera space by the transpose of the camera's rotation (its inverse-transpose for normals);
        # scale and shear of the camera transform are normalised away.
        value = aovs["normal"] @ np.asarray(camera.to_world[:3, :3], np.float64)
        length = np.linalg.norm(value, axis=-1, keepdims=True)
        return np.divide(value, length, out=np.zeros_like(value), where=length > 0)
    linear = np.asarray(camera.to_world[:3, :3], np.float64)
    if kind == "cameraDepth" and np.allclose(linear.T @ linear, np.eye(3), rtol=0.0, atol=1e-9):
        return aovs["z"]  # a rigid camera: camera space is world units, and z is its depth already
    if kind in ("P", "Peye", "cameraDepth"):
        # The hit along the ray the renderer cast through the pixel centre (its AOV ray, whose depth the AOV is).
        origins, directions = camera_rays(scene, camera, shape[1], shape[0])
        hit = (aovs["prim"] >= 0).reshape(-1, 1)
        if kind == "cameraDepth":  # along the ray from its origin, as the z AOV, to keep its digits far out
            axis = -np.linalg.inv(linear)[2]  # camera-space depth per world unit of displacement
            eye = camera.to_world[:3, 3].astype(np.float32).astype(np.float64)  # the rays' eye (see Peye)
            along = (origins.astype(np.float64) - eye) @ axis
            rate = directions.astype(np.float64) @ axis  # unit directions
            with np.errstate(invalid="ignore"):  # inf * 0 on a miss, replaced
                depth = along + aovs["depth"].reshape(-1).astype(np.float64) * rate
            return np.where(hit[:, 0], depth, np.inf).reshape(shape)  # a miss: inf, as the z AOV
        depth = np.where(hit, aovs["depth"].reshape(-1, 1), 0.0)
        points = origins.astype(np.float64) + depth * directions
        if kind == "Peye":  # by the whole inverse transform, as Hydra's view matrix
            # From the eye the rays start at, float32 as the renderer's: far from the world origin the float64 eye
            # lies up to half a float32 step from it (0.03 at 1e6), an error of every Peye, which the depth kept.
            eye = camera.to_world[:3, 3].astype(np.float32).astype(np.float64)
            points = (points - eye) @ np.linalg.inv(camera.to_world)[:3, :3].T
        return np.where(hit, points, 0.0).reshape(*shape, 3)  # a miss has no position: 0, as Hydra clears Peye
    if kind in ("primId", "elementId"):
        prims, elements = scene.hit_prims(*scene.split_ids(aovs["prim"].reshape(-1)))
        return (prims if kind == "primId" else elements).reshape(shape)
    return aovs[kind]


def _paths(kind: str, ids: np.ndarray, scene) -> str:
    """JSON ``{id: path}`` of the ids in ``ids`` (-1: none): prims (``primId``) or instances."""
    name = scene.prim_paths().__getitem__ if kind == "primId" else scene.instances.path
    return json.dumps({str(i): name(i) for i in map(int, np.unique(ids)) if i >= 0})


def output_channels(image, camera, scene, outputs: list[_Output]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """``({channel name: (H, W) array}, {header attribute: JSON})`` of ``outputs`` from ``image`` (a
    :class:`wrt.Image` of ``camera`` and ``scene``); the attributes name the prims of the id layers of
    :data:`NAMED_IDS`."""
    channels, attributes = {}, {}
    for out in outputs:
        value = _values(out.kind, image, camera, scene)
        # Warned where some id changes in a float32 channel: every integer up to 2^24 is exact there, 2^24 itself
        # too (it warned from 2^24 on, saying that 2^24 was rounded).
        rounded = value.dtype.kind in "iu" and value.astype(np.float32).astype(np.int64) != value
        if np.any(rounded):
            # Ids counted once each: the count of pixels said '10000 ids' of one prim covering a 100x100 image.
            ids = np.unique(value[rounded])
            largest = ids[np.argmax(np.abs(ids.astype(np.float64)))]
            warnings.warn(f"{out.layer or out.kind}: ids past {EXACT_FLOAT_INTS} are rounded in the float32 channels "
                          f"of EXR: {ids.size} of them (the largest {largest}), in {np.count_nonzero(rounded)} "
                          "pixels", stacklevel=3)
        if out.kind in NAMED_IDS:
            attributes[f"{out.layer}/paths"] = _paths(out.kind, value, scene)
        names = channel_names(out)
        value = np.asarray(value, np.float32).reshape(*value.shape[:2], len(names) - out.alpha)
        if out.alpha:
            # Coverage, not the pixel centre's hit: the colour is the mean of every sample, so an edge pixel's
            # colour over its alpha is the surface's (premultiplied, as OpenEXR's RGBA is).
            value = np.concatenate([value, image.aovs["coverage"][..., None]], axis=-1)
        for k, name in enumerate(names):
            channels[name] = value[..., k]
    return channels, attributes


def exr_windows(product, camera) -> dict:
    """The EXR header's ``displayWindow`` (the whole image at ``product``'s resolution), ``dataWindow`` (the pixels
    its ``dataWindowNDC`` holds, as :meth:`wrt.render_settings.RenderSettings.crop` renders them), so that a
    compositor places a crop where it lies in the shot, and ``pixelAspectRatio``: that of ``camera``, the product's
    view (:func:`wrt.render.resolve_view`), whose pixels have it (the product's own, or under
    ``adjustPixelAspectRatio`` the one computed from the apertures)."""
    j0, j1, k0, k1 = product.window_pixels(*product.resolution)
    return {**image_exr_windows(product.placement(*product.resolution), j1 - j0, k1 - k0),
            "pixelAspectRatio": float(camera.pixel_aspect_ratio)}


def write_product(path: Path, channels: dict[str, np.ndarray], exposure: float = 0.0,
                  attributes: dict | None = None, data: bool = False, pixel_aspect_ratio: float = 1.0) -> Path:
    """Writes ``channels`` to ``path``: an 8-bit sRGB PNG of ``R, G, B`` (``A``), scaled by ``2**exposure``, or
    an EXR of every channel, with the header ``attributes``. The channels are premultiplied by ``A``, as OpenEXR's
    RGBA is; a PNG's colour is not (its alpha is unassociated), so it gets ``RGB / A`` where ``A > 0``. With
    ``data`` (:attr:`wrt.Image.data`: a normals or depth quick look, made from each pixel centre's ray, so not
    premultiplied) a PNG stores ``R, G, B`` as they are, as :meth:`wrt.Image.save` does. A PNG's ``pHYs`` chunk
    says its pixels' ``pixel_aspect_ratio`` (the EXR's is among ``attributes``)."""
    def write(target: Path) -> None:
        if path.suffix.lower() == ".exr":
            write_exr(target, channels, attributes)
            return
        rgb = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64)
        if data:  # a normal map's values, which a reader takes back: neither divided by alpha nor encoded
            rgb = data_to_8bit(rgb)
            if "A" in channels:
                rgb = np.dstack([rgb, data_to_8bit(channels["A"])])
        elif "A" in channels:
            alpha = np.clip(np.asarray(channels["A"], np.float64), 0.0, 1.0)[..., None]
            # Unpremultiplied in linear, before the sRGB curve: an edge pixel gets the colour of the surface it
            # partly covers, so that a viewer compositing C a + background (1 - a) does not darken the edge again.
            rgb = np.divide(rgb, alpha, out=rgb.copy(), where=alpha > 0.0)
            rgb = np.dstack([to_srgb8(rgb, exposure), np.round(alpha[..., 0] * 255).astype(np.uint8)])
        else:
            rgb = to_srgb8(rgb, exposure)
        write_srgb_png(target, rgb, pixel_aspect_ratio)

    write_atomically(path, write)
    return path


def render_views(scene, views: dict, *, spp: int, seed: int, batch: int | None, progress: bool,
                 **options) -> Iterator[tuple]:
    """Yields ``(key, wrt.Image)`` of each of ``views`` (``{key: (camera, width, height)}``) as soon as its batch is
    rendered, so that a caller keeps what was done when a later batch fails (out of memory, Ctrl-C): the views of
    one size rendered together by one :class:`wrt.Renderer` (``options``: its arguments), as many per launch as fill
    :data:`wrt.render.MAX_PATHS_PER_LAUNCH` pixels (at least one: no more memory than a render of one view). Each
    image is the one a render of its view alone gives (the random stream depends on the pixel within its view, and a
    default headlight follows each camera); a Renderer per view set up its lights and shading tables again, which
    for 40k parts took longer than the render."""
    by_size = {}
    for key, (camera, width, height) in views.items():
        by_size.setdefault((width, height), []).append((key, camera))
    for (width, height), group in by_size.items():
        per_launch = max(1, MAX_PATHS_PER_LAUNCH // (width * height))
        renderer = None
        for start in range(0, len(group), per_launch):
            keys, cameras = zip(*group[start:start + per_launch])
            if renderer is None:
                renderer = Renderer(scene, cameras=list(cameras), width=width, height=height, **options)
            else:
                renderer.set_cameras(list(cameras))
            batch_image = renderer.render(spp=spp, seed=seed, batch=batch, progress=progress)
            for k, key in enumerate(keys):
                yield key, batch_image.image(k)


def _unchosen(source) -> str:
    """What to add to 'no render settings' where the stage file ``source`` has RenderSettings prims that neither its
    ``renderSettingsPrimPath`` nor the caller chose: it read as if the stage had none."""
    if not source or not os.path.isfile(source):
        return ""
    from pxr import Usd

    from .render_settings import settings_prims

    found = settings_prims(Usd.Stage.Open(str(source)))
    if not found:
        return ""
    return (f"; RenderSettings prims in the stage: {', '.join(found)}, none chosen by its renderSettingsPrimPath: "
            "choose one with --render-settings PRIM (load_usd(..., render_settings=PRIM))")


def render_products(scene, directory, *, spp: int = 1, device=None, seed: int = 0, builder: str = "sah",
                    accel: str = "wrt", integrator: str = "whitted", max_depth: int | None = None,
                    ao_radius: float | None = None, batch: int | None = None, progress: bool = False,
                    exposure: float = 0.0) -> dict[str, Path]:
    """Renders every ``RenderProduct`` of ``scene``'s render settings and writes its RenderVars into ``directory``
    (see the module docstring for names, formats and the sources wrt has). Products of one view (camera,
    resolution, film, data window) share one render, and the views of one size render together
    (:func:`render_views`).

    Args:
        scene: a :class:`wrt.Scene` loaded from a stage with render settings.
        directory: the folder the files go to (made if missing).
        spp, device, seed, builder, accel, integrator, max_depth, ao_radius, batch, progress: as :func:`wrt.render`.
        exposure: PNG products only: ``2**exposure`` scales the image before sRGB.

    Returns:
        ``{RenderProduct prim path: file written}``, in the settings' order.

    Raises:
        ValueError: the scene has no render settings with a RenderProduct, or as :func:`wrt.render`.
    """
    directory = check_folder_path(directory, "render_products: directory")  # '' wrote into the current folder
    settings = scene.render_settings
    products = settings.products if settings is not None else ()
    if not products:
        what = f"{settings.path} has no RenderProduct" if settings else "no render settings, so no RenderProduct"
        raise ValueError(f"{scene.source or 'scene'}: {what} to write{'' if settings else _unchosen(scene.source)}")
    exposure = check_exposure(exposure)
    where = os.path.basename(settings.source)
    if exposure != 0.0 and integrator in DATA_INTEGRATORS:  # said once, before the renders; the EXRs' note is moot
        warnings.warn(f"{where}: " + DATA_EXPOSURE_WARNING.format(what="exposure", image=f"the {integrator} "
                                                                  "integrator's products"), stacklevel=2)
        exposure = 0.0
    # Every product is resolved (view, outputs, file name) before any is rendered: a bad one fails the call before
    # it has spent renders and written files.
    views, plan, taken = {}, [], TakenNames()
    for product in products:
        if product.product_type != "raster":
            warnings.warn(f"{where}: {product.product} is a {product.product_type} product; wrt writes raster "
                          "products only, it is skipped", stacklevel=2)
            continue
        outputs = product_outputs(product, where)
        if not outputs:
            warnings.warn(f"{where}: {product.product} has no RenderVar wrt can write; it is skipped", stacklevel=2)
            continue
        view = tuple(getattr(product, f) for f in ("camera", "resolution", "pixel_aspect_ratio", "conform_policy",
                                                   "data_window", "disable_depth_of_field"))
        if view not in views:
            views[view] = resolve_view(scene, settings=product)
            try:
                check_pixels(*views[view][1:])
            except ValueError as error:
                raise ValueError(f"{where}: {product.product}: {error}") from None
        png = len(outputs) == 1 and outputs[0].kind == BEAUTY
        plan.append((product, view, outputs, product_file_name(product, png, where, taken)))
        if not plan[-1][3].lower().endswith(".png"):  # else refused after the render, naming the temporary file
            try:
                check_exr_pixel_aspect(views[view][0].pixel_aspect_ratio, directory / plan[-1][3])
            except ValueError as error:
                raise ValueError(f"{where}: {product.product}: {error}") from None
        if (directory / plan[-1][3]).is_dir():  # refused only after the render, naming the temporary file
            raise IsADirectoryError(f"{where}: {product.product}: cannot write {directory / plan[-1][3]}: it is a "
                                    "directory")
    by_view = {}
    for entry in plan:
        by_view.setdefault(entry[1], []).append(entry)
    # Each view's products are written as soon as it is rendered: a failure in a later batch (out of memory, Ctrl-C)
    # keeps the files of the views done; all written after all rendered lost them.
    files, warned_exposure = {}, False
    for view, image in render_views(scene, {view: views[view] for view in by_view}, spp=spp, seed=seed, batch=batch,
                                    progress=progress, device=device, builder=builder, accel=accel,
                                    integrator=integrator, max_depth=max_depth, ao_radius=ao_radius):
        camera = views[view][0]
        for product, _, outputs, name in by_view[view]:
            channels, attributes = output_channels(image, camera, scene, outputs)
            if not name.lower().endswith(".png"):
                attributes.update(exr_windows(product, camera))
                if exposure != 0.0 and not warned_exposure:  # once, as for wrt render -o x.exr --exposure
                    warnings.warn(f"{where}: exposure applies to .png products only; {name} is written linear, "
                                  "unscaled", stacklevel=2)
                    warned_exposure = True
            files[product.product] = write_product(directory / name, channels, exposure, attributes, image.data,
                                                   camera.pixel_aspect_ratio)
    return {product.product: files[product.product] for product, _, _, _ in plan}  # in the settings' order
