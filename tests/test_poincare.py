"""Poincaré sections (nld.analysis.poincare): stroboscopic maps of scenes and of any ODE, hyperplane
sections, period detection; the section plots of nld.output.plots."""
import math

import numpy as np
import pytest
from numba import njit

from nld.errors import InputError
from nld.integrators.dopri5 import dopri5, no_events, no_on_event
from nld.analysis.poincare import hyperplane_section, period_of, stroboscopic, stroboscopic_rhs
from nld.run.simulate import crank_period, simulate
from nld.model.scene import load_scene
from nld.systems.core import duffing

from pathlib import Path as _Path
from nld.kernel.compile import drop_stale_numba_cache

# this module's njit(cache=True) wrappers inline nld's integrators; numba's cache checks only this
# file's timestamp (after an integrator change a local run would test stale code)
drop_stale_numba_cache(_Path(__file__))

TORQUE = ['driver.mode="torque"', "driver.inertia=1e-3", "driver.torque=0.0"]


# ------------------------------------------------------------------------------ period detection
def test_period_of_synthetic_sequences():
    rng = np.random.default_rng(1)
    base = rng.normal(size=(3, 2))
    assert period_of(np.tile(base[:1], (20, 1))) == 1
    assert period_of(np.tile(base, (10, 1))) == 3
    noisy = np.tile(base, (10, 1)) + 1e-9 * rng.normal(size=(30, 2))
    assert period_of(noisy, tol=1e-6) == 3
    assert period_of(noisy, tol=1e-12) == 0
    # the logistic map at r = 4 is chaotic: no period
    x = [0.3]
    for _ in range(199):
        x.append(4 * x[-1] * (1 - x[-1]))
    assert period_of(np.array(x)) == 0
    # a period needs every phase seen twice: 5 points cannot show period 3
    assert period_of(np.tile(base, (2, 1))[:5]) == 0
    assert period_of(np.tile(base, (4, 1)), n_max=2) == 0
    assert period_of(np.full((4, 1), np.nan)) == 0


# ------------------------------------------------------------------------------ generic ODE path
@njit(cache=True)
def _osc_rhs(t, y, p, z, dy):
    """x'' + 2 zeta w x' + w^2 x = cos(W t); p = [zeta, w, W]."""
    dy[0] = y[1]
    dy[1] = -2.0 * p[0] * p[1] * y[1] - p[1] * p[1] * y[0] + math.cos(p[2] * t)


def _osc_solve(t0, y0, t_eval, land, p, z, rtol, atol, h0, hmax, max_steps, n_events, max_log):
    return dopri5(_osc_rhs, no_events, no_on_event, t0, y0, t_eval, land, p, z, rtol, atol, h0,
                  hmax, max_steps, n_events, max_log)


def test_stroboscopic_rhs_matches_the_analytic_steady_state():
    """A damped linear oscillator forced at W: the stroboscopic points are the steady state
    x = Re H, x' = -W Im H with H = 1/(w^2 - W^2 + 2 i zeta w W), to 1e-9."""
    zeta, w, W = 0.1, 2.0, 1.3
    sec = stroboscopic_rhs(_osc_rhs, [0.0, 0.0], [zeta, w, W], 2 * math.pi / W,
                           transient_revs=150, revs=5, rtol=1e-11, solve=_osc_solve)
    assert sec.success, sec.message
    H = 1.0 / (w * w - W * W + 2j * zeta * w * W)
    assert list(sec.table.columns) == ["rev", "t", "y0", "y1"]
    assert np.allclose(sec.table.t, sec.table.rev * 2 * math.pi / W, rtol=0, atol=1e-12)
    assert np.abs(sec.table.y0 - H.real).max() < 1e-9
    assert np.abs(sec.table.y1 + W * H.imag).max() < 1e-9
    assert sec.period_of() == 1


@pytest.mark.parametrize("gamma,period", [(0.20, 1), (0.28, 2), (0.29, 4), (0.50, 0)])
def test_duffing_period_doubling_route(gamma, period):
    """Forced double-well Duffing (delta 0.3, omega 1.2): period 1, 2, 4, then chaos."""
    sec = stroboscopic(duffing(gamma=gamma), transient_revs=300, revs=64, rtol=1e-10)
    assert sec.success and len(sec.table) == 64
    assert period_of(sec.points, tol=1e-6) == period
    if period:
        # the periodic points agree to 1e-9 (relative to the orbit's size)
        P = sec.points
        scale = np.abs(P).max()
        assert np.abs(P[period:] - P[:-period]).max() < 1e-9 * scale


def test_duffing_continuation_is_the_same_trajectory():
    """y_final of a stroboscopic section, restarted at t = 0, continues the trajectory."""
    sysm = duffing(gamma=0.2)
    one = stroboscopic(sysm, transient_revs=0, revs=40, rtol=1e-10)
    a = stroboscopic(sysm, transient_revs=0, revs=20, rtol=1e-10)
    b = stroboscopic(sysm, transient_revs=0, revs=21, rtol=1e-10, y0=a.y_final, z0=a.z_final)
    assert np.array_equal(b.points[0], a.points[-1])       # rev 0 of b is the start state
    assert np.abs(b.points[1:] - one.points[20:]).max() < 1e-8


def test_level_crossing_section_of_duffing():
    """x = 0 crossed upwards: the located points have |x| ~ 0 and x' > 0; refine=False
    (cubic Hermite on the 360-per-period grid) agrees to 1e-7."""
    sysm = duffing(gamma=0.5)
    kw = dict(observable="x", level=0.0, direction=1, transient_revs=5, revs=20,
              observables=["x", "x_dot"], rtol=1e-10)
    sec = hyperplane_section(sysm, **kw)
    assert sec.success and len(sec.table) >= 5
    assert np.abs(sec.table.x).max() < 1e-10
    assert (sec.table.x_dot > 0).all()
    t = sec.table.t.to_numpy()
    assert t.min() >= 5 * sysm.period and np.all(np.diff(t) > 0)
    interp = hyperplane_section(sysm, refine=False, **kw)
    assert len(interp.table) == len(sec.table)
    assert np.abs(interp.table.t - sec.table.t).max() < 1e-7
    assert np.abs(interp.table.x_dot - sec.table.x_dot).max() < 1e-7
    both = hyperplane_section(sysm, **dict(kw, direction=0))
    down = hyperplane_section(sysm, **dict(kw, direction=-1))
    assert len(both.table) == len(sec.table) + len(down.table)
    assert (down.table.x_dot < 0).all()


# ------------------------------------------------------------------------------ scenes
def test_scene_stroboscopic_samples_exact_multiples_of_the_period():
    sc = load_scene("slider_crank")
    T = crank_period(sc)
    sec = stroboscopic(sc, transient_revs=3, revs=4, observables=["B.ex", "B.ey", "driver.angle"])
    assert sec.success, sec.message
    assert list(sec.table.columns) == ["rev", "t", "B.ex", "B.ey", "driver.angle"]
    assert list(sec.table.rev) == [3, 4, 5, 6]
    assert np.allclose(sec.table.t, sec.table.rev * T, rtol=1e-15, atol=0)
    # the crank is at its starting angle + 2 pi k exactly
    assert np.allclose(sec.table["driver.angle"], 2 * np.pi * sec.table.rev, rtol=1e-14)
    # landing at the sampling times gives the same points as a run that lands there itself (at the
    # section's tolerance: simulate's default is the scene's looser recommended rtol)
    r = simulate(sc, t_eval=sec.table.t.to_numpy(), land=True, t_end=sec.table.t.iloc[-1], rtol=1e-8)
    assert np.array_equal(r.table["B.ex"].to_numpy(), sec.table["B.ex"].to_numpy())
    # default observables: the first clearance joint's eccentricity components
    assert stroboscopic(sc, transient_revs=0, revs=2).observables == ["B.ex", "B.ey"]


def test_scene_stroboscopic_continuation():
    """Two sections chained by y_final/z_final agree with one run to a small fraction of the
    clearance (not exactly: the restart changes the step sequence)."""
    c, ov = 0.25e-3, ["driver.speed=10"]
    one = stroboscopic("four_bar", transient_revs=0, revs=5, overrides=ov)
    a = stroboscopic("four_bar", transient_revs=0, revs=3, overrides=ov)
    b = stroboscopic("four_bar", transient_revs=0, revs=3, y0=a.y_final, z0=a.z_final, overrides=ov)
    assert np.abs(b.points[0] - a.points[-1]).max() < 1e-12 * c     # the same state, t = 0 vs 2T
    assert np.abs(b.points[1:] - one.points[3:]).max() < 1e-6 * c


def test_four_bar_low_speed_is_period_one():
    """The four-bar at 10 rad/s (friction mu 0.01, permanent contact after the first
    revolution) settles on a period-1 orbit: after 60 revolutions successive stroboscopic
    points agree to < 1e-6 of the clearance (~1e-8 .. 1e-7 measured, an integration-noise
    floor that smaller rtol does not lower: see docs/analysis.md)."""
    c = 0.25e-3
    sec = stroboscopic("four_bar", transient_revs=60, revs=8, overrides=["driver.speed=10"])
    assert sec.success, sec.message
    assert period_of(sec.points, tol=1e-5) == 1
    assert np.ptp(sec.points, axis=0).max() < 1e-6 * c


def test_crank_angle_section_of_a_torque_driven_crank():
    """Free (torque-driven) crank: crossings of crank angle = 0 mod 2 pi are located to 1e-9 rad,
    and the section points equal those of a run that lands on the crossing times (to 1e-8 of the
    clearance at the first crossing; later ones drift apart as the impacts amplify the different
    step sequences of the two runs)."""
    sec = hyperplane_section("slider_crank", overrides=TORQUE, revs=4,
                             observables=["B.ex", "B.ey", "driver.angle", "driver.speed"])
    assert sec.success, sec.message
    assert len(sec.table) == 3
    ang = sec.table["driver.angle"].to_numpy()
    k = np.round(ang / (2 * np.pi))
    assert list(k) == [1, 2, 3]
    assert np.abs(ang - 2 * np.pi * k).max() < 1e-9
    assert (sec.table["driver.speed"] > 0).all()
    t = sec.table.t.to_numpy()
    r = simulate("slider_crank", overrides=TORQUE, t_eval=t, t_end=t[-1], land=True, rtol=1e-8)
    c = 0.5e-3
    err = np.abs(r.table[["B.ex", "B.ey"]].to_numpy() - sec.points[:, :2]).max(axis=1)
    assert err[0] < 1e-8 * c and err.max() < 1e-3 * c, err / c
    # cubic Hermite interpolation on the 360-per-revolution grid: times to 1e-11 s, journal
    # position to ~2e-6 of the clearance (measured)
    interp = hyperplane_section("slider_crank", overrides=TORQUE, revs=4, refine=False,
                                observables=["B.ex", "B.ey"])
    assert np.abs(interp.table.t.to_numpy() - t).max() < 1e-10
    assert np.abs(interp.points - sec.points[:, :2]).max() < 2e-5 * c
    with pytest.raises(InputError, match="speed-driven crank"):
        stroboscopic("slider_crank", overrides=TORQUE, revs=2)


def test_input_errors():
    with pytest.raises(InputError, match="no such column"):
        stroboscopic("slider_crank", revs=2, observables=["B.nope"])
    with pytest.raises(InputError, match="revs"):
        stroboscopic("slider_crank", revs=0)
    with pytest.raises(InputError, match="direction"):
        hyperplane_section("slider_crank", revs=1, direction=2)
    with pytest.raises(InputError, match="forcing period"):
        from nld.systems.core import lorenz
        stroboscopic(lorenz(), revs=2)


def test_section_plots():
    from nld.output.plots import exponent_convergence, poincare_scatter
    sec = stroboscopic(duffing(gamma=0.5), transient_revs=10, revs=50)
    fig = poincare_scatter(sec)
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x" and ax.get_ylabel() == "x_dot"     # an ODE: no units known
    sc = stroboscopic("slider_crank", transient_revs=1, revs=3)
    ax = poincare_scatter(sc, scale=1e3, unit="mm").axes[0]
    assert ax.get_xlabel() == "B.ex (mm)" and ax.get_ylabel() == "B.ey (mm)"
    t = np.arange(1, 101) * 0.1
    h = 0.9 + 1.0 / t
    fig = exponent_convergence(times=t, history=h, uncertainty=0.05, period=0.1,
                               per_revolution=True)
    ax = fig.axes[0]
    assert "revolution" in ax.get_xlabel() and "1/revolution" in ax.get_ylabel()
    import io
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    assert buf.getvalue()[:4] == b"\x89PNG"


def _patched_cli(monkeypatch):
    """nld.cli (kept as a helper of the CLI tests of poincare, bifurcation and spectrum: the
    analysis sub-commands are registered by nld.cli.app itself)."""
    from nld import cli
    return cli


def test_cli_poincare(monkeypatch, capsys, tmp_path):
    from nld.output.io import load_table
    cli = _patched_cli(monkeypatch)
    out = tmp_path / "sec.parquet"
    rc = cli.main(["poincare", "four_bar", "--set", "driver.speed=10", "--transient-revs", "2",
                   "--revs", "3", "--out", str(out)])
    assert rc == 0
    df, prov = load_table(out)
    assert list(df.columns) == ["rev", "t", "B.ex", "B.ey"] and list(df.rev) == [2, 3, 4]
    assert prov["kind"] == "stroboscopic" and "period_detected" in prov
    assert "period:" in capsys.readouterr().out
    rc = cli.main(["poincare", "slider_crank", "--set", 'driver.mode="torque"', "--angle", "0",
                   "--transient-revs", "0", "--revs", "2", "--observables", "B.ex,driver.speed"])
    assert rc == 0
    assert "driver.speed" in capsys.readouterr().out
    assert cli.main(["poincare", "slider_crank", "--observables", "B.zz"]) == 2
    assert "no such column" in capsys.readouterr().err


def test_period_of_uses_the_clearance_for_eccentricity_near_zero():
    """A fixed point whose ex is ~0 repeats to 1e-9 of the clearance: judged on its own tiny range
    it looks aperiodic; with section_scales (clearance for J.ex/J.ey) it is period 1."""
    import pandas as pd
    from nld.analysis.poincare import period_of, section_scales
    from nld.model.scene import load_scene
    scene = load_scene("slider_crank")
    c = scene.joints["B"].clearance
    rng = np.random.default_rng(0)
    pts = pd.DataFrame({"rev": np.arange(20), "B.ex": 1e-9 * c * rng.standard_normal(20),
                        "B.ey": -0.9 * c + 1e-9 * c * rng.standard_normal(20)})
    assert period_of(pts) == 0
    sc = section_scales(scene, pts)
    assert sc.tolist() == [c, c]
    assert period_of(pts, scale=sc) == 1
    # other columns keep the default (NaN), and a real period-2 orbit is still period 2
    pts2 = pts.assign(**{"rod.omega": np.tile([1.0, 3.0], 10)})
    sc2 = section_scales(scene, pts2)
    assert np.isnan(sc2[2]) and period_of(pts2, scale=sc2) == 2


def test_section_provenance_names_the_method_the_system_ran():
    """A section of a system that runs dop853 says so in its provenance and message (it said
    dopri5 whatever ran: issue 25). DOP853 is compiled once per machine (test_integrators and
    test_events use it too); the cached duffing_rhs is all this system adds."""
    from nld.systems.core import ContinuousSystem, duffing_rhs
    s = ContinuousSystem(duffing_rhs, [1.0, 0.0], [0.3, -1.0, 1.0, 0.5, 1.2], "duffing-dop853",
                         period=2 * math.pi / 1.2, method="dop853")
    for sec in (stroboscopic(s, transient_revs=0, revs=2),
                hyperplane_section(s, observable="y0", level=0.0, t_end=6.0)):
        assert sec.provenance["integrator"] == "dop853" and sec.message.startswith("dop853: reached")


# ------------------------------------------------------------------------------ one path (issue 24)
def test_stroboscopic_section_of_a_system_is_its_map_orbit():
    """A system's stroboscopic section is StroboscopicMap.orbit(land=True) point for point (one
    integration path), the first point the state after the transient (start=True)."""
    from nld.systems.derived import StroboscopicMap
    s = duffing(gamma=0.5)
    sec = stroboscopic(s, transient_revs=3, revs=6, rtol=1e-10)
    m = StroboscopicMap(s, rtol=1e-10)
    run = m.orbit(s.y0, n=6, transient=3, land=True, start=True)
    assert run.success and run.status == 0
    assert np.array_equal(sec.points, run.Y) and np.array_equal(sec.table.t, run.t)
    assert np.array_equal(sec.y_final, run.Y[-1]) and sec.t_final == run.t_reached
    # without the start point: the same chunks, so the same points from the second on
    later = m.orbit(s.y0, n=5, transient=3, land=True)
    assert np.array_equal(later.Y, run.Y[1:])
    # the dense-output default (the census) agrees to the integration error
    dense = m.orbit(s.y0, n=5, transient=3)
    assert np.abs(dense.X - later.X).max() < 1e-6


def test_interrupted_scene_section_keeps_the_points_reached(monkeypatch):
    """Ctrl-C during a scene's stroboscopic section (SIGINT sent during the second period's
    integration): Interrupted whose partial Section holds the points reached, equal to those of
    the uninterrupted section."""
    import os
    import signal
    from nld.errors import Interrupted
    import nld.run.simulate as simmod
    full = stroboscopic("slider_crank", transient_revs=1, revs=5)
    two = stroboscopic("slider_crank", transient_revs=1, revs=2)
    real = simmod.integrate_chunked
    calls = []

    def chunked(solve, *a, **kw):
        def solve_and_signal(*b):
            calls.append(1)
            if len(calls) == 2:
                os.kill(os.getpid(), signal.SIGINT)
            return solve(*b)
        return real(solve_and_signal, *a, **kw)
    monkeypatch.setattr(simmod, "integrate_chunked", chunked)
    with pytest.raises(Interrupted) as e:
        stroboscopic("slider_crank", transient_revs=1, revs=5)
    part = e.value.partial
    assert part.status == simmod.INTERRUPTED and part.message.startswith("interrupted")
    assert list(part.table.rev) == [1, 2] and part.provenance["partial"] is True
    assert np.array_equal(part.points, full.points[:2])
    assert np.array_equal(part.y_final, two.y_final) and part.t_final == two.t_final
    assert "2 of 5 section points" in e.value.kept


def test_one_crossing_locator_for_hyperplane_sections_and_poincare_maps():
    """nld.systems.section.locate_crossing (Brent on landing integrations) is the locator of
    hyperplane_section and of PoincareMap: the same crossing from another bracket agrees to the
    integration error; a Poincaré map's point lies on its plane to ~|dy/dt| 1e-13."""
    from nld.systems import PoincareMap
    from nld.systems.core import lorenz
    from nld.systems.section import land, locate_crossing
    s = duffing(gamma=0.5)
    rtol, atol = 1e-10, s.tolerance(1e-10)
    sec = hyperplane_section(s, observable="x", level=0.0, direction=1, t_end=20.0,
                             observables=["x", "x_dot"], rtol=rtol)
    tc = float(sec.table.t.iloc[0])
    ya, za = land(s, s.y0, s.z0, 0.0, tc - 0.01, rtol, atol, s.hmax, 10**6)
    t, y, _ = locate_crossing(s, lambda t, y, z: y[0], tc - 0.01, ya, za, tc + 0.01, rtol=rtol)
    assert abs(t - tc) < 1e-7 and abs(y[0]) < 1e-12 and y[1] > 0
    # no sign change on the landing integrations: the bracket's right end
    t, y1, _ = locate_crossing(s, lambda t, y, z: 1.0, tc - 0.01, ya, za, tc + 0.01, rtol=rtol)
    assert t == tc + 0.01
    P = PoincareMap(lorenz(), [0.0, 0.0, 1.0], 27.0, +1, rtol=1e-10)
    x = np.array([1.0, 1.0, 22.0])
    for _ in range(3):
        x = P.step(x).x
        assert abs(x[2] - 27.0) < 1e-9
