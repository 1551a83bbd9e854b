"""A whole sweep: resume from a store, run the remaining points, count them, survive Ctrl-C.

    from nld.sweeps.engine import run_points
    from nld.sweeps.store import ResultStore
    store = ResultStore(out)
    store.prepare(provenance, settings=SETTINGS, resume=resume)
    done = store.finished() if resume else {}
    results = run_points(run_point, payload, items, done=done, store=store, workers=4,
                         desc="my sweep", progress=None)
    # results: {(group, index): record} of every finished point, resumed ones included

``items`` are the argument tuples of the points still to run (``fn(payload, *item)``, see
:func:`nld.sweeps.executors.execute`); a record's key is ``(record["direction"],
record["index"])``. A progress bar counts the points (``progress``: None automatic, True, False;
:mod:`nld.progress`), ``on_point(done, total, record)`` is called as each one finishes.

Ctrl-C (KeyboardInterrupt) while the points run: the pool is ended, the finished points are
already in the store, and :class:`nld.errors.Interrupted` is raised whose ``kept`` says how many
and that ``resume=True`` (``--resume``) continues.

A sweep whose points depend on each other (a continuation, run in this process) uses
:class:`Tracker` directly::

    with Tracker(total, done=len(done), store=store, desc="...") as track:
        for item in chain:
            track.finished(run_and_write(item))
"""
from __future__ import annotations

from contextlib import closing

from nld.errors import Interrupted
from nld.sweeps.executors import execute

__all__ = ["run_points", "Tracker", "interrupted", "record_key"]


def record_key(rec: dict) -> tuple:
    """The key of a record: ``(direction, index)``."""
    return (rec["direction"], int(rec["index"]))


def interrupted(n_done: int, total: int, store=None, what: str = "points") -> Interrupted:
    """The :class:`nld.errors.Interrupted` of a sweep stopped by Ctrl-C after ``n_done`` of
    ``total`` points (``what``: "points", "cells" ...)."""
    if store is not None:
        # workers write each point as it finishes, before its batch comes back: count the files
        n_done = max(n_done, store.count())
        kept = (f"{n_done} of {total} {what} finished and kept in {store.path} (the ones in "
                "progress were abandoned); run the same command with --resume (resume=True) to "
                "continue")
    else:
        kept = f"{n_done} of {total} {what} had finished; nothing written (no out directory)"
    return Interrupted(f"interrupted after {n_done} of {total} {what}", kept=kept)


class Tracker:
    """Progress of a sweep (a context manager): ``finished(record)`` files a result, advances the
    bar and calls ``on_point``; ``results`` holds the records by key (the ``done`` ones first).
    A KeyboardInterrupt inside the block leaves it as :func:`interrupted`."""

    def __init__(self, total: int, *, done: dict | None = None, store=None, desc: str | None = None,
                 unit: str = "point", what: str | None = None, progress=None, on_point=None):
        self.total = int(total)
        self.results = dict(done or {})
        self.n_done = len(self.results)
        self.store = store
        self.what = what or f"{unit}s"
        self.on_point = on_point
        self._bar_args = dict(total=self.total, unit=unit, desc=desc, enabled=progress,
                              initial=self.n_done)
        self._bar = None

    def __enter__(self) -> "Tracker":
        from nld.progress import progress_bar
        self._bar = progress_bar(**self._bar_args).__enter__()
        return self

    def finished(self, rec: dict) -> None:
        self.results[record_key(rec)] = rec
        self.n_done += 1
        self._bar.update(1)
        if self.on_point is not None:
            self.on_point(self.n_done, self.total, rec)

    def __exit__(self, typ, exc, tb):
        self._bar.__exit__(typ, exc, tb)
        if typ is not None and issubclass(typ, KeyboardInterrupt):
            err = interrupted(self.n_done, self.total, self.store, self.what)
            err.__suppress_context__ = True
            raise err
        return False


def run_points(fn, payload, items, *, done: dict | None = None, store=None, workers=None,
               dask=None, batch_size: int | None = None, warm=None, progress=None,
               on_point=None, desc: str | None = None, unit: str = "point",
               what: str | None = None, total: int | None = None) -> dict:
    """Run the points still to do (``items``) and return ``{key: record}`` of all finished
    points, the ``done`` ones included (module docstring). ``total``: the number of points of the
    whole sweep (default ``len(done) + len(items)``); workers, dask, batch_size, warm, store: as
    :func:`nld.sweeps.executors.execute`."""
    items = list(items)
    done = dict(done or {})
    total = len(done) + len(items) if total is None else total
    with Tracker(total, done=done, store=store, desc=desc, unit=unit, what=what,
                 progress=progress, on_point=on_point) as track:
        with closing(execute(fn, payload, items, workers=workers, dask=dask,
                             batch_size=batch_size, warm=warm, store=store)) as results:
            for rec in results:
                track.finished(rec)
    return track.results
