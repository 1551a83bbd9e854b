#!/usr/bin/env python
"""The run-time cost of compiling the integrators once (issue 23, item 2), side by side in one run.

    python benchmarks/bench_indirection.py [--revs 2] [--repeats 20] [--out benchmarks/results/indirection.md]

Since issue 23 the integrators are compiled once per machine and call a scene's rhs / events /
on_event (and the tangent JVPs) through first-class function pointers (nld.integrators.core).
Before, every scene compiled the whole integrator with its functions inlined. Both builds are
measured here on every benchmark scene, warm, in the same process:

* indirect: ``nld.integrators.dopri5`` (what ``Kernel.module.solve`` runs), and the tangent
  DOPRI5 (``dopri5_tangent``, what ``nld lyapunov`` runs) with one tangent vector;
* inlined: ``nld.integrators.core.inlined(core)`` called with the kernel's numba functions
  themselves: the same Python code compiled with the functions inlined (the old build).

Per scene and path: the minimum process CPU time over ``--repeats`` runs, the two paths
alternating so that a change of load hits both; the ratio indirect / inlined; and the largest
difference between the two trajectories (0 means bit-identical: same arithmetic, same steps).
"""
from __future__ import annotations

import argparse
import datetime
import platform
import sys
import time
from pathlib import Path

from _results import write_table  # noqa: E402 (benchmarks/_results.py)

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import numba  # noqa: E402

from nld.integrators import dopri5, native  # noqa: E402,F401
from nld.integrators.core import inlined  # noqa: E402
from nld.integrators.dopri5 import dopri5_core, interp  # noqa: E402
from nld.integrators.events import EVENT_SAMPLES  # noqa: E402
from nld.integrators.tangent import dopri5_tangent, dopri5_tangent_core  # noqa: E402
from nld.systems.core import SceneSystem  # noqa: E402

SCENES = [  # (label, scene, overrides, revolutions factor)
    ("slider_crank (Lankarani-Nikravesh)", "slider_crank", [], 1.0),
    ("slider_crank (hertz_damped)", "slider_crank", ['joints.B.contact.law="hertz_damped"',
                                                      "joints.B.contact.damping=400.0"], 1.0),
    ("slider_crank_olyaei (LN + Ambrosio friction)", "slider_crank_olyaei", [], 1.0),
    ("slider_crank_olyaei (hybrid Coulomb stick-slip)", "slider_crank_olyaei",
     ['joints.B.friction.law="coulomb"'], 1.0),
    ("slider_crank_two (two clearances)", "slider_crank_two", [], 1.0),
    ("four_bar (Rhee-Akay type)", "four_bar", [], 0.25),
    ("excavator (seed paper, two clearances)", "excavator", [], 0.25),
]


def cpu(f):
    t = time.process_time()
    out = f()
    return time.process_time() - t, out


def one_scene(label, name, overrides, revs, repeats, rtol, rtol_tan):
    try:
        S = SceneSystem(name, overrides)
    except Exception as e:      # noqa: BLE001 - a scene override this nld does not know
        return f"| {label} | not run: {' '.join(str(e).split())[:120]} |||||||"
    m = S.kernel.module
    T = S.period
    t_eval = np.linspace(0.0, revs * T, 50)
    atol = S.tolerance(rtol)
    args = lambda z: (0.0, S.y0.copy(), t_eval, False, S.p, z, rtol, atol, 0.0,  # noqa: E731
                      float(S.hmax), 10**8, S.n_events, 100_000, EVENT_SAMPLES)
    twin = inlined(dopri5_core)
    ind = lambda: dopri5(m.rhs, m.events, m.on_event, *args(S.z0.copy()))  # noqa: E731
    inl = lambda: twin(m.rhs, m.events, m.on_event, interp, *args(S.z0.copy()))  # noqa: E731
    t_c0, _ = cpu(inl)            # compiles the inlined build (the old per-scene cost)
    ind()
    a, b = np.inf, np.inf
    for _ in range(repeats):
        ta, ra = cpu(ind)
        tb, rb = cpu(inl)
        a, b = min(a, ta), min(b, tb)
    diff = float(np.nanmax(np.abs(ra[2] - rb[2]))) if ra[3] == rb[3] else np.inf
    same_steps = bool(np.array_equal(ra[4], rb[4]))
    row = (f"| {label} | {revs:g} rev, rtol {rtol:g} | {a * 1e3:.2f} | {b * 1e3:.2f} | {a / b:.3f} | "
           f"{diff:.1e}{'' if same_steps else ' (steps differ)'} | {t_c0:.1f} |")
    # tangent DOPRI5, one vector, if the kernel has tangent functions
    trow = None
    if hasattr(m, "rhs_jvp"):
        ttw = inlined(dopri5_tangent_core)
        marks = T * revs / 4 * np.arange(1, 5)
        atol_t = S.tolerance(rtol_tan)

        def targs():
            W = (np.eye(S.n)[:1] * S.scales).copy()
            return (0.0, S.y0.copy(), S.z0.copy(), W, np.zeros((1, S.z0.size)), marks, S.p,
                    rtol_tan, atol_t, S.scales, 0.0, float(S.hmax), 10**8, S.n_events, True,
                    False, np.zeros(8), np.zeros((marks.size, 1)), EVENT_SAMPLES, True)
        fns = (m.rhs, m.rhs_jvp, m.events, m.events_jvp, m.on_event, m.on_event_jvp)
        tind = lambda: dopri5_tangent(*fns, *targs())  # noqa: E731
        tinl = lambda: ttw(*fns, interp, *targs())  # noqa: E731
        t_c1, _ = cpu(tinl)
        tind()
        a, b = np.inf, np.inf
        for _ in range(max(3, repeats // 4)):
            ta, ra = cpu(tind)
            tb, rb = cpu(tinl)
            a, b = min(a, ta), min(b, tb)
        diff = float(np.max(np.abs(ra[2] - rb[2])))
        trow = (f"| {label}, tangent (k = 1) | {revs:g} rev, rtol {rtol_tan:g} | {a * 1e3:.2f} | "
                f"{b * 1e3:.2f} | {a / b:.3f} | {diff:.1e} | {t_c1:.1f} |")
    return row if trow is None else row + "\n" + trow


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--revs", type=float, default=2.0)
    ap.add_argument("--repeats", type=int, default=20)
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--rtol-tangent", type=float, default=1e-10)
    ap.add_argument("--out", default=str(HERE / "results" / "indirection.md"))
    a = ap.parse_args(argv)
    t0 = time.time()
    rows = []
    for label, name, ov, f in SCENES:
        rows.append(one_scene(label, name, ov, a.revs * f, a.repeats, a.rtol, a.rtol_tangent))
        print(rows[-1], flush=True)
    head = [
        "# Integrators compiled once (indirect calls) against the inlined build, warm",
        "",
        f"Command: `python benchmarks/bench_indirection.py --revs {a.revs:g} --repeats {a.repeats}`; "
        f"{datetime.datetime.now():%Y-%m-%d %H:%M}, {platform.processor() or platform.machine()}, "
        f"numba {numba.__version__}, Python {platform.python_version()}; load average at the end "
        f"{' '.join(f'{v:.2f}' for v in __import__('os').getloadavg())}; {time.time() - t0:.0f} s.",
        "",
        "CPU time per run, minimum over the repeats (the two paths alternate). 'max |dY|': the "
        "largest difference between the two trajectories' output rows (0: bit-identical). "
        "'inlined compile': the seconds the inlined build of this scene took to compile (paid "
        "per scene and process before issue 23; the indirect build compiles nothing per scene "
        "but the scene's own functions).",
        "",
        "| scene | run | indirect (ms) | inlined (ms) | indirect / inlined | max abs dY | inlined compile (s) |",
        "|---|---|---|---|---|---|---|",
    ]
    write_table(a.out, head, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
