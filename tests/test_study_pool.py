"""nld.study.Background: a study's side job (the excavator's route to chaos) on a thread while the
main thread goes on (the sweep's pool)."""
import threading

import pytest

from nld.study import Background


def test_background_runs_beside_the_caller_and_returns_its_value():
    started, go = threading.Event(), threading.Event()

    def job(a, b=0):
        started.set()
        # waits for the caller: a job run before the caller goes on would time out here
        if not go.wait(timeout=20):
            raise TimeoutError("the caller did not go on while the job ran")
        return a + b

    bg = Background(job, 2, b=3)
    assert started.wait(timeout=20)
    go.set()
    assert bg.result() == 5


def test_background_reraises_the_jobs_error_in_the_caller():
    def job():
        raise ValueError("joints.A.clearance = -1: must be >= 0")

    bg = Background(job)
    with pytest.raises(ValueError, match="joints.A.clearance"):
        bg.result()


def test_background_thread_does_not_keep_an_interrupted_process_alive():
    bg = Background(lambda: 1)
    assert bg.thread.daemon
    assert bg.result() == 1
