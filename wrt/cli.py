"""Command-line entry point: ``wrt render``, ``wrt preview``, ``wrt bench`` and ``wrt bvh-stats``.

Bad input (a missing or broken file, an unknown option value) ends with one line on stderr and exit status 2;
no traceback is shown for it.
"""

from __future__ import annotations

import argparse
import collections
import decimal
import errno
import math
import os
import re
import sys
import time
import traceback
import warnings
from importlib import resources
from pathlib import Path

from .options import (
    ACCELERATOR_PRESPLIT,
    ACCELERATORS,
    ALIASES,
    AOV_NAMES,
    BVH_COLORINGS,
    DATA_INTEGRATORS,
    DEFAULT_BINS,
    DEFAULT_LEAF_SIZE,
    DEFAULT_MAX_DEPTH,
    EPO_SAMPLES,
    LAYOUTS,
    MAX_BINS,
    MAX_DEPTH,
    MAX_EPO_SAMPLES,
    MAX_EXPOSURE,
    MAX_LEAF_SIZE,
    MAX_RAYS,
    MAX_SPLIT_LEVELS,
    MAX_SPP,
    MAX_WARP_LEAF_SIZE,
    QUICK_LOOKS,
    TRIANGLE_BUDGET,
    WARP_BUILDERS,
    Builder,
    builder_names,
    parse_builders,
)
from .wording import counted, counted_of, did_you_mean

EXIT_BAD_INPUT = 2  # exit status for bad input, as argparse uses for bad arguments
EXIT_BROKEN_PIPE = 128 + 13  # exit status when stdout's reader is gone, as a shell reports a process SIGPIPE ended
EXIT_INTERRUPTED = 128 + 2  # exit status after Ctrl-C, as a shell reports a process SIGINT ended


def default_scene_path() -> Path:
    """The bundled default scene, ``wrt/data/default_room.usda`` (written by ``scenes/make_default_scene.py``)."""
    return Path(str(resources.files("wrt") / "data" / "default_room.usda"))


class _Progress:
    """Prints one timing line per finished step to stderr (quiet with ``--quiet``)."""

    def __init__(self, quiet: bool):
        self.quiet = quiet

    @property
    def bar(self) -> bool:
        """Whether to draw a progress bar: only on a terminal, where it redraws in place; in a log file each redraw
        would be a line of its own. One rule for a render, its --frames and --products, and wrt bench."""
        return not self.quiet and sys.stderr.isatty()

    def __call__(self, message: str, seconds: float | None = None):
        if not self.quiet:
            from tqdm import tqdm

            suffix = f" ({seconds:.2f} s)" if seconds is not None else ""
            # Through tqdm, as warnings are: a line said under a running progress bar (the first frame's view, as
            # that frame finishes) was printed on the bar's line, after its text.
            tqdm.write(f"wrt: {message}{suffix}", file=sys.stderr)
            sys.stderr.flush()


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows an option's default after its help, except where there is none to show (None, False: an option that is
    off, or whose help says what happens without it); "(default: None)" told the reader nothing."""

    def _get_help_string(self, action):
        if action.default is None or action.default is False or action.default == []:  # []: a repeatable option
            return action.help
        return super()._get_help_string(action)


class _Parser(argparse.ArgumentParser):
    """ArgumentParser whose usage errors are one line (``wrt: error: ...``) and exit status 2."""

    def __init__(self, *args, **kwargs):
        # Options are given in full: argparse took a unique prefix ('--bvh-dept' for '--bvh-depth'), so a script's
        # abbreviation changed meaning, or stopped working, when a later option of the same start was added. The
        # subcommands' parsers are made of this class too (add_parser), so none of them takes one.
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)
        # Values such as -1e3, -inf or -10:-1 (a --time, a --frames range) are values, not options. Before Python
        # 3.13 argparse took only plain negative decimals for values ("--time -1e3": expected one argument).
        self._negative_number_matcher = re.compile(r"^-(\.?\d|inf|nan)", re.IGNORECASE)

    def error(self, message):
        self.exit(EXIT_BAD_INPUT, f"wrt: error: {message} (see '{self.prog} --help')\n")

    def parse_args(self, args=None, namespace=None):
        """As argparse's, but an unknown option after a command is reported by that command's parser, with the
        closest option it has: argparse's own error came from the top parser and pointed at 'wrt --help', which
        lists the commands, not their options."""
        args = self._without_dashes_before_the_command(sys.argv[1:] if args is None else list(args))
        self._check_options_before_the_command(args)
        self._check_long_options_given_one_dash(args)
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            command = self._commands().get(getattr(parsed, "command", None), self)
            unknown = next((e for e in extras if e.startswith("-")), "")
            # Compared without the dashes, which every name shares: with them '--frobnicate' was close to '--frames'.
            names = [o[2:] for action in command._actions for o in action.option_strings if o.startswith("--")]
            # A long option given one dash ('-widht') is compared as well: argparse has no short option of that name.
            dashes = 2 if unknown[:2] == "--" else 1 if len(unknown) > 2 else 0
            hint = did_you_mean(unknown[dashes:].split("=")[0], names).replace(" '", " '--") if dashes else ""
            if not dashes and unknown.swapcase() in command._option_string_actions:  # -O for -o
                hint = f" (did you mean {unknown.swapcase()!r}?)"
            if dashes == 2:  # another command's own option first: a close one of this command's misled
                hint = self._owner_hint(command, unknown.split("=")[0], exact=True) or hint or \
                    self._owner_hint(command, unknown.split("=")[0], exact=False)
            command.error(f"unrecognized arguments: {' '.join(extras)}{hint}")
        return parsed

    def _owner_hint(self, command: argparse.ArgumentParser, name: str, exact: bool) -> str:
        """Where an option that ``command`` has not (``name``; with ``exact`` False, the start of one) belongs: wrt's
        own (``wrt render --version``: give it before the command), or another command's (``wrt render
        --bvh-depth``, preview's), as an option before the command is named
        (:meth:`_check_options_before_the_command`); '' for none. They were 'unrecognized' alone, or got a close
        option of ``command`` that meant something else ('--bvh-depth (did you mean '--max-depth'?)')."""
        own = _option_named(self, name, prefix=not exact)
        if command is not self and own is not None:
            return f"; it is an option of wrt itself: give it before the command (wrt {own})"
        others = [(c, p) for c, p in self._commands().items() if p is not command]
        options = [(c, _option_named(p, name, prefix=not exact)) for c, p in others]
        owners = [f"wrt {c}" + ("" if option == name else f" ({option})") for c, option in options if option]
        return f"; it is an option of {', '.join(owners)}, not of {command.prog}" if owners else ""

    def _without_dashes_before_the_command(self, args: list) -> list:
        """``args`` without a ``--`` before the command (``wrt -- render``), which ends the top parser's options, as
        Python 3.13's argparse drops it (before, 'invalid choice: '--''); a ``--`` followed by no command is named."""
        commands = self._commands()
        for i, arg in enumerate(args):
            if not commands or arg in commands:
                return args
            if arg == "--":
                after = args[i + 1] if i + 1 < len(args) else None
                if after is None or after.startswith("-"):
                    self.error(f"'--' ends the options: a COMMAND ({', '.join(commands)}) must follow it, got "
                               f"{'nothing' if after is None else repr(after)}")
                return args[:i] + args[i + 1:]
        return args

    def _check_options_before_the_command(self, args: list) -> None:
        """An unknown option before the command (``wrt --frobnicate``, ``wrt --width 8 render``) is named: argparse
        said only that 'the following arguments are required: COMMAND', or took the option's value for the command."""
        commands = self._commands()
        for arg in args:
            if not commands or arg in commands or arg == "--":
                return
            name = arg.split("=")[0]
            if arg.startswith("-") and _option_named(self, name) is None:
                # A command's option, or the start of one ('--wid' for render's '--width'), named in full.
                options = [(c, _option_named(p, name, prefix=True)) for c, p in commands.items()]
                owners = [f"wrt {command}" + ("" if option == name else f" ({option})")
                          for command, option in options if option]
                full = ", in full" if any(option and option != name for _, option in options) else ""
                hint = f"; it is an option of {', '.join(owners)}: give it after the command{full}" \
                    if owners else did_you_mean(name, self._option_string_actions)
                self.error(f"unrecognized arguments: {arg}{hint}")

    def _check_long_options_given_one_dash(self, args: list) -> None:
        """A long option given one dash (``-width 8``, ``-output x.png``, ``-quiet``, as many tools spell theirs) is
        named with its two: argparse took ``-output`` for ``-o utput`` ('cannot write utput'),
        ``-quiet`` for ``-q`` given a value ('ignored explicit argument 'uiet''), and ``-width`` with no hint."""
        parser, commands = self, self._commands()
        for arg in args:
            if arg == "--":  # what follows is positional
                return
            if parser is self and arg in commands:
                parser = commands[arg]
            elif arg[:1] == "-" and arg[1:2] not in ("-", "") and len(arg) > 2:
                name = "-" + arg.split("=")[0]
                if name in parser._option_string_actions:
                    parser.error(f"{arg} is no option: long options take two dashes (did you mean {name!r}?)")

    def _check_value(self, action, value):
        """As argparse's, but a misspelt choice (``--builder SAH``, ``--integrator pth``, ``rendr``) names the one
        meant, as misspelt options and the library's own names do; argparse listed the choices only."""
        try:
            super()._check_value(action, value)
        except argparse.ArgumentError as e:
            hint = did_you_mean(value, action.choices) if action.choices is not None else ""
            kind, _, builder = str(value).partition(":")
            accel = any("--accel" in a.option_strings for a in self._actions)  # wrt render's; preview draws wrt's
            if action.dest == "builder" and accel and kind == "warp" and builder in WARP_BUILDERS:
                hint = f" (Warp's wp.Mesh tree is --accel warp --builder {builder})"  # bench's name: was no hint
            if not hint or repr(value) not in e.message:
                raise
            raise argparse.ArgumentError(action, e.message.replace(repr(value), repr(value) + hint, 1)) from None

    def _commands(self) -> dict:
        """The subcommand parsers by name (empty for a parser without subcommands)."""
        for action in self._actions:
            if isinstance(action, argparse._SubParsersAction):
                return action.choices
        return {}


def _option_named(parser: argparse.ArgumentParser, name: str, prefix: bool = False) -> str | None:
    """The option of ``parser`` that ``name`` selects: itself, or (with ``prefix``, for hints: wrt's parsers take no
    abbreviation) the one long option it is the start of ('--vers' for '--version'); None for no option, or an
    ambiguous start."""
    if name in parser._option_string_actions:
        return name
    if (prefix or parser.allow_abbrev) and name.startswith("--"):
        matches = [o for o in parser._option_string_actions if o.startswith(name)]
        return matches[0] if len(matches) == 1 else None
    return None


def int_at_least(minimum: int, what: str, maximum: int | None = None):
    """An argparse type: an integer >= ``minimum`` (and <= ``maximum``), else an error saying it must be ``what``."""

    def parse(text: str) -> int:
        try:
            value = _whole_number(text)
        except OverflowError:  # a whole number past 1e300: out of any range, said without its digits spelt out
            bound = "" if maximum is not None or text.lstrip().startswith("-") else ", at most 1e300"
            raise argparse.ArgumentTypeError(f"must be {what}{bound}, got {text}") from None
        if value is None:
            raise argparse.ArgumentTypeError(f"{text!r} is not an integer")
        if value < minimum or (maximum is not None and value > maximum):
            raise argparse.ArgumentTypeError(f"must be {what}, got {value}")
        return value

    return parse


def _whole_number(text: str) -> int | None:
    """``text`` as an int, also where written in exponent notation or with a zero fraction (``--n-rays 1e5``,
    ``1000.0``), as a ``sphere:1e6`` scene name and a suite's ``"n_rays": 1000.0`` are (``1000.0`` was refused as 'not
    an integer' here alone); None for anything else, a fraction (``2.5``, ``2.5e0``) included. OverflowError for a
    whole number past 1e300 (:func:`whole_number`)."""
    try:
        return int(text)
    except ValueError:
        return whole_number(text)


def whole_number(text: str) -> int | None:
    """The int that decimal number ``text`` (``1e5``, ``2.5e1``, ``1000.0``, ``0e400``) writes exactly, or None where
    it writes none: a fraction, a word, NaN, infinity. Read in decimal: a float rounded ``1.00000000000000001e0`` to
    1, a whole number, and ``12345678901234567e0`` to ...568.

    Raises:
        OverflowError: for a whole number past 1e300 in size (``1e301``), which is made no int (``1e999999999``
            would take minutes, and a message would spell out its digits): a range check names it too large. It
            was None, 'not a whole number', as was ``0e400``, which is 0."""
    try:
        number = decimal.Decimal(text)
    except decimal.InvalidOperation:
        return _past_decimals_exponents(text)
    if not number.is_finite() or number != number.to_integral_value():
        return None
    if number.is_zero():
        return 0
    if number.adjusted() > 300:
        raise OverflowError(f"{text} is past 1e300")
    return int(number)



# A decimal number in exponent notation (digits grouped by '_' as decimal.Decimal and int() read them).
_DIGITS = r"\d+(?:_\d+)*"
_EXPONENT_NOTATION = re.compile(rf"\s*[+-]?({_DIGITS}(?:\.(?:{_DIGITS})?)?|\.{_DIGITS})[eE]([+-]?{_DIGITS})\s*")
DECIMAL_EXPONENT_LIMIT = 999_999_999_999_999_999  # decimal.Decimal reads no exponent past this (libmpdec's MAX_EMAX)


def _past_decimals_exponents(text: str) -> int | None:
    """:func:`whole_number` of a ``text`` that ``decimal.Decimal`` refuses: a number whose exponent is past
    :data:`DECIMAL_EXPONENT_LIMIT` (``1e99999999999999999999``, called 'not an integer' though it is a whole number
    past 1e300; ``0e99999999999999999999``, which is 0) is read from its mantissa and the exponent's sign, as no
    mantissa written comes near that many digits; None for anything else Decimal refuses (a word, a stray '_')."""
    match = _EXPONENT_NOTATION.fullmatch(text)
    if match is None:
        return None
    mantissa, exponent = match.groups()
    if abs(int(exponent)) <= DECIMAL_EXPONENT_LIMIT:  # Decimal refused it for another reason: no number
        return None
    if not mantissa.strip("0._"):
        return 0
    if exponent.startswith("-"):
        return None  # a fraction: 1e-99999999999999999999
    raise OverflowError(f"{text} is past 1e300")

positive_int = int_at_least(1, "a positive integer")
non_negative_int = int_at_least(0, "a non-negative integer")


def _non_empty(text: str) -> str:
    """An argparse type: a value that is not empty (or blank), as an unset shell variable gives (``--frames "$F"``):
    taken as no option, it rendered a still image, or wrote into the current folder; a scene ``''`` was the current
    folder ('.: a directory'), or no scene (``wrt preview ''`` showed the bundled room)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty")
    return text


def _path(text: str) -> str:
    """An argparse type: a file or folder name, not empty, with a leading ``~`` (``~user``) read as the home folder, as
    a shell reads it where it expands one: ``--log=~/a.jsonl``, a quoted ``'~/a.png'`` or a name from a script wrote
    into a folder named ``~`` in the current one."""
    return _home(_non_empty(text))


def _home(text: str) -> str:
    """An argparse type: :func:`_path`'s ``~`` alone, for a value whose emptiness its command names itself."""
    return os.path.expanduser(text)


def _log_file(text: str) -> str:
    """An argparse type for ``--log``: a file name. One ending in a path separator names a folder (as ``-o out/``
    does), which ``Path()`` turned into a file of that name: ``--log logs/`` wrote the rows into a file ``logs``."""
    text = _path(text)
    if _names_a_folder(text):
        raise argparse.ArgumentTypeError(f"{text} names a folder; give the log a file name, e.g. "
                                         f"{text}render-log.jsonl")
    return text


def _finite_float(text: str) -> float:
    """An argparse type: a finite number (``inf`` or ``nan`` would write an all-white or all-black image)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return value


def _positive_float(text: str) -> float:
    """An argparse type: a finite number above 0 (``--ao-radius``: refused before the scene loads, not after)."""
    value = _finite_float(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


def _exposure(text: str) -> float:
    """An argparse type: an exposure :meth:`wrt.Image.save` accepts (checked before the render, not after it)."""
    from .image import check_exposure

    try:
        return check_exposure(_finite_float(text))
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None


def _memory_size(text: str) -> int:
    """An argparse type: a ``--max-memory`` size in bytes, above 0 (read before any scene is loaded: it was read after
    each load, its error without the option's name, and 0 refused every render)."""
    from .resources import parse_bytes

    try:
        value = parse_bytes(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a size above 0, got {text}")
    return value


def _refine_level(text: str) -> int:
    """An argparse type: a subdivision refine level, 0 to ``MAX_REFINE_LEVEL``."""
    from .subdivision import MAX_REFINE_LEVEL

    return int_at_least(0, f"0 to {MAX_REFINE_LEVEL}", MAX_REFINE_LEVEL)(text)  # whole numbers as --spp reads them


REFINE_HELP = ("subdivision steps for meshes by their subdivisionScheme (catmullClark, USD's fallback; loop, for "
               "triangle meshes; bilinear), as Hydra's refine level; each step makes 4x the faces. 0 draws the control "
               "cage, smooth-shaded")


CAMERA_HELP = ("camera prim path; default: the stage's RenderSettings camera, else its first camera, else one framing "
               "the scene")
# 'default: the default time' said nothing to a user who does not know USD's Default time code, nor how wrt reads an
# attribute that has only time samples there (value_at: its first).
TIME_HELP = "USD time code to read the stage at; default: USD's default time (each value authored without a time, " \
    "else its first time sample)"
VIEW_SETTINGS = "camera, resolution, aspect ratio conform, data window, included and material binding purposes"
SETTINGS_HELP = f"RenderSettings prim to follow ({VIEW_SETTINGS}, products)"
PREVIEW_SETTINGS_HELP = f"RenderSettings prim to follow ({VIEW_SETTINGS})"  # preview writes no products


def _variant(text: str) -> str:
    """An argparse type: a ``--variant`` value, ``PRIM:SET=VARIANT`` (checked before any scene is loaded)."""
    from .usd_variants import parse_variant

    try:
        parse_variant(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text


def add_stage_options(p, settings_help: str = SETTINGS_HELP) -> None:
    """``--variant`` and ``--render-settings``: how a command composes and reads the stages it loads (``settings_help``:
    what of the settings the command follows)."""
    p.add_argument("--variant", action="append", default=[], type=_variant, metavar="PRIM:SET=VARIANT",
                   help="select a variant before the stage is read, e.g. /World/Car:paint=red (repeatable; applied "
                   "in order on the session layer, the file is not changed)")
    p.add_argument("--render-settings", metavar="PRIM", type=_non_empty,
                   help=f"{settings_help}; default: the one the stage's renderSettingsPrimPath names")


def _seed(text: str) -> int:
    """An argparse type: a render seed (checked before any scene is loaded)."""
    from .render import MAX_SEED, check_seed

    try:
        value = _whole_number(text)  # '3.0' and '1e3' as --spp reads them (int() refused both)
    except OverflowError:
        value = text  # past 1e300: check_seed names it out of range
    if value is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer")
    try:
        return check_seed(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"seed must be an integer from 0 to {MAX_SEED}, got {text}") from None


def _add_render(sub) -> None:
    p = sub.add_parser(
        "render",
        help="render a USD scene to an image",
        description="Render a USD scene with wrt's ray tracer. With no SCENE, renders the bundled default room.",
        formatter_class=HelpFormatter,
    )
    p.add_argument(
        "scene",
        nargs="*",
        type=_path,
        help="USD files (.usd, .usda, .usdc, .usdz); default: the bundled room. With several, each is rendered in "
        "turn, a failing one is recorded in the log and the others go on",
    )
    p.add_argument(
        "-o",
        "--output",
        type=_path,
        help="output image (.png 8-bit sRGB, .exr linear HDR, .npy linear float); default wrt.png (frame_####.png "
        "with --frames); {stem} stands for "
        "the scene file name without extension; a name ending in / is a folder for {stem}.png ({stem}_####.png with "
        "--frames). With several scenes: "
        "a pattern with {stem} or a folder; default {stem}.png",
    )
    p.add_argument("--log", help="JSON-lines log, one flushed row per scene (per frame with --frames) as it "
                   "finishes, and after Ctrl-C a row of status interrupted for each cut short; default with several "
                   "scenes: render-log.jsonl in the folder that holds all the images (out/ for -o out/{stem}/)",
                   type=_log_file)
    p.add_argument("--max-memory", type=_memory_size, help="refuse renders predicted to need more than this many "
                   "bytes: a number with an optional K, M, G or T suffix (powers of 1024), e.g. 4G; default: no limit "
                   "but the device's free memory")
    p.add_argument("--width", type=positive_int, help="image width in pixels; default: the stage's RenderSettings "
                   "resolution, else 640 (given alone: the camera's aspect fixes the height)")
    p.add_argument("--height", type=positive_int, help="image height in pixels; default: the stage's RenderSettings "
                   "resolution, else 480 (given alone: the camera's aspect fixes the width)")
    p.add_argument("--camera", type=_non_empty, help=CAMERA_HELP)
    add_stage_options(p)
    p.add_argument("--spp", type=int_at_least(1, "an integer from 1 to 2^31 - 1", MAX_SPP), default=1,
                   help="samples per pixel")
    p.add_argument("--seed", type=_seed, default=0, help="seed of every random decision (jitter, lens, paths)")
    # No default here: given with --devices or --dask, which choose the devices, it was dropped without a word.
    p.add_argument("--device", type=_non_empty, help="Warp device, e.g. cpu or cuda:0; default: cpu (with --frames, "
                   "--devices or --dask choose the devices instead)")
    builders = [b.value for b in Builder] + ["binned_sah"]
    builders += [b for b in WARP_BUILDERS if b not in builders]  # cubql: wp.Mesh's alone
    p.add_argument("--builder", default="sah", choices=builders, help="BVH builder: with --accel wrt, any but cubql; "
                   "with --accel warp, wp.Mesh's: sah, median, lbvh (CUDA only: sah on the CPU) or cubql")
    p.add_argument("--accel", default="wrt", choices=ACCELERATORS, help="wrt's BVH or Warp's wp.Mesh (triangles "
                   "only: with warp, gprims such as spheres and cubes are loaded as triangle meshes)")
    p.add_argument("--time", type=_finite_float, default=None, help=TIME_HELP)
    p.add_argument("--refine-level", type=_refine_level, default=0, metavar="N", help=REFINE_HELP)
    p.add_argument("--frames", type=_non_empty,
                   help="render time codes START:END[:STEP] (END included) of an animated stage, one image each; "
                   "OUTPUT's last run of # becomes the frame number, e.g. -o out/frame_####.png (a name without # gets "
                   "_#### before its extension). The BVH is kept "
                   "across frames: refitted when vertices move, only its top level rebuilt when instances move")
    p.add_argument("--resume", action="store_true", help="skip the scenes (frames) that the log (--log, or a batch's "
                   "default) says were finished with the same options, whose images are still as written; render "
                   "the others. --frames without --log: skip frames whose image exists")
    p.add_argument("--devices", help="with --frames: spread the frames over these Warp devices, comma-separated, "
                   "e.g. cuda:0,cuda:1, one worker process each (default: --device)", type=_csv_text)
    p.add_argument("--dask", nargs="?", const="", metavar="ADDRESS", help="with --frames: send the frames to the Dask "
                   "scheduler at ADDRESS (e.g. tcp://scheduler:8786), or without ADDRESS to a LocalCluster of one "
                   "worker per GPU, else per CPU core; each worker renders on its own device. Needs wrt[dask]")
    p.add_argument("--workers", type=positive_int, help="with --dask and no ADDRESS: LocalCluster worker count; "
                   "default: one per GPU, else per CPU core")
    p.add_argument("--aov-dir", help=f"also write every AOV ({', '.join(AOV_NAMES)}) as NAME.npy into this folder, "
                   "with several scenes into its subfolder STEM/, with --frames as NAME_####.npy, numbered as the "
                   "images", type=_path)
    p.add_argument("--products", metavar="DIR", help="write every RenderProduct of the stage's RenderSettings into "
                   "DIR instead of one image, each at its own camera and resolution, its RenderVars (color, depth, "
                   "normal, primId, ...) as channels: DIR/<file name of productName>, PNG for a beauty alone, else "
                   "EXR. Not with -o, --width, --height, --camera, --aov, --aov-dir, --frames, --resume, --log, "
                   "--max-memory or several scenes", type=_path)
    from .integrators import INTEGRATORS

    p.add_argument("--integrator", default="whitted", choices=INTEGRATORS, help="light transport: whitted (shadows, "
                   "mirrors, glass), path (Monte Carlo path tracing), ao, or the quick looks normals/depth/albedo")
    depths = ", ".join(f"{depth} ({name})" for name, depth in DEFAULT_MAX_DEPTH.items())
    p.add_argument("--max-depth", type=int_at_least(0, f"an integer from 0 to {MAX_DEPTH}", MAX_DEPTH), default=None,
                   help=f"bounces per path; default {depths}")
    p.add_argument("--ao-radius", type=_positive_float, default=None,
                   help="ao distance, in scene units; default a tenth of the diagonal of the scene's box")
    p.add_argument("--exposure", type=_exposure, default=0.0,
                   help=f"PNG only: scale the image by 2^EXPOSURE (in stops, from -{MAX_EXPOSURE:g} to "
                   f"{MAX_EXPOSURE:g}) before sRGB; not the {' and '.join(DATA_INTEGRATORS)} integrators' images, "
                   "which are data stored as they are")
    p.add_argument("--aov", action="append", default=[], choices=AOV_NAMES, help="also write a PNG preview of "
                   "this AOV beside the image as OUTPUT.NAME.png (repeatable): normals as 0.5 (n + 1), depth as grey "
                   "levels, ids as random colours, cost as heat maps of nodes visited and triangles tested")
    p.add_argument("-q", "--quiet", action="store_true", help="print no progress lines")
    p.set_defaults(run=_run_render)


def _names_a_folder(output: str) -> bool:
    """Whether ``-o`` ends in a path separator: a folder, which ``Path()`` would turn into a file name."""
    return output.endswith(("/", os.sep))


def _check_not_an_existing_folder(output: str) -> None:
    """Raises IsADirectoryError when ``-o`` names a folder that exists without the ``/`` that makes it one
    (``-o renders``): the error was that ``renders`` (or ``renders_0001`` with --frames) is no image format."""
    if not _names_a_folder(output) and Path(output).is_dir():
        raise IsADirectoryError(f"cannot write {output}: it is a directory; -o {output}/ writes the image into it")


def _warn_unknown_placeholders(output: str) -> None:
    """A warning for each ``{word}`` of ``-o`` other than ``{stem}``: braces are kept in the file name as they are, so a
    misspelt placeholder ('{steam}') named the image '{steam}.png' without a word."""
    for token in dict.fromkeys(re.findall(r"\{\w*\}", output)):
        if token != "{stem}":
            warnings.warn(f"-o {output}: {token} is no placeholder, kept in the file name as it is"
                          f"{did_you_mean(token, ['{stem}'])}; -o's placeholders are {{stem}}, the scene file name "
                          "without extension, and with --frames a run of #, the frame number", stacklevel=2)


def _refuse_images_as_scenes(paths: list, formats: tuple) -> None:
    """Raises ValueError for a scene argument named as an image the command writes, and not there: 'wrt render
    scene.usda out.png' rendered scene.png, then failed on out.png as a scene that was not found. An image that
    exists (a thumbnail a glob took in) fails as a scene of its own, and a batch goes on past it."""
    for path in paths:
        if path.suffix.lower() in formats and not path.exists():
            raise ValueError(f"{path} is an image name, not a USD scene; name the image to write with -o {path}")


def _output_for(args, path: Path, several: bool) -> Path:
    """Where the image of scene ``path`` goes (see ``--output``)."""
    if not several:  # {stem} too: a script's pattern works for one scene as for several
        output = (args.output or "wrt.png").replace("{stem}", path.stem)
        if _names_a_folder(output):  # as for several scenes
            return Path(output) / f"{path.stem}.png"
        _check_not_an_existing_folder(output)
        return Path(output)
    pattern = args.output or "{stem}.png"
    if "{stem}" in pattern:  # replaced as text: other braces are part of the name, not format fields
        output = pattern.replace("{stem}", path.stem)
        # A folder per scene (-o out/{stem}/), as for one scene: Path() dropped the '/', making 'out/room' an image.
        return Path(output) / f"{path.stem}.png" if _names_a_folder(output) else Path(output)
    from .image import IMAGE_FORMATS

    if Path(pattern).suffix.lower() in IMAGE_FORMATS:  # one image name for several scenes: not a folder name
        raise ValueError(f"-o {pattern} names one image for {len(args.scene)} scenes; give a folder or a pattern "
                         "with {stem}, e.g. -o out/{stem}.png")
    return Path(pattern) / f"{path.stem}.png"


def _check_output_location(directory: Path) -> None:
    """Raises NotADirectoryError when ``directory`` cannot be created because a file stands in its way, and an
    OSError when its nearest existing folder takes no files (no write permission, a read-only file system)."""
    import tempfile

    for ancestor in (directory, *directory.parents):
        if ancestor.exists():
            if not ancestor.is_dir():
                raise NotADirectoryError(f"cannot write into {directory}: {ancestor} is a file, not a directory")
            try:  # a file made and removed at once: the only test that holds for root and every file system
                with tempfile.TemporaryFile(dir=ancestor):
                    pass
            except OSError as e:
                # ENOENT for a folder that is there: its file system makes no files (/proc); 'No such file or
                # directory' named no reason.
                why = "its file system makes no files" if e.errno == errno.ENOENT else e.strerror
                raise OSError(f"cannot write into {directory}: {ancestor} takes no new files ({why})") from None
            return


def _name_max(path: Path) -> int:
    """The longest file name, in bytes, that the file system holding ``path`` (or its nearest existing folder) takes:
    ``NAME_MAX`` of ``pathconf``, 255 where it cannot say (Linux, macOS and Windows file systems)."""
    from .animation import MAX_NAME_BYTES

    for folder in path.parents:
        try:
            if folder.is_dir():
                return os.pathconf(folder, "PC_NAME_MAX")
        except (OSError, ValueError, AttributeError):  # a name too long on the way, no pathconf (Windows)
            continue
    return MAX_NAME_BYTES


def _check_name_lengths(paths: list) -> None:
    """Raises the OSError a write would (ENAMETOOLONG, naming the path up to that name) for the first of ``paths``
    with a name (of the file or of a folder on its way) longer than its file system takes. Where its folder did not
    exist yet (-o out/{stem}.png), the file system could not say so before the folder was made, and the write failed
    after the render."""
    for path in map(Path, paths):
        limit = _name_max(path)
        for part in (*reversed(path.parents[:-1]), path):  # the first part too long, named as the file system would
            if len(os.fsencode(part.name)) > limit:
                raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG), str(part))


def _check_output_file(path: Path) -> None:
    """Raises an OSError naming ``path`` when a file cannot be written there: it is a directory, or a file stands
    where one of its folders must go. Called before the work whose result goes there."""
    if path.is_dir():
        raise IsADirectoryError(f"cannot write {path}: it is a directory")
    _check_output_location(path.parent)


def _check_log_path(log: Path, outputs: list, scenes: list) -> None:
    """Raises ValueError when the log would be written where an image goes, or where a folder of the images must be
    created (``-o out --log out``): the run would fail at its first log row, after the first render; or into one of
    the ``scenes`` read: its rows would be appended to the USD file, breaking it; or into a file that is no log."""
    given, log = log, log.resolve()
    for scene in scenes:
        if log == Path(scene).resolve():
            raise ValueError(f"--log {log} is the scene file {scene}; its rows would be appended to it: give the log "
                             "a file name of its own, e.g. --log render-log.jsonl")
    for output in outputs:
        output = output.resolve()
        if log == output or log in output.parents:
            raise ValueError(f"--log {log} is where {output} or its folder goes; give the log a file name "
                             "of its own, e.g. --log render-log.jsonl")
    from .image import IMAGE_FORMATS

    # -o and --log swapped: the rows went into a new file named out.png. A folder of that name is refused as such below.
    if given.suffix.lower() in IMAGE_FORMATS and not given.is_dir():
        raise ValueError(f"--log {given} names an image; the log is JSON lines: give it a file name of its own, e.g. "
                         "--log render-log.jsonl, and the image with -o")
    from .render_log import check_appendable

    # As given: /dev/stdout, a pipe, resolves to /proc/PID/fd/pipe:[N], named by a failed check of its folder.
    check_appendable(given)
    if not given.exists() or given.is_dir():  # one there (a file, /dev/null) is appended to; its folder is no matter
        _check_output_file(log)


def _warn_unused_exposure(exposure: float, outputs: list, integrator: str) -> None:
    """One warning when ``--exposure`` is given but some outputs are linear (``.exr``, ``.npy``), which it leaves
    as they are, or the integrator's image is data (:data:`wrt.render.DATA_INTEGRATORS`), which a PNG stores as it
    is: a user asking for a brighter image would otherwise get the same file without a word."""
    from .image import DATA_EXPOSURE_WARNING

    linear = [Path(o) for o in outputs if Path(o).suffix.lower() != ".png"]
    if exposure != 0.0 and integrator in DATA_INTEGRATORS:
        warnings.warn(DATA_EXPOSURE_WARNING.format(what="--exposure", image=f"the {integrator} integrator's image"),
                      stacklevel=2)
    elif exposure != 0.0 and linear:
        warnings.warn(f"--exposure applies to .png images only; {linear[0].name} is written linear, unscaled",
                      stacklevel=2)


def _png_exposure(args) -> float:
    """The exposure a render's PNGs get: none for a data image (said once by :func:`_warn_unused_exposure`, before the
    render, and not again by each ``Image.save``)."""
    return 0.0 if args.integrator in DATA_INTEGRATORS else args.exposure


def _warn_unused_integrator_options(args) -> None:
    """A warning for ``--ao-radius``, ``--max-depth`` or ``--spp`` above 1 given to an integrator that does not read
    it: the image was the one without it, without a word."""
    from .integrators import INTEGRATORS

    if args.spp > 1 and args.integrator in QUICK_LOOKS:
        sampled = [name for name in INTEGRATORS if name not in QUICK_LOOKS]
        warnings.warn(f"--spp applies to --integrator {', '.join(sampled[:-1])} and {sampled[-1]} only; "
                      f"{args.integrator} draws one sample per pixel, through its centre", stacklevel=2)
    if args.ao_radius is not None and args.integrator != "ao":
        warnings.warn(f"--ao-radius applies to --integrator ao only; {args.integrator} does not use it", stacklevel=2)
    if args.max_depth is not None and args.integrator not in DEFAULT_MAX_DEPTH:
        warnings.warn(f"--max-depth applies to --integrator {' and '.join(DEFAULT_MAX_DEPTH)} only; "
                      f"{args.integrator} does not use it", stacklevel=2)


def _check_builder(args) -> None:
    """Refuses, before any load, a ``--builder`` that ``--accel`` has not (wrt's ploc for wp.Mesh was refused after
    the load, in the library's words, ``accel='warp'``); warns once where wp.Mesh builds another tree than the one
    asked for: lbvh on the CPU, which Warp itself said in its own raw words (see :func:`_built_builder`)."""
    if args.accel == "warp" and args.builder not in (*WARP_BUILDERS, *ALIASES):
        raise ValueError(f"--builder {args.builder} builds wrt's BVH (--accel wrt); --accel warp builds Warp's "
                         f"wp.Mesh, whose builders are {', '.join(WARP_BUILDERS)}")
    wrt_builders = [b.value for b in Builder]
    if args.accel == "wrt" and args.builder not in (*wrt_builders, *ALIASES):
        raise ValueError(f"--builder {args.builder} builds Warp's wp.Mesh (--accel warp); wrt's BVH (--accel wrt, the "
                         f"default) is built by {', '.join(wrt_builders)}")
    if _built_builder(args) != args.builder:
        device = f"--devices {args.devices}" if args.devices else f"--device {args.device}"
        warnings.warn(f"--builder lbvh with --accel warp: wp.Mesh has no lbvh builder on the CPU ({device}), so it "
                      "builds its sah tree, which finds the same hits", stacklevel=2)


def _built_builder(args) -> str:
    """The builder that ``wrt render`` asks for: ``--builder``, but sah for wp.Mesh's lbvh where every device is a
    CPU, which Warp builds instead after a warning of its own (``LBVH constructor is not available``)."""
    if args.accel != "warp" or args.builder != "lbvh" or args.dask is not None:  # Dask's workers pick devices
        return args.builder
    from .bvh.common import resolve_device_option

    devices = [d.strip() for d in (args.devices or args.device).split(",") if d.strip()]
    try:
        cpu_only = all(resolve_device_option(d).is_cpu for d in devices)
    except ValueError:  # a device that does not exist: named where the devices are checked
        return args.builder
    return "sah" if devices and cpu_only else args.builder


def _drawn_spp(args) -> int:
    """The samples per pixel a render draws: ``--spp``, but one for the quick looks, whatever ``--spp`` says."""
    return 1 if args.integrator in QUICK_LOOKS else args.spp


def _aov_png(image: Path, name: str) -> Path:
    """Where ``--aov NAME`` writes its preview of ``image``'s AOV: ``OUTPUT.NAME.png`` beside it."""
    return image.with_name(f"{image.stem}.{name}.png")


def _aov_folder(args, path: Path) -> Path:
    """Where ``--aov-dir`` writes the AOV arrays of scene ``path``: the folder, or its subfolder STEM in a batch."""
    return Path(args.aov_dir) / path.stem if len(args.scene) > 1 else Path(args.aov_dir)


def _files_written(args, path: Path, output: Path) -> list[Path]:
    """Every file a render of scene ``path`` writes: its image ``output`` first, then the ``--aov`` previews and the
    ``--aov-dir`` arrays (one per AOV of :data:`wrt.render.AOV_NAMES`, as ``Image.save_aovs`` writes them)."""
    files = [output] + [_aov_png(output, name) for name in args.aov]
    if args.aov_dir:
        files += [_aov_folder(args, path) / f"{name}.npy" for name in AOV_NAMES]
    return files


def _check_distinct_outputs(paths: list, files: list) -> None:
    """Raises ValueError when two files of a run would be written at one path, ``files`` holding per scene those
    :func:`_files_written` names: two scenes' images (they are named by the scene's file stem, so ``a/room.usda`` and
    ``b/room.usda`` meet), or an image and an AOV file (``-o d/depth.npy --aov-dir d``; ``a.depth.usda``'s image and
    ``a.usda``'s ``--aov depth`` preview). The later would overwrite the first without a word. Also when one file
    would be the folder of another (``-o d/a.png --aov-dir d/a.png``)."""
    first = {}  # resolved file -> (scene, whether it is that scene's image)
    for path, written in zip(paths, files):
        for index, file in enumerate(written):
            key = file.resolve()
            if key not in first:
                first[key] = (path, index == 0)
                continue
            other, other_image = first[key]
            if index == 0 and other_image and Path(other).resolve() == Path(path).resolve():  # one file named twice
                raise ValueError(f"{path} is given twice (as {other} and {path}); give each scene once")
            if index == 0 and other_image:
                raise ValueError(f"{other} and {path} would both write {file} (images are named by the scene's "
                                 "file name without extension); render them in separate runs or rename one")
            roles = [f"{'the image' if image else 'an AOV file'} of {scene}"
                     for scene, image in ((other, other_image), (path, index == 0))]
            raise ValueError(f"{file} would be written twice, as {roles[0]} and as {roles[1]}; give -o, --aov-dir "
                             "or the scene files other names")
    # A file of the run on the path of another, which needs it as a folder (-o out/a.png --aov-dir out/a.png):
    # refused here; it failed after the render, the image written, naming save_aovs and not the options.
    for key, (path, image) in first.items():
        folder = next((parent for parent in key.parents if parent in first), None)
        if folder is not None:
            other, other_image = first[folder]
            raise ValueError(f"cannot write {key}, {'the image' if image else 'an AOV file'} of {path}, into "
                             f"{folder}: that is {'the image' if other_image else 'an AOV file'} of {other}; give -o "
                             "and --aov-dir other names")


def _renderer_options(args) -> dict:
    """The :class:`wrt.Renderer` options of ``wrt render``'s arguments, all but the device. ``max_depth`` and
    ``ao_radius`` only for an integrator that reads them: the others were warned of in the flags' names
    (:func:`_warn_unused_integrator_options`), and the Renderer would say them again in its keywords'."""
    names = ("camera", "width", "height", "accel", "integrator")
    options = {**{name: getattr(args, name) for name in names}, "builder": _built_builder(args)}
    options["max_depth"] = args.max_depth if args.integrator in DEFAULT_MAX_DEPTH else None
    options["ao_radius"] = args.ao_radius if args.integrator == "ao" else None
    return options


def _load_options(args) -> dict:
    """The :func:`wrt.load_usd` options of ``wrt render``'s arguments. Gprims load as triangle meshes for ``--accel
    warp``, as wp.Mesh traces nothing else (the library refuses analytic shapes there and names
    ``tessellate_gprims``, an option the command line does not have)."""
    return {"tessellate_gprims": args.accel == "warp", **stage_options(args), "refine_level": args.refine_level}


def stage_options(args) -> dict:
    """The :func:`wrt.load_usd` options of ``--variant`` and ``--render-settings``."""
    from .usd_variants import variants_option

    return {"variants": variants_option(args.variant), "render_settings": args.render_settings}


def loaded_summary(name: str, stats: dict) -> str:
    """The progress line after a load (see :func:`wrt.scene.contents_summary`)."""
    from .scene import contents_summary

    return f"loaded {name}: {contents_summary(stats)}"


def _check_view_pixels(args, width: int, height: int, settings=None) -> None:
    """:func:`wrt.render.check_pixels` of the image a stage's ``settings`` and ``--width``/``--height`` make, its error
    naming those options where given and the settings where they gave a side (with -q nothing else said where the
    size came from). Checked after the load: a data window of the stage may crop a larger size."""
    from .render import check_view_pixels

    given = [f"--{name} {getattr(args, name)}" for name in ("width", "height") if getattr(args, name)]
    if settings is None:
        check_view_pixels(width, height, 1, given, None)
    else:
        check_view_pixels(width, height, 1, given, settings.product or settings.path,
                          windowed=(width, height) != settings.image_size(args.width, args.height))


def _render_one(args, path: Path, output: Path, progress) -> list[Path]:
    import wrt

    from .render import resolve_view, view_summary
    from .resources import check_memory, device_texture_bytes, estimate_render_bytes

    start = time.perf_counter()
    scene = wrt.load_usd(path, time=args.time, **_load_options(args))
    stats = scene.stats()
    loaded = loaded_summary(path.name, stats)
    progress(loaded, time.perf_counter() - start)
    settings = scene.render_settings
    # One image: say where the others are. Not with --camera: the image is then no product's shot.
    if settings is not None and len(settings.products) > 1 and args.camera is None:
        warnings.warn(f"{path.name}: {settings.path} has {len(settings.products)} RenderProducts; this image is the "
                      f"first's, {settings.product} (--products DIR writes them all)", stacklevel=2)
    camera, width, height = resolve_view(scene, args.camera, args.width, args.height)  # the stage's settings, if any
    if settings is not None:  # without it a --camera render took the first product's size without a word
        progress(f"view: {view_summary(settings, camera, width, height, args.camera, args.width, args.height)}")
    _check_view_pixels(args, width, height, settings)  # the limit is the clearer error where both apply
    if Path(output).suffix.lower() == ".exr":  # else refused by Image.save only after the whole render
        from .image import check_exr_pixel_aspect

        check_exr_pixel_aspect(camera.rendered_pixel_aspect(width, height), output)
    needed = estimate_render_bytes(stats["rendered_triangles"], width, height, args.spp, device_texture_bytes(scene))
    check_memory(needed, args.device, args.max_memory, f"rendering {path.name} at {width}x{height}")
    renderer = wrt.Renderer(scene, device=args.device, **_renderer_options(args))
    built = renderer.timers["build"][0] / 1000.0
    progress(f"built {args.accel} BVH ({_built_builder(args)}) on {renderer.device}", built)
    try:
        image = renderer.render(spp=_drawn_spp(args), seed=args.seed, progress=progress.bar)  # --spp warned of
    except KeyboardInterrupt:  # keep what a long render has so far, then stop as interrupted
        image = renderer.image_so_far()
        if image is not None:
            try:
                out = image.save(output, exposure=_png_exposure(args))
            except OSError as e:  # a full disk: still a stop; the OSError made a batch log an error and go on
                warnings.warn(f"interrupted after {renderer.samples_so_far} of {args.spp} spp; the image of those "
                              f"samples was not written: {error_line(e)}", stacklevel=2)
                raise KeyboardInterrupt from None
            # A warning, not a progress line: with -q the file under the final name was left without a word.
            warnings.warn(f"interrupted after {renderer.samples_so_far} of {args.spp} spp: wrote {out}, the image of "
                          "those samples only", stacklevel=2)
        else:  # said: README's partial image is of finished launches, and a render of few samples is one launch
            warnings.warn(f"interrupted before the first launch of samples finished: {output} was not written",
                          stacklevel=2)
        raise
    progress(
        f"rendered {width}x{height} at {_drawn_spp(args)} spp ({args.integrator})",
        renderer.timers["render"][0] / 1000.0,
    )
    out = image.save(output, exposure=_png_exposure(args))
    progress(f"wrote {out}")
    written = [Path(out)]
    for name in args.aov:
        written.append(image.save_aov_png(name, _aov_png(Path(out), name)))
        progress(f"wrote {written[-1]}")
    if args.aov_dir:
        for p in image.save_aovs(_aov_folder(args, path)):
            written.append(Path(p))
            progress(f"wrote {p}")
    return written  # the image first, then its AOV files


def _log_options(args) -> dict:
    """The row fields of :data:`wrt.render_log.OPTION_FIELDS`, as this run's arguments give them."""
    from .render_log import OPTION_FIELDS

    return {name: getattr(args, name) for name in OPTION_FIELDS if hasattr(args, name)}


def _resume_kinds(args):
    """The device kinds whose images ``--resume`` takes for this run's, or None (any) under ``--dask``, whose
    workers pick their own devices."""
    from .render_log import device_kind

    if args.dask is not None:
        return None
    return {device_kind(d.strip()) for d in (args.devices or args.device).split(",") if d.strip()}


def _finished_images(args, log: Path, jobs: list, options: dict, progress) -> dict:
    """``--resume``: of ``jobs`` (``(scene, image, name)``: name as the progress lines call it), those whose image
    the log says is finished with this run's ``options`` (see :func:`_log_options`), by image path -> that row;
    says why each other one that the log names is rendered again."""
    from .render_log import ResumeIndex, read_rows

    if not log.exists():  # said: a mistyped --log, or a log moved, rendered everything again without a word
        warnings.warn(f"--resume: no log at {log}, so nothing is known to be finished: every "
                      f"{'frame' if args.frames else 'scene'} is rendered", stacklevel=2)
    index = ResumeIndex(read_rows(log))
    kinds, done = _resume_kinds(args), {}
    again = collections.defaultdict(list)  # each reason once, with its scenes or frames: 240 frames are one line
    for scene, image, name in jobs:
        row, why = index.finished(scene, image, options, kinds)
        if row is not None:
            done[image] = row
        elif why:
            again[why].append(name)
    for why, names in again.items():
        more = f" and {len(names) - 6} more" if len(names) > 6 else ""
        progress(f"--resume: rendering {', '.join(names[:6])}{more} again: {why}")
    return done


def _run_render(args) -> int:
    from .errors import SceneError
    from .strict_json import strict_json

    progress = _Progress(args.quiet)
    paths = [Path(s) for s in args.scene] or [default_scene_path()]
    # An AOV given twice is one file: written once, and logged once so that --resume finds the same options.
    args.aov = list(dict.fromkeys(args.aov))
    from .image import IMAGE_FORMATS

    _refuse_images_as_scenes(paths, IMAGE_FORMATS)
    # Options that another one overrides would be dropped without a word.
    if args.workers is not None and args.dask != "":
        raise ValueError("--workers sizes the LocalCluster of --dask without an ADDRESS; it applies to nothing else")
    if args.devices and args.dask is not None:
        raise ValueError("give --devices or --dask, not both: Dask workers each render on their own device")
    if args.device is not None and (args.devices or args.dask is not None):  # it would be dropped without a word
        others = "--devices" if args.devices else "--dask"
        raise ValueError(f"give --device or {others}, not both: {others} chooses the devices the frames render on")
    args.device = args.device or "cpu"
    _warn_unused_integrator_options(args)
    _check_builder(args)
    if not (args.devices or args.dask is not None):  # those choose their own devices, checked where they are used
        from .bvh.common import resolve_device_option
        from .trace import resolve_threads

        # One error before any load, not one per scene of a batch after its load; so for $WRT_THREADS, read on the CPU
        resolve_threads(None, resolve_device_option(args.device))
    if args.products is not None:
        return _run_products(args, paths, progress)
    if args.output:
        _warn_unknown_placeholders(args.output)
    if args.frames:
        return _run_frames(args, paths, progress)
    if args.devices or args.dask is not None:
        raise ValueError("--devices and --dask apply to --frames only")
    if args.output and "#" in args.output:  # a pattern of frames: --frames left out renders one image, named so
        warnings.warn(f"-o {args.output}: a run of # is the frame number with --frames only; without it one image is "
                      "rendered, its file name keeping the # as they are", stacklevel=2)
    several = len(paths) > 1
    if args.resume and not (several or args.log):  # one scene writes no log without --log: nothing to resume from
        raise ValueError("--resume reads the log of an earlier run; give it with --log FILE (a batch of several "
                         "scenes has one by default)")
    from .image import check_image_path

    outputs = [_output_for(args, p, several) for p in paths]
    files = [_files_written(args, path, output) for path, output in zip(paths, outputs)]
    _check_distinct_outputs(paths, files)
    for output in outputs:  # an unwritable output fails now, not after a long render
        _check_output_file(check_image_path(output))
    _check_name_lengths([file for written in files for file in written])  # its --aov previews' longer names too
    _warn_unused_exposure(args.exposure, outputs, args.integrator)
    if args.aov_dir:
        _check_output_location(Path(args.aov_dir))
    if not several and not args.log:
        _render_one(args, paths[0], outputs[0], progress)  # errors: one line, exit 2
        return 0
    log = Path(args.log) if args.log else _batch_log(outputs, args.resume, progress)
    _check_log_path(log, [file for written in files for file in written], paths)
    from .render_log import append_row, carried_files, mtime_ns, new_run, skipped_fields

    jobs = [(path, output, path.name) for path, output in zip(paths, outputs)]
    options = _log_options(args)
    done = _finished_images(args, log, jobs, options, progress) if args.resume else {}
    log.parent.mkdir(parents=True, exist_ok=True)
    from .bvh.common import resolve_device_option

    run, device = new_run(), str(resolve_device_option(args.device))  # cuda:0 where --device said cuda
    failures = []

    def write_row(row: dict, start: float) -> None:
        row["seconds"] = round(time.perf_counter() - start, 3)
        append_row(log, strict_json(row))  # flushed per scene: an interrupted batch keeps every finished row

    for path, output in zip(paths, outputs):
        start = time.perf_counter()
        row = {**run, "scene": str(path), "output": str(output), **options, "device": device,
               "scene_mtime_ns": mtime_ns(path)}
        if output in done:  # the image and its AOV files as that run left them
            before = done[output]
            progress(f"--resume: skipped {path.name}: {output} is finished (run {before['run']}, same options)")
            write_row({**row, **skipped_fields(before), "aov_files": carried_files(before)}, start)
            continue
        try:
            image, *aovs = _render_one(args, path, output, progress)
            row.update(status="ok", output=str(image), output_mtime_ns=mtime_ns(image), aov_files=list(map(str, aovs)))
        except KeyboardInterrupt:  # its image, if written, holds the samples done: not to be taken for a finished one
            write_row(dict(row, status="interrupted"), start)
            raise
        except Exception as e:  # noqa: BLE001 - one failing scene must not stop the batch, as in wrt bench
            message = error_line(e)
            row.update(status="error", error=f"{type(e).__name__}: {message}")
            failures.append(row)
            # A Warning: one that Python's warning filters make an error (python -W error), as --frames takes it.
            if not isinstance(e, (SceneError, ValueError, TypeError, OSError, MemoryError, RuntimeError, Warning)):
                # Not bad input but a fault in wrt (an IndexError, a KeyError): its traceback, to report, and on.
                traceback.print_exc(file=sys.stderr)
                message = f"{type(e).__name__}: {message}"
            print(f"wrt: error: {message if path.name in message else f'{path}: {message}'}", file=sys.stderr)
        write_row(row, start)
    skipped = f", {len(done)} skipped (--resume: finished before)" if args.resume else ""
    rendered = len(paths) - len(failures) - len(done)
    progress(f"{counted_of(rendered, len(paths), 'scene')} rendered{skipped}; log in {log} (run {run['run']})")
    if failures:
        names = ", ".join(Path(r["scene"]).name for r in failures)
        print(f"wrt: {counted_of(len(failures), len(paths), 'scene')} failed: {names}", file=sys.stderr)
        return 1 if len(failures) < len(paths) else EXIT_BAD_INPUT  # none rendered: bad input, as a single render
    return 0


def _run_products(args, paths: list, progress) -> int:
    """``wrt render SCENE --products DIR``: every RenderProduct of the stage into DIR."""
    import wrt

    given = (("-o", args.output), ("--width", args.width), ("--height", args.height), ("--camera", args.camera),
             ("--aov", args.aov), ("--aov-dir", args.aov_dir), ("--frames", args.frames), ("--resume", args.resume),
             ("--devices", args.devices), ("--dask", args.dask is not None), ("--log", args.log),
             ("--max-memory", args.max_memory))
    unsupported = [name for name, value in given if value]
    if unsupported:  # each product names its own camera, size and file
        raise ValueError(f"{', '.join(unsupported)} cannot be combined with --products")
    if len(paths) != 1:
        raise ValueError("--products writes the products of one scene; give exactly one SCENE")
    directory = Path(args.products)
    _check_output_location(directory)
    start = time.perf_counter()
    scene = wrt.load_usd(paths[0], time=args.time, **_load_options(args))
    progress(loaded_summary(paths[0].name, scene.stats()), time.perf_counter() - start)
    start = time.perf_counter()
    options = _renderer_options(args)
    for name in ("camera", "width", "height"):  # each product names its own (refused above where given)
        del options[name]
    written = wrt.render_products(scene, directory, spp=_drawn_spp(args), device=args.device, seed=args.seed,
                                  exposure=args.exposure, progress=progress.bar, **options)
    progress(f"rendered {counted(len(written), 'product')} at {_drawn_spp(args)} spp ({args.integrator})",
             time.perf_counter() - start)
    for product, out in written.items():
        progress(f"wrote {out} ({product})")
    return 0


def _run_frames(args, paths: list, progress) -> int:
    from .animation import parse_frames, pending_frames, render_frames
    from .errors import SceneError
    from .usd_stage import missing_file, refuse_non_file

    if len(paths) != 1:
        raise ValueError("--frames renders one scene; give exactly one SCENE")
    given = (("--time", args.time is not None), ("--aov", args.aov), ("--max-memory", args.max_memory))  # --time 0 too
    unsupported = [name for name, value in given if value]
    if unsupported:
        # --aov's previews are quick looks of one image; every frame's AOVs are --aov-dir's arrays.
        hint = "; --aov-dir DIR writes every frame's AOVs as arrays" if unsupported == ["--aov"] else ""
        raise ValueError(f"{', '.join(unsupported)} cannot be combined with --frames{hint}")
    # One line before any frame, in load_usd's words: a folder or a pipe failed at every frame's load, each a row.
    if not paths[0].exists():
        raise SceneError(missing_file(paths[0]), path=str(paths[0]))
    refuse_non_file(str(paths[0]))
    frames = frames_asked = parse_frames(args.frames)
    # {stem} goes in once the frame is numbered: a # in the scene's name (shot#1.usda) is no frame placeholder.
    pattern = args.output or "frame_####.png"
    output = pattern.replace("{stem}", paths[0].stem)  # as for still images
    _check_not_an_existing_folder(output)
    from .image import check_not_extension_alone

    check_not_extension_alone(output)  # '.png' would become the pattern '.png_####', named as no image format
    if _names_a_folder(output):  # as for a still image: it became the pattern "out_####", no suffix
        pattern += "{stem}_####.png"
        output += f"{paths[0].stem}_####.png"
    from .image import check_image_path

    aov_pattern = _aov_pattern(args.aov_dir, pattern) if args.aov_dir else None
    # Without a log, --resume has only the files to go by: those on disk are skipped, whatever rendered them.
    jobs = pending_frames(frames, pattern, args.resume and not args.log, paths[0].stem, aov_pattern)
    # An unwritable output fails now, not after the first frame's load and render.
    for folder in {check_image_path(file).parent for _, file in jobs}:
        _check_output_location(folder)
    if aov_pattern is not None:
        from .animation import check_aov_pattern

        _check_output_location(Path(args.aov_dir))
        check_aov_pattern(aov_pattern, jobs)  # -o d/depth_####.npy --aov-dir d: refused before any frame
    _warn_unused_exposure(args.exposure, [output], args.integrator)
    from .render_log import append_row, carried_files, mtime_ns, new_run, skipped_fields
    from .strict_json import strict_json

    run, options = new_run(), {k: v for k, v in _log_options(args).items() if k not in ("time", "aov")}
    fields = {**run, "scene": str(paths[0]), **options, "scene_mtime_ns": mtime_ns(paths[0])}
    finished = {}
    skipped_rows = []  # (frame, the log row that finished it) of the frames --resume skips
    if args.log:
        log = Path(args.log)
        _check_log_path(log, [file for _, file in jobs], paths)
        if args.resume:
            named = [(paths[0], file, f"frame {f:g}") for f, file in jobs]
            finished = _finished_images(args, log, named, options, progress)
            log.parent.mkdir(parents=True, exist_ok=True)
            for frame, file in jobs:
                if file in finished:  # a row for it in this run too: each run's rows list every frame
                    before = finished[file]
                    skipped_rows.append((frame, before))
                    # Its AOV files too, as a batch's skipped rows carry them: the next --resume checks them. And its
                    # view: the next --resume says the views of the frames it skips from these rows (it said none).
                    aovs = {"aov_files": carried_files(before)} if "aov_files" in before else {}
                    view = {"view": before["view"]} if "view" in before else {}
                    append_row(log, strict_json({**fields, "frame": frame, "output": str(file),
                                                 **skipped_fields(before), **aovs, **view}))
            jobs = [(frame, file) for frame, file in jobs if file not in finished]
            if finished:
                progress(f"--resume: skipped {counted_of(len(finished), len(frames), 'frame')}: finished before, with "
                         f"the same options (see {log})")
    if len(jobs) < len(frames) and not args.log:
        progress(f"--resume: {counted_of(len(frames) - len(jobs), len(frames), 'frame')} already on disk")

    def log_row(row: dict) -> dict:
        """A frame's row as the log gets it: the run, the scene, the options, and the image's modification time."""
        if row.get("status") == "interrupted":  # cut short by Ctrl-C: no image of its own
            return {**fields, **row}
        status = {"status": "error"} if "error" in row else {"status": "ok", "output_mtime_ns": mtime_ns(row["output"])}
        return {**fields, **row, **status}
    devices = [d.strip() for d in args.devices.split(",") if d.strip()] if args.devices else [args.device]
    if not devices:
        raise ValueError(f"--devices {args.devices!r} names no device; give e.g. cuda:0,cuda:1")
    if args.dask is None:
        from .bvh.common import resolve_device_option

        for device in devices:  # before the first frame loads, naming the option
            resolve_device_option(device, "--devices" if args.devices else "--device")
    said = []  # the view said as the first frame finished

    def say_first_view(row: dict) -> None:
        """Says the view of the first frame drawn as it finishes, as a still render says its view before the image:
        the view lines came once every frame was drawn, hours into a long run."""
        if row.get("view") and not said:
            said.append(row["view"])
            progress(f"view: {row['view']}")

    common = {"spp": _drawn_spp(args), "seed": args.seed, "exposure": _png_exposure(args), "progress": progress.bar,
              "log": args.log, "log_row": log_row,  # a row per frame as it finishes: an interrupted run keeps them
              "on_row": say_first_view, "aov_pattern": aov_pattern}
    common.update(_renderer_options(args), **_load_options(args))
    start = time.perf_counter()
    if args.dask is not None:
        from .animation import render_frames_on_dask

        devices = ["dask " + (args.dask or "LocalCluster")]
        rows = render_frames_on_dask(paths[0], jobs, address=args.dask or None, n_workers=args.workers, **common)
    else:
        rows = render_frames(paths[0], jobs, devices=devices, **common)
    from .animation import warn_mixed_sizes

    # The view of each frame, as a still render says it: each once, with its frames where they differ (the first
    # frame's is said as it finishes: again here, with its frames). The frames --resume skipped too, by their rows
    # of the log: a run that skipped every frame said no view.
    views = collections.defaultdict(list)
    drawn = [*rows, *(dict(row, frame=frame) for frame, row in skipped_rows)]
    for row in sorted((row for row in drawn if row.get("view")), key=lambda row: row["frame"]):
        views[row["view"]].append(row["frame"])
    for view, frames in views.items():
        if len(views) > 1 or view not in said:
            progress(f"view: {view}" + (f" ({_frame_list(frames)})" if len(views) > 1 else ""))
    on_disk = sorted(frame for frame in frames_asked if frame not in {f for f, _ in jobs}) if not args.log else []
    if on_disk and _has_render_settings(paths[0], args.render_settings):
        # Skipped by their files alone: no row says their views, and a run that skipped every frame said none.
        progress(f"view: not known for {_frame_list(on_disk)}, skipped as on disk: --resume without --log keeps no "
                 "record of how they were drawn (with --log FILE, their rows say their views)")
    warn_mixed_sizes(paths[0], rows)
    failures = sorted((row for row in rows if "error" in row), key=lambda row: row["frame"])
    changes = collections.Counter(row["change"] for row in rows if "error" not in row)
    summary = ", ".join(f"{n} {c}" for c, n in sorted(changes.items()))
    done = counted(len(rows) - len(failures), "frame")
    progress(f"rendered {done} on {', '.join(devices)} (BVH: {summary or 'nothing to do'})",
             time.perf_counter() - start)
    # The other frames were rendered, as in a batch of scenes. Each message once, with its frames: the same problem
    # over 240 frames is one line.
    frames_of = collections.defaultdict(list)
    for row in failures:
        frames_of[_bad_input_words(row["error"])].append(row["frame"])
    for message, frames in frames_of.items():
        where = "" if paths[0].name in message else f"{paths[0]}: "
        print(f"wrt: error: {_frame_list(frames)}: {where}{message}", file=sys.stderr)
    if failures:
        # Of every frame asked, the frames --resume skipped as finished included, as a batch of scenes counts the
        # scenes it skipped: a resume whose one frame left failed exited 2, 'none rendered', where a batch exits 1.
        print(f"wrt: {counted_of(len(failures), len(frames_asked), 'frame')} failed", file=sys.stderr)
        return 1 if len(failures) < len(frames_asked) else EXIT_BAD_INPUT  # none rendered: bad input, as one render
    return 0


def _bad_input_words(error: str) -> str:
    """A frame row's ``error`` as ``wrt render`` says it: without the class of bad input (a ``SceneError``, an
    OSError such as a full disk at the frame's write), as a batch of scenes says its scenes' errors; the class of any
    other error stays."""
    import builtins

    kind, colon, message = error.partition(": ")
    quiet = kind == "SceneError" or (isinstance(getattr(builtins, kind, None), type)
                                     and issubclass(getattr(builtins, kind), OSError))
    return message if colon and quiet else error


def _has_render_settings(path: Path, given: str | None) -> bool:
    """Whether a render of the stage at ``path`` says its views: it has render settings, named by ``--render-settings``
    (``given``) or by the ``renderSettingsPrimPath`` of its root layer (stage metadata is read from there). Read from
    the root layer alone, not the composed stage: a resume that skips every frame loads nothing."""
    if given is not None:
        return True
    from pxr import Sdf

    try:
        layer = Sdf.Layer.FindOrOpen(str(path))
    except Exception:  # noqa: BLE001 - a layer USD cannot open: its frames' loads named the problem
        return False
    return bool(layer and layer.pseudoRoot.GetInfo("renderSettingsPrimPath"))


def _aov_pattern(aov_dir: str, pattern: str) -> str:
    """Where ``--aov-dir`` writes the AOVs of ``--frames`` (:func:`wrt.animation.aov_files`): ``DIR/NAME_####.npy``,
    the frame numbered as in the images (the last run of # of ``pattern``, ``-o`` with ``{stem}`` not yet replaced,
    as :func:`wrt.animation.frame_output` reads it; else ``####``). Read after the stem went in, a # in the scene's
    name (shot#1.usda, -o {stem}.png) numbered the AOVs depth_1.npy beside the images shot#1_0001.png."""
    from .animation import FRAME_PATTERN

    runs = FRAME_PATTERN.findall(pattern)
    return str(Path(aov_dir) / f"{{name}}_{runs[-1] if runs else '####'}.npy")


def _batch_log(outputs: list, resume: bool, progress) -> Path:
    """A batch's default log: render-log.jsonl in the folder that holds every image. With ``--resume``, where that
    one is missing and the first image's folder holds one, that one (read and extended): wrt before b7c6abd put a
    ``-o out/{stem}/`` batch's log in out/a/, and a resume of such a batch found no log and rendered every scene."""
    log = _common_folder(outputs) / "render-log.jsonl"
    older = outputs[0].parent / "render-log.jsonl"
    if resume and not log.exists() and older != log and older.is_file():
        progress(f"--resume: no log at {log}; reading and extending {older}, where an earlier wrt wrote it")
        return older
    return log


def _common_folder(outputs: list) -> Path:
    """The folder holding every one of ``outputs``, where a batch's log goes: ``-o out/{stem}/`` writes
    ``out/a/a.png`` and ``out/b/b.png``, and the log went into the first scene's folder, ``out/a``."""
    for folders in ([p.parent for p in outputs], [os.path.abspath(p.parent) for p in outputs]):
        try:  # as given (relative ones stay relative), else absolute: a pattern may mix them ('{stem}' a full path)
            return Path(os.path.commonpath(folders))
        except ValueError:
            pass
    return outputs[0].parent  # on different drives (Windows): no common folder


def _frame_list(frames: list, shown: int = 6) -> str:
    """``frame 2``, ``frames 2, 3, 7`` or ``frames 1, 2, 3, 4, 5, 6 and 234 more``."""
    names = [f"{f:g}" for f in frames[:shown]]
    more = f" and {len(frames) - shown} more" if len(frames) > shown else ""
    return f"frame {names[0]}" if len(frames) == 1 else f"frames {', '.join(names)}{more}"


def _window_size(text: str) -> tuple[int, int]:
    try:  # each side a whole number as every integer option reads one ('1280.0x800' was refused, int() alone)
        width, height = (_whole_number(v) for v in text.lower().split("x"))
    except (ValueError, OverflowError):
        width = height = None
    if width is None or height is None:
        raise argparse.ArgumentTypeError(f"{text!r} is not WIDTHxHEIGHT, e.g. 1280x800")
    from .preview import check_window_size

    try:
        check_window_size((width, height))
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return width, height


def _instance_choice(text: str) -> int | str:
    """``--bvh-instance``: an instance index (a whole number, written as every integer option may: ``1.0`` was taken
    for a path), else an instance path."""
    try:
        index = _whole_number(text.strip())
    except OverflowError:  # past 1e300: no index any scene has, said as a path that names no instance
        index = None
    return index if index is not None and index >= 0 else _non_empty(text)


def _add_preview(sub) -> None:
    p = sub.add_parser(
        "preview",
        help="show a USD scene, its camera, BVH and rays in a 3D view (pyvista)",
        description="Show the scene as wrt reads it, the camera frustum with its near clipping plane, the scene's "
        "lights and, on request, BVH boxes, sample camera rays and the rendered image, in an interactive pyvista "
        "window. With -o, or when there is no display or PYVISTA_OFF_SCREEN=true is set, the view is rendered "
        "off-screen to a PNG instead (preview.png without -o). Needs pyvista: pip install 'wrt[preview]'.",
        formatter_class=HelpFormatter,
    )
    p.add_argument("scene", nargs="?", type=_path,
                   help="USD file (.usd, .usda, .usdc, .usdz); default: the bundled room")
    p.add_argument("-o", "--output", type=_path,
                   help="write the view to this PNG instead of a window (no display, or PYVISTA_OFF_SCREEN=true: "
                   "preview.png)")
    p.add_argument("--camera", type=_non_empty, help=CAMERA_HELP)
    add_stage_options(p, PREVIEW_SETTINGS_HELP)
    bvh = p.add_mutually_exclusive_group()
    bvh.add_argument(
        "--bvh-depth",
        type=non_negative_int,
        metavar="K",
        help="draw the BVH cut at depth K (nodes at depth K plus shallower leaves; past the tree's deepest leaf, "
        "its leaves, with a warning)",
    )
    bvh.add_argument("--bvh-leaves", action="store_true", help="draw every BVH leaf")
    p.add_argument("--bvh-color", default="depth", choices=BVH_COLORINGS, help="BVH box colour: depth or SAH share")
    p.add_argument("--bvh-layout", default="binary", choices=LAYOUTS,
                   help="layout whose boxes --bvh-depth and --bvh-leaves draw: binary or compact (the same binary "
                   "tree), wide (BVH4) or wide8 (BVH8), collapsed as wrt traces it; only binary for a scene with "
                   "instances or analytic shapes")
    p.add_argument("--bvh-instance", type=_instance_choice, metavar="I", help="with --bvh-depth or --bvh-leaves, "
                   "draw the boxes of this instance's own BVH (its prototype's BLAS, placed by the instance's "
                   "transform) instead of the top-level BVH's: its index, or its path (/Instancer[3] for a "
                   "PointInstancer's)")
    p.add_argument(
        "--rays",
        type=int_at_least(0, f"an integer from 0 to {MAX_RAYS:,}", MAX_RAYS),  # checked before the scene loads
        default=0,
        metavar="N",
        help=f"draw N camera rays (at most {MAX_RAYS:,}) from the eye to their hits; misses end at the frustum's "
        "far end (the far clipping plane, or the scene's deepest corner where that is nearer) or where a camera "
        "clipping plane cuts them",
    )
    p.add_argument("--image", action="store_true", help="render with wrt and show the image on the image plane")
    p.add_argument("--width", type=positive_int, help="image width in pixels (frustum aspect, --image); default: the "
                   "stage's RenderSettings resolution, else 640 (given alone: the camera's aspect fixes the height)")
    p.add_argument("--height", type=positive_int, help="image height in pixels; default: the stage's RenderSettings "
                   "resolution, else 480 (given alone: the camera's aspect fixes the width)")
    p.add_argument("--window", type=_window_size, default="1280x800", metavar="WxH",
                   help="window (or PNG) size in pixels, WIDTHxHEIGHT")
    p.add_argument(
        "--max-triangles",
        type=positive_int,
        default=TRIANGLE_BUDGET,
        help="simplify the scene for display above this many triangles",
    )
    p.add_argument("--device", default="cpu", type=_non_empty, help="Warp device, e.g. cpu or cuda:0")
    builders = [b.value for b in Builder] + ["binned_sah"]
    p.add_argument("--builder", default="sah", choices=builders,
                   help="BVH builder of the boxes drawn (--bvh-depth, --bvh-leaves), the --rays and the --image")
    p.add_argument("--time", type=_finite_float, default=None, help=TIME_HELP)
    p.add_argument("--refine-level", type=_refine_level, default=0, metavar="N", help=REFINE_HELP)
    p.add_argument("-q", "--quiet", action="store_true", help="print no progress lines")
    p.set_defaults(run=_run_preview)


def _run_preview(args) -> int:
    import wrt

    from .preview import PreviewUnavailable, has_display, import_pyvista, preview

    progress = _Progress(args.quiet)
    path = Path(args.scene) if args.scene else default_scene_path()
    _refuse_images_as_scenes([path], (".png",))
    output = args.output
    no_window = None  # why no window opens without -o, if none does
    if output is None:
        try:  # pyvista's switch (PYVISTA_OFF_SCREEN=true) asks for no window, as a missing display does
            off_screen = import_pyvista().OFF_SCREEN
        except PreviewUnavailable as e:
            print(f"wrt: error: {e}", file=sys.stderr)
            return 1
        no_window = "no display found" if not has_display() else "PYVISTA_OFF_SCREEN is set" if off_screen else None
    if no_window:  # decided before the load, so that a preview.png that cannot be written fails now, not after it
        output = "preview.png"
    if args.output is not None:
        from .image import check_not_extension_alone

        if _names_a_folder(output) and not Path(output).is_dir():  # Path() drops the /: 'cannot write views: ...'
            raise ValueError(f"cannot write {output}: it names a folder; give the preview a .png file name, e.g. "
                             f"{output}preview.png")
        check_not_extension_alone(output)
        # An unwritable output fails now, not after the load and the preview; a folder as such, not as a name that
        # is no .png.
        _check_output_file(Path(output))
    if output is not None and Path(output).suffix.lower() != ".png":
        # Named as given, as wrt render names its -o; a name without an extension is told so, as render tells it
        # ('cannot write out: previews are written as .png' read as if its extension were a wrong one).
        from .image import no_extension_words

        missing = "" if Path(output).suffix else no_extension_words(Path(output))
        raise ValueError(f"cannot write {output}: {missing}previews are written as .png")
    if no_window:  # the default preview.png: checked now too, saying where the name comes from
        try:
            _check_output_file(Path(output))
        except OSError as e:
            raise type(e)(f"{no_window}, so the preview goes to preview.png: {e}; name a file with -o") from None
    from .bvh.common import resolve_device_option
    from .trace import resolve_threads

    resolve_threads(None, resolve_device_option(args.device))  # before the load, as the output; $WRT_THREADS too
    if args.bvh_instance is not None and args.bvh_depth is None and not args.bvh_leaves:  # before the load
        raise ValueError(f"--bvh-instance {args.bvh_instance} draws an instance's BVH boxes: give --bvh-depth K or "
                         "--bvh-leaves too")
    boxes = args.bvh_depth is not None or args.bvh_leaves
    if args.bvh_color != "depth" and not boxes:
        warnings.warn(f"--bvh-color {args.bvh_color} colours BVH boxes, and none are drawn without --bvh-depth K or "
                      "--bvh-leaves", stacklevel=2)
    if args.bvh_layout != "binary" and not boxes:
        warnings.warn(f"--bvh-layout {args.bvh_layout} picks the BVH whose boxes are drawn, and none are drawn without "
                      "--bvh-depth K or --bvh-leaves", stacklevel=2)
    start = time.perf_counter()
    scene = wrt.load_usd(path, time=args.time, refine_level=args.refine_level, **stage_options(args))
    stats = scene.stats()
    loaded = loaded_summary(path.name, stats)
    progress(loaded, time.perf_counter() - start)
    instance = args.bvh_instance
    if instance is not None:  # refused now, naming the flag: wrt.preview's errors name its keyword, bvh_instance=
        from .preview_blas import CLI_NAMES, instance_row

        instance = instance_row(scene, instance, CLI_NAMES)
    if args.bvh_depth is not None or args.bvh_leaves:  # without boxes the layout is only warned about, above
        from .preview_wide import check_drawn_layout  # refused now, naming the flag, as --bvh-instance is

        check_drawn_layout(scene, args.bvh_layout, "--bvh-layout {}", "--bvh-layout binary")
    if args.image:  # the film is rendered: refused now, naming the options, not inside the preview
        from .render import resolve_view

        _check_view_pixels(args, *resolve_view(scene, args.camera, args.width, args.height)[1:], scene.render_settings)
    if no_window:
        progress(f"{no_window}: rendering off-screen to preview.png")
    start = time.perf_counter()
    try:
        plotter = preview(
            scene,
            camera=args.camera,
            bvh_depth=args.bvh_depth,
            bvh_leaves=args.bvh_leaves,
            bvh_color=args.bvh_color if boxes else "depth",  # with no boxes, warned of above in the flags' names
            rays=args.rays,
            image=args.image,
            width=args.width,
            height=args.height,
            builder=args.builder,
            device=args.device,
            window_size=args.window,
            max_triangles=args.max_triangles,
            off_screen=output is not None,
            bvh_instance=instance,
            bvh_layout=args.bvh_layout if boxes else "binary",
        )
    except PreviewUnavailable as e:
        print(f"wrt: error: {e}", file=sys.stderr)
        return 1  # the machine, not the input, is the problem
    progress(plotter.title.removeprefix("wrt "), time.perf_counter() - start)
    if output is None:
        plotter.show()
        return 0
    from PIL import Image as PilImage

    from .image import write_atomically

    out = Path(output)
    start = time.perf_counter()
    pixels = plotter.screenshot()
    plotter.close()
    # Written by Pillow, not by pyvista's screenshot(path), which refuses a name ending in .PNG (after all the work).
    write_atomically(out, lambda target: PilImage.fromarray(pixels).save(target, format="PNG"))
    if pixels.std() == 0:
        warnings.warn(f"{out}: the off-screen view came out blank; VTK's OpenGL backend may be broken")
    progress(f"wrote {out}", time.perf_counter() - start)
    return 0


def _csv(text: str) -> list[str]:
    """An argparse type: a comma-separated list of at least one name (``--scenes ''`` is refused, as an unset shell
    variable gives it: an empty ``--threads`` measured no CPU row and exited 0), none of them empty."""
    items = [item.strip() for item in text.split(",")]
    _refuse_empty_entries(text, items)
    return items


def _refuse_empty_entries(text: str, items: list[str]) -> None:
    """Raises ArgumentTypeError for a list that names nothing, or one with an empty entry: a comma too many
    (``wrt:sah,``, ``a,,b``) was dropped without a word, where a name may have been left out."""
    if not any(items):
        raise argparse.ArgumentTypeError(f"names nothing, got {text!r}")
    if "" in items:
        raise argparse.ArgumentTypeError(f"entry {items.index('') + 1} of {len(items)} is empty (a comma too many?), "
                                         f"got {text!r}")


def _csv_text(text: str) -> str:
    """An argparse type: :func:`_csv`'s checks for a list kept as the text given (``wrt render --devices``)."""
    _csv(_non_empty(text))
    return text


def _scene_list(text: str) -> list[str]:
    """An argparse type: :func:`_csv` for ``--scenes``, but pieces that name a file when joined by their commas
    (``a,b.usda``) are one scene, unless the first names a file alone: a file whose name held a comma was measured
    as the files ``a`` and ``b.usda``, neither of them there."""

    def is_file(name: str) -> bool:
        # Files only: a folder 'a' beside 'a,b.usda' split it. A join of many pieces past 255 bytes (thirty
        # 'sphere:N') made pathlib raise 'File name too long' out of argparse, a traceback.
        try:
            return Path(os.path.expanduser(name)).is_file()
        except OSError:
            return False

    pieces, names = text.split(","), []
    while pieces:
        first = pieces[0].strip()
        alone = first and is_file(first)  # then no join is tried: a list of files costs a look per file
        take = 1 if alone else next((k for k in range(len(pieces), 1, -1) if is_file(",".join(pieces[:k]).strip())),
                                    1)
        # '~' after a comma is no shell's to expand: '~/b.usda' was a folder named '~' in the current one.
        names.append(os.path.expanduser(",".join(pieces[:take]).strip()))
        del pieces[:take]
    _refuse_empty_entries(text, names)
    return names


def _add_bench(sub) -> None:
    p = sub.add_parser(
        "bench",
        help="benchmark accelerators: scenes x accels x devices x ray kinds",
        description="Time wrt's BVH against Warp's wp.Mesh (and Embree) on the same rays. Rows are appended to "
        "OUT/rows.jsonl as they are measured; OUT/table.md and plots are written at the end. SUITE is a JSON file "
        "or the name of one in wrt/suites (quick, cpu, gpu). Options given here override the suite.",
        formatter_class=HelpFormatter,
    )
    p.add_argument("suite", nargs="?", default="quick", type=_path, help="suite file or name")
    p.add_argument("--quick", action="store_true",
                   help="run the small 'quick' suite (under a minute on a CPU, once the kernels are compiled)")
    suites = "; default: the suite's"  # each of these replaces one field of the suite
    p.add_argument("--scenes", type=_scene_list,
                   help="comma-separated scenes: paths, warp:NAME, asset:ID, sphere:N; only these are measured "
                   "(the suite's scaling sweep is left out)" + suites)
    p.add_argument("--accels", type=_csv,
                   help="comma-separated accelerators: wrt:BUILDER[:LAYOUT], warp:BUILDER, embree" + suites)
    p.add_argument("--devices", type=_csv, help="comma-separated Warp devices, e.g. cpu,cuda:0" + suites)
    p.add_argument("--rays", type=_csv,
                   help="comma-separated ray kinds: primary, shadow (towards the first DistantLight, else a default "
                   "sun: the rows' shadow_light), diffuse, incoherent" + suites)
    p.add_argument("--n-rays", type=positive_int, help="rays per (scene, device, ray kind) group" + suites)
    p.add_argument("--repeats", type=positive_int,  # the cap: bench.MAX_REPEATS (bench imports Warp: not here)
                   help="timed launches per row (median reported), at most 10,000" + suites)
    p.add_argument("--threads", type=_csv, help="CPU thread counts, e.g. 1,all (all: every core); rows also record "
                   "threads_effective, the threads that ran at once (at most the usable cores)" + suites)
    p.add_argument("-o", "--out", default="bench-out", type=_home, help="output folder")
    p.add_argument("--resume", action="store_true",
                   help="keep rows already in OUT/rows.jsonl and skip them (the same ray counts and repeats only); "
                   "rows of changed triangles or rays, hardware, wrt source or Warp version are measured again, as "
                   "are rows unchecked against warp:sah where it is measured now")
    p.add_argument(
        "--dask",
        nargs="?",
        const=True,
        metavar="ADDRESS",
        help="spread the (scene, device, ray kind) groups over a Dask cluster: the scheduler at ADDRESS "
        "(tcp://host:8786), else a local one with a worker per GPU or CPU core (pip install 'wrt[dask]')",
    )
    p.add_argument("--strict", action="store_true",
                   help="exit with status 1 when a row answers some ray otherwise than warp:sah (ray by ray, edge "
                   "ties left out), as for a failed row; without it such rows are only warned about")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(run=_run_bench)


def _how_to_resume(args, out: Path, rows_before: tuple | None) -> str:
    """For the lines after Ctrl-C: where the rows measured so far are, and a line with the command that goes on from
    them (the one run, with ``--resume``), to copy. Nothing when there are no rows, or when ``OUT/rows.jsonl`` is
    still as it was before the run (``rows_before``, :func:`wrt.bench.file_state`) and the run did not resume it:
    those are an earlier run's rows, maybe of other ray counts, which --resume would refuse."""
    import shlex

    from .bench import file_state

    rows_file = out / "rows.jsonl"
    if not rows_file.is_file() or (not args.resume and file_state(rows_file) == rows_before):
        return ""
    table = f" (table: {out / 'table.md'})" if (out / "table.md").is_file() else ""
    command = ["wrt", *args.command_line] + ([] if args.resume else ["--resume"])
    return (f"; the rows measured so far are in {out / 'rows.jsonl'}{table}\n"
            f"wrt: to go on from them: {shlex.join(command)}")


EARLIER_ROW = "of an earlier run (kept by --resume; not in this grid)"  # of rows named in wrt bench's warnings


def _run_bench(args) -> int:
    from .bench import REFERENCE, Grid, GridError, file_state, row_key, run_grid, suite_path

    if args.quick and args.suite != "quick":  # the suite named would be dropped without a word
        raise ValueError(f"give a suite ({args.suite}) or --quick, not both")
    overrides = {k: getattr(args, k) for k in ("scenes", "accels", "devices", "rays", "n_rays", "repeats", "threads")}
    typed = {k: v for k, v in overrides.items() if v is not None}
    if args.scenes is not None:  # the scenes named are all that is measured: the suite's scaling sweep ran too
        typed["scaling"] = None
    out = Path(args.out)
    rows_before = file_state(out / "rows.jsonl")  # set before a Ctrl-C can come: the message reads it
    try:
        # The options replace the suite's values before they are checked: a value overridden is never used.
        grid = Grid.from_suite(args.suite, overrides=typed).validated()  # a bad field: a one-line error naming it
        if all(p.is_dir() or not p.exists() for p in (out, *out.parents)):  # a file in the way: run_grid names it
            _check_output_location(out)  # a folder that takes no files, named as render's -o does, not by an errno
        rows = run_grid(grid, args.out, resume=args.resume, progress=_Progress(args.quiet).bar, dask=args.dask)
    except KeyboardInterrupt:  # 'wrt: interrupted' alone did not say where the rows were, nor how to go on
        print(f"wrt: interrupted{_how_to_resume(args, out, rows_before)}", file=sys.stderr)
        return EXIT_INTERRUPTED
    except GridError as e:  # raised before any row is measured; it named the value only ('unknown ray kind ...')
        fields = [name for name in (e.field, e.also) if name]
        if not any(name in typed for name in fields):  # from the suite file (a device found missing only now)
            raise ValueError(f"{suite_path(args.suite).name}: {e.where()}") from None
        if e.also:  # a pair that cannot go together (--accels warp:lbvh with --devices cpu): both are named
            options = [f"--{name.replace('_', '-')}" for name in fields if name in typed]
            key = e.where().split(":")[0] if e.field not in typed else e.also
            suite = "" if len(options) == 2 else f", with {suite_path(args.suite).name}'s {key}"
            raise ValueError(f"argument{'s' * (len(options) == 2)} {' and '.join(options)}{suite}: {e}") from None
        message = str(e).removeprefix(f"{e.field} ")  # 'threads must be ...' reads 'argument --threads: must be ...'
        raise ValueError(f"argument --{e.field.replace('_', '-')}: {message}") from None
    except MemoryError as e:  # the grid's ray buffers past the host memory, named 'n_rays N' as in Python
        python_name = f"n_rays {typed.get('n_rays')} needs "
        if "n_rays" not in typed or not str(e).startswith(python_name):
            raise
        raise MemoryError(f"argument --n-rays: {typed['n_rays']:,} rays need {str(e).removeprefix(python_name)}"
                          ) from None
    failed = [r for r in rows if "error" in r]
    measured = len(rows) - len(failed) - rows.resumed - rows.earlier  # resumed rows: measured by the earlier run
    # Rows of the earlier run outside this grid are kept, but are no part of this run's count.
    earlier = f", {counted(rows.earlier, 'row')} of an earlier run kept (not in this grid)" if rows.earlier else ""
    summary = (f"wrt: {counted(measured, 'row')} measured, {rows.resumed} resumed, {len(failed)} failed{earlier}; "
               f"results in {os.path.join(args.out, '')}")  # one separator after the folder, given with one or not
    print(summary, file=sys.stderr)
    for r in failed:
        print(f"wrt: failed: {r['scene']} / {r['accel']} / {r['device']} / {r['rays']}: {r['error']}", file=sys.stderr)
    # Rows of an earlier run that --resume kept outside this grid are named as such, as the table and plots mark them:
    # counted as this run's, an old wrong answer or an unchecked row read as measured now.
    earlier = lambda r: row_key(r) in rows.earlier_keys  # noqa: E731
    disagreeing = [r for r in rows if r.get("disagreements")]
    for r in disagreeing:  # a wrong answer, of the row or of wp.Mesh, must not pass as a speed-up
        print(f"wrt: {'error' if args.strict else 'warning'}: {r['scene']} / {r['accel']} / {r['device']} / "
              f"{r['rays']}: {r['disagreements']} of {r['n_rays']} rays answered otherwise than by {REFERENCE} (edge "
              f"ties left out){f'; a row {EARLIER_ROW}' if earlier(r) else ''}", file=sys.stderr)
    unchecked = [r for r in rows if "error" not in r and r.get("agreement") is None and r["accel"] != REFERENCE]
    if unchecked:
        n = sum(map(earlier, unchecked))
        of_earlier = f"; {n} of them {'is a row' if n == 1 else 'are rows'} {EARLIER_ROW}" if n else ""
        print(f"wrt: warning: {counted(len(unchecked), 'row')} not checked against {REFERENCE} (it failed or was not "
              f"run in their group){of_earlier}", file=sys.stderr)
    # None of this run's rows measured: bad input, as a render batch none of whose scenes rendered.
    if failed and len(failed) == len(rows) - rows.earlier:
        return EXIT_BAD_INPUT
    # --strict: a script sees the disagreement in the status (it was a warning line only, status 0).
    return 1 if failed or (args.strict and disagreeing) else 0


def _builders(text: str) -> str:
    """An argparse type: one ``--builder`` value of ``wrt bvh-stats``, comma-separated names
    :func:`wrt.options.parse_builders` reads."""
    _csv(text)
    try:
        parse_builders(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
    return text


def _non_negative_float(text: str) -> float:
    """An argparse type: a finite number at least 0 (``--traversal-cost``)."""
    value = _finite_float(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be a number at least 0, got {text}")
    return value


def _add_bvh_stats(sub) -> None:
    # Each value is checked as it is read, so an error names the option typed (it named the Python argument, as
    # 'presplit must lie in [0, 6]', and came after the scene's load).
    def up_to(lo: int, hi: int):
        return int_at_least(lo, f"an integer from {lo} to {hi}", hi)

    p = sub.add_parser(
        "bvh-stats",
        help="BVH quality and size statistics of a scene, for wrt's builders and Warp's",
        description="Build BVHs over a USD scene's triangles (gprims tessellated) and report SAH cost, EPO "
        "(end-point overlap, estimated), node and leaf counts, depths, leaf sizes, bytes and build time. Warp's "
        "own trees are read from wp.Mesh with --builder warp:sah (or warp:median, warp:lbvh on CUDA, warp:cubql).",
        formatter_class=HelpFormatter,
    )
    p.add_argument("scene", type=_path, help="USD file (.usd, .usda, .usdc, .usdz)")
    p.add_argument(
        "--builder",
        action="append",
        type=_builders,
        help=f"builders, comma-separated or repeated: {', '.join(builder_names())}, all, or warp:<name> for "
        "wp.Mesh's tree (default: sah)",
    )
    p.add_argument("--layout", default="binary", choices=LAYOUTS, help="layout whose node count and bytes are shown")
    # The builders' defaults (build_bvh_device's), which an option left out keeps.
    p.add_argument("--leaf-size", type=up_to(1, MAX_LEAF_SIZE), default=None,
                   help=f"wrt's most triangles per leaf (default: {DEFAULT_LEAF_SIZE})")
    p.add_argument("--warp-leaf-size", type=up_to(1, MAX_WARP_LEAF_SIZE), default=None,
                   help="Warp's bvh_leaf_size (default: Warp's)")
    p.add_argument("--bins", type=up_to(2, MAX_BINS), default=None, help="SAH bins per axis for sah (default: "
                   f"{DEFAULT_BINS})")
    p.add_argument("--traversal-cost", type=_non_negative_float, default=1.0, help="SAH constant C_t (node visit)")
    p.add_argument("--intersection-cost", type=_positive_float, default=1.0, help="SAH constant C_i (triangle test)")
    p.add_argument("--epo-samples", type=up_to(1, MAX_EPO_SAMPLES), default=EPO_SAMPLES,
                   help="surface samples of the EPO estimate")
    p.add_argument("--presplit", type=up_to(0, MAX_SPLIT_LEVELS), default=0, metavar="K",
                   help="pre-split levels of wrt's builds: long diagonal triangles become up to 2**K references; the "
                   f"sah trees of renders and wrt bench use {ACCELERATOR_PRESPLIT}; EPO is n/a for a tree whose "
                   "pre-splits split a triangle (it sits in several leaves)")
    p.add_argument("--device", default="cpu", type=_non_empty, help="Warp device to build on, e.g. cpu or cuda:0")
    p.add_argument("--time", type=_finite_float, default=None, help=TIME_HELP)
    # Only which prims are loaded follows the settings here: no camera, image or material is made.
    add_stage_options(p, "RenderSettings prim whose includedPurposes choose the prims whose triangles are built over")
    p.add_argument("--json", action="store_true", help="print JSON rows instead of a table")
    p.set_defaults(run=_run_bvh_stats)


def _run_bvh_stats(args) -> int:
    from .bvh.report import run_bvh_stats

    return run_bvh_stats(args)


class _VersionAction(argparse._VersionAction):
    """argparse's ``--version``, its line made when it is asked for: it names Warp's version, and importing Warp for
    it made every ``wrt`` command line, ``--help`` too, wait for Warp's import."""

    def __call__(self, parser, namespace, values, option_string=None):
        import warp as wp

        from . import __version__

        self.version = f"wrt {__version__} (warp-lang {wp.config.version}, Python {sys.version.split()[0]})"
        super().__call__(parser, namespace, values, option_string)


def build_parser() -> argparse.ArgumentParser:
    """The ``wrt`` argument parser with every subcommand."""
    parser = _Parser(
        prog="wrt",
        description="wrt: a ray tracer for USD scenes written in NVIDIA Warp kernels.",
        epilog="Run 'wrt COMMAND --help' for the options of a command.",
    )
    # For bug reports; without it 'wrt --version' said that a COMMAND is required.
    parser.add_argument("--version", action=_VersionAction)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    _add_render(sub)
    _add_preview(sub)
    _add_bench(sub)
    _add_bvh_stats(sub)
    return parser


def error_line(error: Exception) -> str:
    """The first line of ``error``'s message, or its type where it has none. An OS error of Python's own wording
    (``[Errno 36] File name too long: 'aaaa...png'``) reads ``aaaa...png: file name too long``, the path first, as
    wrt's own errors name it; one of a file descriptor (``os.stat(3)``) reads ``file descriptor 3: ...``."""
    if isinstance(error, OSError) and error.strerror and error.filename is not None and str(error).startswith("[Errno"):
        paths = " -> ".join(f"file descriptor {p}" if isinstance(p, int) else os.fsdecode(p)
                            for p in (error.filename, error.filename2) if p is not None)
        return f"{paths}: {error.strerror[:1].lower()}{error.strerror[1:]}"
    return str(error).splitlines()[0] if str(error) else type(error).__name__


def _kernel_cache_hint(error: Exception, cache_dir: str | None) -> str:
    """What to do when ``error`` is an OS error about Warp's kernel cache folder, else ''. Warp makes that folder in
    the home folder when it starts (and writes compiled kernels there), so a missing or read-only home fails with
    only a path in the message."""
    failed = getattr(error, "filename", None)
    if not (isinstance(failed, (str, bytes, os.PathLike)) and failed and cache_dir):  # not a file descriptor
        return ""
    failed, cache = Path(os.fsdecode(failed)), Path(cache_dir)  # bytes too (os.stat(b"...") names bytes)
    if failed != cache and failed not in cache.parents and cache not in failed.parents:
        return ""
    return f" (Warp's kernel cache {cache}: set WARP_CACHE_PATH to a writable folder)"


def _help_hint(command: argparse.ArgumentParser, message: str) -> str:
    """`` (see 'wrt bench --help')`` for an error about the options given, as argparse ends its own: one whose first
    clause names an option of ``command`` (``argument --rays: unknown ray kind 'foo'``, ``--builder lbvh builds ...``,
    ``give --devices or --dask, not both``); '' for one about a file or a scene (``cannot write x.png: ...``). Checks
    made after parsing ended without it, argparse's with it, in one command."""
    clause = re.split(r": |; ", message, maxsplit=1)[0]
    named = re.findall(r"(?<![\w/.-])--?[A-Za-z][\w-]*", clause)
    return f" (see '{command.prog} --help')" if any(n in command._option_string_actions for n in named) else ""


def main(argv: list[str] | None = None) -> int:
    """Runs the ``wrt`` command line; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    args.command_line = list(sys.argv[1:] if argv is None else argv)  # as typed: wrt bench's Ctrl-C line repeats it
    import warp as wp

    from .distributed import DaskUnavailable
    from .errors import SceneError

    def show_warning(message, category, filename, lineno, file=None, line=None):
        from tqdm import tqdm

        # Through tqdm, so a warning raised under a running progress bar gets a line of its own, above the bar.
        tqdm.write(f"wrt: warning: {message}", file=sys.stderr)

    warnings.showwarning = show_warning
    try:
        return args.run(args)
    except BrokenPipeError:
        # The reader of stdout went away ('wrt bvh-stats scene.usda | head -1'): stop quietly, with the status of a
        # process SIGPIPE ended, as other tools do; it was 'wrt: error: [Errno 32] Broken pipe', status 2 (bad input).
        # Python's own flush at exit would fail on the closed pipe again: stdout goes to the null device.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    # OSError: unwritable output paths too; a Warning: one that Python's warning filters make an error (python -W
    # error), said in wrt's words as a batch's scenes and --frames' frames say it, not as a traceback.
    except (SceneError, ValueError, TypeError, OSError, MemoryError, Warning) as e:
        message = error_line(e)
        # Not for an OSError: a file's state, which no option's help mends ('--log x: permission denied').
        hint = "" if isinstance(e, OSError) else _help_hint(parser._commands()[args.command], message)
        print(f"wrt: error: {message}{_kernel_cache_hint(e, wp.config.kernel_cache_dir)}{hint}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except DaskUnavailable as e:
        print(f"wrt: error: {e}", file=sys.stderr)
        return 1  # the environment, not the input: dask is missing or its scheduler does not answer
    except RuntimeError as e:
        if not str(e).startswith("Failed to allocate"):  # Warp's words when a device allocation fails
            raise
        print(f"wrt: error: out of memory: {str(e).splitlines()[0]}; lower the resolution or the spp batch, or use "
              "another device", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("wrt: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
