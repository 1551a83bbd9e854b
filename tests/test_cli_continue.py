"""``nld continue`` (issue 40 item 6, issue 37 class 2): the start orbit at the first of --values
(the scene's own value need not be among them), pseudo-arclength by default, every option checked
before the first integration, "completed" only for a branch that covered what was asked."""
import json

import pandas as pd
import pytest

from nld.cli import main


@pytest.fixture
def no_integration(monkeypatch):
    import nld.analysis.continuation  # noqa: F401  (binds the real solver before the patch)
    import nld.analysis.orbits as orbits

    def refuse(*a, **k):
        raise AssertionError("an orbit was computed before the options were checked")
    monkeypatch.setattr(orbits, "periodic_orbit", refuse)


@pytest.mark.parametrize("extra, words", [
    (["--values", "0.1:0.05:3", "--out", "FILE"], "is a file; give a directory"),
    (["--values", "0.1:-0.1:3"], "-0.1 is outside the parameter's domain"),
    (["--values", "0.1:0.05:3", "--natural", "--arclength"], "not allowed with"),
])
def test_continue_checks_every_option_before_any_integration(extra, words, tmp_path, capsys,
                                                            no_integration):
    f = tmp_path / "taken"
    f.write_text("x")
    argv = ["continue", "slider_crank_olyaei", "--param", "joints.B.friction.mu", "--quiet"]
    rc = main(argv + [str(f) if a == "FILE" else a for a in extra])
    err = capsys.readouterr().err.strip()
    assert rc == 2 and words in err and len(err.splitlines()) == 1
    assert f.read_text() == "x"


def test_continue_starts_at_the_first_value_by_arclength(tmp_path, capsys):
    # the scene's friction coefficient is 0.1; the values asked for are 0.12 ... 0.11
    out = tmp_path / "cont"
    rc = main(["continue", "slider_crank_olyaei", "--param", "joints.B.friction.mu",
               "--values", "0.12:0.11:3", "--out", str(out), "--quiet"])
    text = capsys.readouterr().out
    assert rc == 0
    tab = pd.read_parquet(out / "branch.parquet")
    # in the order asked for, from the start at 0.12 to the range's end 0.11, landed on exactly
    assert tab["value"].iloc[0] == 0.12 and tab["value"].iloc[-1] == pytest.approx(0.11, abs=1e-15)
    assert tab["value"].is_monotonic_decreasing
    prov = json.loads((out / "branch.parquet.json").read_text())
    assert prov["method"] == "arclength" and prov["start_value"] == pytest.approx(0.12)
    assert prov["completed"] is True and [e["reason"] for e in prov["ends"]] == ["range_end"] * 2
    assert "completed" in text.splitlines()[0]
    # stability column: stable / unstable / neutral only, never stable within the uncertainty
    assert set(tab["stable"]) <= {"stable", "unstable", "neutral"}
    st = tab[tab["stable"] == "stable"]
    assert (st["max_abs_deciding"] + st["multiplier_uncertainty"] < 1).all()
