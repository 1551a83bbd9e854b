"""The route to chaos as data (nld.analysis.route): regimes and transitions from a sweep, the
stability words of orbits, the agreement of a branch with the brute-force section."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from nld.analysis.route import (ROUTE_COLUMNS, agreement, orbit_class, orbit_stability,
                                route_sentence, route_table, sweep_regimes)


def _pts(values, lam, verdicts, periods):
    return pd.DataFrame({"value": values, "lambda_per_rev": lam,
                         "lambda_unc_per_rev": [0.1] * len(values), "verdict": verdicts,
                         "period": periods})


def _orbit(mu, err=1e-6, continuum=False, onsets=0):
    """A stand-in orbit with the attributes the route reads, its stability by nld's one rule
    (nld.analysis.orbits.multiplier_stability)."""
    from nld.analysis.orbits import multiplier_stability
    mu = np.asarray(mu, dtype=complex)
    e = np.full(mu.size, err)
    n_neutral = 1 if continuum else 0
    stable, u = multiplier_stability(mu, e, n_neutral, 0.0)
    keep = np.ones(mu.size, dtype=bool)
    if continuum:
        keep[int(np.argmin(np.abs(mu - 1.0)))] = False
    return SimpleNamespace(multipliers=mu, multiplier_error=e, continuum=continuum,
                           memory_neutral=continuum, deciding_multipliers=mu[keep],
                           stability={True: "stable", False: "unstable", None: "neutral"}[stable],
                           multiplier_uncertainty=u, onsets_per_period=onsets, period=1,
                           max_abs_multiplier=float(np.max(np.abs(mu))))


def test_regimes_from_verdicts_and_periods():
    pts = _pts([0, 1, 2, 3, 4], [1, 1, -1, -1, 0], ["chaotic", "coexisting", "regular", "regular",
                                                     "uncertain"], [0, 0, 2, 0, 0])
    assert sweep_regimes(pts, "period") == ["chaotic", "coexisting", "period 2", "regular",
                                            "not established"]


def test_route_rows_locate_each_change_between_sweep_points():
    pts = _pts([0.0, 0.01, 0.02, 0.04, 0.06, 0.1], [1.2, 0.8, -0.1, -0.5, -0.6, -0.7],
               ["chaotic", "chaotic", "regular", "regular", "regular", "regular"], [0, 0, 2, 1, 1, 1])
    t = route_table("friction", "mu", pts, period_col="period")
    assert list(t.columns) == ROUTE_COLUMNS
    assert list(t["regime"]) == ["chaotic", "period 2", "period 1"]
    assert list(t["order"]) == [1, 2, 3]
    # chaos ends between 0.01 and 0.02: at the midpoint, +- half the spacing; lambda on each side
    r = t.iloc[0]
    assert r["transition"] == "end_of_chaos"
    assert r["at"] == pytest.approx(0.015) and r["at_unc"] == pytest.approx(0.005)
    assert r["lambda_before"].startswith("+0.8") and r["lambda_after"].startswith("-0.1")
    assert t.iloc[1]["at"] == pytest.approx(0.03) and t.iloc[2]["transition"] == "range_end"
    # told from the periodic end: period 1 -> doubling -> period 2 -> chaos
    s = route_sentence(t, "μ")
    assert s.index("period 1") < s.index("period doubling") < s.index("period 2") \
        < s.index("onset of chaos") < s.index("chaotic")
    assert "μ = 0.015 ± 0.005" in s


def test_stability_leaves_the_memory_multiplier_out():
    # a permanent-contact orbit: the memory's multiplier 1 is not a loss of stability ...
    o = _orbit([1.0, 0.6, 0.1], continuum=True)
    assert orbit_stability(o) == "stable"
    assert orbit_class(o) == "neutral continuum"
    # ... but a multiplier within its uncertainty of the unit circle is neither stable nor unstable
    assert orbit_stability(_orbit([0.9999995, 0.2], err=1e-5)) == "neutral"
    assert orbit_stability(_orbit([-1.3, 0.2])) == "unstable"
    assert orbit_class(_orbit([0.5, 0.2])) == "stable"


def _route_with(value, point, o):
    return {"at_values": {value: o}, "section": {value: {"x": np.array([point[0]]),
                                                        "y": np.array([point[1]])}}}


def test_agreement_on_the_section_within_the_tolerance():
    sweep = pd.DataFrame({"value": [0.1] * 10, "rev": range(10), "status": "ok",
                          "x": 1e-3 + 1e-9 * np.arange(10), "y": np.full(10, -2e-3)})
    a = agreement(_route_with(0.1, (1e-3, -2e-3), _orbit([0.5])), sweep, ["x", "y"], 1e-3,
                  tol=1e-4)
    assert a["agrees"].tolist() == [True] and a["distance"].iloc[0] < 1e-4
    # the brute force settled on another point: a stable orbit there means coexistence
    a = agreement(_route_with(0.1, (0.5e-3, -2e-3), _orbit([0.5])), sweep, ["x", "y"], 1e-3,
                  tol=1e-4)
    assert a["agrees"].tolist() == [False] and a["why"].iloc[0].startswith("coexistence")
    assert a["distance"].iloc[0] == pytest.approx(0.5, rel=1e-3)
    # a permanent-contact orbit's neighbours are orbits too: the continuum is named
    a = agreement(_route_with(0.1, (0.5e-3, -2e-3), _orbit([1.0, 0.5], continuum=True)), sweep,
                  ["x", "y"], 1e-3, tol=1e-4)
    assert a["why"].iloc[0] == "continuum"


def test_linked_branch_matches_natural_continuation_on_the_slider_crank():
    """linked_branch (keys set together, here one key named twice) follows the same orbits as
    nld.analysis.continuation's natural continuation of slider_crank_olyaei in μ (permanent
    contact: a continuum, neutral in the memory direction, stable otherwise)."""
    from nld.analysis.continuation import continue_orbit
    from nld.analysis.orbits import periodic_orbit
    from nld.analysis.route import branch_ends, linked_branch
    from nld.systems.core import SceneSystem
    key = "joints.B.friction.mu"
    S = SceneSystem("slider_crank_olyaei", [f"{key}=0.1"])
    o = periodic_orbit(S, 1, transient=10, rtol=1e-8)
    assert o.converged
    vals = [0.09, 0.1, 0.11]
    br = linked_branch("slider_crank_olyaei", [], f"{key},{key}", vals, o, start=0.1, rtol=1e-8,
                       transient=10)
    ref = continue_orbit(S, o, key, vals, method="natural")
    assert br.values == pytest.approx(vals) and list(ref.values) == pytest.approx(vals)
    for a, b in zip(br.orbits, ref.orbits):
        assert np.max(np.abs(a.points - b.points)) <= 1e-6 * np.max(np.abs(b.points))
        assert a.max_abs_multiplier == pytest.approx(b.max_abs_multiplier, abs=1e-4)
        assert orbit_class(a) == "neutral continuum"
    assert [e["reason"] for e in branch_ends(br)] == ["range_end", "range_end"]
    assert not br.bifurcations


def test_a_jump_of_the_multipliers_is_a_contact_change_not_a_period_doubling():
    from nld.analysis.route import _classify_step

    def orb(mu, onsets):
        o = _orbit(mu)
        o.onsets = np.array(onsets)
        return o
    # a multiplier through -1 continuously: period doubling; through +1: fold
    assert _classify_step(orb([-0.9], [2, 1]), orb([-1.1], [2, 1]))[0] == "period_doubling"
    assert _classify_step(orb([0.95], [2, 1]), orb([1.05], [2, 1]))[0] == "fold"
    # the excavator at 3.5 -> 3.75 um: 0.04 -> -50 with the same onsets: no crossing, a jump
    assert _classify_step(orb([0.0427], [11, 8]), orb([-50.5], [11, 8]))[0] == "contact_change"
    # the onsets of each joint, not only their sum, tell a contact gained or lost
    assert _classify_step(orb([0.04], [11, 8]), orb([0.03], [9, 10]))[0] == "contact_change"
    assert _classify_step(orb([0.04], [11, 8]), orb([0.03], [11, 8]))[0] is None


def test_transition_labels_close_together_do_not_overlap(tmp_path):
    """The route figure's transition labels (olyaei2012's clearance sweep at stop 44: the branch's
    'PD 0.2861' drawn first, then the brute-force changes in order, on a log axis; rows taken by
    turn put 'change 0.2115' over 'PD 0.2861') go to the first row where they clear their left
    neighbour: no label over another."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from nld.analysis.route import _label_transitions
    from nld.output.layout_check import check_pdf
    xs = [0.0423, 0.0474, 0.0532, 0.067, 0.0751, 0.0843, 0.1335, 0.1498, 0.2115, 0.2372, 0.2661]
    labels = [(0.2861, "PD 0.2861", "tab:green")] + [(x, f"change {x:.4g}", "tab:green") for x in xs]
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.plot([0.02, 0.5], [0.0, 1.0], ".")
    ax.set_xscale("log")
    _label_transitions(ax, labels, True)
    path = tmp_path / "labels.pdf"
    fig.savefig(path)
    plt.close(fig)
    over = [d for d in check_pdf(path) if d.kind == "text-overlap"
            and ("change" in d.text or "PD" in d.text)]
    assert over == []
