"""Progress bars of long work (tqdm), on stderr, in crank revolutions or points with rate and ETA.

    from nld.progress import progress_bar
    with progress_bar(total=200, unit="rev", desc="simulate", enabled=progress) as bar:
        ...
        bar.update(1)

``enabled``: None (the default everywhere in the API) shows the bar only when stderr is a terminal
(and ``NLD_PROGRESS`` is not ``0``), True always, False never. The command line's ``--quiet``
passes False and ``--progress`` True (also when stderr is a file or a pipe). ``delay`` (s): a
bar appears only once the work has taken that long (a simulate of a few revolutions prints
nothing). A disabled bar is a no-op object with the same methods, so callers never branch.

:func:`stage` prints one line ``<desc>: <what>`` (a study saying which stage it is in) when
progress is on.

``NLD_PROGRESS=1`` / ``0`` in the environment turns the automatic choice on / off (for a process
whose stderr is not a terminal, e.g. a study run by a scheduler that tails its log).
"""
from __future__ import annotations

import os
import sys

__all__ = ["progress_bar", "progress_enabled", "stage", "NullBar", "resolve"]

ENV = "NLD_PROGRESS"
_DEFAULT: bool | None = None      # set by the command line (--quiet / --progress)


def set_default(enabled: bool | None) -> None:
    """The value that ``enabled=None`` means from now on in this process (the command line's
    --quiet / --progress); None restores the automatic choice."""
    global _DEFAULT
    _DEFAULT = enabled


def progress_enabled(enabled: bool | None = None) -> bool:
    """Whether a bar with this ``enabled`` argument is shown (see the module docstring)."""
    if enabled is not None:
        if not isinstance(enabled, bool):
            from nld.errors import InputError
            raise InputError(f"progress = {enabled!r}: must be True, False or None (automatic)")
        return enabled
    if _DEFAULT is not None:
        return _DEFAULT
    env = os.environ.get(ENV, "").strip().lower()
    if env in ("1", "true", "yes", "on"):
        return True
    if env in ("0", "false", "no", "off"):
        return False
    try:
        return sys.stderr is not None and sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


resolve = progress_enabled


class NullBar:
    """What a disabled :func:`progress_bar` yields: every method does nothing."""
    n = 0
    total = None

    def update(self, n=1):
        self.n += n

    def set_postfix_str(self, *a, **k):
        pass

    def set_description_str(self, *a, **k):
        pass

    def write(self, *a, **k):
        pass

    def refresh(self, *a, **k):
        pass

    def close(self):
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


_ACTIVE = [0]      # bars open in this process


class _Bar:
    """A tqdm bar that counts itself among the open bars (so that inner work stays quiet)."""

    def __init__(self, bar):
        self._bar = bar
        self._open = True
        _ACTIVE[0] += 1

    def __getattr__(self, name):
        return getattr(self._bar, name)

    def close(self):
        if self._open:
            self._open = False
            _ACTIVE[0] -= 1
            self._bar.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False


def progress_bar(total=None, unit: str = "rev", desc: str | None = None,
                 enabled: bool | None = None, delay: float = 0.0, initial: float = 0, **kw):
    """A tqdm bar on stderr (a context manager), or a :class:`NullBar` when not enabled.

    total: the amount of work in ``unit`` (crank revolutions "rev", "point", "cell" ...), None for
    unknown; desc: what is running; enabled: None/True/False (module docstring); delay (s): show
    only after this long, when the bar is automatic (``enabled`` True and --progress show it at
once); initial: work already done (a resumed sweep).

    With ``enabled=None`` a bar opened while another one is open is not shown: the points of a
    sweep do not each draw a bar under the sweep's own."""
    if enabled is True or (enabled is None and _DEFAULT is True):
        delay = 0.0             # asked for: shown at once
    if not progress_enabled(enabled) or (enabled is None and _ACTIVE[0] > 0):
        bar = NullBar()
        bar.n = initial
        bar.total = total
        return bar
    from tqdm import tqdm
    fmt = kw.pop("bar_format", None)
    if fmt is None and unit == "rev":
        # fractional revolutions: one decimal place
        fmt = "{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total_fmt} rev [{elapsed}<{remaining}, {rate_fmt}]"
        if total is None:
            fmt = "{desc}: {n:.1f} rev [{elapsed}, {rate_fmt}]"
    return _Bar(tqdm(total=total, unit=unit, desc=desc, file=sys.stderr, delay=delay,
                     initial=initial, dynamic_ncols=True, leave=True, smoothing=0.1,
                     mininterval=0.2, bar_format=fmt, **kw))


def write(line: str, file=None) -> None:
    """Print a line (default stdout) without breaking an open progress bar."""
    file = sys.stdout if file is None else file
    if _ACTIVE[0] > 0:
        from tqdm import tqdm
        tqdm.write(line, file=file)
        file.flush()
    else:
        print(line, file=file, flush=True)


_STAGE = [None]


def stage(desc: str, what: str, enabled: bool | None = None) -> None:
    """One line ``desc: what`` on stderr when progress is on (a study's current stage); the last
    stage is remembered (:func:`last_stage`) for the message of an interrupted study."""
    _STAGE[0] = what
    if progress_enabled(enabled):
        write(f"{desc}: {what}", file=sys.stderr)


def last_stage() -> str | None:
    return _STAGE[0]


def reset_stage() -> None:
    _STAGE[0] = None


def split_progress(progress, on_item=None):
    """(enabled, callback) from an API's ``progress`` argument: None/True/False switch the bar
    (module docstring); a callable is the older per-item callback ``progress(done, total,
    record)`` (the bar then stays automatic)."""
    if callable(progress) and not isinstance(progress, bool):
        return None, progress
    if progress is not None and not isinstance(progress, bool):
        from nld.errors import InputTypeError
        raise InputTypeError(f"progress = {progress!r}: must be True, False, None (automatic) "
                             "or a callable(done, total, record)")
    return progress, on_item
