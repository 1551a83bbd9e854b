"""The integrators are compiled once per machine, not once per scene (issue 23; nld.integrators.core).

These tests check numba's JIT path (``NLD_AOT=0``): the one a machine uses where the
install-time build of the cores (nld/integrators/aot.py, tests/test_aot.py) is absent or stale.

* A scene of another topology runs on the DOPRI5 already compiled: numba compiles no integrator
  for it (counted with numba's compile events) and DOPRI5 keeps one specialisation.
* The compiled-once build (the scene's functions passed as first-class function pointers) and the
  inlined build (the same integrator compiled with the functions inlined, the build before issue
  23) give the same trajectory, event log and step counts, bit for bit, on one scene per contact
  law: the indirection changes no arithmetic. The inlined build compiles the whole integrator per
  scene (seconds each), so the default run checks the shipped law and the memoryless one with a
  force jump; the other laws are slow tests.
"""
from __future__ import annotations

import numpy as np
import pytest
from numba.core import event

from nld.integrators import dopri5
from nld.integrators.core import inlined
from nld.integrators.dopri5 import dopri5_core, interp
from nld.integrators.events import EVENT_SAMPLES
from nld.systems.core import SceneSystem


class _Compiles(event.Listener):
    """Names of the functions numba compiles while installed."""

    def __init__(self):
        self.names = []

    def on_start(self, ev):
        d = ev.data.get("dispatcher")
        self.names.append(getattr(d, "__qualname__", getattr(d, "__name__", "?")))

    def on_end(self, ev):
        pass


def _run(system, revs=0.3):
    m = system.kernel.module
    t_eval = np.linspace(0.0, revs * system.period, 40)
    return dopri5(m.rhs, m.events, m.on_event, 0.0, system.y0.copy(), t_eval, False, system.p,
                  system.z0.copy(), 1e-8, system.tolerance(1e-8), 0.0, float(system.hmax), 10**7,
                  system.n_events, 10_000)


def test_a_scene_of_another_topology_compiles_no_integrator(monkeypatch):
    monkeypatch.setenv("NLD_AOT", "0")
    a = SceneSystem("slider_crank")
    _run(a)                                     # DOPRI5 is compiled (or loaded) here, once
    b = SceneSystem("four_bar")                 # another topology: another kernel
    assert b.kernel.key != a.kernel.key
    lis = _Compiles()
    with event.install_listener("numba:compile", lis):
        out = _run(b, revs=0.1)
    assert out.status == 0
    integrator_compiles = [nm for nm in lis.names if "core" in nm or "locate" in nm]
    assert integrator_compiles == [], integrator_compiles
    assert len(dopri5_core.signatures) == 1, dopri5_core.signatures
    # what was compiled for the new scene is its own functions only
    assert set(lis.names) <= {"rhs", "events", "on_event"} | {n for n in lis.names if "impl" in n}


def _indirect_equals_inlined(overrides):
    # the front's build (the install-time one where present and current, else the JIT's) against
    # the inlined twin; the install-time build against the JIT: tests/test_aot.py
    s = SceneSystem("slider_crank", overrides)
    m = s.kernel.module
    t_eval = np.linspace(0.0, 0.5 * s.period, 60)

    def args(z):
        return (0.0, s.y0.copy(), t_eval, False, s.p, z, 1e-8, s.tolerance(1e-8), 0.0,
                float(s.hmax), 10**7, s.n_events, 10_000, EVENT_SAMPLES)
    ind = dopri5(m.rhs, m.events, m.on_event, *args(s.z0.copy())[:-1])
    z = s.z0.copy()
    inl = inlined(dopri5_core)(m.rhs, m.events, m.on_event, interp, *args(z))
    assert ind.status == inl[0] == 0
    assert ind.n_ev == inl[8] > 0                       # the run has contact events
    assert np.array_equal(ind.Y, inl[2])                # bit for bit
    assert np.array_equal(ind.Z, inl[9])
    assert np.array_equal(ind.ev_t[:ind.n_ev], inl[5][:inl[8]])
    assert np.array_equal(ind.stats, inl[4])


@pytest.mark.parametrize("law", ["lankarani_nikravesh"])
def test_indirect_and_inlined_builds_agree_bit_for_bit(law):
    _indirect_equals_inlined({"joints.B.contact.law": law})


@pytest.mark.slow
@pytest.mark.parametrize("law", ["hertz_damped", "hertz", "hunt_crossley", "flores", "gonthier"])
def test_indirect_and_inlined_builds_agree_bit_for_bit_other_laws(law):
    _indirect_equals_inlined({"joints.B.contact.law": law})


def test_a_plain_python_function_is_refused_with_the_signature():
    from nld.errors import InputError
    from nld.integrators import native
    from nld.integrators.core import ON_EVENT_SIG

    def on_event(k, direction, t, y, p, z):
        return 0
    with pytest.raises(InputError, match="on_event.*numba-compiled.*on_event\\(k, direction"):
        native(on_event, ON_EVENT_SIG, "on_event")


@pytest.mark.parametrize("aot", ["1", "0"])
def test_an_exception_in_a_scene_function_propagates(monkeypatch, aot):
    """numba's C wrapper of a first-class function drops exceptions; nld passes the function's
    own entry point so that an error inside a model function (a singular matrix) is raised, as
    it was when the functions were inlined (nld.integrators.core._install_jit_address_hook);
    through the core built at install (where present) and through the JIT's."""
    from numba import njit
    monkeypatch.setenv("NLD_AOT", aot)

    from nld.integrators.core import JIT_ADDRESS_HOOK

    @njit
    def rhs(t, y, p, z, dy):
        if t > 0.5:
            raise ValueError("singular")
        dy[0] = 1.0
    if not JIT_ADDRESS_HOOK:
        pytest.skip("this numba has no hook for first-class function entry points")
    with pytest.raises(ValueError, match="singular"):
        dopri5(rhs, None, None, 0.0, np.array([0.0]), np.array([1.0]), False, np.zeros(0),
               np.zeros(0), 1e-6, np.array([1e-9]), 0.0, 0.0, 1000, 0, 1)
