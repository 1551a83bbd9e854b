"""Rules for the numbers the reports state (issue 42): statistics from steady runs only, each run
counted once, tallies that add up to their total, uncertainties that include a check's spread,
messages cut at a word. On small tables made here (no integration)."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from study_harness import load_study


@pytest.fixture(scope="module")
def sens():
    return load_study("zhang2013_sensitivity.py")


@pytest.fixture(scope="module")
def oly():
    return load_study("olyaei2012.py")


F0 = "joints.A.friction.mu=0.0 joints.B.friction.mu=0.0"
F5 = "joints.A.friction.mu=0.05 joints.B.friction.mu=0.05"
F5_AMB = F5 + ' joints.A.friction.law="ambrosio" joints.B.friction.law="ambrosio"'


def _row(base, sweep, x, overrides, mean, *, series="", growing=False, reversed_=False, f=None,
         success=True, lo=None, hi=None):
    f = (0.0 if base == "f=0" else 0.05) if f is None else f
    return dict(base=base, sweep=sweep, series=series, x=x, overrides=overrides, reversed=reversed_, f=f,
                key=f"{base}|{sweep}|{series}|{x}", success=success, message="ok" if success else
                "max_steps exceeded at t = 3.9422463 s after 1000000 steps", mean=mean,
                half_width=0.4 if success else math.nan, growing=growing,
                min=mean - 1 if lo is None else lo, max=mean + 1 if hi is None else hi,
                sampled_max=math.nan)


def _summary():
    """The scene's own point named three ways at each f (damping x1, M43 = 1200 N m, the scene's
    K2), a transient at f = 0 with a higher 'mean', a runaway (friction along the slip) at
    f = 0.05, and one more setting that rises."""
    rows = []
    for base, ov, m in (("f=0", F0, 8.73), ("f=0.05", F5, 7.34)):
        rows += [_row(base, "damping", 1.0, ov + " joints.A.contact.damping=25000.0 "
                      "joints.B.contact.damping=17000.0", m),
                 _row(base, "M43", 1200.0, ov + " loads.0.value=1200.0", m),
                 _row(base, "K2", 3.66e11, ov + " joints.B.contact.stiffness=366000000000.0", m)]
    rows += [_row("f=0", "M43", 7200.0, F0 + " loads.0.value=7200.0", 158.5, growing=True, lo=125, hi=200),
             _row("f=0.05", "M43", 7200.0, F5 + " loads.0.value=7200.0", 20.0),
             _row("f=0", "M43", 4800.0, F0 + " loads.0.value=4800.0", 10.0),
             _row("f=0.05", "M43", 4800.0, F5 + " loads.0.value=4800.0", 30.0),
             _row("f=0", "damping", 0.5, F0 + " joints.A.contact.damping=12500.0 "
                  "joints.B.contact.damping=8500.0", 9.0, series="eq. 17 literal", reversed_=True),
             _row("f=0.05", "damping", 0.5, F5_AMB + " joints.A.contact.damping=12500.0 "
                  "joints.B.contact.damping=8500.0", 364.2, series="eq. 17 literal", reversed_=True,
                  lo=364.1, hi=364.3)]
    return pd.DataFrame(rows)


def test_states_name_transients_and_runaways(sens):
    s = sens.clean(_summary())
    st = dict(zip(s["key"], s["state"]))
    assert st["f=0|M43||7200.0"] == "transient"
    assert st["f=0.05|damping|eq. 17 literal|0.5"] == "runaway"
    assert st["f=0|damping|eq. 17 literal|0.5"] == "steady"          # no friction: nothing fed in
    assert st["f=0|M43||4800.0"] == "steady"


def test_statistics_come_from_steady_runs_only(sens):
    s = sens.clean(_summary())
    tr = sens.trend_rows(s)
    text = " ".join(sens.answer(s, tr))
    # the transient's 158.5 and the runaway's 364.2 are never quoted as a mean
    assert "158" not in text and "364 ±" not in text and "364.2" not in text
    assert "125 -> 200" in text and "transient" in text.lower()
    assert "runaway" in text.lower() and "364" in text
    assert "largest steady 10 ± 0.4" in text        # f = 0: the largest steady point, not the transient
    t = tr.set_index(["sweep", "series", "x"])
    assert t.loc[("M43", "", 7200.0), "trend"] == "transient"
    assert math.isnan(t.loc[("M43", "", 7200.0), "f=0"])          # no statistic of the transient
    assert t.loc[("damping", "eq. 17 literal", 0.5), "trend"] == "runaway"
    assert math.isnan(t.loc[("damping", "eq. 17 literal", 0.5), "f=0.05"])


def test_each_distinct_run_is_counted_once(sens):
    s = sens.clean(_summary())
    assert s["run"].nunique() == len(s) - 4       # damping x1 = M43 1200 = K2 3.66e11: one run per f
    tr = sens.trend_rows(s)
    assert len(tr) == 4                           # the scene's point once, M43 7200, 4800, eq. 17
    own = tr[(tr["sweep"] == "damping") & (tr["x"] == 1.0) & (tr["series"] == "")]
    assert len(own) == 1 and "M43 = 1200" in own["same run as"].iloc[0] and "K2" in own["same run as"].iloc[0]
    text = " ".join(sens.answer(s, tr))
    assert "over 4 distinct settings" in text
    rises = next(p for p in sens.answer(s, tr) if p.startswith("Where the peak rises"))
    assert rises.count("M43 = 4800") == 1


def test_the_trend_tally_adds_up(sens):
    tr = sens.trend_rows(sens.clean(_summary()))
    c = sens.tally(tr)
    assert c["rises"] + c["falls"] + c["not resolved"] + c["not steady"] == c["total"] == len(tr)
    assert c["rises"] == 1 and c["falls"] == 1 and c["not steady"] == 2


def test_two_values_of_one_case_are_named_with_the_reason(sens):
    s = sens.clean(_summary())
    text = " ".join(sens.two_runs_text(s, {"mean": 8.674, "half_width": 0.516, "revs": "2 + 20"},
                                       {"transient_revs": 10, "steady_revs": 20}))
    assert "8.674 ± 0.52" in text and "8.73 ± 0.4" in text and "10 + 20" in text and "overlap" in text
    assert sens.two_runs_text(s, None) == []


def test_messages_are_cut_at_a_word(sens):
    m = "max_steps exceeded at t = 3.9422463 s after 1000000 steps in the hybrid mode"
    short = sens.short_message(m, 40)
    assert short.endswith(" …") and m.startswith(short[:-2])
    assert short[:-2].split()[-1] in m.split()            # the last word is whole
    assert sens.short_message("ok", 40) == "ok"


def test_verdict_tally_adds_up_to_the_points(oly):
    pts = {"speed": pd.DataFrame({"status": ["ok"] * 6 + ["failed"],
                                  "verdict": ["chaotic", "regular", "regular", "coexisting", "coexisting",
                                              "coexisting", "not established"]})}
    c = oly.verdict_counts(pts)
    assert sum(c.values()) == 7 and c["coexisting"] == 3 and c["failed"] == 1
    text = oly.tally_text(c)
    assert text.startswith("Of 7 points, 1 chaotic, 2 regular")
    nums = [int(w) for w in text.replace(",", " ").split() if w.isdigit()]
    assert nums[0] == sum(nums[1:])                       # the parts add up to the total
    assert "3 coexisting" in text and "1 failed" in text


def test_uncertainty_includes_the_spread_of_the_check(oly):
    # the olyaei2012 speed sweep's point: -0.7666 ± 8.9e-8, the checks -0.7785 ... -0.7489
    checks = [-0.7785, -0.76662, -0.76662, -0.7489]
    u = oly.check_uncertainty(-0.76662, 8.9e-8, checks)
    assert all(abs(c - -0.76662) <= u for c in checks)
    assert u == pytest.approx(math.hypot(8.9e-8, 0.76662 - 0.7489), rel=1e-9)
    assert oly.check_uncertainty(1.0, 0.1, [1.0, 1.0]) == pytest.approx(0.1)     # agreeing checks
    assert oly.check_uncertainty(1.0, 0.1, [np.nan]) == pytest.approx(0.1)
