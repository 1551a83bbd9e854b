"""The route's doubled branches (nld.analysis.route.follow_doublings / add_doublings, issue 40
deliverable 2): at a supercritical period doubling the route switches to the doubled branch and
follows it, and on to period 4, with a cost cap and every end's reason; the rows, the sentence and
the figure say it. On the Duffing oscillator (x'' + 0.3 x' - x + x^3 = gamma cos 1.2 t), whose
period-doubling cascade in gamma is the smooth reference (tests/test_continuation_robust.py);
about 2 s."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from nld.analysis.continuation import FEIGENBAUM_DELTA, continue_orbit
from nld.analysis.orbits import periodic_orbit, section_points
from nld.analysis.route import (add_doublings, agreement, check_cascade, route_figure,
                                route_sentence, route_table)
from nld.errors import InputError
from nld.systems import StroboscopicMap, duffing

VALUES = [0.25, 0.26, 0.27, 0.28, 0.29, 0.30]


def _route(cascade):
    S = duffing(gamma=0.25)
    o = periodic_orbit(S, 1, transient=50, rtol=1e-10)
    br = continue_orbit(S, o, "gamma", VALUES, method="natural", locate_tol=1e-6)
    out = {"branch": br, "ends": [e.to_dict() for e in br.ends], "route": "",
           "settings": {"rtol": 1e-10}, "at_values": {}, "section": {}}
    add_doublings(out, S, br, "gamma", VALUES, values=VALUES, locate_tol=1e-6, cascade=cascade,
                  observables=["x"])
    return out


@pytest.fixture(scope="module")
def route():
    return _route(dict(max_period=4, step=0.002, max_points=40))


def _brute(gamma, x0, revs=300, keep=8):
    m = StroboscopicMap(duffing(gamma=gamma, y0=x0), 1, 1e-10)
    X, _ = section_points(m, m.y0, m.z0, revs)
    return X[-keep:]


def test_the_doubled_branches_are_followed_to_period_4_with_the_interval_ratio(route):
    cas = route["cascade"]
    # the chain 1 -> 2 -> 4 -> 8, each doubling supercritical, in increasing gamma
    assert [d[0] for d in cas["doublings"]] == [1, 2, 4]
    assert all(d[3] == "supercritical" for d in cas["doublings"])
    v = [d[1] for d in cas["doublings"]]
    assert np.all(np.diff(v) > 0) and 0.26 < v[0] < 0.27
    # the first interval ratio (Feigenbaum's delta the smooth reference; 4.80 measured)
    assert len(cas["ratios"]) == 1
    assert abs(cas["ratios"][0] - FEIGENBAUM_DELTA) < 0.1 * FEIGENBAUM_DELTA
    assert "interval ratios" in cas["delta"] and "beyond max_period = 4" in cas["message"]
    periods = [e["branch"].period for e in route["doubled"]]
    assert periods == [2, 4]
    for e, (p, val, tol, _c) in zip(route["doubled"], cas["doublings"]):
        b = e["branch"]
        # born just past its doubling, stable there, away from the p-orbit, to the range's end
        assert b.values[0] > val and b.values[0] - val < 0.01
        assert b.orbits[0].stability == "stable"
        far = [x for x in e["ends"] if x["direction"] > 0][0]
        near = [x for x in e["ends"] if x["direction"] < 0][0]
        assert far["reason"] == "range_end" and far["value"] == pytest.approx(0.30)
        assert near["detail"].startswith("born at the period doubling")
        m = b.orbits[0].map
        assert np.max(np.abs(m.difference(b.orbits[0].points[0], b.orbits[0].points[p])
                             / m.scales)) > 1e-3
    assert cas["points"] <= 40 and cas["cpu_s"] >= 0
    assert "The period-2 orbit born at the period doubling" in route["route"]


def test_the_cost_cap_ends_a_branch_with_step_limit():
    out = _route(dict(max_period=4, step=0.002, max_points=4))
    b = out["doubled"][0]["branch"]
    assert len(b.values) == 5 and out["cascade"]["points"] <= 4
    far = [x for x in out["doubled"][0]["ends"] if x["direction"] > 0][0]
    assert far["reason"] == "step_limit" and "cap of 4 points" in far["detail"]
    assert max(b.values) < 0.30


def test_a_stable_doubled_orbit_lies_on_the_brute_force_section(route):
    """The second method: a run from the orbit's state (perturbed by 1e-3) after 300 revolutions
    repeats with period 2 and its section points are the orbit's; agreement() says so."""
    e = route["doubled"][0]
    g = 0.27
    o = e["at_values"][g]
    assert o.stability == "stable"
    X = _brute(g, o.points[0] + 1e-3)
    assert np.ptp(X[::2], axis=0).max() < 1e-6 and np.ptp(X, axis=0).max() > 1e-2  # period 2
    d = np.min([np.max(np.abs(X - p), axis=1) for p in o.points], axis=0)
    assert d.max() < 1e-6
    sweep = pd.DataFrame({"value": g, "x": X[:, 0]})
    ag = agreement(route, sweep, ["x"], [1.0], tol=1e-5)
    row = ag[(ag["value"] == g) & (ag["period"] == 2)].iloc[0]
    assert bool(row["agrees"]) and row["distance"] < 1e-6


def test_rows_sentence_and_figure_name_the_doubled_branches(route):
    pts = pd.DataFrame({"value": VALUES, "lambda_per_rev": [-0.5, -0.4, -0.3, -0.2, -0.1, -0.05],
                        "lambda_unc_per_rev": 0.01, "verdict": "regular",
                        "period": [1, 1, 2, 2, 4, 8]})
    t = route_table("gamma", "gamma", pts, period_col="period", route=route)
    p2 = t[(t["source"] == "continuation") & (t["period"] == 2)]
    assert list(p2["regime"]) == ["period 2 stable", "period 2 unstable"]
    # the stable stretch ends at the second doubling, located on the period-2 branch
    pd4 = route["cascade"]["doublings"][1]
    assert p2.iloc[0]["transition"] == "period_doubling"
    assert p2.iloc[0]["at"] == pytest.approx(pd4[1]) and p2.iloc[0]["at_unc"] == pd4[2]
    assert p2.iloc[1]["transition"] == "range_end"
    assert all("born at the period doubling of the period-1 orbit" in x for x in p2["evidence"])
    p4 = t[(t["source"] == "continuation") & (t["period"] == 4)]
    assert len(p4) and "interval ratios" in p4.iloc[-1]["evidence"]
    s = route_sentence(t, "γ")
    assert "The doubled branch: period 1 → period doubling at γ = 0.2656" in s
    assert s.index("period 2, stable") < s.index("period 2, unstable")
    assert "The doubled branch: period 2 → period doubling at γ = 0.2867" in s
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax, bx) = plt.subplots(2, 1)
    route_figure(ax, bx, route, None, pts, t, "x", label="γ")
    labels = [ln.get_label() for ln in ax.get_lines()]
    assert "period 2, stable" in labels and "period 4, stable" in labels
    # p lines per period-p branch: two x values per gamma on the period-2 curve
    two = [ln for ln in ax.get_lines() if ln.get_color() == "C1" and ln.get_linestyle() == "-"]
    assert len(two) >= 2 * (len(route["doubled"][0]["branch"].values) // 2)
    plt.close(fig)


@pytest.mark.parametrize("bad, what", [
    ("yes", "cascade = 'yes'"), (dict(max_period=1, step=1e-3), "cascade.max_period = 1"),
    (dict(max_period=4, step=-1.0), "cascade.step = -1.0"),
    (dict(max_period=4, step=1e-3, max_points=True), "cascade.max_points = True"),
    (dict(max_period=4, step=1e-3, points=3), "unknown key 'points'")])
def test_a_bad_cascade_setting_is_named(bad, what):
    with pytest.raises(InputError, match=what.replace(".", r"\.").replace("(", r"\(")):
        check_cascade(bad)
    assert check_cascade(None) is None


@pytest.mark.slow
def test_olyaei_period_2_orbit_lies_on_the_brute_force_section():
    """The slider-crank's period-2 orbit at c = 0.28141 mm (a clearance-sweep value, where the
    study's doubled branch runs; docs/route.md): Newton from the state after 100 revolutions finds
    it, its deciding multipliers inside the unit circle (the contact memory's neutral 1 left out);
    runs at the sweep's rtol 1e-8 from the assembly and from the orbit's state (perturbed by 1e-3
    of the scales) repeat with period 2 after 100 revolutions (the study's PERIOD_TOL_C, 1e-4 c),
    the latter on the orbit's points within the route's ROUTE_TOL (1e-3 c). About 4 s."""
    from nld.analysis.route import orbit_class
    from nld.systems.core import SceneSystem
    c = 0.28140892032472753e-3
    S = SceneSystem("slider_crank_olyaei", [f"joints.B.clearance={c!r}"])
    o = periodic_orbit(S, 2, transient=100, rtol=1e-10)
    assert o.converged and orbit_class(o) == "neutral continuum"
    assert np.max(np.abs(o.deciding_multipliers)) < 0.5
    kern = S.kernel
    cols = list(kern.columns)
    jx, jy = cols.index("B.ex"), cols.index("B.ey")

    def obs(m, x, z):
        y, zz = m.unpack(x, z)
        row = np.empty(len(cols))
        kern.module.observe(float(S.t0), np.ascontiguousarray(y), S.p, zz, row)
        return np.array([row[jx], row[jy]])

    Y = np.array([obs(o.map, o.points[k], o.z[k]) for k in range(2)])
    assert np.max(np.abs(Y[0] - Y[1])) / c > 1e-2           # the halves differ: period 2
    m = StroboscopicMap(S, 1, 1e-8)
    near = o.points[0] + 1e-3 * o.map.scales
    for x0, z0, on_orbit in ((m.y0, m.z0, False), (near, o.z[0], True)):
        X, Z = section_points(m, x0, z0, 116)
        B = np.array([obs(m, X[k], Z[k]) for k in range(100, 116)])
        assert np.max(np.abs(B[2:] - B[:-2])) / c < 1e-4
        assert np.max(np.abs(B[1:] - B[:-1])) / c > 1e-2
        if on_orbit:
            d = np.max(np.min(np.max(np.abs(B[:, None, :] - Y[None]), axis=2), axis=1)) / c
            assert d < 1e-3
