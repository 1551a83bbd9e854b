"""The sweep engine shared by bifurcation sweeps, chaos maps and studies: a resumable per-point
result store (store), executors that run a function over points in this process, on a local
process pool or on Dask (executors), and a sweep loop with progress, resume and Ctrl-C handling
(engine). It knows nothing of scenes or analyses: a point is ``fn(payload, *item)`` returning a
record (a dict with ``direction``, ``index`` and ``table``).

    from nld.sweeps import ResultStore, run_points
"""
from nld.sweeps.engine import Tracker, interrupted, record_key, run_points
from nld.sweeps.executors import batches, check_workers, dask_client, execute
from nld.sweeps.store import META_KEY, PROVENANCE, ResultStore, read_point

__all__ = ["ResultStore", "PROVENANCE", "META_KEY", "read_point", "execute", "batches",
           "check_workers", "dask_client", "run_points", "Tracker", "interrupted", "record_key"]
