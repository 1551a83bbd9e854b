"""Settings shared by the API and the command line (nld.settings, issue 16): every default of the
command line equals the API's, both equal the dataclass's, and the table of docs/analysis.md is
the one nld.settings.defaults_table() writes. Parsing only: nothing is integrated."""
from __future__ import annotations

import inspect
from pathlib import Path

import pytest

from nld import settings as S
from nld.analysis import bifurcation, chaos_map, lyapunov, poincare, spectrum
from nld.cli import build_parser
import nld.run.simulate  # noqa: F401  (loads the module)

ROOT = Path(__file__).resolve().parent.parent
BEGIN, END = "<!-- settings-table:begin -->", "<!-- settings-table:end -->"


def cli_defaults(*argv):
    return vars(build_parser().parse_args(list(argv)))


def api_default(func, name):
    return inspect.signature(func).parameters[name].default


def shared_settings():
    """(what, CLI default, API default, dataclass default) of every setting the two share."""
    import importlib
    sim_mod = importlib.import_module("nld.run.simulate")
    out = []
    cli = cli_defaults("simulate", "x")
    out += [("simulate --samples-per-rev", cli["samples_per_rev"],
             api_default(sim_mod.simulate, "samples_per_rev"), S.SIMULATE.samples_per_rev),
            ("simulate rtol fallback", sim_mod.DEFAULT_RTOL, sim_mod.DEFAULT_RTOL, S.SIMULATE.rtol),
            ("simulate max_steps", S.SIMULATE.max_steps, api_default(sim_mod.simulate, "max_steps"),
             S.SIMULATE.max_steps)]
    cli = cli_defaults("poincare", "x")
    f = poincare.stroboscopic
    out += [("poincare --transient-revs", cli["transient_revs"], api_default(f, "transient_revs"),
             S.POINCARE_SPANS.transient_revs),
            ("poincare --revs", cli["revs"], api_default(f, "revs"), S.POINCARE_SPANS.revs),
            ("poincare --rtol", cli["rtol"], api_default(f, "rtol"), S.SECTIONS.rtol),
            ("poincare --rtol (--angle)", cli["rtol"], api_default(poincare.hyperplane_section, "rtol"),
             S.SECTIONS.rtol),
            ("poincare --period-tol", cli["period_tol"], api_default(poincare.period_of, "tol"),
             poincare.DEFAULT_PERIOD_TOL)]
    cli = cli_defaults("bifurcation", "x", "--param", "k", "--values", "1,2", "--out", "d")
    f = bifurcation.sweep
    out += [("bifurcation --transient-revs", cli["transient_revs"], api_default(f, "transient_revs"),
             S.BIFURCATION_SPANS.transient_revs),
            ("bifurcation --revs", cli["revs"], api_default(f, "revs"), S.BIFURCATION_SPANS.revs),
            ("bifurcation --rtol", cli["rtol"], api_default(f, "rtol"), S.SECTIONS.rtol),
            ("bifurcation --estimator", cli["estimator"], api_default(f, "lyapunov_estimator"),
             lyapunov.ESTIMATORS[0])]
    cli = cli_defaults("spectrum", "x")
    f = spectrum.scene_spectrum
    out += [("spectrum --revs", cli["revs"], api_default(f, "revs"), S.SPECTRUM_SPANS.revs),
            ("spectrum --transient-revs", cli["transient_revs"], api_default(f, "transient_revs"),
             S.SPECTRUM_SPANS.transient_revs),
            ("spectrum --samples-per-rev", cli["samples_per_rev"], api_default(f, "samples_per_rev"),
             S.SPECTRUM.samples_per_rev),
            ("spectrum --rtol", cli["rtol"], api_default(f, "rtol"), S.SPECTRUM.rtol),
            ("spectrum --method", cli["method"], api_default(f, "method"), spectrum.METHODS[0])]
    cli = cli_defaults("chaos-map", "x", "--x", "a", "--x-values", "1", "--y", "b", "--y-values", "1",
                       "--out", "d")
    f = chaos_map.chaos_map
    out += [("chaos-map --transient-revs", cli["transient_revs"], api_default(f, "transient_revs"),
             S.CHAOS_MAP_SPANS.transient_revs),
            ("chaos-map --revs", cli["revs"], api_default(f, "revs"), S.CHAOS_MAP_SPANS.revs),
            ("chaos-map --rtol", cli["rtol"], api_default(f, "rtol"), S.LYAPUNOV.rtol),
            ("chaos-map --lyapunov-method", cli["lyapunov_method"], api_default(f, "lyapunov_method"),
             S.LYAPUNOV.method),
            ("chaos-map --estimator", cli["estimator"], api_default(f, "estimator"),
             lyapunov.ESTIMATORS[0]),
            ("chaos-map --seed", cli["seed"], api_default(f, "seed"), 0)]
    cli = cli_defaults("lyapunov", "x")
    d = lyapunov.DEFAULTS
    f = lyapunov.lyapunov_tangent
    out += [("lyapunov --transient", cli["transient"], d["tangent"]["transient_base"],
             S.TANGENT_SPANS.transient_revs),
            ("lyapunov --revs", cli["revs"], d["tangent"]["total_base"], S.TANGENT_SPANS.revs),
            ("lyapunov --rtol", cli["rtol"], d["tangent"]["rtol"], S.LYAPUNOV.rtol),
            ("lyapunov --rtol (benettin)", cli["rtol"], d["flow"]["rtol"], S.LYAPUNOV.rtol),
            ("lyapunov --d0", cli["d0"], d["flow"]["d0"], S.BENETTIN.d0),
            ("lyapunov --method", cli["method"], S.LYAPUNOV.method, "dopri5"),
            ("lyapunov --estimator", cli["estimator"], api_default(lyapunov.largest_exponent, "estimator"),
             lyapunov.ESTIMATORS[0]),
            ("lyapunov --state-error-only", not cli["state_error_only"], api_default(f, "tangent_err"),
             S.TANGENT.tangent_err),
            ("lyapunov --target-uncertainty", cli["target_uncertainty"],
             api_default(f, "target_uncertainty"), S.TANGENT.target_uncertainty),
            ("lyapunov --seed", cli["seed"], api_default(f, "seed"), 0),
            ("lyapunov --k", cli["k"], api_default(f, "k"), 1),
            ("lyapunov renorm (tangent)", S.TANGENT.interval_revs, d["tangent"]["interval_period"],
             1 / 8),
            ("lyapunov renorm (benettin)", S.BENETTIN.interval_revs, d["flow"]["interval_base"], 1.0)]
    return out


def mismatches(rows):
    """The rows whose CLI, API and dataclass defaults are not all equal."""
    return [r for r in rows if not (r[1] == r[2] == r[3])]


def test_the_check_can_fail():
    assert mismatches([("x", 1e-8, 1e-10, 1e-8)]) and mismatches([("x", 50, 50, 20)])
    assert not mismatches([("x", 1e-8, 1e-8, 1e-8)])


def test_cli_defaults_equal_api_defaults():
    rows = shared_settings()
    assert len(rows) > 30
    assert mismatches(rows) == []


def test_help_text_names_the_dataclass_defaults():
    import io
    from contextlib import redirect_stdout
    buf = io.StringIO()
    with redirect_stdout(buf), pytest.raises(SystemExit):
        build_parser().parse_args(["chaos-map", "--help"])
    assert f"(default {S.LYAPUNOV.rtol:g};" in " ".join(buf.getvalue().split())


def test_settings_are_frozen():
    import dataclasses
    with pytest.raises(dataclasses.FrozenInstanceError):
        S.SECTIONS.rtol = 1e-6


def test_docs_table_is_current():
    """docs/analysis.md holds the table of nld.settings.defaults_table() between the markers;
    after changing a default, paste the new table (python -c 'from nld.settings import
    defaults_table; print(defaults_table())')."""
    text = (ROOT / "docs" / "analysis.md").read_text()
    assert BEGIN in text and END in text
    table = text.split(BEGIN, 1)[1].split(END, 1)[0]
    assert table.strip() == S.defaults_table().strip()


def test_the_rtol_range_is_checked_in_one_place():
    """nld.settings.check_rtol / rtol_in_range is the one range check of a relative tolerance
    (it was written seven times: issue 25); no other module writes the range."""
    import re

    import numpy as np

    from nld.errors import InputError
    from nld.settings import check_rtol
    assert check_rtol(np.float32(1e-6)) == pytest.approx(1e-6) and check_rtol(None, none_ok=True) is None
    for bad in (True, 1.0, 0, float("nan"), "1e-8"):
        with pytest.raises(InputError, match=r"rtol = .*: must be a number in \[1e-14, 1\)$"):
            check_rtol(bad)
    nld_dir = Path(__file__).resolve().parent.parent / "nld"
    writes = [p.name for p in nld_dir.rglob("*.py") if p.name != "settings.py"
              and re.search(r"1e-14 <=|ge=1e-14", p.read_text())]
    assert writes == []
