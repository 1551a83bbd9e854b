#!/usr/bin/env python
"""Speed against error of nld's simulator on the Flores slider-crank (docs/performance.md).

    python benchmarks/bench_simulator.py [--quick]

Two crank revolutions at 5000 rpm, rtol 1e-6 and 1e-8, in one run:

(i)   the generated scene kernel through nld's dopri5 (the kernel module's ``solve``, the call
      ``nld.run.simulate`` makes, with the same arguments: tolerances(kernel, q, rtol), hmax =
      period/20, contact events on), without the per-row observation that simulate adds
      afterwards, so both kernels do the same work;
(ii)  the hand-written kernel (benchmarks/handwritten_slider_crank.py) through the same dopri5,
      wrapped the same way;
(iii) scipy.integrate.solve_ivp, RK45 / DOP853 / LSODA, on the scene kernel's numba rhs wrapped in
      a Python function, with the same atol vector and per-state rtol (rtol * weight, floored at
      100 eps where the weight is 0) and max_step, over a ladder of rtol.

The contact-law memory of Lankarani-Nikravesh (approach velocity stored at onset) needs event
handling, which solve_ivp only offers through terminal events and restarts; so the main three-way
comparison uses the scene with ``joints.B.contact.law = "hertz_damped"`` (K delta^1.5 + C delta_dot,
no memory, C = 400 N s/m) for ALL methods. The shipped LN scene is run for (i) and (ii), and, as a
second comparison, with solve_ivp stopping at every contact onset/loss (terminal events), storing
the approach velocity and restarting: what a scipy user has to do to integrate the same model.

Protocol (shared/references.md section 6): one warm-up run (it also compiles), then the minimum
of several timed runs, timed in CPU time of the process (equal to wall-clock time on an idle
machine; on a shared one wall-clock time also counts waiting for a core, so both are reported).
nld is timed with simulate's event log (sized to the run: nld.run.simulate.event_log_size) and with a
1000-entry one: same steps; the difference is the cost of allocating the log (docs/performance.md). The error of every run is measured against a reference computed by a
different method: scipy DOP853 at rtol 1e-12 (the same tolerance vector; for LN with terminal
events at contact onset and loss), cross-checked against nld's dopri5 at rtol 1e-12. Errors are
taken over the first quarter revolution (the motion is chaotic; later differences measure the
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

from nld.kernel.compile import drop_stale_numba_cache  # noqa: E402

drop_stale_numba_cache(HERE / "handwritten_slider_crank.py")
import handwritten_slider_crank as H  # noqa: E402
from nld.kernel.compile import compile_scene  # noqa: E402
from nld.model.scene import load_scene  # noqa: E402
from nld.run.simulate import crank_period, event_log_size, initial_state, tolerances  # noqa: E402

REVS = 2.0
NLD_RTOLS = (1e-6, 1e-8)
LADDER = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11)
LADDER_QUICK = (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
SCIPY_METHODS = ("RK45", "DOP853", "LSODA")
REF_RTOL = 1e-12
WINDOW_REVS = 0.25           # error window (revolutions from the start); see below
# Why 0.25: the journal error of every method and tolerance grows ~100x between 0.3 and 0.5
# revolution (hertz_damped, rtol 1e-8: 2.6e-8 m at 0.3 rev, 3.2e-6 m at 0.5 rev; the same jump for
# the scipy runs): past 0.3 revolution the error measures the divergence of nearby chaotic
# trajectories (a few Lyapunov times), not the integrator's accuracy.
SAMPLES_PER_REV = 360        # nld.run.simulate's default output grid
FINE_PER_REV = 7200          # output grid inside the error window (1.7 us at 5000 rpm)
HD_DAMPING = 400.0           # N s/m: restitution 0.90 at 1 m/s (0.88-0.92 for 0.3-4 m/s), m = 0.14 kg
MAX_STEPS = 50_000_000
MAX_LOG = event_log_size(REVS)  # nld.run.simulate's event-log length for this run
SMALL_LOG = 1_000            # enough for these runs (< 150 events): shows the cost of the log
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
    q: np.ndarray               # initial joint coordinates (for nld.run.simulate.tolerances)
    period: float
    t_eval: np.ndarray
    t_time: np.ndarray          # output times of the timed runs: nld.run.simulate's default grid
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
                q, per, t_eval, coarse, t_eval <= t_w, t_w)


# ------------------------------------------------------------------ contact force along a solution
@njit(cache=True)
def _forces(ts, Y, ph, zs):
    out = np.empty(ts.shape[0])
    z = np.zeros(1)
    for i in range(ts.shape[0]):
        z[0] = zs[i]
        out[i] = H.contact_force(ts[i], Y[i], ph, z)[0]
    return out


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
def tol_vector(case: Case, rtol: float) -> np.ndarray:
    """The 2n tolerance vector nld.run.simulate passes (atol, then per-state rtol weights)."""
    return tolerances(case.kern, case.q, rtol)


def _dopri5(case: Case, kernel: str, rtol: float, t_eval: np.ndarray, max_log: int = MAX_LOG):
    """One run through the kernel module's ``solve`` (nld's dopri5 specialised for the kernel),
    with the arguments nld.run.simulate passes to it."""
    mod, par = (case.kern.module, case.p) if kernel == "scene" else (H, case.ph)
    z = case.z0.copy()
    return mod.solve(0.0, case.y0.copy(), t_eval, False, par, z, float(rtol), tol_vector(case, rtol),
                     0.0, case.period / 20.0, MAX_STEPS,
                     int(case.kern.n_events) if kernel == "scene" else 1, max_log)


def dopri5_solution(case: Case, kernel: str, rtol: float):
    """(Y on case.t_eval, stored approach velocity z[0] per row, status, stats, events)."""
    out = _dopri5(case, kernel, rtol, case.t_eval)
    return out[2], np.ascontiguousarray(out[9][:, 0]), int(out[0]), out[4].copy(), int(out[8])


# ------------------------------------------------------------------ scipy runs
def scipy_run(case: Case, method: str, rtol: float, t_end=None, with_events=False, grid=None):
    """solve_ivp on the scene kernel's numba rhs, output on ``grid`` (default case.t_eval) up to
    t_end. with_events: LN memory and hertz_damped's contact mode through terminal events (onset:
    z = max(delta_dot, v_min); loss: z = 0) and restarts. Returns (Y, zs, ok, nfev)."""
    rhs, p = case.kern.module.rhs, case.p
    t_eval = case.t_eval if grid is None else grid
    if t_end is not None:
        t_eval = t_eval[t_eval <= t_end]
    t_end = t_eval[-1]
    tv = tol_vector(case, rtol)
    n = case.y0.size
    atol = tv[:n]
    rtol = np.maximum(rtol * tv[n:], 100 * np.finfo(float).eps)    # per-state rtol (0 -> floor)
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
def timed(fn) -> tuple[float, float]:
    """(wall-clock, CPU) seconds of one call. CPU time (time.process_time) is the measure used: on
    an idle machine the two agree; on a shared one wall-clock time includes waiting for a core."""
    w, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - w, time.process_time() - c


def reference(case: Case, log) -> None:
    """Tight reference on the error window: scipy DOP853 at rtol 1e-12; cross-check with dopri5."""
    t = time.perf_counter()
    Y, zs, ok, nfev = scipy_run(case, "DOP853", REF_RTOL, t_end=case.t_window, with_events=True)
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
    time: float          # s, min CPU time of the timed runs (NaN if failed)
    nfev: int
    steps: str
    pos_err: float       # m
    f_err: float         # relative
    ok: bool
    time_small_log: float = math.nan   # s, same runs with a 1000-entry event log
    wall: float = math.nan             # s, min wall-clock time of the timed runs

    @property
    def revs_per_s(self) -> float:
        return REVS / self.time if self.ok and self.time > 0 else math.nan


def bench_nld_pair(case: Case, rtol: float, repeats: int) -> dict[str, Row]:
    """Scene and hand-written kernel through dopri5; timed runs interleaved so that a change of
    the machine's load hits both alike. Each is timed with simulate's event log (MAX_LOG entries)
    and with a short one (SMALL_LOG): the steps are the same, the allocation differs."""
    rows, ok = {}, {}
    for kernel in ("scene", "hand"):
        _dopri5(case, kernel, rtol, case.t_eval)                  # warm-up (compiles once)
        Y, zs, status, stats, n_ev = dopri5_solution(case, kernel, rtol)
        ok[kernel] = status == 0
        pos, fe = errors(case, metrics(case, Y, zs)) if ok[kernel] else (math.nan, math.nan)
        rows[kernel] = Row(case.law, "nld dopri5", kernel, rtol, math.nan, int(stats[3]),
                           f"{stats[1]}/{stats[2]}", pos, fe, ok[kernel])
    best = {(k, ml): [math.inf, math.inf] for k in ("scene", "hand") for ml in (MAX_LOG, SMALL_LOG)}
    for _ in range(repeats):
        for (kernel, ml), b in best.items():
            w, c = timed(lambda: _dopri5(case, kernel, rtol, case.t_time, ml))
            b[0], b[1] = min(b[0], w), min(b[1], c)
    for kernel in rows:
        if ok[kernel]:
            rows[kernel].wall, rows[kernel].time = best[(kernel, MAX_LOG)]
            rows[kernel].time_small_log = best[(kernel, SMALL_LOG)][1]
    return rows


def bench_scipy(case: Case, method: str, rtol: float, repeats: int, with_events: bool) -> Row:
    kern = "scene rhs in Python" + (", terminal events" if with_events else "")
    t = time.perf_counter()
    Y, zs, ok, nfev = scipy_run(case, method, rtol, with_events=with_events)   # warm-up, measured
    t_first = time.perf_counter() - t
    if not ok:
        return Row(case.law, f"scipy {method}", kern, rtol, math.nan, nfev, "-", math.nan, math.nan, False)
    pos, fe = errors(case, metrics(case, Y, zs))
    bw = bc = math.inf
    for _ in range(repeats if t_first < 20.0 else 1):
        w, c = timed(lambda: scipy_run(case, method, rtol, with_events=with_events, grid=case.t_time))
        bw, bc = min(bw, w), min(bc, c)
    return Row(case.law, f"scipy {method}", kern, rtol, bc, nfev, "-", pos, fe, True, wall=bw)


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
           f"| journal error (m) | error / clearance | peak-force error | time, {SMALL_LOG}-entry event log (ms) "
           "| wall-clock (ms) |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r.law} | {r.method} | {r.kernel} | {r.rtol:.0e} | {fmt(r.time * 1e3, '.2f')} "
                   f"| {fmt(r.revs_per_s, '.0f')} | {r.nfev} | {r.steps} | {fmt(r.pos_err, '.2e')} "
                   f"| {fmt(r.pos_err / clearance, '.1e')} | {fmt(r.f_err, '.1e')} "
                   f"| {fmt(r.time_small_log * 1e3, '.2f') if r.method.startswith('nld') else '-'} "
                   f"| {fmt(r.wall * 1e3, '.2f')} |")
    return out


def ratio_table(nld: dict) -> tuple[list[str], list[float]]:
    out = ["| contact law | rtol | scene kernel (ms) | hand-written (ms) | scene / hand "
           f"| target <= {TARGET_RATIO} | rhs evals scene / hand | scene / hand per rhs evaluation "
           f"| with a {SMALL_LOG}-entry event log: scene / hand (ms) | ratio |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    ratios = []
    for (law, rtol), pair in nld.items():
        s, h = pair["scene"], pair["hand"]
        r = s.time / h.time
        ratios.append(r)
        out.append(f"| {law} | {rtol:.0e} | {s.time * 1e3:.2f} | {h.time * 1e3:.2f} | {r:.2f} "
                   f"| {'met' if r <= TARGET_RATIO else 'missed'} | {s.nfev} / {h.nfev} "
                   f"| {r * h.nfev / s.nfev:.2f} | {s.time_small_log * 1e3:.2f} / "
                   f"{h.time_small_log * 1e3:.2f} | {s.time_small_log / h.time_small_log:.2f} |")
    return out, ratios


def speedup_table(nld: dict, law: str, sp: dict) -> tuple[list[str], list[float]]:
    """For each nld rtol: per scipy method the loosest ladder rtol with journal error <= nld's."""
    out = ["| nld rtol | nld journal error (m) | nld time (ms) | "
           + " | ".join(f"scipy {m} at equal error" for m in SCIPY_METHODS)
           + f" | best scipy (ms) | speed-up | target >= {TARGET_SPEEDUP:g}x "
           f"| speed-up, {SMALL_LOG}-entry event log |",
           "|---|---|---|" + "---|" * len(SCIPY_METHODS) + "---|---|---|---|"]
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
            out.append(lead + " | NaN | NaN | - | NaN |")
            sus.append(math.nan)
        else:
            su = best.time / s.time
            sus.append(su)
            out.append(lead + f" | {best.time * 1e3:.1f} ({best.method[6:]}, rtol {best.rtol:.0e}) "
                       f"| {su:.1f}x | {'met' if su >= TARGET_SPEEDUP else 'missed'} "
                       f"| {best.time / s.time_small_log:.1f}x |")
    return out, sus


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="shorter ladder and fewer timed repeats")
    ap.add_argument("--out", default=str(HERE / "results" / "simulator.md"))
    args = ap.parse_args(argv)
    rep_nld, rep_sp = (20, 1) if args.quick else (100, 5)
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
                log(f"  {law:19s} nld dopri5 {kernel:5s} rtol {rtol:.0e}: {r.time * 1e3:8.2f} ms "
                    f"({r.time_small_log * 1e3:.2f} ms with a short event log), "
                    f"journal error {r.pos_err:.2e} m, peak force {r.f_err:.1e}")
    sp: dict[str, dict] = {}
    # both laws need the located contact events: LN's onset memory, hertz_damped's contact mode
    for law, with_events in (("hertz_damped", True), ("lankarani_nikravesh", True)):
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
        f"interleaved) / {rep_sp} (scipy) timed runs. Time = CPU time of the process "
        "(time.process_time; equal to wall-clock time on an idle machine, while on this shared one "
        "wall-clock time also counts waiting for a core; both are in the last table) spent in the "
        "integration only, no "
        f"observation, output on nld.run.simulate's default {len(hd.t_time)} times (360 per revolution) "
        "for every method. The warm-up run of each configuration is also its measured solve: it "
        f"outputs on {len(hd.t_eval)} times ({FINE_PER_REV} per revolution in the error window), "
        "which changes no step of any of the integrators. nld runs with simulate's arguments, "
        f"including its {MAX_LOG}-entry event log, and again with a {SMALL_LOG}-entry log (same "
        "steps; the difference is the cost of allocating the log). Tolerances: "
        "nld.run.simulate.tolerances (positions absolute) and max step = period/20 for every method. Errors over the first "
        f"{WINDOW_REVS:g} revolution against scipy DOP853 at rtol {REF_RTOL:g} (nld dopri5 at rtol "
        f"{REF_RTOL:g} differs from it by {hd.ref['check'][0]:.1e} m (hertz_damped) and "
        f"{ln.ref['check'][0]:.1e} m (lankarani_nikravesh)). Journal error: largest distance between "
        f"the rod's journal centres, clearance c = {clearance * 1e3:g} mm. Peak-force error: "
        "|peak F - peak F_ref| / peak F_ref on the window. A failed solve counts as NaN. "
        f"hertz_damped: C = {HD_DAMPING:g} N s/m, no contact memory, solve_ivp without events; "
        "lankarani_nikravesh: the shipped scene; solve_ivp stops at each contact onset and loss "
        "(terminal events), stores the approach velocity and restarts.",
        "",
        "## Scene kernel against hand-written kernel (same dopri5, each through its module's `solve`)",
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
