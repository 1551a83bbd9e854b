"""Run one function over many independent points: in this process, on a local process pool, or on
a Dask cluster; results come back as they finish.

    from nld.sweeps.executors import execute
    for record in execute(run_point, payload, items, workers=4, store=store, warm=(warm_up, args)):
        ...                                   # each record as its point finishes

``fn(payload, *item)`` runs for every ``item`` of ``items`` and returns a record (a dict, see
:mod:`nld.sweeps.store`); ``fn``, ``payload`` and the items must be picklable (``fn`` a module-level
function). With a ``store`` every record is written to it as soon as its point finishes, exactly
once: by the worker process itself on the local pool (a killed sweep keeps every finished point),
by this process otherwise (Dask workers need not see the output directory).

* ``workers=1``: in this process, in order (:func:`serial`).
* ``workers=N`` (default: the CPU count, at most one per item): a ``ProcessPoolExecutor`` of
  spawned processes (:func:`process_pool`), items sent in batches (default ``ceil(items / (4
  workers))`` per batch). Every worker first runs ``warm[0](*warm[1])`` once (e.g. load a compiled
  kernel from numba's cache; its errors are ignored: the points report their own), ignores
  SIGINT and shows no progress bars. On Ctrl-C (or any error) the pool is ended at once
  (:func:`nld.interrupt.end_pool`): the points in progress are abandoned, the finished ones are
  already in the store.
* ``dask=``: a ``distributed.Client`` or a scheduler address (:func:`on_dask`); every worker
  runs the warm-up once, batches are Dask tasks, and Ctrl-C cancels them.

The numbers do not depend on where a point ran. :func:`execute` is a generator: close it (or run
it to the end) to release the pool.
"""
from __future__ import annotations

import math
import os
from concurrent.futures import ProcessPoolExecutor, as_completed

from nld.errors import InputError
from nld.interrupt import end_pool, spawning
from nld.output.io import remove_temporary

__all__ = ["execute", "serial", "process_pool", "on_dask", "dask_client", "batches",
           "check_workers", "portable", "FORWARDED_ENV"]

# environment variables a worker takes over from this process (where it has none of its own)
FORWARDED_ENV = ("NLD_CACHE_DIR",)


def check_workers(workers) -> int:
    """``workers`` as an int >= 1 (None: the CPU count), else InputError."""
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"workers = {workers!r}: must be an integer >= 1")
    return workers


def batches(items, n_workers: int, batch_size: int | None = None) -> list[list]:
    """``items`` cut into batches of ``batch_size`` (default ceil(len / (4 n_workers)))."""
    items = list(items)
    if batch_size is None:
        batch_size = max(1, math.ceil(len(items) / (4 * max(1, n_workers))))
    batch_size = int(batch_size)
    if batch_size < 1:
        raise InputError(f"batch_size = {batch_size}: must be >= 1")
    return [items[k:k + batch_size] for k in range(0, len(items), batch_size)]


# ---------------------------------------------------------------------------------------------------
# in the workers


def _init_worker(env: dict, warm) -> int:
    """A worker's set-up: SIGINT ignored (the main process ends the pool), no progress bars, the
    forwarded environment, then the caller's warm-up; returns the pid."""
    from nld.interrupt import ignore_in_worker
    from nld.progress import set_default
    ignore_in_worker()
    set_default(False)
    for k, v in env.items():
        if not os.environ.get(k):
            os.environ[k] = v
    if warm is not None:
        fn, args = warm
        try:
            fn(*args)
        except Exception:         # noqa: BLE001 - the points report their own errors
            pass
    return os.getpid()


def _run_one(fn, payload, item, out):
    rec = fn(payload, *item)
    if out is not None:
        from nld.sweeps.store import ResultStore
        ResultStore(out).write(rec)
    return rec


def _run_batch(fn, payload, batch, out=None) -> list:
    try:
        return [_run_one(fn, payload, item, out) for item in batch]
    except Exception as e:
        raise portable(e) from None


def portable(e: BaseException) -> BaseException:
    """``e`` if it survives pickling (nld's errors do: nld.errors.Picklable), else a RuntimeError
    with its class name and message: an error that cannot be rebuilt in the main process would
    break the pool (BrokenProcessPool) and hide the worker's message."""
    import pickle
    try:
        pickle.loads(pickle.dumps(e))
        return e
    except Exception:             # noqa: BLE001 - any failure to pickle or to rebuild
        return RuntimeError(f"{type(e).__name__} in a worker process: {e}")


def _env() -> dict:
    return {k: os.environ[k] for k in FORWARDED_ENV if os.environ.get(k)}


# ---------------------------------------------------------------------------------------------------
# the executors


def serial(fn, payload, items, *, store=None):
    """Every item in this process, in order; each record written to ``store`` before it is yielded."""
    for item in items:
        rec = fn(payload, *item)
        if store is not None:
            store.write(rec)
        yield rec


def process_pool(fn, payload, items, *, workers: int, batch_size: int | None = None, warm=None,
                 store=None):
    """The items on ``workers`` spawned processes, in batches (module docstring); yields the
    records as their batches finish. The workers write the records to ``store``."""
    import multiprocessing as mp
    parts = batches(items, workers, batch_size)
    out = None if store is None else str(store.path)
    ex = ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn"),
                             initializer=_init_worker, initargs=(_env(), warm))
    futures = []
    try:
        with spawning():          # workers and the pool's threads start with SIGINT/SIGTERM blocked
            futures = [ex.submit(_run_batch, fn, payload, b, out) for b in parts]
        for fut in as_completed(futures):
            yield from fut.result()
    except BaseException:
        # Ctrl-C, an error or the consumer stopped: do not wait for the points in progress
        for f in futures:
            f.cancel()
        pids = end_pool(ex)
        if out is not None:       # a worker ended while it wrote a point leaves its temporary file
            remove_temporary(out, pids)
        raise
    ex.shutdown(wait=True)


def dask_client(dask):
    """(client, own) for ``dask``: a ``distributed.Client`` (own False) or a scheduler address
    (a new client, own True: close it after use)."""
    try:
        from distributed import Client
    except ImportError:
        raise InputError("dask: the distributed package is missing: "
                         "pip install \"dask[distributed]\"") from None
    if isinstance(dask, Client):
        return dask, False
    if isinstance(dask, str):
        try:
            return Client(dask, timeout="30s"), True
        except OSError as e:
            raise InputError(f"dask = {dask!r}: cannot reach the scheduler ({e})") from None
    raise InputError(f"dask = {dask!r}: give a distributed.Client or a scheduler address")


def on_dask(fn, payload, items, dask, *, batch_size: int | None = None, warm=None, store=None):
    """The items on a Dask cluster (``dask``: a Client or a scheduler address); every worker runs
    the warm-up once; yields the records as their batches finish, after writing them to
    ``store`` in this process."""
    from distributed import as_completed as dask_completed
    client, own = dask_client(dask)
    try:
        n_workers = max(1, len(client.scheduler_info().get("workers", {})))
        client.run(_init_worker, _env(), warm)
        futures = [client.submit(_run_batch, fn, payload, b, pure=False)
                   for b in batches(items, n_workers, batch_size)]
        try:
            for fut in dask_completed(futures):
                for rec in fut.result():
                    if store is not None:
                        store.write(rec)
                    yield rec
        except BaseException:
            try:
                client.cancel(futures)
            except Exception:     # noqa: BLE001
                pass
            raise
    finally:
        if own:
            client.close()


def execute(fn, payload, items, *, workers=None, dask=None, batch_size: int | None = None,
            warm=None, store=None):
    """Run ``fn(payload, *item)`` for every item: on Dask when ``dask`` is given, else on
    ``workers`` local processes (None: the CPU count; 1, or a single item: in this process).
    Yields the records as they finish (module docstring)."""
    items = list(items)
    if not items:
        return
    if dask is not None:
        yield from on_dask(fn, payload, items, dask, batch_size=batch_size, warm=warm, store=store)
        return
    workers = min(check_workers(workers), len(items))
    if workers == 1:
        yield from serial(fn, payload, items, store=store)
    else:
        yield from process_pool(fn, payload, items, workers=workers, batch_size=batch_size,
                                warm=warm, store=store)


class Background:
    """``fn(*args)`` on one spawned worker process (set up as the pool's: SIGINT ignored, killed
    with its parent, no progress bars, the forwarded environment) while the caller goes on, e.g.
    a study's route to chaos beside its sweep's pool: the main process only waits for the pool,
    and a second thread of it would hold the GIL through its compiled calls and stall the pool's
    result reading. ``fn``, ``args`` and the result must pickle. Use it as a context manager:
    leaving the block by an exception (Ctrl-C, SIGTERM, an error) ends the process at once
    (nld.interrupt.end_pool) instead of waiting for it. ``result()`` waits and returns the value
    or raises the worker's error."""

    def __init__(self, fn, *args):
        import multiprocessing as mp
        self._ex = ProcessPoolExecutor(max_workers=1, mp_context=mp.get_context("spawn"),
                                       initializer=_init_worker, initargs=(_env(), None))
        with spawning():
            self._future = self._ex.submit(_call, fn, args)

    def result(self):
        try:
            value = self._future.result()
        except BaseException:
            end_pool(self._ex)
            raise
        self._ex.shutdown(wait=True)
        return value

    def cancel(self) -> None:
        """End the worker now (its work is lost)."""
        self._future.cancel()
        end_pool(self._ex)

    def __enter__(self):
        return self

    def __exit__(self, kind, value, tb):
        if kind is not None:
            self.cancel()
        return False


def _call(fn, args):
    try:
        return fn(*args)
    except Exception as e:
        raise portable(e) from None

