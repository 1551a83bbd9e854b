"""Command line (nld.cli) and result tables on disk (nld.output.io).

Commands run in-process through ``main(argv)`` (capsys); one test runs ``python -m nld`` in a
subprocess for the real exit status. Simulations are 0.2 crank revolutions of slider_crank.
"""
from __future__ import annotations

import dataclasses
import json
import os
import shlex
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import nld
from nld.cli import main
from nld.errors import InputError, SolveError
from nld.output.io import load_table, save_table, sidecar_path

ROOT = Path(__file__).resolve().parent.parent


def run(capsys, *argv):
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def assert_one_line_error(err: str, *needles: str):
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("nld: error: "), err
    assert "Traceback" not in err
    for n in needles:
        assert n in lines[0], (n, err)


# --------------------------------------------------------------------------- scenes, show, version


def test_scenes_lists_slider_crank(capsys):
    rc, out, _ = run(capsys, "scenes")
    assert rc == 0
    line = next(ln for ln in out.splitlines() if ln.split()[0] == "slider_crank")
    assert "Flores" in line           # the description follows the name


def test_show_prints_resolved_parameters_with_units(capsys):
    rc, out, _ = run(capsys, "show", "slider_crank")
    assert rc == 0
    assert "joints.B.clearance = 0.0005 m" in out.splitlines()
    rc, out, _ = run(capsys, "show", "slider_crank", "--set", "joints.B.clearance=2e-4",
                     "--set", "driver.speed=300")
    assert rc == 0
    assert "joints.B.clearance = 0.0002 m" in out.splitlines()
    assert "driver.speed = 300.0 rad/s" in out.splitlines()


def test_version(capsys):
    rc, out, _ = run(capsys, "--version")
    assert rc == 0
    assert out.strip() == f"nld {nld.__version__}"


# --------------------------------------------------------------------------- simulate


def test_simulate_parquet_provenance_round_trip(tmp_path, capsys):
    out = tmp_path / "x.parquet"
    rc, stdout, err = run(capsys, "simulate", "slider_crank", "--revs", "0.2", "--out", str(out))
    assert rc == 0, err
    assert "73 rows" in stdout
    df, prov = load_table(out)
    assert {"t", "B.Fn", "slider.x", "driver.torque"} <= set(df.columns)
    assert len(df) == 73 and df["t"].iloc[0] == 0.0          # 360 samples per rev -> 72 + 1
    assert np.all(np.diff(df["t"].to_numpy()) > 0)
    assert prov["kind"] == "simulate" and prov["status"] >= 0
    assert prov["rtol"] == 1e-5          # the scene's recommended rtol ([scene] rtol in slider_crank.toml)
    assert prov["nld_version"] == nld.__version__ and prov["git_hash"]
    assert prov["command"] == shlex.join(["nld", "simulate", "slider_crank", "--revs", "0.2", "--out", str(out)])
    assert prov["scene_parameters"]["joints"]["B"]["clearance"] == 5e-4
    # the schema metadata and the human-readable sidecar carry the same provenance
    import pyarrow.parquet as pq
    meta = pq.read_schema(out).metadata
    assert json.loads(meta[b"nld"]) == prov
    assert json.loads(sidecar_path(out).read_text()) == prov


def test_simulate_override_stored_in_provenance_csv(tmp_path, capsys):
    out = tmp_path / "sub" / "y.csv"
    rc, _, err = run(capsys, "simulate", "slider_crank", "--set", "joints.B.clearance=2e-4",
                     "--revs", "0.2", "--rtol", "1e-7", "--samples-per-rev", "100", "--out", str(out))
    assert rc == 0, err
    df, prov = load_table(out)
    assert prov["scene_parameters"]["joints"]["B"]["clearance"] == 2e-4
    assert "--set joints.B.clearance=2e-4" in prov["command"]
    assert prov["rtol"] == 1e-7
    assert len(df) == 21 and "B.Fn" in df.columns


def test_simulate_summary(capsys):
    rc, out, _ = run(capsys, "simulate", "slider_crank", "--revs", "0.2")
    assert rc == 0
    assert "reached t_end" in out
    assert "rows: 73" in out
    assert "max |B.Fn|" in out and "max |driver.torque|" in out and "wall time" in out
    assert "first" in out and "last" in out


def test_simulate_ideal_matches_closed_form(tmp_path, capsys):
    sim, ide = tmp_path / "sim.parquet", tmp_path / "ideal.parquet"
    assert run(capsys, "simulate", "slider_crank", "--revs", "0.2", "--out", str(sim))[0] == 0
    rc, _, err = run(capsys, "simulate", "slider_crank", "--revs", "0.2", "--ideal", "--out", str(ide))
    assert rc == 0, err
    d_sim, _ = load_table(sim)
    d_id, prov = load_table(ide)
    assert prov["kind"] == "ideal"
    np.testing.assert_array_equal(d_id["t"].to_numpy(), d_sim["t"].to_numpy())
    # slider position of the ideal slider-crank: r cos(th) + sqrt(l^2 - r^2 sin^2(th))
    r, l, w = 0.05, 0.12, 523.5987755982989
    th = w * d_id["t"].to_numpy()
    x = r * np.cos(th) + np.sqrt(l ** 2 - (r * np.sin(th)) ** 2)
    np.testing.assert_allclose(d_id["slider.x"].to_numpy(), x, rtol=0, atol=1e-12)


def test_simulate_failed_integration_exits_1_and_keeps_the_good_file(tmp_path, capsys, monkeypatch):
    """A failed run never replaces an existing table: its partial table goes beside the target
    (f.partial.csv, marked partial) and the message says where (issue 27: the good run.csv of an
    earlier run used to be overwritten by the failed run's rows)."""
    import importlib
    sim_mod = importlib.import_module("nld.run.simulate")   # the module (nld.simulate is the function)
    real = sim_mod.simulate
    out = tmp_path / "f.csv"
    rc, _, err = run(capsys, "simulate", "slider_crank", "--revs", "0.2", "--out", str(out))
    assert rc == 0, err
    good = out.read_bytes()
    good_side = (tmp_path / "f.csv.json").read_bytes()

    def failing(*a, **k):
        res = real(*a, **k)
        return dataclasses.replace(res, status=-3, message="step size too small at t = 0.001 s",
                                   table=res.table.iloc[:10])
    monkeypatch.setattr(sim_mod, "simulate", failing)
    rc, _, err = run(capsys, "simulate", "slider_crank", "--revs", "0.2", "--out", str(out))
    assert rc == 1
    partial = tmp_path / "f.partial.csv"
    assert_one_line_error(err, "step size too small", str(partial), "partial")
    assert out.read_bytes() == good and (tmp_path / "f.csv.json").read_bytes() == good_side
    df, prov = load_table(partial)
    assert len(df) == 10 and prov["status"] == -3 and prov["partial"] is True
    assert load_table(out)[1].get("partial") is None


def test_simulate_max_steps_failure_keeps_the_good_file(tmp_path, capsys, monkeypatch):
    """The same with a real failed integration (max_steps exceeded, as a locking four-bar ends)."""
    import importlib
    sim_mod = importlib.import_module("nld.run.simulate")
    real = sim_mod.simulate
    out = tmp_path / "run.parquet"
    assert run(capsys, "simulate", "slider_crank", "--revs", "0.1", "--out", str(out))[0] == 0
    good = out.read_bytes()
    monkeypatch.setattr(sim_mod, "simulate", lambda *a, **k: real(*a, **dict(k, max_steps=40)))
    rc, _, err = run(capsys, "simulate", "slider_crank", "--revs", "0.1", "--out", str(out))
    assert rc == 1
    assert_one_line_error(err, "max_steps", "run.partial.parquet")
    assert out.read_bytes() == good
    df, prov = load_table(tmp_path / "run.partial.parquet")
    assert prov["partial"] is True and prov["status"] < 0 and 0 < len(df) < 73


def test_solve_error_exits_1(capsys, monkeypatch):
    import nld.model.ideal

    def boom(scene, times):
        raise SolveError("position analysis failed at t = 0.001 s: singular Jacobian")
    monkeypatch.setattr(nld.model.ideal, "ideal_solution", boom)
    rc, _, err = run(capsys, "simulate", "slider_crank", "--ideal")
    assert rc == 1
    assert_one_line_error(err, "singular Jacobian")


@pytest.mark.parametrize("argv, needles", [
    (["show", "no_such_scene"], ["no_such_scene"]),
    (["simulate", "no_such_scene"], ["no_such_scene"]),
    (["show", "slider_crank", "--set", "joints.B.clearnce=1e-4"], ["joints.B.clearnce"]),
    (["show", "slider_crank", "--set", "joints.B.clearance=-1e-3"], ["joints.B.clearance", "-0.001"]),
    (["simulate", "slider_crank", "--set", "joints.B.clearance=nan"], ["joints.B.clearance", "nan"]),
    (["show", "slider_crank", "--set", "joints.B.clearance"], ["joints.B.clearance"]),
    (["simulate", "slider_crank", "--revs", "nan"], ["--revs", "nan"]),
    (["simulate", "slider_crank", "--t-end", "-1"], ["--t-end", "-1"]),
    (["simulate", "slider_crank", "--rtol", "0"], ["--rtol", "0"]),
    (["simulate", "slider_crank", "--rtol", "abc"], ["--rtol", "abc"]),
    (["simulate", "slider_crank", "--samples-per-rev", "0"], ["--samples-per-rev"]),
    (["simulate", "slider_crank", "--revs", "1", "--t-end", "0.1"], ["--revs", "--t-end"]),
    (["simulate", "slider_crank", "--out", "x.txt"], ["x.txt", ".csv", ".parquet"]),
    (["frobnicate"], ["frobnicate"]),
    ([], ["COMMAND"]),
])
def test_bad_input_exits_2_with_one_line(capsys, argv, needles):
    rc, out, err = run(capsys, *argv)
    assert rc == 2
    assert_one_line_error(err, *needles)


def test_malformed_toml_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text('[scene]\nname = "x"\ngravity = [0.0, \n')
    rc, _, err = run(capsys, "show", str(bad))
    assert rc == 2
    assert_one_line_error(err, "bad.toml", "malformed TOML")


# --------------------------------------------------------------------------- io


def test_io_sidecar_failure_names_the_sidecar_and_replaces_nothing(tmp_path, monkeypatch):
    """A disk where the table fits but its provenance sidecar does not: the error names the
    sidecar (not the table), and neither file of an earlier save is replaced (issue 27: "cannot
    write run.csv" although run.csv was whole, and a new table beside the old sidecar)."""
    import errno

    import nld.output.io as io
    df = pd.DataFrame({"t": [0.0, 1.0]})
    p = save_table(df, tmp_path / "run.csv", {"run": 1})
    real = io._write_text

    def full(path, text):
        raise OSError(errno.ENOSPC, "No space left on device")
    monkeypatch.setattr(io, "_write_text", full)
    with pytest.raises(InputError) as ei:
        save_table(pd.DataFrame({"t": [5.0]}), p, {"run": 2})
    msg = str(ei.value)
    assert msg.startswith(f"cannot write {p}.json: No space left on device")
    assert "nothing replaced" in msg and "\n" not in msg
    monkeypatch.setattr(io, "_write_text", real)
    back, prov = load_table(p)
    assert list(back["t"]) == [0.0, 1.0] and prov == {"run": 1}
    assert sorted(x.name for x in tmp_path.iterdir()) == ["run.csv", "run.csv.json"]   # no temp files


def test_io_partial_goes_beside_the_target(tmp_path):
    """save_table(partial=True): run.parquet -> run.partial.parquet, marked partial; the target is
    not touched."""
    from nld.output.io import partial_path
    target = tmp_path / "run.parquet"
    target.write_bytes(b"old")
    p = save_table(pd.DataFrame({"t": [0.0]}), target, {"status": -1}, partial=True)
    assert p == partial_path(target) == tmp_path / "run.partial.parquet"
    assert target.read_bytes() == b"old"
    assert load_table(p)[1] == {"status": -1, "partial": True}
    assert partial_path("a/b.c.csv") == Path("a/b.c.partial.csv")


def test_io_csv_round_trip_and_bad_suffix(tmp_path):
    df = pd.DataFrame({"t": [0.0, 0.1 + 0.2], "B.Fn": [1e-300, np.pi]})
    prov = {"scene": "s", "rtol": 1e-8, "stats": {"steps": np.int64(3)}, "x": np.array([1.0, 2.0])}
    p = save_table(df, tmp_path / "a.csv", prov)
    back, prov2 = load_table(p)
    pd.testing.assert_frame_equal(back, df)              # floats round-trip exactly
    assert prov2 == {"scene": "s", "rtol": 1e-8, "stats": {"steps": 3}, "x": [1.0, 2.0]}
    for bad in ("a.txt", "a", "a.parquet.gz"):
        with pytest.raises(InputError, match=r"\.csv, \.parquet"):
            save_table(df, tmp_path / bad, prov)
    with pytest.raises(InputError, match="not found"):
        load_table(tmp_path / "missing.parquet")


# --------------------------------------------------------------------------- study


@pytest.fixture
def studies(tmp_path, monkeypatch):
    d = tmp_path / "studies"
    d.mkdir()
    (d / "zhang2013_excavator.py").write_text(textwrap.dedent("""
        from pathlib import Path

        def main(quick: bool, out_dir: Path) -> Path:
            pdf = Path(out_dir) / ("zhang_quick.pdf" if quick else "zhang.pdf")
            pdf.write_bytes(b"%PDF-1.4 dummy")
            return pdf
    """))
    (d / "flores_a.py").write_text("def main(quick, out_dir):\n    return out_dir / 'a.pdf'\n")
    (d / "flores_b.py").write_text("def main(quick, out_dir):\n    return out_dir / 'b.pdf'\n")
    (d / "_helpers.py").write_text("")
    monkeypatch.setenv("NLD_STUDIES_DIR", str(d))
    return d


def test_study_runs_dummy_by_alias(studies, tmp_path, capsys):
    out_dir = tmp_path / "out"
    rc, out, err = run(capsys, "study", "zhang2013", "--quick", "--out-dir", str(out_dir))
    assert rc == 0, err
    pdf = Path(out.strip())
    assert pdf == out_dir / "zhang_quick.pdf" and pdf.read_bytes().startswith(b"%PDF")
    rc, out, _ = run(capsys, "study", "zhang2013_excavator", "--out", str(out_dir))
    assert rc == 0 and Path(out.strip()).name == "zhang.pdf"


def test_study_writes_to_nld_out_by_default_and_quick_never_to_reports(studies, tmp_path, capsys,
                                                                      monkeypatch):
    """The default output is ./nld-out/ (ignored by git); the committed full-mode reports live in
    reports/ beside the studies directory, and a --quick run is refused there."""
    work = tmp_path / "cwd"
    work.mkdir()
    monkeypatch.chdir(work)
    rc, out, err = run(capsys, "study", "zhang2013", "--quick")
    assert rc == 0, err
    assert Path(out.strip()) == Path("nld-out") / "zhang_quick.pdf" and (work / "nld-out" / "zhang_quick.pdf").is_file()
    reports = studies.parent / "reports"
    reports.mkdir()
    (reports / "zhang.pdf").write_bytes(b"%PDF-1.4 committed")
    rc, _, err = run(capsys, "study", "zhang2013", "--quick", "--out", str(reports))
    assert rc == 2
    assert_one_line_error(err, "--out", "--quick", "committed full-mode reports")
    assert sorted(p.name for p in reports.iterdir()) == ["zhang.pdf"]
    rc, out, err = run(capsys, "study", "zhang2013", "--out", str(reports))      # full mode: allowed
    assert rc == 0 and Path(out.strip()) == reports / "zhang.pdf"


def test_quick_study_refused_where_full_mode_outputs_are_by_their_provenance(example_clone, capsys):
    """A --quick run is refused in any directory holding full-mode outputs of the same study,
    recognised by their provenance (a sidecar saying mode "full", or the PDF's keywords), not by
    where nld is installed: another clone's reports/ (issue 27: only the reports/ of the
    checkout nld ran from was protected). Other studies' full-mode files, and quick-mode ones,
    do not stop it."""
    studies, reports = example_clone
    before = {p.name: p.read_bytes() for p in reports.iterdir()}
    rc, _, err = run(capsys, "study", "zhang2013", "--quick", "--out", str(reports))
    assert rc == 2
    assert_one_line_error(err, "--quick", "zhang_full_summary.csv.json", "full mode")
    assert {p.name: p.read_bytes() for p in reports.iterdir()} == before
    (reports / "zhang_full_summary.csv.json").write_text('{"study": "zhang_full", "mode": "quick"}')
    rc, _, err = run(capsys, "study", "zhang2013", "--quick", "--out", str(reports))
    assert rc == 2
    assert_one_line_error(err, "--quick", "zhang_full.pdf", "full mode")
    (reports / "zhang_full.pdf").write_bytes(b"%PDF-1.4 /Keywords (nld; git 0; other; quick) /X")
    rc, out, err = run(capsys, "study", "zhang2013", "--quick", "--out", str(reports))
    assert rc == 0, err
    assert Path(out.strip()) == reports / "zhang_quick.pdf"


@pytest.fixture
def example_clone(tmp_path, monkeypatch):
    """A study (STEM zhang_full) in a studies/ directory of one checkout, and the reports/ of
    another clone holding its full-mode outputs (a sidecar and a PDF with the mode in their
    provenance), with nld installed from neither."""
    d = tmp_path / "clone_a" / "studies"
    d.mkdir(parents=True)
    (d / "zhang2013_excavator.py").write_text(
        "STEM = 'zhang_full'\n"
        "def main(quick, out_dir):\n"
        "    p = out_dir / ('zhang_quick.pdf' if quick else 'zhang_full.pdf')\n"
        "    p.write_bytes(b'%PDF-1.4')\n"
        "    return p\n")
    monkeypatch.setenv("NLD_STUDIES_DIR", str(d))
    reports = tmp_path / "clone_b" / "reports"
    reports.mkdir(parents=True)
    (reports / "zhang_full_summary.csv").write_text("a\n1\n")
    (reports / "zhang_full_summary.csv.json").write_text(
        '{"study": "zhang_full", "mode": "full", "nld_version": "0.1.0"}')
    (reports / "zhang_full.pdf").write_bytes(
        b"%PDF-1.4\n<< /Keywords (nld; git abc; nld 0.1.0; excavator; full) /Title (x) >>\n")
    return d, reports


def test_study_unknown_or_ambiguous_exits_2(studies, capsys):
    rc, _, err = run(capsys, "study", "nope")
    assert rc == 2
    assert_one_line_error(err, "nope", "flores_a", "zhang2013_excavator")
    assert "_helpers" not in err
    rc, _, err = run(capsys, "study", "flores")
    assert rc == 2
    assert_one_line_error(err, "ambiguous", "flores_a", "flores_b")


# --------------------------------------------------------------------------- the real entry point


def test_python_m_nld_exit_status():
    env = dict(os.environ, PYTHONPATH=str(ROOT) + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.run([sys.executable, "-m", "nld", "scenes"], cwd=ROOT, env=env, capture_output=True,
                       text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert any(ln.split()[0] == "slider_crank" for ln in p.stdout.splitlines() if ln.strip())
    p = subprocess.run([sys.executable, "-m", "nld", "show", "slider_crank", "--set",
                        "joints.B.clearance=-1e-3"], cwd=ROOT, env=env, capture_output=True, text=True,
                       timeout=120)
    assert p.returncode == 2
    assert p.stderr.strip() == "nld: error: joints.B.clearance = -0.001: must be >= 0 (m)"


def test_lyapunov_command_json(capsys):
    import json
    rc = main(["lyapunov", "slider_crank", "--transient", "2", "--revs", "10", "--json"])
    assert rc == 0
    out = json.loads(capsys.readouterr().out)
    assert out["scene"] == "slider_crank" and "git_hash" in out["provenance"]
    # per revolution = per second x crank period
    T = 2 * 3.141592653589793 / 523.5987755982989
    assert abs(out["exponent_per_revolution"] - out["exponent_per_s"] * T) < 1e-9 * abs(out["exponent_per_s"] * T)


def test_lyapunov_command_bad_input(capsys):
    rc = main(["lyapunov", "slider_crank", "--rtol", "-1"])
    assert rc == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--rtol" in err[0]


def test_package_level_simulate_is_the_function():
    """``nld.simulate(...)`` as in the README, also after ``import nld.run.simulate``."""
    import importlib
    import nld.run.simulate  # noqa: F401
    assert callable(nld.simulate) and nld.simulate is importlib.import_module("nld.run.simulate").simulate
    res = nld.simulate("slider_crank", revs=0.05)
    assert res.success and len(res.table) > 10
    assert nld.load_scene("four_bar").name == "four_bar"
