"""Per-call overhead of the Python fronts in front of the compiled-once integrator, side by side on a
tiny window of slider_crank (so the per-call cost dominates). Run: python benchmarks/bench_solve_front.py

* ``Kernel.module.solve``: the kernel's binding (nld.integrators.bind) -> ``dopri5`` (Python front:
  the model functions looked up as NativeFunction, the arrays and scalars coerced) -> dopri5_core;
* ``dopri5_core`` called directly with the NativeFunction objects made once (no front at all).
"""
import time

import numpy as np

from nld.integrators.core import INTERP_SIG, functions, native
from nld.integrators.dopri5 import dopri5_core, interp
from nld.kernel.compile import compile_scene
from nld.model.scene import load_scene
from nld.run.simulate import initial_state

k = compile_scene(load_scene("slider_crank")); m = k.module
y0, z0, _ = initial_state(k); p = k.params(k.scene)
te = np.array([0.0, 1e-5]); atol = np.full(y0.size, 1e-9)
args = lambda: (0.0, y0.copy(), te, False, p, z0.copy(), 1e-7, atol, 0.0, 1e-3, 10**6, k.n_events, 8, 3)
fns = functions(m.rhs, m.events, m.on_event) + (native(interp, INTERP_SIG),)
direct = lambda *a: dopri5_core(*fns, *a)
m.solve(*args()); direct(*args())
for name, f in (("Kernel.module.solve (bind + front)", m.solve), ("dopri5_core (direct)", direct)) * 2:
    a = [args() for _ in range(2000)]
    t0 = time.perf_counter()
    for x in a: f(*x)
    print(f"{name}: {(time.perf_counter() - t0) / 2000 * 1e6:.2f} us per call")

# The tolerance vector per call (stop 21): nld.run.simulate.tolerances walks the scene's geometry in
# Python; SceneSystem.tolerance (every advance() of the analyses) keeps the state scales.
from nld.run.simulate import tolerances
from nld.systems.core import SceneSystem
S = SceneSystem("slider_crank")
_, _, q = initial_state(S.kernel)
for name, f in (("tolerances(kernel, q, rtol)", lambda: tolerances(S.kernel, q, 1e-8)),
                ("SceneSystem.tolerance(rtol)", lambda: S.tolerance(1e-8))) * 2:
    t0 = time.perf_counter()
    for _ in range(2000):
        f()
    print(f"{name}: {(time.perf_counter() - t0) / 2000 * 1e6:.2f} us per call")
