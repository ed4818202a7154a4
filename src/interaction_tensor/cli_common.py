"""What every ``itensor`` subcommand module shares: the parser class (defaults shown in
``--help``), option types, common options and printing helpers. Imported by :mod:`.cli`,
:mod:`.cli_viz` and :mod:`.cli_eval`; it imports none of them."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from .errors import InputError


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
    """``itensor``'s parsers: defaults shown in ``--help``."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)


def seed_option(p) -> None:
    p.add_argument("--seed", type=int, default=0, help="seed of every random step")


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


def _fraction(text: str) -> float:
    value = float(text)
    if not 0 < value <= 1:
        raise argparse.ArgumentTypeError(f"must be in (0, 1], got {text}")
    return value


def _show_progress(args) -> bool:
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def _say(args, *parts) -> None:
    """Report lines: none with --quiet, and none with --json (stdout is the JSON line)."""
    if not getattr(args, "quiet", False) and not getattr(args, "json", False):
        print(*parts)


def _out_path(path) -> Path:
    """An output directory argument, checked but not created (results are swapped in)."""
    if not str(path).strip():
        raise InputError(None, "-o/--output is empty; give a directory")
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(path, "exists and is not a directory")
    return path


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


