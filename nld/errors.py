"""Exceptions of nld. Every input error is one line naming the field, the value and what is allowed.

Every class here (and every subclass of them elsewhere in nld) survives pickling with its message
and attributes: an error raised in a pool worker (a sweep point, a census, a study's pool) reaches
the main process as the same exception, so the user sees the same one line as with one worker.
Python's default pickling calls ``cls(*args)`` with the message alone, which fails for classes
whose ``__init__`` takes other arguments (SceneError's three) and drops extra attributes
(AssemblyError.joint, Interrupted.kept); :class:`Picklable` rebuilds the instance without calling
``__init__``.
"""


def _rebuild(cls, args, state):
    """An exception of class ``cls`` with ``args`` and attributes ``state``, without ``__init__``."""
    e = cls.__new__(cls, *args)
    e.args = tuple(args)
    e.__dict__.update(state)
    return e


class Picklable:
    """Mixin: pickled as (class, args, attributes), rebuilt without calling ``__init__``."""

    def __reduce__(self):
        return (_rebuild, (type(self), self.args, dict(self.__dict__)))


class SceneError(Picklable, ValueError):
    """Bad scene or parameter input.

    The message has the form ``<field path> = <value>: <what is allowed>`` on one line,
    e.g. ``joints.B.clearance = -0.001: must be >= 0 (m)``.
    """

    def __init__(self, path: str, value, allowed: str):
        self.path = path
        self.value = value
        self.allowed = allowed
        super().__init__(f"{path} = {value!r}: {allowed}")


class InputError(Picklable, ValueError):
    """Bad input that is not a scene field (a file that cannot be read, a malformed option)."""


class SolveError(Picklable, RuntimeError):
    """An integration that could not meet its tolerance; the message says where and why."""


class Interrupted(Picklable, KeyboardInterrupt):
    """Ctrl-C (SIGINT) during a long computation, raised after it stopped cleanly between two
    chunks of integration. ``partial`` holds what was computed (e.g. the
    :class:`nld.run.simulate.SimulationResult` up to the interruption, ``status`` INTERRUPTED) or None;
    ``kept`` says it in words. A subclass of KeyboardInterrupt, so code that does not know it
    stops as on any Ctrl-C."""

    def __init__(self, message: str = "interrupted", partial=None, kept: str = ""):
        super().__init__(message)
        self.partial = partial
        self.kept = kept


class OutputError(Picklable, OSError):
    """A result file that could not be written (a full disk, a folder without write permission):
    the message names the file and what was kept. Exit status 1 on the command line."""


class InputTypeError(InputError, TypeError):
    """An argument of the wrong type (``revs='abc'``, ``scene=None``): both an InputError (a
    ValueError) and a TypeError, so either ``except`` catches it."""


class AssemblyError(InputError, SolveError):
    """A mechanism that cannot be assembled at its start (link lengths that cannot close a loop,
    a ground point out of reach): bad input (exit status 2 on the command line) that is also a
    SolveError for code that catches those. ``joint``: the joint named where its
    loop does not close; ``gap``: how far that loop is from closing (m), from its geometry
    (nld.model.closure); both None when the geometry decides nothing."""

    def __init__(self, message: str, joint: str | None = None, gap: float | None = None):
        super().__init__(message)
        self.joint = joint
        self.gap = gap
