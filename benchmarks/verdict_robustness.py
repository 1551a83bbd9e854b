"""Do the reported verdicts hold at 100x tighter rtol and 4x the averaging span?

For cases of the rhee1996 and olyaei2012 reports: lambda1 (tangent estimator) after the given
transient at the report's rtol and averaging span, then at rtol / 100 over 4x the span.
Results in docs/studies.md ("Verdict robustness"). Run: python benchmarks/verdict_robustness.py
[case names]  (about 6 min on one core).
"""
import sys, time
from nld.systems.core import SceneSystem
from nld.analysis.lyapunov import lyapunov_tangent
cases = [  # name, scene, overrides, report rtol, report revs, transient revs
    ("rhee c=0.05mm mu=0.01", "four_bar", ["joints.B.clearance=5e-5", "joints.B.friction.mu=0.01"], 1e-8, 200, 100),
    ("rhee c=0.25mm mu=0", "four_bar", ["joints.B.friction.mu=0.0"], 1e-8, 200, 100),
    ("rhee c=0.25mm mu=0.02", "four_bar", ["joints.B.friction.mu=0.02"], 1e-8, 200, 100),
    ("rhee c=0.25mm mu=0.1", "four_bar", ["joints.B.friction.mu=0.1"], 1e-8, 200, 100),
    ("olyaei mu=0.05 5000rpm", "slider_crank_olyaei", ["joints.B.friction.mu=0.05"], 1e-10, 64, 100),
    ("olyaei mu=0 5000rpm", "slider_crank_olyaei", ["joints.B.friction.mu=0.0"], 1e-10, 64, 100),
    ("olyaei c=0.1mm mu=0.1", "slider_crank_olyaei", ["joints.B.clearance=1e-4"], 1e-10, 64, 100),
]
sel = sys.argv[1:] or [c[0] for c in cases]
for name, scene, ov, rt, revs, tr in cases:
    if name not in sel:
        continue
    S = SceneSystem(scene, ov)
    T = S.period
    for rtol, n in ((rt, revs), (rt / 100, 4 * revs)):
        t0 = time.time()
        r = lyapunov_tangent(S, transient=tr * T, total=n * T, rtol=rtol, progress=False)
        lam, u = r.per_revolution, r.uncertainty_per_revolution
        v = "chaotic" if lam - u > 0 else "regular" if lam + u < 0 else "uncertain"
        print(f"{name:26s} rtol={rtol:.0e} revs={n:4d} lambda={lam:8.3f} +- {u:.3f} /rev {v:9s} "
              f"onsets/rev={r.diagnostics.get('onsets_per_period', float('nan')):.2f} wall={time.time()-t0:.0f}s", flush=True)
