"""Reading a USD attribute at a time code, with wrt's rule for the default time: a value that has only time
samples is read at its first sample, as points and transforms are (``time=None`` in ``load_usd``); and positions
and orientations moved by their velocities between samples, as USD moves them."""

from __future__ import annotations

import numpy as np
from pxr import Ar, Sdf, Usd

from .usd_problems import property_stack

HAS_SPLINES = hasattr(Usd.Attribute, "HasSpline")  # usd-core before 25.05 has no attribute splines


def value_at(attr: Usd.Attribute, time: Usd.TimeCode):
    """``attr`` at ``time``, or at its earliest time sample when ``time`` is default and it has no authored default
    (a schema fallback, such as visibility's ``inherited`` or a light's intensity, does not count)."""
    return attr.Get(read_time(attr, time))


def token_typed(attr: Usd.Attribute) -> bool:
    """Whether ``attr`` holds a token, as its schema declares (``visibility``, ``purpose``): one authored as a
    ``string`` reads in Python as the same text, but USD's ``Get<TfToken>`` fails on it, so ``ComputeVisibility``
    and ``ComputePurpose`` read the fallback (visible; default)."""
    stack = attr.GetPropertyStack()  # (GetTypeName gives the schema's type, whatever the layers author)
    return not stack or stack[0].typeName == Sdf.ValueTypeNames.Token


def value_or_fallback(attr: Usd.Attribute, time: Usd.TimeCode):
    """:func:`value_at`, or the schema's fallback for ``attr`` where a value block (``= None``) leaves it none (None
    where the schema has none): a blocked value is no value, as where nothing is authored, and USD's own readers
    (``UsdGeom.Camera.GetCamera``, UsdImaging) then use the fallback."""
    value = value_at(attr, time)
    if value is None:
        value = attr.GetPrim().GetPrimDefinition().GetAttributeFallbackValue(attr.GetName())
    return value


def schema_typed_value(attr: Usd.Attribute, time: Usd.TimeCode, read=None):
    """``(value, wrong)``: ``attr`` at ``time`` (by :func:`value_or_fallback`'s rule) as USD's typed readers read
    it, and where the value authored is of another type than the schema's, words for it (``"float radius = 3"``;
    else None).

    USD's ``Get<T>`` with the schema's ``T``, which ``UsdGeom.Camera.GetCamera``, ``ComputeExtent``,
    ``BBoxCache`` and UsdImaging use, does not convert: an opinion of another value type (``float radius`` where the
    schema says ``double``, ``int size``, ``double focalLength``, ``point3d[] points``) is passed over at the default
    time, for the next weaker default of the schema's type, else the schema's fallback (none for ``points``); at a
    time (its samples, or a default read at a time) USD's read fails on it: ``GetCamera`` keeps its fallbacks,
    ``ComputeExtent`` computes no extent, and wrt reads the schema's fallback.
    Python's ``Get`` hands any type back, so wrt drew a ``float radius = 3`` sphere of radius 3 that usdview draws
    of radius 1. Roles are no types here: ``float3[] points`` is ``point3f[]``. ``read``: the value the caller
    read already (a mesh's points, not read twice), or None.
    """
    def fallback():
        return attr.GetPrim().GetPrimDefinition().GetAttributeFallbackValue(attr.GetName())

    if not attr.HasAuthoredValue():  # nothing authored (most gprims' orientation, doubleSided), or blocked: no type
        value = attr.Get(time) if read is None else read  # to check, and no specs to walk (a third of the cost)
        return (fallback() if value is None else value), None
    at = read_time(attr, time)
    value = attr.Get(at) if read is None else read
    want = attr.GetTypeName().type  # a schema attribute's type name is the schema's whatever the layers author
    if type(value) is (want.pythonClass or _PYTHON_TYPES.get(want.typeName)):
        return value, None  # a Gf, Vt or bool value is of one C++ type: no walk over the specs (a mesh's points)
    if value is None:  # blocked
        return fallback(), None
    wrong = None
    for spec, samples in _valued_specs(attr, at):
        if spec.typeName.type == want or (not samples and isinstance(spec.default, Sdf.ValueBlock)):
            if wrong is None:  # (a block, of whatever type name, blocks weaker values as one of the schema's does)
                return value, None  # the value read is of the schema's type
            default = spec.default
            if default is None or isinstance(default, Sdf.ValueBlock):
                return fallback(), wrong
            return _resolved_assets(default, spec.layer), wrong
        if wrong is None:
            shown = repr(value) if isinstance(value, str) else str(value)  # Gf, Vt: (1, 2, 3), [1, 2]
            shown = shown if len(shown) <= 40 else shown[:36] + " ..."  # a mesh's points
            wrong = f"{spec.typeName} {attr.GetName()} = {shown}"
        if not at.IsDefault():  # at a time USD's typed read fails on it: its readers use the fallback
            return fallback(), wrong
    return (value, None) if wrong is None else (fallback(), wrong)


def _valued_specs(attr: Usd.Attribute, at: Usd.TimeCode):
    """``(spec, samples)`` for each property spec of ``attr`` at ``at``, strongest first, that holds a value there
    (``samples``: its time samples do; else its default); opinions of no value (metadata, a connection) left out."""
    for spec in property_stack(attr, at):
        samples = not at.IsDefault() and spec.layer.GetNumTimeSamplesForPath(spec.path) > 0
        if samples or spec.HasDefaultValue():
            yield spec, samples


def schema_type_authored(attr: Usd.Attribute, time: Usd.TimeCode) -> bool:
    """Whether a value of the schema's type is authored for ``attr`` (by :func:`value_or_fallback`'s rule), under
    whatever opinions of other types are stronger: the value USD's typed read takes at the default time
    (:func:`schema_typed_value`), or time samples of that type, which a read at the default time passes over for the
    schema's fallback as a read at a time passes over a default (looked for among defaults alone, such samples
    counted as none authored); a value block above it hides it, as it does from USD."""
    want = attr.GetTypeName().type
    at = read_time(attr, time)
    for spec in property_stack(attr, at):
        has_samples = spec.layer.GetNumTimeSamplesForPath(spec.path) > 0
        if not (has_samples or spec.HasDefaultValue()):
            continue  # an opinion of no value (metadata, a connection)
        if not (has_samples and not at.IsDefault()) and isinstance(spec.default, Sdf.ValueBlock):
            return False
        if spec.typeName.type == want:
            return True
    return False


def asset_in_layer(path: str, layer: Sdf.Layer | None) -> Sdf.AssetPath:
    """The ``Sdf.AssetPath`` of ``path`` as authored in ``layer``, resolved against it as USD's value resolution
    resolves asset paths (its resolved path empty where there is no such file)."""
    if not path:
        return Sdf.AssetPath(path)
    anchored = Sdf.ComputeAssetPathRelativeToLayer(layer, path) if layer else path
    return Sdf.AssetPath(path, str(Ar.GetResolver().Resolve(anchored)))


def _resolved_assets(value, layer: Sdf.Layer):
    """``value``, a spec's default, with its asset paths resolved against ``layer`` (the one authoring it), as USD's
    value resolution hands them back: a spec's default holds none (a light's texture was "not found")."""
    if isinstance(value, Sdf.AssetPath):
        return asset_in_layer(value.path, layer)
    if isinstance(value, Sdf.AssetPathArray):
        return Sdf.AssetPathArray([asset_in_layer(asset.path, layer) for asset in value])
    return value


_PYTHON_TYPES = {"bool": bool}  # C++ types whose Python values no other C++ type gives (float: float and double)


def read_time(attr: Usd.Attribute, time: Usd.TimeCode) -> Usd.TimeCode:
    """The time code :func:`value_at` reads ``attr`` at: ``time``, or ``EarliestTime`` when ``time`` is default and
    ``attr`` has only time samples. For USD queries that read attributes themselves (a primvar's
    ``ComputeFlattened``, an xform op's ``GetOpTransform``).

    ``EarliestTime`` rather than ``GetTimeSamples()[0]``: the result is the same, and ``GetTimeSamples`` can hang
    usd-core 26.11 on stages with ``timeCodesPerSecond = 0``. A spline (USD 25.05's animation of scalar values) is
    read at its first knot instead: before it, its extrapolation (linear, sloped, a loop) gave ``EarliestTime`` -inf
    or another knot's value.
    """
    if (
        time.IsDefault()
        and attr.HasAuthoredValue()
        and attr.GetResolveInfo(time).GetSource() != Usd.ResolveInfoSourceDefault
    ):
        return _first_knot(attr) or Usd.TimeCode.EarliestTime()
    return time


def _first_knot(attr: Usd.Attribute) -> Usd.TimeCode | None:
    """The time of the first knot of the spline that gives ``attr`` its values (in the stage's time: ``GetSpline``
    applies layer offsets), or None where no spline does."""
    if not (HAS_SPLINES and attr.HasSpline()):
        return None
    times = attr.GetSpline().GetKnots().keys()
    return Usd.TimeCode(min(times)) if times else None


def moved_positions(positions: Usd.Attribute, velocities: Usd.Attribute, accelerations: Usd.Attribute,
                    time: Usd.TimeCode, time_codes_per_second: float, wrong_lengths: list | None = None):
    """Positions (a PointInstancer's ``positions``, a point-based prim's ``points``) at ``time`` moved by their
    ``velocities`` and ``accelerations`` as USD computes them (``UsdGeomPointBased::ComputePointsAtTime``,
    ``UsdGeomPointInstancer::ComputeInstanceTransformsAtTime``): the sample at or before ``time`` plus
    ``v dt + a dt^2 / 2``, ``dt = (time - sample time) / timeCodesPerSecond`` in seconds. Velocities are used only
    when their samples bracket ``time`` at the same times as the positions' and they have one entry per position
    (accelerations likewise against the velocities); otherwise, or at the default time or ``EarliestTime`` (the
    first samples as they are), returns None and the caller
    reads the positions as they are (interpolated between samples). A rate of the wrong length is ignored, as USD
    ignores it (with a warning): ``wrong_lengths`` gets one ``"3 velocities for 2 positions"`` for each.

    Returns:
        ``(N, 3)`` float64 array, or None.
    """
    found = _with_rate(positions, velocities, time, time_codes_per_second, wrong_lengths=wrong_lengths)
    if found is None:
        return None
    base, velocity, dt = found
    moved = base + dt * velocity
    acceleration = _with_rate(velocities, accelerations, time, time_codes_per_second, wrong_lengths=wrong_lengths)
    if acceleration is not None:
        moved += 0.5 * dt * dt * acceleration[1]
    return moved


def spun_rotations(orientations: Usd.Attribute, angular_velocities: Usd.Attribute, time: Usd.TimeCode,
                   time_codes_per_second: float, wrong_lengths: list | None = None):
    """A PointInstancer's orientations at ``time`` turned by its ``angularVelocities`` (degrees per second about
    their own direction) as ``ComputeInstanceTransformsAtTime`` turns them: ``(quaternions at the sample at or before
    time, (N, 3, 3) column-vector rotations by angle |w| dt about w)``; the caller applies the rotation after the
    orientation. None under the same conditions as :func:`moved_positions`, which also says what ``wrong_lengths``
    gets."""
    found = _with_rate(orientations, angular_velocities, time, time_codes_per_second, width=4,
                       wrong_lengths=wrong_lengths)
    if found is None:
        return None
    quats, omega, dt = found
    omega = omega[:, :3]
    with np.errstate(invalid="ignore", over="ignore"):  # a NaN or inf rate: its instance is left out by the caller
        speed = np.linalg.norm(omega, axis=1)
        axis = omega / np.maximum(speed, 1e-300)[:, None]
        angle = np.radians(speed * dt)
        cos, sin = np.cos(angle)[:, None, None], np.sin(angle)[:, None, None]
    cross = np.zeros((len(axis), 3, 3))
    cross[:, 0, 1], cross[:, 0, 2], cross[:, 1, 2] = -axis[:, 2], axis[:, 1], -axis[:, 0]
    cross -= cross.transpose(0, 2, 1)
    outer = axis[:, :, None] * axis[:, None, :]
    return quats, cos * np.eye(3) + sin * cross + (1.0 - cos) * outer  # Rodrigues


def held_value(attr: Usd.Attribute, time: Usd.TimeCode):
    """``attr`` at its sample at or before ``time`` (no interpolation), as USD holds every instance attribute once
    velocities or angular velocities move the instances; :func:`value_at` where it has no time samples."""
    if not time.IsDefault() and attr.GetNumTimeSamples() > 0:
        found = attr.GetBracketingTimeSamples(time.GetValue())
        if found:
            return attr.Get(found[0])
    return value_at(attr, time)


def _with_rate(base: Usd.Attribute, rate: Usd.Attribute, time: Usd.TimeCode, time_codes_per_second: float,
               width: int = 3, wrong_lengths: list | None = None):
    """``(base at its sample at or before time, rate there, dt in seconds)`` as float64 arrays when ``rate`` is a
    usable derivative of ``base`` at ``time`` as USD checks it (both time-sampled, bracketing ``time`` with the same
    samples, one rate entry per base entry; ``base`` entries ``width`` wide), else None. A rate whose length is
    not the base's is told to ``wrong_lengths``, as USD warns about that one (the other checks are silent)."""
    if time.IsDefault() or time.IsEarliestTime() or not (time_codes_per_second > 0) or not rate.HasAuthoredValue():
        return None  # EarliestTime reads the first samples as they are: -DBL_MAX is no time to move them by
    t = time.GetValue()
    sample, bracket = _bracket(base, t)
    if sample is None or _bracket(rate, t) != (sample, bracket):
        return None
    values = np.asarray(base.Get(sample) or [], np.float64).reshape(-1, width)
    rates = np.asarray(rate.Get(sample) or [], np.float64).reshape(-1, 3)
    if len(rates) != len(values):
        if wrong_lengths is not None:
            wrong_lengths.append(f"{len(rates)} {rate.GetName()} for {len(values)} {base.GetName()}")
        return None
    return values, rates, (t - sample) / time_codes_per_second


def _bracket(attr: Usd.Attribute, t: float):
    """``(sample time at or before t, (lower, upper) samples around t)`` as USD's velocity sampling compares them
    (at a sample, the bracket just after it), or ``(None, None)`` when ``attr`` has no time samples."""
    found = attr.GetBracketingTimeSamples(t)
    if not found or attr.GetNumTimeSamples() == 0:
        return None, None
    lower, upper = found
    if lower == upper:
        found = attr.GetBracketingTimeSamples(t + Usd.TimeCode.SafeStep())
    return lower, tuple(found)
