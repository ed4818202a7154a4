"""What every ``itensor`` subcommand module shares: the parser class (defaults shown in
``--help``), option types, common options and printing helpers. Imported by :mod:`.main`,
:mod:`.viz` and :mod:`.examples`; it imports none of them."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from interaction_tensor import affordances
from interaction_tensor.errors import InputError


class HelpFormatter(argparse.HelpFormatter):
    """Shows every option's default after its help, unless the help already speaks of it
    or there is none to show (a flag, an option with no default)."""

    def _get_help_string(self, action):
        text = action.help or ""
        default = action.default
        if ("default" in text.lower() or default in (None, False, argparse.SUPPRESS)
                or not action.option_strings or isinstance(default, bool)):
            return text
        shown = ",".join(f"{v:g}" for v in default) if isinstance(default, tuple) else "%(default)s"
        return f"{text} (default: {shown})"


class Parser(argparse.ArgumentParser):
    """``itensor``'s parsers: defaults shown in ``--help``; a usage error is one line that
    names the option and points to ``--help``, not the whole usage."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message} (see '{self.prog} --help')\n")


def number(kind=float, *, low=None, high=None, low_open: bool = False, what: str | None = None):
    """An argparse ``type`` for a finite number in [low, high] (``low_open``: (low, high]).
    Its errors name the option through argparse (``argument --voxel-size: expected ...``)
    and say the allowed range, never Python's own text."""
    if what is None:
        noun = "an integer" if kind is int else "a number"
        if low is not None and high is not None:
            what = f"{noun} in {'(' if low_open else '['}{low:g}, {high:g}]"
        elif low is not None:
            what = f"{noun} {'>' if low_open else '>='} {low:g}"
        else:
            what = noun

    def parse(text: str):
        try:
            value = kind(text)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if (not math.isfinite(value) or (low is not None and value < low)
                or (low_open and value == low) or (high is not None and value > high)):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return value

    parse.__name__ = what
    return parse


#: Seeds numpy's generators take: non-negative integers below 2**63.
MAX_SEED = 2 ** 63 - 1


def seed_option(p) -> None:
    p.add_argument("--seed", type=number(int, low=0, high=MAX_SEED,
                                         what="a non-negative integer"),
                   default=0, help="seed of every random step")


def quiet_option(p) -> None:
    p.add_argument("-q", "--quiet", action="store_true",
                   help="print nothing but errors (no progress bar, no report)")


def _vector(text: str) -> tuple:
    named = {"up": (0.0, 0.0, 1.0), "down": (0.0, 0.0, -1.0)}
    if text in named:
        return named[text]
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected 'up', 'down' or x,y,z, got {text!r}") from None
    if len(values) != 3:
        raise argparse.ArgumentTypeError(f"expected three comma-separated numbers, got {text!r}")
    return values


#: A sampling spacing: the bounds of :data:`settings.MIN_SPACING` and 1 m (samples cost
#: memory as 1 / spacing^2).
_spacing = number(low=1e-3, high=1.0, what="metres in [0.001, 1]")
_fraction = number(low=0, high=1, low_open=True, what="a fraction in (0, 1]")


def _show_progress(args) -> bool:
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def _say(args, *parts) -> None:
    """Report lines: none with --quiet, and none with --json (stdout is the JSON line)."""
    if not getattr(args, "quiet", False) and not getattr(args, "json", False):
        print(*parts)


def _out_path(path) -> Path:
    """An output directory argument, checked but not created (results are swapped in)."""
    path = _out_file(path, "-o/--output", "a directory")
    if path.exists() and not path.is_dir():
        raise InputError(path, "exists and is not a directory")
    return path


def _out_file(path, option: str = "-o/--output", what: str = "a file to write") -> Path:
    """An output argument refused, before any work, when it is empty (``-o ''``: Path reads
    it as the working directory)."""
    if not str(path).strip():
        raise InputError(None, f"{option} is empty; give {what}")
    return Path(path)


def _axis_or_vector(text: str):
    if text in ("x", "y", "z", "-x", "-y", "-z", "auto"):
        return text
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected auto, an axis (z, y, -y, ...) or x,y,z; "
                                         f"got {text!r}") from None
    if len(values) != 3 or not any(values):
        raise argparse.ArgumentTypeError(f"expected three numbers, not all zero: {text!r}")
    return values




def objects_dir(path):
    if path is None:
        return None
    p = Path(path)
    if not p.is_dir():
        raise InputError(p, "objects directory not found")
    return str(p)


def examples_option(names):

    if not names:
        return ()
    out = []
    for n in names:
        out += [s for s in n.split(",") if s]
    for n in out:
        affordances.spec(n)          # InputError for unknown names
    return tuple(out)
