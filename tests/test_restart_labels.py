"""Restarts from a state reached at another time keep the switched loads' branches right
(nld.systems.core.restart_labels, Kernel.time_labels).

The excavator's crushing torque (``crank_halves``, seed eq. 19) switches sign at every whole crank
revolution: exactly where stroboscopic runs stop. A run that stops a round-off before the switch
carries the old branch (-1) in z; restarted near the time origin (``period_shift`` in the
Lyapunov runs, a map's next iteration from t0), sin(omega t) was exactly 0 there, the integrator
saw no crossing and the torque kept the wrong sign for half a revolution. Tangent runs of the
excavator sat in one-impact motions for tens of revolutions (local rates near 0 against ~11 per
revolution once the loads were right): the fix sets the time's labels from the state at every
such restart.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from nld.analysis.poincare import stroboscopic
from nld.run.simulate import simulate
from nld.systems.core import SceneSystem, restart_labels
from nld.systems.derived import StroboscopicMap

RTOL = 1e-7


@pytest.fixture(scope="module")
def excavator():
    """The excavator, its state at the end of a 2-point section (a whole revolution) and the z whose crushing
    torque branch is the one before the switch (-1), as a run stopping a round-off early leaves it."""
    S = SceneSystem("excavator")
    sec = stroboscopic("excavator", transient_revs=0, revs=2, rtol=RTOL, observables=["A.ex"])
    assert sec.success
    ZL = S.kernel.z_layout
    i0 = ZL.load[0]                     # loads.0: crank_halves
    z_before = np.array(sec.z_final, float)
    z_before[i0] = -1.0
    return S, np.array(sec.y_final, float), z_before, i0, float(sec.table["t"].iloc[-1])


def test_the_branch_follows_the_crank_angle(excavator):
    S, y, z, i0, _ = excavator
    P = S.period
    others = [i for i in range(z.size) if i != S.kernel.z_layout.load[0]
              and i != S.kernel.z_layout.load[1]]
    # on the switch (t = 0: sin q = 0, the crank turning forward) and inside the first half
    for t in (0.0, 0.25 * P):
        zz = restart_labels(S, t, y, z)
        assert zz[i0] == 1.0
        np.testing.assert_array_equal(zz[others], z[others])   # contact labels are kept
    zz = restart_labels(S, 0.75 * P, y, np.where(np.arange(z.size) == i0, 1.0, z))
    assert zz[i0] == -1.0
    assert z[i0] == -1.0                                     # the caller's array is not changed
    # a system without switched loads keeps z as it is
    sc = SceneSystem("slider_crank")
    assert restart_labels(sc, 0.0, sc.y0, sc.z0) is sc.z0


def test_a_restart_on_the_switch_continues_the_motion(excavator):
    """From the section point with the pre-switch branch: restarted at t = 0 (the time origin a
    continued run uses) the motion is the one the run continued at the section time gives."""
    S, y, z, i0, t_sec = excavator
    P = S.period
    k = round(t_sec / P)
    assert k >= 1 and math.isclose(t_sec, k * P, rel_tol=1e-12)     # a whole revolution
    a = simulate("excavator", t_end=0.3 * P, rtol=RTOL, y0=y, z0=z, t0=0.0, samples_per_rev=36)
    b = simulate("excavator", t_end=t_sec + 0.3 * P, rtol=RTOL, y0=y, z0=z, t0=t_sec,
                 samples_per_rev=36)
    assert a.success and b.success
    onsets = [int(((r.events["direction"] == 1) & r.events["joint"].isin(["A", "B"])).sum())
              for r in (a, b)]
    assert onsets[0] == onsets[1] > 3               # impacts, the same number (0 with the bug)
    scale = S.scales
    assert np.max(np.abs(a.y_final - b.y_final) / scale) < 1e-2
    # a map's iteration from t0 likewise: its z carries the branch of the previous iterate
    m = StroboscopicMap(S, 1, RTOL)
    s1 = m.step(m.pack(y, z), z)
    zp = z.copy()
    zp[i0] = 1.0
    s2 = m.step(m.pack(y, zp), zp)
    np.testing.assert_array_equal(s1.x, s2.x)


def test_the_tangent_run_does_not_depend_on_the_carried_branch(excavator):
    """lyapunov_tangent from the section point: the same local rates whichever branch z carries
    (with the bug: the wrong torque for the first half revolution, and no impacts)."""
    from nld.analysis.lyapunov import lyapunov_tangent
    S, y, z, i0, _ = excavator
    out = []
    for b in (-1.0, 1.0):
        Sx = SceneSystem("excavator")
        Sx.y0, Sx.z0 = y.copy(), z.copy()
        Sx.z0[i0] = b
        r = lyapunov_tangent(Sx, transient=0.0, align=0.0, total=0.5 * S.period, rtol=RTOL,
                             progress=False)
        out.append(r)
    np.testing.assert_array_equal(out[0].local_rates, out[1].local_rates)
    assert out[0].diagnostics["upward_crossings"] > 3


def test_revolution_maxima_from_a_section_point_does_not_depend_on_the_carried_branch(excavator):
    """nld.analysis.extrema.revolution_maxima(y0=, z0=) restarts at t = 0 as simulate does."""
    from nld.analysis.extrema import revolution_maxima
    S, y, z, i0, _ = excavator
    runs = []
    for b in (-1.0, 1.0):
        zb = z.copy()
        zb[i0] = b
        runs.append(revolution_maxima("excavator", ["rod.omega"], revs=1, rtol=RTOL,
                                      samples_per_rev=720, keep_every=1, refine_top=0, y0=y, z0=zb))
    assert runs[0].status == runs[1].status == 0
    np.testing.assert_array_equal(runs[0].maxima["peak"], runs[1].maxima["peak"])
    np.testing.assert_array_equal(runs[0].y_final, runs[1].y_final)
