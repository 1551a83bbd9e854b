"""Test-run order: the longest files first.

The suite runs on 2 workers with ``--dist loadfile --no-loadscope-reorder`` (pyproject.toml), which
hands out whole files, one or two at a time to whichever worker is free, in
collection order. xdist's default order (by number of tests) left long files with few tests
(tangent dynamics, the zhang2013 main job) to the end of a cold run, where one worker ran them alone. Starting with them lets the short
files fill the other worker's time. Only the order changes; every test still runs.
"""
from __future__ import annotations

# cold-run wall time per file, longest first (measured on 2 cores with an empty kernel cache)
LONGEST_FIRST = [
    "test_study_zhang2013.py",
    "test_tangent.py",
    "test_chaos_map.py",
    "test_tangent_flows.py",
    "test_integrators.py",
    "test_study_rhee1996.py",
    "test_hybrid.py",
    "test_events.py",
    "test_study_chaos_onset.py",
    "test_hard_cases.py",
    "test_lyapunov.py",
    "test_contact_laws.py",
]


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(LONGEST_FIRST)}
    first = len(LONGEST_FIRST)
    # a stable sort: within a file, and among the files not listed, the order is unchanged
    items.sort(key=lambda item: rank.get(item.path.name, first))
