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

# cold-run wall time per file, longest first (measured on 2 cores with empty kernel and numba caches)
LONGEST_FIRST = [          # seconds in a cold run at stop 22 (sum of setup + call, --durations=0)
    "test_tangent.py",           # 50 (176 at stop 21, before the integrators were compiled once)
    "test_hybrid.py",            # 47 (261)
    "test_study_rhee1996.py",    # 47 (173)
    "test_study_zhang2013.py",   # 43 (140)
    "test_integrators.py",       # 25 (244)
    "test_simulator.py",         # 21 (78)
    "test_study_olyaei2012.py",  # 20 (31)
    "test_chaos_map.py",         # 20 (23)
    "test_control.py",           # 16 (new: 15.1 s CPU, 24 s wall at load 6.8; ~12 s of it compiling the delay integrator)
    "test_lyapunov.py",          # 13 (13)
    "test_scenes_family.py",     # 10 (60)
    "test_compile_once.py",      # 10 (new)
    "test_study_chaos_onset.py", # 10 (12)
    "test_study_zhang2013_sensitivity.py",  # 6 (new: 8.0 s wall, 4.7 s CPU at load 4.4; no integration)
]


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    first = len(LONGEST_FIRST)
    # a stable sort: within a file, and among the files not listed, the order is unchanged
    items.sort(key=lambda item: rank.get(item.path.name, first))

