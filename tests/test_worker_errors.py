"""Errors raised in pool workers reach the user as the same one line as in one process (issue 37,
class 3): nld's error classes survive pickling, and the sweeps' pool (also the studies' pool_map
and the attractor census) hands a worker's error back as itself, never as BrokenProcessPool or
a TypeError from rebuilding it."""
from __future__ import annotations

import inspect
import pickle

import pytest

import nld.errors as errors
from nld.errors import (AssemblyError, InputError, InputTypeError, Interrupted, OutputError, SceneError,
                        SolveError)
from nld.model.ideal import NotClosed
from nld.sweeps.executors import execute

ERRORS = [
    SceneError("joints.B.clearance", -1e-3, "must be >= 0 (m)"),
    InputError("--gain = 'x': must be a number"),
    InputTypeError("revs = 'abc': must be a number"),
    SolveError("step size underflow at t = 0.1 s"),
    AssemblyError("scene 'four_bar' cannot be assembled", "B", 0.6),
    Interrupted("interrupted after 3 of 9 points", partial=[1, 2, 3], kept="3 of 9 points kept"),
    NotClosed("Newton-Raphson did not converge", "C", 0.7),
    OutputError("cannot write the point file x: No space left on device"),
]


def test_every_error_class_is_listed():
    classes = {c for _, c in inspect.getmembers(errors, inspect.isclass)
               if issubclass(c, BaseException) and c.__module__ == errors.__name__}
    assert classes <= {type(e) for e in ERRORS}


@pytest.mark.parametrize("e", ERRORS, ids=lambda e: type(e).__name__)
def test_errors_survive_pickling(e):
    back = pickle.loads(pickle.dumps(e))
    assert type(back) is type(e)
    assert str(back) == str(e) and back.args == e.args
    assert back.__dict__ == e.__dict__
    if isinstance(e, SceneError):
        assert (back.path, back.value, back.allowed) == ("joints.B.clearance", -1e-3, "must be >= 0 (m)")


def test_an_error_that_cannot_be_pickled_becomes_a_runtime_error_with_its_message():
    import threading
    from nld.sweeps.executors import portable
    bad = ValueError("x and y")
    bad.lock = threading.Lock()          # cannot be pickled
    e = portable(bad)
    assert isinstance(e, RuntimeError) and "ValueError" in str(e) and "x and y" in str(e)
    ok = SceneError("a", 1, "b")
    assert portable(ok) is ok


# ---- through a real pool (spawned processes import this module by name)

def point(payload, k):
    """A sweep point that fails with ``payload``'s error at k == 2."""
    if k == 2:
        raise payload
    return {"direction": "grid", "index": k}


def _raised(workers, err):
    with pytest.raises(BaseException) as ei:
        list(execute(point, err, [(k,) for k in range(4)], workers=workers, batch_size=1))
    return ei.value


def test_a_worker_error_is_the_one_of_a_single_process():
    err = ERRORS[0]
    one = _raised(1, err)
    pool = _raised(2, err)
    assert type(pool) is type(one) is type(err)
    assert str(pool) == str(one)
    assert pool.__dict__ == one.__dict__


def test_pool_map_hands_back_a_scene_error():
    from nld.study import pool_map
    with pytest.raises(SceneError) as ei:
        pool_map(_pool_item, [(1,), (2,), (3,)], workers=2)
    assert str(ei.value) == "joints.B.clearance = 2: must be >= 0 (m)"


def _pool_item(k):
    if k == 2:
        raise SceneError("joints.B.clearance", k, "must be >= 0 (m)")
    return k
