"""Where the compile time goes: run one nld command in this process with numba's compile events
recorded, and print the time spent compiling each function (self time: a function's compile
minus the compiles it triggered).

    NLD_CACHE_DIR=$(mktemp -d) NUMBA_CACHE_DIR=$(mktemp -d) \
        python benchmarks/compile_profile.py simulate slider_crank --revs 2

The arguments are those of the ``nld`` command line. Both caches must be empty for a cold profile
(the script does not empty them: it runs in the process whose compiles it records). Used for
docs/performance.md, "Where the compile time goes"; benchmarks/bench_cold.py times whole
commands cold and warm.
"""
from __future__ import annotations

import sys
import time
from collections import defaultdict

from numba.core import event


class _Listener(event.Listener):
    def __init__(self):
        self.stack = []           # [name, start, child time]
        self.self_time = defaultdict(float)
        self.total = defaultdict(float)
        self.count = defaultdict(int)

    def on_start(self, ev):
        d = ev.data.get("dispatcher")
        name = f"{getattr(d, 'py_func', d).__module__}.{getattr(d, '__name__', '?')}" if d else "?"
        self.stack.append([name, time.perf_counter(), 0.0])

    def on_end(self, ev):
        name, t0, child = self.stack.pop()
        dt = time.perf_counter() - t0
        self.self_time[name] += dt - child
        self.total[name] += dt
        self.count[name] += 1
        if self.stack:
            self.stack[-1][2] += dt


def main(argv: list[str]) -> int:
    lis = _Listener()
    event.register("numba:compile", lis)
    t0 = time.perf_counter()
    from nld.cli import main as nld_main
    t_imp = time.perf_counter() - t0
    try:
        rc = nld_main(argv)
    except SystemExit as e:
        rc = e.code
    wall = time.perf_counter() - t0
    rows = sorted(lis.self_time.items(), key=lambda kv: -kv[1])
    print(f"\n# nld {' '.join(argv)}: wall {wall:.2f} s (import of nld.cli {t_imp:.2f} s), "
          f"numba compile (self times summed) {sum(lis.self_time.values()):.2f} s")
    print("| function | compiles | self (s) | incl. callees (s) |\n|---|---|---|---|")
    for name, s in rows:
        if s >= 0.05:
            print(f"| {name} | {lis.count[name]} | {s:.2f} | {lis.total[name]:.2f} |")
    return int(rc or 0)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
