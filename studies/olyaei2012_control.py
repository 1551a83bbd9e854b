"""Study: chaos control of the clearance slider-crank, Olyaei & Ghazavi (2012) style (issue 26, item 7).

    nld study olyaei2012_control [--quick] [--out DIR]

Scene ``slider_crank_olyaei --set joints.B.clearance=2e-4 --set joints.B.friction.mu=0`` (the Flores
slider-crank, 0.2 mm rod-slider clearance, Lankarani-Nikravesh contact, no friction, 5000 rpm):
chaotic, the case on which docs/control.md measured what works. The study runs

* the uncontrolled mechanism (``nld.run.simulate``): the stroboscopic section of the journal
  eccentricity over ``free_revs`` revolutions after ``free_transient``, contact onsets per
  revolution, the crank's drive torque (the torque scale the control torque is compared with);
* ``nld control`` with its documented defaults (EDFC, torque on the rod, signal rod.phi_dot,
  K = 1 N m s/rad, R = 0.9, tau = one crank period; ``nld.analysis.scene_control.control_scene``,
  the command's own workflow): lambda1 free and controlled with their uncertainties, the effort, the capture
  revolution, the orbit of the controlled motion (Newton) with its Floquet multipliers and the
  odd-number verdict, and the stability domain lambda1(K) at R = 0.9 (``gains``) from the end of the
  controlled run;
* from the controlled run's samples (50 per revolution): the time histories of the control torque,
  the rod's angular velocity and the contact force, the section before and after capture, and what
  it takes in torque (rms and peak during the capture and after it).

Outputs: ``olyaei2012_control.pdf``; ``_summary.csv`` (quantity, value, uncertainty, unit),
``_domain.csv`` (lambda1(K)), ``_revolutions.csv`` (per controlled revolution: effort rms, peak |u|,
onsets, section point), ``_sections.csv`` (free and controlled section points, with the contact onsets in the revolution
that starts there), ``_torque.csv``
(rms / peak torque during and after capture, the crank's drive torque), each with its ``.csv.json``
provenance; ``_history.parquet`` (the controlled run's samples; not committed).
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pandas as pd

SCENE = "slider_crank_olyaei"
OVERRIDES = ["joints.B.clearance=2e-4", "joints.B.friction.mu=0"]
STEM = "olyaei2012_control"
TITLE = "Chaos control of the clearance slider-crank (Olyaei & Ghazavi 2012 style)"
CITATION = ("A. A. Olyaei, M. R. Ghazavi (2012), \"Stabilizing slider-crank mechanism with clearance "
            "joints\", Mechanism and Machine Theory 53:17-29 (not read here)")
INTERRUPT_KEEPS = ("nothing kept: the report and its data are written only at the end; run the "
                   "study again (nld control's own message above says which part had finished)")

# control: nld control's defaults (nld.settings.CONTROL, measured in docs/control.md); gains:
# the stability domain at R = 0.9; free_*: the uncontrolled section (nld.run.simulate)
FULL = dict(transient=10, revs=300, lyapunov_revs=32, scan_transient=20,
            gains=[round(float(k), 6) for k in np.linspace(0.1, 3.0, 30)],
            free_transient=10, free_revs=100, free_samples_per_rev=100, rtol=1e-8)
QUICK = dict(FULL, gains=[0.3, 1.0, 2.0])
SMOKE = dict(QUICK, revs=20, lyapunov_revs=4, scan_transient=2, gains=[0.5, 1.0],
             free_transient=1, free_revs=10, free_samples_per_rev=20)
MODE_LABELS = {"quick": "QUICK MODE: the default controlled run, {gains} as the stability domain",
               "smoke": "SMOKE MODE (test only)"}
SAMPLE_Z_ELASTIC = 1e30     # contact memory that removes the hysteresis term: F = K delta^n


# ------------------------------------------------------------------------------------- computation


def control_kwargs(st: dict) -> dict:
    """The keyword arguments of :func:`nld.analysis.scene_control.control_scene` for the study:
    the scene and its overrides, the study's revolutions, tolerance and gains; every other setting
    the command's default (nld.settings.CONTROL)."""
    command = "nld " + " ".join(
        ["control", SCENE] + [a for o in OVERRIDES for a in ("--set", o)] + [
            "--transient", str(st["transient"]), "--revs", str(st["revs"]),
            "--lyapunov-revs", str(st["lyapunov_revs"]), "--scan-transient",
            str(st["scan_transient"]), "--rtol", repr(st["rtol"]),
            "--gains", ",".join(repr(float(k)) for k in st["gains"])])
    return dict(scene=SCENE, overrides=list(OVERRIDES), transient=st["transient"], revs=st["revs"],
                lyapunov_revs=st["lyapunov_revs"], scan_transient=st["scan_transient"],
                rtol=st["rtol"], gains=[float(k) for k in st["gains"]], command=command)


def controlled_case(st: dict, say) -> dict:
    """``nld control``'s workflow (control_scene) with the defaults and the gain scan; from its controlled run
    the sampled time history (t, rev, u, rod.phi_dot, B.ex, B.ey, the contact force's elastic part
    for the whole run and the whole force where the contact memory is the final one), onset
    times, the control's start, the crank period and the clearance."""
    from nld.analysis.scene_control import control_scene
    t0 = time.perf_counter()
    r = control_scene(**control_kwargs(st), say=say)
    wall = time.perf_counter() - t0
    out, res, S = r.out, r.result, r.system
    run = res.run
    T = float(S.period)
    kern = S.kernel
    cols = list(kern.columns)
    ie, ix, iy = cols.index("B.Fn"), cols.index("B.ex"), cols.index("B.ey")
    row = np.empty(len(cols))
    n = run.Y.shape[0]
    fel, ffull, ex, ey = (np.empty(n) for _ in range(4))
    zel = np.full_like(np.asarray(run.z, float), SAMPLE_Z_ELASTIC)
    zfin = np.asarray(run.z, float)
    for i in range(n):
        y = np.ascontiguousarray(run.Y[i])
        kern.module.observe(float(run.t[i]), y, S.p, zel.copy(), row)
        fel[i], ex[i], ey[i] = row[ie], row[ix], row[iy]
        kern.module.observe(float(run.t[i]), y, S.p, zfin.copy(), row)
        ffull[i] = row[ie]
    onsets = run.ev_t[run.ev_dir > 0]
    last = float(onsets.max()) if onsets.size else -math.inf
    ffull[run.t <= last] = np.nan            # the memory changes at each onset: only after the last
    t_start = float(run.t[0])
    hist = pd.DataFrame({"t": run.t, "rev": (run.t - t_start) / T, "u": run.u,
                         "rod.phi_dot": run.Y[:, S.state_names.index("rod.phi_dot")],
                         "B.ex": ex, "B.ey": ey, "B.Fn_elastic": fel, "B.Fn": ffull})
    return dict(out=out, history=hist, onset_t=np.asarray(onsets, float), t_start=t_start, T=T,
                clearance=float(S.scene.joints["B"].clearance), wall_s=wall,
                samples_per_rev=int(res.settings["samples_per_delay"]))


def free_case(st: dict) -> dict:
    """The uncontrolled mechanism by nld.run.simulate: the section (B.ex, B.ey at every crank
    revolution after ``free_transient``), contact onsets per revolution, the drive torque."""
    from nld.run.simulate import crank_period, simulate
    from nld.model.scene import resolve_scene
    scene = resolve_scene(SCENE, OVERRIDES)
    T = crank_period(scene)
    n_rev, spr = st["free_transient"] + st["free_revs"], st["free_samples_per_rev"]
    t0 = time.perf_counter()
    r = simulate(scene, revs=n_rev, rtol=st["rtol"], samples_per_rev=spr, progress=False,
                 raise_on_failure=True)
    wall = time.perf_counter() - t0
    tab = r.table
    k = np.arange(st["free_transient"], n_rev + 1)
    sec = tab.iloc[k * spr][["t", "B.ex", "B.ey"]].reset_index(drop=True)
    sec.insert(0, "rev", k)
    ev = r.events
    on = ev.loc[ev["direction"] > 0, "t"].to_numpy(float)
    per_rev = np.histogram(on, bins=np.arange(st["free_transient"], n_rev + 1) * T)[0]
    steady = tab[tab["t"] >= st["free_transient"] * T]
    tq = steady["driver.torque"].to_numpy(float)
    return dict(section=sec, onsets_per_rev=per_rev, T=T, clearance=scene.joints["B"].clearance,
                drive_rms=float(np.sqrt(np.mean(tq ** 2))), drive_peak=float(np.max(np.abs(tq))),
                drive_samples=int(tq.size), wall_s=wall, steps=int(r.stats.get("accepted", 0)))


# ------------------------------------------------------------------------------------- tables


def per_revolution(ctl: dict) -> pd.DataFrame:
    """One row per controlled revolution: effort rms and peak |u| over it, contact onsets in it,
    the section point at its start (B.ex, B.ey)."""
    h, spr, T = ctl["history"], ctl["samples_per_rev"], ctl["T"]
    n = (len(h) - 1) // spr
    u = h["u"].to_numpy(float)[1: 1 + n * spr].reshape(n, spr)
    on = np.histogram(ctl["onset_t"], bins=ctl["t_start"] + np.arange(n + 1) * T)[0]
    sec = h.iloc[np.arange(n) * spr]
    return pd.DataFrame({"rev": np.arange(n), "effort_rms": np.sqrt(np.mean(u ** 2, axis=1)),
                         "u_peak": np.max(np.abs(u), axis=1), "onsets": on,
                         "B.ex": sec["B.ex"].to_numpy(float), "B.ey": sec["B.ey"].to_numpy(float)})


def captured_rev(ctl: dict):
    c = ctl["out"]["captured_at_revolution"]
    return None if c is None else int(round(c))


def last_onset(ctl: dict) -> float:
    """Revolutions of control at the controlled run's last contact onset (nan: none)."""
    on = ctl["onset_t"]
    return float((on.max() - ctl["t_start"]) / ctl["T"]) if on.size else math.nan


def torque_table(ctl: dict, free: dict) -> pd.DataFrame:
    """rms and peak control torque during the capture (control start to the capture revolution)
    and after it, beside the crank's drive torque of the free mechanism."""
    h = ctl["history"]
    cap = captured_rev(ctl)
    u, rev = h["u"].to_numpy(float), h["rev"].to_numpy(float)
    rows = []
    for name, sel in (("control torque, during capture (revolution 0 to capture)",
                       rev <= (cap if cap is not None else math.inf)),
                      ("control torque, after capture", rev > cap if cap is not None
                       else np.zeros(rev.size, bool))):
        x = u[sel]
        rows.append({"what": name, "rms": float(np.sqrt(np.mean(x ** 2))) if x.size else math.nan,
                     "peak": float(np.max(np.abs(x))) if x.size else math.nan, "samples": int(x.size)})
    rows.append({"what": "crank drive torque, free mechanism (steady revolutions)",
                 "rms": free["drive_rms"], "peak": free["drive_peak"],
                 "samples": int(free["drive_samples"])})
    return pd.DataFrame(rows)


def summary_table(ctl: dict, free: dict) -> pd.DataFrame:
    o, s = ctl["out"], ctl["out"]["settings"]
    co = s.get("controlled_orbit") or {}
    tg = s.get("target_orbit") or {}
    mu = lambda d: "; ".join(f"{a:.5g}" + (f"{b:+.2g}j" if abs(b) > 1e-12 else "")   # noqa: E731
                             for a, b in d.get("multipliers", []))
    on = np.asarray(free["onsets_per_rev"], float)
    rows = [
        ("lambda1 free (gain 0, two trajectories)", o["lambda1_uncontrolled"],
         s.get("uncertainty_uncontrolled"), "per revolution"),
        ("lambda1 controlled; contact memory " + str(s.get("lyapunov_controlled_memory", "")),
         o["lambda1_controlled"], s.get("uncertainty_controlled"), "per revolution"),
        ("effort decay rate after capture (second estimate of lambda1 controlled)",
         s.get("effort_decay_per_revolution"), None, "per revolution"),
        ("contact onsets per revolution, free (mean, SE over the section's revolutions)",
         float(on.mean()) if on.size else math.nan,
         float(on.std(ddof=1) / math.sqrt(on.size)) if on.size > 1 else math.nan, "1/rev"),
        ("contact onsets per revolution, controlled (last quarter)", o["onsets_per_period"], None,
         "1/rev"),
        ("last contact onset of the controlled run (revolutions of control)", last_onset(ctl),
         None, "rev"),
        ("effort rms, first controlled revolution", o["effort_rms_initial"], None, "N m"),
        ("effort rms, last controlled revolution", o["effort_rms_final"], None, "N m"),
        ("captured at revolution (every later one below 5 % of the first)",
         o["captured_at_revolution"] if o["captured_at_revolution"] is not None else math.nan,
         None, "rev"),
        ("distance of the last revolution to the orbit of the controlled motion",
         o["orbit_distance"], None, "scaled"),
        ("distance of the last revolution to the target found before control",
         s.get("distance_to_target"), None, "scaled"),
        ("periodicity max |y(t) - y(t - T)|, last revolution", s.get("periodicity"), None,
         "scaled"),
    ]
    df = pd.DataFrame(rows, columns=["quantity", "value", "uncertainty", "unit"])
    df["value"] = pd.to_numeric(df["value"], errors="coerce")
    df["uncertainty"] = pd.to_numeric(df["uncertainty"], errors="coerce")
    df["note"] = ""
    extra = [("captured orbit: Floquet multipliers (free mechanism)", mu(co)),
             ("captured orbit: odd-number limitation",
              (co.get("odd_number_limitation") or {}).get("message", "no orbit from the run")),
             ("target before control: Floquet multipliers", mu(tg)),
             ("target before control: odd-number limitation",
              (tg.get("odd_number_limitation") or {}).get("message", ""))]
    df = pd.concat([df, pd.DataFrame([{"quantity": q, "value": math.nan, "uncertainty": math.nan,
                                       "unit": "", "note": t} for q, t in extra])],
                   ignore_index=True)
    return df


STABLE_RULE = ("stable: lambda1 + uncertainty < 0; unstable: lambda1 - uncertainty > 0; "
               "undecided: the interval contains 0 (the uncertainty: the standard error of batch "
               "means combined with the difference of the two halves' means, "
               "nld.analysis.control.delayed_lyapunov)")


def verdict(lam: float, unc: float) -> str:
    """'stable', 'unstable' or 'undecided' by lambda1 and its uncertainty (STABLE_RULE); the
    ``stable`` column of nld control's stability domain is verdict == 'stable'."""
    if not math.isfinite(lam):
        return "failed"
    u = unc if math.isfinite(unc) else 0.0
    return "stable" if lam + u < 0 else "unstable" if lam - u > 0 else "undecided"


def domain_table(ctl: dict) -> pd.DataFrame:
    d = ctl["out"]["stability_domain"]
    lam = [np.nan if x is None else x for x in d["lambda1"]]
    unc = [np.nan if x is None else x for x in d["uncertainty"]]
    return pd.DataFrame({"K": d["gains"], "R": d["memory"], "lambda1": lam, "uncertainty": unc,
                         "stable": d["stable"],
                         "verdict": [verdict(a, b) for a, b in zip(lam, unc)]})


def gain_ranges(dom: pd.DataFrame, which: str) -> str:
    """The gains of verdict ``which`` as runs of consecutive rows of the domain table, e.g.
    '0.7-1.4, 2-3' (a set that is not one range is not printed as its min...max)."""
    runs, cur = [], []
    for k, v in zip(dom["K"], dom["verdict"]):
        if v == which:
            cur.append(float(k))
        elif cur:
            runs.append(cur)
            cur = []
    if cur:
        runs.append(cur)
    return ", ".join(f"{r[0]:g}" if len(r) == 1 else f"{r[0]:g}-{r[-1]:g}" for r in runs)


def sections_table(ctl: dict, free: dict, revs: pd.DataFrame) -> pd.DataFrame:
    c, cap = free["clearance"], captured_rev(ctl)
    f = free["section"]
    on = np.asarray(free["onsets_per_rev"], float)
    on = np.concatenate([on, np.full(max(0, len(f) - on.size), np.nan)])[: len(f)]
    a = pd.DataFrame({"case": "free", "rev": f["rev"], "ex/c": f["B.ex"] / c, "ey/c": f["B.ey"] / c,
                      "onsets": on})
    phase = np.where(revs["rev"] < (cap if cap is not None else math.inf), "controlled, before capture",
                     "controlled, after capture")
    b = pd.DataFrame({"case": phase, "rev": revs["rev"], "ex/c": revs["B.ex"] / c,
                      "ey/c": revs["B.ey"] / c, "onsets": revs["onsets"].astype(float)})
    return pd.concat([a, b], ignore_index=True)


# ------------------------------------------------------------------------------------- report


def _fmt(x, spec=".3g"):
    return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, spec)


def findings(ctl, free, tq, dom) -> list[str]:
    o, s = ctl["out"], ctl["out"]["settings"]
    cap = o["captured_at_revolution"]
    co = s.get("controlled_orbit") or {}
    on = np.asarray(free["onsets_per_rev"], float)
    st = dom[dom["verdict"] == "stable"]
    n_un, n_und = int((dom["verdict"] == "unstable").sum()), int((dom["verdict"] == "undecided").sum())
    paras = [
        f"Uncontrolled: lambda1 = {_fmt(o['lambda1_uncontrolled'])} ± "
        f"{_fmt(s.get('uncertainty_uncontrolled'), '.2g')} per revolution (two trajectories, "
        f"{s['lyapunov_revs']} revolutions, gain 0, after {s['transient_revs']} free revolutions); "
        f"{_fmt(float(on.mean()) if on.size else math.nan)} contact onsets per revolution over "
        f"{on.size} revolutions of the free run (nld.run.simulate, rtol {s['rtol']:g}).",
        f"Controlled ({s['method'].upper()}, torque on the {s['body']}, signal {s['signal']}, "
        f"K = {s['gain']:g} N m s/rad, R = {s['memory']:g}, tau = {s['delay_revolutions']:g} crank "
        f"period): lambda1 = {_fmt(o['lambda1_controlled'])} ± "
        f"{_fmt(s.get('uncertainty_controlled'), '.2g')} per revolution "
        f"({s.get('lyapunov_controlled_memory')}); the effort decays after the capture at "
        f"{_fmt(s.get('effort_decay_per_revolution'))} per revolution, a second estimate of the "
        f"same exponent; effort rms {_fmt(o['effort_rms_initial'])} -> "
        f"{_fmt(o['effort_rms_final'])} N m; "
        + (f"captured at revolution {cap:g} of {s['revs']}" if cap is not None else
           f"not captured within {s['revs']} revolutions")
        + f"; last contact onset at revolution {_fmt(last_onset(ctl), '.4g')} of control, "
        f"{_fmt(o['onsets_per_period'])} contact onsets per revolution over the last quarter; "
        f"distance of the last revolution to the orbit of the controlled motion "
        f"{_fmt(o['orbit_distance'])} (scaled). " + ("That orbit's Floquet multipliers (free "
        "mechanism): " + ", ".join(f"{a:.4g}" for a, b in co.get("multipliers", [])) + " — "
        + (co.get("odd_number_limitation") or {}).get("message", "") if co else
        "No orbit was found from the controlled motion."),
        f"Stability domain (R = {s['memory']:g}, {len(dom)} gains {dom['K'].min():g}..."
        f"{dom['K'].max():g}): stable (lambda1 + uncertainty < 0) at {len(st)} gains"
        + (f" (K = {gain_ranges(dom, 'stable')}; deepest {st['lambda1'].min():.3g} at "
           f"K = {st.loc[st['lambda1'].idxmin(), 'K']:g})" if len(st) else "")
        + f", unstable (lambda1 - uncertainty > 0) at {n_un}"
        + (f" (K = {gain_ranges(dom, 'unstable')})" if n_un else "")
        + f", undecided (the interval contains 0) at {n_und}"
        + (f" (K = {gain_ranges(dom, 'undecided')})" if n_und else "") + ". The uncertainty "
        "is the standard error of batch means combined with the difference of the two halves' "
        "means (a slow drift of the running estimate counts).",
        f"Torque: during the capture the control torque is {_fmt(tq['rms'].iloc[0])} N m rms "
        f"({_fmt(tq['peak'].iloc[0])} N m peak), after it {_fmt(tq['rms'].iloc[1])} N m rms "
        f"({_fmt(tq['peak'].iloc[1])} peak); the crank's drive torque of the free mechanism is "
        f"{_fmt(tq['rms'].iloc[2])} N m rms ({_fmt(tq['peak'].iloc[2])} N m peak).",
    ]
    return paras


OLYAEI_TEXT = [
    "Olyaei & Ghazavi (2012), \"Stabilizing slider-crank mechanism with clearance joints\" "
    "(Mechanism and Machine Theory 53:17-29), could not be read here. What is known of it comes "
    "from papers citing it: chaos in a slider-crank with a clearance joint is suppressed by a "
    "modified extended delayed feedback control (EDFC) that keeps the journal in continuous "
    "contact with the bearing.",
    "What could be checked: that qualitative claim, on nld's own model. EDFC on the rod's angular "
    "velocity, acting as a torque on the rod, takes the chaotic impacting motion (about four "
    "contact onsets per revolution, lambda1 about 4 per revolution) to a period-1 motion with no "
    "contact onset (permanent contact, the journal does not leave the bearing), whose closed-loop "
    "lambda1 is below zero, with a control torque that falls to a vanishing fraction of its first "
    "value (non-invasive: the motion is an unstable orbit of the free mechanism, not one the "
    "controller imposes). The numbers are on the first page and in the tables.",
    "What could not: their mechanism's bodies, clearance, speed and friction (this scene uses the "
    "Flores benchmark's bodies at 5000 rpm with a 0.2 mm clearance and no friction: the olyaei2012 "
    "study found this combination chaotic), their actuator (which body or joint the control acts "
    "on), their measured signal, gains, memory and what the 'modification' of EDFC is, their "
    "control effort, their stability domain and their Lyapunov exponents. None of the numbers in "
    "this report is a reproduction of theirs.",
    "Other methods on the same case (docs/control.md, measured there, not rerun here): Pyragas "
    "control (R = 0) on rod.phi_dot or slider.s_dot did not capture (its reach in the flip "
    "multiplier is about -3 by the map approximation; the orbits here have -8 and -16); EDFC at "
    "R = 0.5-0.8 and small gains did not; OGY on the controller's torque offset did not (the "
    "chaotic impacting motion never comes near the permanent-contact orbit, and OGY needs it to). "
    "When the capture happens is chance: the chaotic motion must pass close enough to the orbit "
    "(8 of 8 starts captured within 300 revolutions in docs/control.md, after 31 to 273).",
    "On a permanent-contact motion the contact memory (approach speed of the last impact) is never "
    "reset: a neutral direction (multiplier 1). lambda1 of the controlled motion is therefore "
    "conditional on the memory, and each permanent-contact orbit is one of a continuum: the orbit "
    "the controller lands on need not be the one Newton found before control (both distances are "
    "given). The odd-number limitation (Nakajima 1997: an odd number of real multipliers > 1 "
    "rules out delayed feedback with tau = the period) does not apply to the flip saddles here.",
]


def report(study, ctl, free, revs, secs, tq, dom, summ) -> None:
    from nld.model.scene import resolve_scene
    from nld.study import timing
    st = study.settings
    o, s = ctl["out"], ctl["out"]["settings"]
    h = ctl["history"]
    cap = captured_rev(ctl)
    lam_f, se_f = o["lambda1_uncontrolled"], s.get("uncertainty_uncontrolled") or 0.0
    with study.report({"Mode": study.label, "Scene": f"{SCENE} " + " ".join(f"--set {x}" for x in OVERRIDES),
                       "Controller": f"{s['method']} on {s['signal']}, torque on {s['body']}, "
                                     f"K = {s['gain']:g} N m s/rad, R = {s['memory']:g}, "
                                     f"tau = {s['delay_revolutions']:g} rev",
                       "Revolutions": f"{st['transient']} free + {st['revs']} controlled; lambda1 "
                                      f"over {st['lyapunov_revs']}; domain {len(st['gains'])} gains, "
                                      f"{st['scan_transient']} + {st['lyapunov_revs']} each",
                       "rtol": st["rtol"],
                       "Wall time (control + domain / free run)":
                           timing(f"{ctl['wall_s']:.0f} s / {free['wall_s']:.0f} s")},
                      scene=resolve_scene(SCENE, OVERRIDES), subject="Delayed-feedback control of "
                      "a clearance slider-crank", keywords=["control", "EDFC", "Olyaei 2012",
                                                             "slider-crank"]) as rep:
        rep.text_page("What this report shows", findings(ctl, free, tq, dom))
        c = free["clearance"]
        with rep.style():
            fig, ax = rep.subplots(1, 2, title="Uncontrolled: section of the journal eccentricity "
                                               "and contact onsets")
            th = np.linspace(0, 2 * np.pi, 200)
            f = secs[secs["case"] == "free"]
            ax[0].plot(np.cos(th), np.sin(th), color="grey", lw=0.8)
            ax[0].plot(f["ex/c"], f["ey/c"], ".", ms=4, color="tab:blue")
            ax[0].set_aspect("equal")
            ax[0].set_xlabel("B.ex / c")
            ax[0].set_ylabel("B.ey / c")
            on = np.asarray(free["onsets_per_rev"])
            ax[1].step(np.arange(on.size) + st["free_transient"], on, where="post")
            ax[1].set_xlabel("revolution")
            ax[1].set_ylabel("contact onsets in the revolution")
        rep.figure(fig, caption=(
            f"Free mechanism ({SCENE}, c = {c * 1e3:g} mm, mu = 0): stroboscopic section (crank "
            f"angle 0) of the journal eccentricity at B over {len(f)} revolutions after "
            f"{st['free_transient']}, scaled by the clearance (circle: the clearance); contact "
            f"onsets per revolution (nld.run.simulate, rtol {st['rtol']:g}). lambda1 = "
            f"{_fmt(lam_f)} ± {_fmt(se_f, '.2g')} per revolution (the control command's "
            f"two-trajectory estimate at gain 0)."))
        with rep.style():
            fig, ax = rep.subplots(3, 1, title="Controlled: control torque, rod angular velocity, "
                                               "contact force", sharex=True)
            r = h["rev"].to_numpy(float)
            ax[0].semilogy(r, np.abs(h["u"]) + 1e-300, lw=0.4, color="tab:red", label="|u|")
            ax[0].semilogy(revs["rev"] + 1, revs["effort_rms"], "k-", lw=1, label="rms per revolution")
            ax[0].set_ylabel("|control torque| [N m]")
            ax[0].legend(fontsize=7)
            ax[1].plot(r, h["rod.phi_dot"], lw=0.4)
            ax[1].set_ylabel("rod.phi_dot [rad/s]")
            ax[2].plot(r, h["B.Fn_elastic"], lw=0.4, color="grey", label="elastic part K δ^n")
            ax[2].plot(r, h["B.Fn"], lw=0.6, color="tab:green", label="whole force (after the last onset)")
            ax[2].set_ylabel("contact force at B [N]")
            ax[2].set_xlabel("revolutions of control")
            ax[2].legend(fontsize=7)
            if cap is not None:
                for a in ax:
                    a.axvline(cap, color="k", ls=":", lw=0.8)
        rep.figure(fig, caption=(
            f"The controlled run ({st['revs']} revolutions after {st['transient']} free ones; "
            f"{ctl['samples_per_rev']} samples per revolution, so impacts are not resolved in "
            f"time). Dotted: the capture revolution ({_fmt(o['captured_at_revolution'], 'g')}). "
            f"Contact force: grey, the elastic part K δ^n of the Lankarani-Nikravesh force (no "
            f"contact memory needed); green, the whole force including the hysteresis damping, "
            f"shown only after the last contact onset, where the contact memory is the run's "
            f"final one (before, it changes at each impact and is not stored with the samples)."))
        with rep.style():
            fig, ax = rep.subplots(1, 2, title="Section collapsing to the period-1 point")
            for case, col in (("free", "lightgrey"), ("controlled, before capture", "tab:blue"),
                              ("controlled, after capture", "tab:red")):
                g = secs[secs["case"] == case]
                ax[0].plot(g["ex/c"], g["ey/c"], ".", ms=4 if case != "free" else 3, color=col,
                           label=f"{case} ({len(g)})")
            ax[0].plot(np.cos(th), np.sin(th), color="grey", lw=0.8)
            ax[0].set_aspect("equal")
            ax[0].set_xlabel("B.ex / c")
            ax[0].set_ylabel("B.ey / c")
            ax[0].legend(fontsize=6)
            e = np.hypot(revs["B.ex"], revs["B.ey"]) / c
            ax[1].plot(revs["rev"], e, ".", ms=3)
            ax[1].set_xlabel("revolution of control")
            ax[1].set_ylabel("|e| / c at the section")
            if cap is not None:
                ax[1].axvline(cap, color="k", ls=":", lw=0.8)
        rep.figure(fig, caption=(
            "Stroboscopic section (crank angle 0) of the journal eccentricity: the free run (grey), "
            "the controlled run before (blue) and after (red) the capture; after it the points "
            "collapse to one (period 1) at |e| / c > 1 (penetration: permanent contact)."))
        with rep.style():
            fig, ax = rep.subplots(1, 1, title="Stability domain: lambda1 of the closed loop against the gain")
            ok = np.isfinite(dom["lambda1"])
            ax.errorbar(dom["K"][ok], dom["lambda1"][ok], yerr=dom["uncertainty"][ok].fillna(0),
                        fmt="-", color="tab:blue", lw=0.8, capsize=2,
                        label=f"EDFC, R = {s['memory']:g}")
            # the table's verdict on each point (STABLE_RULE): filled / open / cross
            for v, mk, fc in (("stable", "o", "tab:blue"), ("undecided", "o", "white"),
                              ("unstable", "x", "tab:blue")):
                sel = ok & (dom["verdict"] == v)
                if sel.any():
                    ax.plot(dom["K"][sel], dom["lambda1"][sel], mk, ms=4, mec="tab:blue",
                            mfc=fc, ls="none", label=v)
            ax.axhline(lam_f, color="tab:red", lw=1, label="free mechanism")
            ax.axhspan(lam_f - se_f, lam_f + se_f, color="tab:red", alpha=0.15)
            ax.axhline(0, color="k", lw=0.6)
            ax.axvline(s["gain"], color="grey", ls=":", lw=0.8, label="default K")
            ax.set_xlabel("gain K [N m s/rad]")
            ax.set_ylabel("lambda1 [per revolution]")
            ax.legend(fontsize=7)
        sd = o["stability_domain"]
        rep.figure(fig, caption=(
            f"lambda1 ± its uncertainty at each gain (filled: stable, open: undecided, cross: "
            f"unstable, as in the table; {STABLE_RULE}), from the end of the controlled run: "
            f"{sd['transient_revs']} revolutions under that gain, then lambda1 over "
            f"{sd['span_revs']} (two trajectories, renormalised every quarter revolution; "
            f"conditional on the contact memory where the motion stays in permanent contact). Red "
            f"line and band: the free mechanism's lambda1 ± SE."))
        rep.table("Stability domain", dom, {"K": "N m s/rad", "lambda1": "1/rev",
                                             "uncertainty": "1/rev"},
                  notes=[STABLE_RULE + "."])
        rep.table("What it takes in torque", tq, {"rms": "N m", "peak": "N m"}, notes=[
            "Control torque u on the rod from the controlled run's samples (50 per revolution: "
            "the peaks of short impacts are not resolved); 'during capture' from the start of "
            "control to the capture revolution. The crank's drive torque: the torque the "
            "constant-speed driver supplies in the free run (nld.run.simulate, driver.torque) over "
            "its steady revolutions."])
        rep.table("Summary", summ.drop(columns=["note"]).iloc[:11],
                  {"value": "", "uncertainty": ""})
        rep.text_page("Orbits and the odd-number limitation", [
            f"{q}: {t}" for q, t in zip(summ["quantity"].iloc[11:], summ["note"].iloc[11:])] + [
            f"Target found before control: {s.get('target_found_by')}. Orbit of the controlled "
            f"motion: Newton from its last state (the free mechanism). Distances: scaled states "
            f"(clearance-based scales, angles mod 2 pi), the largest over the last revolution."])
        rep.text_page("Comparison with Olyaei & Ghazavi (2012)", OLYAEI_TEXT)


def main(quick: bool = False, out_dir: Path = Path("reports"), *, smoke: bool = False) -> Path:
    """Free run, the controlled run with its stability domain, the tables and the report."""
    from nld.model.scene import resolve_scene
    from nld.study import Study
    study = Study(globals(), quick, out_dir, smoke=smoke)
    st = study.settings
    study.stage(f"free run: {st['free_transient']} + {st['free_revs']} revolutions")
    free = free_case(st)
    study.stage(f"nld control: {st['transient']} + {st['revs']} revolutions, {len(st['gains'])} gains")
    ctl = controlled_case(st, lambda text: study.stage(text))
    revs = per_revolution(ctl)
    tq, dom = torque_table(ctl, free), domain_table(ctl)
    secs, summ = sections_table(ctl, free, revs), summary_table(ctl, free)
    study.stage("writing the data and the report")
    study.provenance(scene=resolve_scene(SCENE, OVERRIDES), overrides=OVERRIDES,
                     integrator="delay DOPRI5 (nld.integrators.delay) / dopri5", paper=CITATION,
                     settings=st, command=ctl["out"]["provenance"].get("command"),
                     control_settings=ctl["out"]["settings"], control_wall_s=ctl["wall_s"],
                     free_wall_s=free["wall_s"], compute_wall_s=study.elapsed())
    for suffix, df in (("_summary.csv", summ), ("_domain.csv", dom), ("_revolutions.csv", revs),
                       ("_sections.csv", secs), ("_torque.csv", tq), ("_history.parquet", ctl["history"])):
        study.save(suffix, df)
    report(study, ctl, free, revs, secs, tq, dom, summ)
    return study.pdf


if __name__ == "__main__":
    import sys
    print(main(quick="--quick" in sys.argv, smoke="--smoke" in sys.argv))
