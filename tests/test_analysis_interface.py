"""The analyses take a System and use only its interface (issue 39): no getattr probes for what a
system is, one way to address a parameter, defaults in nld.settings, built-in systems in
nld.systems."""
from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from nld.errors import InputError

ANALYSIS = Path(__file__).resolve().parent.parent / "nld" / "analysis"


def _probes(path: Path):
    tree = ast.parse(path.read_text())
    return [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Call)
            and isinstance(n.func, ast.Name) and n.func.id in ("getattr", "hasattr")]


def test_getattr_probes_in_nld_analysis_are_few_and_commented():
    """An analysis reads declared System fields (is_scene, is_map, period_name ...): what
    getattr/hasattr is left in nld/analysis is not about a system, and is commented on its line
    or the line above."""
    found, bare = [], []
    for path in sorted(ANALYSIS.glob("*.py")):
        lines = path.read_text().splitlines()
        for ln in _probes(path):
            found.append(f"{path.name}:{ln}")
            if "#" not in lines[ln - 1] and not lines[ln - 2].strip().startswith("#"):
                bare.append(f"{path.name}:{ln}")
    assert len(found) <= 2 and bare == [], (found, bare)


def test_a_family_is_the_system_at_another_value():
    """continuation.Family addresses its parameter through the System interface: at(v) has the
    p of system.with_parameter(param, v), value0 is system.parameter(param), the label names the
    parameter; a forcing frequency sets the period."""
    from nld.analysis.continuation import Family
    from nld.systems import duffing, henon
    D = duffing(gamma=0.2)
    fam = Family(D, "gamma")
    assert fam.value0 == D.parameter("gamma") == 0.2 and fam.label == "gamma"
    assert np.array_equal(fam.at(0.25).p, D.with_parameter("gamma", 0.25).p)
    assert fam.at(0.25).p[D.param_names.index("gamma")] == 0.25 and D.p[3] == 0.2
    w = Family(D, "omega")
    assert w.at(2.0).period == pytest.approx(np.pi)
    with pytest.raises(InputError, match="omega = -1 is outside the parameter's domain: the "
                                         "forcing frequency must be > 0"):
        w.check(-1.0)
    assert Family(henon(), 0).label == "p[0]"
    i = D.param_names.index("gamma")
    assert Family(D, i).label == "gamma" and Family(D, i).value0 == 0.2


def test_the_controllers_address_parameters_through_the_system():
    """delayed_feedback's parameter input and OGY's parameter come from
    System.parameter_index; OGY perturbs its own copy (with_parameter): the system's p is left
    as it was; a forcing frequency (it sets the map's period) is refused."""
    from nld.analysis import control as C
    from nld.systems import henon, rossler
    S = rossler()
    fb = C.delayed_feedback(S, 0.1, 5.88, "y", input="param", target="c")
    assert (fb.target, fb.target_name) == (2, "c") == (S.parameter_index("c"), "c")
    with pytest.raises(InputError, match="target = 'd': no such parameter"):
        C.delayed_feedback(S, 0.1, 5.88, "y", input="param", target="d")
    H = henon()
    p0 = H.p.copy()
    r = C.ogy(H, 0, dp_max=0.1, radius=0.1, n_iter=300, x0=[0.1, 0.1], lyapunov_iter=10)
    assert np.array_equal(H.p, p0) and r.settings is not None
    from nld.systems import duffing
    with pytest.raises(InputError, match="param = 'omega': the forcing frequency sets the map's "
                                         "period"):
        C.ogy(duffing(), "omega", dp_max=0.01, radius=0.1)


def test_defaults_and_builtins_live_in_one_place():
    import nld.settings as S
    from nld.analysis import attractors, control, lyapunov
    from nld.systems import rossler
    assert attractors.DEFAULTS is S.CENSUS_DEFAULTS and lyapunov.DEFAULTS is S.LYAPUNOV_DEFAULTS
    assert lyapunov.DEFAULTS["flow"]["rtol"] == S.LYAPUNOV.rtol
    assert control.rossler is rossler and rossler().param_names == ["a", "b", "c"]


def test_several_scene_keys_are_one_parameter():
    """Keys set together ("joints.A.clearance,joints.B.clearance", as the route to chaos varies
    both clearances) are one parameter of a scene: with_parameter sets every key on the same
    kernel, parameter gives their common value (InputError where they differ), and a
    continuation family takes them."""
    from nld.analysis.continuation import Family
    from nld.systems import SceneSystem
    S = SceneSystem("slider_crank_two")
    keys = "joints.A.clearance,joints.B.clearance"
    S2 = S.with_parameter(keys, 4e-4)
    assert S2.kernel.key == S.kernel.key
    assert S2.parameter("joints.A.clearance") == S2.parameter("joints.B.clearance") == 4e-4
    assert S2.parameter(keys) == 4e-4
    fam = Family(S2, keys)
    assert fam.value0 == 4e-4 and fam.at(5e-4).parameter("joints.B.clearance") == 5e-4
    with pytest.raises(InputError, match="must be >= 0"):
        fam.check(-1.0)
    with pytest.raises(InputError, match="no such scene key"):
        S.with_parameter("joints.A.clearance,joints.Q.clearance", 4e-4)
    S3 = S.with_parameter("joints.A.clearance", 3e-4)
    with pytest.raises(InputError, match="different values"):
        S3.parameter(keys)
