"""nld.sweeps.executors.Background / nld.study.background: a study's side job (the excavator's
route to chaos) on a process of its own while the study's pool runs its sweep."""
import os
import time

import pytest

from nld.study import background
from nld.sweeps.executors import Background


def pid_plus(a, b=0):
    return os.getpid(), a + b


def fails():
    raise ValueError("joints.A.clearance = -1: must be >= 0")


def sleeps(seconds):
    time.sleep(seconds)
    return os.getpid()


def test_background_runs_in_another_process_and_returns_its_value():
    with background(pid_plus, 2, 3) as job:
        pid, value = job.result()
    assert value == 5 and pid != os.getpid()


def test_background_disabled_runs_at_once_in_this_process():
    with background(pid_plus, 2, 3, enabled=False) as job:
        assert job.result() == (os.getpid(), 5)


def test_background_reraises_the_workers_error_in_the_caller():
    with pytest.raises(ValueError, match="joints.A.clearance"):
        with Background(fails) as job:
            job.result()


def test_leaving_the_block_by_an_error_ends_the_process_at_once():
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        with Background(sleeps, 60) as job:
            procs = list(job._ex._processes.values())
            time.sleep(1.0)            # the worker has started and sleeps
            raise KeyboardInterrupt
    assert time.monotonic() - t0 < 20
    assert procs and not any(p.is_alive() for p in procs)
