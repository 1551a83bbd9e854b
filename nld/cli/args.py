"""Shared pieces of the command line: the parser class with one-line errors, argument types (finite
numbers, relative tolerances, counts, value lists), the scene and progress options, and the
one-line messages on stderr (``nld: error: ...``, ``nld: interrupted: ...``)."""
from __future__ import annotations

import argparse
import math
import re
import sys

from nld.errors import InputError

PROG = "nld"


class UsageError(Exception):
    """An argparse error, turned into the one-line message of :func:`nld.cli.app.main`."""


# a value that starts with '-' but is a number, a range or a list of numbers: -1e-3, -.5, -inf,
# -Infinity, -nan, -0.5:0.5:3, -1,2 (argparse's own matcher takes only -12 and -1.5 as values)
NEGATIVE_VALUE = re.compile(r"^-(\d|\.\d|inf(inity)?\b|nan\b)", re.IGNORECASE)


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors (:meth:`error`) and values that start with '-': every option
    of every command takes ``--gain -inf``, ``--memory -1e-3``, ``--gains -0.5:0.5:3`` or
    ``--values -1,2`` as its value (argparse would read those as unknown options and say
    "expected one argument"). No nld option looks like a number, so nothing is lost."""

    def _parse_optional(self, arg_string):
        if NEGATIVE_VALUE.match(arg_string) and arg_string not in self._option_string_actions:
            return None                 # a value (positional), not an option
        return super()._parse_optional(arg_string)

    def error(self, message):       # one line instead of usage + message, see main()
        message = one_line(message)
        m = re.match(r"argument (\S+): (\1 = .*)", message)    # our type checks name the option
        if m:
            message = m.group(2)
        cmd = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        hint = f" (see '{PROG}{' ' + cmd if cmd else ''} --help')"
        raise UsageError(message + hint)


def one_line(text) -> str:
    return " ".join(str(text).split())


def print_error(message) -> None:
    """``nld: error: <message>`` on one line of stderr."""
    print(f"{PROG}: error: {one_line(message)}", file=sys.stderr)


def print_interrupted(what: str, signum: int | None = None) -> None:
    """``nld: interrupted: <what was kept>`` (SIGINT, Ctrl-C) or ``nld: terminated by SIGTERM:
    <what was kept>`` on one line of stderr."""
    import signal
    if signum is None or signum == signal.SIGINT:
        head = "interrupted"
    else:
        try:
            head = f"terminated by {signal.Signals(signum).name}"
        except ValueError:
            head = f"terminated by signal {signum}"
    print(f"{PROG}: {head}: {one_line(what)}", file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------------------
# argument types (each message names the option: ``--revs = 'x': not a number``)


def number_arg(name: str, *, positive: bool = True):
    """argparse type: a finite float (> 0 if ``positive``); the message names the option."""
    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: not a number") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be a finite number")
        if positive and not v > 0:
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be > 0")
        return v
    conv.__name__ = name
    return conv


def rtol_arg(text: str) -> float:
    """argparse type of ``--rtol`` and the like: a number in [1e-14, 1) (nld.settings.rtol_in_range)."""
    from nld.settings import RTOL_RANGE_TEXT, rtol_in_range
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--rtol = {text!r}: not a number") from None
    if not rtol_in_range(v):
        raise argparse.ArgumentTypeError(f"--rtol = {text}: must be {RTOL_RANGE_TEXT}")
    return v


def count_arg(name: str, minimum: int):
    """argparse type: an integer >= ``minimum``; the message names the option."""
    def conv(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: not an integer") from None
        if v < minimum:
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be >= {minimum}")
        return v
    conv.__name__ = name
    return conv


def values_of(name: str):
    """argparse type of a swept value list: START:STOP:NUM (ends included) or V1,V2,...; the
    message names the option ``name``."""
    def conv(text: str):
        from nld.analysis.bifurcation import parse_values
        try:
            return parse_values(text, name)
        except InputError as e:
            raise argparse.ArgumentTypeError(str(e)) from None
    conv.__name__ = name
    return conv


values_arg = values_of("--values")


# ---------------------------------------------------------------------------------------------------
# options shared by several commands


def scene_args(sp, *, scene_help="built-in scene name or path of a .toml file",
               set_help="override a scene value, e.g. joints.B.clearance=2e-4 (repeatable)") -> None:
    """The positional SCENE and the repeatable ``--set KEY=VALUE``."""
    sp.add_argument("scene", metavar="SCENE", help=scene_help)
    sp.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help=set_help)


def progress_args(sp) -> None:
    """``--quiet`` / ``--progress`` (every command; ``nld.progress``)."""
    g = sp.add_mutually_exclusive_group()
    g.add_argument("--quiet", "-q", dest="progress", action="store_const", const=False, default=None,
                   help="no progress bars")
    g.add_argument("--progress", dest="progress", action="store_const", const=True,
                   help="progress bars on stderr even when it is not a terminal")


def progress_kw(func, progress) -> dict:
    """``{"progress": progress}`` when ``func`` takes a ``progress`` argument, else {}."""
    import inspect
    try:
        params = inspect.signature(func).parameters
    except (TypeError, ValueError):
        return {}
    if "progress" in params or any(p.kind is p.VAR_KEYWORD for p in params.values()):
        return {"progress": progress}
    return {}


def json_plain(o):
    """``json.dumps(default=...)`` of the commands' --json output: numpy scalars and arrays as
    numbers and lists, a complex number as [re, im], anything else as its text."""
    import numpy as np
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (complex, np.complexfloating)):
        return [float(o.real), float(o.imag)]
    return str(o)


def pool_args(sp) -> None:
    """``--workers N`` (local worker processes, default the CPU count) and ``--dask ADDRESS``
    (a Dask scheduler instead), as every parallel command takes them (nld.sweeps.executors)."""
    sp.add_argument("--workers", type=count_arg("--workers", 1), default=None, metavar="N",
                    help="local worker processes (default: CPU count)")
    sp.add_argument("--dask", default=None, metavar="ADDRESS",
                    help="run on a Dask cluster at this scheduler address instead")
