"""Workflows live below the front ends (issue 39, deliverable 4): no study builds an argument parser
or imports the command line, studies compare verdicts by nld.analysis.verdict's names, ``nld
control`` is a thin adapter over nld.analysis.scene_control.control_scene (every option reaches it,
its checks come before any work), and the cli docstring and docs/architecture.md list what exists.
Parsing and source reading only: nothing is integrated here (the library against the command on a
small case: tests/test_cli_control.py::test_json_keys_on_a_short_run)."""
from __future__ import annotations

import ast
import inspect
import json
from pathlib import Path

import pytest

from nld.analysis.verdict import VERDICTS
from nld.errors import InputError

ROOT = Path(__file__).resolve().parent.parent
STUDIES = sorted((ROOT / "studies").glob("*.py"))
PARSER_CALLS = {"ArgumentParser", "add_parser", "add_subparsers", "parse_args", "parse_known_args",
                "build_parser"}


def parser_uses(source: str) -> list[str]:
    """What in ``source`` imports argparse or the command line, or builds / runs a parser."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            out += [a.name for a in node.names
                    if a.name.split(".")[0] == "argparse" or a.name.startswith("nld.cli")]
        elif isinstance(node, ast.ImportFrom) and node.module and (
                node.module.split(".")[0] == "argparse" or node.module == "nld.cli"
                or node.module.startswith("nld.cli.")):
            out.append(node.module)
        elif isinstance(node, ast.Call):
            f = node.func
            name = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
            if name in PARSER_CALLS:
                out.append(f"{name}()")
    return out


def verdict_literals(source: str) -> list[str]:
    """Comparisons in ``source`` with a verdict's word written out ("chaotic" == ..., x in
    ("regular", ...), .isin(["uncertain"])) instead of nld.analysis.verdict's name."""
    words = set(VERDICTS)

    def strings(node):
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return [node.value]
        if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
            return [s for e in node.elts for s in strings(e)]
        return []
    out = []
    for node in ast.walk(ast.parse(source)):
        found = []
        if isinstance(node, ast.Compare):
            for side in [node.left] + node.comparators:
                found += strings(side)
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                and node.func.attr == "isin":
            for a in node.args:
                found += strings(a)
        out += [f"line {node.lineno}: {w!r}" for w in found if w in words]
    return out


def test_the_checks_can_fail():
    assert parser_uses("import argparse\np = argparse.ArgumentParser()") == \
        ["argparse", "ArgumentParser()"]
    assert parser_uses("from nld.cli.control import add_parser") == ["nld.cli.control"]
    assert parser_uses("def f(p):\n    return p.parse_args(['x'])") == ["parse_args()"]
    assert parser_uses("from nld.analysis.scene_control import control_scene") == []
    assert verdict_literals("ok = v == 'chaotic'\nn = df['v'].isin(['regular', 'x'])\n"
                            "y = w in ('not established', 'ok')") == \
        ["line 1: 'chaotic'", "line 2: 'regular'", "line 3: 'not established'"]
    assert verdict_literals("from nld.analysis.verdict import CHAOTIC\nok = v == CHAOTIC") == []


@pytest.mark.parametrize("path", STUDIES, ids=[p.name for p in STUDIES])
def test_no_study_builds_a_parser_or_imports_the_command_line(path):
    assert parser_uses(path.read_text()) == []


@pytest.mark.parametrize("path", STUDIES, ids=[p.name for p in STUDIES])
def test_studies_compare_verdicts_by_the_verdict_modules_names(path):
    assert verdict_literals(path.read_text()) == []


# ---------------------------------------------------------------------------------------------------
# nld control: the CLI parses, calls the library, prints

CHAOTIC_SCENE = ["slider_crank_olyaei", "--set", "joints.B.clearance=2e-4",
                 "--set", "joints.B.friction.mu=0"]


def test_every_control_option_reaches_the_library_and_its_result_is_printed(monkeypatch, capsys):
    import nld.analysis.scene_control as sc
    from nld.cli import main
    keywords = set(inspect.signature(sc.control_scene).parameters)
    got = {}

    def fake(scene, overrides=(), **kw):
        got.update(kw, scene=scene, overrides=list(overrides))
        return sc.SceneControl(out={"status": "controlled", "lambda1_controlled": -0.5},
                               result=None, system=None)
    monkeypatch.setattr(sc, "control_scene", fake)
    argv = ["control"] + CHAOTIC_SCENE + [
        "--method", "edfc", "--signal", "slider.s_dot", "--body", "slider", "--gain", "0.5",
        "--memory", "0.7", "--delay", "0.024", "--target-period", "2", "--transient", "3",
        "--revs", "7", "--lyapunov-revs", "5", "--gains", "0.5,1.5", "--scan-transient", "4",
        "--dp-max", "0.2", "--radius", "0.3", "--rtol", "1e-9", "--json", "--quiet"]
    assert main(argv) == 0
    assert json.loads(capsys.readouterr().out) == {"status": "controlled",
                                                   "lambda1_controlled": -0.5}
    assert got.pop("command") == "nld " + " ".join(argv)
    names = got.pop("names")
    assert got.pop("say") is not None and got.pop("progress") is False
    assert list(got.pop("gains")) == [0.5, 1.5]
    assert got == dict(scene="slider_crank_olyaei", overrides=CHAOTIC_SCENE[2::2], method="edfc",
                       signal="slider.s_dot", body="slider", gain=0.5, memory=0.7, delay=0.024,
                       target_period=2, transient=3, revs=7, lyapunov_revs=5, scan_transient=4,
                       dp_max=0.2, radius=0.3, rtol=1e-9)
    # every keyword of the library that a message can name is named by its option
    assert all(v == "--" + k.replace("_", "-") for k, v in names.items())
    assert set(names) == keywords - {"scene", "overrides", "body", "progress", "say", "command",
                                     "names"}


@pytest.fixture
def no_integration(monkeypatch):
    import nld.analysis.orbits as orbits

    def refuse(*a, **k):
        raise AssertionError("an orbit was computed before the arguments were checked")
    monkeypatch.setattr(orbits, "periodic_orbit", refuse)
    monkeypatch.setattr(orbits, "find_orbits", refuse)


@pytest.mark.parametrize("kw, words", [
    (dict(revs=1), "revs = 1: must be an integer >= 2"),
    (dict(transient=2.5), "transient = 2.5: must be an integer >= 0"),
    (dict(method="lqr"), "method = 'lqr': must be one of pyragas, edfc, ogy"),
    (dict(gain=float("nan")), "gain = nan: must be a finite number"),
    (dict(dp_max=0.0), "dp_max = 0.0: must be a finite number > 0"),
    (dict(rtol=2.0), "rtol = 2.0: must be a number in [1e-14, 1)"),
    (dict(gains=[]), "gains = []: must be a non-empty list of finite numbers"),
    (dict(delay=-0.012), "delay = -0.012: tau must be a positive time in s"),
    (dict(memory=1.0), "memory = 1.0: R must be in [0, 1)"),
    (dict(method="ogy", gains=[1.0]), "gains: the stability domain is of delayed feedback"),
    (dict(signal="rod.nope"), "signal = 'rod.nope': no such state of slider_crank_olyaei"),
    (dict(delay=-0.012, names={"delay": "--delay"}), "--delay = -0.012: tau must be a positive"),
])
def test_control_scene_checks_its_arguments_before_any_work(no_integration, kw, words):
    from nld.analysis.scene_control import control_scene
    with pytest.raises(InputError) as e:
        control_scene(CHAOTIC_SCENE[0], CHAOTIC_SCENE[2::2], progress=False, **kw)
    assert words in str(e.value) and "\n" not in str(e.value)


def test_control_defaults_are_the_settings():
    """The command's option defaults and the library's keyword defaults are nld.settings.CONTROL."""
    from nld.analysis.scene_control import control_scene
    from nld.cli import build_parser
    from nld.settings import CONTROL
    a = vars(build_parser().parse_args(["control", "x"]))
    sig = inspect.signature(control_scene).parameters
    for k in ("transient", "revs", "lyapunov_revs", "scan_transient", "dp_max", "radius", "rtol"):
        assert a[k] == sig[k].default == getattr(CONTROL, k), k
    for k in ("method", "gain", "memory", "delay", "target_period", "signal", "body"):
        assert a[k] is None and sig[k].default is None, k     # the scene's, else CONTROL's


# ---------------------------------------------------------------------------------------------------
# the docs list what exists


def test_the_cli_docstring_lists_every_command_and_module():
    import nld.cli
    from nld.cli import build_parser
    doc = nld.cli.__doc__
    commands = list(build_parser().commands)
    assert [c for c in commands if f"    nld {c}" not in doc] == []
    modules = sorted(p.stem for p in (ROOT / "nld" / "cli").glob("*.py")
                     if p.stem not in ("__init__", "app", "args"))
    assert [m for m in modules if f"``{m}``" not in doc] == []


def test_the_architecture_lists_the_analysis_and_cli_modules():
    text = (ROOT / "docs" / "architecture.md").read_text()
    tree = text[:text.index("## ")]          # the pipeline's tree, before the first section
    words = set(tree.replace(",", " ").replace("(", " ").replace(")", " ").split())
    missing = [f"{pkg}/{p.stem}" for pkg in ("analysis", "cli")
               for p in sorted((ROOT / "nld" / pkg).glob("*.py"))
               if p.stem != "__init__" and p.stem not in words]
    assert missing == []
