"""Compile a scene to its numba kernel: generate, cache on disk, import.

The generated source is written to ``$NLD_CACHE_DIR`` (default ``~/.cache/nld/kernels``) under a name
that is the hash of the scene's *structure* (codegen.structure_key) and of nld's version, so numba's
on-disk cache (``cache=True``) is reused across processes and numbers never enter the key. The scene's
name is not in the key either: two scenes of the same structure share one kernel (and its compiled
integrators).
"""
from __future__ import annotations

import hashlib
import importlib.util
import json
import os
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from nld.version import __version__
from nld.kernel.codegen import columns, event_count, generate, structure_key
from nld.model.parameters import ParamLayout, build_layout, pack
from nld.model.scene_model import Scene
from nld.model.topology import Topology, build_topology, partition

_LOADED: dict[str, object] = {}
# one thread of a process writes and imports a kernel at a time (a study's route runs on a second
# thread, nld.study.Background): two imports of one module would compile it twice
_COMPILING = threading.RLock()


def cache_dir() -> Path:
    d = Path(os.environ.get("NLD_CACHE_DIR", Path.home() / ".cache" / "nld" / "kernels"))
    d.mkdir(parents=True, exist_ok=True)
    return d


@dataclass
class Kernel:
    """A compiled scene structure: generated functions plus the layout of its parameters."""
    scene: Scene
    topo: Topology
    layout: ParamLayout
    module: object
    key: str
    columns: list[str]
    n_events: int
    source_path: Path

    def __reduce__(self):
        # pickled as its scene: another process compiles it again (or loads it from the kernel
        # cache), so that results holding a kernel (periodic orbits, branches) cross processes
        return compile_scene, (self.scene,)

    @property
    def n_state(self) -> int:
        return 2 * len(self.topo.independent)

    @property
    def n_z(self) -> int:
        return self.z_layout.n

    @property
    def z_layout(self):
        """Where each discrete-state entry lives and the events' order (codegen.ZLayout)."""
        from nld.kernel.codegen import ZLayout
        return ZLayout(self.scene, self.topo)

    def init_modes(self, t: float, y, p, z) -> None:
        """Set the mode entries of z (switched loads, contact and stick/slip modes) consistently
        with the continuous state (t, y), in place (the kernel's generated ``init_modes``)."""
        self.module.init_modes(float(t), np.ascontiguousarray(y, dtype=float),
                               np.ascontiguousarray(p, dtype=float), z)

    def time_labels(self):
        """``f(t, y, p, z)`` setting in place the entries of z that the time decides (the branches
        of the scene's switched loads) as ``init_modes`` sets them, every other entry kept; None
        when the scene has no switched load. For restarts from a state reached at another time
        (``nld.systems.core.restart_labels``)."""
        idx = np.array(sorted(self.z_layout.load.values()), dtype=np.int64)
        if idx.size == 0:
            return None

        def relabel(t, y, p, z, _kern=self, _idx=idx):
            zz = np.array(z, dtype=float)
            _kern.init_modes(t, y, p, zz)
            z[_idx] = zz[_idx]
        return relabel

    def params(self, scene: Scene | None = None) -> np.ndarray:
        """Parameter vector of ``scene`` (default: the scene compiled) for this kernel."""
        s = scene or self.scene
        return pack(s, self.layout)

    def state_labels(self) -> list[str]:
        q = [self.topo.coords[k].label for k in self.topo.independent]
        return q + [lab + "_dot" for lab in q]


def kernel_dependencies() -> list[Path]:
    """The source files whose change must give a new kernel (see ``_generator_digest``)."""
    here = Path(__file__).resolve().parent.parent          # nld/
    files = [here / f for f in ("kernel/codegen.py", "kernel/autodiff.py", "model/topology.py",
                                "model/parameters.py", "kernel/support.py",
                                "settings.py")]   # settings: EVENT_SAMPLES
    # the integrators are not inlined into kernels any more (nld.integrators.core): an integrator
    # change leaves every kernel valid; nld.integrators.core.drop_stale_caches covers them
    return files + sorted((here / "laws").rglob("*.py"))


def drop_stale_numba_cache(source: Path) -> int:
    """Delete numba's disk cache of ``source`` (a module with ``@njit(cache=True)`` functions that
    call nld's integrators or laws) when a kernel dependency is newer than it; returns the count.

    numba checks only the timestamp of ``source`` itself, so after an upgrade of an integrator a
    hand-written module (benchmarks/handwritten_slider_crank.py) would run stale machine code."""
    source = Path(source).resolve()
    newest = max(f.stat().st_mtime for f in kernel_dependencies())
    n = 0
    for f in (source.parent / "__pycache__").glob(f"{source.stem}.*.nb[ic]"):
        try:
            stale = f.stat().st_mtime < newest
        except FileNotFoundError:       # another process (a test worker) removed it
            continue
        if stale:
            f.unlink(missing_ok=True)
            n += 1
    return n


def _generator_digest() -> str:
    """Hash of the source of the code generator and of every module the generated kernel calls.

    numba's disk cache checks only the timestamp of the generated file itself, not of the njit
    functions it calls (contact and friction laws, inlined into rhs); without them in the key an
    upgraded law would silently run the old code."""
    h = hashlib.sha1()
    for f in kernel_dependencies():
        h.update(f.read_bytes())
    return h.hexdigest()[:12]


def _import(path: Path, name: str):
    with _COMPILING:
        if name in _LOADED:
            return _LOADED[name]
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        sys.modules[name] = mod
        spec.loader.exec_module(mod)
        _LOADED[name] = mod
        return mod


def compile_scene(scene: Scene) -> Kernel:
    """Build (or fetch from cache) the kernel of a validated scene."""
    topo = build_topology(scene)
    if topo.cuts:
        from nld.model.assembly import constraint_jacobian_at_assembly
        partition(topo, constraint_jacobian_at_assembly(scene, topo))
    else:
        partition(topo, np.zeros((0, len(topo.coords))))
    layout = build_layout(scene)
    key_src = json.dumps({"v": __version__, "g": _generator_digest(), "s": structure_key(scene, topo),
                          "p": layout.names}, sort_keys=True, default=str)
    key = hashlib.sha1(key_src.encode()).hexdigest()[:16]
    # the name is the key alone: scenes that differ only in numbers (slider_crank and
    # slider_crank_olyaei) generate the same source and share one compiled kernel
    name = f"nld_kernel_{key}"
    path = cache_dir() / f"{name}.py"
    with _COMPILING:
        if not path.exists():
            src = generate(scene, topo, layout)
            tmp = path.with_suffix(f".tmp{os.getpid()}-{threading.get_ident()}")
            tmp.write_text(src)
            os.replace(tmp, path)
    mod = _import(path, name)
    return Kernel(scene, topo, layout, mod, key, columns(scene, topo), event_count(scene, topo), path)
