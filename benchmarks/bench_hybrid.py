#!/usr/bin/env python
"""Cost of the non-smooth laws run as hybrid modes (issue 14; docs/contact-laws.md, "Modes").

    python benchmarks/bench_hybrid.py [--out benchmarks/results/hybrid.md] [--repeats 3]

(i)  excavator, one crank revolution at rtol 1e-7 (the tolerance an exponent or a Poincare section
     needs), Coulomb friction f = mu at both clearance joints, f = 0.05 and 0.1 against f = 0:
     steps, rejected steps, events, CPU time (``time.process_time`` of ``nld.run.simulate`` after a
     warm-up run that compiles the kernel; minimum over repeats) and their ratios to f = 0 in the
     same run. Issue 14 asks for <= 3x in steps and CPU time.
(ii) slider_crank with hertz_damped contact (K d^1.5 + C d', C = 400 N s/m) against
     Lankarani-Nikravesh at equal rtol over 0.25 revolution: steps, share of rejected steps, and
     the error = largest journal-centre distance to the same law's run at rtol 1e-12, divided by
     the clearance.

Run it with another checkout first on PYTHONPATH to get the numbers of that code (the script
uses only ``nld.run.simulate``). No timed asserts: the table goes to stdout and to ``--out``.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
if "PYTHONPATH" not in os.environ:
    sys.path.insert(0, str(HERE.parent))

from nld.run.simulate import simulate  # noqa: E402

EXC_MU = (0.0, 0.05, 0.1)
SC_LAWS = {"lankarani_nikravesh": [], "hertz_damped": ["joints.B.contact.law=hertz_damped",
                                                        "joints.B.contact.damping=400"]}
SC_RTOLS = (1e-6, 1e-8, 1e-10)


def excavator_rows(repeats: int, log) -> list[dict]:
    rows = []
    for mu in EXC_MU:
        ov = [f"joints.A.friction.mu={mu}", f"joints.B.friction.mu={mu}"]

        def run():
            return simulate("excavator", revs=1, rtol=1e-7, samples_per_rev=100, overrides=ov,
                            max_steps=50_000_000)
        r = run()                                       # warm-up: compiles the kernel
        cpu = []
        for _ in range(repeats):
            c = time.process_time()
            r = run()
            cpu.append(time.process_time() - c)
        st = r.stats
        rows.append(dict(mu=mu, status=r.status, steps=st["steps"], rejected=st["rejected"],
                         events=st["events"], cpu=min(cpu), message=r.message))
        log(f"excavator f = {mu}: {r.message}, CPU {min(cpu):.3f} s")
    return rows


def journal(tab):
    return np.column_stack([tab["B.ex"].to_numpy(), tab["B.ey"].to_numpy()])


def slider_rows(log) -> list[dict]:
    rows = []
    c = 0.5e-3
    for law, ov in SC_LAWS.items():
        kw = dict(revs=0.25, samples_per_rev=4000, overrides=ov)
        ref = simulate("slider_crank", rtol=1e-12, **kw)
        for rtol in SC_RTOLS:
            r = simulate("slider_crank", rtol=rtol, **kw)
            err = float(np.max(np.hypot(*(journal(r.table) - journal(ref.table)).T))) / c
            st = r.stats
            rows.append(dict(law=law, rtol=rtol, steps=st["steps"], rejected=st["rejected"],
                             share=st["rejected"] / max(1, st["steps"]), err=err, status=r.status))
            log(f"slider_crank {law} rtol {rtol:.0e}: {st['steps']} steps, {st['rejected']} rejected, "
                f"error {err:.2e} c")
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--skip-excavator", action="store_true")
    a = ap.parse_args(argv)

    def log(s):
        print(s, file=sys.stderr, flush=True)

    import nld
    out = ["# Hybrid modes: cost of Coulomb stick/slip and of hertz_damped's jump (issue 14)", "",
           f"{datetime.datetime.now(datetime.timezone.utc):%Y-%m-%d %H:%M} UTC, nld from "
           f"{Path(nld.__file__).resolve().parent}, {platform.processor() or platform.machine()}, "
           f"load {os.getloadavg()[0]:.2f}; command: `python benchmarks/bench_hybrid.py`", ""]
    if not a.skip_excavator:
        ex = excavator_rows(a.repeats, log)
        base = ex[0]
        out += ["## excavator, one revolution, rtol 1e-7, Coulomb f at both joints", "",
                "| f | status | steps | rejected | events | CPU (s) | steps / f=0 | CPU / f=0 | <= 3x |",
                "|---|---|---|---|---|---|---|---|---|"]
        for r in ex:
            rs, rc = r["steps"] / base["steps"], r["cpu"] / base["cpu"]
            out.append(f"| {r['mu']:g} | {r['status']} | {r['steps']} | {r['rejected']} | {r['events']} | "
                       f"{r['cpu']:.3f} | {rs:.2f} | {rc:.2f} | {'yes' if max(rs, rc) <= 3 else 'no'} |")
        out.append("")
    sc = slider_rows(log)
    out += ["## slider_crank, 0.25 revolution: hertz_damped (C = 400 N s/m) vs Lankarani-Nikravesh", "",
            "error: largest journal-centre distance to the same law at rtol 1e-12, / clearance (0.5 mm)", "",
            "| law | rtol | steps | rejected | rejected share | error / c |", "|---|---|---|---|---|---|"]
    for r in sc:
        out.append(f"| {r['law']} | {r['rtol']:.0e} | {r['steps']} | {r['rejected']} | {r['share']:.1%} | "
                   f"{r['err']:.2e} |")
    text = "\n".join(out) + "\n"
    print(text)
    if a.out:
        Path(a.out).write_text(text, encoding="utf-8")


if __name__ == "__main__":
    main()
