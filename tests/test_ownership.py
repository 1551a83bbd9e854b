"""Borrowed views in the integrators' step loops (nld.integrators.ownership): a view shares the
data of its owner, carries no owner itself, and the integrators that use them neither leak nor
free their work arrays early (every allocation of a run is freed once, after it)."""
import gc

import numpy as np
from numba import njit
from numba.core.runtime import _nrt_python as _nrt, rtsys

from nld.integrators.ownership import borrowed, keep_alive
from nld.systems.core import SceneSystem
from nld.systems.tangent import run_tangent


@njit(cache=False)
def _write_through(a, b):
    owners = (a, b)
    va, vb = borrowed(owners)
    va[0] = 7.0
    vb[1, 1] = -3.0
    v = borrowed(a)
    v[2] += 1.0
    keep_alive(owners)
    return a, b


@njit(cache=False)
def _view_of(a):
    v = borrowed(a)
    v[0] = 1.5
    return a[0], v.shape[0], v.strides[0]


def test_a_borrowed_view_writes_into_its_owner():
    a = np.zeros(3)
    b = np.zeros((2, 2))
    ra, rb = _write_through(a, b)
    assert ra is a or np.shares_memory(ra, a)
    np.testing.assert_array_equal(a, [7.0, 0.0, 1.0])
    np.testing.assert_array_equal(b, [[0.0, 0.0], [0.0, -3.0]])
    x = np.zeros(4)
    first, size, stride = _view_of(x)
    assert (first, size, stride) == (1.5, 4, 8)


def _net_allocations():
    s = rtsys.get_allocation_stats()
    return s.alloc - s.free, s.mi_alloc - s.mi_free


def test_runs_free_every_work_array_once(monkeypatch):
    """After a trajectory and a tangent run (results dropped), numba's allocator has freed
    exactly what the runs allocated: the owners of the borrowed views are released (no leak)
    and none twice (the counts would go below the start). On numba's JIT build (the cores built
    at install carry their own allocator, whose counts are not exported; they are compiled from
    the same code)."""
    monkeypatch.setenv("NLD_AOT", "0")
    S = SceneSystem("slider_crank")
    m = S.kernel.module
    te = np.linspace(0.0, S.period, 20)

    def run():
        r = m.solve(0.0, S.y0.copy(), te, False, S.p, S.z0.copy(), 1e-8, S.tolerance(1e-8), 0.0,
                    S.hmax, 10**6, S.n_events, 100)
        n, nz = S.y0.size, S.z0.size
        W = np.eye(2, n)
        tr = run_tangent(S, S.y0.copy(), S.z0.copy(), W, np.zeros((2, nz)), 0.0,
                         np.array([0.5 * S.period, S.period]), 1e-9)
        return r, tr

    run()                                  # compile and warm
    _nrt.memsys_enable_stats()
    try:
        gc.collect()
        before = _net_allocations()
        out = run()
        assert int(out[0].status) == 0
        during = _net_allocations()
        del out
        gc.collect()
        after = _net_allocations()
    finally:
        _nrt.memsys_disable_stats()
    assert during[0] > before[0]           # the results are alive while held
    assert after == before
