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
