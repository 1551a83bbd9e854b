"""The attractor census (nld.analysis.attractors) and the one verdict rule (nld.analysis.verdict):
systems whose attractors and basin split are known, permanent contact as its own class, the
matching of attractors across a parameter, and the command line."""
from __future__ import annotations

import ast
import json
import math
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from nld.analysis.attractors import census, match_attractors, section_period, wilson_interval
from nld.analysis.verdict import (CHAOTIC, COEXISTING, NOT_ESTABLISHED, PERMANENT_CONTACT,
                                  REGULAR, SHORT, census_verdict, checked_verdict,
                                  exponent_verdict, verdict)
from nld.errors import InputError
from nld.systems.core import DiscreteMap, duffing


# ------------------------------------------------------------------ systems with known attractors
@njit(cache=True)
def _cubic(x, p, out):
    """x -> a x - (a - 1) x^3, a = 1.2: stable fixed points +-1 (multiplier 0.6), 0 unstable;
    every x in (0, 1.5] stays positive and goes to +1, so the basin split is at 0 exactly."""
    out[0] = p[0] * x[0] - (p[0] - 1.0) * x[0] ** 3


def test_wilson_interval_known_values():
    lo, hi = wilson_interval(5, 10)
    assert lo == pytest.approx(0.2366, abs=1e-4) and hi == pytest.approx(0.7634, abs=1e-4)
    assert wilson_interval(0, 20)[0] == 0.0 and wilson_interval(20, 20)[1] == 1.0


def test_section_period_finds_the_smallest_period():
    X = np.tile(np.array([[0.0], [1.0], [2.0]]), (10, 1))
    assert section_period(X, np.ones(1), tol=1e-9, max_period=6) == 3
    assert section_period(X + np.linspace(0, 1, 30)[:, None], np.ones(1), tol=1e-9,
                          max_period=6) == 0


def test_two_symmetric_periodic_attractors_split_half_and_half():
    """Forced double well x'' + 0.5 x' - x + x^3 = 0.1 cos(1.4 t): one period-1 motion in each
    well, images of each other under (x, v, t) -> (-x, -v, t + T/2); from starts in a box
    symmetric about the origin each takes about half (the forcing makes the split at one phase
    only nearly even: the binomial interval must contain 0.5)."""
    from nld.systems.derived import StroboscopicMap
    s = duffing(delta=0.5, alpha=-1.0, beta=1.0, gamma=0.1, omega=1.4)
    r = census(s, 40, sampler=((-1.5, -1.0), (1.5, 1.0)), transient=30, record=32,
               progress=False)
    assert [a.kind for a in r.attractors] == ["periodic", "periodic"], str(r)
    assert all(a.period == 1 for a in r.attractors)
    a, b = r.attractors
    assert a.count + b.count == 40 and r.unsettled == 0 and r.failed == 0
    for att in (a, b):
        lo, hi = att.fraction_interval
        assert lo <= 0.5 <= hi, str(r)
        assert att.lambda1 < -3 * att.lambda1_uncertainty
    # mirror images half a period apart
    t, Y = StroboscopicMap(s).trajectory(a.points[-1], n_samples=3)
    np.testing.assert_allclose(Y[1], -b.points[-1], atol=1e-5)
    assert r.verdict == COEXISTING


def test_one_attractor_is_one_attractor():
    r = census(duffing(delta=0.3, alpha=1.0, beta=1.0, gamma=0.3, omega=1.2), 10,
               sampler=((-1.5, -1.0), (1.5, 1.0)), transient=30, record=32, progress=False)
    assert len(r.attractors) == 1 and r.attractors[0].kind == "periodic"
    assert r.attractors[0].fraction == 1.0 and r.verdict == REGULAR


def test_a_known_basin_split_of_a_map():
    """Uniform starts on [-0.5, 1.5]: 3/4 of them are positive, so the +1 attractor's fraction
    interval must contain 0.75; λ1 = ln 0.6 per iteration at both fixed points."""
    m = DiscreteMap(_cubic, [0.3], [1.2], "cubic map")
    r = census(m, 60, sampler=((-0.5,), (1.5,)), seed=3, progress=False)
    assert len(r.attractors) == 2
    plus = [a for a in r.attractors if a.points[-1, 0] > 0][0]
    lo, hi = plus.fraction_interval
    assert lo <= 0.75 <= hi
    assert plus.points[-1, 0] == pytest.approx(1.0, abs=1e-9)
    assert plus.lambda1 == pytest.approx(math.log(0.6), abs=1e-6)


def test_a_chaotic_attractor_is_chaotic():
    r = census(duffing(), 3, sampler=((-1.0, -0.5), (1.0, 0.5)), transient=20, record=200,
               progress=False)
    assert [a.kind for a in r.attractors] == ["chaotic"], str(r)
    # the check at a tenth of the tolerance over twice the span agrees: the verdict holds
    a = r.attractors[0]
    assert a.lambda1_check - a.lambda1_check_uncertainty > 0
    assert r.verdict == CHAOTIC == a.verdict


def test_escaping_runs_are_their_own_class():
    """The cubic map from [-5, 5]: starts beyond |x| ~ 3.5 are thrown out and grow without bound
    (escaping), the others settle on +-1 (the same map as above: nothing new to compile)."""
    m = DiscreteMap(_cubic, [0.3], [1.2], "cubic map")
    r = census(m, 30, sampler=((-5.0,), (5.0,)), transient=100, record=20, seed=1,
               progress=False)
    kinds = {}
    for a in r.attractors:
        kinds.setdefault(a.kind, []).append(a)
    assert set(kinds) == {"escaping", "periodic"}, str(r)
    assert sum(a.count for a in r.attractors) == 30 and r.unsettled == 0
    assert 0 < kinds["escaping"][0].count < 30


@pytest.mark.slow
def test_permanent_contact_is_its_own_class():
    """slider_crank_olyaei, c = 0.1 mm, mu = 0.1 (issue 25): the journal settles into permanent
    contact with no onset; the census calls it so and prints the memory it depends on (quick
    variant in the default run: test_cli_attractors_json, one start)."""
    from nld.systems.core import SceneSystem
    s = SceneSystem("slider_crank_olyaei", ["joints.B.clearance=1e-4", "joints.B.friction.mu=0.1"])
    r = census(s, 2, transient=60, record=16, lyapunov_members=1, rtol=1e-9, seed=2,
               progress=False)
    assert [a.kind for a in r.attractors] == [PERMANENT_CONTACT], str(r)
    assert r.attractors[0].count == 2
    a = r.attractors[0]
    assert a.onsets_per_period == 0.0 and "B.v_onset" in a.conditional_on_memory
    assert r.verdict == PERMANENT_CONTACT and "conditional on the recorded memory" in str(r)


def test_bad_input_is_one_line():
    m = DiscreteMap(_cubic, [0.3], [1.2], "cubic map")
    with pytest.raises(InputError, match="starts = 0"):
        census(m, 0, sampler=((-1.0,), (1.0,)))
    with pytest.raises(InputError, match="sampler = None"):
        census(m, 4)
    with pytest.raises(InputError, match="two vectors of 1 values"):
        census(m, 4, sampler=((1.0,), (-1.0,)))


# ------------------------------------------------------------------ matching across a parameter
def _record(value, attractors, points):
    import pandas as pd
    rows = [{"attractor": i, "k": 0, "x": p} for i, p in enumerate(points)]
    return dict(value=value, status="ok", table=pd.DataFrame(rows), state_names=["x"],
                scales=[1.0], angles=[],
                census=dict(attractors=[dict(id=i, kind=k, period=1, count=1, fraction=f,
                                             fraction_interval=[0, 1],
                                             lambda1_per_revolution=-1.0,
                                             lambda1_uncertainty=0.1, onsets_per_period=None)
                                        for i, (k, f) in enumerate(attractors)],
                            unsettled=0, n_starts=10))


def test_attractors_keep_their_identity_across_a_parameter():
    """Two attractors whose order of size swaps between two values keep their labels (matched
    by distance of their sets, not by rank)."""
    recs = [_record(0.0, [("periodic", 0.7), ("periodic", 0.3)], [1.0, -1.0]),
            _record(1.0, [("periodic", 0.6), ("periodic", 0.4)], [-1.05, 1.02]),
            _record(2.0, [("periodic", 1.0)], [5.0])]
    t = match_attractors(recs)
    lab = {(r.value, round(r.fraction, 2)): r.label for r in t.itertuples()}
    assert lab[(0.0, 0.7)] == lab[(1.0, 0.4)] and lab[(0.0, 0.3)] == lab[(1.0, 0.6)]
    assert lab[(2.0, 1.0)] not in (lab[(0.0, 0.7)], lab[(0.0, 0.3)])


# ------------------------------------------------------------------ the verdict rule
def test_the_one_verdict_rule():
    assert exponent_verdict(2.0, 0.5) == CHAOTIC and exponent_verdict(-2.0, 0.5) == REGULAR
    assert exponent_verdict(0.2, 0.5) == "uncertain"
    assert exponent_verdict(2.0, 0.5, 8, 50) == SHORT
    assert exponent_verdict(2.0, 0.5, permanent_contact=True) == PERMANENT_CONTACT
    assert exponent_verdict(float("nan"), 0.5) == "failed"
    assert verdict(2.0, 0.5, lam_check=2.5, unc_check=0.5) == CHAOTIC
    assert verdict(2.0, 0.5, lam_check=6.0, unc_check=0.5) == NOT_ESTABLISHED
    assert verdict(2.0, 0.5, lam_check=-1.0, unc_check=0.1) == NOT_ESTABLISHED
    assert checked_verdict(CHAOTIC, REGULAR) == NOT_ESTABLISHED
    assert checked_verdict(CHAOTIC, None) == CHAOTIC
    assert census_verdict(["chaotic", "permanent contact"]) == COEXISTING
    assert census_verdict(["quasi-periodic"]) == REGULAR and census_verdict([]) == NOT_ESTABLISHED


def test_no_other_module_defines_a_verdict():
    """Architecture: the verdict rule lives in nld/analysis/verdict.py only (issue 25, item 4):
    no function of another module of nld/ or studies/ returns a verdict word it decided itself
    (a literal 'chaotic', 'regular', 'uncertain', 'not established' ... in a return value, as
    the former nld.study.verdict and chaos_map._verdict did). Functions that pass on what the
    rule returned are fine."""
    from nld.analysis.verdict import VERDICTS
    words = set(VERDICTS) - {"failed"}
    root = Path(__file__).resolve().parent.parent
    found = []
    for path in sorted(list((root / "nld").rglob("*.py")) + list((root / "studies").glob("*.py"))):
        if path.name == "verdict.py" and path.parent.name == "analysis":
            continue
        for fn in ast.walk(ast.parse(path.read_text(), str(path))):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for ret in ast.walk(fn):
                if isinstance(ret, ast.Return) and ret.value is not None and \
                        _returns_word(ret.value, words):
                    found.append(f"{path.relative_to(root)}:{ret.lineno} {fn.name}")
    assert found == []


def _returns_word(node, words) -> bool:
    """The expression's value can be a literal verdict word: the literal itself, or one of the
    branches of a conditional expression or a boolean operation (not a subscript key)."""
    if isinstance(node, ast.Constant):
        return node.value in words
    if isinstance(node, ast.IfExp):
        return _returns_word(node.body, words) or _returns_word(node.orelse, words)
    if isinstance(node, ast.BoolOp):
        return any(_returns_word(v, words) for v in node.values)
    return False


# ------------------------------------------------------------------ command line
def test_cli_attractors_json(tmp_path, capsys):
    from nld.cli.app import main
    code = main(["attractors", "slider_crank_olyaei", "--set", "joints.B.clearance=1e-4",
                 "--set", "joints.B.friction.mu=0.1", "--starts", "1", "--transient", "60",
                 "--revs", "16", "--rtol", "1e-9", "--workers", "1", "--seed", "1", "--json",
                 "--quiet"])
    assert code == 0
    out = json.loads(capsys.readouterr().out)
    a = out["attractors"][0]
    for key in ("kind", "fraction", "fraction_interval", "lambda1_per_revolution",
                "lambda1_uncertainty", "onsets_per_period", "period"):
        assert key in a
    # permanent contact is its own class (issue 25, item 3): no onset, the memory printed
    assert a["kind"] == PERMANENT_CONTACT and out["unsettled"] == 0
    assert a["onsets_per_period"] == 0.0 and "B.v_onset" in a["conditional_on_memory"]
    assert out["verdict"] == PERMANENT_CONTACT
    assert out["provenance"]["git_hash"] and out["settings"]["starts"] == 1


def test_cli_attractors_bad_input(capsys):
    from nld.cli.app import main
    assert main(["attractors", "slider_crank_olyaei", "--starts", "0"]) == 2
    assert main(["attractors", "slider_crank_olyaei", "--param", "joints.B.clearance"]) == 2
    err = capsys.readouterr().err
    assert "--starts = 0" in err and "--param, --values and --out go together" in err
