"""Study: what it takes to reach the seed paper's numbers (issue 28), on scene ``excavator``.

    nld study zhang2013_sensitivity [--quick] [--out DIR]

The seed paper (Zhang, Liu, Xu, Hou 2013) states max |rod omega| = 40 rad/s at f = 0 and 90 rad/s at
f = 0.05 (r1 = 0.07, r2 = 0.03 mm), 20 and 200 rad/s at r1 = r2 = 0.01 and 0.5 mm (f = 0.01); the
scene (docs/models/excavator.md) gives 4-10 times less and a peak that falls with f. The paper leaves
out or garbles the values that could explain it. This study varies each of them, one at a time
and in the pairs that matter, and measures the located per-revolution peak of |rod omega|
(nld.analysis.extrema.revolution_maxima) over ``steady_revs`` revolutions after ``transient_revs``,
as mean +- 95 % interval (nld.analysis.peaks.peak_interval), at each base case:

* ``damping``: contact damping C1n, C2n as a multiple of the scene's (0 = undamped Hertz);
* ``M43``: the crushing torque (loads.0.value, N m);
* ``K2``: contact stiffness at B, as printed (3.91e7), the scene's Hertz value (3.66e11), steel;
* ``l4``, ``R``: the cutter head's pivot D = (l4, R - l3) within the feasible geometry (the crank
  still turns, the head's swing contains theta3 = pi/2 where eq. 20 switches; the ideal-joint
  swing and transmission angle are stored per point);
* ``motor inertia``, ``motor slope``: the crank driven by a motor, T = T0 - k (omega - omega1), with
  rotor inertia J (driver.mode = "torque"; T0 = the mean torque of the constant-speed run);
* ``friction``: f at A and B for several readings of the friction law, among them the paper's
  eqs 12-17 read literally, whose friction moments on the rod drive the relative rotation instead
  of resisting it (an experiment: the Ambrosio law with the sign of mu reversed in the kernel's
  parameters, ``reversed_kernel``; the core laws are not changed);
* pairs: damping x M43 (the two unknowns that set the energy of the rattle).

Every point is one run from the assembled state (hybrid Coulomb stick/slip modes, damped Hertz
contact unless varied, rtol ``rtol``). Finished points are kept under ``<out>/.work/`` (one JSON file
each) and reused when the study is run again (Ctrl-C, then the same command, resumes). Outputs:
``zhang2013_sensitivity.pdf``, ``_summary.csv`` (one row per point), ``_peaks.csv`` (every located
per-revolution peak), each with its ``.csv.json`` provenance. :func:`paper_page` draws the page
"What it takes to reach the paper's numbers" from the summary CSV; the zhang2013 study calls it.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd

SCENE = "excavator"
STEM = "zhang2013_sensitivity"
TITLE = "Zhang et al. (2013) excavator: what it takes to reach the paper's numbers"
CITATION = ("Zhang Su-xia, Liu Xi-jun, Xu Long-xu, Hou Shu-jun (2013), \"Nonlinear dynamic analysis of "
            "low-noise excavating system with two clearances\", Journal of Vibroengineering 15(3), "
            "paper 1129")
INTERRUPT_KEEPS = ("the finished points are kept under <out>/.work/; run the same command again to "
                   "resume from them")

# per point: transient_revs discarded, then steady_revs whose located peaks give the mean and interval;
# detection samples per revolution and peak refinement as in the zhang2013 study (its docs: 14400
# locate the peaks to 5e-7); max_steps_per_rev stops a run whose steps explode (reported failed).
_RUN = dict(rtol=1e-7, samples_per_rev=14400, keep_every=40, refine_top=4, peak_rtol=1e-6,
            max_steps_per_rev=1_000_000, workers=2)
FULL = dict(_RUN, transient_revs=10, steady_revs=20,
            bases=["f=0", "f=0.05", "r=0.01mm", "r=0.5mm"],
            damping=[0.0, 0.03, 0.1, 0.3, 1.0, 3.0], m43=[0.0, 600.0, 1200.0, 2400.0, 4800.0, 7200.0],
            k2=[3.91e7, 3.91e9, 3.66e11, 5.54e11], l4=[0.115, 0.1225, 0.13, 0.1375, 0.145],
            R=[0.465, 0.515, 0.565, 0.665, 0.765], motor_inertia=[0.01, 0.1, 1.0],
            motor_slope=[10.0, 100.0, 1000.0], motor=(0.1, 100.0),
            pair_damping=[0.0, 0.1, 0.3], pair_m43=[0.0, 2400.0, 4800.0, 7200.0],
            literal_damping=[0.0, 0.1, 0.3, 0.5, 0.55, 0.6, 0.65, 0.7, 1.0, 2.0, 3.0],
            frictions=[0.0, 0.01, 0.02, 0.05, 0.1],
            readings=["coulomb", "coulomb, undamped", "ambrosio", "eq. 17 literal", "eq. 17 literal, damping x3"],
            clearance_sweeps=["damping", "M43", "K2", "pairs"], long_revs=150)
QUICK = dict(_RUN, transient_revs=1, steady_revs=3, samples_per_rev=3600, workers=1,
             bases=["f=0", "f=0.05"], damping=[0.0, 1.0], m43=[4800.0], k2=[3.91e7], l4=[], R=[],
             motor_inertia=[0.1], motor_slope=[], motor=(0.1, 100.0), pair_damping=[], pair_m43=[], literal_damping=[],
             frictions=[0.0, 0.05], readings=["coulomb", "eq. 17 literal"], clearance_sweeps=[], long_revs=0)
SMOKE = dict(QUICK, transient_revs=0, steady_revs=2, samples_per_rev=720, keep_every=8, refine_top=2, workers=1,
             damping=[1.0], m43=[], k2=[], motor_inertia=[], frictions=[], readings=[])
MODE_LABELS = {"quick": "QUICK MODE: {transient_revs} + {steady_revs} revolutions, a few points",
               "smoke": "SMOKE MODE (test only): {transient_revs} + {steady_revs} revolutions"}

# base cases: name -> (overrides, the paper's max |rod omega| in rad/s, colour)
BASES = {
    "f=0": (["joints.A.friction.mu=0.0", "joints.B.friction.mu=0.0"], 40.0, "tab:blue"),
    "f=0.05": (["joints.A.friction.mu=0.05", "joints.B.friction.mu=0.05"], 90.0, "tab:red"),
    "r=0.01mm": (["joints.A.friction.mu=0.01", "joints.B.friction.mu=0.01", "joints.A.clearance=1e-05",
                  "joints.B.clearance=1e-05"], 20.0, "tab:green"),
    "r=0.5mm": (["joints.A.friction.mu=0.01", "joints.B.friction.mu=0.01", "joints.A.clearance=0.0005",
                 "joints.B.clearance=0.0005"], 200.0, "tab:purple"),
}
# the unknowns: name -> (axis label, log axis)
SWEEPS = {"damping": ("contact damping C1n, C2n / the scene's [-]", True),
          "M43": ("crushing torque M43 [N m]", False),
          "K2": ("contact stiffness K2 [N/m^1.5]", True),
          "l4": ("l4 (pivot D = (l4, R - l3)) [m]", False),
          "R": ("R (pivot D = (l4, R - l3)) [m]", False),
          "motor inertia": ("motor: rotor inertia J [kg m^2] (k = {k:g} N m s/rad)", True),
          "motor slope": ("motor: slope k [N m s/rad] (J = {J:g} kg m^2)", True),
          "friction": ("friction coefficient f at A and B [-]", False)}
# a paper value counts as reached when the interval of the mean overlaps [value / FACTOR, value x FACTOR]
# (the paper's numbers are read off the text of one run: "the maximum angular velocity is 40 rad/s")
FACTOR = 1.5
LEVEL = 0.95
MIN_TREND = 5       # revolutions needed to call a point's peaks growing (a line through them)


# ------------------------------------------------------------------------------------- the grid


def defaults(scene) -> dict:
    """The scene's values of the unknowns (SI units), read from the scene, not assumed."""
    cut = scene.bodies["cutter"].points
    return {"C1n": scene.joints["A"].contact.damping, "C2n": scene.joints["B"].contact.damping,
            "M43": float(scene.loads[0].value), "K2": scene.joints["B"].contact.stiffness,
            "l4": scene.ground_points["D"][0], "rho": scene.ground_points["D"][1],
            "ls3": cut["B"][0], "l3": cut["B"][0] - cut["C"][0], "speed": scene.driver.speed}


def _damping(d, s):
    return [f"joints.A.contact.damping={d['C1n'] * s!r}", f"joints.B.contact.damping={d['C2n'] * s!r}"]


def _pivot(d, l4, rho):
    return [f"ground.points.D=[{l4!r},{rho!r}]", f"bodies.cutter.points.D=[{rho + d['ls3']!r},0.0]"]


def _friction(reading, f):
    """Overrides and the reversed flag of one reading of the friction law at coefficient f."""
    mu = [f"joints.A.friction.mu={f!r}", f"joints.B.friction.mu={f!r}"]
    amb = ['joints.A.friction.law="ambrosio"', 'joints.B.friction.law="ambrosio"'] if f > 0 else []   # f = 0: no friction
    return {"coulomb": (mu, False, 1.0), "coulomb, undamped": (mu, False, 0.0), "ambrosio": (mu + amb, False, 1.0),
            "eq. 17 literal": (mu + amb, True, 1.0), "eq. 17 literal, damping x3": (mu + amb, True, 3.0)}[reading]


def grid(st: dict, d: dict) -> list[dict]:
    """Every point of the study: base, sweep, series (a line of a figure), x, overrides, reversed
    (the eq. 17 experiment), motor (J, k) for a torque-driven crank (T0 filled in later)."""
    pts = []

    def add(base, sweep, x, ov, series="", reversed_=False, motor=None, revs=None):
        pts.append(dict(base=base, sweep=sweep, series=series, x=float(x), reversed=reversed_, motor=motor,
                        overrides=(BASES[base][0] if base in BASES else []) + ov,
                        revs=revs or (st["transient_revs"], st["steady_revs"])))
    friction_bases = [b for b in st["bases"] if b.startswith("f=")]
    for b in st["bases"]:
        swept = ["damping", "M43", "K2", "l4", "R", "motor"] if b in friction_bases else st["clearance_sweeps"]
        for s in st["damping"] if "damping" in swept else []:
            add(b, "damping", s, _damping(d, s))
        for m in st["m43"] if "M43" in swept else []:
            add(b, "M43", m, [f"loads.0.value={m!r}"])
        for k in st["k2"] if "K2" in swept else []:
            add(b, "K2", k, [f"joints.B.contact.stiffness={k!r}"])
        for l4 in st["l4"] if "l4" in swept else []:
            add(b, "l4", l4, _pivot(d, l4, d["rho"]))
        for R in st["R"] if "R" in swept else []:
            add(b, "R", R, _pivot(d, d["l4"], R - d["l3"]))
        J0, k0 = st["motor"]
        for J in st["motor_inertia"] if "motor" in swept else []:
            add(b, "motor inertia", J, [], motor=(J, k0))
        for k in st["motor_slope"] if "motor" in swept else []:
            add(b, "motor slope", k, [], motor=(J0, k))
        if b in friction_bases:
            f = float(b[2:])
            law = ['joints.A.friction.law="ambrosio"', 'joints.B.friction.law="ambrosio"'] if f > 0 else []
            for s in st["literal_damping"]:
                add(b, "damping", s, law + _damping(d, s), series="eq. 17 literal", reversed_=f > 0)
        if b in friction_bases and st["long_revs"]:         # undamped: does the rattle settle?
            add(b, "long run", 0.0, _damping(d, 0.0), series=f"undamped, 0 + {st['long_revs']} revolutions",
                revs=(0, st["long_revs"]))
        if b in friction_bases or "pairs" in swept:
            for s in st["pair_damping"]:
                for m in st["pair_m43"]:
                    add(b, "M43", m, _damping(d, s) + [f"loads.0.value={m!r}"], series=f"damping x{s:g}")
    for r in st["readings"]:
        for f in st["frictions"]:
            ov, rev, s = _friction(r, f)
            add("friction", "friction", f, ov + _damping(d, s), series=r, reversed_=rev and f > 0)
    for p in pts:
        p["f"] = float(next((o.split("=")[1] for o in p["overrides"] if o.startswith("joints.A.friction.mu=")),
                            "nan"))
        p["key"] = hashlib.sha1(json.dumps([p["overrides"], p["reversed"], p["motor"],
                                            {k: st[k] for k in _RUN if k != "workers"},
                                            p["revs"]]).encode()).hexdigest()[:16]
    return pts


# ------------------------------------------------------------------------------------- one point


class reversed_kernel:
    """A compiled kernel whose parameter vector carries -mu at A and B: the friction force acts
    along the slip instead of against it (the paper's eqs 12-17 read literally, docs/models/excavator.md
    §5). An experiment through the kernel's parameters; the friction laws are not changed."""

    def __init__(self, kernel):
        self._k = kernel

    def __getattr__(self, name):
        return getattr(self._k, name)

    def params(self, scene=None):
        p = self._k.params(scene)
        for j in ("A", "B"):
            i = self._k.layout.index[f"joints.{j}.friction.mu"]
            p[i] = -p[i]
        return p


def geometry(scene) -> dict:
    """Ideal-joint swing of the cutter head (theta3 range, deg), transmission angle range (deg) and
    the largest distance (deg of crank angle) of the head's reversals from crank 0 and pi (eq. 19)."""
    from nld.model.ideal import ideal_solution
    t = np.linspace(0.0, 2 * math.pi / scene.driver.speed, 1441)
    s = ideal_solution(scene, t)
    th3, w3 = s["cutter.theta"].to_numpy(), s["cutter.omega"].to_numpy()
    trans = np.degrees(np.abs(th3 - s["rod.theta"].to_numpy()))
    crank = np.degrees(s["driver.angle"].to_numpy()) % 360.0
    rev = crank[1:][np.sign(w3[1:]) != np.sign(w3[:-1])]
    off = max((min(abs(c - 180.0), abs(c), abs(360.0 - c)) for c in rev), default=float("nan"))
    return dict(theta3_min=float(np.degrees(th3.min())), theta3_max=float(np.degrees(th3.max())),
                transmission_min=float(trans.min()), transmission_max=float(trans.max()), reversal_offset=off)


def run_point(p: dict, st: dict, work: str, show: bool, i: int, n: int) -> dict:
    """One point: its record (point fields, peak statistics, run statistics) and per-revolution
    peaks, from ``work/KEY.json`` if a run of this code and these settings finished it before."""
    from nld.analysis.extrema import revolution_maxima
    from nld.analysis.peaks import peak_interval
    from nld.model.scene import resolve_scene
    from nld.output.io import json_default
    from nld.progress import stage
    path = Path(work) / f"{p['key']}.json"
    if path.is_file():          # finished before (or the same run under another sweep's name)
        try:
            rec = json.loads(path.read_text(encoding="utf-8"))
            return dict(rec, **{k: v for k, v in p.items() if k not in ("overrides", "motor", "revs")})
        except (OSError, ValueError):
            pass
    stage(STEM, f"point {i} of {n}: {p['base']}, {p['sweep']} = {p['x']:g} {p['series']}".rstrip(), enabled=show)
    ov = list(p["overrides"])
    if p["motor"]:
        J, k, T0 = p["motor"]
        ov += ['driver.mode="torque"', f"driver.inertia={J!r}", f"driver.torque_slope={k!r}", f"driver.torque={T0!r}"]
    scene = resolve_scene(SCENE, ov)
    kern = None
    if p["reversed"]:
        from nld.kernel.compile import compile_scene
        kern = reversed_kernel(compile_scene(scene))
    t0 = time.perf_counter()
    tr, n_revs = p["revs"]
    run = revolution_maxima(scene, ["rod.omega"], revs=n_revs, transient_revs=tr,
                            rtol=st["rtol"], samples_per_rev=st["samples_per_rev"], keep_every=st["keep_every"],
                            refine_top=st["refine_top"], peak_rtol=st["peak_rtol"], kernel=kern,
                            max_steps_per_rev=st["max_steps_per_rev"], progress=False)
    pk = run.maxima["peak"].to_numpy(float) if run.success else np.zeros(0)
    w = run.table["rod.omega"].to_numpy(float) if len(run.table) else np.zeros(0)
    rec = {k: v for k, v in p.items() if k not in ("overrides", "motor", "revs")}
    rec.update(overrides=" ".join(ov), success=bool(run.success and len(pk) == n_revs),
               transient_revs=tr, steady_revs=n_revs,
               message=run.message, t_reached=float(run.t_reached), steps=int(run.stats.get("accepted", 0)),
               rejected=int(run.stats.get("rejected", 0)), events=int(run.events), wall_s=time.perf_counter() - t0,
               motor_J=p["motor"][0] if p["motor"] else None, motor_k=p["motor"][1] if p["motor"] else None,
               motor_T0=p["motor"][2] if p["motor"] else None, peaks=[float(v) for v in pk],
               sampled_max=float(np.nanmax(np.abs(w))) if w.size else None)
    if rec["success"]:
        iv = peak_interval(pk, LEVEL)
        r = np.arange(pk.size, dtype=float)
        slope, icpt = np.polyfit(r, pk, 1)
        res = pk - (slope * r + icpt)
        se = float(np.sqrt(res @ res / max(pk.size - 2, 1) / ((r - r.mean()) @ (r - r.mean()))))
        steady = run.table[run.table["t"] >= tr * 2 * math.pi / st["speed"] - 1e-12]
        rec.update(mean=iv.mean, half_width=iv.half_width, batch=iv.batch, tau=iv.tau, min=float(pk.min()),
                   max=float(pk.max()), slope=float(slope), slope_se=se,
                   growing=bool(pk.size >= MIN_TREND and slope - 2 * se > 0 and slope * pk.size > 0.1 * iv.mean),
                   mean_torque=float(steady["driver.torque"].mean()),
                   crank_speed_min=float(steady["crank.omega"].min()), crank_speed_max=float(steady["crank.omega"].max()))
    if p["sweep"] in ("l4", "R"):
        rec.update(geometry(scene))
    tmp = path.with_suffix(f".tmp{os.getpid()}")
    tmp.write_text(json.dumps(rec, default=json_default), encoding="utf-8")
    os.replace(tmp, path)
    return rec


def run_grid(study, st: dict, workers: int) -> list[dict]:
    """Every point of :func:`grid`, the constant-speed ones first (they give the motor's T0), on
    ``workers`` processes, each finished point kept in the study's work directory."""
    import shutil

    from nld.model.scene import load_scene
    from nld.progress import progress_enabled
    d = dict(defaults(load_scene(SCENE)))
    st["speed"] = d["speed"]
    work = study.work_dir("points")
    for old in work.parent.glob(f"{STEM}-*-points-*"):
        if old != work and old.is_dir():
            shutil.rmtree(old, ignore_errors=True)       # points of other code or another mode
    work.mkdir(parents=True, exist_ok=True)
    pts = grid(st, d)
    first = list({p["key"]: p for p in pts if not p["motor"]}.values())     # one run per distinct point
    first.sort(key=lambda p: (-sum(p["revs"]), not any(o.endswith("damping=0.0") for o in p["overrides"]),
                              not p["reversed"]))                              # the long ones first
    n_motor = len({p["key"] for p in pts if p["motor"]})
    n, show = len(first) + n_motor, progress_enabled()
    study.stage(f"{n} distinct points ({len(pts)} in the figures), {st['transient_revs']} + {st['steady_revs']} "
                f"revolutions each ({workers} workers)")
    runs = {r["key"]: r for r in study.map(run_point, [(p, st, str(work), show, i + 1, n)
                                                       for i, p in enumerate(first)], workers)}
    ref = {p["base"]: runs[p["key"]].get("mean_torque") for p in pts
           if p["sweep"] == "damping" and p["x"] == 1.0 and not p["series"]}    # T0: the speed-driven crank's mean
    for p in pts:
        if p["motor"]:
            p["motor"] = (*p["motor"], ref[p["base"]])
            p["key"] += hashlib.sha1(repr(p["motor"][2]).encode()).hexdigest()[:6]
    rest = list({p["key"]: p for p in pts if p["motor"]}.values())
    runs.update({r["key"]: r for r in study.map(run_point, [(p, st, str(work), show, len(first) + i + 1, n)
                                                            for i, p in enumerate(rest)], workers)})
    return [dict(runs[p["key"]], **{k: v for k, v in p.items() if k not in ("overrides", "motor", "revs")}) for p in pts]


def tables(records: list[dict]) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(summary: one row per point, peaks: one row per point and steady revolution)."""
    summary = pd.DataFrame([{k: v for k, v in r.items() if k != "peaks"} for r in records])
    summary.insert(3, "paper", [BASES[b][1] if b in BASES else math.nan for b in summary["base"]])
    peaks = pd.DataFrame([dict(key=r["key"], base=r["base"], sweep=r["sweep"], series=r["series"], x=r["x"],
                               rev=i, peak=v) for r in records for i, v in enumerate(r["peaks"])])
    return summary, peaks


# ------------------------------------------------------------------------------------- the answer


def clean(summary: pd.DataFrame) -> pd.DataFrame:
    """The summary as written, or as read back from its CSV (empty series read as NaN)."""
    s = summary.copy()
    s["series"] = s["series"].astype(object).where(s["series"].notna(), "").astype(str)
    s["success"] = s["success"].astype(bool)
    s["growing"] = s["growing"].fillna(False).astype(bool) if "growing" in s else False
    s["state"] = states(s)
    s["run"] = run_ids(s)
    return s


STATES = ("steady", "transient", "runaway", "failed")


def states(summary: pd.DataFrame) -> list[str]:
    """Each point's state, which decides whether its peaks give a statistic: "failed" (the run
    stopped), "runaway" (friction along the slip, the paper's eq. 17 read literally, with f > 0:
    the friction pair feeds energy into the rattle, so the level it reaches is that of a runaway,
    not a property of the machine), "transient" (the per-revolution peaks still grow across the
    window, ``growing``), else "steady". Only steady points are reported as mean ± interval."""
    out = []
    for r in summary.to_dict("records"):
        f = r.get("f")
        rev = bool(r.get("reversed")) if r.get("reversed") == r.get("reversed") else False
        if not bool(r.get("success")):
            out.append("failed")
        elif rev and f == f and f is not None and float(f) > 0.0:
            out.append("runaway")
        elif bool(r.get("growing")):
            out.append("transient")
        else:
            out.append("steady")
    return out


def run_ids(summary: pd.DataFrame) -> list[str]:
    """An id of the run each point is, the same for points that set the same model: overrides
    equal to the scene's own value are dropped (damping = 1 x the scene's, M43 = 1200 N m,
    K2 = 3.66e11 and l4 = 0.13 m at a base case are all the base case's run), then the rest,
    the friction reading (reversed) and the motor are hashed."""
    from nld.model.scene import load_scene, scene_to_dict
    scene = scene_to_dict(load_scene(SCENE))

    def value(key):
        node = scene
        for part in key.split("."):
            if isinstance(node, list):
                node = node[int(part)] if part.isdigit() and int(part) < len(node) else None
            elif isinstance(node, dict):
                node = node.get(part)
            else:
                return None
        return node

    def same(a, b):
        try:
            return bool(np.allclose(np.asarray(a, dtype=float), np.asarray(b, dtype=float), rtol=1e-12, atol=0.0))
        except (TypeError, ValueError):
            return a == b

    out = []
    for r in summary.to_dict("records"):
        ovs = r.get("overrides")
        ovs = ovs if isinstance(ovs, list) else str(ovs or "").split()
        kept = []
        for o in ovs:
            k, _, v = str(o).partition("=")
            try:
                v = json.loads(v)
            except ValueError:
                pass
            if not same(v, value(k)):
                kept.append(f"{k}={v!r}")
        motor = [r.get(c) for c in ("motor_J", "motor_k") if r.get(c) == r.get(c) and r.get(c) is not None]
        rev = bool(r.get("reversed")) if r.get("reversed") == r.get("reversed") else False
        out.append(hashlib.sha1(json.dumps([sorted(kept), rev, motor], default=str).encode()).hexdigest()[:16])
    return out


def steady(summary: pd.DataFrame) -> pd.DataFrame:
    """The points whose peaks give a statistic (state "steady"), each distinct run once."""
    s = clean(summary) if "state" not in summary else summary
    return s[s["state"] == "steady"].drop_duplicates("run")


def trend_rows(summary: pd.DataFrame) -> pd.DataFrame:
    """Every setting run at both f = 0 and f = 0.05 (the friction bases, or a reading of the
    friction law): the two means, the change and its verdict, and whether each paper value is reached."""
    summary = clean(summary)
    s = summary[summary["success"]]
    rows = []
    seen: dict = {}
    fb = s[s["base"].isin(["f=0", "f=0.05"])]
    for (sweep, series, x), g in fb.groupby(["sweep", "series", "x"], sort=False):
        a, b = g[g["base"] == "f=0"], g[g["base"] == "f=0.05"]
        if len(a) and len(b):
            rows.append(_trend(sweep, series, x, a.iloc[0], b.iloc[0]))
    fr = s[s["base"] == "friction"]
    for series, g in fr.groupby("series", sort=False):
        a, b = g[np.isclose(g["x"], 0.0)], g[np.isclose(g["x"], 0.05)]
        if len(a) and len(b):
            rows.append(_trend("friction", series, math.nan, a.iloc[0], b.iloc[0]))
    # each distinct pair of runs once: settings that set the same model are named together
    out = []
    for r in rows:
        k = r.pop("_runs")
        name = _setting_name(r)
        if k in seen:
            seen[k]["same run as"] = ", ".join(x for x in (seen[k]["same run as"], name) if x)
            continue
        r["same run as"] = ""
        seen[k] = r
        out.append(r)
    return pd.DataFrame(out)


def _setting_name(r) -> str:
    x = r.get("x")
    return (f"{r['sweep']}{' (' + r['series'] + ')' if r['series'] else ''}"
            f"{'' if x is None or x != x else ' = ' + format(x, 'g')}")


def tally(trends: pd.DataFrame) -> dict:
    """How the distinct settings of :func:`trend_rows` divide: rises, falls, not resolved (both
    ends steady) and not steady (an end transient or runaway); the counts add up to the total."""
    c = trends["trend"].value_counts() if len(trends) else pd.Series(dtype=int)
    out = {k: int(c.get(k, 0)) for k in ("rises", "falls", "not resolved")}
    out["not steady"] = int(len(trends) - sum(out.values()))
    out["total"] = int(len(trends))
    return out


def _reached(mean, hw, paper):
    return bool(mean + hw >= paper / FACTOR and mean - hw <= paper * FACTOR)


def _trend(sweep, series, x, a, b):
    """One setting's change from f = 0 (run a) to f = 0.05 (run b): a statistic only where both
    runs are steady; otherwise the trend names the state ("transient", "runaway") and the numbers
    of the unsteady end are left out (–)."""
    sa, sb = a.get("state", "steady"), b.get("state", "steady")
    ma, ha = (a["mean"], a["half_width"]) if sa == "steady" else (math.nan, math.nan)
    mb, hb = (b["mean"], b["half_width"]) if sb == "steady" else (math.nan, math.nan)
    if sa == "steady" and sb == "steady":
        dm, hw = mb - ma, math.hypot(ha, hb)
        verdict = "rises" if dm > hw else "falls" if -dm > hw else "not resolved"
    else:
        dm = hw = math.nan
        verdict = "runaway" if "runaway" in (sa, sb) else "transient"
    r40 = sa == "steady" and _reached(ma, ha, 40.0)
    r90 = sb == "steady" and _reached(mb, hb, 90.0)
    return {"sweep": sweep, "series": series, "x": x, "f=0": ma, "± f=0": ha,
            "f=0.05": mb, "± f=0.05": hb, "change": dm, "± change": hw, "trend": verdict,
            "40 reached": r40, "90 reached": r90,
            "all three": bool(verdict == "rises" and r40 and r90),
            "_runs": (a.get("run", a.get("key")), b.get("run", b.get("key")))}


def answer(summary: pd.DataFrame, trends: pd.DataFrame) -> list[str]:
    """The page's text, every number from the data."""
    summary = clean(summary)
    ok = summary[summary["state"] == "steady"]            # statistics: steady runs only
    failed = summary[~summary["success"]]

    def name(r):
        return f"{r['sweep']} = {r['x']:g}{', ' + r['series'] if r['series'] else ''}"

    def best(base):
        g = ok[ok["base"] == base]
        txt = f"{base}: no steady point" if not len(g) else None
        if len(g):
            r = g.loc[g["mean"].idxmax()]
            txt = (f"{base}: largest steady {r['mean']:.3g} ± {r['half_width']:.2g} rad/s ({name(r)}; "
                   f"paper {BASES[base][1]:g})")
        top = float(g["mean"].max()) if len(g) else -math.inf
        un = summary[(summary["base"] == base) & summary["state"].isin(["transient", "runaway"])
                     & (summary["max"] > top)].drop_duplicates("run")
        for _, u in un.iterrows():
            txt += (f"; higher only in a transient ({name(u)}: still growing, {u['min']:.3g} -> {u['max']:.3g})"
                    if u["state"] == "transient" else
                    f"; higher only in a runaway ({name(u)}: friction along the slip feeds energy in, "
                    f"|rod omega| up to {u['max']:.3g})")
        return txt
    ref = {b: ok[(ok["base"] == b) & (ok["sweep"] == "damping") & np.isclose(ok["x"], 1.0)] for b in BASES}
    refs = "; ".join(f"{b} {r['mean'].iloc[0]:.3g} ± {r['half_width'].iloc[0]:.2g}" for b, r in ref.items() if len(r))
    paras = [f"Each point: the located per-revolution maximum of |rod omega|, mean ± {100 * LEVEL:g} % interval "
             "(nld.analysis.peaks.peak_interval, batch means) over the steady revolutions of one run from the "
             f"assembled state. 'Reached' means the interval overlaps [paper / {FACTOR:g}, paper x {FACTOR:g}]; "
             "a change with f 'rises' or 'falls' when it exceeds the combined half-width. Only steady runs give "
             "a mean: a run whose peaks still grow is a transient, and one with friction along the slip (eq. 17 "
             "read literally, f > 0) a runaway; both are named as such, with the range they covered. "
             f"The scene's own choices give: {refs} rad/s."]
    paras.append("Largest peak found per base case: " + "; ".join(best(b) for b in BASES if (summary["base"] == b).any()) + ".")
    if len(trends):
        c = tally(trends)
        all3 = trends[trends["all three"]]
        paras.append(f"Friction trend f = 0 -> 0.05 over {c['total']} distinct settings (settings that set the same "
                     f"model, e.g. a value equal to the scene's own, are one run and counted once): rises in "
                     f"{c['rises']}, falls in {c['falls']}, not resolved in {c['not resolved']}, not steady "
                     f"(transient or runaway at an end) in {c['not steady']}. "
                     f"40 rad/s at f = 0 reached in {int(trends['40 reached'].sum())}, 90 at f = 0.05 in "
                     f"{int(trends['90 reached'].sum())}; all three together in {len(all3)}"
                     + (": " + "; ".join(_setting_name(r) for _, r in all3.iterrows()) if len(all3) else "") + ".")
        rises = trends[trends["trend"] == "rises"]
        if len(rises):
            paras.append("Where the peak rises with f: " + "; ".join(
                f"{_setting_name(r)}: {r['f=0']:.3g} -> {r['f=0.05']:.3g} (± {r['± change']:.2g})"
                for _, r in rises.iterrows()) + ".")
    grow = summary[summary["state"] == "transient"].drop_duplicates("run")
    if len(grow):
        paras.append(f"Transients: at {len(grow)} runs the per-revolution peaks still grow across the window "
                     "(slope of a line through them > 2 standard errors and > 10 % of the mean over the "
                     "window): " + "; ".join(f"{r['base']} {name(r)} ({r['min']:.3g} -> {r['max']:.3g})"
                                             for _, r in grow.iterrows())
                     + ". No mean is given for them: it would depend on how long one integrates.")
    run = summary[summary["state"] == "runaway"].drop_duplicates("run")
    if len(run):
        paras.append(f"Runaways: {len(run)} finished runs with friction along the slip (f > 0): "
                     + "; ".join(f"{r['base']} {name(r)} (|rod omega| {r['min']:.3g} to {r['max']:.3g})"
                                 for _, r in run.iterrows())
                     + ". The friction pair feeds energy into the rattle; the level reached is that of the "
                       "runaway, not a statistic of the machine.")
    cl = ok[ok["base"].isin(["r=0.01mm", "r=0.5mm"])]
    pairs = [(g[g["base"] == "r=0.01mm"], g[g["base"] == "r=0.5mm"])
             for _, g in cl.groupby(["sweep", "series", "x"], sort=False)]
    pairs = [(a.iloc[0], b.iloc[0]) for a, b in pairs if len(a) and len(b)]
    if pairs:
        hits = [(a, b) for a, b in pairs if _reached(a["mean"], a["half_width"], 20.0)
                and _reached(b["mean"], b["half_width"], 200.0)]
        paras.append(f"Clearance study (f = 0.01) over {len(pairs)} settings: r = 0.01 -> 0.5 mm raises the peak "
                     f"by x{min(b['mean'] / a['mean'] for a, b in pairs):.2g} to x{max(b['mean'] / a['mean'] for a, b in pairs):.2g}"
                     f" (paper x10); 20 rad/s at 0.01 mm reached in "
                     f"{sum(_reached(a['mean'], a['half_width'], 20.0) for a, _ in pairs)}, 200 at 0.5 mm in "
                     f"{sum(_reached(b['mean'], b['half_width'], 200.0) for _, b in pairs)}, both in {len(hits)}.")
    if len(failed):
        paras.append(f"Failed ({len(failed)}): " + "; ".join(
            f"{r['base']} {r['sweep']} = {r['x']:g} {r['series']}: {short_message(r['message'])}".rstrip()
            + (f" (|rod omega| had reached {r['sampled_max']:.3g} rad/s)" if r.get("sampled_max") == r.get("sampled_max")
               and r.get("sampled_max") is not None else "") for _, r in failed.iterrows()) + ".")
    return paras


def short_message(message, n: int = 60) -> str:
    """A run's failure message cut to at most about ``n`` characters at a word boundary (with
    " …"), never inside a word or a number."""
    m = " ".join(str(message).split())
    if len(m) <= n:
        return m
    cut = m.rfind(" ", 0, n)
    return (m[:cut] if cut > 0 else m.split(" ")[0]).rstrip(" ,;:") + " …"


EQ5_TEXT = [
    "The paper's eq. 5 takes the slip v_t = e_dot . t + (theta_i' - theta_{i+1}') R_i with one radius R_i for "
    "both surfaces; nld uses each surface's own radius (R_i and R_i + r_i), which differs by r_i "
    "theta_{i+1}' (below 1e-4 of the slip): the same slip. At A the eccentric (R1 = 80 mm) turns at "
    "omega1 = 15.6 rad/s inside the rod's big end, so the slip there is about 1.2 m/s and never reverses; "
    "friction at A puts a moment f F_n R1 on the rod (about 24 N m at f = 0.05 and 6 kN).",
    "What differs is the direction of the friction force. Eq. 12 writes the force of the crank on the rod as "
    "F12 = F_n (cos a, sin a) + F_t (sin a, -cos a), eq. 17 its moment on the rod (R1 + e1)(F12y cos a - F12x sin a) "
    "= -(R1 + e1) F_t, and at B (eq. 15: the rod receives -F32) + R2 F_t2, with F_t = f sigma F_n and sigma "
    "the sign of eq. 5's slip. Whatever quadrant eq. 4's arctan is given, the moment on the rod at A "
    "turns it against the eccentric's spin, and at B with the pin's relative rotation: friction that "
    "drives the relative motion instead of resisting it (anti-dissipative: the friction pair does work "
    "+f F_n |v_t| instead of -f F_n |v_t|). nld's law (docs/contact-laws.md) applies F_t opposite to the "
    "slip, as Coulomb friction does. The series 'eq. 17 literal' runs this literal reading: the "
    "Ambrosio law (the sign law cannot stick when friction pushes) with mu negated in the kernel's "
    "parameters (reversed_kernel), i.e. the friction force along the slip at both joints.",
]


# ------------------------------------------------------------------------------------- figures


def _panel(ax, g, base, color, label, marker="o", ls="-"):
    g = g.sort_values("x")
    st = g["state"] if "state" in g else pd.Series(states(g), index=g.index)
    ok = g[st == "steady"]
    if len(ok):            # mean ± interval: steady runs only
        ax.errorbar(ok["x"], ok["mean"], yerr=ok["half_width"], color=color, marker=marker, ms=4, lw=1,
                    ls=ls, capsize=2, label=label)
    gr = g[st == "transient"]          # transients and runaways: the largest peak, no statistic
    ax.plot(gr["x"], gr["max"], ls="none", marker="o", ms=8, mfc="none", mec=color,
            label=None if len(ok) or not len(gr) else label)
    ra = g[st == "runaway"]
    ax.plot(ra["x"], ra["max"], ls="none", marker="^", ms=8, mfc="none", mec=color,
            label=None if len(ok) or len(gr) or not len(ra) else label)
    bad = g[~g["success"].astype(bool)]
    for x in bad["x"]:
        ax.annotate("failed", (x, 1.0), xycoords=("data", "axes fraction"), color=color, fontsize=6,
                    rotation=90, va="top", ha="center")


def fig_unknowns(rep, summary: pd.DataFrame, bases, d: dict, title: str, caption: str) -> None:
    """Peak |rod omega| against each unknown, one line per base case, the paper's values marked."""
    sweeps = [s for s in SWEEPS if s != "friction" and (summary["sweep"].eq(s) & summary["base"].isin(bases)).any()]
    if not sweeps:
        return
    cur = {"damping": 1.0, "M43": d["M43"], "K2": d["K2"], "l4": d["l4"], "R": d["rho"] + d["l3"]}
    nc = 2 if len(sweeps) <= 4 else 3 if len(sweeps) <= 6 else 4
    fig, axes = rep.subplots((len(sweeps) + nc - 1) // nc, nc, title=title, squeeze=False)
    for ax, sw in zip(axes.flat, sweeps):
        g = summary[(summary["sweep"] == sw) & summary["base"].isin(bases)]
        for b in bases:
            gb = g[g["base"] == b]
            for k, (series, gs) in enumerate(gb.groupby("series", sort=True)):
                _panel(ax, gs, b, BASES[b][2], f"{b} {series}".strip(), ls=["-", "--", ":", "-."][k % 4],
                       marker="os^v"[k % 4])
            ax.axhline(BASES[b][1], color=BASES[b][2], ls="--", lw=0.8)
        if sw in cur:
            ax.axvline(cur[sw], color="grey", ls=":", lw=0.8)
        lab, log = SWEEPS[sw]
        m = g[g["motor_J"].notna()] if "motor_J" in g else g
        ax.set_xlabel(fontsize=7, xlabel=lab.format(J=float(m["motor_J"].iloc[0]) if len(m) else 0, k=float(m["motor_k"].iloc[0]) if len(m) else 0))
        if log:
            ax.set_xscale("symlog", linthresh=0.01) if sw == "damping" else ax.set_xscale("log")
            if sw == "damping":
                ax.set_xlim(-0.004, 1.5 * float(g["x"].max()))
        ax.set_yscale("log")
        ax.set_ylabel("peak |rod ω| [rad/s]")
        ax.legend(fontsize=5)
    for ax in list(axes.flat)[len(sweeps):]:
        ax.set_visible(False)
    rep.figure(fig, caption=caption)


def fig_friction(rep, summary: pd.DataFrame) -> None:
    g = summary[summary["base"] == "friction"]
    if not len(g):
        return
    fig, ax = rep.subplots(1, 1, title="Peak |rod ω| against the friction coefficient: readings of the friction law")
    for k, (series, gs) in enumerate(g.groupby("series", sort=False)):
        _panel(ax, gs, "friction", f"C{k}", series, marker="os^vD"[k % 5])
    ax.plot([0.0, 0.05], [40.0, 90.0], "k*", ms=12, label="paper (f = 0: 40, f = 0.05: 90)")
    ax.set_yscale("log")
    ax.set_xlabel(SWEEPS["friction"][0])
    ax.set_ylabel("peak |rod ω| [rad/s]")
    ax.legend(fontsize=7)
    rep.figure(fig, caption=(
        "r1 = 0.07, r2 = 0.03 mm. 'coulomb': the scene (hybrid stick/slip modes, contact damping as chosen); "
        "'undamped': C1n = C2n = 0; 'ambrosio': the continuous Ambrosio law; 'eq. 17 literal': the paper's "
        "eqs 12-17 read literally, friction along the slip (Ambrosio law, mu negated in the kernel's "
        "parameters), with the scene's damping or 3x it. Mean ± interval: steady runs only; open circles: "
        "transients (peaks still growing across the window), open triangles: runaways (friction along the slip "
        "with f > 0), each at its largest peak, no statistic; 'failed': the run stopped (step budget per "
        "revolution). Stars: the paper."))


def fig_revolutions(rep, summary: pd.DataFrame, peaks: pd.DataFrame) -> None:
    """The per-revolution peaks of the points that grow, beside the scene's reference points."""
    ok = summary[summary["success"].astype(bool)]
    keys = list(ok[ok["sweep"] == "long run"]["key"]) + list(ok[ok["growing"].astype(bool)]
                                                              .drop_duplicates("run")["key"] if "run" in ok
                                                              else ok[ok["growing"].astype(bool)]["key"])[:6]
    keys += list(ok[(ok["sweep"] == "damping") & np.isclose(ok["x"], 1.0) & ok["base"].str.startswith("f=")]["key"])
    if not keys or not len(peaks):
        return
    fig, ax = rep.subplots(1, 1, title="Per-revolution peaks: the points that do not settle, and the scene's own")
    for k in dict.fromkeys(keys):
        r = ok[ok["key"] == k].iloc[0]
        p = peaks[peaks["key"] == k]
        ax.plot(p["rev"], p["peak"], marker=".", label=f"{r['base']} {r['sweep']} = {r['x']:g} {r['series']}".rstrip())
    ax.set_xlabel("revolution after the transient (the long runs: after the assembled start)")
    ax.set_ylabel("peak |rod ω| [rad/s]")
    ax.legend(fontsize=6)
    rep.figure(fig, caption="Located maximum of |rod omega| in each steady revolution: the long undamped runs "
                            "(from the assembled state), the points flagged as still growing, and the scene's own "
                            "choices at f = 0 and 0.05.")


def paper_page(rep, summary: pd.DataFrame, prov: dict | None = None, *, own: dict | None = None) -> None:
    """The page "What it takes to reach the paper's numbers" (text and the figure against each
    unknown at f = 0 and 0.05) from a summary table of this study; used by the zhang2013 study,
    which passes ``own``: its own run of the scene's f = 0 case (mean, half_width [rad/s], revs
    "transient + steady"), so that the page says why the two numbers of one case differ."""
    from nld.model.scene import load_scene
    d = defaults(load_scene(SCENE))
    summary = clean(summary)
    tr = trend_rows(summary)
    src = "" if not prov else (f" (data: {STEM}_summary.csv, {prov.get('mode')} mode, git {prov.get('git_hash')}, "
                               f"{prov.get('transient_revs')} + {prov.get('steady_revs')} revolutions per point)")
    rep.text_page("What it takes to reach the paper's numbers", [
        "The sensitivity study (studies/zhang2013_sensitivity.py, issue 28)" + src + " varies the values "
        "the paper leaves out or garbles, one at a time and in pairs."] + answer(summary, tr)
        + two_runs_text(summary, own, prov) + EQ5_TEXT)
    fig_unknowns(rep, summary, ["f=0", "f=0.05"], d, "Peak |rod ω| against each unknown, f = 0 and f = 0.05",
                 "Mean ± 95 % interval of the located per-revolution maxima; dashed lines: the paper's 40 (f = 0) "
                 "and 90 rad/s (f = 0.05); dotted vertical line: the scene's choice; open circles: transients, open "
                 "triangles: runaways, each at its largest peak (no statistic).")


def two_runs_text(summary: pd.DataFrame, own: dict | None, prov: dict | None = None) -> list[str]:
    """A paragraph naming both values of the scene's f = 0 case when the zhang2013 report has its
    own run of it (``own``) beside this study's: two runs of one model over different windows."""
    if not own:
        return []
    s = clean(summary)
    r = s[(s["base"] == "f=0") & (s["sweep"] == "damping") & np.isclose(s["x"], 1.0) & (s["series"] == "")
          & (s["state"] == "steady")]
    if not len(r):
        return []
    m, h = float(r["mean"].iloc[0]), float(r["half_width"].iloc[0])
    revs = "?" if not prov else f"{prov.get('transient_revs')} + {prov.get('steady_revs')}"
    overlap = abs(m - own["mean"]) <= h + own["half_width"]
    return [f"Two values of the scene's f = 0 case: this report's own run gives {own['mean']:.4g} ± "
            f"{own['half_width']:.2g} rad/s ({own['revs']} revolutions: transient + steady, the comparison "
            f"table), the sensitivity study's run {m:.4g} ± {h:.2g} rad/s ({revs} revolutions). The model is "
            "the same; the windows differ (a longer transient discarded, other revolutions averaged), so the "
            "two are two estimates of one mean, and their intervals "
            + ("overlap." if overlap else "do not overlap: the revolutions averaged are not yet steady enough "
               "for either interval to hold alone.")]


# ------------------------------------------------------------------------------------- report


def report(study, summary, peaks, d, workers) -> None:
    from nld.model.scene import load_scene
    from nld.study import run_table, timing
    st = study.settings
    summary = clean(summary)
    tr = trend_rows(summary)
    ok = int(summary["success"].astype(bool).sum())
    with study.report({"Mode": study.label, "Points": f"{len(summary)} ({ok} finished)",
                       "Revolutions per point": f"{st['transient_revs']} transient + {st['steady_revs']} steady",
                       "rtol": st["rtol"], "Detection samples per revolution": st["samples_per_rev"],
                       "Worker processes": workers, "Wall time of the points": timing(f"{study.elapsed():.0f} s")},
                      scene=load_scene(SCENE), subject="Sensitivity of the excavator's rod angular velocity to the paper's "
                      "unknowns", keywords=["excavator", "Zhang 2013", "sensitivity"]) as rep:
        paper_page(rep, summary, study.prov)
        fig_friction(rep, summary)
        fig_unknowns(rep, summary, ["r=0.01mm", "r=0.5mm"], d, "Peak |rod ω| against each unknown, "
                     "r1 = r2 = 0.01 and 0.5 mm (f = 0.01)", "As before; dashed lines: the paper's 20 and 200 rad/s.")
        fig_revolutions(rep, summary, peaks)
        if len(tr):
            rep.table("Friction trend and the paper's magnitudes, setting by setting", tr,
                      col_units={"f=0": "rad/s", "f=0.05": "rad/s", "change": "rad/s"},
                      notes=[f"Reached: the 95 % interval overlaps [paper / {FACTOR:g}, paper x {FACTOR:g}]."],
                      float_format=lambda v: f"{v:.4g}")
        cols = ["base", "sweep", "series", "x", "paper", "mean", "half_width", "batch", "min", "max", "growing",
                "crank_speed_min", "crank_speed_max", "success"]
        rep.table("Every point", summary[[c for c in cols if c in summary]],
                  notes=["Stored in zhang2013_sensitivity_summary.csv with the overrides, run statistics and, for "
                         "the geometry points, the ideal-joint swing and transmission angle."],
                  float_format=lambda v: f"{v:.4g}")
        runs = {f"{r['base']} {r['sweep']}={r['x']:g} {r['series']}": r for r in summary.to_dict("records")}
        rep.table("Run statistics", run_table(runs, {"steps": "steps", "rejected": "rejected", "events": "events"}),
                  col_units={"wall time": "s"})


def main(quick: bool = False, out_dir: Path = Path("reports"), *, smoke: bool = False) -> Path:
    """Run the grid (resumable), write the summary and peaks CSV and the report; returns the PDF."""
    from nld.model.scene import load_scene
    from nld.study import Study
    study = Study(globals(), quick, out_dir, smoke=smoke)
    st, workers = study.settings, study.workers(study.settings["workers"])
    records = run_grid(study, st, workers)
    summary, peaks = tables(records)
    study.stage("writing the data and the report")
    study.provenance(scene=load_scene(SCENE), integrator="dopri5 (nld.analysis.extrema.revolution_maxima)",
                     paper=CITATION, **dict(st, workers=workers), points_wall_s=study.elapsed(),
                     paper_values={b: v[1] for b, v in BASES.items()}, reached_factor=FACTOR, level=LEVEL)
    study.save("_summary.csv", summary)
    study.save("_peaks.csv", peaks)
    report(study, summary, peaks, defaults(load_scene(SCENE)), workers)
    return study.pdf


if __name__ == "__main__":
    import sys
    print(main(quick="--quick" in sys.argv, smoke="--smoke" in sys.argv))
