"""``model:drawMode`` (``UsdGeomModelAPI``): where usdview and other UsdImaging viewers draw a model as a stand-in
(``cards``, ``bounds`` or ``origin``) in place of its geometry, wrt draws the full geometry; this finds those models so
that the loader can say so."""

from __future__ import annotations

from pxr import Kind, Usd, UsdGeom

STAND_INS = ("cards", "bounds", "origin")  # draw modes that replace a model's geometry in UsdImaging


def stand_in_draw_mode(prim: Usd.Prim) -> str | None:
    """The draw mode UsdImaging replaces model ``prim``'s subtree with (one of :data:`STAND_INS`), or None where it
    draws the subtree: the mode resolved through ancestors (``ComputeModelDrawMode``) is applied to a model whose
    ``model:applyDrawMode`` is true, or, unauthored, whose kind is a component (UsdGeomModelAPI's documentation)."""
    if not prim.IsModel():  # draw modes are for models only (and this check is cheap for every other prim)
        return None
    api = UsdGeom.ModelAPI(prim)
    apply = api.GetModelApplyDrawModeAttr()
    if apply and apply.HasAuthoredValue():
        applied = bool(apply.Get())
    else:
        kind = Usd.ModelAPI(prim).GetKind()
        applied = bool(kind) and Kind.Registry.IsA(kind, Kind.Tokens.component)
    if not applied:
        return None
    mode = str(api.ComputeModelDrawMode())
    return mode if mode in STAND_INS else None
