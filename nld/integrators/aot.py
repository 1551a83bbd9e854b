"""The integrator cores built ahead of time, at install, into extension modules.

numba compiles an integrator core once per machine (``nld.integrators.core``: the scene's
functions are first-class function arguments), but that once costs a new user 8-20 s before the
first result (docs/performance.md, "Cold, new scene, warm"). ``pip install`` therefore also builds
the five cores -- ``dopri5_core``, ``dop853_core``, ``rodas_core``, ``dopri5_tangent_core`` and
``dde_core`` -- with ``numba.pycc`` into extension modules ``nld/integrators/_aot_<core>*.so``
(setup.py calls ``nld.integrators.aot_build.build``), for exactly the argument types the Python
fronts call them with. At run time :func:`compiled` hands a front the built core when it is
present and current, and numba's JIT dispatcher otherwise.

*Current* means: built from the same sources of ``nld/integrators`` (and ``nld/settings.py``,
``nld/errors.py``), by the same numba and numpy versions as the running ones; a stamp file
``_aot.json`` written beside the module records these, and any difference (an edited integrator
in a development checkout, an upgraded numba) selects the JIT silently. ``NLD_AOT=0`` in the
environment selects the JIT too (for comparisons). The build itself never fails an install: where
it cannot run (no C compiler), nld uses the JIT, as before. Rebuild in place after editing an
integrator: ``python -m nld.integrators.aot_build``.

Both builds run the same code on the same arithmetic: their trajectories are bit-identical
(tests/test_aot.py). ``numba.pycc`` is deprecated by numba (still in 0.68) without a successor for
this use; the JIT path stays the reference (docs/performance.md, "Built at install").
"""
from __future__ import annotations

import hashlib
import importlib
import json
import os
import pickle
from pathlib import Path

from nld.interrupt import called_from_compiled

HERE = Path(__file__).resolve().parent
PREFIX = "_aot_"
STAMP = HERE / "_aot.json"
CORES = ("dopri5_core", "dop853_core", "rodas_core", "dopri5_tangent_core", "dde_core")
SOURCES = ("integrators/*.py", "settings.py", "errors.py")


def stamp() -> dict:
    """What the built modules must match: the hash of the sources they are built from and the
    numba and numpy versions."""
    import numba
    import numpy
    h = hashlib.sha256()
    root = HERE.parent
    for pattern in SOURCES:
        for f in sorted(root.glob(pattern)):
            h.update(f.relative_to(root).as_posix().encode())
            h.update(f.read_bytes())
    return {"sources": h.hexdigest(), "numba": numba.__version__,
            "numpy": ".".join(numpy.__version__.split(".")[:2])}


STATE: dict = {}      # the build state ("current", "why"; aot_build sets "record" while it builds)


def why_not() -> str:
    """Why the built cores are not used ('' when they are)."""
    _current()
    return STATE["why"]


def _current() -> bool:
    """Whether the stamp matches these sources and versions (checked once per process)."""
    if "current" not in STATE:
        try:
            recorded = json.loads(STAMP.read_text())
        except (OSError, ValueError):
            STATE["current"], STATE["why"] = False, "not built (no nld/integrators/_aot.json)"
        else:
            now = stamp()
            diff = [k for k in now if recorded.get(k) != now[k]]
            STATE["current"] = not diff
            STATE["why"] = f"stale: built for other {', '.join(diff)}" if diff else ""
    return STATE["current"]


_PICKLE_LOADS = pickle.loads


class _MemoLoads:
    """``pickle.loads`` with a memo on the bytes, handed to a built module as its unpickler.

    A module built by numba.pycc unpickles, at every call, the signature of each first-class
    function argument to unbox it (numba's JIT memoises this; pycc's copy of its helper calls
    ``pickle.loads`` directly): 26 numba types per DOPRI5 call, about 70 us on top of the call's
    own 8 us (benchmarks/bench_solve_front.py). The module
    looks ``pickle.loads`` up once, at its first unpickling, which is its import (it rebuilds its
    environments' constants there), and keeps it; :func:`built` imports it with this in place.
    What it unpickles are its own constants (types, signatures, exception arguments), the same
    bytes every call, so one object per distinct byte string serves. (``pickle.loads`` is
    replaced only while the module is imported, once per process.)"""

    def __init__(self):
        self.memo: dict = {}

    def __call__(self, data, *args, **kwargs):
        try:
            return self.memo[data]
        except (KeyError, TypeError):
            obj = _PICKLE_LOADS(data, *args, **kwargs)
            if not args and not kwargs and isinstance(data, bytes):
                self.memo[data] = obj
            return obj


called_from_compiled(_MemoLoads.__call__)


def built(name: str):
    """The built core ``name`` if present and current, else None (looked up once per process)."""
    key = ("core", name)
    if key not in STATE:
        fn = None
        if _current():
            pickle.loads = STATE[("loads", name)] = _MemoLoads()   # the module keeps it
            try:
                fn = getattr(importlib.import_module(f"{__package__}.{PREFIX}{name}"), name)
            except (ImportError, AttributeError) as e:
                STATE["why"] = f"{name}: {e}"
            finally:
                pickle.loads = _PICKLE_LOADS
        STATE[key] = fn
    return STATE[key]


def compiled(core):
    """The integrator core to call: the built one when present and current (and ``NLD_AOT`` is
    not ``0``), else ``core``, numba's dispatcher. While ``aot_build.signatures`` records, a
    recorder."""
    rec = STATE.get("record")
    if rec is not None:
        return rec(core)
    if os.environ.get("NLD_AOT", "1") == "0":
        return core
    return built(core.__name__) or core
