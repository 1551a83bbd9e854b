"""λ1 of a permanent-contact motion against the contact memory it was left with (issue 25, item 3).

slider_crank_olyaei at its defaults (c = 0.1 mm, mu = 0.1) settles into permanent contact: no
contact onset, so the Lankarani-Nikravesh onset velocity v- recorded at the last impact is never
reset and sets the contact damping for good. This script takes the state after a transient, sets
the memory to factor x its recorded value (factors 0.3 ... 10) and measures λ1 per revolution by the
tangent estimator over the same span from the same state. A motion whose exponent moves with a
value chosen by the history is "permanent contact", not chaotic or regular (docs/contact-laws.md).

    python benchmarks/memory_dependence.py        # ~1 min on 2 cores

Writes benchmarks/results/memory_dependence.md and .png.
"""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _results import write_table  # noqa: E402

FACTORS = [0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0]
TRANSIENT, REVS, RTOL = 100, 50, 1e-10


def main() -> None:
    import copy
    from matplotlib.figure import Figure
    from nld.analysis.lyapunov import lyapunov_tangent
    from nld.systems.core import SceneSystem, advance
    s = SceneSystem("slider_crank_olyaei")
    y, z = advance(s, s.y0, s.z0, 0.0, TRANSIENT * s.period, RTOL)
    mem = int(s.memory[0])
    v0 = float(z[mem])
    rows, lam, unc, onsets = [], [], [], []
    for f in FACTORS:
        c = copy.copy(s)
        zz = z.copy()
        zz[mem] = f * v0
        c.y0, c.z0 = y.copy(), zz
        r = lyapunov_tangent(c, transient=0.0, total=REVS * s.period, rtol=RTOL, progress=False)
        d = r.diagnostics
        lam.append(r.per_revolution)
        unc.append(r.uncertainty_per_revolution)
        onsets.append(d.get("onsets_per_period", float("nan")))
        rows.append(f"| {f:g} | {f * v0:.4g} | {r.per_revolution:.4g} ± "
                    f"{r.uncertainty_per_revolution:.2g} | {d.get('onsets_per_period'):.3g} | "
                    f"{d.get('permanent_contact')} |")
        print(rows[-1], flush=True)
    out = Path(__file__).resolve().parent / "results"
    fig = Figure(figsize=(5.6, 3.8), layout="constrained")
    ax = fig.add_subplot()
    ax.errorbar(np.array(FACTORS) * v0 * 1e3, lam, yerr=unc, fmt="o-", capsize=3)
    ax.axvline(v0 * 1e3, color="0.5", ls=":", label="recorded at the last onset")
    ax.set_xscale("log")
    ax.set_xlabel("contact memory v⁻ (onset approach velocity) [mm/s]")
    ax.set_ylabel("λ1 [per revolution]")
    ax.set_title("slider_crank_olyaei, permanent contact: λ1 depends on the memory")
    ax.legend(fontsize=8)
    fig.savefig(out / "memory_dependence.png", dpi=130)
    head = ["# λ1 of a permanent-contact motion against its contact memory", "",
            f"`python benchmarks/memory_dependence.py`: slider_crank_olyaei (defaults: c = 0.1 mm, "
            f"μ = 0.1, Lankarani-Nikravesh), state after {TRANSIENT} revolutions at rtol {RTOL:g}; "
            f"the memory (B.v_onset, recorded {v0:.4g} m/s) set to factor × that value; λ1 by the "
            f"tangent estimator over {REVS} revolutions from the same state. Figure: "
            f"memory_dependence.png.", "",
            "| factor | v⁻ [m/s] | λ1 per revolution | onsets per revolution | permanent contact |",
            "|---|---|---|---|---|"]
    write_table(out / "memory_dependence.md", head, rows)


if __name__ == "__main__":
    main()
