#!/usr/bin/env python
"""Every integrator method side by side at matched error, per built-in scene (docs/performance.md).

    python benchmarks/bench_methods.py [--quick] [--out benchmarks/results/methods.md]

(i)  Per built-in scene (nld/scenes/*.toml), each method of ``nld.simulate(method=...)``
     (dopri5, dop853, rodas, scipy:RK45, scipy:DOP853, scipy:Radau, scipy:LSODA) over a ladder of
     rtol, timed as ``simulate`` calls it (``studies/work_precision.py``'s ``Setup.solve``: the
     kernel module's solve / ``nld.integrators.solve_method`` with simulate's tolerances, hmax and
     contact events), CPU time, minimum over repeats. Error: the largest journal-centre distance to
     a reference by a DIFFERENT method at rtol 1e-12 over a short window from the start (a couple
     of Lyapunov times), divided by the smallest clearance. At each target error (1e-2, 1e-4, 1e-6
     clearances) each method's configuration is the cheapest run of its ladder that meets it;
     revolutions per second = window revolutions / CPU time of that run. Ratios: best scipy
     configuration / best nld configuration (time), and / dopri5.
(ii) numbalsoda (its LSODA and DOP853, C/Fortran, no events) on the scene kernel's numba rhs
     wrapped in a numba cfunc, on ``slider_crank`` with ``hertz_damped`` contact (F = K d^1.5 + C
     d', C = 400 N s/m: the LN law's onset memory needs event handling, which numbalsoda has not).
     numbalsoda takes one scalar rtol and atol; the state is integrated in units of nld's state
     scales (u = y / state_scales), so atol = rtol there is nld's absolute tolerance; its relative
     term also applies to positions (nld weights it 0), so a second ladder with rtol = 1e-3 * atol
     is run and the cheaper of the two at equal error is used. nld runs the same model.

(iii) ``--hertz-damped-only``: only the slider_crank hertz_damped setup of (ii), with every method
     of (i) over the ladder too (issue 14's targets: >= 30x the best scipy method at rtol 1e-8 with
     an error comparable to LN's, >= 1.5x numbalsoda at every error target), written to
     benchmarks/results/methods_hertz_damped.md; the LN rows of the same window are run beside it
     for the error comparison.

No timed asserts: the tables are written to the results file with the machine and the load.
"""
from __future__ import annotations

import argparse
import datetime
import math
import os
import platform
import runpy
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

WP = runpy.run_path(str(ROOT / "studies" / "work_precision.py"))
Setup, window_measures, _timed = WP["Setup"], WP["window_measures"], WP["_timed"]
FAMILY = WP["FAMILY"]

METHODS = WP["ALL_METHODS"]
NATIVE = ("dopri5", "dop853", "rodas")
SCENES = {  # scene -> window revolutions
    "slider_crank": 0.25, "slider_crank_crankpin": 0.25, "slider_crank_two": 0.25,
    "slider_crank_olyaei": 0.25, "four_bar": 0.25, "excavator": 0.01,
}
LADDER = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
LADDER_QUICK = (1e-5, 1e-7, 1e-9)
TARGETS = (1e-2, 1e-4, 1e-6)            # journal error / smallest clearance
REF_RTOL = 1e-12
WINDOW_POINTS = 2000
HD = {"joints.B.contact.law": "hertz_damped", "joints.B.contact.damping": 400.0}
TARGET_SCIPY, TARGET_NBS = 30.0, 1.5


def settings(quick):
    return dict(window_points=WINDOW_POINTS, transient_revs=0, long_revs=0,
                ladder=LADDER_QUICK if quick else LADDER, repeats=3 if quick else 20,
                repeat_budget=0.2 if quick else 0.5, cap_window_s=1.0 if quick else 3.0,
                max_steps=20_000_000)


def make_setup(scene, window, st, overrides=()):
    spec = dict(scene=scene, overrides=tuple(overrides), window_revs=window, long_revs=0, label=scene)
    return Setup(scene, spec, st)


def reference(setup):
    refs = {}
    for m in ("dop853", "dopri5", "rodas"):
        if len(refs) == 2:
            break
        out = setup.solve(m, REF_RTOL, setup.t_win_eval, 50_000_000)
        if int(out[0]) >= 0 and int(out[3]) == len(setup.t_win_eval):
            refs[m] = (setup.observe(setup.t_win_eval, out), setup.events(out))
    return refs


def ladder_runs(setup, methods, st, refs, log, also_ends=False):
    """Each method over the ladder. also_ends: the time is also taken with 2 output times (the steps
    do not depend on the output grid, land=False) and the smaller one is kept."""
    rows = []
    for m in methods:
        ref_m = next((r for r in refs if FAMILY[r] != FAMILY[m]), None)
        setup.solve(m, st["ladder"][0], setup.t_win_eval[:3], st["max_steps"])       # warm-up
        for rtol in st["ladder"]:
            out, cpu = _timed(lambda: setup.solve(m, rtol, setup.t_win_eval, st["max_steps"]),
                              st["repeats"] if not m.startswith("scipy") else min(3, st["repeats"]),
                              st["repeat_budget"])
            cpu_fine = cpu
            if also_ends:
                ends = np.array([0.0, setup.t_window])
                _, cpu_end = _timed(lambda: setup.solve(m, rtol, ends, st["max_steps"]), st["repeats"],
                                    st["repeat_budget"])
                cpu = min(cpu, cpu_end)
            err = math.nan
            if int(out[0]) >= 0 and ref_m is not None:
                tab = setup.observe(setup.t_win_eval, out)
                err = window_measures(setup, tab, setup.events(out), *refs[ref_m])["journal_err_rel"]
            rows.append(dict(method=m, rtol=rtol, cpu=cpu, err=err, status=int(out[0]), ref=ref_m))
            if also_ends:
                rows[-1].update(cpu_fine=cpu_fine, cpu_end=cpu_end)
            log(f"    {m:13s} rtol {rtol:.0e}: {cpu * 1e3:9.3f} ms  err/c {err:.2e}")
            if cpu > st["cap_window_s"]:
                break
    return rows


def at_target(rows, method, target):
    ok = [r for r in rows if r["method"] == method and r["err"] == r["err"] and r["err"] <= target]
    return min(ok, key=lambda r: r["cpu"]) if ok else None


# ------------------------------------------------------------------ numbalsoda
def numbalsoda_runs(setup, st, refs, log):
    """numbalsoda lsoda and dop853 on the kernel rhs; rows like ladder_runs, or a reason string."""
    try:
        import numbalsoda
        from numba import carray, cfunc
    except Exception as exc:                                   # noqa: BLE001
        return f"numbalsoda could not be imported: {exc!r}"
    from nld.run.simulate import state_scales
    rhs, events = setup.kern.module.rhs, setup.kern.module.events
    n = int(setup.y0.size)
    NE = max(1, int(setup.kern.n_events))
    NC = len(setup.clearances)
    P = np.ascontiguousarray(setup.p, dtype=float)
    Z = np.ascontiguousarray(setup.z0, dtype=float)
    NZ = int(Z.size)
    SC = np.ascontiguousarray(state_scales(setup.kern, setup.q), dtype=float)
    ZL = setup.kern.z_layout
    # hertz_damped joints: the clamp (the unclamped force's zero) is a mode too; its event function
    # with the joint's flags set to contact gives the unclamped force (one events() call, as before)
    CL = np.array([ci in ZL.clamp for ci in range(NC)], dtype=np.bool_)
    SIG = np.array([ZL.sig_c.get(ci, 0) for ci in range(NC)], dtype=np.int64)
    EVC = np.array([ZL.ev_c.get(ci, 0) for ci in range(NC)], dtype=np.int64)
    try:
        @cfunc(numbalsoda.lsoda_sig)
        def f(t, u, du, data):
            uu = carray(u, (n,))
            dd = carray(du, (n,))
            ws = carray(data, (2 * n + NE + NZ,))
            y = ws[:n]
            dy = ws[n:2 * n]
            g = ws[2 * n:2 * n + NE]
            zz = ws[2 * n + NE:]          # the discrete state (a global array would be read-only)
            for i in range(n):
                y[i] = uu[i] * SC[i]
            # no events in numbalsoda: hertz_damped's contact mode follows the penetration's sign
            # and the clamp the unclamped force's sign at every evaluation (the law stepped across,
            # as before issue 14)
            for i in range(NC):
                zz[i] = 1.0
                if CL[i]:
                    zz[SIG[i]] = 1.0
            events(t, y, P, zz, g)
            for i in range(NC):
                if g[i] <= 0.0:
                    zz[i] = 0.0
                elif CL[i] and g[EVC[i]] <= 0.0:
                    zz[i] = -1.0
            rhs(t, y, P, zz, dy)
            for i in range(n):
                dd[i] = dy[i] / SC[i]
        ptr = f.address
    except Exception as exc:                                   # noqa: BLE001
        return f"numbalsoda: the cfunc wrapping the kernel rhs did not compile: {exc!r}"
    u0 = np.ascontiguousarray(setup.y0 / SC)
    data = np.zeros(2 * n + NE + NZ)
    data[2 * n + NE:] = Z
    grid = setup.t_win_eval
    ends = np.array([0.0, setup.t_window])
    rows = []
    cols = [(f"{j}.ex", f"{j}.ey") for j in setup.clearances]
    for name, fn in (("numbalsoda:lsoda", numbalsoda.lsoda), ("numbalsoda:dop853", numbalsoda.dop853)):
        # the reference is a different method: not the 8th-order Dormand-Prince pair for dop853
        fam = "dp8" if name.endswith("dop853") else "lsoda"
        ref_m = next((r for r in refs if FAMILY[r] != fam), None)
        if ref_m is None:
            return "numbalsoda: no reference by a different method"
        ref_tab = refs[ref_m]
        fn(ptr, u0, ends, data=data, rtol=1e-6, atol=1e-6, mxstep=10_000_000)      # warm-up
        for variant, rfac in (("rtol = atol", 1.0), ("rtol = 1e-3 atol", 1e-3)):
            for tol in st["ladder"]:
                def call(g=grid):
                    return fn(ptr, u0, g, data=data, rtol=tol * rfac, atol=tol, mxstep=10_000_000)
                (usol, ok), cpu_fine = _timed(call, st["repeats"], st["repeat_budget"])
                _, cpu_end = _timed(lambda: call(ends), st["repeats"], st["repeat_budget"])
                err = math.nan
                if ok and np.all(np.isfinite(usol)):
                    Y = np.ascontiguousarray(usol * SC)
                    Zs = np.zeros((len(grid), max(1, Z.size)))
                    Zs[:, :Z.size] = Z
                    rws = np.empty((len(grid), len(setup.kern.columns)))
                    setup.kern.module.observe_all(grid, Y, Zs, len(grid), P, rws)
                    d = 0.0
                    for (cx, cy) in cols:
                        ix, iy = setup.kern.columns.index(cx), setup.kern.columns.index(cy)
                        d = max(d, float(np.max(np.hypot(rws[:, ix] - ref_tab[0][cx].to_numpy(),
                                                         rws[:, iy] - ref_tab[0][cy].to_numpy()))))
                    err = d / setup.cmin
                rows.append(dict(method=f"{name} ({variant})", rtol=tol, cpu=min(cpu_fine, cpu_end),
                                 cpu_fine=cpu_fine, cpu_end=cpu_end, err=err, status=0 if ok else -1, ref=ref_m))
                log(f"    {name} ({variant}) tol {tol:.0e}: {cpu_end * 1e3:8.3f} ms (2 outputs), "
                    f"{cpu_fine * 1e3:8.3f} ms ({len(grid)} outputs), err/c {err:.2e}")
    return rows


# ------------------------------------------------------------------ report
def machine():
    cpu = platform.processor() or ""
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import numba
    import scipy
    try:
        import numbalsoda  # noqa: F401
        from importlib.metadata import version
        nbs = version("numbalsoda")
    except Exception:                                          # noqa: BLE001
        nbs = "not installed"
    return (f"{cpu}, {os.cpu_count()} cores; Python {platform.python_version()}, numba {numba.__version__}, "
            f"numpy {np.__version__}, scipy {scipy.__version__}, numbalsoda {nbs}")


def fmt_cfg(r):
    return "–" if r is None else f"rtol {r['rtol']:.0e}: {r['cpu'] * 1e3:.3g} ms"


def run_row(label: str, r: dict) -> str:
    """One row of the "All runs" table (numbalsoda rows with both output timings)."""
    extra = (f" (2 outputs {r['cpu_end'] * 1e3:.4g}, {WINDOW_POINTS + 1} outputs {r['cpu_fine'] * 1e3:.4g})"
             if "cpu_end" in r else "")
    return (f"| {label} | {r['method']} | {r['rtol']:.0e} | {r['cpu'] * 1e3:.4g}{extra} | {r['err']:.3g} | "
            f"{r['status']} | {r['ref']} |")


def write_out(lines: list[str], path) -> None:
    """The report's markdown to ``path`` (folders made) and to stdout."""
    text = "\n".join(lines) + "\n"
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    Path(path).write_text(text)
    print(text)


def numbalsoda_table(nbs_nld, nbs, w) -> tuple[list[str], list[float]]:
    """The numbalsoda section's rows (markdown), one per error target, and the ratio numbalsoda CPU /
    nld CPU per target (nan where either misses it)."""
    out = ["numbalsoda has no events and one scalar rtol/atol; it integrates u = y / state_scales "
           "(so atol = tol is nld's absolute tolerance) with rtol = tol or 1e-3 tol. For both libraries "
           "the time is the cheaper of a run with 2 outputs and one with the error grid's "
           f"{WINDOW_POINTS + 1} outputs (the error is measured on the latter). nld runs the same model "
           "with simulate's arguments, contact events on (located; numbalsoda steps across the force kinks).", "",
           "| target err / c | nld dopri5 | nld dop853 | best nld (rev/s) | numbalsoda lsoda | numbalsoda dop853 | "
           f"best numbalsoda (rev/s) | numbalsoda / nld | target >= {TARGET_NBS:g}x |",
           "|---|---|---|---|---|---|---|---|---|"]
    ratios = []
    for target in TARGETS:
        c5, c8 = at_target(nbs_nld, "dopri5", target), at_target(nbs_nld, "dop853", target)
        nl = [at_target(nbs, f"numbalsoda:lsoda ({v})", target) for v in ("rtol = atol", "rtol = 1e-3 atol")]
        nd = [at_target(nbs, f"numbalsoda:dop853 ({v})", target) for v in ("rtol = atol", "rtol = 1e-3 atol")]
        bl = min([r for r in nl if r], key=lambda r: r["cpu"], default=None)
        bd = min([r for r in nd if r], key=lambda r: r["cpu"], default=None)
        bn = min([r for r in (c5, c8) if r], key=lambda r: r["cpu"], default=None)
        bb = min([r for r in (bl, bd) if r], key=lambda r: r["cpu"], default=None)
        ratio = bb["cpu"] / bn["cpu"] if bb and bn else math.nan
        met = "–" if ratio != ratio else ("met" if ratio >= TARGET_NBS else "missed")

        def cell(r):
            return "–" if r is None else f"{r['method'].split(' ', 1)[-1] if 'numbalsoda' in r['method'] else ''} tol {r['rtol']:.0e}: {r['cpu'] * 1e3:.3g} ms".strip()
        out.append(f"| {target:g} | {cell(c5)} | {cell(c8)} | {bn['method'] + ' ' + format(w / bn['cpu'], '.4g') if bn else '–'} "
                   f"| {cell(bl)} | {cell(bd)} | {bb['method'] + ' ' + format(w / bb['cpu'], '.4g') if bb else '–'} "
                   f"| {ratio:.3g}x | {met} |")
        ratios.append(ratio)
    return out + [""], ratios


def hertz_damped_only(args, st, log):
    """(iii): slider_crank hertz_damped against every scipy method and numbalsoda; LN beside it."""
    load0 = os.getloadavg()
    t_start = time.perf_counter()
    w = 0.25
    hd = make_setup("slider_crank", w, st, [f"{k}={v}" for k, v in HD.items()])
    log("slider_crank, hertz_damped")
    hd_refs = reference(hd)
    hd_rows = ladder_runs(hd, METHODS, st, hd_refs, log)
    log("slider_crank, hertz_damped, 2-output timings and numbalsoda")
    nbs_nld = ladder_runs(hd, ("dopri5", "dop853"), st, hd_refs, log, also_ends=True)
    nbs = numbalsoda_runs(hd, st, hd_refs, log)
    log("slider_crank, Lankarani-Nikravesh (the error comparison)")
    ln = make_setup("slider_crank", w, st)
    ln_rows = ladder_runs(ln, ("dopri5", "dop853"), st, reference(ln), log)
    wall = time.perf_counter() - t_start
    load1 = os.getloadavg()
    out = ["# slider_crank with hertz_damped contact: nld against scipy and numbalsoda "
           "(benchmarks/bench_methods.py --hertz-damped-only)", "",
           f"Machine: {machine()}; {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC. "
           f"Load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f} at the start, "
           f"{load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} at the end (shared machine); run took {wall:.0f} s.", "",
           f"slider_crank, joints.B.contact.law = hertz_damped, damping C = {HD['joints.B.contact.damping']:g} N s/m; "
           f"window {w} revolution from the assembled state. Time: CPU time as simulate() calls it (min over "
           "repeats); error: max journal-centre distance to a reference by a different method at rtol "
           f"{REF_RTOL:g}, / clearance c.", "",
           "## At rtol 1e-8 (issue 14: >= 30x the best scipy method, error comparable to LN's)", "",
           "| method | CPU (ms) | err / c | best scipy / this |", "|---|---|---|---|"]
    at8 = {r["method"]: r for r in hd_rows if r["rtol"] == 1e-8}
    # a scipy run that lost a contact (solve_ivp looks for sign changes at step ends only, and a
    # missed hertz_damped onset leaves the journal without a contact force) is no solution
    sci = [r for m, r in at8.items() if m.startswith("scipy") and r["status"] >= 0 and r["err"] <= TARGETS[0]]
    bs = min(sci, key=lambda r: r["cpu"]) if sci else None
    for m in METHODS:
        r = at8.get(m)
        if r is None:
            out.append(f"| {m} | – | – | – |")
            continue
        rat = f"{bs['cpu'] / r['cpu']:.3g}x" if bs and not m.startswith("scipy") else ""
        out.append(f"| {m} | {r['cpu'] * 1e3:.4g} | {r['err']:.3g} | {rat} |")
    for r in ln_rows:
        if r["rtol"] == 1e-8:
            out.append(f"| {r['method']} with LN contact | {r['cpu'] * 1e3:.4g} | {r['err']:.3g} | |")
    out += ["", f"best scipy at rtol 1e-8: {bs['method'] if bs else '–'} (among the scipy runs with error "
            f"<= {TARGETS[0]:g} c: a larger error is a lost contact)", ""]
    out += ["## At matched error", "",
            "| target err / c | " + " | ".join(METHODS) + " | best scipy / best nld | target >= 30x |",
            "|---|" + "---|" * (len(METHODS) + 2)]
    for target in TARGETS:
        cfg = {m: at_target(hd_rows, m, target) for m in METHODS}
        nat = [cfg[m] for m in NATIVE if cfg[m]]
        scs = [cfg[m] for m in METHODS if m.startswith("scipy") and cfg[m]]
        bn = min(nat, key=lambda r: r["cpu"], default=None)
        bsc = min(scs, key=lambda r: r["cpu"], default=None)
        ratio = bsc["cpu"] / bn["cpu"] if bn and bsc else math.nan
        met = "–" if ratio != ratio else ("met" if ratio >= TARGET_SCIPY else "missed")
        out.append(f"| {target:g} | " + " | ".join("–" if cfg[m] is None else f"{cfg[m]['rtol']:.0e}: {cfg[m]['cpu'] * 1e3:.3g} ms"
                                                  for m in METHODS) + f" | {ratio:.3g}x | {met} |")
    out += ["", "## numbalsoda (same setup)", ""]
    out += ([f"Not measured: {nbs}", ""] if isinstance(nbs, str) else numbalsoda_table(nbs_nld, nbs, w)[0])
    out += ["## All runs", "", "| contact | method | rtol | CPU (ms) | err / c | status | reference |",
            "|---|---|---|---|---|---|---|"]
    for lab, rows in (("hertz_damped", hd_rows), ("hertz_damped", nbs_nld),
                      ("hertz_damped", [] if isinstance(nbs, str) else nbs), ("LN", ln_rows)):
        out += [run_row(lab, r) for r in rows]
    write_out(out, args.out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=None)
    ap.add_argument("--scenes", default=",".join(SCENES))
    ap.add_argument("--hertz-damped-only", action="store_true",
                    help="only slider_crank with hertz_damped contact against scipy and numbalsoda (iii)")
    args = ap.parse_args(argv)
    st = settings(args.quick)
    if args.hertz_damped_only:
        args.out = args.out or str(HERE / "results" / "methods_hertz_damped.md")
        return hertz_damped_only(args, st, print)
    args.out = args.out or str(HERE / "results" / "methods.md")
    log = print
    load0 = os.getloadavg()
    t_start = time.perf_counter()
    summary = []
    all_rows = {}
    for scene in args.scenes.split(","):
        win = SCENES[scene]
        setup = make_setup(scene, win, st)
        log(f"{scene}: window {win} rev ({setup.t_window * 1e3:.3f} ms)")
        refs = reference(setup)
        rows = ladder_runs(setup, METHODS, st, refs, log)
        all_rows[scene] = (setup, rows)
    nbs_setup = make_setup("slider_crank", 0.25, st, [f"{k}={v}" for k, v in HD.items()])
    log("slider_crank, hertz_damped (numbalsoda comparison)")
    nbs_refs = reference(nbs_setup)
    nbs_nld = ladder_runs(nbs_setup, ("dopri5", "dop853"), st, nbs_refs, log, also_ends=True)
    nbs = numbalsoda_runs(nbs_setup, st, nbs_refs, log)
    wall = time.perf_counter() - t_start
    load1 = os.getloadavg()

    out = [f"# Integrator methods at matched error (benchmarks/bench_methods.py{' --quick' if args.quick else ''})",
           "",
           f"Machine: {machine()}; {datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC. "
           f"Load average {load0[0]:.2f} {load0[1]:.2f} {load0[2]:.2f} at the start, "
           f"{load1[0]:.2f} {load1[1]:.2f} {load1[2]:.2f} at the end (shared machine); run took {wall:.0f} s.",
           "",
           "Time: CPU time of the integration as simulate() calls it (min over repeats), window of the first "
           "revolutions from the assembled state; error: max journal-centre distance to a reference by a "
           f"different method at rtol {REF_RTOL:g}, / smallest clearance c. rev/s = window revolutions / time. "
           "At each target, each method's cheapest ladder run meeting it (ladder "
           + ", ".join(f"{r:.0e}" for r in st["ladder"]) + "; '–': no run met it).",
           ""]
    for target in TARGETS:
        out += [f"## Target journal error <= {target:g} c", "",
                "| scene | " + " | ".join(METHODS) + " | best nld (rev/s) | best scipy (rev/s) | scipy / nld | "
                f"target >= {TARGET_SCIPY:g}x | scipy / dopri5 |",
                "|---|" + "---|" * (len(METHODS) + 5)]
        for scene, (setup, rows) in all_rows.items():
            cfg = {m: at_target(rows, m, target) for m in METHODS}
            cells = [("–" if cfg[m] is None else f"{cfg[m]['rtol']:.0e}: {setup.spec['window_revs'] / cfg[m]['cpu']:.4g}")
                     for m in METHODS]
            nat = [cfg[m] for m in NATIVE if cfg[m] is not None]
            sci = [(m, cfg[m]) for m in METHODS if m.startswith("scipy") and cfg[m] is not None]
            bn = min(nat, key=lambda r: r["cpu"]) if nat else None
            bs = min(sci, key=lambda x: x[1]["cpu"]) if sci else None
            ratio = bs[1]["cpu"] / bn["cpu"] if bn and bs else math.nan
            r5 = bs[1]["cpu"] / cfg["dopri5"]["cpu"] if bs and cfg["dopri5"] else math.nan
            w = setup.spec["window_revs"]
            met = "–" if ratio != ratio else ("met" if ratio >= TARGET_SCIPY else "missed")
            out.append(f"| {scene} | " + " | ".join(cells)
                       + f" | {bn['method'] + ' ' + format(w / bn['cpu'], '.4g') if bn else '–'}"
                       + f" | {bs[0] + ' ' + format(w / bs[1]['cpu'], '.4g') if bs else '–'}"
                       + f" | {ratio:.3g}x | {met} | {r5:.3g}x |")
            summary.append(dict(scene=scene, target=target, ratio=ratio, best_nld=bn and bn["method"],
                                best_scipy=bs and bs[0]))
        out += ["", "Cells: rtol of the cheapest run meeting the target: window revolutions per CPU second.", ""]

    out += ["## numbalsoda (slider_crank, hertz_damped contact, C = 400 N s/m)", ""]
    if isinstance(nbs, str):
        out += [f"Not measured: {nbs}", ""]
    else:
        rows, ratios = numbalsoda_table(nbs_nld, nbs, nbs_setup.spec["window_revs"])
        out += rows
        summary += [dict(scene="slider_crank hertz_damped", target=t, nbs_ratio=r) for t, r in zip(TARGETS, ratios)]

    out += ["## All runs", "", "| scene | method | rtol | CPU (ms) | err / c | status | reference |", "|---|---|---|---|---|---|---|"]
    for scene, (setup, rows) in all_rows.items():
        out += [run_row(scene, r) for r in rows]
    out += [run_row("slider_crank hertz_damped", r) for r in nbs_nld + ([] if isinstance(nbs, str) else nbs)]
    write_out(out, args.out)
    return summary


if __name__ == "__main__":
    main()
