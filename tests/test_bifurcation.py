"""Bifurcation sweeps (nld.analysis.bifurcation): local pool vs Dask, resume after an interruption, failed
points, continuation up and down, provenance; the bifurcation diagram of nld.output.plots."""
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from nld.analysis.bifurcation import load_sweep, parse_values, sweep
from nld.errors import InputError
from nld.analysis.poincare import stroboscopic
from interrupt import run_and_kill

ROOT = Path(__file__).resolve().parent.parent
VALUES = [300.0, 350.0, 400.0, 450.0, 500.0, 550.0]       # driver.speed, rad/s
KW = dict(transient_revs=10, revs=8, observables=["B.ex", "B.ey", "rod.omega"])


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted sweep, run point by point in this process."""
    out = tmp_path_factory.mktemp("ref") / "sweep"
    df = sweep("slider_crank", "driver.speed", VALUES, workers=1, out=out, **KW)
    return df, out


def test_sweep_table_files_and_provenance(reference):
    df, out = reference
    assert list(df.columns) == ["value", "direction", "index", "rev", "B.ex", "B.ey", "rod.omega",
                                "period", "lyapunov", "lyapunov_uncertainty", "status", "message"]
    assert len(df) == len(VALUES) * KW["revs"]
    assert (df.status == "ok").all() and (df.direction == "up").all()
    assert list(df.drop_duplicates("index").value) == VALUES
    assert list(df.rev.iloc[:8]) == list(range(10, 18))
    assert df.lyapunov.isna().all()
    files = sorted(p.name for p in out.iterdir())
    assert files == [f"point-up-{i:05d}.parquet" for i in range(6)] + ["provenance.json"]
    prov = json.loads((out / "provenance.json").read_text())
    for key in ("nld_version", "git_hash", "scene", "scene_parameters", "param", "values", "rtol",
                "transient_revs", "revs", "observables"):
        assert key in prov, key
    assert prov["param"] == "driver.speed" and prov["values"] == VALUES and prov["rtol"] == 1e-8
    pd.testing.assert_frame_equal(df, load_sweep(out))
    # the points are the stroboscopic sections of each value
    sec = stroboscopic("slider_crank", overrides=["driver.speed=400"], **KW)
    got = df[df.value == 400.0][KW["observables"]].to_numpy()
    assert np.array_equal(got, sec.points)


def test_local_pool_and_dask_give_identical_tables(reference, tmp_path):
    """The same sweep on a real Dask cluster (2 worker processes) and on the local pool."""
    distributed = pytest.importorskip("distributed")
    ref, _ = reference
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        dk = sweep("slider_crank", "driver.speed", VALUES, dask=client, out=tmp_path / "dask",
                   batch_size=2, **KW)
    pd.testing.assert_frame_equal(dk, ref)
    pd.testing.assert_frame_equal(load_sweep(tmp_path / "dask"), ref)


def test_killed_sweep_resumed_equals_uninterrupted(reference, tmp_path):
    """A sweep killed after two points, resumed (on the local pool of 2 workers), gives the
    table of the uninterrupted sweep; a finished point is not run again."""
    ref, _ = reference
    out = tmp_path / "killed"
    code = ("from nld.analysis.bifurcation import sweep\n"
            f"sweep('slider_crank', 'driver.speed', {VALUES!r}, workers=1, out={str(out)!r}, "
            f"**{KW!r})\n")
    done = run_and_kill(code, out)
    assert 2 <= len(done) < len(VALUES), "the sweep was not interrupted"
    assert not list(out.glob(".*.tmp"))           # nothing half-written left behind
    stamps = {p.name: p.stat().st_mtime_ns for p in done}
    df = sweep("slider_crank", "driver.speed", VALUES, workers=2, out=out, resume=True, **KW)
    pd.testing.assert_frame_equal(df, ref)
    pd.testing.assert_frame_equal(load_sweep(out), ref)
    assert all(p.stat().st_mtime_ns == stamps[p.name] for p in done)


def test_failing_points_are_recorded_and_the_sweep_goes_on(tmp_path):
    """scene.gravity = -1e200 m/s^2 makes the state non-finite at once; a negative clearance
    is refused by the scene check: both points are 'failed' with their message, the others run."""
    df = sweep("slider_crank", "scene.gravity.1", [-9.81, -1e200, -5.0], transient_revs=2, revs=3,
               workers=1, out=tmp_path / "g")
    pts = df.drop_duplicates(["direction", "index"]).set_index("index")
    assert list(pts.status) == ["ok", "failed", "ok"]
    assert "non-finite" in pts.message[1]
    bad = df[df["index"] == 1]
    assert len(bad) == 1 and bad.rev.iloc[0] == -1 and bad["B.ex"].isna().all()
    assert (df[df["index"] != 1].groupby("index").size() == 3).all()
    df = sweep("slider_crank", "joints.B.clearance", [5e-4, -1.0], transient_revs=1, revs=2,
               workers=1, continuation=True)
    pts = df.drop_duplicates(["direction", "index"]).set_index("index")
    assert list(pts.status) == ["ok", "failed"]
    assert "SceneError" in pts.message[1] and "clearance" in pts.message[1]
    # an integration that runs out of steps fails the same way
    df = sweep("slider_crank", "driver.speed", [400.0], transient_revs=1, revs=2, workers=1,
               max_steps=100)
    assert df.status.iloc[0] == "failed" and "max_steps" in df.message.iloc[0]


def test_continuation_up_down_and_resume(tmp_path):
    """Continuation: each point starts from the previous point's final state; down starts where
    up ended. Resuming after losing the last points recomputes them identically."""
    vals = [400.0, 500.0, 600.0]
    kw = dict(transient_revs=3, revs=4, observables=["B.ex", "B.ey"])
    out = tmp_path / "cont"
    df = sweep("slider_crank", "driver.speed", vals, continuation=True, up_down=True, out=out, **kw)
    assert list(df.drop_duplicates(["direction", "index"])[["direction", "index"]]
                .itertuples(index=False, name=None)) == \
        [("up", 0), ("up", 1), ("up", 2), ("down", 2), ("down", 1), ("down", 0)]
    # the chain by hand
    y = z = None
    for direction, i in (("up", 0), ("up", 1), ("up", 2), ("down", 2)):
        sec = stroboscopic("slider_crank", overrides=[f"driver.speed={vals[i]}"], y0=y, z0=z, **kw)
        got = df[(df.direction == direction) & (df["index"] == i)][kw["observables"]].to_numpy()
        assert np.array_equal(got, sec.points), (direction, i)
        y, z = sec.y_final, sec.z_final
    for name in ("point-down-00001.parquet", "point-down-00000.parquet"):
        (out / name).unlink()
    again = sweep("slider_crank", "driver.speed", vals, continuation=True, up_down=True, out=out,
                  resume=True, **kw)
    pd.testing.assert_frame_equal(again, df)


def test_out_directory_guards(reference, tmp_path):
    _, out = reference
    with pytest.raises(InputError, match="already holds"):
        sweep("slider_crank", "driver.speed", VALUES, workers=1, out=out, **KW)
    with pytest.raises(InputError, match="different sweep"):
        sweep("slider_crank", "driver.speed", VALUES, workers=1, out=out, resume=True,
              **dict(KW, revs=9))
    with pytest.raises(InputError, match="not a value"):
        sweep("slider_crank", "driver.nope", VALUES)
    with pytest.raises(InputError, match="resume"):
        sweep("slider_crank", "driver.speed", VALUES, resume=True)
    assert parse_values("100:500:5") == [100.0, 200.0, 300.0, 400.0, 500.0]
    assert parse_values("1, 2.5,4") == [1.0, 2.5, 4.0]
    with pytest.raises(InputError, match="START:STOP:NUM"):
        parse_values("1:2")


def test_lyapunov_column(tmp_path):
    """lyapunov=True fills the exponent (1/s): the tangent estimator (default) from the end of the
    point's section, the same number as calling it directly; "benettin" on request; a bad
    estimator is refused."""
    from nld.analysis.lyapunov import lyapunov_benettin, lyapunov_tangent
    from nld.analysis.poincare import stroboscopic
    from nld.systems.core import SceneSystem
    kw = dict(transient_revs=2, revs=3, workers=1, lyapunov=True, lyapunov_revs=3, rtol=1e-8)
    df = sweep("slider_crank", "driver.speed", [523.6], **kw)
    assert df.status.iloc[0] == "ok" and (df.lyapunov == df.lyapunov.iloc[0]).all()
    sec = stroboscopic("slider_crank", transient_revs=2, revs=3, rtol=1e-8,
                       overrides=["driver.speed=523.6"])
    s = SceneSystem("slider_crank", ["driver.speed=523.6"])
    s.y0, s.z0 = sec.y_final.copy(), sec.z_final.copy()
    lam = lyapunov_tangent(s, transient=0.0, total=3 * s.period)
    assert df.lyapunov.iloc[0] == lam.exponent
    assert df.lyapunov_uncertainty.iloc[0] == lam.uncertainty
    db = sweep("slider_crank", "driver.speed", [523.6], lyapunov_estimator="benettin", **kw)
    assert db.lyapunov.iloc[0] == lyapunov_benettin(s, transient=0.0, total=3 * s.period).exponent
    with pytest.raises(InputError, match="lyapunov_estimator = 'qr'"):
        sweep("slider_crank", "driver.speed", [523.6], lyapunov_estimator="qr", **kw)


def test_bifurcation_diagram(reference):
    from nld.output.plots import bifurcation_diagram
    df, _ = reference
    fig = bifurcation_diagram(df, "B.ex", scale=1e3, unit="mm")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "driver.speed (rad/s)"
    assert ax.get_ylabel() == "B.ex (mm)"
    assert len(ax.collections) == 1 and len(ax.collections[0].get_offsets()) == len(df)
    both = pd.concat([df, df.assign(direction="down")], ignore_index=True)
    both.attrs = df.attrs
    fig = bifurcation_diagram(both, "B.ex")
    labels = [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    assert labels == ["sweep up", "sweep down"]


def test_cli_bifurcation(monkeypatch, capsys, tmp_path):
    from test_poincare import _patched_cli
    cli = _patched_cli(monkeypatch)
    out = tmp_path / "cli"
    rc = cli.main(["bifurcation", "slider_crank", "--param", "driver.speed", "--values", "400,500",
                   "--transient-revs", "1", "--revs", "2", "--workers", "1", "--out", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "[2/2] driver.speed = 500.0 (up): ok" in text and str(out) in text
    df = load_sweep(out)
    assert list(df.drop_duplicates("index").value) == [400.0, 500.0] and len(df) == 4
    assert cli.main(["bifurcation", "slider_crank", "--param", "driver.speed", "--values", "1:2",
                     "--out", str(out)]) == 2
    assert "START:STOP:NUM" in capsys.readouterr().err
