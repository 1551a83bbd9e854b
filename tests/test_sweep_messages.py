"""Sweep messages that name the right cause (issue 37, class 6): a point file that cannot be
written is named (not "standard output"), ``--resume`` into another command's folder says so,
and a failed point prints its reason."""
from __future__ import annotations

import errno
import json

import pandas as pd
import pytest

from nld.cli import main
from nld.errors import InputError, OutputError
from nld.sweeps import store as store_mod
from nld.sweeps.store import ResultStore, producer


def _full_disk(monkeypatch):
    """Every point file write fails as on a full disk (provenance.json still goes through)."""
    real = store_mod.write_atomic

    def write_atomic(path, write):
        if "point-" in str(path):
            raise OSError(errno.ENOSPC, "Error writing bytes to file. Detail: [errno 28] No space left on device")
        return real(path, write)
    monkeypatch.setattr(store_mod, "write_atomic", write_atomic)


def test_point_file_on_a_full_disk_is_named(tmp_path, monkeypatch):
    _full_disk(monkeypatch)
    st = ResultStore(tmp_path / "s")
    st.prepare({"kind": "bifurcation"}, ("kind",), resume=False)
    with pytest.raises(OutputError) as ei:
        st.write({"direction": "up", "index": 3, "table": pd.DataFrame({"x": [1.0]})})
    msg = str(ei.value)
    assert str(tmp_path / "s" / "point-up-00003.parquet") in msg
    assert "No space left on device" in msg and "--resume" in msg and "\n" not in msg


def test_sweep_on_a_full_disk_names_the_point_file(tmp_path, monkeypatch, capsys):
    _full_disk(monkeypatch)
    out = tmp_path / "sweep"
    rc = main(["bifurcation", "slider_crank", "--param", "driver.speed", "--values", "300",
               "--revs", "2", "--transient-revs", "0", "--workers", "1", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err.strip()
    assert rc == 1
    assert err.count("\n") == 0 and "standard output" not in err
    assert "point-up-00000.parquet" in err and "No space left on device" in err


@pytest.mark.parametrize("old, argv, words", [
    ({"kind": "bifurcation", "scene": "slider_crank", "param": "driver.speed", "values": [300.0]},
     ["attractors", "slider_crank", "--param", "driver.speed", "--values", "300"],
     ["holds the output of another command (nld bifurcation)", "not of nld attractors"]),
    ({"command": "nld attractors slider_crank --param driver.speed --values 300 --out x",
      "scene": "slider_crank", "param": "driver.speed", "values": [300.0], "starts": 32},
     ["bifurcation", "slider_crank", "--param", "driver.speed", "--values", "300"],
     ["another command (nld attractors", "not of nld bifurcation"]),
    ({"producer": "census sweep", "scene": "slider_crank"},
     ["chaos-map", "slider_crank", "--x", "joints.B.clearance", "--x-values", "1e-4", "--y",
      "driver.speed", "--y-values", "300"],
     ["another command (nld attractors", "not of nld chaos-map"]),
])
def test_resume_into_another_commands_folder(tmp_path, capsys, old, argv, words):
    d = tmp_path / "other"
    d.mkdir()
    (d / "provenance.json").write_text(json.dumps(old))
    assert main(argv + ["--out", str(d), "--resume", "--workers", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "differs" not in err
    for w in words:
        assert w in err, (w, err)


def test_same_command_other_settings_still_names_the_setting(tmp_path):
    st = ResultStore(tmp_path)
    st.prepare({"kind": "bifurcation", "revs": 10}, ("revs",), resume=False)
    with pytest.raises(InputError, match="revs differs"):
        st.check_settings({"kind": "bifurcation", "revs": 20}, ("revs",))


def test_producer():
    assert producer({"kind": "chaos_map"}) == "chaos_map"
    assert producer({"command": "nld attractors slider_crank"}) == "census sweep"
    assert producer({}, "census sweep") == "census sweep"
    assert producer({}, "sweep") is None and producer({"command": "nld simulate x"}) is None


def test_failed_census_value_prints_its_reason(tmp_path, capsys):
    """Clearance 0 leaves no free coordinates: the value fails at once and its line says why."""
    rc = main(["attractors", "slider_crank", "--param", "joints.B.clearance", "--values", "0",
               "--out", str(tmp_path / "c"), "--workers", "1", "--quiet"])
    out = capsys.readouterr().out
    assert rc == 0
    line = next(ln for ln in out.splitlines() if ln.startswith("joints.B.clearance = 0"))
    assert "failed: " in line and "no free coordinates" in line


def test_out_of_memory_names_the_command_not_a_guess(monkeypatch, capsys):
    """A MemoryError the command did not foresee: one line naming the command line as given,
    not a guess at its cause (it used to blame revolutions or samples, also for a tiny delay)."""
    import nld.cli.simulate as sim_cli

    def boom(args):
        raise MemoryError
    monkeypatch.setattr(sim_cli, "cmd_simulate", boom)
    assert main(["simulate", "slider_crank", "--revs", "3"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "nld simulate slider_crank --revs 3" in err
    assert "revolutions or samples" not in err


def test_a_writer_killed_mid_write_leaves_a_temporary_file_that_is_removed(tmp_path):
    """A pool worker ended (SIGTERM/SIGKILL by end_pool) while it writes a point leaves its
    temporary file; remove_temporary removes that process's files and no other's."""
    import signal
    import subprocess
    import sys

    from nld.output.io import remove_temporary
    code = ("import sys, time; from nld.output.io import write_atomic\n"
            "def w(tmp):\n    tmp.write_bytes(b'x'); print('writing', flush=True); time.sleep(60)\n"
            "write_atomic(sys.argv[1], w)\n")
    p = subprocess.Popen([sys.executable, "-c", code, str(tmp_path / "point-up-00001.parquet")],
                         stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "writing"
    p.send_signal(signal.SIGKILL)
    p.wait(timeout=10)
    other = tmp_path / f".point-up-00002.parquet.{p.pid + 1}.tmp"
    other.write_bytes(b"y")
    left = sorted(x.name for x in tmp_path.glob(".*.tmp"))
    assert left == sorted([f".point-up-00001.parquet.{p.pid}.tmp", other.name])
    assert remove_temporary(tmp_path, [p.pid]) == 1
    assert [x.name for x in tmp_path.glob(".*.tmp")] == [other.name]
    assert not (tmp_path / "point-up-00001.parquet").exists()
