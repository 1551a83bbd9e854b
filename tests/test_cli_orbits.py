"""``nld orbits`` and ``nld continue`` (issue 24): JSON layout, tables with provenance, one-line
errors with exit status 2."""
import json

import pandas as pd
import pytest

from nld.cli import main


def test_orbits_json_gives_the_documented_fields(capsys):
    assert main(["orbits", "slider_crank_olyaei", "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out) == {"orbits", "settings", "provenance"}
    o = out["orbits"][0]
    for key in ("period", "points", "residual", "multipliers", "max_abs_multiplier", "stable",
                "onsets_per_period", "min_approach_speed"):
        assert key in o
    assert o["period"] == 1 and o["residual"] <= o["tolerance"]
    # permanent contact at the defaults: no onset, and the memory's multiplier 1
    assert o["onsets_per_period"] == 0 and o["min_approach_speed"] is None and o["continuum"]
    assert min(abs(complex(*m) - 1.0) for m in o["multipliers"]) < 1e-9
    assert out["provenance"]["git_hash"] and out["settings"]["rtol"] == 1e-10


def test_continue_writes_branch_and_bifurcation_tables(tmp_path, capsys):
    out = tmp_path / "cont"
    rc = main(["continue", "slider_crank_olyaei", "--param", "joints.B.friction.mu",
               "--values", "0.1:0.09:3", "--natural", "--out", str(out), "--plot",
               str(tmp_path / "b.png"), "--quiet"])
    assert rc == 0
    tab = pd.read_parquet(out / "branch.parquet")
    assert list(tab["value"]) == pytest.approx([0.1, 0.095, 0.09])
    assert (tab["converged"]).all() and set(tab["onsets_per_period"]) == {0}
    prov = json.loads((out / "branch.parquet.json").read_text())
    assert prov["param"] == "joints.B.friction.mu" and prov["values"] == pytest.approx([0.1, 0.095, 0.09])
    assert (out / "bifurcations.parquet").exists() and (tmp_path / "b.png").stat().st_size > 1000


@pytest.mark.parametrize("argv, words", [
    (["orbits", "slider_crank", "--period", "0"], "--period"),
    (["orbits", "slider_crank", "--period", "-2"], "--period"),
    (["orbits", "slider_crank", "--period", "1.5"], "--period"),
    (["orbits", "slider_crank", "--max-period", "0"], "--max-period"),
    (["continue", "slider_crank", "--param", "joints.B.nonsense", "--values", "1:2:3"],
     "no such scene key"),
    (["continue", "slider_crank_olyaei", "--param", "joints.B.friction.mu", "--values", "0.1:-0.1:3"],
     "outside the parameter's domain"),
    (["continue", "slider_crank_olyaei", "--param", "joints.B.friction.mu", "--values", "0.1:0.1:3"],
     "--values"),
    (["continue", "slider_crank_olyaei", "--param", "joints.B.friction.mu", "--values", "0.1:0.05:3",
      "--plot", "b.txt"], "--plot"),
])
def test_bad_orbit_input_is_one_line_exit_2(argv, words, capsys):
    assert main(argv + ["--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert words in err and len(err.splitlines()) == 1 and "Traceback" not in err


# SIGTERM under -m slow: the same handler as SIGINT (nld.interrupt), its 143 checked by the sweeps'
# SIGTERM test in the default run (tests/test_interrupt.py)
@pytest.mark.parametrize("signame, status", [("SIGINT", 130),
                                             pytest.param("SIGTERM", 143, marks=pytest.mark.slow)])
def test_continue_interrupted_keeps_the_finished_branch_points(tmp_path, signame, status):
    import re
    import signal

    from interrupt import signal_when
    out = tmp_path / "cont"
    argv = ["continue", "slider_crank_olyaei", "--param", "joints.B.friction.mu",
            "--values", "0.1:0.06:41", "--out", str(out), "--progress"]
    # the signal goes out once the bar shows 2 or more of the 41 points done (a bar refresh may
    # skip counts: any of 2..40 will do)
    rc, _, err, dt, _ = signal_when(argv, lambda e: re.search(r"\| ?([2-9]|[1-3][0-9]|40)/41", e)
                                    is not None, tmp_path, getattr(signal, signame))
    assert rc == status and "Traceback" not in err and dt < 10
    part = pd.read_parquet(out / "branch.partial.parquet")
    assert 2 <= len(part) < 41 and part["converged"].all()
    assert not (out / "branch.parquet").exists()
    assert f"{len(part)} branch points computed" in err
