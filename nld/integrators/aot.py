"""The integrator cores built ahead of time, at install, into an extension module.

numba compiles an integrator core once per machine (``nld.integrators.core``: the scene's
functions are first-class function arguments), but that once costs a new user 8-20 s before the
first result (docs/performance.md, "Cold, new scene, warm"). ``pip install`` therefore also builds
the five cores -- ``dopri5_core``, ``dop853_core``, ``rodas_core``, ``dopri5_tangent_core`` and
``dde_core`` -- with ``numba.pycc`` into extension modules ``nld/integrators/_aot_<core>*.so``
(setup.py calls :func:`build`; one module per core, each built in its own process: numba 0.68's
pycc types a later core of the same module wrongly after an earlier one), for exactly the signatures the Python fronts call them with (recorded from the
fronts themselves, :func:`signatures`). At run time :func:`compiled` hands a front the built core
when it is present and current, and numba's JIT dispatcher otherwise.

*Current* means: built from the same sources of ``nld/integrators`` (and ``nld/settings.py``,
``nld/errors.py``), by the same numba and numpy versions as the running ones; a stamp file
``_aot.json`` written beside the module records these, and any difference (an edited integrator
in a development checkout, an upgraded numba) selects the JIT silently. ``NLD_AOT=0`` in the
environment selects the JIT too (for comparisons). The build itself never fails an install: where
it cannot run (no C compiler), nld uses the JIT, as before. Rebuild in place after editing an
integrator: ``python -m nld.integrators.aot``.

Both builds run the same code on the same arithmetic: their trajectories are bit-identical
(tests/test_aot.py). ``numba.pycc`` is deprecated by numba (still in 0.68) without a successor for
this use; the JIT path stays the reference (docs/performance.md, "Built at install").
"""
from __future__ import annotations

import hashlib
import importlib
import json
import os
import sys
from pathlib import Path

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


_STATE: dict = {}


def why_not() -> str:
    """Why the built cores are not used ('' when they are)."""
    _current()
    return _STATE["why"]


def _current() -> bool:
    """Whether the stamp matches these sources and versions (checked once per process)."""
    if "current" not in _STATE:
        try:
            recorded = json.loads(STAMP.read_text())
        except (OSError, ValueError):
            _STATE["current"], _STATE["why"] = False, "not built (no nld/integrators/_aot.json)"
        else:
            now = stamp()
            diff = [k for k in now if recorded.get(k) != now[k]]
            _STATE["current"] = not diff
            _STATE["why"] = f"stale: built for other {', '.join(diff)}" if diff else ""
    return _STATE["current"]


def built(name: str):
    """The built core ``name`` if present and current, else None (looked up once per process)."""
    key = ("core", name)
    if key not in _STATE:
        fn = None
        if _current():
            try:
                fn = getattr(importlib.import_module(f"{__package__}.{PREFIX}{name}"), name)
            except (ImportError, AttributeError) as e:
                _STATE["why"] = f"{name}: {e}"
        _STATE[key] = fn
    return _STATE[key]


def compiled(core):
    """The integrator core to call: the built one when present and current (and ``NLD_AOT`` is
    not ``0``), else ``core``, numba's dispatcher. While :func:`signatures` records, a recorder."""
    rec = _STATE.get("record")
    if rec is not None:
        return rec(core)
    if os.environ.get("NLD_AOT", "1") == "0":
        return core
    return built(core.__name__) or core


class _Recorded(Exception):
    pass


def signatures(only=CORES) -> dict:
    """{core name: its argument types} for the cores ``only``, recorded from the Python fronts on
    a one-state sample problem (so the built signatures are the ones the fronts call with;
    compiles the sample's small functions only)."""
    import numpy as np
    from numba import njit, typeof

    dopri5, dop853, rosenbrock = (importlib.import_module(f"{__package__}.{m}")
                                  for m in ("dopri5", "dop853", "rosenbrock"))
    from .delay import DelayLaw, dde
    from .tangent import dopri5_tangent

    got: dict = {}

    def recorder(core):
        def record(*args):
            got[core.__name__] = tuple(typeof(a) for a in args)
            raise _Recorded
        return record

    @njit(cache=False)
    def rhs(t, y, p, z, dy):
        dy[0] = -y[0]

    @njit(cache=False)
    def jvp(t, y, p, z, dy, t_d, y_d, z_d, dy_d):
        dy_d[0] = -y_d[0]

    y0, te, p, z, atol = np.ones(1), np.array([0.0, 1.0]), np.zeros(1), np.zeros(0), np.ones(1)
    calls = {
        "dopri5_core": lambda: dopri5.dopri5(rhs, None, None, 0.0, y0, te, False, p, z, 1e-6, atol, 0.0, 0.0,
                              10, 0, 1),
        "dop853_core": lambda: dop853.dop853(rhs, None, None, 0.0, y0, te, False, p, z, 1e-6, atol, 0.0, 0.0,
                              10, 0, 1),
        "rodas_core": lambda: rosenbrock.rodas(rhs, None, None, 0.0, y0, te, False, p, z, 1e-6, atol, 0.0, 0.0,
                                 10, 0, 1),
        "dopri5_tangent_core": lambda: dopri5_tangent(rhs, jvp, None, None, None, None, 0.0, y0, z, np.ones((1, 1)),
                               np.zeros((1, 0)), np.array([1.0]), p, 1e-6, atol, np.ones(1), 0.0,
                               0.0, 10, 0, True, False, np.zeros(8), np.zeros((1, 1))),
        "dde_core": lambda: dde(rhs, None, None, 0.0, y0, te, False, p, z, 1e-6, atol, 0.0, 0.0, 10, 0, 1,
                    DelayLaw.make(1, 1, [0.5], [0])),
    }
    _STATE["record"] = recorder
    try:
        for name in only:
            try:
                calls[name]()
            except _Recorded:
                pass
    finally:
        del _STATE["record"]
    missing = [c for c in only if c not in got]
    if missing:
        raise RuntimeError(f"no call recorded for {missing}")
    return got


def build_one(name: str, output_dir: str | Path = HERE, verbose: bool = False) -> Path:
    """Build the extension module of the core ``name`` into ``output_dir`` (the package
    directory ``nld/integrators``) with numba.pycc; returns its path. Needs a C compiler."""
    import warnings

    from numba.core.errors import NumbaExperimentalFeatureWarning
    from numba.pycc import CC

    modules = {"dopri5_core": "dopri5", "dop853_core": "dop853", "rodas_core": "rosenbrock",
               "dopri5_tangent_core": "tangent", "dde_core": "delay"}
    fn = getattr(importlib.import_module(f"{__package__}.{modules[name]}"), name)
    sig = signatures((name,))[name]
    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    cc = CC(PREFIX + name)
    cc.output_dir = str(out)
    cc.verbose = verbose
    cc.export(name, sig)(fn.py_func)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NumbaExperimentalFeatureWarning)
        cc.compile()
    return out / cc._output_file


# run in a fresh interpreter with only numpy and numba importable (setup.py's build
# environment): the package nld is stubbed so that nld/__init__.py (which needs scipy and the
# rest) does not run; nld.integrators needs only nld.errors and nld.settings.
_CHILD = """
import sys, types
root, name, out = sys.argv[1:4]
pkg = types.ModuleType("nld")
pkg.__path__ = [root + "/nld"]
sys.modules["nld"] = pkg
from nld.integrators.aot import build_one
build_one(name, out)
"""


def build(output_dir: str | Path = HERE, jobs: int | None = None, verbose: bool = False) -> list:
    """Build every core into ``output_dir``, each in its own process (``jobs`` at a time,
    default the CPU count), then write the stamp; returns the modules' paths. The stamp is
    removed first and written last: an interrupted or failed build is never used. Raises
    RuntimeError naming the core whose build failed (with its last output lines)."""
    import subprocess
    import tempfile

    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    stamp_file = out / STAMP.name
    stamp_file.unlink(missing_ok=True)
    root = str(HERE.parent.parent)
    jobs = max(1, jobs or os.cpu_count() or 1)
    with tempfile.TemporaryDirectory(prefix="nld-aot-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, PYTHONWARNINGS="ignore")
        pending = list(CORES)
        running: list = []
        failed = []
        while pending or running:
            while pending and len(running) < jobs:
                name = pending.pop(0)
                proc = subprocess.Popen([sys.executable, "-c", _CHILD, root, name, str(out)],
                                        env=env, stdout=subprocess.PIPE,
                                        stderr=subprocess.STDOUT, text=True)
                running.append((name, proc))
            name, proc = running.pop(0)
            text, _ = proc.communicate()
            if verbose and text:
                print(text)
            if proc.returncode != 0:
                failed.append(f"{name}: {' | '.join(text.strip().splitlines()[-3:])}")
        if failed:
            raise RuntimeError("ahead-of-time build failed: " + "; ".join(failed))
    paths = sorted(out.glob(PREFIX + "*"))
    stamp_file.write_text(json.dumps(stamp(), indent=1) + "\n")
    return paths


def main(argv=None) -> int:
    """``python -m nld.integrators.aot [DIR]``: build in place (or into DIR)."""
    import time
    argv = sys.argv[1:] if argv is None else argv
    t = time.perf_counter()
    paths = build(argv[0] if argv else HERE)
    print(f"built {len(paths)} modules in {time.perf_counter() - t:.1f} s: "
          + ", ".join(p.name for p in paths))
    return 0


if __name__ == "__main__":
    # run the package's own module (the fronts consult its state), not this __main__ copy
    from nld.integrators.aot import main as _main
    raise SystemExit(_main())
