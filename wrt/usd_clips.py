"""The value clips (``UsdClipsAPI``) of a stage kept for frames (:class:`wrt.usd_frames.StageFrames`): the files a
fresh open would read them from, and the prims whose values they give.

Clip layers are not in the stage's composition: USD opens them lazily, at the first read of a time they cover, keeps
a missing one as an empty dummy for the stage's life, and derives a template's clip list (``templateAssetPath``,
``templateStartTime``, ...) from the files that exist when the stage is opened. So a kept stage did not see a clip a
simulation wrote after it was opened (a fresh open does), nor a clip rewritten after its first read (the stage's
used layers, stamped when it was opened, hold no clip layer not yet read). :func:`clip_stamps` gives the stamps that
tell: every clip file named (a missing one too) and the folder a template's files appear in.

An attribute whose values come from clips alone has no spec in the stage's layers: ``UsdPrim.GetAuthoredAttributes``
does not list it (a mesh's ``points``), though a read finds its values (a schema's attribute: one that is neither in
the schema nor declared in the stage does not exist, and no read finds a value for it). So where clips may reach a
prim (:func:`under_clips`: at or below a prim with clips, or in a native prototype or an instance proxy while the
stage has clips) every attribute it has is asked whether it might vary (:func:`asked_attributes`),
``UsdAttribute.ValueMightBeTimeVarying`` counting the clips (several clips, or one retimed, say True; clips that give
no value for it, or a default that overrides them, False), and an instance proxy's are asked of its prim in the
prototype (:func:`asked_prim`): USD says an instance proxy's clip-driven attribute, or transform, cannot vary
(usd-core 0.26) while its prototype's says it might, and both read the same values. Clips above a native instance
(on the instance prim or its ancestors) do not reach its prototype: its prims read no value of theirs, and USD's
answers for them say so. Meshes (:mod:`wrt.usd_mesh_memo`), visibility and transforms
(:mod:`wrt.usd_placement_memo`) and shading (:func:`wrt.usd_material_memo.network_might_vary`) are asked so.
"""

from __future__ import annotations

import os

from pxr import Ar, Sdf, Usd

TEMPLATE_KEY = "templateAssetPath"  # a clip set's template: its files are those of its folder that exist at open


def clip_roots(stage: Usd.Stage) -> list:
    """The paths of the prims of ``stage`` (native prototypes too) that author value clips."""
    roots = []
    for top in (stage.GetPseudoRoot(), *stage.GetPrototypes()):
        roots += [p.GetPath() for p in Usd.PrimRange(top, Usd.PrimAllPrimsPredicate) if p.HasAuthoredMetadata("clips")]
    return roots


def under_clips(prim: Usd.Prim, roots: list) -> bool:
    """Values of ``prim`` may come from clips: it is at or below one of ``roots`` (:func:`clip_roots`), or in a native
    prototype or an instance proxy (whose prototype's clips are at prototype paths) while there are clips at all."""
    if not roots:
        return False
    path = prim.GetPath()
    return prim.IsInPrototype() or prim.IsInstanceProxy() or any(path.HasPrefix(root) for root in roots)


def asked_prim(prim: Usd.Prim) -> Usd.Prim:
    """The prim whose ``ValueMightBeTimeVarying`` and ``TransformMightBeTimeVarying`` tell whether ``prim``'s values
    might vary: an instance proxy's prim in its prototype (the proxy's own answer misses its prototype's clips), else
    ``prim``."""
    while prim.IsInstanceProxy():
        prim = prim.GetPrimInPrototype()
    return prim


def asked_attributes(prim: Usd.Prim, roots: list) -> list:
    """The attributes of ``prim`` whose ``ValueMightBeTimeVarying`` tell whether some value of it might vary: where
    clips may reach it (:func:`under_clips` of ``roots``), every attribute of :func:`asked_prim` (its schema's
    unauthored ones too, to which clips give values); elsewhere its authored ones (an unauthored one reads its
    fallback at every time)."""
    if under_clips(prim, roots):
        return asked_prim(prim).GetAttributes()
    return prim.GetAuthoredAttributes()


def clip_stamps(stage: Usd.Stage, roots: list, file_stamp) -> dict | None:
    """``{file: file_stamp(file)}`` of every file the clips at ``roots`` name, missing ones (stamped None) too, and of
    the folder of each template; None when one is no local file (its changes could not be seen)."""
    stamps = {}
    for root in roots:
        prim = stage.GetPrimAtPath(root)
        for spec in prim.GetPrimStack():
            for clip_set in dict(spec.GetInfo("clips") if spec.HasInfo("clips") else {}).values():
                assets = [*clip_set.get("assetPaths", ()), clip_set.get("manifestAssetPath")]
                files = [_local_file(spec.layer, asset.path) for asset in assets if asset]
                if clip_set.get(TEMPLATE_KEY):
                    template = _local_file(spec.layer, clip_set[TEMPLATE_KEY], resolve=False)
                    files.append(template and os.path.dirname(template))
                if None in files:
                    return None
                stamps.update((file, file_stamp(file)) for file in files)
        stamps.update((file, file_stamp(file)) for file in _found_files(prim))
    return stamps


def _found_files(prim: Usd.Prim) -> list:
    """The clip files USD found for the clip sets of ``prim`` (a template's: those that existed when it opened)."""
    clips = Usd.ClipsAPI(prim)
    return [Ar.SplitPackageRelativePathOuter(asset.resolvedPath)[0] for name in clips.GetClips()
            for asset in clips.ComputeClipAssetPaths(name) if asset.resolvedPath]


def _local_file(layer: Sdf.Layer, asset: str, resolve: bool = True) -> str | None:
    """The local file ``asset`` (anchored to ``layer``) is or would be, the package of one inside a ``.usdz``; None
    where that is no absolute file path (a search path that finds nothing, a URI)."""
    anchored = layer.ComputeAbsolutePath(asset) if asset else ""
    resolved = str(Ar.GetResolver().Resolve(anchored)) if resolve and anchored else ""
    file = Ar.SplitPackageRelativePathOuter(resolved or anchored)[0]
    return file if file and os.path.isabs(file) else None
