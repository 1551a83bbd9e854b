"""The kernel cache key covers every module whose numba code the generated kernel calls (numba's own
cache checks only the generated file's timestamp, so a changed contact law would otherwise run
stale machine code). The integrators are not among them: the kernel binds its functions to the
shared, compiled-once integrators in Python (nld.integrators.bind), and their own cache is
checked by nld.integrators.core.drop_stale_caches."""
import ast
import importlib.util
from pathlib import Path

from nld.kernel.compile import compile_scene, kernel_dependencies
from nld.model.scene import load_scene


def _nld_imports(path: Path, skip: str = "nld.integrators") -> set[Path]:
    """Files of the nld modules imported by a source file (transitively, within nld), except the
    package ``skip`` (the kernel imports only Python binders from it)."""
    seen: set[Path] = set()
    todo = [path]
    while todo:
        tree = ast.parse(todo.pop().read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("nld") \
                    and not node.module.startswith(skip):
                f = Path(importlib.util.find_spec(node.module).origin).resolve()
                if f not in seen:
                    seen.add(f)
                    todo.append(f)
    return seen


def test_cache_key_covers_every_module_the_kernel_calls():
    kern = compile_scene(load_scene("slider_crank"))
    deps = {f.resolve() for f in kernel_dependencies()}
    used = _nld_imports(Path(kern.source_path))
    # package __init__ files only re-export; errors.py holds no numba code
    used = {f for f in used if f.name not in ("__init__.py", "errors.py")}
    assert used, "the generated kernel imports nothing from nld?"
    missing = sorted(str(f) for f in used - deps)
    assert not missing, f"not in the kernel cache key: {missing}"
    # what the kernel takes from nld.integrators is the Python binders, never an integrator that
    # numba would compile into the kernel
    src = Path(kern.source_path).read_text()
    taken = {a.name for node in ast.walk(ast.parse(src)) if isinstance(node, ast.ImportFrom)
             and node.module and node.module.startswith("nld.integrators") for a in node.names}
    assert taken == {"bind", "bind_tangent"}, taken


def test_scenes_of_the_same_structure_share_one_kernel():
    """slider_crank_olyaei is slider_crank with Ambrosio friction and other numbers: with that law
    set, one generated module (and one set of compiled integrators) serves both; a change of
    structure (the contact law) gives another."""
    a = compile_scene(load_scene("slider_crank", ['joints.B.friction.law="ambrosio"',
                                                  "joints.B.friction.mu=0.1"]))
    b = compile_scene(load_scene("slider_crank_olyaei"))
    assert a.source_path == b.source_path and a.module is b.module
    c = compile_scene(load_scene("slider_crank_olyaei", ['joints.B.contact.law="hertz"']))
    assert c.source_path != a.source_path


def test_one_compiled_integrator_per_kernel_whatever_the_caller_passes(monkeypatch):
    """A read-only t_eval (a pandas column, a broadcast) and a call without event_samples used to
    compile the whole integrator again; the integrator's Python front fixes the types, so every
    caller below uses one specialisation of the shared DOPRI5 (and observe_all one), and the
    kernel's functions one each."""
    from nld.integrators.dopri5 import dopri5_core
    import numpy as np
    from nld.run.simulate import simulate
    monkeypatch.setenv("NLD_AOT", "0")     # numba's JIT path (the built cores: test_aot.py)
    from nld.systems.core import SceneSystem, advance
    kern = compile_scene(load_scene("slider_crank"))
    t = np.linspace(0.0, 2e-3, 5)
    t.setflags(write=False)
    simulate("slider_crank", t_eval=t)
    simulate("slider_crank", revs=0.01)
    s = SceneSystem("slider_crank")
    advance(s, s.y0, s.z0, 0.0, 1e-3, 1e-7)
    y, z = s.y0.copy(), s.z0.copy()
    kern.module.solve(0, y, np.array([1e-3]), 0, s.p, z, 1e-7, s.tolerance(1e-7), 0, 1e-3, 10**6,
                      kern.n_events, 8)          # ints for floats, event_samples left out
    assert len(dopri5_core.signatures) == 1, dopri5_core.signatures
    for f in (kern.module.rhs, kern.module.events, kern.module.on_event):
        assert len(f.signatures) == 1, (f, f.signatures)
    assert len(kern.module.observe_all.signatures) == 1, kern.module.observe_all.signatures
