"""The one integrator call site of nld.systems (issue 39): ``nld.systems.base.integrate`` (one
call or in chunks) and ``integrate_tangent`` are the only places that call an integrator, and
their typed results are read by name."""
import ast
from pathlib import Path

import numpy as np

from nld.systems import advance, duffing
from nld.systems.base import Solution, TangentSolution, integrate, integrate_tangent
from nld.systems.section import land
from nld.systems.tangent import run_tangent, tangent_functions

SYSTEMS = Path(__file__).resolve().parent.parent / "nld" / "systems"
INTEGRATORS = {"solve", "solve_tangent", "integrate_chunked", "dopri5", "dopri5_tangent"}


def _integrator_calls(path: Path):
    """(line, name) of every call of an integrator by name in ``path`` (``solve(...)``,
    ``x.solve(...)``, ``integrate_chunked(...)``), except in the bodies of the functions that ARE
    a system's ``solve`` (ContinuousSystem.solve, the built-in flows' ``_solve_builtin`` ...)."""
    tree = ast.parse(path.read_text())
    skip = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef) and (node.name == "solve"
                                                  or node.name.startswith("_solve")):
            skip |= {id(n) for n in ast.walk(node)}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and id(node) not in skip:
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
            if name in INTEGRATORS:
                found.append((node.lineno, name))
    return found


def test_the_integrators_are_called_from_base_only():
    calls = {p.name: _integrator_calls(p) for p in sorted(SYSTEMS.glob("*.py"))}
    assert {k: v for k, v in calls.items() if v and k != "base.py"} == {}
    assert len(calls["base.py"]) == 3          # integrate: one call and chunks; integrate_tangent


def test_chunked_integration_is_a_solution_close_to_one_call():
    d = duffing(gamma=0.3, omega=1.2)
    T = d.period
    te = d.t0 + T * np.arange(1, 6)
    one = integrate(d, d.t0, d.y0, d.z0, te, land=True, rtol=1e-10, max_steps=10**6)
    chunks = integrate(d, d.t0, d.y0, d.z0, te, land=True, rtol=1e-10, max_steps=10**6, span=T)
    assert isinstance(chunks, Solution) and chunks.ok and one.ok
    assert chunks.interrupted is False and one.interrupted is False
    # a restart at every period changes the step sequence only: agreement to the tolerance
    assert np.max(np.abs(chunks.Y - one.Y)) < 1e-7
    # the first chunk is the one call over one period, bit for bit
    first = integrate(d, d.t0, d.y0, d.z0, te[:1], land=True, rtol=1e-10, max_steps=10**6)
    assert np.array_equal(chunks.Y[0], first.Y[0])
    assert int(chunks.stats[0]) > int(one.stats[0]) - 5


def test_land_is_advance_and_the_start_before_it():
    d = duffing()
    atol = d.tolerance(1e-9)
    y1, z1 = advance(d, d.y0, d.z0, 0.0, 2.5, 1e-9)
    y2, z2 = land(d, d.y0, d.z0, 0.0, 2.5, 1e-9, atol, d.hmax, 10**6)
    assert np.array_equal(y1, y2) and np.array_equal(z1, z2)
    y3, _ = land(d, d.y0, d.z0, 2.5, 2.5, 1e-9, atol, d.hmax, 10**6)
    assert np.array_equal(y3, d.y0) and y3 is not d.y0


def test_tangent_integration_is_read_by_name():
    """run_tangent over one period from W = I, not orthonormalised: the rows of W are those of
    the transposed state-transition matrix, whose determinant is exp(-delta T) (Liouville)."""
    d = duffing()
    T = d.period
    run = run_tangent(d, d.y0, d.z0, np.eye(2), np.zeros((2, 0)), 0.0, [T], 1e-10,
                      orthonormalise=False)
    assert abs(np.linalg.det(run.W) - np.exp(-0.3 * T)) < 1e-7
    y, _ = advance(d, d.y0, d.z0, 0.0, T, 1e-10)
    assert np.max(np.abs(run.y - y)) < 1e-7
    W = np.eye(2)
    solve = tangent_functions(d)[0]
    out = integrate_tangent(d, solve, 0.0, d.y0.copy(), d.z0.copy(), W, np.zeros((2, 0)),
                            np.array([T]), 1e-10, tangent_err=True, want_div=False, h0=0.0,
                            max_steps=10**6, diag=np.zeros(run.diag.size), logs=np.zeros((1, 2)),
                            orthonormalise=False)
    assert isinstance(out, TangentSolution) and out.status == 0 and out.n_done == 1
    assert np.array_equal(out.y, run.y) and np.array_equal(W, run.W) and out.t == run.t
