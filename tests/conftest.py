"""Test-run order: the longest files first.

The suite runs on 2 workers with ``--dist loadfile --no-loadscope-reorder`` (pyproject.toml), which
hands out whole files, one or two at a time to whichever worker is free, in
collection order. xdist's default order (by number of tests) left long files with few tests
(tangent dynamics, the zhang2013 main job) to the end of a cold run, where one worker ran them alone. Starting with them lets the short
files fill the other worker's time. Only the order changes; every test still runs.
"""
from __future__ import annotations

import os
import sys

# One BLAS thread per process. The suite runs 2 worker processes on 2 cores; OpenBLAS starts a
# thread per core in each, and its threads wait for a core the other worker holds: the tests' many
# small linear-algebra calls (2x2 expm, solves, eigenvalues in Python loops) then ran 3-4x slower
# (the closed-form impact orbit of tests/impact_closed_form.py: 3.0 s with one thread, 10.8 s with
# the default, both cores busy). Set here, before numpy is imported in this process, and inherited
# by the xdist workers and by every subprocess a test starts; a value given outside is kept.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# cold-run time per file, longest first: the sum of setup + call (--durations=0) per file in a run
# of the whole suite on 2 cores with empty kernel and numba caches (d9c6b9b, before the one-BLAS-
# thread setting above; the machine partly busy: 662 s wall). A file not listed runs after these,
# in collection order.
LONGEST_FIRST = [
    "test_hybrid.py",            # 202
    "test_tangent.py",           # 99
    "test_interrupt.py",         # 99
    "test_study_rhee1996.py",    # 92
    "test_study_zhang2013.py",   # 67
    "test_report_layout.py",     # 62
    "test_compile_once.py",      # 48
    "test_orbits.py",            # 124 (52 of it the closed-form impact orbit under BLAS contention, 37 the Henon table)
    "test_simulator.py",         # 34
    "test_study_olyaei2012.py",  # 22
    "test_lyapunov.py",          # 21
    "test_poincare.py",          # 19
    "test_scenes_family.py",     # 19
    "test_cli_control.py",       # 18
    "test_cli_orbits.py",        # 18
    "test_study_flores2004.py",  # 17
    "test_chaos_map.py",         # 17
    "test_integrators.py",       # 16
    "test_study_chaos_onset.py", # 16
    "test_hard_cases.py",        # 16
    "test_continuation.py",      # 14
    # 46, most of it compiling the JIT build of the integrator cores (NLD_AOT=0), which
    # test_compile_once compiles too: late, so that it finds them in numba's disk cache instead of
    # compiling them at the same time on the other worker
    "test_ownership.py",
]


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    first = len(LONGEST_FIRST)
    # a stable sort: within a file, and among the files not listed, the order is unchanged
    items.sort(key=lambda item: rank.get(item.path.name, first))

