#!/usr/bin/env python
"""The delay integrator's cost per step against the plain DOPRI5 on the same system, side by side
in one run (issue 26, item 8).

    python benchmarks/bench_control.py [--repeats 10] [--out benchmarks/results/control.md]

Cases, each warm (compiled first), minimum process CPU time over ``--repeats`` runs, the paths
alternating so that a change of load hits both:

* Rössler (a = b = 0.2, c = 5.7) over 50 delay periods (tau = 5.88), rtol 1e-9: the plain DOPRI5
  (``nld.integrators.dopri5``); the delay integrator (``nld.integrators.delay.dde``) with gain 0
  (the same trajectory: the overhead of keeping the history, the delayed look-ups and the breaking
  points); with Pyragas' control K = 0.2; with EDFC R = 0.5 (the channel's own history too);
* slider_crank (contact events), rtol 1e-8, plain against the delay
  integrator with a gain-0 controller (delay = one revolution): 1 revolution (over 4 the two
  chaotic runs part and take different steps).

Reported per case: steps (accepted), rhs evaluations, CPU ms, microseconds per accepted step, and
the ratio of the per-step cost to the plain DOPRI5's on the same system.

With ``--evidence`` (default on; ``--no-evidence`` skips it) the same file also gets the numbers
quoted in docs/control.md: the delay integrator against the method-of-steps closed form and its
order, the Rössler period-1 UPO (periodic_orbit) and its Pyragas / EDFC control (lambda1, effort,
distance to the UPO), the stability domain lambda1(K, R), and OGY on the Hénon map.

``--scene-scan`` runs only the issue's speed target instead: the 30-gain stability domain of
slider_crank_olyaei (``nld control slider_crank_olyaei --set joints.B.clearance=2e-4 --set
joints.B.friction.mu=0 --gains 0.1:3:30``: the default EDFC run, then lambda1 at each gain from its
end), wall and CPU time, written as the section "Scene: 30-gain stability domain" of the results
file (the rest of the file kept).
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numpy as np  # noqa: E402

from _results import write_table  # noqa: E402

from nld.analysis import control as C  # noqa: E402
from nld.integrators import dopri5  # noqa: E402
from nld.integrators.delay import dde  # noqa: E402


def cpu(f):
    t = time.process_time()
    out = f()
    return time.process_time() - t, out


def plain(S, t1, rtol):
    z = S.z0.copy()
    return dopri5(S.rhs, S.events, S.on_event, 0.0, S.y0.copy(), np.array([t1]), True, S.p, z, rtol,
                  S.tolerance(rtol), 0.0, float(S.hmax), 10**8, int(S.n_events), 10_000)


def delayed(S, fb, t1, rtol, gain=None):
    z = S.z0.copy()
    return dde(S.rhs, S.events, S.on_event, 0.0, S.y0.copy(), np.array([t1]), True, S.p, z, rtol,
               S.tolerance(rtol), 0.0, float(S.hmax), 10**8, int(S.n_events), 10_000,
               fb.law(S, gain), event_samples=int(S.event_samples))


def measure(label, base, other, repeats):
    base(), other()
    a = b = np.inf
    ra = rb = None
    for _ in range(repeats):
        ta, ra = cpu(base)
        tb, rb = cpu(other)
        a, b = min(a, ta), min(b, tb)
    return label, a, ra, b, rb


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--out", default=str(HERE / "results" / "control.md"))
    ap.add_argument("--evidence", action=argparse.BooleanOptionalAction, default=True)
    ap.add_argument("--scene-scan", action="store_true",
                    help="only the 30-gain stability domain of slider_crank_olyaei (a section of "
                         "--out)")
    args = ap.parse_args(argv)
    if args.scene_scan:
        return scene_scan(args.out)
    rows = []
    S = C.rossler()
    tau = 5.88
    t1 = 50 * tau
    rtol = 1e-9
    fb = C.pyragas(S, 0.2, tau, "y")
    cases = [
        ("Rössler, delay integrator, K = 0", lambda: delayed(S, fb, t1, rtol, 0.0)),
        ("Rössler, Pyragas K = 0.2", lambda: delayed(S, fb, t1, rtol)),
        ("Rössler, EDFC K = 0.2, R = 0.5", lambda: delayed(S, fb.with_(memory=0.5), t1, rtol)),
    ]
    for label, f in cases:
        rows.append(measure(label, lambda: plain(S, t1, rtol), f, args.repeats))
    scene_note = ""
    try:
        from nld.systems.core import SceneSystem
        SC = SceneSystem("slider_crank")
        fbs = C.pyragas(SC, 0.0, SC.period, 2 if SC.n > 2 else 0)
        t1s = 1 * SC.period
        rows.append(measure("slider_crank (contact events), K = 0, 1 revolution",
                            lambda: plain(SC, t1s, 1e-8),
                            lambda: delayed(SC, fbs, t1s, 1e-8, 0.0), max(3, args.repeats // 2)))
        scene_note = (f"slider_crank: 1 revolution (longer: the chaotic runs part, different steps) (T = {SC.period:.6g} s), rtol 1e-8, signal "
                      f"{SC.state_names[fbs.signal]}, delay T")
    except Exception as e:  # noqa: BLE001 - report, do not hide
        scene_note = f"slider_crank not run: {' '.join(str(e).split())[:160]}"
    table = ["| case | plain steps | plain rhs | plain CPU ms | plain us/step | delay steps | "
             "delay rhs | delay CPU ms | delay us/step | per-step ratio |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for label, a, ra, b, rb in rows:
        sa, sb = int(ra.stats[1]), int(rb.stats[1])
        pa, pb = a / max(sa, 1) * 1e6, b / max(sb, 1) * 1e6
        ok = "" if (ra.status == 0 and rb.status == 0) else f" (status {ra.status}/{rb.status})"
        table.append(f"| {label}{ok} | {sa} | {int(ra.stats[3])} | {a * 1e3:.2f} | {pa:.2f} | {sb} | "
                     f"{int(rb.stats[3])} | {b * 1e3:.2f} | {pb:.2f} | {pb / pa:.2f} |")
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    head = ["# Delay integrator: cost per step against the plain DOPRI5 (issue 26)", "",
            f"{now}, {platform.machine()}, load {load:.2f}; command: `python "
            f"benchmarks/bench_control.py --repeats {args.repeats}`; minimum process CPU time "
            f"over the repeats, warm.", "",
            f"Rössler: 50 delay periods (tau = {tau}), rtol {rtol:g}. {scene_note}.", ""]
    if args.evidence:
        table += [""] + evidence()
    write_table(args.out, head, table)
    print("\n".join(table))
    return 0


SCAN_SECTION = "## Scene: 30-gain stability domain (nld control --gains)"
SCAN_ARGV = ["control", "slider_crank_olyaei", "--set", "joints.B.clearance=2e-4", "--set",
             "joints.B.friction.mu=0", "--gains", "0.1:3:30", "--json", "--quiet"]


def scene_scan(out) -> int:
    """The issue's target: a 30-gain stability-domain scan of slider_crank_olyaei in <= 5 min on
    2 cores (it runs on one: the gains one after the other)."""
    import contextlib
    import io
    import json
    from nld.cli import main as nld_main
    buf = io.StringIO()
    w, c = time.perf_counter(), time.process_time()
    with contextlib.redirect_stdout(buf):
        rc = nld_main(list(SCAN_ARGV))
    wall, cpu_s = time.perf_counter() - w, time.process_time() - c
    d = json.loads(buf.getvalue()) if rc == 0 else None
    now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    lines = [SCAN_SECTION, "",
             f"{now}, {platform.machine()}, {os.cpu_count()} CPUs, load {load:.2f}; command: "
             f"`python benchmarks/bench_control.py --scene-scan` = `nld "
             f"{' '.join(SCAN_ARGV[:-2])}` (one process, the gains one after the other), warm "
             f"kernel cache. Issue 26 target: <= 5 min on 2 cores.", "",
             f"exit status {rc}; **wall {wall:.1f} s, CPU {cpu_s:.1f} s** (the default controlled "
             f"run and its two lambda1 included)."]
    if d is not None:
        s, sd = d["settings"], d["stability_domain"]
        lines += ["", f"Controlled run ({s['transient_revs']} free + {s['revs']} controlled "
                      f"revolutions, lambda1 over {s['lyapunov_revs']}, controlled: memory "
                      f"{s['lyapunov_controlled_memory']}): lambda1 "
                      f"{d['lambda1_uncontrolled']:.3f} +- "
                      f"{s['uncertainty_uncontrolled']:.2f} -> {d['lambda1_controlled']:.3f} +- "
                      f"{s['uncertainty_controlled']:.2f} per revolution, effort "
                      f"{d['effort_rms_initial']:.3g} -> {d['effort_rms_final']:.3g} N m, "
                      f"captured at revolution {d['captured_at_revolution']}.", "",
                  f"lambda1 per revolution +- SE (R = {sd['memory']:g}; from the controlled run's "
                  f"end, {sd['transient_revs']} revolutions under each gain, then "
                  f"{sd['span_revs']}):", "",
                  "| K (N m s/rad) | lambda1 | SE | lambda1 + SE < 0 |", "|---|---|---|---|"]
        for k, lam, se, ok in zip(sd["gains"], sd["lambda1"], sd["uncertainty"], sd["stable"]):
            f = (lambda x: "n/a" if x is None else f"{x:.3f}")
            lines.append(f"| {k:.3g} | {f(lam)} | {f(se)} | {'yes' if ok else 'no'} |")
    p = Path(out)
    text = p.read_text(encoding="utf-8") if p.exists() else ""
    if SCAN_SECTION in text:
        text = text[:text.index(SCAN_SECTION)].rstrip("\n") + "\n"
    p.write_text((text + "\n" if text else "") + "\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    return rc


def _zero_rhs():
    from numba import njit

    @njit
    def zero_rhs(t, y, p, z, dy):
        dy[0] = 0.0
    return zero_rhs


def steps_closed_form(t):
    import math
    n = math.floor(t) + 1
    return sum((-1) ** k * (t - (k - 1)) ** k / math.factorial(k) for k in range(n + 1))


def evidence() -> list[str]:
    import math
    from nld.analysis.orbits import periodic_orbit
    from nld.integrators.delay import STATE, DelayLaw
    from nld.systems.core import advance, henon
    from nld.systems.derived import PoincareMap
    out = ["## Evidence quoted in docs/control.md", ""]
    zr = _zero_rhs()
    law = DelayLaw.make(1, 0, [1.0], [0], gd=[[-1.0]], kinds=[STATE], targets=[0])

    def run(te, rtol, h=0.0, land=False, **kw):
        return dde(zr, None, None, 0.0, [1.0], np.asarray(te, dtype=float), land, np.zeros(0),
                   np.zeros(0), rtol, np.array([rtol]), h, h, 10**6, 0, 1, law, **kw)
    te = np.linspace(0, 3, 61)
    ex = np.array([steps_closed_form(x) for x in te])
    e_ok = np.max(np.abs(run(te, 1e-6).Y[:, 0] - ex))
    e_bad = np.max(np.abs(run(te, 1e-6, t_break0=0.37).Y[:, 0] - ex))
    out += ["### y'(t) = -y(t - 1), y = 1 for t <= 0", "",
            f"On [0, 3] (61 points), rtol 1e-6: max error {e_ok:.1e} landing on the breaking "
            f"points t = 1, 2; {e_bad:.1e} with them placed at 0.37 + k (steps straddle 1 and 2).",
            "", "Fixed steps on [0, 8] (error at t = 8 against the method-of-steps sum):", "",
            "| h | steps | error | observed order |", "|---|---|---|---|"]
    prev = None
    for h in (0.5, 0.25, 0.125, 0.0625, 0.03125):
        r = run([8.0], 1e3, h=h, land=True)
        e = abs(r.Y[0, 0] - steps_closed_form(8.0))
        order = "" if prev is None else f"{math.log2(prev / e):.2f}"
        out.append(f"| {h:g} | {int(r.stats[1])} | {e:.2e} | {order} |")
        prev = e
    out += ["", "Adaptive (error at t = 8):", "", "| rtol | steps | error |", "|---|---|---|"]
    for rtol in (1e-5, 1e-7, 1e-9, 1e-11):
        r = run([8.0], rtol, land=True)
        out.append(f"| {rtol:g} | {int(r.stats[1])} | {abs(r.Y[0, 0] - steps_closed_form(8.0)):.2e} |")
    # Rossler UPO
    S = C.rossler()
    y, _ = advance(S, S.y0, S.z0, 0.0, 100.0, 1e-10)
    o = periodic_orbit(PoincareMap(C.rossler(y0=y), [1.0, 0.0, 0.0], 0.0, 1), 1)
    T = C.orbit_period_time(o)
    v = C.odd_number_limitation(o)
    mu = ", ".join(f"{m.real:.6g}" + (f"{m.imag:+.3g}i" if abs(m.imag) > 0 else "")
                   for m in o.multipliers)
    out += ["", "### Rössler (a = b = 0.2, c = 5.7), control on dy/dt, signal y", "",
            f"Period-1 UPO (periodic_orbit on the Poincaré map x = 0, x' > 0; converged "
            f"{o.converged}, residual {o.residual:.1e}): period T = {T:.10f}, multipliers "
            f"{mu}; odd-number verdict: {v.message}.", "",
            "| controller | lambda1 free | lambda1 controlled | effort rms first / last period "
            "| captured after (periods) | distance to UPO | CPU s |", "|---|---|---|---|---|---|---|"]
    for label, fb in (("Pyragas K = 0.2", C.pyragas(S, 0.2, T, "y")),
                      ("EDFC K = 0.2, R = 0.5", C.edfc(S, 0.2, T, "y", 0.5)),
                      ("EDFC K = 0.3, R = 0.5", C.edfc(S, 0.3, T, "y", 0.5))):
        c0 = time.process_time()
        r = C.control_delayed(S, fb, transient=100.0, duration=60 * T, lyapunov_span=40 * T,
                              target=o)
        out.append(f"| {label} | {r.lambda1_uncontrolled:.4f} +- {r.uncertainty_uncontrolled:.4f} "
                   f"| {r.lambda1_controlled:.4f} +- {r.uncertainty_controlled:.4f} | "
                   f"{r.effort_rms_initial:.3g} / {r.effort_rms_final:.2g} | {r.captured_at} | "
                   f"{r.orbit_distance:.1e} | {time.process_time() - c0:.1f} |")
        if label.startswith("Pyragas"):
            start = r.run
    fb = C.pyragas(S, 0.2, T, "y")
    lt = [C.delayed_lyapunov(S, fb, 40 * T, y0=start.y, t0=start.t[-1], history=start.history,
                             t_break0=start.t_break0, transverse=tr) for tr in (False, True)]
    r588 = C.control_delayed(S, C.pyragas(S, 0.2, 5.88, "y"), transient=100.0,
                             duration=60 * 5.88, lyapunov_span=40 * 5.88, target=o,
                             uncontrolled=False)
    out += ["", f"Pyragas K = 0.2 on the captured orbit, lambda1 over 40 T: "
            f"{lt[0].lambda1:.4f} +- {lt[0].uncertainty:.4f} with the time-shift direction kept "
            f"(the trivial exponent 0 of a periodic orbit of an autonomous system), "
            f"{lt[1].lambda1:.4f} +- {lt[1].uncertainty:.4f} with it removed (transverse).",
            "", f"Pyragas K = 0.2 with tau = 5.88 instead of T: effort rms "
            f"{r588.effort_rms_initial:.3g} -> {r588.effort_rms_final:.2g}, periodicity "
            f"{r588.periodicity:.1e}, distance to the UPO {r588.orbit_distance:.1e}, lambda1 "
            f"{r588.lambda1_controlled:.4f} +- {r588.uncertainty_controlled:.4f}."]
    gains = np.round(np.linspace(0.0, 0.6, 7), 3)
    c0 = time.process_time()
    scan = C.stability_domain(S, C.pyragas(S, 0.2, T, "y"), gains, [0.0, 0.5], y0=start.y,
                              t0=start.t[-1], history=start.history, transient=10 * T,
                              span=30 * T)
    out += ["", f"Stability domain (lambda1 per time unit +- SE; from the controlled orbit's end, "
            f"10 T under the new gain, then 30 T; {time.process_time() - c0:.0f} s CPU):", "",
            "| R \\ K | " + " | ".join(f"{g:g}" for g in gains) + " |",
            "|---|" + "---|" * gains.size]
    for a, R in enumerate(scan.memories):
        out.append(f"| {R:g} | " + " | ".join(f"{scan.lambda1[a, b]:.3f} +- {scan.uncertainty[a, b]:.3f}"
                                              for b in range(gains.size)) + " |")
    # OGY Henon
    c0 = time.process_time()
    r = C.ogy(henon(), 0, dp_max=0.1, radius=0.1, n_iter=3000, x0=[0.1, 0.1])
    cl = ", ".join(f"{abs(m):.3g}" for m in r.closed_loop_multipliers)
    out += ["", "### OGY, Hénon map (a = 1.4, b = 0.3), parameter a, dp_max 0.1, radius 0.1", "",
            f"Fixed point {np.round(r.orbit.points[0], 6).tolist()}, multipliers "
            f"{np.round(r.orbit.multipliers.real, 5).tolist()}; closed-loop |multipliers| {cl}; "
            f"from x0 = (0.1, 0.1): captured at iteration {r.captured_at}, final distance "
            f"{r.orbit_distance:.1e}, |dp| rms {r.effort_rms_initial:.3g} (first 50 after "
            f"activation) -> {r.effort_rms_final:.1e}; lambda1 {r.lambda1_uncontrolled:.3f} "
            f"(free, 200 iterations) -> {r.lambda1_controlled:.3f} (closed loop, last 50) per "
            f"iteration; {time.process_time() - c0:.1f} s CPU."]
    # OGY on a stroboscopic map: the forced Duffing oscillator, parameter gamma
    from nld.analysis.orbits import find_orbits
    from nld.systems.core import duffing
    c0 = time.process_time()
    D = duffing()
    found = find_orbits(D, max_period=1)
    orbs = [q for q in getattr(found, "orbits", found) if q.stable is False]
    q = orbs[0]
    r = C.ogy(D, "gamma", orbit=q, dp_max=0.05, radius=0.3, n_iter=400, lyapunov_iter=50,
              window=30)
    cl = ", ".join(f"{abs(m):.3g}" for m in r.closed_loop_multipliers)
    out += ["", "### OGY, forced Duffing (delta 0.3, alpha -1, beta 1, gamma 0.5, omega 1.2), "
            "stroboscopic map, parameter gamma, dp_max 0.05, radius 0.3", "",
            f"Period-1 saddle from find_orbits {np.round(q.points[0], 6).tolist()}, multipliers "
            f"{np.round(q.multipliers.real, 5).tolist()}; closed-loop |multipliers| {cl}; from "
            f"the system's y0: {r.message}; lambda1 {r.lambda1_uncontrolled:.3f} (free, 50 "
            f"periods) -> {r.lambda1_controlled:.3f} (closed loop, last 30) per period; "
            f"{time.process_time() - c0:.1f} s CPU."]
    return out


if __name__ == "__main__":
    raise SystemExit(main())
