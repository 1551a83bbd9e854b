"""The integrator cores built at install (nld/integrators/aot.py).

* Where a C compiler is present, the install built them and they are current (a fresh clone
  installed by the README's command: this is CI's case).
* The fronts call the built cores: a run compiles no integrator with numba.
* Built and JIT cores give the same trajectory, event log and step counts, bit for bit
  (DOPRI5 on a scene with contacts in the default run; DOP853, Rodas4, the tangent DOPRI5 and
  the delay integrator as slow tests: each JIT build costs 10-15 s of compilation).
* A stamp that does not match the sources (an edited integrator) selects the JIT.
"""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from nld.integrators import aot
from nld.integrators.dopri5 import dopri5_core
from nld.systems.core import SceneSystem

_COMPILER = shutil.which("cc") or shutil.which("gcc")
needs_build = pytest.mark.skipif(aot.why_not() != "", reason=f"cores not built: {aot.why_not()}")


@pytest.mark.skipif(_COMPILER is None, reason="no C compiler: the install cannot build the cores")
def test_the_install_built_current_cores():
    assert aot.why_not() == "", (
        f"{aot.why_not()}: rebuild with `python -m nld.integrators.aot_build` (or reinstall)")
    for name in aot.CORES:
        assert aot.built(name) is not None, name


@needs_build
def test_the_fronts_call_the_built_cores(monkeypatch):
    monkeypatch.delenv("NLD_AOT", raising=False)
    assert aot.compiled(dopri5_core) is aot.built("dopri5_core")
    before = len(dopri5_core.signatures)
    s = SceneSystem("four_bar")
    r = s.kernel.module.solve(0.0, s.y0.copy(), np.linspace(0, 0.1 * s.period, 5), False, s.p,
                              s.z0.copy(), 1e-7, s.tolerance(1e-7), 0.0, s.hmax, 10**6,
                              s.n_events, 100)
    assert int(r.status) == 0
    assert len(dopri5_core.signatures) == before       # numba compiled no DOPRI5
    monkeypatch.setenv("NLD_AOT", "0")
    assert aot.compiled(dopri5_core) is dopri5_core


def _solve_both(monkeypatch, run):
    monkeypatch.setenv("NLD_AOT", "1")
    a = run()
    monkeypatch.setenv("NLD_AOT", "0")
    b = run()
    return a, b


def _same_solution(a, b):
    assert int(a.status) == int(b.status) == 0
    assert np.array_equal(a.Y, b.Y, equal_nan=True)
    assert np.array_equal(a.Z, b.Z)
    assert a.n_ev == b.n_ev
    assert np.array_equal(a.ev_t[:a.n_ev], b.ev_t[:b.n_ev])
    assert np.array_equal(a.ev_k[:a.n_ev], b.ev_k[:b.n_ev])
    assert np.array_equal(a.stats, b.stats)


def _scene_run(method):
    from nld.integrators import dop853, dopri5, rodas
    fn = {"dopri5": dopri5, "dop853": dop853, "rodas": rodas}[method]
    s = SceneSystem("slider_crank")
    m = s.kernel.module
    t_eval = np.linspace(0.0, 0.5 * s.period, 60)

    def run():
        return fn(m.rhs, m.events, m.on_event, 0.0, s.y0.copy(), t_eval, False, s.p,
                  s.z0.copy(), 1e-8, s.tolerance(1e-8), 0.0, float(s.hmax), 10**7, s.n_events,
                  10_000)
    return run


@needs_build
def test_built_and_jit_dopri5_agree_bit_for_bit(monkeypatch):
    a, b = _solve_both(monkeypatch, _scene_run("dopri5"))
    assert a.n_ev > 0                                   # the run has contact events
    _same_solution(a, b)


@pytest.mark.slow
@needs_build
@pytest.mark.parametrize("method", ["dop853", "rodas"])
def test_built_and_jit_agree_bit_for_bit_other_methods(monkeypatch, method):
    _same_solution(*_solve_both(monkeypatch, _scene_run(method)))


@pytest.mark.slow
@needs_build
def test_built_and_jit_tangent_and_delay_agree_bit_for_bit(monkeypatch):
    from nld.integrators.delay import DelayLaw, dde
    from nld.systems.tangent import run_tangent
    s = SceneSystem("slider_crank")
    n, nz = s.y0.size, s.z0.size

    def tangent():
        W = np.eye(2, n)
        return run_tangent(s, s.y0.copy(), s.z0.copy(), W, np.zeros((2, nz)), 0.0,
                           np.array([0.25 * s.period, 0.5 * s.period]), 1e-9), W
    (ta, Wa), (tb, Wb) = _solve_both(monkeypatch, tangent)
    assert np.array_equal(Wa, Wb)
    assert np.array_equal(np.asarray(ta.y), np.asarray(tb.y))

    law = DelayLaw.make(2, 0, [0.7], [0], kinds=[0], targets=[1], gd=[[0.3]], gy=[[-0.3, 0.0]])

    from numba import njit

    @njit
    def rhs(t, y, p, z, dy):
        dy[0] = y[1]
        dy[1] = -0.1 * y[1] - y[0] - y[0] ** 3 + 0.3 * np.cos(1.2 * t)

    def delayed():
        return dde(rhs, None, None, 0.0, np.array([1.0, 0.0]), np.linspace(0, 20, 41), False,
                   np.zeros(0), np.zeros(0), 1e-8, np.full(2, 1e-10), 0.0, 0.0, 10**6, 0, 1, law)
    da, db = _solve_both(monkeypatch, delayed)
    assert int(da.status) == int(db.status) == 0
    assert np.array_equal(da.Y, db.Y) and np.array_equal(da.U, db.U)


def test_a_stale_stamp_selects_the_jit(monkeypatch, tmp_path):
    stale = tmp_path / "_aot.json"
    stale.write_text(json.dumps(dict(aot.stamp(), sources="0" * 64)))
    monkeypatch.setattr(aot, "STAMP", stale)
    monkeypatch.setattr(aot, "STATE", {})
    monkeypatch.delenv("NLD_AOT", raising=False)
    assert aot.why_not() == "stale: built for other sources"
    assert aot.compiled(dopri5_core) is dopri5_core
    monkeypatch.setattr(aot, "STAMP", tmp_path / "missing.json")
    monkeypatch.setattr(aot, "STATE", {})
    assert aot.why_not().startswith("not built")
    assert aot.compiled(dopri5_core) is dopri5_core


# ---- the build's bookkeeping, with stand-in children (the real build takes ~40 s of CPU)

def _previous_build(out):
    (out / "_aot.json").write_text("previous")
    (out / "_aot_dopri5_core.so").write_text("previous")


def test_a_failed_build_keeps_the_previous_one(monkeypatch, tmp_path):
    from nld.integrators import aot_build
    _previous_build(tmp_path)
    monkeypatch.setattr(aot_build, "_CHILD", "import sys; print('RuntimeError: no compiler'); "
                                             "sys.exit(1)")
    with pytest.raises(RuntimeError) as e:
        aot_build.build(tmp_path, jobs=2)
    assert str(e.value) == ("dopri5_core, dop853_core, rodas_core, dopri5_tangent_core, "
                            "dde_core: RuntimeError: no compiler")
    assert (tmp_path / "_aot.json").read_text() == "previous"
    assert (tmp_path / "_aot_dopri5_core.so").read_text() == "previous"


def test_a_build_moves_its_modules_in_and_writes_the_stamp_last(monkeypatch, tmp_path):
    from nld.integrators import aot_build
    _previous_build(tmp_path)
    monkeypatch.setattr(aot_build, "_CHILD", (
        "import sys, pathlib; root, name, out = sys.argv[1:4]; p = pathlib.Path(out); "
        "p.mkdir(parents=True, exist_ok=True); (p / ('_aot_' + name + '.so')).write_text(name)"))
    seen = []
    paths = aot_build.build(tmp_path, jobs=2, progress=lambda name, s: seen.append(name))
    assert sorted(seen) == sorted(aot.CORES)
    assert sorted(p.name for p in paths) == sorted(f"_aot_{c}.so" for c in aot.CORES)
    assert (tmp_path / "_aot_dopri5_core.so").read_text() == "dopri5_core"
    assert json.loads((tmp_path / "_aot.json").read_text()) == aot.stamp()


def test_an_interrupted_build_leaves_no_child_and_the_previous_build(monkeypatch, tmp_path):
    import os
    import time
    from nld.integrators import aot_build
    out = tmp_path / "out"
    out.mkdir()
    _previous_build(out)
    pids = tmp_path / "pids"
    pids.mkdir()
    monkeypatch.setattr(aot_build, "_CHILD", (
        "import os, sys, time, pathlib; root, name, out = sys.argv[1:4]; "
        f"(pathlib.Path({str(pids)!r}) / name).write_text(str(os.getpid())); "
        "time.sleep(0 if name == 'dopri5_core' else 60)"))

    def stop(name, seconds):
        deadline = time.time() + 20          # the second child has started and said who it is
        while not (pids / "dop853_core").exists() and time.time() < deadline:
            time.sleep(0.05)
        raise KeyboardInterrupt
    t = time.time()
    with pytest.raises(KeyboardInterrupt):
        aot_build.build(out, jobs=2, progress=stop)
    assert time.time() - t < 30
    pid = int((pids / "dop853_core").read_text())
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)                      # killed and reaped
    assert (out / "_aot.json").read_text() == "previous"


@needs_build
def test_a_law_made_by_hand_with_other_dtypes_runs_as_the_checked_one(monkeypatch):
    """The built core reads its arguments as the types it was built for (a wrong dtype is not
    compiled anew as with the JIT, it is misread: it crashed the process); the delay front
    coerces a DelayLaw made without DelayLaw.make."""
    import dataclasses

    from numba import njit

    from nld.integrators.delay import DelayLaw, dde

    @njit
    def rhs(t, y, p, z, dy):
        dy[0] = y[1]
        dy[1] = -y[0]
    law = DelayLaw.make(2, 0, [0.7], [0], kinds=[0], targets=[1], gd=[[0.3]], gy=[[-0.3, 0.0]])
    odd = dataclasses.replace(law, signals=law.signals.astype(np.int32),
                              kinds=law.kinds.astype(np.int32), targets=law.targets.tolist(),
                              gd=np.asfortranarray(law.gd))
    monkeypatch.setenv("NLD_AOT", "1")
    runs = [dde(rhs, None, None, 0.0, np.array([1.0, 0.0]), np.linspace(0, 5, 6), False,
                np.zeros(0), np.zeros(0), 1e-8, np.full(2, 1e-10), 0.0, 0.0, 10**6, 0, 1, lw)
            for lw in (law, odd)]
    assert int(runs[0].status) == int(runs[1].status) == 0
    assert np.array_equal(runs[0].Y, runs[1].Y)


@needs_build
def test_a_built_core_unpickles_its_signatures_once(monkeypatch):
    """pycc's modules unpickle their first-class functions' signatures at every call (70 us a
    call); nld hands them a memoising unpickler at import (nld.integrators.aot._MemoLoads): after
    the first call no call unpickles again."""
    monkeypatch.setenv("NLD_AOT", "1")
    run = _scene_run("dopri5")
    run()
    memo = aot.STATE[("loads", "dopri5_core")]
    assert len(memo.memo) > 0                    # the module unpickles through it
    calls = []
    real = aot._PICKLE_LOADS
    monkeypatch.setattr(aot, "_PICKLE_LOADS", lambda *a, **k: calls.append(1) or real(*a, **k))
    run()
    assert calls == []
