"""Every option takes a value that starts with '-' (issue 37, class 4): the shared Parser reads
-1e-3, -.5, -inf, -0.5:0.5:3 and -1,2 as values, on every command, instead of "expected one
argument". Parsing only: no command runs."""
from __future__ import annotations

import pytest

from nld.cli import main
from nld.cli.app import build_parser, parse
from nld.cli.args import UsageError


def _args(argv):
    return parse(build_parser(), argv)


@pytest.mark.parametrize("argv, dest, expected", [
    (["control", "slider_crank_olyaei", "--gain", "-1e-3"], "gain", -1e-3),
    (["control", "slider_crank_olyaei", "--gain", "-.5"], "gain", -0.5),
    (["control", "slider_crank_olyaei", "--memory", "-2E-1"], "memory", -0.2),
    (["control", "slider_crank_olyaei", "--delay", "-1e-9"], "delay", -1e-9),
    (["control", "slider_crank_olyaei", "--gains", "-0.5:0.5:3"], "gains", [-0.5, 0.0, 0.5]),
    (["attractors", "slider_crank", "--param", "driver.angle0", "--values", "-1,2"], "values", [-1.0, 2.0]),
    (["continue", "slider_crank", "--param", "driver.angle0", "--values", "-1e-1:-2e-1:2"],
     "values", [-0.1, -0.2]),
    (["bifurcation", "slider_crank", "--param", "driver.angle0", "--values", "-1e-1,2", "--out", "x"],
     "values", [-0.1, 2.0]),
])
def test_negative_values_are_values(argv, dest, expected):
    got = getattr(_args(argv), dest)
    assert list(got) == pytest.approx(expected) if isinstance(expected, list) else got == pytest.approx(expected)


@pytest.mark.parametrize("argv, words", [
    (["control", "slider_crank_olyaei", "--gain", "-inf"], ["--gain = -inf", "finite"]),
    (["control", "slider_crank_olyaei", "--gain", "-Infinity"], ["--gain = -Infinity", "finite"]),
    (["simulate", "slider_crank", "--revs", "-1e-3"], ["--revs = -1e-3", "> 0"]),
    (["lyapunov", "slider_crank", "--revs", "-.5"], ["--revs = -0.5", "positive"]),
    (["attractors", "slider_crank", "--starts", "-1e2"], ["--starts = '-1e2'", "integer"]),
])
def test_negative_values_reach_the_option_check(argv, words, capsys):
    """The option's own check answers (one line naming the option and the value), not argparse's
    "expected one argument"."""
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "expected one argument" not in err
    for w in words:
        assert w in err, (w, err)


def test_an_unknown_option_is_still_an_option():
    with pytest.raises(UsageError, match="unrecognized arguments: -x"):
        _args(["simulate", "slider_crank", "-x"])
    with pytest.raises(UsageError, match="-information"):
        _args(["simulate", "slider_crank", "-information"])
