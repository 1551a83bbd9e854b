"""``nld continue ... --follow KIND --param2 KEY2 --values2 A:B:N`` (issue 41 item 3): every
option checked before any integration (one line naming the option, the value and what is
allowed; exit 2); the curve written as parquet with provenance and drawn in the (KEY, KEY2)
plane (the writing path checked on a forced Duffing's doubling curve, the whole command on the
slider-crank under the slow mark)."""
import argparse
import json

import pytest

from nld.cli import main
from nld.output.io import load_table


@pytest.fixture
def no_integration(monkeypatch):
    import nld.analysis.continuation  # noqa: F401  (binds the real solver before the patch)
    import nld.analysis.orbits as orbits

    def refuse(*a, **k):
        raise AssertionError("an orbit was computed before the options were checked")
    monkeypatch.setattr(orbits, "periodic_orbit", refuse)


MU, CLEAR = "joints.B.friction.mu", "joints.B.clearance"


@pytest.mark.parametrize("extra, words", [
    (["--follow", "fold"], "--follow = 'fold': needs --param2 and --values2"),
    (["--param2", CLEAR], f"--param2 = '{CLEAR}': needs --follow and --values2"),
    (["--follow", "flip", "--param2", CLEAR, "--values2", "1e-4:6e-4:3"],
     "--follow = 'flip': must be one of period-doubling, fold, neimark-sacker, grazing"),
    (["--follow", "fold", "--param2", CLEAR, "--values2", "-1e-4:6e-4:3"],
     "--values2: joints.B.clearance = -0.0001 is outside the parameter's domain"),
    (["--follow", "fold", "--param2", CLEAR, "--values2", "1e-4:2e-4:3"],
     "--values2 = 0.0001:0.0002: must contain the scene's value of joints.B.clearance, 0.0005"),
    (["--follow", "fold", "--param2", MU, "--values2", "0.1:0.2:3"],
     f"--param2 = '{MU}': must differ from --param"),
    (["--follow", "grazing", "--param2", "joints.X.y", "--values2", "0.1:0.2:3"],
     "--param2 = 'joints.X.y': no such scene key"),
    (["--follow", "fold", "--param2", CLEAR, "--values2", "1e-4:6e-4:3", "--max-points2", "1"],
     "--max-points2 = 1: must be >= 2"),
])
def test_follow_options_are_checked_before_any_integration(extra, words, tmp_path, capsys,
                                                           no_integration):
    out = tmp_path / "out"
    rc = main(["continue", "slider_crank_olyaei", "--param", MU, "--values", "0.1:0.12:3",
               "--out", str(out), "--quiet"] + extra)
    err = capsys.readouterr().err.strip()
    assert rc == 2 and words in err and len(err.splitlines()) == 1
    assert not list(out.glob("*.parquet"))


def test_follow_writes_the_curve_with_provenance_and_draws_it(tmp_path, capsys):
    # the writing path of --follow on a forced double-well Duffing's first period doubling
    # (tests/test_codim2.py checks the curve itself against one-parameter continuation)
    from nld.analysis.continuation import continue_orbit
    from nld.analysis.orbits import periodic_orbit
    from nld.cli.codim2 import follow
    from nld.systems import duffing
    S = duffing(gamma=0.23, omega=1.2)
    o = periodic_orbit(S, 1, transient=50, rtol=1e-10)
    br = continue_orbit(S, o, "gamma", range=(0.23, 0.30), step=0.005, criticality=False)
    args = argparse.Namespace(follow="period-doubling", param="gamma", param2="omega",
                              values2=[1.18, 1.2, 1.22], max_points2=50)
    rc = follow(args, S, br, tmp_path, tmp_path / "curve.png", {"command": "test"})
    text = capsys.readouterr().out
    assert rc == 0 and "period_doubling curve from gamma" in text and "completed" in text
    tab, prov = load_table(tmp_path / "curve.parquet")
    assert prov["follow"] == "period_doubling" and prov["curve_completed"] is True
    assert prov["values2"] == [1.18, 1.2, 1.22] and prov["command"] == "test"
    assert [e["reason"] for e in prov["curve_ends"]] == ["range_end", "range_end"]
    # landed exactly on the values asked for, the start on the doubling that was followed
    landed = tab[tab["landed"]]
    assert sorted(landed["value2"]) == [1.18, 1.2, 1.22]
    pd0 = [b for b in br.bifurcations if b.kind == "period_doubling"][0]
    start = tab[tab["value2"] == 1.2].iloc[0]
    assert abs(start["value1"] - pd0.value) <= pd0.tolerance + start["tolerance1"]
    assert (tab["distance"] < 1e-6).all()
    sp, _ = load_table(tmp_path / "curve_special_points.parquet")
    assert list(sp.columns[:5]) == ["kind", "value1", "uncertainty1", "value2", "uncertainty2"]
    assert (tmp_path / "curve.png").stat().st_size > 1000
    json.dumps(prov)


def test_follow_without_that_kind_on_the_branch_is_exit_1(tmp_path, capsys):
    from nld.analysis.continuation import continue_orbit
    from nld.analysis.orbits import periodic_orbit
    from nld.cli.codim2 import follow
    from nld.errors import SolveError
    from nld.systems import duffing
    S = duffing(gamma=0.23, omega=1.2)
    o = periodic_orbit(S, 1, transient=50, rtol=1e-10)
    br = continue_orbit(S, o, "gamma", [0.23, 0.235], criticality=False)
    args = argparse.Namespace(follow="fold", param="gamma", param2="omega",
                              values2=[1.18, 1.22], max_points2=50)
    with pytest.raises(SolveError, match="--follow fold: no located fold on the branch"):
        follow(args, S, br, tmp_path, None, {})
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_continue_follow_on_the_slider_crank(tmp_path, capsys):
    # the permanent-contact period-1 orbit's doubling in the clearance near 0.28613 mm (mu = 0.1;
    # tests/test_codim2.py) followed in mu over 0.0995 ... 0.1005
    out = tmp_path / "c"
    rc = main(["continue", "slider_crank_olyaei", "--param", CLEAR, "--values",
               "0.28e-3,0.2835e-3,0.287e-3,0.29e-3", "--natural", "--transient", "100",
               "--rtol", "1e-10", "--follow", "period-doubling", "--param2", MU,
               "--values2", "0.0995:0.1005:3", "--out", str(out), "--plot",
               str(out / "curve.png"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    tab, prov = load_table(out / "curve.parquet")
    assert prov["curve_completed"] and prov["param2"] == MU
    assert sorted(tab.loc[tab["landed"], "value2"]) == [0.0995, 0.1, 0.1005]
    assert ((tab["value1"] > 0.285e-3) & (tab["value1"] < 0.2875e-3)).all()
    assert (out / "curve.png").is_file() and (out / "branch.parquet").is_file()
