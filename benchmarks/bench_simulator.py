#!/usr/bin/env python
"""Speed against error of nld's simulator on the Flores slider-crank (docs/performance.md).

    python benchmarks/bench_simulator.py [--quick]

Two crank revolutions at 5000 rpm, rtol 1e-6 and 1e-8, in one run:

(i)   the generated scene kernel through nld's dopri5, called with the arguments ``nld.simulate``
      uses (atol = rtol * state_scales, hmax = period/20, contact events on), without the
      per-row observation that simulate adds afterwards, so both kernels do the same work;
(ii)  the hand-written kernel (benchmarks/handwritten_slider_crank.py) through the same dopri5;
(iii) scipy.integrate.solve_ivp, RK45 / DOP853 / LSODA, on the scene kernel's numba rhs wrapped in
      a Python function, with the same atol vector and max_step, over a ladder of rtol.

The contact-law memory of Lankarani-Nikravesh (approach velocity stored at onset) needs event
handling, which solve_ivp only offers through terminal events and restarts; so the main three-way
comparison uses the scene with ``joints.B.contact.law = "hertz_damped"`` (K delta^1.5 + C delta_dot,
no memory, C = 400 N s/m) for ALL methods. The shipped LN scene is run for (i) and (ii), and, as a
second comparison, with solve_ivp stopping at every contact onset/loss (terminal events), storing
the approach velocity and restarting: what a scipy user has to do to integrate the same model.

Protocol (shared/references.md section 6): one warm-up run (it also compiles), then the minimum
of several timed runs. The error of every run is measured against a reference computed by a
different method: scipy DOP853 at rtol 1e-12 (atol = 1e-12 * state_scales; for LN with terminal
events at contact onset and loss), cross-checked against nld's dopri5 at rtol 1e-12. Errors are
taken over the first half revolution (the motion is chaotic; later differences measure the
Lyapunov exponent, not the integrator): the maximum distance between the journal centres (m, and
relative to the clearance) and the relative error of the peak contact force. A failed solve counts
as NaN. For each nld rtol and each scipy method the loosest rtol of the ladder whose journal error
is <= nld's is the method's configuration at equal error; the fastest of those is "best scipy".
"""
from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(HERE))

import numba  # noqa: E402
import scipy  # noqa: E402
from numba import njit  # noqa: E402
from scipy.integrate import solve_ivp  # noqa: E402

import handwritten_slider_crank as H  # noqa: E402
from nld.integrators.dopri5 import dopri5  # noqa: E402
from nld.kernel import compile_scene  # noqa: E402
from nld.scene import load_scene  # noqa: E402
from nld.simulate import crank_period, initial_state, state_scales  # noqa: E402

REVS = 2.0
NLD_RTOLS = (1e-6, 1e-8)
LADDER = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
LADDER_QUICK = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
SCIPY_METHODS = ("RK45", "DOP853", "LSODA")
REF_RTOL = 1e-12
WINDOW_REVS = 0.5            # error window (revolutions from the start)
SAMPLES_PER_REV = 360        # nld.simulate's default output grid
FINE_PER_REV = 7200          # output grid inside the error window (1.7 us at 5000 rpm)
HD_DAMPING = 400.0           # N s/m: restitution 0.90 at 1 m/s (0.88-0.92 for 0.3-4 m/s), m = 0.14 kg
MAX_STEPS = 50_000_000
MAX_LOG = 200_000
TARGET_RATIO = 1.3
TARGET_SPEEDUP = 30.0


# ------------------------------------------------------------------ the two scenes
@dataclass
class Case:
    law: str
    scene: object
    kern: object
    p: np.ndarray
    ph: np.ndarray
    y0: np.ndarray
    z0: np.ndarray
    scales: np.ndarray
    period: float
    t_eval: np.ndarray
    window: np.ndarray          # bool mask of t_eval rows inside the error window
    t_window: float             # s, end of the error window (an element of t_eval)
    ref: dict = field(default_factory=dict)


def make_case(law: str) -> Case:
    over = None if law == "lankarani_nikravesh" else {"joints.B.contact.law": "hertz_damped",
                                                       "joints.B.contact.damping": HD_DAMPING}
    scene = load_scene("slider_crank", over)
    kern = compile_scene(scene)
    y0, z0, q = initial_state(kern)
    per = crank_period(scene)
    coarse = np.linspace(0.0, REVS * per, int(round(REVS * SAMPLES_PER_REV)) + 1)
    fine = np.linspace(0.0, WINDOW_REVS * per, int(round(WINDOW_REVS * FINE_PER_REV)) + 1)
    t_eval = np.union1d(coarse, fine)
    t_eval = t_eval[np.r_[True, np.diff(t_eval) > 1e-9 * per]]     # drop near-duplicates
    t_w = t_eval[np.argmin(np.abs(t_eval - WINDOW_REVS * per))]
    return Case(law, scene, kern, kern.params(scene), H.hand_params(scene), y0, z0,
                state_scales(kern, q), per, t_eval, t_eval <= t_w, t_w)


# ------------------------------------------------------------------ contact force along a solution
@njit(cache=True)
def _forces(ts, Y, ph, zs):
    out = np.empty(ts.shape[0])
    z = np.zeros(1)
    for i in range(ts.shape[0]):
        z[0] = zs[i]
        out[i] = H.contact_force(ts[i], Y[i], ph, z)[0]
    return out


def z_history(ts, ev_t, ev_dir, ev_v):
    """Stored approach velocity z[0] at each time of ts from an event log (onset +1 sets, loss -1 clears)."""
    zs = np.zeros(len(ts))
    if len(ev_t) == 0:
        return zs
    k = np.searchsorted(ev_t, ts, side="left") - 1       # last event strictly before t
    has = k >= 0
    vals = np.where(np.asarray(ev_dir) > 0, ev_v, 0.0)
    zs[has] = vals[k[has]]
    return zs


def metrics(case: Case, Y: np.ndarray, zs: np.ndarray) -> dict:
    """Journal positions and contact forces on the error window."""
    ts = case.t_eval[case.window]
    Yw = np.ascontiguousarray(Y[case.window])
    return {"B": H.journal_position(ts, Yw, case.ph), "F": _forces(ts, Yw, case.ph, zs[case.window])}


def errors(case: Case, m: dict) -> tuple[float, float]:
    if m is None or not np.all(np.isfinite(m["B"])):
        return math.nan, math.nan
    pos = float(np.max(np.hypot(*(m["B"] - case.ref["B"]).T)))
    fref = case.ref["F"].max()
    return pos, float(abs(m["F"].max() - fref) / fref)


# ------------------------------------------------------------------ nld dopri5 runs
def _dopri5(case: Case, kernel: str, rtol: float, t_eval: np.ndarray):
    mod, par = (case.kern.module, case.p) if kernel == "scene" else (H, case.ph)
    z = case.z0.copy()
    out = dopri5(mod.rhs, mod.events, mod.on_event, 0.0, case.y0.copy(), t_eval, False, par, z,
                 float(rtol), rtol * case.scales, 0.0, case.period / 20.0, MAX_STEPS,
                 int(case.kern.n_events), MAX_LOG)
    return out


def dopri5_solution(case: Case, kernel: str, rtol: float):
    """(Y on t_eval, z history, status, stats, events): one untimed run with the onset times added
    to the output grid, so the stored approach velocity of every contact is known exactly. With
    land=False the output grid does not change the steps, so Y equals the timed runs' Y."""
    out = _dopri5(case, kernel, rtol, case.t_eval)
    n_ev = min(int(out[8]), MAX_LOG)
    ev_t, ev_dir = out[5][:n_ev].copy(), out[7][:n_ev].copy()
    t_aug = np.union1d(case.t_eval, ev_t)
    out2 = _dopri5(case, kernel, rtol, t_aug)
    idx = np.searchsorted(t_aug, case.t_eval)
    Y = out2[2][idx]
    if not np.array_equal(Y, out[2], equal_nan=True):
        raise RuntimeError("extra output times changed the solution: dopri5 is not deterministic?")
    y_on = out2[2][np.searchsorted(t_aug, ev_t)]
    ev_v = np.array([max(H._gap(t, y, case.ph)[1], case.ph[H.V_MIN]) for t, y in zip(ev_t, y_on)])
    return Y, z_history(case.t_eval, ev_t, ev_dir, ev_v), int(out[0]), out[4].copy(), n_ev


# ------------------------------------------------------------------ scipy runs
def scipy_run(case: Case, method: str, rtol: float, atol_scale=None, t_end=None, with_events=False):
    """solve_ivp on the scene kernel's numba rhs. with_events: LN memory through terminal events
    (onset: z = max(delta_dot, v_min); loss: z = 0) and restarts. Returns (Y, zs, ok, nfev)."""
    rhs, p = case.kern.module.rhs, case.p
    t_eval = case.t_eval if t_end is None else case.t_eval[case.t_eval <= t_end]
    t_end = t_eval[-1]
    atol = (rtol if atol_scale is None else atol_scale) * case.scales
    z = case.z0.copy()

    def f(t, y):
        dy = np.empty(4)
        rhs(t, y, p, z, dy)
        return dy

    if not with_events:
        sol = solve_ivp(f, (0.0, t_end), case.y0, method=method, t_eval=t_eval, rtol=rtol, atol=atol,
                        max_step=case.period / 20.0)
        ok = sol.status == 0 and sol.y.shape[1] == len(t_eval)
        Y = sol.y.T if ok else None
        return Y, np.zeros(len(t_eval)), ok, sol.nfev

    ph = case.ph
    Y = np.full((len(t_eval), 4), np.nan)
    zs = np.zeros(len(t_eval))
    t0, y0, i_out, nfev = 0.0, case.y0.copy(), 0, 0
    in_contact = H._gap(0.0, y0, ph)[0] > 0.0
    while t0 < t_end:
        def g(t, y):
            return H._gap(t, y, ph)[0]
        g.terminal = True
        g.direction = -1.0 if in_contact else 1.0
        te = t_eval[i_out:]
        sol = solve_ivp(f, (t0, t_end), y0, method=method, t_eval=te, rtol=rtol, atol=atol,
                        max_step=case.period / 20.0, events=g)
        nfev += sol.nfev
        if sol.status < 0:
            return None, zs, False, nfev
        ys = np.asarray(sol.y, float).reshape(4, -1) if len(sol.t) else np.zeros((4, 0))
        n = ys.shape[1]
        Y[i_out:i_out + n] = ys.T
        zs[i_out:i_out + n] = z[0]
        i_out += n
        if sol.status == 0:
            break
        t0 = float(sol.t_events[0][0])
        y0 = sol.y_events[0][0].copy()
        if in_contact:
            z[0] = 0.0
        else:
            z[0] = max(H._gap(t0, y0, ph)[1], ph[H.V_MIN])
        in_contact = not in_contact
    return Y, zs, i_out == len(t_eval), nfev


# ------------------------------------------------------------------ timing
def reference(case: Case, log) -> None:
    """Tight reference on the error window: scipy DOP853 at rtol 1e-12; cross-check with dopri5."""
    t = time.perf_counter()
    Y, zs, ok, nfev = scipy_run(case, "DOP853", REF_RTOL, t_end=case.t_window,
                                with_events=(case.law == "lankarani_nikravesh"))
    if not ok:
        raise RuntimeError("reference solve failed")
    Yf = np.full((len(case.t_eval), 4), np.nan)
    Yf[: len(Y)] = Y
    zf = np.zeros(len(case.t_eval))
    zf[: len(zs)] = zs
    case.ref = metrics(case, Yf, zf)
    log(f"  reference ({case.law}): scipy DOP853 rtol {REF_RTOL:g}, {nfev} rhs evaluations, "
        f"{time.perf_counter() - t:.1f} s; peak contact force {case.ref['F'].max():.6g} N")
    Y2, z2, st, stats, _ = dopri5_solution(case, "scene", REF_RTOL)
    pos, fe = errors(case, metrics(case, Y2, z2))
    case.ref["check"] = (pos, fe)
    log(f"  reference check: nld dopri5 rtol {REF_RTOL:g} differs by {pos:.2e} m in the journal "
        f"position and {fe:.1e} in the peak force")


@dataclass
class Row:
    law: str
    method: str          # "nld dopri5" | "scipy RK45" ...
    kernel: str          # "scene" | "hand" | "scene rhs in Python"
    rtol: float
    time: float          # s, min of the timed runs (NaN if failed)
    nfev: int
    steps: str
    pos_err: float       # m
    f_err: float         # relative
    ok: bool

    @property
    def revs_per_s(self) -> float:
        return REVS / self.time if self.ok and self.time > 0 else math.nan


def bench_nld_pair(case: Case, rtol: float, repeats: int) -> dict[str, Row]:
    """Scene and hand-written kernel through dopri5; timed runs interleaved so that a change of
    the machine's load hits both alike."""
    rows, ok = {}, {}
    for kernel in ("scene", "hand"):
        _dopri5(case, kernel, rtol, case.t_eval)                  # warm-up (compiles once)
        Y, zs, status, stats, n_ev = dopri5_solution(case, kernel, rtol)
        ok[kernel] = status == 0
        pos, fe = errors(case, metrics(case, Y, zs)) if ok[kernel] else (math.nan, math.nan)
        rows[kernel] = Row(case.law, "nld dopri5", kernel, rtol, math.nan, int(stats[3]),
                           f"{stats[1]}/{stats[2]}", pos, fe, ok[kernel])
    best = {"scene": math.inf, "hand": math.inf}
    for _ in range(repeats):
        for kernel in ("scene", "hand"):
            t = time.perf_counter()
            _dopri5(case, kernel, rtol, case.t_eval)
            best[kernel] = min(best[kernel], time.perf_counter() - t)
    for kernel in rows:
        rows[kernel].time = best[kernel] if ok[kernel] else math.nan
    return rows


def bench_scipy(case: Case, method: str, rtol: float, repeats: int, with_events: bool) -> Row:
    kern = "scene rhs in Python" + (", terminal events" if with_events else "")
    t = time.perf_counter()
    Y, zs, ok, nfev = scipy_run(case, method, rtol, with_events=with_events)   # warm-up, measured
    t_first = time.perf_counter() - t
    if not ok:
        return Row(case.law, f"scipy {method}", kern, rtol, math.nan, nfev, "-", math.nan, math.nan, False)
    pos, fe = errors(case, metrics(case, Y, zs))
    best = math.inf
    for _ in range(repeats if t_first < 20.0 else 1):
        t = time.perf_counter()
        scipy_run(case, method, rtol, with_events=with_events)
        best = min(best, time.perf_counter() - t)
    return Row(case.law, f"scipy {method}", kern, rtol, best, nfev, "-", pos, fe, True)


# ------------------------------------------------------------------ report
def machine_info() -> dict:
    cpu = "unknown"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return {"cpu": cpu, "cores": os.cpu_count(), "python": platform.python_version(),
            "numba": numba.__version__, "numpy": np.__version__, "scipy": scipy.__version__,
            "date": datetime.datetime.now().strftime("%Y-%m-%d %H:%M"),
            "load": " ".join(f"{x:.2f}" for x in os.getloadavg())}


def fmt(x, spec):
    return "NaN" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, spec)


def runs_table(rows: list[Row], clearance: float) -> list[str]:
    out = ["| contact law | method | kernel | rtol | time (ms) | rev/s | rhs evals | steps acc/rej "
           "| journal error (m) | error / clearance | peak-force error |",
           "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r.law} | {r.method} | {r.kernel} | {r.rtol:.0e} | {fmt(r.time * 1e3, '.2f')} "
                   f"| {fmt(r.revs_per_s, '.0f')} | {r.nfev} | {r.steps} | {fmt(r.pos_err, '.2e')} "
                   f"| {fmt(r.pos_err / clearance, '.1e')} | {fmt(r.f_err, '.1e')} |")
    return out


def ratio_table(nld: dict) -> tuple[list[str], list[float]]:
    out = ["| contact law | rtol | scene kernel (ms) | hand-written (ms) | scene / hand "
           f"| target <= {TARGET_RATIO} |", "|---|---|---|---|---|---|"]
    ratios = []
    for (law, rtol), pair in nld.items():
        s, h = pair["scene"], pair["hand"]
        r = s.time / h.time
        ratios.append(r)
        out.append(f"| {law} | {rtol:.0e} | {s.time * 1e3:.2f} | {h.time * 1e3:.2f} | {r:.2f} "
                   f"| {'met' if r <= TARGET_RATIO else 'missed'} |")
    return out, ratios


def speedup_table(nld: dict, law: str, sp: dict) -> tuple[list[str], list[float]]:
    """For each nld rtol: per scipy method the loosest ladder rtol with journal error <= nld's."""
    out = ["| nld rtol | nld journal error (m) | nld time (ms) | "
           + " | ".join(f"scipy {m} at equal error" for m in SCIPY_METHODS)
           + f" | best scipy (ms) | speed-up | target >= {TARGET_SPEEDUP:g}x |",
           "|---|---|---|" + "---|" * len(SCIPY_METHODS) + "---|---|---|"]
    sus = []
    for rtol in NLD_RTOLS:
        s = nld[(law, rtol)]["scene"]
        cells, best = [], None
        for method in SCIPY_METHODS:
            ok = [r for (m, rt), r in sp.items() if m == method and r.ok and r.pos_err <= s.pos_err]
            if not ok:
                cells.append("none on the ladder")
                continue
            r = max(ok, key=lambda r: r.rtol)           # loosest rtol at equal or better error
            cells.append(f"rtol {r.rtol:.0e}: {r.time * 1e3:.1f} ms ({r.pos_err:.1e} m)")
            if best is None or r.time < best.time:
                best = r
        lead = f"| {rtol:.0e} | {s.pos_err:.2e} | {s.time * 1e3:.2f} | " + " | ".join(cells)
        if best is None:
            out.append(lead + " | NaN | NaN | - |")
            sus.append(math.nan)
        else:
            su = best.time / s.time
            sus.append(su)
            out.append(lead + f" | {best.time * 1e3:.1f} ({best.method[6:]}, rtol {best.rtol:.0e}) "
                       f"| {su:.0f}x | {'met' if su >= TARGET_SPEEDUP else 'missed'} |")
    return out, sus


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="shorter ladder and fewer timed repeats")
    ap.add_argument("--out", default=str(HERE / "results" / "simulator.md"))
    args = ap.parse_args(argv)
    rep_nld, rep_sp = (10, 1) if args.quick else (30, 3)
    ladder = LADDER_QUICK if args.quick else LADDER
    info = machine_info()

    def log(s):
        print(s, flush=True)

    log(f"nld speed benchmark: slider_crank, {REVS:g} revolutions at 5000 rpm"
        f"{' (quick)' if args.quick else ''}; load average at start {info['load']}")
    t_all = time.perf_counter()
    cases = {law: make_case(law) for law in ("hertz_damped", "lankarani_nikravesh")}
    for c in cases.values():
        reference(c, log)
    clearance = cases["hertz_damped"].ph[H.CLEAR]

    rows: list[Row] = []
    nld: dict[tuple, dict] = {}
    for law in ("hertz_damped", "lankarani_nikravesh"):
        for rtol in NLD_RTOLS:
            pair = bench_nld_pair(cases[law], rtol, rep_nld)
            nld[(law, rtol)] = pair
            for kernel, r in pair.items():
                rows.append(r)
                log(f"  {law:19s} nld dopri5 {kernel:5s} rtol {rtol:.0e}: {r.time * 1e3:8.2f} ms, "
                    f"journal error {r.pos_err:.2e} m, peak force {r.f_err:.1e}")
    sp: dict[str, dict] = {}
    for law, with_events in (("hertz_damped", False), ("lankarani_nikravesh", True)):
        sp[law] = {}
        for method in SCIPY_METHODS:
            for rtol in ladder:
                r = bench_scipy(cases[law], method, rtol, rep_sp, with_events)
                sp[law][(method, rtol)] = r
                rows.append(r)
                log(f"  {law:19s} scipy {method:6s} rtol {rtol:.0e}: {r.time * 1e3:8.1f} ms, "
                    f"journal error {r.pos_err:.2e} m, peak force {r.f_err:.1e}, {r.nfev} rhs")

    ratios, ratio_vals = ratio_table(nld)
    su_hd, su_hd_vals = speedup_table(nld, "hertz_damped", sp["hertz_damped"])
    su_ln, su_ln_vals = speedup_table(nld, "lankarani_nikravesh", sp["lankarani_nikravesh"])
    hd, ln = cases["hertz_damped"], cases["lankarani_nikravesh"]
    info["load_end"] = " ".join(f"{x:.2f}" for x in os.getloadavg())
    md = [
        "# Simulator speed: slider_crank, 2 crank revolutions at 5000 rpm",
        "",
        f"Command: `python benchmarks/bench_simulator.py{' --quick' if args.quick else ''}` "
        f"(whole benchmark {time.perf_counter() - t_all:.0f} s wall, compilation included).",
        "",
        f"Machine: {info['cpu']}, {info['cores']} cores; Python {info['python']}, numba {info['numba']}, "
        f"numpy {info['numpy']}, scipy {info['scipy']}; {info['date']}. Load average "
        f"{info['load']} at the start, {info['load_end']} at the end (shared machine).",
        "",
        f"Protocol: one warm-up run, then the minimum of {rep_nld} (nld; scene and hand-written runs "
        f"interleaved) / {rep_sp} (scipy) timed runs, wall clock. Time = integration only, no "
        f"observation; output on the same {len(hd.t_eval)} times for every method (360 per "
        f"revolution, plus {FINE_PER_REV} per revolution in the error window). atol = rtol * "
        "nld.simulate.state_scales and max step = period/20 for every method. Errors over the first "
        f"{WINDOW_REVS:g} revolution against scipy DOP853 at rtol {REF_RTOL:g} (nld dopri5 at rtol "
        f"{REF_RTOL:g} differs from it by {hd.ref['check'][0]:.1e} m (hertz_damped) and "
        f"{ln.ref['check'][0]:.1e} m (lankarani_nikravesh)). Journal error: largest distance between "
        f"the rod's journal centres, clearance c = {clearance * 1e3:g} mm. Peak-force error: "
        "|peak F - peak F_ref| / peak F_ref on the window. A failed solve counts as NaN. "
        f"hertz_damped: C = {HD_DAMPING:g} N s/m, no contact memory, solve_ivp without events; "
        "lankarani_nikravesh: the shipped scene; solve_ivp stops at each contact onset and loss "
        "(terminal events), stores the approach velocity and restarts.",
        "",
        "## Scene kernel against hand-written kernel (same dopri5)",
        "",
        *ratios,
        "",
        "## Speed-up over scipy at equal or better journal error: hertz_damped (all methods)",
        "",
        *su_hd,
        "",
        "## Speed-up over scipy at equal or better journal error: lankarani_nikravesh "
        "(scipy with terminal events)",
        "",
        *su_ln,
        "",
        "## All runs",
        "",
        *runs_table(rows, clearance),
        "",
    ]
    text = "\n".join(md)
    print()
    print(text)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(f"written {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
