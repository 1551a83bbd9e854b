"""The kernel cache key covers every module the generated kernel calls (numba's own cache checks
only the generated file's timestamp, so a changed integrator or contact law would otherwise run
stale machine code)."""
import ast
import importlib.util
from pathlib import Path

from nld.kernel.compile import compile_scene, kernel_dependencies
from nld.model.scene import load_scene


def _nld_imports(path: Path) -> set[Path]:
    """Files of the nld modules imported by a source file (transitively, within nld)."""
    seen: set[Path] = set()
    todo = [path]
    while todo:
        tree = ast.parse(todo.pop().read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("nld"):
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
