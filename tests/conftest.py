"""Test-run order: the longest files first.

The suite runs on 2 workers with ``--dist loadfile --no-loadscope-reorder`` (pyproject.toml), which
hands out whole files, one or two at a time to whichever worker is free, in
collection order. xdist's default order (by number of tests) left long files with few tests
(tangent dynamics, the zhang2013 main job) to the end of a cold run, where one worker ran them alone. Starting with them lets the short
files fill the other worker's time. Only the order changes; every test still runs.
"""
from __future__ import annotations

# cold-run wall time per file, longest first (measured on 2 cores with an empty kernel cache)
LONGEST_FIRST = [          # seconds in a cold run at stop 20 (sum of setup + call, --durations=0)
    "test_integrators.py",       # 262
    "test_tangent.py",           # 220
    "test_hybrid.py",            # 201
    "test_study_zhang2013.py",   # 152
    "test_tangent_flows.py",     # 145 (less since: one tangent solver per set of user functions)
    "test_study_rhee1996.py",    # 136
    "test_simulator.py",         # 79
    "test_lyapunov.py",          # 63
    "test_scenes_family.py",     # 47
    "test_poincare.py",          # 45
    "test_contact_laws.py",      # 41
    "test_dopri5.py",            # 35
    "test_bad_input.py",         # 24
]


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    first = len(LONGEST_FIRST)
    # a stable sort: within a file, and among the files not listed, the order is unchanged
    items.sort(key=lambda item: rank.get(item.path.name, first))
