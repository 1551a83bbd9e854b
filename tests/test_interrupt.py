"""Ctrl-C and broken pipes (nld.interrupt, the chunked integration of nld.run.simulate).

Real subprocesses receive SIGINT in the middle of a compiled integration: they end within seconds
with exit status 130, one line saying what was kept, the partial result on disk and no core dump
(before: a segmentation fault, exit 139, 5 of 5 tries). The chunked integration that makes this
possible gives the same results as one integrator call to well below the integration error.
"""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import nld
from nld.output.io import load_table

ROOT = Path(__file__).resolve().parent.parent


def _env(**extra):
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    env.pop("NLD_PROGRESS", None)
    env.update(extra)
    return env


def interrupt_when(argv, ready, tmp_path, timeout=180.0, sig=signal.SIGINT):
    """Run ``python -m nld argv``, send ``sig`` (SIGINT) once ``ready(stderr_text)`` is true, and
    return (exit status, stdout, stderr, seconds from the signal to exit)."""
    from interrupt import signal_when
    rc, out, err, dt, _ = signal_when(argv, ready, tmp_path, sig, env=_env(), timeout=timeout)
    return rc, out, err, dt


def _last_line(err: str) -> str:
    lines = [ln for ln in err.replace("\r", "\n").splitlines() if ln.strip()]
    return lines[-1] if lines else ""


@pytest.mark.parametrize("sig, status, head", [(signal.SIGINT, 130, "nld: interrupted: "),
                                               (signal.SIGTERM, 143, "nld: terminated by SIGTERM: ")],
                         ids=["SIGINT", "SIGTERM"])
def test_signal_during_simulate_writes_the_partial_table_beside_the_target(tmp_path, sig, status, head):
    """SIGINT (Ctrl-C) or SIGTERM (kill, a scheduler) while the integrator runs (the progress bar,
    forced on, appears after 2 s of integration): exit 128 + signal within seconds, no core dump,
    one line, the partial table kept beside --out (run.partial.parquet, marked partial) and the
    file already at --out left alone (issue 27: SIGTERM used to end it silently, nothing kept)."""
    out = tmp_path / "run.parquet"
    out.write_bytes(b"a good table of an earlier run")
    argv = ["simulate", "slider_crank", "--revs", "200000", "--samples-per-rev", "2", "--progress",
            "--out", str(out)]
    rc, stdout, err, dt = interrupt_when(argv, lambda e: "rev [" in e or "rev/s" in e, tmp_path, sig=sig)
    assert rc == status, err
    assert dt < 10.0
    assert "Traceback" not in err and "Fatal Python error" not in err
    line = _last_line(err)
    partial = tmp_path / "run.partial.parquet"
    assert line.startswith(head + "simulate stopped at t = ") and "partial" in line, err
    assert str(partial) in line and f"{out} not replaced" in line
    assert out.read_bytes() == b"a good table of an earlier run"
    table, prov = load_table(partial)
    n_total = 200000 * 2 + 1
    assert 2 < len(table) < n_total
    assert prov["partial"] is True and prov["status"] == -9 and "interrupted" in prov["message"]
    # the rows kept are the run's first rows: times on the output grid, finite states
    T = 2 * np.pi / nld.load_scene("slider_crank").driver.speed
    np.testing.assert_allclose(table["t"].to_numpy(), np.arange(len(table)) * T / 2, rtol=1e-12, atol=1e-15)
    assert np.isfinite(table["B.ex"].to_numpy()).all()
    assert prov["t_reached"] == pytest.approx(table["t"].iloc[-1], rel=0, abs=T)


def test_ctrl_c_during_a_sweep_keeps_the_finished_points_and_resumes(tmp_path):
    """A sweep on 2 worker processes: SIGINT after two finished points ends the pool, exit 130,
    the finished point files are kept, and --resume runs only the rest.

    Once marked slow ("failed in a cold 2-core run: SIGINT lost or the sweep done first"): 12
    points of 440 revolutions, the signal sent once two point files existed whether or not both
    workers ran, a 180 s wait for them in a cold run (each worker compiles) and a 10 s bound on
    the reaction. Where nld itself could delay or drop the signal is closed now
    (nld.interrupt.spawning): the pool's threads start with SIGINT/SIGTERM blocked, so the
    kernel never hands the signal to one of them (the main thread, waiting for results in a lock,
    would then sleep until the next finished batch), and workers start with them blocked (a
    Ctrl-C while a worker imports cannot kill it with a traceback). The sweep here has short
    points, many of them (it cannot finish first), and the signal waits until both workers run,
    as the SIGTERM test does."""
    from interrupt import signal_when
    out = tmp_path / "sweep"
    total = 40
    argv = ["bifurcation", "slider_crank", "--param", "driver.speed", "--values", f"200:600:{total}",
            "--transient-revs", "0", "--revs", "20", "--workers", "2", "--quiet", "--out", str(out)]
    rc, stdout, err, dt, kids = signal_when(argv, lambda e: len(list(out.glob("point-*.parquet"))) >= 2,
                                            tmp_path, signal.SIGINT, env=_env(), timeout=300,
                                            workers=2)
    assert rc == 130, err
    assert dt < 10.0 and "Traceback" not in err
    kept = sorted(out.glob("point-*.parquet"))
    assert 2 <= len(kept) < total
    line = _last_line(err)
    assert line.startswith("nld: interrupted: ") and f"{len(kept)} of {total} points" in line
    assert "--resume" in line
    stamps = {p.name: p.stat().st_mtime_ns for p in kept}
    p = subprocess.run([sys.executable, "-m", "nld", *argv, "--resume"], cwd=tmp_path, env=_env(),
                       capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert len(list(out.glob("point-*.parquet"))) == total
    assert all(q.stat().st_mtime_ns == stamps[q.name] for q in kept)     # not run again


def test_broken_pipe_exits_quietly_with_141(tmp_path):
    """``nld show excavator | head -0``: the reader is gone before nld writes; nld ends quietly
    with 141 (128 + SIGPIPE, as a program killed by SIGPIPE), no traceback."""
    p = subprocess.Popen([sys.executable, "-m", "nld", "show", "excavator"], cwd=tmp_path, env=_env(),
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    p.stdout.close()              # the reader goes away at once
    err = p.stderr.read().decode()
    rc = p.wait(timeout=120)
    assert rc == 141, err
    assert err == ""


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
@pytest.mark.parametrize("argv", [["scenes"], ["show", "excavator"]], ids=["scenes", "show"])
def test_full_disk_on_stdout_is_one_line_and_exit_1(tmp_path, argv):
    """Standard output on a full disk (``nld scenes > /dev/full``): one line saying so and exit
    status 1, no traceback (issue 27: OSError [Errno 28] as a traceback)."""
    with open("/dev/full", "w") as full:
        p = subprocess.run([sys.executable, "-m", "nld", *argv], cwd=tmp_path, env=_env(),
                           stdout=full, stderr=subprocess.PIPE, text=True, timeout=120)
    assert p.returncode == 1, p.stderr
    assert p.stderr == "nld: error: cannot write to standard output: No space left on device\n"


# ----------------------------------------------------------------------------- chunked integration


def _eccentricity_error(a, b, col, c):
    return float(np.max(np.abs(a.table[col].to_numpy() - b.table[col].to_numpy()))) / c


def test_chunked_integration_agrees_with_one_call_to_the_tolerance():
    """slider_crank (chaotic: errors grow) over 2 revolutions at rtol 1e-8, in chunks of a quarter
    revolution against one integrator call: the two are equally good realisations of the
    tolerance. Measured over event_samples 0 ... 5 and chunks of 0.2, 0.25, 0.5 revolution: one
    call 4e-4 ... 5.3e-3 of the clearance from a run at rtol 1e-11, chunked 8e-5 ... 4.4e-3, the
    two 1.3e-4 ... 3.5e-3 apart (which of them is closer to the reference is chance: the ratio
    of their difference to the one-call error ranged 0.11 ... 5.4). Asserted: both within 1e-2
    of the clearance, chunked no worse than 5 x one call, and the same contact events, their
    times to 1e-6 s (1e-4 revolution; up to 1.1e-7 s apart by the second revolution)."""
    c = nld.load_scene("slider_crank").joints["B"].clearance
    kw = dict(revs=2, rtol=1e-8, samples_per_rev=720)
    one = nld.simulate("slider_crank", chunk_revs=None, **kw)
    chunked = nld.simulate("slider_crank", chunk_revs=0.25, **kw)
    ref = nld.simulate("slider_crank", revs=2, rtol=1e-11, samples_per_rev=720, chunk_revs=None)
    assert one.success and chunked.success
    err = _eccentricity_error(one, ref, "B.ex", c)
    diff = _eccentricity_error(chunked, one, "B.ex", c)
    err_chunked = _eccentricity_error(chunked, ref, "B.ex", c)
    assert 0 < diff < 1e-2 and err < 1e-2, (diff, err)       # of the clearance
    assert err_chunked < max(5 * err, 2e-3), (err_chunked, err)
    e1, e2 = one.events, chunked.events
    assert len(e1) == len(e2) > 10
    assert list(e1["direction"]) == list(e2["direction"]) and list(e1["joint"]) == list(e2["joint"])
    np.testing.assert_allclose(e2["t"].to_numpy(), e1["t"].to_numpy(), rtol=0, atol=1e-6)
    # the statistics add up over the chunks (about as many steps as one call)
    assert 0.9 * one.stats["accepted"] <= chunked.stats["accepted"] <= 1.1 * one.stats["accepted"]
    np.testing.assert_array_equal(chunked.table["t"], one.table["t"])


def test_chunked_stroboscopic_section_of_a_periodic_orbit_is_unchanged():
    """four_bar at 10 rad/s (a period-1 orbit; at its default speed it is chaotic): section points
    (landing on t = kT) of a run in chunks of one revolution equal those of one call to the
    integration error at rtol 1e-10: measured 1.9e-8 apart with the step's ends only
    (event_samples 0; one call 6.9e-7 of the clearance from rtol 1e-12), 2.4e-8 with the
    default interior samples (one call 1.9e-8 from rtol 1e-12, chunked 3.4e-8)."""
    sc = nld.load_scene("four_bar", ["driver.speed=10"])
    c = sc.joints["B"].clearance
    T = 2 * np.pi / abs(sc.driver.speed)
    t = np.arange(5, 10) * T
    a = nld.simulate(sc, t_eval=t, land=True, rtol=1e-10)
    b = nld.simulate(sc, t_eval=t, land=True, rtol=1e-10, chunk_revs=None)
    ref = nld.simulate(sc, t_eval=t, land=True, rtol=1e-12, chunk_revs=None)
    assert a.success and b.success and len(a.table) == 5

    def dist(x, y):
        return float(np.max(np.abs(x.table[["B.ex", "B.ey"]].to_numpy()
                                   - y.table[["B.ex", "B.ey"]].to_numpy()))) / c
    assert dist(a, b) < 1e-7 and dist(a, ref) < 3 * dist(b, ref) and dist(b, ref) < 1e-5


def test_interrupted_partial_result_api_shape():
    """The API's Interrupted is a KeyboardInterrupt carrying the partial result."""
    from nld.errors import Interrupted
    assert issubclass(Interrupted, KeyboardInterrupt)
    e = Interrupted("x", partial=1, kept="y")
    assert e.partial == 1 and e.kept == "y"
    import importlib
    sim_mod = importlib.import_module("nld.run.simulate")
    assert sim_mod.INTERRUPTED < 0 and sim_mod.INTERRUPTED not in (-1, -2, -3, -4, -5, -6)


def test_sigint_deferred_inside_compiled_calls_is_raised_after_them(tmp_path):
    """nld.interrupt.install (the command line's handler): SIGINT during a compiled call that
    returns a tuple of arrays (numba boxes it by calling back into Python) becomes a clean
    KeyboardInterrupt after the call, not a crash (a plain Python handler segfaults here).

    Once marked slow (failed in a cold 2-core run). 'go' was printed before the ``try``: on a
    loaded machine the signal could come before the loop and end the script with a traceback;
    it is printed inside the ``try`` now. The memo of numba's unpickler is emptied before every
    call so that every boxing runs Python code (the path the deferral protects)."""
    script = tmp_path / "m.py"
    script.write_text(
        "import sys, numpy as np\n"
        "from numba import njit\n"
        "import nld.interrupt as ni\n"
        "@njit\n"
        "def work(n):\n"
        "    s = 0.0\n"
        "    for i in range(n):\n"
        "        s += np.sin(i * 1e-9)\n"
        "    return 0, s, np.zeros(100), 3, np.ones(5, dtype=np.int64)\n"
        "work(10)\n"
        "import numba.core.serialize as ser\n"
        "ni.install()\n"
        "try:\n"
        "    print('go', flush=True)\n"
        "    while True:\n"
        "        ser._unpickled_memo.clear()\n"
        "        r = work(30_000_000)\n"
        "        assert r[2].shape == (100,)\n"
        "except KeyboardInterrupt:\n"
        "    print('clean', flush=True)\n"
        "    sys.exit(130)\n")
    proc = subprocess.Popen([sys.executable, str(script)], env=_env(), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline().strip() == "go"
        time.sleep(1.0)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 130, err
    assert out.strip() == "clean" and "Error" not in err


def test_progress_flags(tmp_path):
    """--progress draws a bar on stderr even when it is a file; --quiet and a non-terminal stderr
    draw none; the result is the same."""
    base = [sys.executable, "-m", "nld", "poincare", "slider_crank", "--transient-revs", "2",
            "--revs", "30"]
    shown = subprocess.run(base + ["--progress"], env=_env(), capture_output=True, text=True,
                           timeout=300, cwd=tmp_path)
    quiet = subprocess.run(base + ["--quiet"], env=_env(), capture_output=True, text=True,
                           timeout=300, cwd=tmp_path)
    auto = subprocess.run(base, env=_env(), capture_output=True, text=True, timeout=300,
                          cwd=tmp_path)
    assert shown.returncode == quiet.returncode == auto.returncode == 0
    assert "31.0/31.0 rev" in shown.stderr, shown.stderr
    assert quiet.stderr == "" and auto.stderr == ""
    assert shown.stdout == quiet.stdout == auto.stdout


def test_progress_enabled_rules(monkeypatch):
    from nld import progress
    from nld.errors import InputError
    monkeypatch.setattr(progress, "_DEFAULT", None)
    monkeypatch.setenv("NLD_PROGRESS", "1")
    assert progress.progress_enabled(None) and not progress.progress_enabled(False)
    monkeypatch.setenv("NLD_PROGRESS", "0")
    assert not progress.progress_enabled(None) and progress.progress_enabled(True)
    assert isinstance(progress.progress_bar(10, enabled=False), progress.NullBar)
    with pytest.raises(InputError, match="progress"):
        progress.progress_enabled("yes")
    # a bar inside another one (a sweep's points) stays quiet unless asked for
    with progress.progress_bar(3, unit="point", enabled=True) as outer:
        assert not isinstance(outer, progress.NullBar)
        assert isinstance(progress.progress_bar(5, enabled=None), progress.NullBar)


# ------------------------------------------------- SIGTERM and the process pools (issue 27)

needs_proc = pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")


def _pool_ended(kids, out=None):
    """No worker is left alive, and (with ``out``) no point file appears after the exit."""
    from interrupt import alive
    n = len(list(out.glob("point-*.parquet"))) if out is not None else 0
    deadline = time.monotonic() + 3.0
    while any(alive(k) for k in kids) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(alive(k) for k in kids), "worker processes left running"
    if out is not None:
        time.sleep(0.5)
        assert len(list(out.glob("point-*.parquet"))) == n, "point files written after the exit"
        assert not list(out.glob(".*.tmp")), "a temporary point file left behind"
    return n


@needs_proc
# the bifurcation sweep under -m slow: the same pool (nld.sweeps.executors.process_pool) as the map's
@pytest.mark.parametrize("command", [pytest.param("bifurcation", marks=pytest.mark.slow), "chaos-map"])
def test_sigterm_ends_the_pool_with_the_parent_and_keeps_the_finished_points(tmp_path, command):
    """SIGTERM to `nld bifurcation/chaos-map --workers 2` after the first finished point: exit 143
    within seconds, one line saying how many points were kept (the files on disk), no worker
    process left and no point file written after the exit (before: the workers went on at full
    CPU, writing point files, and the parent died silently)."""
    from interrupt import signal_when
    out = tmp_path / "out"
    if command == "bifurcation":
        argv = ["bifurcation", "slider_crank", "--param", "driver.speed", "--values", "200:600:40",
                "--transient-revs", "0", "--revs", "40"]
        total, what = 40, "points"
    else:
        argv = ["chaos-map", "slider_crank", "--x", "joints.B.clearance", "--x-values", "1e-4:5e-4:6",
                "--y", "joints.B.friction.mu", "--y-values", "0:0.2:6", "--transient-revs", "0",
                "--revs", "10"]
        total, what = 36, "cells"
    argv += ["--workers", "2", "--quiet", "--out", str(out)]
    rc, _, err, dt, kids = signal_when(argv, lambda e: any(out.glob("point-*.parquet")), tmp_path,
                                       signal.SIGTERM, workers=2)
    assert rc == 143, err
    assert dt < 10.0 and "Traceback" not in err
    n = _pool_ended(kids, out)
    assert 1 <= n < total
    line = _last_line(err)
    assert line.startswith("nld: terminated by SIGTERM: ")
    assert f"{n} of {total} {what} finished and kept in {out}" in line and "--resume" in line


STUDY = '''
"""A study whose runs sleep on a pool of two processes (issue 27's signal tests)."""
import os
import time
from pathlib import Path

import pandas as pd

STEM = "sleepy"
TITLE = "sleepy"
FULL = {"n": 4}
QUICK = {"n": 4}


def nap(i):
    Path(f"nap-{os.getpid()}").touch()      # in the working directory: the worker is running
    time.sleep(6.0)
    return i


def main(quick=False, out_dir=Path("reports")):
    from nld.study import Study
    study = Study(globals(), quick, out_dir)
    study.provenance(scene="none")
    study.save("_first.csv", pd.DataFrame({"x": [1.0, 2.0]}))
    print("pool", flush=True)
    study.map(nap, [(i,) for i in range(study.settings["n"])], 2)
    return study.pdf
'''


@pytest.fixture
def sleepy(tmp_path):
    d = tmp_path / "studies"
    d.mkdir()
    (d / "sleepy.py").write_text(STUDY)
    out = tmp_path / "out"
    out.mkdir()
    (out / "sleepy_first.csv").write_text("x\n5.0\n")          # an earlier run's output
    return dict(os.environ, NLD_STUDIES_DIR=str(d)), out


def _napping(cwd):
    """The pids of the study's workers that are running an item (their marker files)."""
    return [int(p.name.split("-")[1]) for p in cwd.glob("nap-*")]


@needs_proc
def test_sigterm_ends_a_study_pool_and_keeps_its_outputs_beside(tmp_path, sleepy):
    """SIGTERM to `nld study` while its pool runs: exit 143 within seconds, one line, the pool's
    processes end with the parent (their items would run 6 s more); the output the study had
    written is kept in out/sleepy.partial/ and the one of an earlier run in out/ is unchanged."""
    from interrupt import signal_when
    env, out = sleepy
    rc, stdout, err, dt, _ = signal_when(["study", "sleepy", "--out", str(out), "--quiet"],
                                         lambda e: len(_napping(tmp_path)) >= 2, tmp_path,
                                         signal.SIGTERM, env=env)
    assert rc == 143, err
    assert dt < 5.0 and "Traceback" not in err
    _pool_ended(_napping(tmp_path))
    line = _last_line(err)
    assert line.startswith("nld: terminated by SIGTERM: study sleepy stopped after ")
    assert str(out / "sleepy.partial") in line and "unchanged" in line
    assert (out / "sleepy_first.csv").read_text() == "x\n5.0\n"
    kept = out / "sleepy.partial"
    assert (kept / "sleepy_first.csv").read_text() == "x\n1.0\n2.0\n"
    assert json.loads((kept / "partial.json").read_text())["partial"] is True
    assert not list(out.glob(".staging-*"))


@needs_proc
def test_workers_die_with_a_killed_parent(tmp_path, sleepy):
    """SIGKILL (nothing of the parent runs): the kernel ends the pool's workers with it
    (PR_SET_PDEATHSIG, nld.interrupt.die_with_parent) instead of letting them finish their items."""
    from interrupt import signal_when
    env, out = sleepy
    rc, _, err, _, _ = signal_when(["study", "sleepy", "--out", str(out), "--quiet"],
                                   lambda e: len(_napping(tmp_path)) >= 2, tmp_path, signal.SIGKILL,
                                   env=env)
    assert rc == -signal.SIGKILL
    _pool_ended(_napping(tmp_path))
