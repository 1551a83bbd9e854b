#!/usr/bin/env python
"""A fixed set of results, captured so that two commits can be compared bit for bit.

    python benchmarks/capture_results.py OUT.npz            # capture (about a minute warm)
    python benchmarks/capture_results.py --compare A.npz B.npz
    python benchmarks/capture_results.py --list             # the cases

For a refactoring that must not change any number (issue 39: one System interface, one
integrator call site): capture on the commit before and on the commit after, then compare. The
comparison prints ``identical`` (exit 0), or every differing key with the maximum absolute
difference (exit 1); keys present in one file only count as differences.

What is captured (each case a few seconds warm; the first run of a fresh checkout also compiles):
  sim.*        ``nld.run.simulate`` of four built-in scenes (slider_crank, slider_crank_olyaei,
               four_bar, excavator) over short spans: the output table, the final state, the
               integrator's counters, the event log;
  sys.*        ``nld.systems``: trajectory() and advance() of the scene systems, Lorenz and
               Duffing; a stroboscopic map step with its Jacobian (tangent integrator) and a
               Poincare map step;
  orbit.*      ``nld.analysis.orbits.periodic_orbit``: slider_crank_olyaei's period-1 orbit
               (permanent contact), the Duffing double well's period-1 orbit and the Henon
               fixed point, the impact oscillator's period-1 orbit, the period-1 orbits that
               find_orbits finds on the chaotic Duffing, with their multipliers;
  census.*     ``nld.analysis.attractors.census`` of the forced double well (two period-1
               attractors) and of a map;
  control.*    ``nld.analysis.control``: OGY on the Henon map, a short Pyragas run on Rossler;
  lyap.*       ``nld.analysis.lyapunov``: Benettin on Lorenz, the spectrum of Duffing, the tangent
               exponent and Benettin on the slider-crank scene (short runs).
Every result object is flattened into named arrays (numbers, arrays, strings; nested objects one
level down): nothing is pickled. Timings and anything with a wall-clock time are left out.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

SKIP = ("time", "elapsed", "wall", "seconds", "cpu")     # field names that hold timings


def _skip(name: str) -> bool:
    low = name.lower()
    return any(s in low for s in SKIP) or name.startswith("_")


def _flatten(prefix: str, obj, out: dict, depth: int = 0) -> None:
    """Numbers, arrays and strings of ``obj`` (a result object, dict, list) under ``prefix``."""
    if obj is None:
        out[prefix] = np.array("None")
    elif isinstance(obj, (bool, np.bool_, int, np.integer, float, np.floating, complex,
                          np.complexfloating)):
        out[prefix] = np.array(obj)
    elif isinstance(obj, str):
        out[prefix] = np.array(obj)
    elif isinstance(obj, np.ndarray):
        if obj.dtype.kind in "biufcUS":
            out[prefix] = obj.copy()
        elif obj.dtype.kind == "O" and depth < 3:
            for i, v in enumerate(obj.ravel()):
                _flatten(f"{prefix}[{i}]", v, out, depth + 1)
    elif isinstance(obj, (list, tuple)):
        try:
            a = np.asarray(obj)
            if a.dtype.kind in "biufcUS" and a.size:
                out[prefix] = a
                return
        except (ValueError, TypeError):
            pass
        if depth < 3:
            for i, v in enumerate(obj):
                _flatten(f"{prefix}[{i}]", v, out, depth + 1)
    elif isinstance(obj, dict):
        if depth < 3:
            for k, v in obj.items():
                if not _skip(str(k)):
                    _flatten(f"{prefix}.{k}", v, out, depth + 1)
    elif hasattr(obj, "to_numpy") and hasattr(obj, "columns"):           # a DataFrame
        out[prefix + ".columns"] = np.array([str(c) for c in obj.columns])
        for c in obj.columns:
            col = obj[c].to_numpy()
            out[f"{prefix}[{c}]"] = col if col.dtype.kind in "biufc" else col.astype(str)
    elif depth < 3:
        if dataclasses.is_dataclass(obj):
            names = [f.name for f in dataclasses.fields(obj)]
        else:
            names = list(getattr(obj, "__dict__", {}))
            names += [n for n in getattr(type(obj), "__slots__", ())]
        for k in names:
            if _skip(k):
                continue
            try:
                v = getattr(obj, k)
            except AttributeError:
                continue
            if callable(v) and not isinstance(v, np.ndarray):
                continue
            _flatten(f"{prefix}.{k}", v, out, depth + 1)


# ------------------------------------------------------------------ the cases
def case_simulate(out):
    from nld.run.simulate import simulate
    for name, revs, kw in (("slider_crank", 2.0, {}),
                           ("slider_crank_olyaei", 3.0, {}),
                           ("four_bar", 2.0, {}),
                           ("excavator", 0.2, {})):
        r = simulate(name, revs=revs, samples_per_rev=50, progress=False, **kw)
        _flatten(f"sim.{name}", dict(table=r.table, status=r.status, t_reached=r.t_reached,
                                     stats=r.stats, events=r.events, y_final=r.y_final,
                                     z_final=r.z_final), out)


def case_systems(out):
    from nld.systems import SceneSystem, StroboscopicMap, PoincareMap, advance, duffing, lorenz, trajectory
    for name, revs in (("slider_crank", 2), ("slider_crank_olyaei", 2), ("four_bar", 1)):
        s = SceneSystem(name)
        t, Y = trajectory(s, 40, s.period / 20, transient=s.period)
        out[f"sys.{name}.trajectory"] = Y
        y, z = advance(s, s.y0, s.z0, s.t0, s.t0 + revs * s.period)
        out[f"sys.{name}.advance.y"], out[f"sys.{name}.advance.z"] = y, z
    s = SceneSystem("excavator")
    t, Y = trajectory(s, 20, s.period / 200, transient=s.period / 20)
    out["sys.excavator.trajectory"] = Y
    y, z = advance(s, s.y0, s.z0, s.t0, s.t0 + 0.1 * s.period)
    out["sys.excavator.advance.y"], out["sys.excavator.advance.z"] = y, z
    L = lorenz()
    out["sys.lorenz.trajectory"] = trajectory(L, 200, 0.05, transient=1.0)[1]
    out["sys.lorenz.advance"] = advance(L, L.y0, L.z0, 0.0, 3.0)[0]
    D = duffing()
    out["sys.duffing.trajectory"] = trajectory(D, 200, D.period / 10, transient=5 * D.period)[1]
    out["sys.duffing.advance"] = advance(D, D.y0, D.z0, 0.0, 7 * D.period)[0]
    # derived maps: a stroboscopic step of a scene with its Jacobian (tangent integrator), a
    # Poincare step of Lorenz (section z = 27, upwards)
    m = StroboscopicMap(SceneSystem("slider_crank"), 1)
    x, z = m.y0, m.z0
    for _ in range(3):
        st = m.step(x, z, relabel=True)
        x, z = st.x, st.z
    _flatten("sys.strobe.slider_crank", m.step(x, z, jacobian=True, relabel=True), out)
    _flatten("sys.strobe.duffing", StroboscopicMap(D, 1).step(D.y0, D.z0, jacobian=True), out)
    P = PoincareMap(L, [0.0, 0.0, 1.0], 27.0, +1)
    x = P.y0
    for i in range(3):
        st = P.step(x, P.z0)
        _flatten(f"sys.poincare.lorenz[{i}]", st, out)
        x = st.x


def case_orbits(out):
    from nld.analysis.orbits import periodic_orbit
    from nld.systems import SceneSystem, duffing, henon
    o = periodic_orbit(SceneSystem("slider_crank_olyaei"), 1, transient=10, rtol=1e-10)
    _flatten("orbit.slider_crank_olyaei", o, out)
    D = duffing(delta=0.5, alpha=-1.0, beta=1.0, gamma=0.1, omega=1.4)
    _flatten("orbit.duffing_well", periodic_orbit(D, 1, [1.0, 0.0], rtol=1e-10), out)
    _flatten("orbit.henon", periodic_orbit(henon(), 1, [0.5, 0.1]), out)
    from nld.systems import impact_oscillator       # events and a discrete state: tests/test_orbits.py
    _flatten("orbit.impact", periodic_orbit(impact_oscillator(0.05, 0.8, 1.0, 1.5, 10.0, 0.5), 1,
                                            [1.0, 0.5], rtol=1e-11), out)
    from nld.analysis.orbits import find_orbits
    for i, o in enumerate(find_orbits(duffing(), max_period=1)):
        _flatten(f"orbit.duffing_find[{i}]", o, out)


def case_census(out):
    from nld.analysis.attractors import census
    from nld.systems import duffing
    s = duffing(delta=0.5, alpha=-1.0, beta=1.0, gamma=0.1, omega=1.4)
    r = census(s, 12, sampler=((-1.5, -1.0), (1.5, 1.0)), transient=30, record=32, progress=False)
    _flatten("census.double_well", r, out)
    from nld.systems import logistic
    r = census(logistic(3.5), 8, sampler=((0.1,), (0.9,)), transient=200, record=32, progress=False)
    _flatten("census.logistic", r, out)


def case_control(out):
    from nld.analysis import control as C
    from nld.systems import henon
    r = C.ogy(henon(), 0, dp_max=0.1, radius=0.1, n_iter=1500, x0=[0.1, 0.1], lyapunov_iter=100)
    _flatten("control.ogy_henon", r, out)
    S = C.rossler()
    fb = C.pyragas(S, 0.2, 5.88, "y")
    r = C.control_delayed(S, fb, transient=20.0, duration=12 * 5.88, lyapunov_span=8 * 5.88)
    _flatten("control.pyragas_rossler", r, out)


def case_lyapunov(out):
    from nld.analysis.lyapunov import lyapunov_benettin, lyapunov_spectrum, lyapunov_tangent
    from nld.systems import SceneSystem, duffing, lorenz
    _flatten("lyap.lorenz_benettin", lyapunov_benettin(lorenz(), total=100.0), out)
    D = duffing()
    _flatten("lyap.duffing_spectrum", lyapunov_spectrum(D, total=40 * D.period), out)
    _flatten("lyap.duffing_tangent", lyapunov_tangent(D, 2, transient=5 * D.period,
                                                      total=30 * D.period,
                                                      target_uncertainty=None), out)
    s = SceneSystem("slider_crank")
    P = s.period
    _flatten("lyap.slider_crank_benettin", lyapunov_benettin(s, transient=2 * P, total=10 * P), out)
    _flatten("lyap.slider_crank_tangent", lyapunov_tangent(s, 1, transient=2 * P, total=10 * P,
                                                           target_uncertainty=None), out)


CASES = dict(simulate=case_simulate, systems=case_systems, orbits=case_orbits,
             census=case_census, control=case_control, lyapunov=case_lyapunov)


def capture(path: str, only=None) -> None:
    out: dict = {}
    for name, fn in CASES.items():
        if only and name not in only:
            continue
        t = time.perf_counter()
        try:
            fn(out)
        except Exception as e:                                  # a case that fails is recorded
            out[f"{name}.ERROR"] = np.array(f"{type(e).__name__}: {e}")
        print(f"{name:10s} {time.perf_counter() - t:7.2f} s", file=sys.stderr)
    np.savez(path, **out)
    print(f"{len(out)} arrays -> {path}")


def _maxdiff(a: np.ndarray, b: np.ndarray):
    if a.shape != b.shape:
        return f"shape {a.shape} vs {b.shape}"
    if a.dtype.kind in "US" or b.dtype.kind in "US":
        return f"{a!s:.60} vs {b!s:.60}"
    d = np.abs(a.astype(complex) - b.astype(complex))
    finite = np.isfinite(d)
    nan_mismatch = int(np.sum(np.isnan(a.astype(complex)) != np.isnan(b.astype(complex))))
    m = float(np.max(d[finite])) if finite.any() else math.nan
    rel = ""
    if finite.any():
        scale = np.abs(a.astype(complex))[finite]
        r = d[finite] / np.where(scale > 0, scale, 1.0)
        rel = f", max rel {float(np.max(r)):.3g}"
    return f"max abs {m:.3g}{rel}" + (f", {nan_mismatch} NaN mismatches" if nan_mismatch else "")


def compare(a_path: str, b_path: str) -> int:
    A, B = np.load(a_path), np.load(b_path)
    ka, kb = set(A.files), set(B.files)
    diffs = []
    for k in sorted(ka - kb):
        diffs.append(f"{k}: only in {a_path}")
    for k in sorted(kb - ka):
        diffs.append(f"{k}: only in {b_path}")
    for k in sorted(ka & kb):
        a, b = A[k], B[k]
        same = (a.shape == b.shape and a.dtype == b.dtype
                and (np.array_equal(a, b) if a.dtype.kind in "USb"
                     else np.array_equal(a, b, equal_nan=True)))
        if not same:
            diffs.append(f"{k}: {_maxdiff(a, b)}")
    if not diffs:
        print(f"identical ({len(ka)} arrays)")
        return 0
    print(f"{len(diffs)} of {len(ka | kb)} arrays differ:")
    for d in diffs:
        print("  " + d)
    return 1


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", nargs="?", help="the .npz file to write")
    ap.add_argument("--compare", nargs=2, metavar=("A", "B"), help="compare two captures")
    ap.add_argument("--only", nargs="+", choices=list(CASES), help="capture only these cases")
    ap.add_argument("--list", action="store_true", help="list the cases")
    a = ap.parse_args(argv)
    if a.list:
        print("\n".join(CASES))
        return 0
    if a.compare:
        return compare(*a.compare)
    if not a.out:
        ap.error("give OUT.npz, or --compare A B")
    capture(a.out, a.only)
    return 0


if __name__ == "__main__":
    sys.exit(main())
