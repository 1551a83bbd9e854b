"""Building the integrator cores ahead of time (the runtime side: nld/integrators/aot.py).

``python -m nld.integrators.aot_build [DIR]`` builds them in place (after editing an
integrator in a development checkout); setup.py calls :func:`build` at install. Each core is
compiled by ``numba.pycc`` into its own extension module, in its own process (numba 0.68's pycc
types a later core of one module wrongly after an earlier one: "No conversion from int64 to
Literal[int](2) for 'status'"), for the argument types its Python front passes, recorded from the
fronts themselves on a one-state sample problem (:func:`signatures`).
"""
from __future__ import annotations

import importlib
import json
import os
import sys
from pathlib import Path

from .aot import CORES, HERE, PREFIX, STAMP, STATE, stamp


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
    STATE["record"] = recorder
    try:
        for name in only:
            try:
                calls[name]()
            except _Recorded:
                pass
    finally:
        del STATE["record"]
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
from nld.integrators.aot_build import build_one
build_one(name, out)
"""


def build(output_dir: str | Path = HERE, jobs: int | None = None, verbose: bool = False,
          progress=None) -> list:
    """Build every core into ``output_dir``, each in its own process (``jobs`` at a time,
    default the CPU count); returns the modules' paths. The modules are built in a temporary
    folder and moved in place, with the stamp written last, only when all five are built: a
    failed or interrupted build leaves the previous modules and stamp as they were (and no child
    process: they are killed on the way out). ``progress(name, seconds)`` is called as each core
    is done. Raises RuntimeError naming each reason of failure with the cores it stopped."""
    import subprocess
    import tempfile
    import time

    out = Path(output_dir)
    out.mkdir(parents=True, exist_ok=True)
    root = str(HERE.parent.parent)
    jobs = max(1, jobs or os.cpu_count() or 1)
    t0 = time.perf_counter()
    running: list = []
    try:
        with tempfile.TemporaryDirectory(prefix="nld-aot-") as work:
            cache, staged = Path(work) / "numba-cache", Path(work) / "modules"
            env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONWARNINGS="ignore")
            pending = list(CORES)
            failed = []
            while pending or running:
                while pending and len(running) < jobs:
                    name = pending.pop(0)
                    proc = subprocess.Popen([sys.executable, "-c", _CHILD, root, name,
                                             str(staged)], env=env, stdout=subprocess.PIPE,
                                            stderr=subprocess.STDOUT, text=True)
                    running.append((name, proc))
                name, proc = running[0]
                text, _ = proc.communicate()
                running.pop(0)
                if verbose and text:
                    print(text)
                if proc.returncode != 0:
                    lines = [ln for ln in text.strip().splitlines() if "Error" in ln] or \
                        text.strip().splitlines()[-1:] or ["no output"]
                    failed.append((name, lines[-1][:200]))
                elif progress is not None:
                    progress(name, time.perf_counter() - t0)
            if failed:
                reasons: dict = {}
                for name, why in failed:
                    reasons.setdefault(why, []).append(name)
                raise RuntimeError("; ".join(f"{', '.join(names)}: {why}"
                                             for why, names in reasons.items()))
            stamp_file = out / STAMP.name
            stamp_file.unlink(missing_ok=True)
            paths = []
            for f in sorted(staged.glob(PREFIX + "*")):
                os.replace(f, out / f.name)
                paths.append(out / f.name)
            stamp_file.write_text(json.dumps(stamp(), indent=1) + "\n")
            return paths
    finally:
        for _, proc in running:
            proc.kill()
            proc.wait()


def main(argv=None) -> int:
    """``python -m nld.integrators.aot_build [DIR]``: build in place (or into DIR), a line per
    core as it is done; Ctrl-C / SIGTERM stop it (exit 130 / 143) leaving the previous build."""
    import signal
    import time
    argv = sys.argv[1:] if argv is None else argv

    term = []

    def on_term(signum, frame):
        term.append(signum)
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_term)
    t = time.perf_counter()
    done = []

    def progress(name, seconds):
        done.append(name)
        print(f"built {name} ({len(done)}/{len(CORES)}, {seconds:.0f} s)", flush=True)
    try:
        paths = build(argv[0] if argv else HERE, progress=progress)
    except KeyboardInterrupt:
        print("nld: build interrupted; the previous build (if any) is kept", file=sys.stderr)
        return 143 if term else 130
    except RuntimeError as e:
        print(f"nld: build failed: {e}", file=sys.stderr)
        return 1
    except OSError as e:
        print(f"nld: output folder {argv[0] if argv else HERE}: {e.strerror or e}", file=sys.stderr)
        return 2
    print(f"built {len(paths)} modules in {time.perf_counter() - t:.1f} s")
    return 0


if __name__ == "__main__":
    # run the package's own module (the fronts consult its state), not this __main__ copy
    from nld.integrators.aot_build import main as _main
    raise SystemExit(_main())
