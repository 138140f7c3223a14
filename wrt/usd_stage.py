"""Opening a USD stage for :func:`wrt.usd.load_usd`, and the stage-wide checks made before any prim is read:
composition errors, layers in other units or up axes, a time outside the stage's authored range."""

from __future__ import annotations

import contextlib
import math
import os
import re
import warnings
from pathlib import Path

from pxr import Sdf, Tf, Usd, UsdGeom, UsdSkel

from .errors import SceneError, TimeRangeWarning, did_you_mean, user_stacklevel
from .scene import MIN_METERS_PER_UNIT

# The composition errors a warning names in full; USD's own printed lines report the others.
MAX_NAMED_COMPOSITION_ERRORS = 8


def trap_usd_diagnostics():
    """A context that holds back the diagnostics USD posts inside it (``Tf.DiagnosticTrap``), so that
    :func:`warn_composition_errors` can drop USD's own report of what it reports; those not dropped are posted as
    usual when the context ends. Nothing is held where this usd-core lacks the trap (the reports then come twice)."""
    trap = getattr(Tf, "DiagnosticTrap", None)
    return trap() if trap is not None else contextlib.nullcontext()


def held_diagnostics(trap) -> list:
    """``(kind, function, file, line, text)`` of each diagnostic ``trap`` (a :func:`trap_usd_diagnostics`) holds, in
    the order USD posted them: what it reports as the trap ends. ``kind`` is ``"Warning"``, ``"StatusObject"`` or
    ``"Error"``. Empty where this usd-core has no trap."""
    held = []
    if trap is not None:
        trap.ForEach(lambda d: held.append((type(d).__name__, d.sourceFunction, d.sourceFileName, d.sourceLineNumber,
                                            d.commentary)))
    return held


def reposted(held: list) -> bool:
    """:func:`post_again` posts all of ``held`` again: it holds warnings and statuses alone (no error), and this
    usd-core has the (private) functions that post them from another code location."""
    if not held:
        return True
    return hasattr(Tf, "_Warn") and hasattr(Tf, "_Status") and all(kind in ("Warning", "StatusObject")
                                                                   for kind, *_ in held)


def post_again(held: list) -> None:
    """Posts the warnings and statuses of ``held`` (:func:`held_diagnostics`) to USD's diagnostics again, from where
    USD posted them, so that they print as they did (the function named by its own name alone, as USD prints its
    own); an error is not posted again (a stage whose opening posted one is not kept: :func:`reposted`)."""
    for kind, function, file, line, text in held:
        function = bare_function_name(function)
        if kind == "Warning":
            Tf._Warn(text, "", function, file, line)  # Tf.Warn, from a code location of the caller's choosing
        elif kind == "StatusObject":
            Tf._Status(text, "", function, file, line)


def bare_function_name(qualified: str) -> str:
    """The name USD prints for a diagnostic's function (C++ ``__func__``: ``_GetLayerForClip``) from the one a held
    diagnostic gives (``pxrInternal_v0_26_11__pxrReserved__::Usd_Clip::_GetLayerForClip``): the part after the last
    ``::`` outside template arguments, its own template arguments dropped (a function posted from Python,
    ``__main__.<module>``, is named as it was). Only USD's namespace was dropped before:
    a warning from a method printed as ``in Usd_Clip::_GetLayerForClip``, not as a fresh load prints it."""
    depth, start = 0, 0
    for k, c in enumerate(qualified):
        depth += (c == "<") - (c == ">")
        if depth == 0 and qualified.startswith("::", k):
            start = k + 2
    name = qualified[start:]
    template = re.fullmatch(r"(.*?\w)<.*>", name)  # f<int>; not Python's __main__.<module>, nor an operator
    return template.group(1) if template and not name.startswith("operator") else name


def warn_composition_errors(stage: Usd.Stage, source: str, trap=None) -> None:
    """Warns about the stage's composition errors (a reference, payload or subLayer whose file is missing, a
    reference to a prim path that is not there): USD only prints them from C++ to stderr, where Python cannot catch
    them, and composes the stage without what they would bring in. A warning, not an error: partially composed
    stages are common and the rest still renders. Each error is named by the stage prim it is found at, as USD names
    it. ``trap``: the :func:`trap_usd_diagnostics` the stage was opened in, whose held copies of USD's printed
    report of these errors are dropped (the same error was printed twice)."""
    # Sorted: USD's order varies. A parse error of the file an arc brings in ends in a newline and a full stop. Once
    # each: USD lists a missing subLayer again for every arc that brings its layer stack in anew (a prim referencing
    # a prim of the same file), and the warning counted and named it twice.
    errors = sorted({(str(e.rootSite.path), str(e).strip().rstrip(".").rstrip()) for e in stage.GetCompositionErrors()})
    if not errors:
        return
    named = errors[:MAX_NAMED_COMPOSITION_ERRORS]
    # On one line: the texts keep their newlines only to match USD's printed report of them below. An error found at
    # no site (a variant expression's undefined variable: its text names the prim) has no prim to put before it.
    shown = "; ".join(f"{prim}: {' '.join(text.split())}" if prim else ' '.join(text.split()) for prim, text in named)
    if len(errors) > len(named):
        shown += f"; and {len(errors) - len(named)} more, as USD prints them"
    warnings.warn(
        f"{source}: {len(errors)} composition error(s); what they would bring in is missing from the scene: {shown}",
        stacklevel=user_stacklevel(),
    )
    if trap is not None:
        # Only the errors the warning names: USD's own lines for the rest still print, so none goes unread.
        # How UsdStage::_ReportErrors words them: "In </World/Chair>: Could not open asset ..."; one at the root (a
        # missing subLayer) without the "In </>: ", so its line printed beside the warning.
        reported = {f"In <{prim}>: {text}" for prim, text in named} | {text for prim, text in named if prim == "/"}
        trap.EraseMatching(lambda d: d.sourceFunction.endswith("UsdStage::_ReportErrors")
                           and any(d.commentary.startswith(r) for r in reported))


def warn_other_layer_units(stage: Usd.Stage, source: str) -> None:
    """Warns about layers the stage composes (references, payloads, subLayers) that author a ``metersPerUnit`` or
    ``upAxis`` other than the stage's. USD does not convert them and neither does wrt (their geometry is drawn as
    authored), so a robot authored in metres referenced into a centimetre stage was drawn 100 times too small, and a
    Z-up one in a Y-up stage on its side, without a word; a reference that scales or turns it itself is right.

    A referenced or payload layer that authors no ``metersPerUnit`` is in USD's fallback, centimetres (what
    ``GetStageMetersPerUnit`` gives it opened alone): in a stage of other units it is named too (it was silent: a
    centimetre asset in a metre stage drawn 100 times too big). So is one that authors no ``upAxis`` (USD's fallback,
    ``GetFallbackUpAxis``, Y) in a Z-up stage: it was drawn on its side without a word. A sublayer that authors none
    shares its layer stack's units and axis (the root's, or the referenced layer's that lists it), and a value clip
    the stage's, so neither is named. Nor is a layer whose layer stack holds nothing sized or placed in space
    (:func:`_holds_sized`: a material library, a layer of material bindings and colours): its units and axis change
    nothing drawn, and it was named; a layer of normals alone is named for its axis only."""

    def shown(value) -> str:
        return f"{value:g}" if isinstance(value, float) else str(value)

    def differ(key, value, stage_value) -> bool:
        if key == "metersPerUnit":
            return not UsdGeom.LinearUnitsAre(float(value), float(stage_value))
        return value != stage_value

    own = (stage.GetRootLayer(), stage.GetSessionLayer())
    used = stage.GetUsedLayers()
    # Value clips and their manifests hold values of the stage's prims, in its units: none is an asset of its own.
    shares_units = _sublayer_identifiers(used) | ({layer.identifier for layer in used}
                                                 - {layer.identifier for layer in stage.GetUsedLayers(False)})
    stage_values = {"metersPerUnit": UsdGeom.GetStageMetersPerUnit(stage), "upAxis": UsdGeom.GetStageUpAxis(stage)}
    # What a layer that authors none is in, opened alone (GetStageMetersPerUnit, GetStageUpAxis of it).
    fallbacks = {"metersPerUnit": UsdGeom.LinearUnits.centimeters, "upAxis": UsdGeom.GetFallbackUpAxis()}
    sized = {}  # (layer identifier, key) -> whether its layer stack holds anything sized (_holds_sized, asked once)
    for key, value in stage_values.items():
        others = []
        for layer in used:
            if layer in own:
                continue
            if (layer.identifier, key) not in sized:  # normals turn with the axis, have no length
                sized[layer.identifier, key] = _holds_sized(layer, directions=key == "upAxis")
            if not sized[layer.identifier, key]:
                continue
            name = os.path.basename(layer.identifier)
            if layer.pseudoRoot.HasInfo(key):
                authored = layer.pseudoRoot.GetInfo(key)
                if differ(key, authored, value):
                    others.append(f"{name}: {shown(authored)}")
            elif layer.identifier not in shares_units and differ(key, fallbacks[key], value):
                others.append(f"{name}: none authored, so USD's fallback {shown(fallbacks[key])}")
        others.sort()
        if others:
            warnings.warn(
                f"{os.path.basename(source)}: {key} = {shown(value)}, but {len(others)} layer(s) it composes author "
                f"another ({', '.join(others[:3])}{', ...' if len(others) > 3 else ''}); USD does not convert them and "
                "neither does wrt: they are drawn as authored",
                stacklevel=user_stacklevel(),
            )


# Attributes that hold no length nor direction in space, on any prim: a layer that authors only these (with
# relationships: material bindings, light links) and shading prims changes nothing drawn by its units or axis.
_UNSIZED_ATTRIBUTES = ("visibility", "purpose", "doubleSided", "orientation")


def _holds_sized(layer: Sdf.Layer, directions: bool = False) -> bool:
    """``layer`` or a layer of its layer stack (its subLayers, whose units and axis are its own) holds a prim spec
    whose values are in its units and axis (:func:`_sized_spec`; ``directions``: or only turn with its axis), in
    variants too."""
    seen, layers = set(), [layer]
    while layers:
        current = layers.pop()
        if current is None or current.identifier in seen:
            continue
        seen.add(current.identifier)
        specs = list(current.pseudoRoot.nameChildren)
        while specs:
            spec = specs.pop()
            if _sized_spec(spec, directions):
                return True
            specs.extend(spec.nameChildren)
            specs.extend(variant.primSpec for variant_set in spec.variantSets for variant in variant_set.variants)
        layers.extend(Sdf.Layer.FindRelativeToLayer(current, path) for path in current.subLayerPaths)
    return False


def _sized_spec(spec: Sdf.PrimSpec, directions: bool = False) -> bool:
    """A prim spec that defines something placed in space with sizes of its own (a gprim, light, camera, point
    instancer, skeleton: types derived from UsdGeom.Xformable, other than a plain Xform), a skeleton animation or a
    blend shape (its ``offsets`` are lengths in the layer's units, though UsdSkel.BlendShape is no Xformable), or
    that authors an attribute of :func:`_sized_attribute` on an Xform or a prim of no type (an ``over``: an xformOp,
    points, a light's radius). Shading prims (Material, Shader, NodeGraph), Scopes and other types not placed in
    space hold no length. ``directions``: a direction without length (normals) counts too, as for ``upAxis``."""
    kind = Usd.SchemaRegistry.GetTypeFromName(spec.typeName) if spec.typeName else Tf.Type.Unknown
    if kind.IsA(Tf.Type.Find(UsdSkel.Animation)) or kind.IsA(Tf.Type.Find(UsdSkel.BlendShape)):
        return True
    if kind != Tf.Type.Unknown and kind != Tf.Type.Find(UsdGeom.Xform):
        return kind.IsA(Tf.Type.Find(UsdGeom.Xformable))
    return any(_sized_attribute(name, attribute.typeName, directions) for name, attribute in spec.attributes.items())


def _sized_attribute(name: str, type_name: Sdf.ValueTypeName, directions: bool) -> bool:
    """An attribute (of an Xform or an ``over``) whose value is in its layer's units or axis: any but
    :data:`_UNSIZED_ATTRIBUTES`, primvars and normals, and of primvars ``widths`` and those of a point or vector
    type (a length and a direction); with ``directions`` also normals (``normals``, ``primvars:normals`` and any
    attribute of a normal type), which turn with the layer's axis but have no length (a layer of normals alone is
    named for its upAxis, not its units)."""
    if name in _UNSIZED_ATTRIBUTES:
        return False
    role = type_name.role
    if role == "Normal" or name in ("normals", "primvars:normals") or name.startswith("primvars:normals:"):
        return directions  # directions: they turn with the axis but have no length
    if not name.startswith("primvars:") or name.startswith("primvars:widths"):
        return True
    return role in ("Point", "Vector")


def _sublayer_identifiers(layers) -> set[str]:
    """The identifiers of the layers that one of ``layers`` lists in its ``subLayers`` (and which are open)."""
    found = set()
    for layer in layers:
        for path in layer.subLayerPaths:
            child = Sdf.Layer.FindRelativeToLayer(layer, path)
            if child is not None:
                found.add(child.identifier)
    return found


def check_time_in_range(stage: Usd.Stage, source: str, time: float) -> None:
    """Warns about a time outside the stage's authored ``[startTimeCode, endTimeCode]``. USD evaluates any time
    (values hold at the nearest sample), and stages do animate outside their advertised range (teapot_scene_1000
    says [1, 1] and moves its camera over 0-479), so this is a warning, not an error. Reads only layer metadata,
    never time samples, which can hang usd-core on stages with ``timeCodesPerSecond = 0``."""
    if not stage.HasAuthoredTimeCodeRange():
        return
    start, end = stage.GetStartTimeCode(), stage.GetEndTimeCode()
    if not start <= time <= end:
        warnings.warn(f"{os.path.basename(source)}: time {time:g} is {outside_range(start, end)}", TimeRangeWarning,
                      stacklevel=user_stacklevel())


def outside_range(start: float, end: float) -> str:
    """The words of a :class:`TimeRangeWarning`, after the time or frames it is about. A reversed range (start after
    end) holds no time: its words say so, where they said that USD holds the nearest samples' values, which it does
    not at a time between two samples."""
    if start > end:
        return (f"outside the stage's time range [{start:g}, {end:g}], which is reversed (startTimeCode after "
                "endTimeCode) and holds no time; USD evaluates the stage there as at any other time")
    return f"outside the stage's time range [{start:g}, {end:g}]; USD holds the values of the nearest time samples"


def stage_time_range(path) -> tuple[float, float] | None:
    """The authored ``(startTimeCode, endTimeCode)`` of the stage at ``path``, as ``Usd.Stage`` reads them (the
    deprecated ``startFrame`` and ``endFrame`` where the time codes are missing), or None when the stage has no
    authored range or the file cannot be read. Asked of a stage whose population mask holds no prim: its root layer
    stack is opened, nothing is composed. Reading the root layer's time codes alone missed a range authored as
    frames."""
    try:
        layer = Sdf.Layer.FindOrOpen(os.fspath(path))
    except Tf.ErrorException:
        return None
    if layer is None:
        return None
    with trap_usd_diagnostics() as trap:
        with Usd.StageCacheContext(Usd.BlockStageCaches):  # not put into a caller's cache (open_stage)
            stage = Usd.Stage.OpenMasked(layer, Usd.StagePopulationMask())
        if trap is not None:
            trap.EraseMatching(lambda d: True)  # a missing sublayer: the load reports it, once
    if not stage.HasAuthoredTimeCodeRange():
        return None
    return float(stage.GetStartTimeCode()), float(stage.GetEndTimeCode())


def stage_meters_per_unit(stage: Usd.Stage, source: str) -> float:
    """The stage's ``metersPerUnit``; a value that is not a finite number above ``MIN_METERS_PER_UNIT`` falls back
    to USD's own default, centimetres, with a warning."""
    value = float(UsdGeom.GetStageMetersPerUnit(stage))
    if math.isfinite(value) and value > MIN_METERS_PER_UNIT:
        return value
    fallback = float(UsdGeom.LinearUnits.centimeters)
    warnings.warn(f"{os.path.basename(source)}: metersPerUnit = {value:g} is not a finite number above "
                  f"{MIN_METERS_PER_UNIT:g}; using {fallback:g} (centimetres, USD's default)",
                  stacklevel=user_stacklevel())
    return fallback


def stage_up_axis(stage: Usd.Stage, source: str) -> str:
    """The stage's ``upAxis``; anything but ``Y`` or ``Z`` (USD allows no other) falls back to ``Y``, USD's
    default, with a warning: an ``X`` stage was taken for Y-up without a word."""
    value = str(UsdGeom.GetStageUpAxis(stage))
    if value in ("Y", "Z"):
        return value
    warnings.warn(f"{os.path.basename(source)}: upAxis = {value!r} is not Y or Z; using Y (USD's default)",
                  stacklevel=user_stacklevel())
    return "Y"


USD_SUFFIXES = (".usd", ".usda", ".usdc", ".usdz")  # the scene files USD opens


def missing_file(source) -> str:
    """``file not found``, with the USD file beside it meant by a misspelt ``source`` (``goood.usda`` beside
    good.usda): compared by stem, as every candidate shares the suffix that made an unrelated name look close."""
    path = Path(os.fsdecode(source))
    try:
        files = [p for p in path.parent.iterdir() if p.suffix.lower() in USD_SUFFIXES and p.is_file()]
    except OSError:  # no such folder, or one that cannot be listed: nothing to offer
        files = []
    near = [p.name for p in files if did_you_mean(path.stem, [p.stem])]
    return f"file not found{did_you_mean(path.name, near) if near else ''}"


def refuse_non_file(source: str) -> None:
    """Raises SceneError naming ``source`` where it exists and is no file: USD reads a named pipe or a terminal until
    a writer closes it (a render that waits forever), and answers a folder with 'Cannot determine file format'.
    Paths that do not exist pass: USD's resolver may still find them."""
    if os.path.exists(source) and not os.path.isfile(source):
        kind = "a directory" if os.path.isdir(source) else "a pipe or device"
        raise SceneError(f"{kind}, not a USD file", path=source)


def open_stage(source: str) -> Usd.Stage:
    """``Usd.Stage.Open(source)``, refusing what is no file and naming what USD cannot open; first lets go of the
    stages kept for frames whose files changed (:func:`wrt.usd_frames.release_changed`), whose layers USD would
    hand out again as they were. The stage is a new one, never a caller's ``Usd.StageCache``'s."""
    from .usd_frames import release_changed  # (that module's loads open stages here)

    release_changed()
    refuse_non_file(source)
    try:
        source.encode("utf-8") if isinstance(source, str) else None
    except UnicodeEncodeError:  # bytes that are no UTF-8: USD failed with Python's codec error, naming no file
        shown = os.fsencode(source).decode("utf-8", errors="backslashreplace")
        raise SceneError("the file name is not UTF-8 text, which USD cannot open; rename the file",
                         path=shown) from None
    try:
        # Opened for wrt alone, whatever StageCacheContext the caller holds: a cached stage is the caller's (its
        # interpolation type, its edits), and the variants wrt selects would be written onto its session layer.
        with Usd.StageCacheContext(Usd.BlockStageCaches):
            stage = Usd.Stage.Open(source)
    except Tf.ErrorException as e:
        if not os.path.exists(source):
            raise SceneError(missing_file(source), path=source) from None
        raise SceneError(f"USD cannot open this file ({tf_message(e)})", path=source) from None
    if stage is None:
        raise SceneError("USD cannot open this file", path=source)
    return stage


def tf_message(error: Exception) -> str:
    """The quoted reasons inside a ``Tf.ErrorException`` text, without the C++ file and line noise."""
    # A reason may span lines (the text parser's ends in a newline before its closing quote).
    reasons = re.findall(r" : '(.*?)'\s*(?=\n\s*Error in|\Z)", str(error), flags=re.DOTALL)
    reasons = [re.sub(r"pxrInternal_\w+?::", "", r).strip() for r in reasons]
    return "; ".join(r for r in reasons if r) or str(error).strip()

