"""``UsdGeom.Camera`` prims read into :class:`wrt.camera.Camera`: at their instance-proxy paths inside native
instances (hidden ones too), skipped inside PointInstancer prototypes."""

from __future__ import annotations

import numpy as np
from pxr import Usd, UsdGeom

from .camera import Camera
from .usd_contents import PROTOTYPE_PREDICATE, Context
from .usd_values import value_at
from .usd_xforms import affine_part


class CameraReading:
    """Camera reading of the stage reader (``stage``, ``time``, ``xforms``, ``scene``)."""

    def _read_cameras(self, prim: Usd.Prim, cameras: list, ctx: Context):
        """The ``cameras`` at paths relative to ``prim`` (a camera itself, ``.``, or the cameras of native instance
        ``prim``, relative to its prototype), read through :meth:`_read_through_instances`: in the world at their
        instance-proxy paths (``/Instance/Cam``), which USD places in the world."""

        def read(proxy: Usd.Prim):
            self.scene.cameras[str(proxy.GetPath())] = self._read_camera(proxy)

        self._read_through_instances(prim, cameras, ctx, "cameras", read, "cameras")

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
                if p.IsA(UsdGeom.PointInstancer):
                    it.PruneChildren()  # cameras in its prototypes are not read
                elif p.IsA(UsdGeom.Camera):
                    found.append(p.GetPath().MakeRelativePath(key))
            self.prototype_cameras[key] = found
        return self.prototype_cameras[key]

    def _read_camera(self, prim: Usd.Prim) -> Camera:
        camera = UsdGeom.Camera(prim)
        time = self.time

        def number(attr):
            return float(value_at(attr, time))

        near, far = value_at(camera.GetClippingRangeAttr(), time)
        projection = str(value_at(camera.GetProjectionAttr(), time))
        if projection != UsdGeom.Tokens.orthographic:
            if projection != UsdGeom.Tokens.perspective:  # as UsdGeom.Camera.GetCamera reads it
                self._skip("cameras with an unknown projection are perspective", prim, f"projection = {projection!r}")
            projection = "perspective"
        m = affine_part(np.array(self.xforms.GetLocalToWorldTransform(prim), dtype=np.float64),  # row vectors
                        lambda reason: self._skip(reason, prim))
        try:
            loaded = Camera(
                to_world=m.T,  # column vectors
                focal_length=number(camera.GetFocalLengthAttr()),
                horizontal_aperture=number(camera.GetHorizontalApertureAttr()),
                vertical_aperture=number(camera.GetVerticalApertureAttr()),
                horizontal_aperture_offset=number(camera.GetHorizontalApertureOffsetAttr()),
                vertical_aperture_offset=number(camera.GetVerticalApertureOffsetAttr()),
                clipping_range=(float(near), float(far)),
                clipping_planes=[tuple(plane) for plane in value_at(camera.GetClippingPlanesAttr(), time) or []],
                projection=projection,
                fit="expandAperture",  # USD's fallback aspectRatioConformPolicy
                f_stop=number(camera.GetFStopAttr()),
                focus_distance=number(camera.GetFocusDistanceAttr()),
                exposure_scale=_exposure_scale(camera, number),
            )
        except ValueError as e:  # unnamed above: the SceneError names the file and the prim, once
            raise self._error(str(e), prim) from None
        loaded.path = str(prim.GetPath())  # for messages at render time, e.g. a singular transform
        return loaded


def _exposure_scale(camera: UsdGeom.Camera, number) -> float:
    """USD's ``ComputeLinearExposureScale`` of ``camera``, its attributes read by ``number`` (at the loader's time).
    In float64 without exceptions: an fStop of 0 or a huge exposure gives inf, which the Camera then refuses."""
    with np.errstate(all="ignore"):
        stops, fstop = np.float64(number(camera.GetExposureAttr())), np.float64(number(camera.GetExposureFStopAttr()))
        return float(np.exp2(stops) * number(camera.GetExposureTimeAttr()) * number(camera.GetExposureIsoAttr())
                     / 100.0 * number(camera.GetExposureResponsivityAttr()) / (fstop * fstop))

