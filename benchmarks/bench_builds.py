#!/usr/bin/env python
"""Warm speed of this build against another (e.g. the build before issue 23), side by side.

    git worktree add /tmp/nld-old 3a0d175          # the build to compare with
    python benchmarks/bench_builds.py --other /tmp/nld-old [--rounds 3] [--out benchmarks/results/builds.md]

For each benchmark scene the same work runs in a fresh process per build (each with its own warm
kernel and numba caches, filled by a first round that is not timed): a trajectory through the
kernel's ``solve`` (DOPRI5, the call ``nld simulate`` makes) and a tangent run (``run_tangent``,
one vector, the call of ``nld lyapunov``). The builds alternate for ``--rounds`` rounds; each
figure is the minimum process CPU time over the rounds and the repeats inside a round. The ratio
this / other is what to read (machines are noisy); both builds must give the same results here
(the script prints the largest difference of the final states).
"""
from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

WORK = r'''
import json, sys, time
import numpy as np
from nld.systems.core import SceneSystem
from nld.systems.tangent import run_tangent
SCENES = json.loads(sys.argv[1]); REPEATS = int(sys.argv[2])
out = {}
for label, name, ov, revs in SCENES:
    S = SceneSystem(name, ov)
    m = S.kernel.module
    te = np.linspace(0.0, revs * S.period, 50)
    def traj():
        z = S.z0.copy()
        r = m.solve(0.0, S.y0.copy(), te, False, S.p, z, 1e-8, S.tolerance(1e-8), 0.0,
                    float(S.hmax), 10**8, S.n_events, 100000)
        return r[2][-1]
    marks = revs * S.period / 4 * np.arange(1, 5)
    def tan():
        W = (np.eye(S.n)[:1] * S.scales).copy()
        r = run_tangent(S, S.y0.copy(), S.z0.copy(), W, np.zeros((1, S.z0.size)), 0.0, marks, 1e-10)
        return np.concatenate([r.y, r.logs.ravel()])
    res = {}
    for key, f in (("trajectory", traj), ("tangent", tan)):
        v = f()
        best = np.inf
        for _ in range(REPEATS if key == "trajectory" else max(2, REPEATS // 5)):
            t = time.process_time(); f(); best = min(best, time.process_time() - t)
        res[key] = [best, [float(x) for x in v]]
    out[label] = res
print("RESULT " + json.dumps(out))
'''

SCENES = [  # label, scene, overrides, revolutions
    ["slider_crank (LN)", "slider_crank", [], 2.0],
    ["slider_crank (hertz_damped)", "slider_crank", ['joints.B.contact.law="hertz_damped"',
                                                     "joints.B.contact.damping=400.0"], 2.0],
    ["slider_crank_olyaei (LN + Ambrosio)", "slider_crank_olyaei", [], 2.0],
    ["slider_crank_two", "slider_crank_two", [], 2.0],
    ["four_bar", "four_bar", [], 0.5],
    ["excavator", "excavator", [], 0.5],
]


def run_build(path, caches, repeats):
    env = dict(os.environ)
    env["PYTHONPATH"] = str(path)
    env["NLD_CACHE_DIR"] = str(caches / "k")
    env["NUMBA_CACHE_DIR"] = str(caches / "n")
    r = subprocess.run([sys.executable, "-c", WORK, json.dumps(SCENES), str(repeats)], env=env,
                       capture_output=True, text=True, cwd=caches, timeout=3600)
    if r.returncode != 0:
        raise SystemExit(f"build {path} failed:\n{r.stderr[-3000:]}")
    line = [ln for ln in r.stdout.splitlines() if ln.startswith("RESULT ")][-1]
    return json.loads(line[len("RESULT "):])


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--other", required=True, help="root of the other build (a git worktree)")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--out", default=str(HERE / "results" / "builds.md"))
    a = ap.parse_args(argv)
    t0 = time.time()
    base = Path(tempfile.mkdtemp(prefix="nld-builds-"))
    builds = {"this": ROOT, "other": Path(a.other).resolve()}
    for k in builds:
        (base / k).mkdir()
        run_build(builds[k], base / k, 1)                    # fill the caches (not timed)
    best: dict = {k: {} for k in builds}
    finals: dict = {}
    for _ in range(a.rounds):
        for k in builds:
            res = run_build(builds[k], base / k, a.repeats)
            for label, r in res.items():
                for what, (t, v) in r.items():
                    best[k][(label, what)] = min(best[k].get((label, what), 1e9), t)
                    finals[(k, label, what)] = v
    rev = {k: subprocess.run(["git", "-C", str(p), "rev-parse", "--short", "HEAD"], capture_output=True,
                             text=True).stdout.strip() for k, p in builds.items()}
    rows = []
    for (label, what), t_this in best["this"].items():
        t_other = best["other"][(label, what)]
        import numpy as np
        d = float(np.max(np.abs(np.array(finals[("this", label, what)])
                                - np.array(finals[("other", label, what)]))))
        rows.append(f"| {label} | {what} | {t_this * 1e3:.2f} | {t_other * 1e3:.2f} | "
                    f"{t_this / t_other:.3f} | {d:.1e} |")
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    text = "\n".join([
        "# Warm speed: this build against another, side by side",
        "",
        f"Command: `python benchmarks/bench_builds.py --other <worktree of {rev['other']}> --rounds "
        f"{a.rounds} --repeats {a.repeats}`; this build {rev['this']} (with uncommitted changes if "
        f"any); {datetime.datetime.now():%Y-%m-%d %H:%M}, {os.cpu_count()} cores, "
        f"{platform.processor() or platform.machine()}; {time.time() - t0:.0f} s; load average "
        f"at the end {load}.",
        "",
        "Minimum process CPU time (ms) over the rounds and repeats; trajectory: DOPRI5 through the "
        "kernel's solve at rtol 1e-8 (2 revolutions, 0.5 for four_bar and excavator); tangent: "
        "run_tangent with one vector at rtol 1e-10 over the same span. 'max |d|': the largest "
        "difference between the two builds' final states (and logs of the tangent run).",
        "",
        f"| scene | work | this {rev['this']} (ms) | other {rev['other']} (ms) | this / other | max abs d |",
        "|---|---|---|---|---|---|",
    ] + rows) + "\n"
    Path(a.out).parent.mkdir(parents=True, exist_ok=True)
    Path(a.out).write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
