"""``UsdGeom.Camera`` prims read into :class:`wrt.camera.Camera`: at their instance-proxy paths inside native
instances (hidden ones too), skipped inside PointInstancer prototypes.

A camera whose values :class:`wrt.camera.Camera` refuses (a perspective camera's zero focal length, a negative
aperture, an inverted clipping range, a transform that is not finite or singular, ...) is skipped with a warning
naming it and why (:data:`UNUSABLE_CAMERA`): the stage may well be rendered from another camera. The reason is kept in
``Scene.skipped_cameras``, and a render asked for it by path, or whose render settings name it, raises it
(:func:`wrt.render.resolve_camera`, :func:`wrt.render.resolve_view`). A blocked value (``= None``) is the schema's
fallback, as ``UsdGeom.Camera.GetCamera`` reads it.
"""

from __future__ import annotations

import numpy as np
from pxr import Tf, Usd, UsdGeom, UsdShade

from .camera import Camera
from .errors import SceneError
from .usd_contents import PROTOTYPE_PREDICATE, Context
from .usd_stage import tf_message
from .usd_values import schema_typed_value, value_or_fallback
from .usd_xforms import affine_part, xform_cache

PROBED_TIMES = 32  # most sample times a stage's first camera, unusable at the load's, is read at again
UNUSABLE_CAMERA = "cameras wrt cannot use were skipped (rendering one by its path raises this reason)"
NO_MOTION_BLUR = ("cameras with a shutter interval on a stage with time samples render an instant: wrt has no motion "
                  "blur (shutter:open and shutter:close are not read)")


class CameraReading:
    """Camera reading of the stage reader (``stage``, ``time``, ``xforms``, ``scene``)."""

    def _read_cameras(self, prim: Usd.Prim, cameras: list, ctx: Context):
        """The ``cameras`` at paths relative to ``prim`` (a camera itself, ``.``, or the cameras of native instance
        ``prim``, relative to its prototype), read through :meth:`_read_through_instances`: in the world at their
        instance-proxy paths (``/Instance/Cam``), which USD places in the world."""

        def read(proxy: Usd.Prim):
            path = str(proxy.GetPath())
            try:
                self.scene.cameras[path] = self._read_camera(proxy)
            except SceneError:
                raise
            except (ValueError, Tf.ErrorException) as e:
                # A bad camera stopped the load of a stage rendered from another one: kept for when it is asked for.
                # (Values of the wrong type are ValueErrors naming the attribute; a TypeError is a bug, not skipped.)
                reason = str(e) if isinstance(e, ValueError) else f"camera cannot be read ({tf_message(e)})"
                self.scene.skipped_cameras[path] = reason
                # (what made it unusable: its transform, its values (other ValueErrors), or either (USD's errors))
                values, transform = not isinstance(e, _TransformError), type(e) is not ValueError
                if not (self.scene.cameras or hasattr(self.scene, "_first_camera_skipped")) and _might_vary(
                        proxy, values, transform) and self._usable_at_another_time(proxy, values, transform):
                    # The stage's first camera, bad at this time only: frames refuse to draw another (wrt.animation);
                    # one bad at every time draws none of them, as a still render does.
                    self.scene._first_camera_skipped = path
                self._skip(UNUSABLE_CAMERA, proxy, reason)

        self._read_through_instances(prim, cameras, ctx, "cameras", read, "cameras")

    def _usable_at_another_time(self, prim: Usd.Prim, values: bool = True, transform: bool = True) -> bool:
        """Camera ``prim``, unusable at the load's time, reads at another of the times its camera attributes
        (``values``) or the transforms that place it (``transform``), whichever made it unusable, have samples at (at
        most :data:`PROBED_TIMES` of them, evenly spread), without a word. Something of it that varies is not always
        what is wrong with it: a zero focal length beside an animated focusDistance (a rack focus) is bad at every
        time, yet every frame was refused, where the next camera draws them all, as it draws a still render; so it
        was under a rig animated by a spline, which cannot make a focal length 0."""
        times = _sample_times(prim, values, transform)
        if times is None:  # it varies by a spline (or otherwise without samples): taken for bad at this time only
            return True
        times = sorted(times - ({float(self.time.GetValue())} if not self.time.IsDefault() else set()))
        if len(times) > PROBED_TIMES:
            times = [times[int(k)] for k in np.linspace(0, len(times) - 1, PROBED_TIMES).round()]
        kept = self.time, self.xforms
        self._skip = lambda *args, **kwargs: None  # (the load's warnings are of its own time)
        try:
            for t in times:
                self.time = Usd.TimeCode(t)
                self.xforms = xform_cache(self.time, self.stage)
                try:
                    self._read_camera(prim)
                    return True
                except (ValueError, Tf.ErrorException):
                    continue
            return False
        finally:
            self.time, self.xforms = kept
            del self._skip

    def _prototype_cameras(self, prototype: Usd.Prim) -> list:
        """Paths relative to ``prototype`` of the cameras in it and in the instances nested in it (as a read
        prototype's ``cameras``), without reading its geometry; none for an instance without a prototype."""
        if not prototype:
            return []
        key = prototype.GetPath()
        if key not in self.prototype_cameras:
            found = []
            it = iter(Usd.PrimRange(prototype, Usd.TraverseInstanceProxies(PROTOTYPE_PREDICATE)))
            for p in it:
                if p.IsA(UsdGeom.PointInstancer) or p.IsA(UsdShade.Material):
                    it.PruneChildren()  # cameras in its prototypes are not read, nor under a Material (wrt.usd)
                elif p.IsA(UsdGeom.Camera):
                    found.append(p.GetPath().MakeRelativePath(key))
            self.prototype_cameras[key] = found
        return self.prototype_cameras[key]

    def _read_camera(self, prim: Usd.Prim) -> Camera:
        camera = UsdGeom.Camera(prim)
        time = self.time

        mistyped = []

        def value(attr):
            # A blocked value (= None) is the schema's fallback, as GetCamera reads it: a blocked projection was the
            # token 'None' (perspective with a warning), other blocked values skipped the camera. So is a value of
            # another type than the schema's (double focalLength = 35: a 50 mm lens to GetCamera, 35 to wrt).
            found, wrong = schema_typed_value(attr, time)
            if wrong is not None:
                mistyped.append(wrong)
            if found is None:  # (every attribute read here has a fallback)
                raise ValueError(f"camera {attr.GetName()} has no value (blocked)")
            return found

        def numbers(attr, found, count: int) -> tuple:
            """``found``, read from ``attr``, as ``count`` floats, else a ValueError naming the attribute (an
            attribute authored with another type than the schema's: a ``float clippingRange``)."""
            try:
                values = tuple(float(x) for x in (found if count > 1 else [found]))
            except (TypeError, ValueError):
                values = ()
            if len(values) != count:
                raise ValueError(f"camera {attr.GetName()} must be {count} number{'s' * (count > 1)}, got {found!r}")
            return values

        def number(attr):
            return numbers(attr, value(attr), 1)[0]

        near, far = numbers(camera.GetClippingRangeAttr(), value(camera.GetClippingRangeAttr()), 2)
        planes_attr = camera.GetClippingPlanesAttr()
        planes = [numbers(planes_attr, plane, 4) for plane in _elements(planes_attr, value(planes_attr))]
        projection = str(value(camera.GetProjectionAttr()))
        if projection != UsdGeom.Tokens.orthographic:
            if projection != UsdGeom.Tokens.perspective:  # as UsdGeom.Camera.GetCamera reads it
                self._skip("cameras with an unknown projection are perspective", prim, f"projection = {projection!r}")
            projection = "perspective"
        world = np.array(self.xforms.GetLocalToWorldTransform(prim), dtype=np.float64)  # row vectors
        if not np.all(np.isfinite(world)):  # (before affine_part, which took NaN for a projective column)
            raise _TransformError("camera transform is not finite")
        m = affine_part(world, lambda reason: self._skip(reason, prim))
        if not abs(np.linalg.det(m[:3, :3])) > 0.0:  # as Camera.to_struct refuses it, but skipped: the stage's first
            raise _TransformError("camera transform is singular (a zero scale), so it has no view")  # the default one
        loaded = Camera(  # ValueError naming the field it refuses, as "camera needs ...": the caller names the prim
            to_world=m.T,  # column vectors
            focal_length=number(camera.GetFocalLengthAttr()),
            horizontal_aperture=number(camera.GetHorizontalApertureAttr()),
            vertical_aperture=number(camera.GetVerticalApertureAttr()),
            horizontal_aperture_offset=number(camera.GetHorizontalApertureOffsetAttr()),
            vertical_aperture_offset=number(camera.GetVerticalApertureOffsetAttr()),
            clipping_range=(near, far),
            clipping_planes=planes,
            projection=projection,
            fit="expandAperture",  # USD's fallback aspectRatioConformPolicy
            f_stop=number(camera.GetFStopAttr()),
            focus_distance=number(camera.GetFocusDistanceAttr()),
            exposure_scale=_exposure_scale(camera, number),
        )
        loaded.path = str(prim.GetPath())  # for messages at render time, e.g. a singular transform
        if mistyped:
            self._skip("camera values authored with another type than the schema's were read as GetCamera reads them "
                       "(a weaker opinion of the schema's type, else the schema's fallback)", prim, ", ".join(mistyped))
        self._warn_of_shutter(camera, prim)
        return loaded

    def _warn_of_shutter(self, camera: UsdGeom.Camera, prim: Usd.Prim):
        """Names ``camera`` (:data:`NO_MOTION_BLUR`) when its shutter interval is not empty and the stage's layers
        hold time samples at two times or more, where something may move; a static stage says nothing."""
        try:
            interval = (float(value_or_fallback(camera.GetShutterCloseAttr(), self.time))
                        - float(value_or_fallback(camera.GetShutterOpenAttr(), self.time)))
        except (TypeError, ValueError):  # not read anyway
            return
        if interval == 0.0 or not np.isfinite(interval):
            return
        if getattr(self, "_stage_has_motion", None) is None:  # once per load, and only for such a camera
            # A kept stage's layers hold the samples they held when it was opened (an edit opens it afresh): asked
            # once for all its frames, not at each (every layer's samples listed: 10 ms for 5,000 on 50 prims).
            memo = self.placement_memo
            kept = None if memo is None else memo.stage_has_motion
            self._stage_has_motion = _layers_hold_motion(self.stage) if kept is None else kept
            if memo is not None:
                memo.stage_has_motion = self._stage_has_motion
        if self._stage_has_motion:
            self._skip(NO_MOTION_BLUR, prim, f"shutter {interval:g} frames")


def _layers_hold_motion(stage: Usd.Stage) -> bool:
    """The layers ``stage`` uses hold time samples at two times or more, or it has value clips: USD opens a clip
    with a ``manifestAssetPath`` only when it reads a value of its, so its samples are in no used layer before (where
    the camera was read before the prims the clips move, they were not seen)."""
    from .usd_clips import clip_roots

    times = set()
    for layer in stage.GetUsedLayers():
        times.update(layer.ListAllTimeSamples())
        if len(times) > 1:
            return True
    return bool(clip_roots(stage))


def _elements(attr: Usd.Attribute, found) -> list:
    """The elements of array ``found`` read from ``attr`` (none for no value), else a ValueError naming it."""
    if found is None:
        return []
    try:
        return list(found)
    except TypeError:
        raise ValueError(f"camera {attr.GetName()} must be an array, got {found!r}") from None


def _exposure_scale(camera: UsdGeom.Camera, number) -> float:
    """USD's ``ComputeLinearExposureScale`` of ``camera``, its attributes read by ``number`` (at the loader's time).
    In float64 without exceptions: an fStop of 0 or a huge exposure gives inf, which the Camera then refuses."""
    with np.errstate(all="ignore"):
        stops, fstop = np.float64(number(camera.GetExposureAttr())), np.float64(number(camera.GetExposureFStopAttr()))
        return float(np.exp2(stops) * number(camera.GetExposureTimeAttr()) * number(camera.GetExposureIsoAttr())
                     / 100.0 * number(camera.GetExposureResponsivityAttr()) / (fstop * fstop))



class _TransformError(ValueError):
    """A camera's transform, not its values, is what wrt cannot use."""


def _might_vary(prim: Usd.Prim, values: bool = True, transform: bool = True) -> bool:
    """A camera attribute of ``prim`` (``values``) or a transform that places it (``transform``: its own or an
    ancestor's) has time samples. Asked of what made the camera unusable only: a zero focal length on a moving camera
    (or under a moving parent) is bad at every time, and was taken for animated, so every frame was refused where the
    next camera draws them all, as it draws a still render."""
    return any(True for _ in _varying(prim, values, transform))


def _sample_times(prim: Usd.Prim, values: bool = True, transform: bool = True) -> set[float] | None:
    """The times the attributes of camera ``prim`` but its transform ops (``values``) and the transform ops of it and
    its ancestors (``transform``) have samples at; None where one of them varies without samples (a spline: its
    values between knots are not its knots')."""
    times = set()
    for attr in _varying(prim, values, transform):
        found = attr.GetTimeSamples()
        if not found:
            return None
        times.update(found)
    return times


def _varying(prim: Usd.Prim, values: bool = True, transform: bool = True):
    """The attributes that might vary of camera ``prim`` but its transform ops (``values``), and its and its
    ancestors' transform ops (``transform``). Ops are the ``xformOp:`` attributes, those ``xformOpOrder`` leaves out
    too (they add times to read at, nothing else), rather than ``UsdGeom.Xformable``'s: it raises for an op of no
    known type (``xformOp:foo``), which wrt reads as the identity with a warning, and such an op up the chain of a
    camera unusable at one frame failed that frame's load (cannot read this prim)."""
    yield from (a for a in prim.GetAttributes() if values and not a.GetName().startswith("xformOp:")
                and a.ValueMightBeTimeVarying())
    while transform and prim and not prim.IsPseudoRoot():
        yield from (a for a in prim.GetAttributes() if a.GetName().startswith("xformOp:")
                    and a.ValueMightBeTimeVarying())
        prim = prim.GetParent()


def what_is_at(source: str, path: str, variants=None) -> str | None:
    """Words for what the stage at ``source`` (with ``variants`` selected, as it was loaded) holds at ``path``, where
    the scene has no camera: ``"'/Box' is a Cube, not a camera"``; None where there is no prim there or the stage
    cannot be opened again. Asked only when a render names a camera the scene lacks (an error), so the stage is
    opened again, its warnings unsaid: the load said them."""
    import warnings

    from pxr import Sdf

    from .usd_stage import open_stage, trap_usd_diagnostics
    from .usd_variants import apply_variants

    if not (Sdf.Path.IsValidPathString(path) and Sdf.Path(path).IsAbsolutePath()):
        return None
    with warnings.catch_warnings(), trap_usd_diagnostics() as trap:
        warnings.simplefilter("ignore")
        try:
            stage = open_stage(source)
            if variants:
                apply_variants(stage, source, variants)
            prim = stage.GetPrimAtPath(path)
            why = why_not_read(stage, path)
        except (SceneError, Tf.ErrorException, OSError):
            prim = why = None
        finally:
            if trap is not None:
                trap.EraseMatching(lambda d: True)
    if why is not None:
        return f"the Camera at {path!r} is not among the scene's cameras: {why}"
    if not prim or not prim.IsDefined():
        return None
    if prim.IsA(UsdGeom.Camera):
        return f"the Camera at {path!r} is not among the scene's cameras (it was taken out of scene.cameras)"
    kind = prim.GetTypeName()
    return f"{path!r} is {'a prim of no type' if not kind else f'a {kind}'}, not a camera"


def why_not_read(stage: Usd.Stage, path: str) -> str | None:
    """Why the loader reads no camera at ``path`` where ``stage`` has a Camera there, or one under an inactive
    ancestor, in words (``"it is inactive"``); None where nothing of the kind is there. A render that names it, by
    path or through render settings, says this, where it said the camera was not among those wrt reads."""
    from pxr import Sdf

    prim = stage.GetPrimAtPath(path)
    if not prim:  # the children of an inactive prim are not composed
        for prefix in Sdf.Path(path).GetParentPath().GetPrefixes():
            above = stage.GetPrimAtPath(prefix)
            if above and not above.IsActive():
                return f"it is under {prefix}, which is inactive"
        return None
    if not prim.IsA(UsdGeom.Camera):
        return None
    if not prim.IsActive():
        return "it is inactive"
    if not prim.HasDefiningSpecifier():
        return "it is only an 'over' (defined nowhere)"
    if prim.IsAbstract():
        return "it is abstract (a class, or under one)"
    if not prim.IsLoaded():
        return "it is in a payload that is not loaded"
    above = prim.GetParent()
    while above and not above.IsPseudoRoot():
        if above.IsA(UsdGeom.PointInstancer):
            return f"it is inside PointInstancer {above.GetPath()} (wrt reads no camera in its prototypes)"
        if above.IsA(UsdShade.Material):
            return f"it is under Material {above.GetPath()} (wrt reads no camera there)"
        above = above.GetParent()
    return None
