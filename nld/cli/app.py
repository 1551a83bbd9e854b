"""The parser of the ``nld`` command line, assembled from one module per command, and
:func:`main`: parse, run, and turn errors into exit statuses (see :mod:`nld.cli`)."""
from __future__ import annotations

import errno
import os
import shlex
import signal
import sys

from nld.cli import attractors, bifurcation, chaos_map, control, hard_cases, lyapunov, orbits, poincare, \
    scenes, simulate, spectrum, study
from nld.cli.args import PROG, Parser, UsageError, print_error, print_interrupted, progress_args
from nld.errors import InputError, Interrupted, OutputError, SceneError, SolveError
from nld.version import __version__

# the sub-commands in the order of ``nld --help``
COMMANDS = (scenes, simulate, poincare, bifurcation, spectrum, chaos_map, lyapunov, orbits,
            attractors, control, hard_cases, study)


def build_parser() -> Parser:
    p = Parser(prog=PROG, description="Nonlinear dynamics of planar mechanisms with clearance joints.")
    p.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    for command in COMMANDS:
        command.add_parser(sub)
    for sp in sub.choices.values():
        progress_args(sp)
    p.commands = sub.choices          # for the messages of unknown options (main)
    return p


def parse(parser: Parser, argv: list[str]):
    """``parser.parse_args(argv)``, except that an unknown option is reported by its command's
    parser (the hint names ``nld COMMAND --help``, not ``nld --help``)."""
    args, extra = parser.parse_known_args(argv)
    if extra:
        sp = getattr(parser, "commands", {}).get(getattr(args, "command", None), parser)
        sp.error(f"unrecognized arguments: {' '.join(extra)}")
    return args


def main(argv=None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    from nld import interrupt
    from nld import progress
    argv = list(sys.argv[1:] if argv is None else argv)
    interrupt.forget_received()           # before install: a signal from now on is counted
    try:
        interrupt.install()               # inside the try: a Ctrl-C right after it is one line
        try:
            args = parse(build_parser(), argv)
        except SystemExit as e:          # --help, --version
            return e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
        args.command_line = shlex.join([PROG] + [str(a) for a in argv])
        progress.set_default(getattr(args, "progress", None))
        try:
            return int(args.func(args))
        finally:
            progress.set_default(None)
            sys.stdout.flush()
    except UsageError as e:
        print_error(e)
        return 2
    except (SceneError, InputError) as e:
        print_error(e)
        return 2
    except SolveError as e:
        print_error(e)
        return 1
    except KeyboardInterrupt as e:        # Ctrl-C or SIGTERM; Interrupted says what was kept
        sig = interrupt.received() or signal.SIGINT
        if isinstance(e, Interrupted):
            kept = e.kept or str(e) or "nothing kept"
        else:
            kept = "nothing kept (the command had not finished a result yet)"
        print_interrupted(kept, sig)
        return 128 + int(sig)
    except BrokenPipeError:               # e.g. `nld scenes | head -1`
        quiet_stdout()
        return 141
    except OutputError as e:              # a result file that could not be written: named
        try:
            print_error(e)
        except OSError:
            pass
        return 1
    except MemoryError:
        # the command cannot tell which option made the run too large: name what was asked
        print_error(f"out of memory: {shlex.join([PROG] + [str(a) for a in argv])} needs more memory "
                    "than this machine has; ask for a smaller run (the options that set its size)")
        return 2
    except OSError as e:
        # standard output (or a file written without nld.output.io) on a full or failing disk
        if e.errno not in FULL_DISK:
            raise
        where = "standard output" if e.filename is None else str(e.filename)
        try:
            print_error(f"cannot write to {where}: {e.strerror or e}")
        except OSError:
            pass
        quiet_stdout()
        return 1


# the errors of a full or failing disk: one line, exit status 1, no traceback
FULL_DISK = tuple(getattr(errno, n) for n in ("ENOSPC", "EDQUOT", "EFBIG", "EIO") if hasattr(errno, n))


def quiet_stdout() -> None:
    """After EPIPE: point stdout at /dev/null so the interpreter's final flush stays silent."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass
