"""The excavator study's orbit check (studies/zhang2013_excavator.py orbit_checks, docs/route.md):
a regular sweep point that the route added is checked by its periodic orbit, whose exponent
ln(max |mu|) / p (nld.analysis.route.orbit_exponent) must agree with the run's; no Newton here
(stand-in orbits), so each test takes milliseconds."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from nld.analysis.route import orbit_exponent
from study_harness import load_study


def _orbit(mu, unc, period=1, neutral=False):
    mu = np.asarray(mu, dtype=complex)
    deciding = mu[np.abs(mu - 1.0) > 1e-12] if neutral else mu
    return SimpleNamespace(period=period, deciding_multipliers=deciding,
                           max_abs_multiplier=float(np.max(np.abs(mu))),
                           multiplier_uncertainty=unc, memory_neutral=neutral)


def test_orbit_exponent_is_the_log_of_the_largest_deciding_multiplier_per_period():
    lam, u = orbit_exponent(_orbit([0.0179, -0.002], 4e-5))
    assert lam == pytest.approx(math.log(0.0179)) and u == pytest.approx(4e-5 / 0.0179)
    # a period-2 orbit of the one-revolution map: per revolution, half its log-multiplier
    lam2, u2 = orbit_exponent(_orbit([0.25j, 0.01], 1e-3, period=2))
    assert lam2 == pytest.approx(math.log(0.25) / 2) and u2 == pytest.approx(1e-3 / 0.25 / 2)
    # the contact memory's neutral 1 does not decide
    lam3, _ = orbit_exponent(_orbit([1.0, 0.5], 1e-4, neutral=True))
    assert lam3 == pytest.approx(math.log(0.5))


@pytest.fixture(scope="module")
def study():
    return load_study("zhang2013_excavator.py")


def _case(study, lam, unc, *, agrees=True, cls="stable", mu=0.0179, mu_unc=4.4e-5):
    v = 3e-6
    pts = pd.DataFrame([{"sweep": "clearance", "value": v, "lambda_per_rev": lam,
                         "lambda_unc_per_rev": unc, "verdict_main": "regular", "verdict": "regular",
                         "verdict_check": "", "lambda_check_per_rev": np.nan,
                         "lambda_check_unc_per_rev": np.nan, "section_points": 50, "status": "ok",
                         "message": "", "check_method": study.ORBIT_CHECK_PENDING}])
    secs = pd.DataFrame({"sweep": "clearance", "value": v, "rev": np.arange(50), "status": "ok",
                         **{o: 0.5e-6 for o in study.SECTION_OBS}})
    agree = pd.DataFrame([{"value": v, "class": cls, "max_abs_mu": mu, "mu_unc": mu_unc,
                           "onsets": 16, "distance": 5e-6 if agrees else 0.3, "agrees": agrees,
                           "why": ""}])
    routes = {"route": {"at_values": {v: _orbit([mu, 1e-3], mu_unc)}}, "agree": agree,
              "settings": study.ROUTE_FULL}
    stage = SimpleNamespace(stage=lambda *a, **k: pytest.fail("no Newton expected"))
    return study.orbit_checks(stage, routes, secs, pts).iloc[0], routes


def test_a_regular_route_point_on_its_stable_orbit_is_regular(study):
    # the 3 µm point as measured: λ1 -4.0225 ± 2e-5 (tangent in the error control) against
    # ln(0.0179 ± 4.4e-5) = -4.0230 ± 0.0025
    row, routes = _case(study, -4.0225, 2e-5)
    assert row["verdict"] == "regular" and row["verdict_check"] == "regular"
    assert row["lambda_check_per_rev"] == pytest.approx(math.log(0.0179))
    assert row["check_method"].startswith("period-1 orbit") and "the branch's orbit" in row["message"]
    assert routes["orbit_checks"][0]["verdict"] == "regular"


def test_exponents_that_disagree_or_an_orbit_off_the_section_are_not_established(study):
    # the state-only error control's value (-4.0437 ± 1e-5): 8x the summed uncertainties off
    row, _ = _case(study, -4.0437, 1e-5)
    assert row["verdict"] == "not established"
    row, _ = _case(study, -4.0225, 2e-5, agrees=False)
    assert row["verdict"] == "not established" and "not on" in row["message"]
    row, _ = _case(study, -4.0225, 2e-5, cls="unstable", mu=1.5)
    assert row["verdict"] == "not established" and "unstable" in row["message"]
