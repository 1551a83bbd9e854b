"""Bad input on every path: a table of cases, each with its input, the expected exit status (command
line) or exception type (API), and words the one-line message must contain.

Command line: exit status 2 and exactly one line ``nld: error: ...`` on stderr, no traceback.
API: only nld's own error types (nld.errors: InputError, SceneError, InputTypeError; subclasses of
ValueError and TypeError), with a message naming the argument.
Physically absurd but valid numbers (a 1e300 kg crank, a crank at 1e300 rad/s) are refused with the
plausible range (docs/scene-format.md, "Plausible ranges").
"""
from __future__ import annotations

from pathlib import Path

import pytest

import nld
from nld.cli import main
from nld.errors import InputError, InputTypeError, SceneError

SCENES = Path(nld.__file__).resolve().parent / "scenes"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("bad_input")
    text = (SCENES / "four_bar.toml").read_text(encoding="utf-8")
    lines, skip = [], False
    for ln in text.splitlines():                 # the four-bar without its [driver] table
        if ln.strip().startswith("["):
            skip = ln.strip() == "[driver]"
        if not skip:
            lines.append(ln)
    (d / "nodriver.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    (d / "a_directory.toml").mkdir()
    return d


# (id, argv, exit status, words in the message); "{d}" is the fixture's directory
CLI_CASES = [
    ("revs-1e12", ["simulate", "slider_crank", "--revs", "1e12"], 2,
     ["--revs", "1e+12 revolutions", "GiB", "--samples-per-rev"]),
    ("revs-abc", ["simulate", "slider_crank", "--revs", "abc"], 2, ["--revs", "'abc'", "not a number"]),
    ("revs-negative", ["simulate", "slider_crank", "--revs", "-2"], 2, ["--revs", "-2", "> 0"]),
    ("revs-and-t-end", ["simulate", "slider_crank", "--revs", "2", "--t-end", "0.1"], 2,
     ["--t-end", "--revs", "not allowed"]),
    ("samples-0", ["simulate", "slider_crank", "--samples-per-rev", "0"], 2,
     ["--samples-per-rev", "0", ">= 1"]),
    ("samples-negative", ["simulate", "slider_crank", "--samples-per-rev", "-5"], 2,
     ["--samples-per-rev", "-5", ">= 1"]),
    ("speed-1e300", ["simulate", "slider_crank", "--set", "driver.speed=1e300"], 2,
     ["driver.speed", "1e+300", "plausible range", "rad/s"]),
    ("mass-1e300", ["simulate", "slider_crank", "--set", "bodies.crank.mass=1e300"], 2,
     ["bodies.crank.mass", "1e+300", "plausible range", "kg"]),
    ("mass-1e-300", ["show", "slider_crank", "--set", "bodies.rod.mass=1e-300"], 2,
     ["bodies.rod.mass", "1e-300", "plausible range", "kg"]),
    ("inertia-1e300", ["show", "slider_crank", "--set", "bodies.rod.inertia=1e300"], 2,
     ["bodies.rod.inertia", "plausible range", "kg m^2"]),
    ("point-1e9", ["show", "slider_crank", "--set", "bodies.rod.points.B=[1e9, 0]"], 2,
     ["bodies.rod.points.B", "plausible range", "(m)"]),
    ("clearance-above-radius", ["simulate", "slider_crank", "--set", "joints.B.clearance=0.05"], 2,
     ["joints.B.clearance", "0.05", "journal_radius"]),
    ("clearance-negative", ["show", "slider_crank", "--set", "joints.B.clearance=-1e-3"], 2,
     ["joints.B.clearance", ">= 0"]),
    ("mu-s-below-mu", ["simulate", "excavator", "--set", "joints.B.friction.mu=0.1",
                       "--set", "joints.B.friction.mu_s=0.05"], 2,
     ["joints.B.friction.mu_s", "0.05", ">= mu = 0.1", "static"]),
    ("mu-s-negative", ["show", "excavator", "--set", "joints.A.friction.mu_s=-0.1"], 2,
     ["joints.A.friction.mu_s", "-0.1", ">= 0"]),
    ("mu-negative", ["show", "excavator", "--set", "joints.A.friction.mu=-0.01"], 2,
     ["joints.A.friction.mu", "-0.01", ">= 0"]),
    ("scene-directory", ["simulate", "{d}/a_directory.toml"], 2, ["a_directory.toml", "directory"]),
    ("scene-missing", ["simulate", "{d}/missing.toml"], 2, ["missing.toml", "not found"]),
    ("scene-unknown", ["show", "no_such_scene"], 2, ["no_such_scene", "slider_crank"]),
    ("no-driver-revs", ["simulate", "{d}/nodriver.toml", "--revs", "2"], 2,
     ["--revs", "no driver", "--t-end"]),
    ("values-negative-range", ["bifurcation", "slider_crank", "--param", "joints.B.clearance",
                               "--values", "-1:-5:2", "--out", "{d}/sweep1"], 2,
     ["--values", "-1", "joints.B.clearance", ">= 0"]),
    ("values-negative-range-eq", ["bifurcation", "slider_crank", "--param", "joints.B.clearance",
                                  "--values=-1:-5:2", "--out", "{d}/sweep2"], 2,
     ["--values", "-1", "joints.B.clearance", ">= 0"]),
    ("values-garbage", ["bifurcation", "slider_crank", "--param", "driver.speed", "--values", "a:b",
                        "--out", "{d}/sweep3"], 2, ["--values", "START:STOP:NUM"]),
    ("param-unknown", ["bifurcation", "slider_crank", "--param", "joints.Z.clearance", "--values",
                       "1:2:2", "--out", "{d}/sweep4"], 2, ["joints.Z.clearance"]),
    ("chaos-map-x-values", ["chaos-map", "slider_crank", "--x", "joints.B.clearance", "--x-values",
                            "-1e-4", "--y", "joints.B.friction.mu", "--y-values", "0", "--out",
                            "{d}/map1"], 2, ["--x-values", "joints.B.clearance", ">= 0"]),
    ("rtol-range", ["simulate", "slider_crank", "--rtol", "2"], 2, ["--rtol", "[1e-14, 1)"]),
    ("poincare-revs-0", ["poincare", "slider_crank", "--revs", "0"], 2, ["--revs", ">= 1"]),
    ("poincare-no-driver", ["poincare", "{d}/nodriver.toml"], 2, ["speed-driven crank"]),
    ("lyapunov-rtol", ["lyapunov", "slider_crank", "--rtol", "-1"], 2, ["--rtol"]),
    ("lyapunov-revs-abc", ["lyapunov", "slider_crank", "--revs", "abc"], 2, ["--revs", "abc"]),
    ("study-unknown", ["study", "no_such_study"], 2, ["no_such_study", "available"]),
    ("out-bad-suffix", ["simulate", "slider_crank", "--out", "{d}/x.txt"], 2, [".csv", ".parquet"]),
    ("set-malformed", ["show", "slider_crank", "--set", "joints.B.clearance"], 2, ["KEY=VALUE"]),
    ("quiet-and-progress", ["simulate", "slider_crank", "--quiet", "--progress"], 2,
     ["--progress", "--quiet"]),
    # issue 27: tracebacks, inputs accepted without a word, unclear messages
    ("lyapunov-seed-negative", ["lyapunov", "slider_crank", "--seed", "-1"], 2, ["--seed", "-1", ">= 0"]),
    ("chaos-map-seed-negative", ["chaos-map", "slider_crank", "--x", "joints.B.clearance", "--x-values",
                                 "1e-4", "--y", "driver.speed", "--y-values", "300", "--seed", "-1",
                                 "--out", "{d}/map1"], 2, ["--seed", "-1", ">= 0"]),
    ("chaos-map-plot-unwritable", ["chaos-map", "slider_crank", "--x", "joints.B.clearance",
                                   "--x-values", "1e-4", "--y", "driver.speed", "--y-values", "300",
                                   "--out", "{d}/map1", "--plot", "{d}/nodriver.toml/map.png"], 2,
     ["--plot", "nodriver.toml/map.png", "a file is in the way"]),
    ("lyapunov-k-check", ["lyapunov", "slider_crank", "--k", "4", "--check"], 2,
     ["--check", "--k 4", "lambda1", "without --k"]),
    ("lyapunov-spectrum-negative", ["lyapunov", "slider_crank", "--spectrum", "-2"], 2,
     ["--spectrum", "-2", ">= 0"]),
    ("lyapunov-k-0", ["lyapunov", "slider_crank", "--k", "0"], 2, ["--k", "0", ">= 1"]),
    ("lyapunov-revs-1e12", ["lyapunov", "slider_crank", "--revs", "1e12"], 2,
     ["--revs", "1e+12", "GiB", "at most 1.68e+07 revolutions"]),
    ("lyapunov-max-revs-1e12", ["lyapunov", "slider_crank", "--target-uncertainty", "0.05",
                                "--max-revs", "1e12"], 2, ["--max-revs", "1e+12", "GiB", "at most"]),
    ("lyapunov-max-revs-below-revs", ["lyapunov", "slider_crank", "--revs", "20", "--max-revs", "5"], 2,
     ["--max-revs", "5", ">= --revs (20)"]),
    ("lyapunov-target-2", ["lyapunov", "slider_crank", "--target-uncertainty", "2"], 2,
     ["--target-uncertainty", "2", "(0, 1)"]),
    ("lyapunov-transient-negative", ["lyapunov", "slider_crank", "--transient", "-1"], 2,
     ["--transient", "-1", ">= 0"]),
    ("values-repeated-range", ["bifurcation", "slider_crank", "--param", "driver.speed", "--values",
                               "300:300:3", "--out", "{d}/sweep1"], 2,
     ["--values", "'300:300:3'", "300 appears 3 times", "NUM = 1"]),
    ("values-repeated-list", ["bifurcation", "slider_crank", "--param", "driver.speed", "--values",
                              "300,400,300", "--out", "{d}/sweep1"], 2, ["--values", "300 appears 2 times"]),
    ("y-values-repeated", ["chaos-map", "slider_crank", "--x", "joints.B.clearance", "--x-values",
                           "1e-4", "--y", "driver.speed", "--y-values", "300:300:2", "--out", "{d}/map1"], 2,
     ["--y-values", "300 appears 2 times"]),
    ("mu-s-not-coulomb", ["show", "slider_crank", "--set", "joints.B.friction.mu_s=0.3"], 2,
     ["joints.B.friction.mu_s", "0.3", "law = 'coulomb'", "'none'"]),
    ("mu-1e6", ["show", "excavator", "--set", "joints.A.friction.mu=1e6"], 2,
     ["joints.A.friction.mu", "1000000", "plausible range", "5"]),
    ("mu-s-1e6", ["show", "excavator", "--set", "joints.A.friction.mu_s=1e6"], 2,
     ["joints.A.friction.mu_s", "plausible range"]),
    ("hard-cases-unknown-option", ["hard-cases", "--fast"], 2, ["--fast", "'nld hard-cases --help'"]),
    ("four-bar-ground-out-of-reach", ["simulate", "four_bar", "--set", "ground.points.C=[1.0, 0]",
                                      "--revs", "0.1"], 2,
     ["scene 'four_bar' cannot be assembled", "joints B-C-O-A", "at joint B", "link lengths"]),
    ("four-bar-ideal-ground-out-of-reach", ["simulate", "four_bar", "--set", "ground.points.C=[1.0, 0]",
                                            "--revs", "0.1", "--ideal"], 2,
     ["cannot be assembled", "at joint B"]),
    ("four-bar-crank-too-long", ["simulate", "four_bar", "--set", "bodies.crank.points.O=[-0.07, 0]",
                                 "--set", "bodies.crank.points.A=[0.07, 0]", "--revs", "0.1"], 2,
     ["cannot be assembled", "does not close"]),
    # issue 27, the audit
    ("poincare-revs-1e9", ["poincare", "slider_crank", "--revs", "1000000000"], 2,
     ["revs = 1000000000", "GiB", "at most 7.78e+06"]),
    ("bifurcation-observables-unknown", ["bifurcation", "slider_crank", "--param", "driver.speed",
                                         "--values", "300", "--observables", "nope", "--out",
                                         "{d}/sweep1"], 2, ["--observables", "'nope'", "no such column"]),
    ("chaos-map-check-span-200", ["chaos-map", "slider_crank", "--x", "joints.B.clearance", "--x-values",
                                  "1e-4", "--y", "driver.speed", "--y-values", "300", "--check-span",
                                  "200", "--out", "{d}/map1"], 2, ["--check-span", "200", "[1, 100]"]),
    ("simulate-out-under-a-file", ["simulate", "slider_crank", "--out", "{d}/nodriver.toml/x.csv"], 2,
     ["--out", "nodriver.toml/x.csv", "a file is in the way"]),
    ("study-out-is-a-file", ["study", "flores2004", "--quick", "--out", "{d}/nodriver.toml"], 2,
     ["--out", "nodriver.toml", "in the way"]),
]


@pytest.mark.parametrize("argv, status, words", [c[1:] for c in CLI_CASES],
                         ids=[c[0] for c in CLI_CASES])
def test_cli_bad_input(argv, status, words, files, capsys):
    argv = [a.replace("{d}", str(files)) for a in argv]
    rc = main(argv)
    out, err = capsys.readouterr()
    assert rc == status, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("nld: error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w.replace("{d}", str(files)) in lines[0], (w, lines[0])
    assert not (files / "sweep1").exists() and not (files / "map1").exists()


def test_cli_no_driver_with_t_end_runs(files, capsys):
    """A scene without a driver runs for a time span (the hint of the revs error is right)."""
    rc = main(["simulate", str(files / "nodriver.toml"), "--t-end", "0.002", "--quiet"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert "rows: 1001" in out


def _sweep(**kw):
    from nld.analysis.bifurcation import sweep
    args = dict(scene="slider_crank", param="driver.speed", values=[300.0], workers=1, revs=1,
                transient_revs=0)
    args.update(kw)
    return sweep(args.pop("scene"), args.pop("param"), args.pop("values"), **args)


def _chaos_map(**kw):
    from nld.analysis.chaos_map import chaos_map
    args = dict(param_x="joints.B.clearance", values_x=[5e-4], param_y="joints.B.friction.mu",
                values_y=[0.0], workers=1, revs=2, transient_revs=0)
    args.update(kw)
    return chaos_map("slider_crank", **args)


def _strobo(**kw):
    from nld.analysis.poincare import stroboscopic
    args = dict(transient_revs=0, revs=2)
    args.update(kw)
    return stroboscopic(args.pop("scene", "slider_crank"), **args)


sim = nld.simulate


def _lyap(name, **kw):
    import nld.analysis.lyapunov as L
    from nld.systems import lorenz
    return getattr(L, name)(lorenz(), **kw)


def _map(**kw):
    from nld.systems import core as S
    args = dict(f=S.henon_f, x0=[0.0, 0.0], p=[1.4, 0.3], name="h")
    args.update(kw)
    return S.DiscreteMap(args.pop("f"), args.pop("x0"), **args)


def _python_jac(x, p, J):       # a plain Python function (not numba)
    J[:, :] = 0.0


def _jit(src: str):
    """A numba function jac(x, p, J) from its body (compiled when the map probes it)."""
    from numba import njit
    ns = {}
    exec("def jac(x, p, J):\n" + "".join(f"    {ln}\n" for ln in src.splitlines()), ns)
    return njit(ns["jac"])

# (id, call, exception type, words in the message)
API_CASES = [
    ("revs-str", lambda: sim("slider_crank", revs="abc"), InputTypeError, ["revs", "'abc'", "number"]),
    ("revs-1e12", lambda: sim("slider_crank", revs=1e12), InputError, ["revs", "1e+12", "GiB"]),
    ("revs-nan", lambda: sim("slider_crank", revs=float("nan")), InputError, ["revs", "finite"]),
    ("revs-negative", lambda: sim("slider_crank", revs=-1), InputError, ["revs", "> 0"]),
    ("scene-none", lambda: sim(None), InputTypeError, ["scene = None", "built-in scene name"]),
    ("scene-int", lambda: sim(42), InputTypeError, ["scene = 42", "built-in scene name"]),
    ("revs-and-t-end", lambda: sim("slider_crank", revs=1, t_end=0.01), InputError,
     ["revs", "t_end", "not both"]),
    ("samples-0", lambda: sim("slider_crank", samples_per_rev=0), InputError,
     ["samples_per_rev = 0", ">= 1"]),
    ("samples-negative", lambda: sim("slider_crank", samples_per_rev=-4), InputError,
     ["samples_per_rev = -4", ">= 1"]),
    ("samples-fraction", lambda: sim("slider_crank", samples_per_rev=2.5), InputError,
     ["samples_per_rev = 2.5", "integer"]),
    ("rtol-str", lambda: sim("slider_crank", rtol="x"), InputError, ["rtol", "'x'"]),
    ("mu-s-below-mu", lambda: sim("slider_crank", overrides=["joints.B.friction.law=coulomb",
                                                             "joints.B.friction.mu=0.2",
                                                             "joints.B.friction.mu_s=0.1"]),
     SceneError, ["joints.B.friction.mu_s", ">= mu = 0.2"]),
    ("mu-s-str", lambda: sim("slider_crank", overrides=["joints.B.friction.mu_s=\"a\""]),
     SceneError, ["joints.B.friction.mu_s", "number"]),
    ("t-eval-unsorted", lambda: sim("slider_crank", t_eval=[0.01, 0.0]), InputError,
     ["t_eval", "sorted"]),
    ("t-eval-str", lambda: sim("slider_crank", t_eval="abc"), InputTypeError, ["t_eval", "'abc'"]),
    ("t-eval-before-t0", lambda: sim("slider_crank", t_eval=[-1.0, 0.0]), InputError,
     ["t_eval[0]", "t0"]),
    ("y0-length", lambda: sim("slider_crank", y0=[0.0, 1.0, 2.0]), InputError, ["y0", "3 values"]),
    ("overrides-int", lambda: sim("slider_crank", overrides=5), InputTypeError, ["overrides = 5"]),
    ("override-malformed", lambda: sim("slider_crank", overrides=["x"]), InputError, ["'x'", "KEY=VALUE"]),
    ("speed-1e300", lambda: sim("slider_crank", overrides=["driver.speed=1e300"]), SceneError,
     ["driver.speed", "plausible range"]),
    ("mass-1e300", lambda: sim("slider_crank", overrides={"bodies.crank.mass": 1e300}), SceneError,
     ["bodies.crank.mass", "plausible range", "kg"]),
    ("mass-1e-300", lambda: nld.load_scene("slider_crank", ["bodies.crank.mass=1e-300"]), SceneError,
     ["bodies.crank.mass", "plausible range"]),
    ("clearance-above-radius", lambda: nld.load_scene("slider_crank", {"joints.B.clearance": 0.02}),
     SceneError, ["joints.B.clearance", "journal_radius"]),
    ("method-unknown", lambda: sim("slider_crank", method="euler"), InputError, ["method", "dopri5"]),
    ("max-steps-0", lambda: sim("slider_crank", max_steps=0), InputError, ["max_steps = 0"]),
    ("chunk-revs-0", lambda: sim("slider_crank", chunk_revs=0), InputError, ["chunk_revs = 0"]),
    ("progress-str", lambda: sim("slider_crank", revs=0.01, progress="yes"), InputError, ["progress"]),
    ("load-scene-none", lambda: nld.load_scene(None), InputTypeError, ["scene = None"]),
    ("strobo-scene-none", lambda: _strobo(scene=None), InputTypeError, ["scene = None"]),
    ("strobo-revs-str", lambda: _strobo(revs="a"), InputError, ["revs = 'a'"]),
    ("strobo-rtol", lambda: _strobo(rtol=2), InputError, ["rtol = 2"]),
    ("sweep-values-str", lambda: _sweep(values="1:2:3"), InputTypeError, ["values = '1:2:3'"]),
    ("sweep-param-none", lambda: _sweep(param=None), InputError, ["param = None"]),
    ("sweep-rtol", lambda: _sweep(rtol=-1), InputError, ["rtol = -1"]),
    ("sweep-revs", lambda: _sweep(revs=0), InputError, ["revs = 0"]),
    ("map-values-str", lambda: _chaos_map(values_x="abc"), InputTypeError, ["values_x = 'abc'"]),
    ("map-rtol", lambda: _chaos_map(rtol=0), InputError, ["rtol = 0"]),
    ("map-param-none", lambda: _chaos_map(param_x=None), InputError, ["param_x = None"]),
    # issue 27
    ("map-seed-negative", lambda: _chaos_map(seed=-1), InputError, ["seed = -1", ">= 0"]),
    ("tangent-seed-negative", lambda: _lyap("lyapunov_tangent", total=1.0, seed=-1), InputError,
     ["seed = -1", ">= 0"]),
    ("benettin-seed-negative", lambda: _lyap("lyapunov_benettin", total=1.0, seed=-1), InputError,
     ["seed = -1", ">= 0"]),
    ("spectrum-seed-str", lambda: _lyap("lyapunov_spectrum", total=1.0, seed="x"), InputError,
     ["seed = 'x'"]),
    ("tangent-total-1e12", lambda: _lyap("lyapunov_tangent", total=1e12), InputError,
     ["total = 1000000000000.0", "GiB", "at most 1.34e+08 intervals"]),
    ("benettin-total-1e12", lambda: _lyap("lyapunov_benettin", total=1e12), InputError,
     ["total = 1000000000000.0", "GiB", "at most 1.34e+08 intervals"]),
    ("map-f-python", lambda: _map(f=_python_jac), InputError,
     ["the map must be a numba-compiled function f(x, p, out)"]),
    ("map-jacobian-python", lambda: _map(jacobian=_python_jac), InputError,
     ["the Jacobian must be a numba-compiled function jac(x, p, J)"]),
    ("map-jacobian-outside", lambda: _map(jacobian=_jit("for i in range(3):\n    J[i, 0] = 1.0\n"
                                                        "    J[i, 1] = 1.0")), InputError,
     ["jacobian", "writes outside", "(2, 2)"]),
    ("map-jacobian-partial", lambda: _map(jacobian=_jit("J[0, 0] = 1.0")), InputError,
     ["jacobian", "unwritten", "(2, 2)"]),
    ("map-jacobian-signature", lambda: _map(jacobian=_jit("J[0, 0] = x[5]")), InputError,
     ["jacobian"]),
    ("mu-1e6", lambda: nld.load_scene("excavator", {"joints.A.friction.mu": 1e6}), SceneError,
     ["joints.A.friction.mu", "plausible range"]),
    ("mu-s-not-coulomb", lambda: nld.load_scene("slider_crank", {"joints.B.friction.mu_s": 0.1}),
     SceneError, ["joints.B.friction.mu_s", "coulomb"]),
    ("mu-s-not-coulomb-ambrosio", lambda: nld.load_scene("excavator", {
        "joints.A.friction.law": "ambrosio", "joints.A.friction.mu_s": 0.3}),
     SceneError, ["joints.A.friction.mu_s", "coulomb", "'ambrosio'"]),
    ("assembly", lambda: sim("four_bar", revs=0.1, overrides=["ground.points.C=[1.0, 0]"]),
     InputError, ["cannot be assembled", "at joint B"]),
    ("strobo-revs-1e9", lambda: _strobo(revs=10**9), InputError, ["revs = 1000000000", "GiB"]),
]


@pytest.mark.parametrize("call, exc, words", [c[1:] for c in API_CASES], ids=[c[0] for c in API_CASES])
def test_api_bad_input(call, exc, words):
    with pytest.raises((InputError, SceneError)) as ei:
        call()
    e = ei.value
    assert isinstance(e, exc) and isinstance(e, ValueError), (type(e), e)
    if exc is InputTypeError:
        assert isinstance(e, TypeError)
    msg = str(e)
    assert "\n" not in msg
    for w in words:
        assert w in msg, (w, msg)


def test_plausible_ranges_leave_the_builtin_scenes_alone():
    """Every built-in scene passes the plausible-range checks (they bound absurd values only)."""
    from nld.model.scene import builtin_scenes
    for name in builtin_scenes():
        sc = nld.load_scene(name)
        for b in sc.bodies.values():
            assert 1e-9 <= b.mass <= 1e7
        for j in sc.joints.values():
            assert j.clearance == 0 or j.clearance < j.journal_radius


def test_assembly_error_is_also_a_solve_error():
    """A mechanism that cannot be assembled is bad input (exit status 2) that code catching
    SolveError still catches."""
    from nld.errors import AssemblyError, SolveError
    with pytest.raises(SolveError) as ei:
        sim("four_bar", revs=0.1, overrides=["ground.points.C=[1.0, 0]"])
    assert isinstance(ei.value, AssemblyError) and ei.value.joint == "B"
    # the geometric gap: A = (0.05, 0) is 0.95 m from C = (1.0, 0); coupler + rocker = 0.35 m
    assert ei.value.gap == pytest.approx(0.95 - 0.35, rel=1e-9)


def test_map_with_a_correct_numba_jacobian_is_accepted():
    """The probe leaves correct maps alone (the built-in Henon with its Jacobian, and a user map)."""
    from nld.systems import core as S
    m = _map(jacobian=S.henon_jac)
    assert m.n == 2 and m.jacobian is S.henon_jac
    assert S.henon().n == 2 and S.logistic().n == 1


def test_lyapunov_transient_0_is_accepted(capsys):
    """--transient 0 (measure from the start) is a valid request (issue 27: it was refused)."""
    import json
    rc = main(["lyapunov", "slider_crank", "--transient", "0", "--revs", "2", "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    res = json.loads(out)
    assert res["transient_revs"] == 0 and res["averaged_revs"] == pytest.approx(2.0)


def test_lyapunov_help_shows_a_plain_percent(capsys):
    """The description is not %-formatted by argparse: "95 %%" was printed as it is."""
    from nld.cli import build_parser
    with pytest.raises(SystemExit):
        build_parser().parse_args(["lyapunov", "--help"])
    out = capsys.readouterr().out
    assert "about 95 %)" in " ".join(out.split()) and "%%" not in out


def test_source_date_epoch_malformed_is_refused_before_the_study(monkeypatch, tmp_path, capsys):
    """SOURCE_DATE_EPOCH=abc: one line naming the variable, exit 2, before the study runs
    (issue 27: a ValueError traceback)."""
    from nld.output.report import source_date_epoch
    d = tmp_path / "studies"
    d.mkdir()
    (d / "s.py").write_text("def main(quick, out_dir):\n    raise SystemExit('ran')\n")
    monkeypatch.setenv("NLD_STUDIES_DIR", str(d))
    for bad in ("abc", "1.5", "-1", "1e20"):
        monkeypatch.setenv("SOURCE_DATE_EPOCH", bad)
        with pytest.raises(InputError, match="SOURCE_DATE_EPOCH"):
            source_date_epoch()
        rc = main(["study", "s", "--quick", "--out", str(tmp_path / "o")])
        err = capsys.readouterr().err
        assert rc == 2, err
        assert err.startswith(f"nld: error: SOURCE_DATE_EPOCH = {bad!r}") and len(err.splitlines()) == 1
    monkeypatch.setenv("SOURCE_DATE_EPOCH", " 1700000000 ")
    assert source_date_epoch() == 1700000000


def test_corrupt_point_file_through_the_loaders(tmp_path):
    """load_sweep / load_chaos_map on a directory with a corrupt point file: an InputError naming
    the file and saying how to recompute it (issue 27: a pyarrow exception)."""
    import pandas as pd

    from nld.analysis.bifurcation import load_sweep
    from nld.analysis.chaos_map import load_chaos_map
    from nld.sweeps.store import ResultStore
    store = ResultStore(tmp_path)
    store.prepare({"kind": "test"}, settings=(), resume=False)
    store.write({"direction": "grid", "index": 0, "table": pd.DataFrame({"value": [1.0]})})
    bad = store.point_path("grid", 1)
    bad.write_bytes(b"PAR1 cut short")
    for load in (load_sweep, load_chaos_map):
        with pytest.raises(InputError) as ei:
            load(tmp_path)
        msg = str(ei.value)
        assert msg.startswith(f"point file {bad} cannot be read") and "--resume" in msg
        assert "\n" not in msg


def test_mu_s_equal_to_mu_is_accepted_on_any_law():
    """mu_s = mu is what a law without stiction does: accepted whatever the law (only a mu_s that
    would be ignored is refused)."""
    sc = nld.load_scene("excavator", {"joints.A.friction.law": "ambrosio", "joints.A.friction.mu": 0.2,
                                      "joints.A.friction.mu_s": 0.2})
    assert sc.joints["A"].friction.law == "ambrosio" and sc.joints["A"].friction.mu_s == 0.2


def test_an_escaping_ode_is_named_as_such_not_as_stiff_contact():
    """x'' = x^3 (a Duffing oscillator with a softening cubic and nothing else) from x = 2 blows up
    in finite time: the failure says the solution grows without bound (|y| and t), with no contact
    guess for a system without contacts (issue 25; a built-in rhs: nothing to compile)."""
    from nld.errors import SolveError
    from nld.systems.core import advance, duffing

    s = duffing(delta=0.0, alpha=0.0, beta=-1.0, gamma=0.0, y0=(2.0, 0.0))
    with pytest.raises(SolveError, match=r"grows without bound \(\|y\| = \d.*e\+\d+ at t = 0\.") as e:
        advance(s, s.y0, s.z0, 0.0, 5.0, 1e-8)
    assert "contact" not in str(e.value)
