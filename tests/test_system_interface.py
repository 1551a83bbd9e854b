"""The System interface (nld.systems.base, issue 39): every system implements it, the one
integrator call site reproduces the integrator called directly, and a parameter is addressed one
way (``parameter`` / ``with_parameter``)."""
import ast
import math
from pathlib import Path

import numpy as np
import pytest

from nld.errors import InputError
from nld.systems import (ContinuousSystem, DiscreteMap, PoincareMap, SceneSystem, StroboscopicMap,
                         advance, duffing, henon, impact_oscillator, logistic, lorenz, trajectory)
from nld.systems.base import Solution, System, integrate
from nld.systems.derived import NumbaMap, as_map
from nld.systems.section import land

SYSTEMS = Path(__file__).resolve().parent.parent / "nld" / "systems"


def raw(system, t0, y, z, t_eval, land_, rtol, atol, max_steps=10**7, max_log=1):
    """The integrator called directly with its positional arguments (the pre-interface way)."""
    zz = np.array(z, dtype=float)
    out = system.solve(float(t0), np.array(y, dtype=float), np.array(t_eval, dtype=float), land_,
                       system.p, zz, float(rtol), np.ascontiguousarray(atol, dtype=float), 0.0,
                       float(system.hmax), int(max_steps), int(system.n_events), int(max_log))
    return out, zz


@pytest.fixture(scope="module")
def scene():
    return SceneSystem("slider_crank_olyaei")


def test_every_system_implements_the_interface(scene):
    flows = [lorenz(), duffing(), impact_oscillator(), scene]
    maps = [logistic(), henon(), StroboscopicMap(duffing()), NumbaMap(henon()),
            PoincareMap(lorenz(), [0.0, 0.0, 1.0], 27.0)]
    for s in flows + maps:
        assert isinstance(s, System), s
        assert s.dimension == s.n == s.y0.size
        assert s.is_map == (s in maps)
        assert s.is_scene == (s is scene)
    assert isinstance(scene, SceneSystem) and isinstance(scene, ContinuousSystem)
    assert not isinstance(lorenz(), SceneSystem)
    assert isinstance(logistic(), DiscreteMap)
    assert [s.is_derived for s in maps] == [False, False, True, False, True]
    # declared fields, read without probes
    assert lorenz().kernel is None and scene.kernel is not None and scene.scene.name == scene.name
    assert scene.memory.size == 1 and scene.angle_states.size >= 1
    assert impact_oscillator().contact_events == [0] and lorenz().contact_events is None


def test_integrate_reproduces_the_integrator_called_directly():
    s = lorenz()
    z = s.z0.copy()
    te = np.linspace(0.0, 2.0, 41)
    sol = integrate(s, 0.0, s.y0, z, te, land=False, rtol=1e-9, max_steps=10**7)
    out, _ = raw(s, 0.0, s.y0, z, te, False, 1e-9, s.tolerance(1e-9))
    assert isinstance(sol, Solution) and sol.ok
    assert np.array_equal(sol.Y, out.Y) and sol.t == out.t and np.array_equal(sol.stats, out.stats)
    # the system's own tolerance is the default, the inputs are not modified
    y = s.y0.copy()
    y1, _ = advance(s, y, s.z0, 0.0, 1.5, 1e-9)
    out, _ = raw(s, 0.0, s.y0, s.z0, [1.5], True, 1e-9, s.tolerance(1e-9))
    assert np.array_equal(y1, out.Y[0]) and np.array_equal(y, s.y0)


def test_scene_paths_reproduce_the_integrator_called_directly(scene):
    s, T = scene, scene.period
    # advance / land: the scene's own tolerance; the discrete state is carried
    y1, z1 = advance(s, s.y0, s.z0, 0.0, 0.7 * T, 1e-8)
    out, zr = raw(s, 0.0, s.y0, s.z0, [0.7 * T], True, 1e-8, s.tolerance(1e-8))
    assert np.array_equal(y1, out.Y[0]) and np.array_equal(z1, zr)
    y2, z2 = land(s, s.y0, s.z0, 0.0, 0.7 * T, 1e-8, s.tolerance(1e-8), s.hmax, 10**7)
    assert np.array_equal(y2, y1) and np.array_equal(z2, z1)
    # the stroboscopic step is one landing integration over the period
    m = StroboscopicMap(s, 1, 1e-8)
    st = m.step(m.y0)
    out, zr = raw(s, 0.0, s.y0, s.z0, [T], True, 1e-8, s.tolerance(1e-8), 50_000_000, 4096)
    from nld.systems import wrap_angles
    assert np.array_equal(st.x, m.pack(wrap_angles(s, out.Y[0]), zr)) and np.array_equal(st.z, zr)
    # trajectory() too integrates at the scene's own tolerance, not rtol * scales for every
    # state (which it used before issue 39: other samples; docs/architecture.md)
    t, Y = trajectory(s, 20, T / 10, rtol=1e-8)
    own, _ = raw(s, 0.0, s.y0, s.z0, t, False, 1e-8, s.tolerance(1e-8))
    assert np.array_equal(Y, own.Y)
    every, _ = raw(s, 0.0, s.y0, s.z0, t, False, 1e-8, 1e-8 * s.scales)
    assert not np.array_equal(Y, every.Y)


def test_stroboscopic_step_of_a_flow_is_its_advance_over_the_period():
    d = duffing()
    m = StroboscopicMap(d, 1, 1e-9)
    y1, _ = advance(d, d.y0, d.z0, 0.0, d.period, 1e-9)
    assert np.array_equal(m.step(m.y0).x, y1)


def test_parameter_getter_and_with_parameter():
    s = lorenz()
    assert s.parameter("rho") == 28.0 == s.parameter(1)
    s2 = s.with_parameter("rho", 30.0)
    assert s2.p.tolist() == [10.0, 30.0, 8.0 / 3.0] and s.p[1] == 28.0
    assert s2._solve is s._solve            # the same compiled integrator: no recompilation
    d = duffing().with_parameter("omega", 2.0)
    assert d.period == pytest.approx(math.pi) and d.hmax == pytest.approx(math.pi / 20)
    m = StroboscopicMap(duffing(), 1, 1e-9).with_parameter("gamma", 0.3)
    assert isinstance(m, StroboscopicMap) and m.flow.parameter("gamma") == 0.3 == m.parameter(3)
    h = as_map(henon()).with_parameter(1, 0.2)
    assert h.system.p.tolist() == [1.4, 0.2]
    for key in ("nope", 3, -1, True, 2.5):
        with pytest.raises(InputError, match="param = "):
            lorenz().with_parameter(key, 1.0)


def test_scene_parameter_by_scene_key_and_layout_name(scene):
    assert scene.parameter("joints.B.clearance") == pytest.approx(5e-4)
    s2 = scene.with_parameter("joints.B.clearance", 2e-4)
    assert isinstance(s2, SceneSystem) and s2.kernel.key == scene.kernel.key
    assert s2.parameter("joints.B.clearance") == 2e-4 and s2.scene is not scene.scene
    # a name of the kernel's parameter layout that is no scene key (a derived entry) addresses
    # that entry of p; one that is a scene key too means the scene key
    name = next(k for k in scene.kernel.layout.index if scene._scene_value(k) is None)
    i = scene.kernel.layout.index[name]
    assert scene.parameter(name) == scene.p[i]
    s3 = scene.with_parameter(name, 2.0 * scene.p[i] + 1.0)
    assert s3.p[i] == 2.0 * scene.p[i] + 1.0 and s3.kernel is scene.kernel
    with pytest.raises(InputError, match="no such scene key"):
        scene.with_parameter("joints.Q.clearance", 1e-4)
    with pytest.raises(InputError, match="structure"):
        scene.with_parameter("joints.B.clearance", 0.0)


def _probes(path: Path):
    tree = ast.parse(path.read_text())
    return [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Call)
            and isinstance(n.func, ast.Name) and n.func.id in ("getattr", "hasattr")]


def test_getattr_probes_in_nld_systems_are_few_and_commented():
    """What a system is, is declared (System): the few getattr/hasattr left in nld/systems are
    introspection of functions or modules, each with a comment on its line or the line above."""
    found, bare = 0, []
    for path in sorted(SYSTEMS.glob("*.py")):
        lines = path.read_text().splitlines()
        for ln in _probes(path):
            found += 1
            if "#" not in lines[ln - 1] and not lines[ln - 2].strip().startswith("#"):
                bare.append(f"{path.name}:{ln}")
    assert found <= 5 and bare == []
