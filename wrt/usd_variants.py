"""Variant selections chosen when a stage is loaded (``load_usd(path, variants=...)``, ``--variant``).

Each selection is authored on the stage's session layer, so the file and every layer it brings in are left as they
are, and USD composes the stage with it before wrt reads anything. Selections are applied in the order given, so a
variant set that exists only inside another variant (nested variants) can be selected after the outer one.
"""

from __future__ import annotations

from .errors import SceneError, did_you_mean

MAX_LISTED = 12  # prims with variant sets named in an error about a prim that has none
# A file's own selection of a variant its set lacks (a typo, a variant renamed upstream) composes none of the set's
# variants, and USD reports no composition error: the prims the set held are simply missing.
UNKNOWN_SELECTION = "variant selections that name no variant of their set: USD composes none of the set's variants"


def parse_variant(text: str) -> tuple[str, str, str]:
    """``(prim path, variant set, variant)`` of ``PRIM:SET=VARIANT`` (``/World/Car:paint=red``).

    Raises:
        ValueError: ``text`` is not of that form.
    """
    prim, _, selection = text.partition(":")
    variant_set, equals, variant = selection.partition("=")
    if not (prim.startswith("/") and variant_set and equals and variant):
        raise ValueError(f"{text!r} is not PRIM:SET=VARIANT, e.g. /World/Car:paint=red")
    return prim, variant_set, variant


def variants_option(texts) -> dict[str, dict[str, str]] | None:
    """The ``variants`` argument of :func:`wrt.load_usd` from ``--variant`` values (``None`` for none); a later
    selection of the same prim and set replaces the earlier one."""
    variants: dict[str, dict[str, str]] = {}
    for text in texts or ():
        prim, variant_set, variant = parse_variant(text)
        variants.setdefault(prim, {})[variant_set] = variant
    return variants or None


def apply_variants(stage, source: str, variants) -> None:
    """Selects ``variants`` (prim path -> {variant set: variant}) on ``stage``'s session layer.

    Raises:
        SceneError: naming the file and prim: the prim does not exist (the prims that have variant sets are listed)
            or lies inside a native instance, or it has no such variant set or variant (the ones it has are listed).
        TypeError: ``variants`` is not a mapping of prim paths to mappings of names.
    """
    from pxr import Sdf, Usd

    if not hasattr(variants, "items"):
        raise TypeError(f"variants must be a dict of prim path -> {{variant set: variant}}, got {variants!r}")
    with Usd.EditContext(stage, stage.GetSessionLayer()):
        for path, selections in variants.items():
            if not (isinstance(path, str) and hasattr(selections, "items")):
                raise TypeError(f"variants must map a prim path string to a dict of {{variant set: variant}}, got "
                                f"{path!r}: {selections!r}")
            valid = Sdf.Path.IsValidPathString(path) and Sdf.Path(path).IsAbsolutePath()
            prim = stage.GetPrimAtPath(path) if valid else None
            if not prim:
                found = _prims_with_variants(stage)
                listed = [f"{p} ({', '.join(names)})" for p, names in found[:MAX_LISTED]]
                listed += ["..."] if len(found) > MAX_LISTED else []
                raise SceneError(f"no prim at {path} to select variants on{did_you_mean(path, [p for p, _ in found])};"
                                 f" prims with variant sets: {', '.join(listed) or 'none'}", path=source)
            if prim.IsInstanceProxy():  # USD refuses to author there (a Tf error): the prototype is shared
                raise SceneError("is inside a native instance, whose prims every instance shares; select the variant "
                                 "on the prim the instance brings in, or make the instance not instanceable",
                                 path=source, prim=path)
            for name, variant in selections.items():
                sets = prim.GetVariantSets()
                if name not in sets.GetNames():
                    raise SceneError(f"no variant set {name!r}{did_you_mean(name, sets.GetNames())}; its variant sets: "
                                     f"{', '.join(sets.GetNames()) or 'none'}", path=source, prim=path)
                choices = sets.GetVariantSet(name).GetVariantNames()
                if variant not in choices:
                    meant = did_you_mean(variant, choices)
                    raise SceneError(f"variant set {name!r} has no variant {variant!r}{meant}; its variants: "
                                     f"{', '.join(choices)}", path=source, prim=path)
                sets.GetVariantSet(name).SetVariantSelection(variant)


def unknown_selections(prim) -> list[str]:
    """``SET = 'SELECTION', its variants: ...`` for each variant set of ``prim`` whose composed selection names none
    of the set's variants (:data:`UNKNOWN_SELECTION`); empty for a prim without variant sets."""
    if not prim.HasVariantSets():
        return []
    index = prim.GetPrimIndex()
    found = []
    for name in prim.GetVariantSets().GetNames():
        selection = index.GetSelectionAppliedForVariantSet(name)  # an expression's value, not its text
        choices = prim.GetVariantSet(name).GetVariantNames()
        if selection and selection not in choices:
            found.append(f"{name} = {selection!r}, its variants: {', '.join(choices) or 'none'}")
    return found


def _prims_with_variants(stage) -> list[tuple[str, list[str]]]:
    """``(path, variant set names)`` of each prim of ``stage`` that has variant sets, for an error message."""
    return [(str(prim.GetPath()), names) for prim in stage.Traverse() if (names := prim.GetVariantSets().GetNames())]
