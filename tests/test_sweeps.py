"""The sweep engine (nld.sweeps) on a cheap function, no simulation: the logistic map's orbit per
point. Resume after an interruption, the settings check, atomic point files, and the serial,
process-pool and Dask executors giving the same table."""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from nld.errors import InputError, Interrupted
from nld.sweeps import PROVENANCE, ResultStore, execute, read_point, run_points

VALUES = [2.8, 3.2, 3.5, 3.7, 3.83, 3.9]
SETTINGS = ("values", "n", "x0")


def logistic_point(payload: dict, direction: str, index: int, r: float) -> dict:
    """One point: the last ``payload["n"]`` iterates of the logistic map at r after 100."""
    if payload.get("interrupt_at") == index:
        raise KeyboardInterrupt
    x = payload["x0"]
    for _ in range(100):
        x = r * x * (1 - x)
    xs = []
    for _ in range(payload["n"]):
        x = r * x * (1 - x)
        xs.append(x)
    table = pd.DataFrame({"value": [r] * len(xs), "direction": [direction] * len(xs),
                          "index": np.full(len(xs), index, dtype=np.int64),
                          "k": np.arange(len(xs), dtype=np.int64), "x": xs})
    return dict(direction=direction, index=int(index), value=r, status="ok", message="",
                table=table)


def _payload(**kw):
    return dict(dict(n=5, x0=0.2), **kw)


def _items():
    return [("up", i, v) for i, v in enumerate(VALUES)]


def _table(results: dict) -> pd.DataFrame:
    frames = [results[("up", i)]["table"] for i in range(len(VALUES)) if ("up", i) in results]
    return pd.concat(frames, ignore_index=True)


def _prov(**kw):
    return dict(dict(kind="test", values=VALUES, n=5, x0=0.2), **kw)


@pytest.fixture(scope="module")
def reference():
    return _table(run_points(logistic_point, _payload(), _items(), workers=1, progress=False))


def test_serial_and_process_pool_give_the_same_table(reference, tmp_path):
    store = ResultStore(tmp_path / "pool")
    store.prepare(_prov(), SETTINGS, resume=False)
    seen = []
    res = run_points(logistic_point, _payload(), _items(), workers=2, batch_size=2, store=store,
                     progress=False, on_point=lambda k, n, rec: seen.append((k, n)))
    pd.testing.assert_frame_equal(_table(res), reference)
    assert sorted(seen) == [(k, 6) for k in range(1, 7)]
    # the workers wrote every point, and the files read back into the same table
    assert [p.name for p in store.files()] == [f"point-up-{i:05d}.parquet" for i in range(6)]
    pd.testing.assert_frame_equal(_table(store.finished()), reference)
    assert store.provenance()["values"] == VALUES
    # execute() alone yields the same records
    recs = list(execute(logistic_point, _payload(), _items(), workers=1))
    pd.testing.assert_frame_equal(_table({("up", r["index"]): r for r in recs}), reference)


def test_resume_after_an_interruption_continues_where_it_stopped(reference, tmp_path):
    store = ResultStore(tmp_path / "sweep")
    store.prepare(_prov(), SETTINGS, resume=False)
    with pytest.raises(Interrupted) as err:
        run_points(logistic_point, _payload(interrupt_at=3), _items(), workers=1, store=store,
                   progress=False)
    assert "3 of 6 points finished and kept" in err.value.kept and "--resume" in err.value.kept
    assert [p.name for p in store.files()] == [f"point-up-{i:05d}.parquet" for i in range(3)]
    stamps = {p.name: p.stat().st_mtime_ns for p in store.files()}
    # without resume the directory is refused, with resume only the rest runs
    with pytest.raises(InputError, match="already holds 3 finished points"):
        ResultStore(store.path).prepare(_prov(), SETTINGS, resume=False)
    store = ResultStore(store.path)
    store.prepare(_prov(), SETTINGS, resume=True)
    done = store.finished()
    todo = [it for it in _items() if (it[0], it[1]) not in done]
    assert [it[1] for it in todo] == [3, 4, 5]
    ran = []
    res = run_points(logistic_point, _payload(), todo, done=done, workers=1, store=store,
                     progress=False, on_point=lambda k, n, rec: ran.append((k, n, rec["index"])))
    assert ran == [(4, 6, 3), (5, 6, 4), (6, 6, 5)]
    pd.testing.assert_frame_equal(_table(res), reference)
    pd.testing.assert_frame_equal(_table(store.finished()), reference)
    assert all(p.stat().st_mtime_ns == stamps[p.name] for p in store.files()[:3])


def test_a_settings_mismatch_is_refused_naming_the_field(tmp_path):
    store = ResultStore(tmp_path / "sweep")
    store.prepare(_prov(), SETTINGS, resume=False)
    run_points(logistic_point, _payload(), _items()[:2], workers=1, store=store, progress=False)
    with pytest.raises(InputError) as err:
        ResultStore(store.path).prepare(_prov(n=6), SETTINGS, resume=True)
    msg = str(err.value)
    assert "\n" not in msg and "(n differs)" in msg and "different sweep" in msg
    # a setting the check does not name may change; numpy values compare as plain numbers
    ResultStore(store.path).prepare(_prov(kind="other", x0=np.float64(0.2)), SETTINGS, resume=True)
    # an older provenance without a setting: the default it stands for
    p = json.loads((store.path / PROVENANCE).read_text())
    del p["x0"]
    (store.path / PROVENANCE).write_text(json.dumps(p))
    store.check_settings(_prov(), ["x0"], what="run", defaults={"x0": 0.2})
    with pytest.raises(InputError, match=r"holds a different run \(x0 differs\)"):
        store.check_settings(_prov(), ["x0"], what="run", defaults={"x0": 0.1})
    with pytest.raises(InputError, match="sweep directory not found"):
        ResultStore.existing(tmp_path / "nothing")


def test_a_point_file_is_whole_or_absent(tmp_path, monkeypatch):
    """A crash while a point is written leaves neither the point file nor a temporary one."""
    import pyarrow.parquet as pq
    store = ResultStore(tmp_path / "sweep")
    store.prepare(_prov(), SETTINGS, resume=False)
    rec = logistic_point(_payload(), "up", 0, 3.5)

    def crash(table, where, **kw):
        with open(where, "wb") as f:
            f.write(b"PAR1 half a file")
        raise OSError("disk full")

    monkeypatch.setattr(pq, "write_table", crash)
    with pytest.raises(OSError, match="disk full"):
        store.write(rec)
    assert sorted(p.name for p in store.path.iterdir()) == [PROVENANCE]
    monkeypatch.undo()
    path = store.write(rec)
    back = read_point(path)
    pd.testing.assert_frame_equal(back.pop("table"), rec["table"])
    assert back == {k: v for k, v in rec.items() if k != "table"}
    assert sorted(p.name for p in store.path.iterdir()) == ["point-up-00000.parquet", PROVENANCE]


def test_bad_workers_and_batch_size():
    with pytest.raises(InputError, match="workers = 0"):
        run_points(logistic_point, _payload(), _items(), workers=0, progress=False)
    with pytest.raises(InputError, match="batch_size = 0"):
        run_points(logistic_point, _payload(), _items(), workers=2, batch_size=0, progress=False)


def test_dask_gives_the_same_table(reference, tmp_path):
    distributed = pytest.importorskip("distributed")
    store = ResultStore(tmp_path / "dask")
    store.prepare(_prov(), SETTINGS, resume=False)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        res = run_points(logistic_point, _payload(), _items(), dask=client, batch_size=2,
                         store=store, progress=False)
    pd.testing.assert_frame_equal(_table(res), reference)
    # this process wrote the files
    pd.testing.assert_frame_equal(_table(store.finished()), reference)
