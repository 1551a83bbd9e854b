#!/usr/bin/env python
"""First results in seconds: wall time of nld commands cold, for a new scene, and warm (issue 23).

    python benchmarks/bench_cold.py [--out benchmarks/results/cold.md] [--only simulate_slider]

Each command runs in a new process, three times, with the caches set up by this script:

* **cold**: empty kernel cache (``NLD_CACHE_DIR``) and empty numba cache (``NUMBA_CACHE_DIR``):
  a new machine just after ``pip install`` (which built the integrator cores ahead of time where
  it could, nld/integrators/aot.py); everything else is compiled;
* **new scene**: the integrators already compiled (numba cache kept from a run of *another*
  scene, ``nld simulate four_bar --revs 0.1`` and ``nld lyapunov four_bar --revs 2``), the kernel
  cache empty: what every new scene structure, law combination or user system costs once the
  integrators have been compiled on the machine;
* **warm**: both caches filled by the cold run;
* **cold, JIT**: as cold, with ``NLD_AOT=0``: the integrator cores built at install are not used,
  numba compiles them (a machine where the install-time build could not run).

Wall-clock seconds of the whole process (interpreter start, imports, compilation, the run).
Run nothing else on the machine meanwhile. The caches are temporary folders, deleted at the end.
"""
from __future__ import annotations

import argparse
import datetime
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _results import write_table  # noqa: E402 (benchmarks/_results.py)

HERE = Path(__file__).resolve().parent

USER_LORENZ = """
import numpy as np
from numba import njit
from nld.systems.core import ContinuousSystem
from nld.analysis.lyapunov import lyapunov_tangent

@njit
def rhs(t, y, p, z, dy):
    dy[0] = p[0] * (y[1] - y[0])
    dy[1] = y[0] * (p[1] - y[2]) - y[1]
    dy[2] = y[0] * y[1] - p[2] * y[2]

s = ContinuousSystem(rhs, [1.0, 1.0, 1.0], [10.0, 28.0, 8.0 / 3.0], name="my Lorenz")
r = lyapunov_tangent(s, transient=10.0, total=100.0)
print(f"lambda1 = {r.exponent:.3f} +- {r.uncertainty:.3f}")
"""

COMMANDS = {  # name: (argv after the interpreter, target for cold in s or None)
    "simulate_slider": (["-c", "import sys; from nld.cli import main; sys.exit(main())", "simulate", "slider_crank", "--revs", "2", "--out", "{tmp}/a.csv"], 5.0),
    "lyapunov_slider": (["-c", "import sys; from nld.cli import main; sys.exit(main())", "lyapunov", "slider_crank", "--revs", "50"], 8.0),
    "simulate_excavator": (["-c", "import sys; from nld.cli import main; sys.exit(main())", "simulate", "excavator", "--revs", "1", "--out", "{tmp}/b.csv"], None),
    "lyapunov_excavator": (["-c", "import sys; from nld.cli import main; sys.exit(main())", "lyapunov", "excavator", "--revs", "20"], None),
    "user_lorenz_tangent": (["-c", USER_LORENZ], 5.0),
}
LABELS = {
    "simulate_slider": "`nld simulate slider_crank --revs 2`",
    "lyapunov_slider": "`nld lyapunov slider_crank --revs 50`",
    "simulate_excavator": "`nld simulate excavator --revs 1`",
    "lyapunov_excavator": "`nld lyapunov excavator --revs 20`",
    "user_lorenz_tangent": "first `lyapunov_tangent` of a user ODE (Lorenz, 100 time units)",
}
WARMERS = [["-c", "import sys; from nld.cli import main; sys.exit(main())", "simulate", "four_bar", "--revs", "0.1", "--out", "{tmp}/w.csv"],
           ["-c", "import sys; from nld.cli import main; sys.exit(main())", "lyapunov", "four_bar", "--revs", "2"]]


def run(argv, kernels, numba_cache, tmp, aot=True):
    env = dict(os.environ)
    env["NLD_AOT"] = "1" if aot else "0"
    env["NLD_CACHE_DIR"] = str(kernels)
    env["NUMBA_CACHE_DIR"] = str(numba_cache)
    env.pop("NLD_QUIET", None)
    argv = [a.replace("{tmp}", str(tmp)) for a in argv]
    t = time.perf_counter()
    r = subprocess.run([sys.executable, *argv], env=env, capture_output=True, text=True,
                       cwd=tmp, timeout=1800)
    dt = time.perf_counter() - t
    if r.returncode != 0:
        raise SystemExit(f"{argv} failed ({r.returncode}):\n{r.stderr[-2000:]}")
    return dt, r.stdout.strip().splitlines()[-1] if r.stdout.strip() else ""


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(HERE / "results" / "cold.md"))
    ap.add_argument("--only", nargs="*", default=None, help="names of COMMANDS to run")
    a = ap.parse_args(argv)
    names = a.only or list(COMMANDS)
    rows = []
    t_all = time.time()
    base = Path(tempfile.mkdtemp(prefix="nld-cold-"))
    try:
        # the integrators compiled once, by another scene, for the "new scene" column
        warm_numba = base / "warm-numba"
        for w in WARMERS:
            run(w, base / "warm-kernels", warm_numba, base)
        for name in names:
            cmd, target = COMMANDS[name]
            d = base / name
            d.mkdir()
            cold, line = run(cmd, d / "k", d / "n", d)
            warm, _ = run(cmd, d / "k", d / "n", d)
            nk = base / f"{name}-newscene"
            nk.mkdir()
            nn = base / f"{name}-numba"
            shutil.copytree(warm_numba, nn)
            new, _ = run(cmd, nk / "k", nn, nk)
            dj = base / f"{name}-jit"
            dj.mkdir()
            cold_jit, _ = run(cmd, dj / "k", dj / "n", dj, aot=False)
            met = "" if target is None else (" met" if cold <= target else " missed")
            rows.append(f"| {LABELS[name]} | {cold:.1f} | {'' if target is None else f'<= {target:g}'}{met} "
                        f"| {new:.1f} | {warm:.1f} | {cold_jit:.1f} | {line[:90]} |")
            print(rows[-1], flush=True)
    finally:
        shutil.rmtree(base, ignore_errors=True)
    load = " ".join(f"{v:.2f}" for v in os.getloadavg())
    from nld.integrators import aot
    built = aot.why_not() or "present and current"
    head = [
        "# Cold, new-scene and warm wall times (issue 23)",
        "",
        f"Command: `python benchmarks/bench_cold.py`; {datetime.datetime.now():%Y-%m-%d %H:%M}, "
        f"{os.cpu_count()} cores, {platform.processor() or platform.machine()}, Python "
        f"{platform.python_version()}; {time.time() - t_all:.0f} s; load average at the end {load}.",
        "",
        "Seconds of wall time of the whole process. cold: empty kernel and numba caches (a new "
        "machine after the install); new scene: integrators compiled before by "
        "another scene, kernel cache empty; warm: both caches filled. The integrator cores built "
        f"at install (nld/integrators/aot.py): {built}; the cold, new-scene and warm columns use "
        "them; 'cold, JIT': empty caches with NLD_AOT=0 (numba compiles the cores too, what a "
        "machine without the install-time build pays once).",
        "",
        "| command | cold (s) | target | new scene (s) | warm (s) | cold, JIT (s) | last line of output |",
        "|---|---|---|---|---|---|---|",
    ]
    write_table(a.out, head, rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
