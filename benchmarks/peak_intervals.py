"""Do peak intervals hold from one realisation to the next? (issue 29)

K independent realisations of a chaotic, impacting motion (seeded relative perturbations of
``EPS`` on the assembled starting state, then ``transient`` discarded revolutions), each with
``revs`` steady revolutions whose per-revolution maxima are located
(nld.analysis.extrema.revolution_maxima). Every realisation is cut into windows of ``window``
revolutions (20: the zhang2013 study's steady_revs); for each window three intervals are formed:

* ``± SE``: today's report, mean ± std/sqrt(n) (no level stated; about 68 % if the revolutions
  were independent);
* ``± t SE (95 %)``: the same standard error with the 95 % Student-t quantile;
* ``batch means (95 %)``: nld.analysis.peaks.peak_interval of the window.

and for the whole realisation (``revs`` revolutions) the last two. ``pool of G`` is
peak_interval over G realisations (window j of each: G x window revolutions). The reference is
the pooled value: the mean of every peak of the *other* realisations (leave-one-out, so a window
is not compared with itself; for a pool, those outside the pool). Counted: how many intervals
contain it, against the stated 95 %. Windows of one realisation are neighbours in time, so their
counts are not independent trials (the per-realisation and pool counts are).

Run: ``python benchmarks/peak_intervals.py [--quick]`` (writes benchmarks/results/peak_intervals.md
and .png; quick: fewer realisations and revolutions, results/peak_intervals_quick.*). Two worker
processes (NLD_WORKERS overrides).
"""
from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "studies"))
from _results import write_table  # noqa: E402

EPS = 1e-6                # relative perturbation of each state component (seeded normal)
WINDOW = 20               # revolutions per window: the zhang2013 study's steady_revs
GROUP = 5                 # realisations per pool
LEVEL = 0.95
# case -> (scene, overrides, columns {column: absolute}, K, transient, revs, samples_per_rev)
CASES = {
    "slider_crank": ("slider_crank", None, {"rod.omega": True, "B.Fn": False}, 30, 20, 200, 14400),
    "excavator f=0": ("excavator", "zhang_f0", {"rod.omega": True, "B.Fn": False}, 20, 10, 200, 14400),
}
QUICK = {"slider_crank": (10, 10, 40, 1440), "excavator f=0": (10, 5, 40, 3600)}


def _overrides(key):
    if key == "zhang_f0":
        import zhang2013_excavator as Z
        return Z.CASES["f=0"][2]
    return key


def realisation(case: str, seed: int, transient: int, revs: int, samples: int) -> dict:
    """One realisation: the located per-revolution maxima of the steady revolutions."""
    from nld.analysis.extrema import revolution_maxima
    from nld.kernel.compile import compile_scene
    from nld.model.scene import resolve_scene
    from nld.run.simulate import initial_state
    scene, ov, cols, *_ = CASES[case]
    sc = resolve_scene(scene, _overrides(ov))
    kern = compile_scene(sc)
    y, _, _ = initial_state(kern)
    rng = np.random.default_rng(seed)
    y0 = y * (1.0 + EPS * rng.standard_normal(y.size))
    t0 = time.perf_counter()
    run = revolution_maxima(sc, list(cols), revs=revs, transient_revs=transient, rtol=1e-7,
                            samples_per_rev=samples, keep_every=samples // 10, keep_revs=0,
                            refine_top=4, absolute=cols, kernel=kern, y0=y0,
                            max_steps_per_rev=1_000_000)
    wall = time.perf_counter() - t0
    m = run.maxima
    return dict(seed=seed, ok=run.success, message=run.message, wall_s=wall,
                peaks={c: m.loc[m["column"] == c].sort_values("rev")["peak"].to_numpy(float)
                       for c in cols})


def naive(x, t95=False):
    from scipy.stats import t as student_t
    se = x.std(ddof=1) / math.sqrt(x.size)
    return x.mean(), se * (student_t.ppf(0.5 + 0.5 * LEVEL, x.size - 1) if t95 else 1.0)


def analyse(series: list[np.ndarray]) -> dict:
    """Coverage counts of the pooled (leave-one-out) value; series: one array per realisation."""
    from nld.analysis.peaks import peak_interval
    K = len(series)
    tot, cnt = sum(s.sum() for s in series), sum(s.size for s in series)
    loo = [(tot - s.sum()) / (cnt - s.size) for s in series]
    res = {k: [0, 0, []] for k in ("se", "tse", "bm", "long_tse", "long_bm", "pool")}

    def add(key, inside, hw):
        res[key][0] += int(inside)
        res[key][1] += 1
        res[key][2].append(hw)
    nwin = min(s.size for s in series) // WINDOW
    first = []
    for k, s in enumerate(series):
        for j in range(nwin):
            x = s[j * WINDOW:(j + 1) * WINDOW]
            for key, (m, h) in (("se", naive(x)), ("tse", naive(x, True))):
                add(key, abs(m - loo[k]) <= h, h)
            iv = peak_interval(x, LEVEL)
            add("bm", iv.contains(loo[k]), iv.half_width)
            if j == 0:
                first.append((x.mean(), naive(x)[1], iv.half_width, iv.batch))
        m, h = naive(s, True)
        add("long_tse", abs(m - loo[k]) <= h, h)
        iv = peak_interval(s, LEVEL)
        add("long_bm", iv.contains(loo[k]), iv.half_width)
    for g in range(K // GROUP):
        members = range(g * GROUP, (g + 1) * GROUP)
        out = [s for k, s in enumerate(series) if k not in members]
        ref = sum(s.sum() for s in out) / sum(s.size for s in out)
        for j in range(nwin):
            iv = peak_interval([series[k][j * WINDOW:(j + 1) * WINDOW] for k in members], LEVEL)
            add("pool", iv.contains(ref), iv.half_width)
    pooled = peak_interval(series, LEVEL)
    # drift: window j pooled over the realisations (a transient shows as early windows off the rest)
    drift = [peak_interval([s[j * WINDOW:(j + 1) * WINDOW] for s in series], LEVEL) for j in range(nwin)]
    # decorrelation of the starts: spread of the first steady peak across realisations against the
    # spread of the peaks within a realisation (about 1 when the perturbation has grown to the attractor)
    spread = float(np.std([s[0] for s in series], ddof=1) / np.mean([s.std(ddof=1) for s in series]))
    return dict(res=res, pooled=pooled, first=first, loo=loo, drift=drift, spread=spread,
                taus=[peak_interval(s, LEVEL).tau for s in series])


LABELS = {"se": f"± SE ({WINDOW} revs; today)", "tse": f"± t SE, 95 % ({WINDOW} revs)",
          "bm": f"batch means, 95 % ({WINDOW} revs)", "long_tse": "± t SE, 95 % (whole realisation)",
          "long_bm": "batch means, 95 % (whole realisation)",
          "pool": f"pool of {GROUP} realisations × {WINDOW} revs, 95 %"}


def main(argv=None):
    import argparse
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--cases", nargs="*", default=list(CASES))
    a = ap.parse_args(argv)
    from nld.study import pool_map
    workers = int(os.environ.get("NLD_WORKERS", "2"))
    t_all = time.perf_counter()
    results = {}
    for case in a.cases:
        K, tr, revs, samples = QUICK[case] if a.quick else CASES[case][3:]
        t0 = time.perf_counter()
        runs = pool_map(realisation, [(case, seed, tr, revs, samples) for seed in range(K)], workers)
        bad = [r for r in runs if not r["ok"] or any(np.any(~np.isfinite(p)) for p in r["peaks"].values())]
        if bad:
            raise SystemExit(f"{case}: {len(bad)} realisation(s) failed: {bad[0]['message']}")
        results[case] = dict(K=K, transient=tr, revs=revs, samples=samples, wall=time.perf_counter() - t0,
                             cpu=sum(r["wall_s"] for r in runs),
                             cols={c: analyse([r["peaks"][c] for r in runs]) for c in CASES[case][2]})
        print(f"{case}: {K} realisations in {results[case]['wall']:.0f} s")
    tag = "_quick" if a.quick else ""
    out = HERE / "results" / f"peak_intervals{tag}.md"
    head = ["# Peak intervals across realisations (issue 29)", "",
            f"`python benchmarks/peak_intervals.py{' --quick' if a.quick else ''}` "
            f"({time.perf_counter() - t_all:.0f} s wall, {workers} workers). Per case: K realisations "
            f"from the assembled state perturbed by a seeded relative {EPS:g} normal, a transient, then "
            f"the steady revolutions; rtol 1e-7. Reference: the pooled mean of the other realisations "
            f"(leave-one-out; for a pool, the realisations outside it). Stated rate 95 % except "
            f"'± SE' (today's report, about 68 % for independent revolutions). "
            f"Windows of one realisation are neighbours in time: their counts are not independent "
            f"trials. Figure: peak_intervals{tag}.png.", ""]
    for case, R in results.items():
        head.append(f"- {case}: K = {R['K']} realisations × ({R['transient']} transient + {R['revs']} "
                    f"steady revolutions), {R['samples']} detection samples per revolution; "
                    f"{R['cpu']:.0f} CPU s ({R['cpu'] / (R['K'] * (R['transient'] + R['revs'])):.3f} s per "
                    f"revolution)")
        for c, A in R["cols"].items():
            p = A["pooled"]
            head.append(f"  - {c}: pooled {p.mean:.5g} ± {p.half_width:.2g} ({p.describe()}); integrated "
                        f"autocorrelation time of the realisations: median {np.median(A['taus']):.2g}, "
                        f"range {min(A['taus']):.2g} - {max(A['taus']):.2g} revolutions; first steady "
                        f"peak's spread across realisations / spread within one: {A['spread']:.2f}; "
                        f"window means pooled over the realisations, by window: "
                        + ", ".join(f"{d.mean:.4g} ± {d.half_width:.2g}" for d in A["drift"]))
    head += ["", "| case | quantity | interval | contain the pooled value | rate | stated | median half-width |",
             "|---|---|---|---|---|---|---|"]
    rows = []
    for case, R in results.items():
        for c, A in R["cols"].items():
            for key, lab in LABELS.items():
                k, n, hw = A["res"][key]
                if n == 0:
                    continue
                stated = "~68 %" if key == "se" else "95 %"
                rows.append(f"| {case} | {c} | {lab} | {k} / {n} | {k / n:.2f} | {stated} | "
                            f"{np.median(hw):.3g} |")
    write_table(out, head, rows)
    figure(results, out.with_suffix(".png"))


def figure(results, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    panels = [(case, c, A) for case, R in results.items() for c, A in R["cols"].items()]
    fig, axes = plt.subplots(len(panels), 1, figsize=(9, 2.6 * len(panels)), squeeze=False)
    for ax, (case, c, A) in zip(axes[:, 0], panels):
        f = np.array(A["first"])
        k = np.arange(len(f))
        ax.errorbar(k - 0.15, f[:, 0], yerr=f[:, 1], fmt="o", ms=3, color="0.5", capsize=2,
                    label=f"± SE (today), first {WINDOW} revs")
        ax.errorbar(k + 0.15, f[:, 0], yerr=f[:, 2], fmt="o", ms=3, color="tab:blue", capsize=2,
                    label="batch means, 95 %")
        p = A["pooled"]
        ax.axhline(p.mean, color="tab:red", lw=1, label="pooled (all realisations)")
        ax.axhspan(p.lower, p.upper, color="tab:red", alpha=0.15)
        ax.set_title(f"{case}: per-revolution max of {c}", fontsize=9)
        ax.set_xlabel("realisation (seed)")
        ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
