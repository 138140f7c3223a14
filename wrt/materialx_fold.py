"""Constant folding of the MaterialX nodes between a surface shader input and its sources (:mod:`wrt.materialx`).

wrt evaluates no node graph per hit: a material input is a constant, a texture (:class:`wrt.materials.TextureInput`,
``texel * scale + bias``) or a mesh's colour primvar (:class:`wrt.materials.PrimvarInput`, ``primvar * scale``). The
math and channel nodes below are evaluated once, at load time, as the MaterialX Standard Nodes specification (1.39)
defines them, with its input defaults:

=====================  ==============================================  ===========================================
node (``ND_<node>_*``)  output                                          of a texture or primvar
=====================  ==============================================  ===========================================
``constant``           ``value`` (0)                                   --
``dot``                ``in`` (a no-op)                                passed through
``convert``            ``in``: a float fills every channel; 3 from 2    the channels past those kept read 0 (a
                       add 0, 4 from 3 add 1 (alpha); fewer drop the   fourth 1); one channel broadcast: a float
                       last                                            widened (not a vector2 of it: named)
``multiply``           ``in1 (0) * in2 (1)``, per channel               times a constant: its ``scale``
``add``, ``subtract``  ``in1 (0) +/- in2 (0)``                          plus or minus a constant: its ``bias``
                                                                        (a constant minus it: ``scale`` negated)
``invert``             ``amount (1) - in (0)``                          as ``subtract``
``mix``                ``fg (0) * mix + bg (0) * (1 - mix)``            the chosen one where ``mix`` is 0 or 1
``extract``            channel ``index`` (0) of ``in``                  a texture's channel
``separate2/3/4``      the output's channel of ``in`` (``outr``,        a texture's channel
                       ``outg``, ... ``outx``, ...)
``combine3``           ``(in1, in2, in3)`` (0 each)                     --
=====================  ==============================================  ===========================================

Anything else, or a texture or primvar where the table has "--", cannot be folded: :class:`Unfoldable` names the
node, and the surface input keeps its constant (with a note in the material's warning). So is a texture read as one
channel (a float image, an ``extract``) times a colour whose channels differ: its one channel is broadcast after the
scale, which therefore cannot tint it. So is a node whose input of one number in its definition (:func:`port_type`:
a ``mix_color3``'s ``mix``, ``in2`` of ``multiply_color3FA``) is authored with several.
"""

from __future__ import annotations

import copy
import dataclasses
import re

import numpy as np

from .materials import CHANNELS, PrimvarInput, TextureInput

FOLDABLE = re.compile(r"^ND_(multiply|add|subtract|invert|mix|constant|convert|extract|separate[234]|combine3|dot)_"
                      r"(\w+)$")
SEPARATE_CHANNELS = {"outr": 0, "outg": 1, "outb": 2, "outa": 3, "outx": 0, "outy": 1, "outz": 2, "outw": 3}
# Channels of each type; a nodedef name ends in its types (ND_mix_color3_color3, ND_multiply_color3FA: in2 a float).
TYPE_SIZES = {"float": 1, "integer": 1, "boolean": 1, "vector2": 2, "color3": 3, "vector3": 3, "color4": 4,
              "vector4": 4}
TYPE_NAME = re.compile("|".join(TYPE_SIZES))
MAX_DEPTH = 32  # nodes between a surface input and a source; a deeper chain (or a cycle) is not folded


@dataclasses.dataclass
class Folded:
    """A node output after folding: ``value`` (float64, one entry per channel) is the constant, or for a texture
    or primvar ``source`` the value where it has none (its fallback, through the same nodes)."""

    value: np.ndarray
    source: TextureInput | PrimvarInput | None = None


class Unfoldable(Exception):
    """``node`` (a ``UsdShade.Shader``) cannot be folded into a constant, texture or primvar; ``problem``, where
    the node is not one wrt lacks but one MaterialX gives no value (an extract's index past its input's channels),
    says what is wrong with it."""

    def __init__(self, node, problem: str | None = None):
        super().__init__(str(node.GetPath()))
        self.node = node
        self.problem = problem


def fold(reader, node, leaf, depth: int = 0, memo: dict | None = None, output: str = "out") -> Folded:
    """The output ``output`` of MaterialX ``node`` folded (``separate3``'s ``outg``, ...; other nodes have one):
    ``leaf(node, info_id)`` gives sources (images, primvar readers) as a :class:`Folded`, or None for any other node;
    ``reader`` (a :class:`wrt.materials.MaterialReader`) resolves inputs. ``memo`` holds the nodes folded so far in
    this graph: a node that several inputs read (a diamond) is folded once, where a chain of 20 of them was folded
    2^20 times (a load of some 8 minutes).

    Raises:
        Unfoldable: naming the first node (depth first) that cannot be folded.
    """
    memo = {} if memo is None else memo
    key = (node.GetPath(), depth, output)  # the depth too: MAX_DEPTH is counted along each path
    if key not in memo:
        try:
            memo[key] = _fold(reader, node, leaf, depth, memo, output)
        except Unfoldable as e:
            memo[key] = e
    found = memo[key]
    if isinstance(found, Unfoldable):
        raise Unfoldable(found.node, found.problem)
    # A copy: a texture or primvar is scaled (or its channel picked) in place by the node that reads it.
    return Folded(found.value, copy.copy(found.source))


def _fold(reader, node, leaf, depth: int, memo: dict, output: str) -> Folded:
    """:func:`fold` of a node not in ``memo``."""
    node_id = node.GetShaderId() or ""
    found = leaf(node, node_id)
    if found is not None:
        return found
    match = FOLDABLE.match(node_id)
    if match is None:
        raise Unfoldable(node)
    if depth >= MAX_DEPTH:  # (a supported node: "which is not supported" named a constant or dot of a loop)
        raise Unfoldable(node, f"sources lie more than {MAX_DEPTH} nodes deep or loop back to it")
    op, types = match.group(1), match.group(2)

    def arg(name: str, default: float) -> Folded:
        producer = reader._producer(node, name)
        if producer is None:
            return Folded(np.array([default], np.float64))
        if producer[0] == "shader":
            return fold(reader, producer[1], leaf, depth + 1, memo, producer[2])
        # (named: "which is not supported" named a constant node of a string or an infinite value)
        try:
            value = np.asarray(producer[1], np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise Unfoldable(node, f"input {name} is no number ({producer[1]!r})") from None
        if value.size == 0 or not np.all(np.isfinite(value)):
            raise Unfoldable(node, f"input {name} is not finite numbers ({producer[1]})")
        from .color_spaces import decoded_color

        # The node's definition types the input, as MaterialX's port (port_type), not the USD attribute nor the
        # count of numbers: a mix's float mix authored as a color3f was decoded as a colour and mixed each channel
        # by its own amount, a combine3's took its first number, without a word.
        port = port_type(match.group(1), types, name)
        if TYPE_SIZES[port] == 1 and value.size > 1:
            raise Unfoldable(node, f"input {name}, a {port} in its definition, is authored with {value.size} numbers")
        # In its colorSpace, as MaterialX transforms a colour value bound to any node's input: a constant node's
        # srgb_texture 0.5 was read as 0.5 for 0.214. (A note on an unknown space is not passed on from here.) A
        # float3 value of a constant_color3 is a colour, a color3f one of a constant_vector3 is not.
        decoded, _ = decoded_color(node.GetInput(name), value, name, color=port in ("color3", "color4"))
        if decoded is None:
            raise Unfoldable(node, f"{name} decoded from its colour space is past float32's range")
        return Folded(decoded)

    names = TYPE_NAME.findall(types)  # the output's type: a convert's last, any other node's first
    if not names:  # (a string constant fed to a number)
        raise Unfoldable(node, f"output is of type {types}, not numbers")
    size = 1 if op == "extract" or op.startswith("separate") else TYPE_SIZES[names[-1 if op == "convert" else 0]]
    if op == "convert":
        return _convert(node, arg("in", 0.0), names[0], names[-1])
    if op in ("constant", "dot"):
        found = arg("value" if op == "constant" else "in", 0.0)
        return found if found.source is not None else Folded(_converted(found.value, size))
    if op == "extract":
        return _extract(node, arg("in", 0.0), arg("index", 0.0), names[0])
    if op.startswith("separate"):  # (an ORM map's occlusion, roughness and metalness)
        k = SEPARATE_CHANNELS.get(output)
        if k is None or k >= TYPE_SIZES[names[0]]:
            raise Unfoldable(node)
        return _extract(node, arg("in", 0.0), Folded(np.array([float(k)])), names[0])
    if op == "combine3":
        parts = [arg(name, 0.0) for name in ("in1", "in2", "in3")]
        if any(p.source is not None for p in parts):
            raise Unfoldable(node)
        return Folded(np.array([p.value[0] for p in parts]))
    if op == "mix":
        fg, bg, amount = arg("fg", 0.0), arg("bg", 0.0), arg("mix", 0.0)
        if amount.source is None and np.all(amount.value == 0.0):
            return bg
        if amount.source is None and np.all(amount.value == 1.0):
            return fg
        if fg.source is not None or bg.source is not None or amount.source is not None:
            raise Unfoldable(node)
        mix = _sized(amount.value, size)
        return Folded(_sized(fg.value, size) * mix + _sized(bg.value, size) * (1.0 - mix))
    if op == "invert":
        op, a, b = "subtract", arg("amount", 1.0), arg("in", 0.0)  # amount - in
    else:
        a, b = arg("in1", 0.0), arg("in2", 1.0 if op == "multiply" else 0.0)
    if a.source is None and b.source is None:
        a_value, b_value = _sized(a.value, size), _sized(b.value, size)
        return Folded({"multiply": a_value * b_value, "add": a_value + b_value, "subtract": a_value - b_value}[op])
    if a.source is not None and b.source is not None:
        raise Unfoldable(node)
    varying, constant = (a, b.value) if a.source is not None else (b, a.value)
    if op == "multiply":
        return _scaled(node, varying, constant)
    if op == "subtract" and varying is a:
        return _offset(node, varying, -constant, False, size)
    return _offset(node, varying, constant, op == "subtract", size)  # c + texture, c - texture


def port_type(op: str, types: str, name: str) -> str:
    """The type MaterialX's nodedef ``ND_<op>_<types>`` (stdlib_defs.mtlx) gives its input ``name``, for a node
    :func:`fold` reads: a convert's input is of its first type; ``in2`` of the ``FA`` forms of multiply, add and
    subtract and invert's ``amount`` a float; mix's ``mix`` of its second type (``ND_mix_color3_color3``), else a
    float (``ND_mix_color3``); combine3's inputs floats; extract's ``index`` an integer; any other input of the
    node's first type."""
    names = TYPE_NAME.findall(types)
    if op == "convert":
        return names[0]
    if types.endswith("FA") and name == ("amount" if op == "invert" else "in2"):
        return "float"
    if op == "mix" and name == "mix":
        return names[1] if len(names) > 1 else "float"
    if op == "combine3":
        return "float"
    if op == "extract" and name == "index":
        return "integer"
    return names[0]


def _offset(node, varying: Folded, offset: np.ndarray, negate: bool, size: int) -> Folded:
    """``offset -/+ varying`` (``negate``: minus) for a texture ``varying`` and a constant ``offset`` (1 or N
    channels) of a node of ``size`` channels: the texture's bias (and its scale negated). A colour3 node leaves the
    texture's alpha as it is. A primvar (no bias), a texture read as one channel plus a colour whose channels differ
    (its one bias cannot tint it), or a bias past float32's range cannot be folded (``node`` is named)."""
    source = varying.source
    if not isinstance(source, TextureInput):
        raise Unfoldable(node)
    one_channel = CHANNELS[source.channel] < 4  # read and broadcast
    if one_channel and np.ptp(_sized(offset, 3)) > 0:
        raise Unfoldable(node)
    n = max(varying.value.size, offset.size)
    value = _sized(offset, n) + (-1.0 if negate else 1.0) * _sized(varying.value, n)
    sign = np.full(4, -1.0 if negate else 1.0)
    shift = _sized(offset, 4)
    if size in (2, 3) and not one_channel:  # a colour3 has no alpha of its own, a vector2 no third channel either
        sign[size:], shift[size:] = 1.0, 0.0
    with np.errstate(over="ignore", invalid="ignore"):  # checked below
        source.scale = (source.scale * sign).astype(np.float32)
        source.bias = (source.bias * sign + shift).astype(np.float32)
    if not (np.all(np.isfinite(source.scale)) and np.all(np.isfinite(source.bias))):
        raise Unfoldable(node)
    return Folded(value, source)


def _sized(value: np.ndarray, size: int) -> np.ndarray:
    """``value`` with ``size`` channels: one number fills them all (MaterialX's float variants of the nodes)."""
    return np.full(size, value[0]) if value.size == 1 else np.resize(value, size)


def _converted(value: np.ndarray, size: int) -> np.ndarray:
    """``convert`` of a constant to ``size`` channels: a float fills all of them, a vector2 gains a third of 0 and
    a 3-channel value an alpha (w) of 1, as MaterialX's implementations widen them; more channels drop the last."""
    if value.size == 2 and size > 2:  # (x, y, 0); it repeated x
        value = np.append(value, 0.0)
    if value.size == 3 and size == 4:
        return np.append(value, 1.0)
    return _sized(value, size)


def _convert(node, found: Folded, in_type: str, out_type: str) -> Folded:
    """``convert`` of ``found`` from ``in_type`` to ``out_type``, as the specification's channel nodes define it: a
    float fills every channel; of more channels the first are kept; of fewer they are copied and the ones added are
    0, but for a fourth of 1. A texture's channels past those kept read that 0 or 1 (scale 0, bias 0 or 1), as an
    image node's past its own type do, and a primvar's third is scaled by 0, so that a vector3 image narrowed to a
    vector2 and widened again shows no blue of the file (a color4's alpha likewise). A texture read as one channel
    broadcast holds a float repeated; widened past the channels it was repeated into, it would need ``(x, x, 0)``,
    which no scale of one broadcast channel reads: that is refused, naming the node."""
    n, m = TYPE_SIZES[in_type], TYPE_SIZES[out_type]
    value, source = _converted(found.value, m), found.source
    if source is None:
        return Folded(value)
    kept = min(n, m)
    if isinstance(source, PrimvarInput):  # a colour3 or vector3 reader's: three channels, times scale
        if n == 1:
            raise Unfoldable(node)
        scale = np.array(source.scale, np.float32)  # a new array: the memo's copy shares the old one
        scale[kept:] = 0.0
        source.scale = scale
    elif CHANNELS[source.channel] < 4:  # one channel, broadcast: right for a float widened, or for fewer channels
        if 1 < n < m:
            added = ["1" if k == 3 else "0" for k in range(n, m)]
            repeated, widened = ", ".join(["x"] * n), ", ".join(["x"] * n + added)
            raise Unfoldable(node, f"input is one texture channel repeated into a {in_type} ({repeated}): widened "
                                   f"to {out_type} it is ({widened}), which one texture channel broadcast cannot read")
    else:
        if n == 1:  # an rgb texture typed as a float: not MaterialX's
            raise Unfoldable(node)
        scale, bias = np.array(source.scale, np.float32), np.array(source.bias, np.float32)
        scale[kept:], bias[kept:] = 0.0, 0.0
        if kept < 4:
            bias[3] = 1.0
        source.scale, source.bias = scale, bias
    return Folded(value, source)


def _extract(node, found: Folded, index: Folded, in_type: str) -> Folded:
    """``extract``: channel ``index`` of ``found`` (of type ``in_type``); of an rgb texture that channel's output.
    An index that is no channel of ``in_type`` (2 of a vector2, 3 of a colour3, negative, fractional) has no value
    in MaterialX: it is refused, saying so."""
    if index.source is not None:
        raise Unfoldable(node)
    k, size = float(index.value[0]), TYPE_SIZES[in_type]
    if not (k.is_integer() and 0 <= k < size):
        raise Unfoldable(node, f"index {k:g} is not a channel of its {in_type} input (0 to {size - 1})")
    k = int(k)
    texture = found.source
    if texture is None:
        return Folded(np.array([_sized(found.value, 4)[k]]))
    if not isinstance(texture, TextureInput) or texture.channel != "rgb":
        raise Unfoldable(node)
    texture.channel = "rgba"[k]
    return Folded(np.array([_sized(found.value, 4)[k]]), texture)


def _scaled(node, varying: Folded, factor: np.ndarray) -> Folded:
    """``varying`` (a texture or primvar) times the constant ``factor`` (1 or N channels), as its ``scale``; a scale
    past float32's range cannot be folded (``node``, the multiply, is named)."""
    source = varying.source
    size = max(varying.value.size, factor.size)
    value = _sized(varying.value, size) * _sized(factor, size)
    one_channel = isinstance(source, TextureInput) and CHANNELS[source.channel] < 4  # read and broadcast
    if one_channel and np.ptp(_sized(factor, 3)) > 0:
        raise Unfoldable(node)  # a grey channel times a colour: its one scale cannot tint it
    with np.errstate(over="ignore", invalid="ignore"):  # checked below
        if isinstance(source, PrimvarInput):
            source.scale = (np.asarray(source.scale, np.float64) * _sized(factor, 3)).astype(np.float32)
        else:  # (texel * scale + bias) * factor; a missing UDIM tile's fallback stands in for the texel
            # A factor of two or three channels leaves the channels past its own alone (a vector2's fourth is 1).
            per_channel = _sized(factor, 4) if factor.size not in (2, 3) or one_channel else np.append(
                factor, np.ones(4 - factor.size))
            source.scale = (source.scale * per_channel).astype(np.float32)
            source.bias = (source.bias * per_channel).astype(np.float32)
    for array in (source.scale, getattr(source, "bias", 0.0)):
        if not np.all(np.isfinite(array)):
            raise Unfoldable(node)
    return Folded(value, source)
