"""Two threads of one process (a study's route on nld.study.Background beside the main thread)
reading the contact-law registry and compiling a scene's kernel at once. Each case runs in a
fresh interpreter: the registry and the kernel cache must start empty."""
import os
import subprocess
import sys
import textwrap


def _run(code: str, tmp_path) -> subprocess.CompletedProcess:
    env = dict(os.environ, NLD_CACHE_DIR=str(tmp_path / "kernels"), PYTHONPATH=os.getcwd())
    return subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env,
                          capture_output=True, text=True, timeout=120)


def test_threads_see_the_whole_contact_law_registry_on_first_use(tmp_path):
    r = _run("""
        import threading
        from nld.laws.law import contact_laws
        gate, seen = threading.Barrier(6), []
        def look():
            gate.wait()
            seen.append(contact_laws())
        ts = [threading.Thread(target=look) for _ in range(6)]
        [t.start() for t in ts]; [t.join() for t in ts]
        print(sorted(len(s) for s in seen))
        assert len(set(seen)) == 1 and "lankarani_nikravesh" in seen[0], seen
    """, tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]


def test_threads_compiling_one_scene_share_one_kernel_module(tmp_path):
    r = _run("""
        import threading
        from nld.kernel.compile import compile_scene
        from nld.model.scene import load_scene
        scene = load_scene("slider_crank")
        gate, mods, errors = threading.Barrier(4), [], []
        def build():
            gate.wait()
            try:
                mods.append(compile_scene(scene).module)
            except Exception as e:
                errors.append(repr(e))
        ts = [threading.Thread(target=build) for _ in range(4)]
        [t.start() for t in ts]; [t.join() for t in ts]
        assert not errors, errors
        assert len(mods) == 4 and len({id(m) for m in mods}) == 1, mods
    """, tmp_path)
    assert r.returncode == 0, r.stderr[-2000:]
