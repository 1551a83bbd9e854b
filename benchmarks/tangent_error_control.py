"""Does the tangent vector need to take part in the step-size control? lambda1 by lyapunov_tangent
with tangent_err=True (default) and False (state-only error control) on seven contact cases at two
tolerances, 30 revolutions of transient, 100 averaged. Results in benchmarks/results/lyapunov.md.

Run: python benchmarks/tangent_error_control.py   (about 5 min CPU, compilation included)
"""
import sys, time
from nld.systems.core import SceneSystem
from nld.analysis.lyapunov import lyapunov_tangent
cases = {
  "slider_crank": [],
  "stiff_K1e12": ["joints.B.contact.stiffness=1e12"],
  "olyaei_c1e-4_mu0.1": ["joints.B.clearance=1e-4"],
  "olyaei_mu0": ["joints.B.friction.mu=0.0"],
  "highspeed_10krpm": ["driver.speed=1047.2"],
  "four_bar": [],
  "tiny_c_1e-5": ["joints.B.clearance=1e-5"],
}
scene_of = {"olyaei_c1e-4_mu0.1": "slider_crank_olyaei", "olyaei_mu0": "slider_crank_olyaei", "four_bar": "four_bar"}
for name, ov in cases.items():
    S = SceneSystem(scene_of.get(name, "slider_crank"), ov)
    T = S.period
    for te in (True, False):
        for rtol in (1e-8, 1e-10):
            t0 = time.process_time()
            r = lyapunov_tangent(S, transient=30 * T, total=100 * T, rtol=rtol, tangent_err=te, progress=False)
            print(f"{name:22s} tangent_err={te!s:5s} rtol={rtol:.0e} lambda={r.per_revolution:8.3f} +- {r.uncertainty_per_revolution:.3f} /rev onsets/rev={r.diagnostics.get('onsets_per_period', float('nan')):.2f} cpu={time.process_time()-t0:.1f}s", flush=True)
