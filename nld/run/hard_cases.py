"""Named hard regression cases for the integrators (docs/integrator.md, "Hard cases").

Issue 5: the seed's K1 = 9.59e11 at r = 0.01 mm, 0.5 mm clearance at 5000 rpm, Coulomb f = 0.05 with
slip reversals inside contacts, a grazing contact that barely touches, 10^4 revolutions without drift
in energy or power balance, a crank at 10 000 rpm, and a stiff damped contact. Each must either run
within its tolerance or stop with a clear message; none may return NaN or a silently wrong answer.

Each case is ``(scene, overrides, revs, rtol, method, expectation)`` plus the means to check it:
``run_case(name)`` runs it and

* checks the outcome against ``expectation``: ``"success"`` (status 0, every output finite), or
  ``"stop:<fragment>"`` (a failure status whose message contains the fragment: a clear stop, not
  garbage);
* for a successful run, compares the journal positions (ex, ey of every clearance joint) on a short
  window ``[0, ref_revs]`` with a run by a different method or a much tighter tolerance
  (``ref_method``/``ref_rtol``): the largest difference must be below ``ref_bound`` (m), so an
  answer that is finite but wrong is caught;
* runs the case's physics check (``check``): slip reversals inside contacts (their count agrees
  with the reference run's), grazing contacts found with their tiny penetration (every onset and
  loss of the reference run, none more), or the energy / power balance drift.

``run_case(name, quick=True)`` runs the shortened variant (``quick_revs``) that the default test run
uses. ``run_case`` returns a :class:`CaseReport` (``passed``, the checks with values and bounds, the
result); ``nld hard-cases [--quick] [name ...]`` (nld.cli.hard_cases) prints the reports (``--list``: the
cases).
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from nld.run.simulate import SimulationResult, crank_period, simulate

# free crank (torque mode, no motor torque), elastic Hertz contact, no friction: energy is conserved
CONSERVATIVE = ('driver.mode="torque"', 'joints.B.contact.law="hertz"')
STIFF_DAMPED = ("driver.speed=15.0", 'joints.B.contact.law="hertz_damped"',
                "joints.B.contact.damping=2e6", "joints.B.contact.stiffness=1e10")


@dataclass(frozen=True)
class HardCase:
    scene: str
    overrides: tuple[str, ...]
    revs: float                      # full length (crank revolutions, nominal in torque mode)
    rtol: float
    method: str
    expectation: str                 # "success" | "stop:<fragment of the message>"
    description: str = ""
    quick_revs: float | None = None  # shortened variant of the default test run (None: as revs)
    ref_method: str = "dop853"       # comparison run on [0, ref_revs] (successful cases)
    ref_rtol: float = 1e-11
    ref_revs: float = 0.1
    ref_bound: float = 1e-6          # m, largest journal-position difference allowed
    check: str = ""                  # "slip_reversal" | "grazing" | "energy" | ""
    check_bound: float = 0.0
    quick_check_bound: float | None = None  # bound of the quick variant's check (None: as check_bound)
    samples_per_rev: int = 360
    max_steps: int = 50_000_000

    def as_tuple(self):
        return (self.scene, self.overrides, self.revs, self.rtol, self.method, self.expectation)

    @property
    def has_long_variant(self) -> bool:
        return self.quick_revs is not None and self.quick_revs != self.revs


CASES: dict[str, HardCase] = {
    # the seed paper's K1 = 9.59e11 N/m^1.5 at the excavator's joint A, with r = 0.01 mm there
    # (joint B keeps 0.03 mm, K2 = 3.66e11): persistent two-joint contact, Coulomb friction at
    # both joints. dopri5 steps are ~1e-7 s and more than half of them are rejected; the reference
    # is dopri5 at a 10x tighter rtol (1e-9 costs 1.1e6 steps for 0.02 revolution).
    "seed_k1_r001": HardCase(
        "excavator", ("joints.A.clearance=1e-5",), 1.0, 1e-7, "dopri5", "success",
        "seed K1 = 9.59e11 N/m^1.5 at r = 0.01 mm (excavator, joints A and B in contact)",
        quick_revs=0.1, ref_method="dopri5", ref_rtol=1e-8, ref_revs=0.05, ref_bound=2e-9),
    # the Flores benchmark as it is: 0.5 mm, 5000 rpm, Lankarani-Nikravesh, free flight and impacts
    "flores_05mm_5000rpm": HardCase(
        "slider_crank", (), 10.0, 1e-8, "dopri5", "success",
        "0.5 mm clearance at 5000 rpm (slider_crank default)",
        quick_revs=2.0, ref_revs=0.25, ref_bound=1e-7),
    # Coulomb friction f = 0.05 at the 0.5 mm joint: the friction force flips with the slip inside
    # contacts (a jump of the rhs that no event locates); the reversals counted in the output must
    # be those of a run at a 1000x tighter tolerance
    "coulomb_f005": HardCase(
        "slider_crank", ('joints.B.friction.law="coulomb"', "joints.B.friction.mu=0.05"), 5.0, 1e-8,
        "dopri5", "success",
        "Coulomb friction f = 0.05, slip reversals inside contacts",
        quick_revs=1.0, ref_method="dopri5", ref_rtol=1e-11, ref_revs=0.5, ref_bound=3e-7,
        check="slip_reversal", check_bound=2, samples_per_rev=7200),
    # ref_bound: the rtol 1e-8 run's journal error on 0.5 rev scatters 1.3e-8 ... 2.1e-7 m over
    # rtol 0.7e-8 ... 1.3e-8 and event_samples 0 ... 6 (21 runs; the references at rtol 1e-11,
    # 1e-12 and dop853 1e-12 agree to 2e-10 m whatever the sampling): 1e-7 was one lucky draw
    # (almost) no gravity, 0.01 mm clearance, a crawling crank (1 rad/s) and K = 1e12: the journal
    # drifts across the clearance under the tiny inertia forces and barely touches: ~110 contacts
    # of 0.08-0.35 ms with peak penetrations of at most 35 nm. Every one must be found (a missed
    # one changes the trajectory) and none may be invented. Gravity is 1e-6 m/s^2, not 0, so that
    # the kernel is slider_crank's (a zero component drops the gravity code: another kernel to
    # compile). Journal error vs dop853 1e-12 on 0.05 rev: 9.3e-10 m at rtol 1e-8, 2.5e-11 at
    # 1e-9, 1.9e-12 at 1e-10 (large for rtol 1e-8: grazing contacts are ill-conditioned).
    "grazing": HardCase(
        "slider_crank", ("scene.gravity=[0.0, -1e-6]", "joints.B.clearance=1e-5", "driver.speed=1.0",
                         "joints.B.contact.stiffness=1e12"), 0.05, 1e-8, "dopri5", "success",
        "grazing contacts: max penetration < 0.1 um, every contact found",
        quick_revs=0.02, ref_rtol=1e-12, ref_revs=0.05, ref_bound=3e-9, check="grazing",
        check_bound=1e-7),
    # free crank, elastic Hertz contact, no friction: energy is conserved exactly; 10^4 nominal
    # revolutions, ~8e5 impacts, 7.7e7 steps (the quick variant: 200 revolutions). dopri5 loses
    # ~9e-9 of the energy per revolution, steadily: 8.9e-5 at 10^4 revolutions (doc)
    "energy_10krev": HardCase(
        "slider_crank", CONSERVATIVE, 1.0e4, 1e-10, "dopri5", "success",
        "conservative free crank, 10^4 revolutions: no drift of energy",
        quick_revs=200.0, ref_method="dopri5", ref_rtol=1e-12, ref_revs=0.05, ref_bound=1e-8,
        check="energy", check_bound=2e-4, quick_check_bound=2e-6, samples_per_rev=4,
        max_steps=300_000_000),
    # the same with DOP853, the higher-order method (docs/integrator.md, "Hard cases"; it stopped
    # with a non-finite state after ~905 revolutions until issue 38: a step whose end derivative,
    # the next step's first stage, was not finite was accepted). Energy drift measured at 10^4
    # revolutions: 2.35e-5 (605 625 impacts; proportional to rtol: 4.0e-7 / 7.0e-8 / 2.1e-8 at
    # 300 revolutions and rtol 1e-9 / 1e-10 / 1e-11); the bound 2e-5 had been extrapolated from
    # 905 revolutions, now 5e-5 (2.1x the measured, as dopri5's 2e-4 is 2.2x its 8.9e-5)
    "energy_10krev_dop853": HardCase(
        "slider_crank", CONSERVATIVE, 1.0e4, 1e-10, "dop853", "success",
        "conservative free crank, 10^4 revolutions with dop853",
        quick_revs=200.0, ref_method="dopri5", ref_rtol=1e-12, ref_revs=0.05, ref_bound=1e-8,
        check="energy", check_bound=5e-5, quick_check_bound=1e-6, samples_per_rev=4,
        max_steps=300_000_000),
    # power balance with a motor: constant torque T0 = 0.05 N m on the free crank, conservative
    # contact: E(t) - E(0) = T0 (theta(t) - theta(0)) exactly, and the power column integrates to it
    "power_balance": HardCase(
        "slider_crank", CONSERVATIVE + ("driver.torque=0.05",), 100.0, 1e-10, "dopri5", "success",
        "free crank with a constant motor torque: E - E0 = work of the motor",
        quick_revs=5.0, ref_method="dopri5", ref_rtol=1e-12, ref_revs=0.05, ref_bound=1e-8,
        check="energy", check_bound=1e-6, samples_per_rev=720),
    # 10 000 rpm (1047 rad/s): contact forces up to 1.1e5 N (5000 rpm: 2.7e4 N), 90 impacts in 10 rev
    "crank_10000rpm": HardCase(
        "slider_crank", ("driver.speed=1047.2",), 10.0, 1e-8, "dopri5", "success",
        "crank at 10 000 rpm",
        quick_revs=2.0, ref_revs=0.25, ref_bound=1e-7),
    # heavily damped persistent contact (C = 2e6 N s/m, K = 1e10): stiff (C / m ~ 1e7 1/s).
    # The explicit 8th-order method must stop with a clear message (rather than go on with noisy
    # stiff components); the stiff solver runs it in ~2200 steps (dopri5 needs ~1.1e6).
    "stiff_damped_dop853": HardCase(
        "slider_crank", STIFF_DAMPED, 0.5, 1e-6, "dop853", "stop:became stiff",
        "stiff damped contact with dop853: stops, names rodas"),
    "stiff_damped_rodas": HardCase(
        "slider_crank", STIFF_DAMPED, 0.5, 1e-6, "rodas", "success",
        "stiff damped contact with rodas",
        ref_method="dopri5", ref_rtol=1e-8, ref_revs=0.5, ref_bound=5e-6),
    # the same at a tight tolerance: rodas at rtol <= 1e-9 stops with a step size underflow at the
    # first contact onset (the damping force jumps there by C * approach speed); see the doc
    "stiff_damped_rodas_tight": HardCase(
        "slider_crank", STIFF_DAMPED, 0.5, 1e-9, "rodas", "success",
        "stiff damped contact with rodas at rtol 1e-9",
        ref_method="dopri5", ref_rtol=1e-8, ref_revs=0.5, ref_bound=5e-6),
}


@dataclass
class Check:
    name: str
    value: float
    bound: float
    ok: bool
    note: str = ""

    def __str__(self):
        return f"{'ok  ' if self.ok else 'FAIL'} {self.name}: {self.value:.4g} (bound {self.bound:.4g}) {self.note}"


@dataclass
class CaseReport:
    name: str
    case: HardCase
    revs: float
    result: SimulationResult
    checks: list[Check] = field(default_factory=list)
    reference: SimulationResult | None = None
    wall: float = 0.0

    @property
    def passed(self) -> bool:
        return bool(self.checks) and all(c.ok for c in self.checks)

    def check(self, prefix: str) -> Check:
        """The first check whose name starts with ``prefix``."""
        return next(c for c in self.checks if c.name.startswith(prefix))

    def summary(self) -> str:
        head = (f"{self.name}: {'PASS' if self.passed else 'FAIL'} ({self.wall:.2f} s) "
                f"{self.case.description}; {self.case.scene} {' '.join(self.case.overrides)} "
                f"revs {self.revs:g} rtol {self.case.rtol:g} {self.case.method}\n  {self.result.message}")
        return head + "".join(f"\n  {c}" for c in self.checks)


def _journal_cols(result: SimulationResult) -> list[str]:
    return [c for c in result.table.columns if c.endswith(".ex") or c.endswith(".ey")]


def _joints(result: SimulationResult) -> list[str]:
    return sorted({c.split(".")[0] for c in _journal_cols(result)})


def _contact_intervals(contact: np.ndarray):
    """Index arrays of the runs of consecutive rows in contact."""
    idx = np.flatnonzero(np.diff(contact.astype(int)) != 0) + 1
    return [b for b in np.split(np.arange(len(contact)), idx) if len(b) and contact[b[0]]]


def slip_reversals(table, joint: str, n_rows: int | None = None) -> tuple[int, int, int]:
    """(reversals, contact intervals with at least one, contact intervals) in the first ``n_rows``
    output rows: a reversal is a sign change of the slip velocity between consecutive output rows
    of one contact interval."""
    tab = table if n_rows is None else table.iloc[:n_rows]
    contact = tab[f"{joint}.contact"].to_numpy() > 0
    s = np.sign(tab[f"{joint}.slip"].to_numpy())
    runs = [b for b in _contact_intervals(contact) if len(b) > 1]
    per = [int(np.sum(s[b][1:] * s[b][:-1] < 0)) for b in runs]
    return sum(per), sum(1 for k in per if k), len(runs)


def _check_slip_reversal(case, res, ref, n_win) -> list[Check]:
    checks = []
    for jn in _joints(res):
        rev, with_rev, runs = slip_reversals(res.table, jn)
        checks.append(Check(f"{jn}: contacts with a slip reversal", with_rev, case.check_bound,
                            with_rev >= case.check_bound,
                            f"of {runs} contact intervals, {rev} reversals in all"))
        if ref is not None:
            r_run = slip_reversals(res.table, jn, n_win)
            r_ref = slip_reversals(ref.table, jn, n_win)
            checks.append(Check(f"{jn}: slip reversals on the window vs reference", r_run[0], r_ref[0],
                                r_run == r_ref,
                                f"(reversals, contacts with one, contacts) {r_run} vs {r_ref}"))
    return checks


def _check_grazing(case, res, ref) -> list[Check]:
    pen = [c for c in res.table.columns if c.endswith(".penetration")]
    pmax = max(float(res.table[c].max()) for c in pen)
    n_on = int((res.events.direction == 1).sum())
    checks = [Check("max penetration (m, dense output)", pmax, case.check_bound,
                    0.0 < pmax < case.check_bound, f"positive: the contacts are found ({n_on} onsets)")]
    if ref is not None:
        t_end = ref.t_reached * (1 + 1e-12)
        n_ref = len(ref.events)
        mine = res.events[res.events.t <= t_end]
        n = len(mine)
        checks.append(Check("contact events vs reference", n, n_ref,
                            n == n_ref and list(mine.direction) == list(ref.events.direction),
                            "onsets and losses on the window, same sequence"))
        if n == n_ref and n >= 2:
            # grazing onsets are ill-conditioned (time error = position error / normal approach
            # speed: on 0.05 rev the positions agree to 2e-10 m, the onset times to 1.7e-5 s),
            # so the times are not compared to a fixed bound: each
            # contact interval must overlap its reference counterpart (the same contact)
            a, b = mine.t.to_numpy(), ref.events.t.to_numpy()
            m = len(a) // 2 * 2
            d = np.asarray(mine.direction)
            pairs = bool(np.all(d[:m:2] == 1) and np.all(d[1:m:2] == -1))
            overlap = np.maximum(a[:m:2], b[:m:2]) < np.minimum(a[1:m:2], b[1:m:2])
            n_bad = int(np.sum(~overlap)) if pairs else m // 2
            dt = float(np.abs(a - b).max())
            checks.append(Check("contacts not overlapping their reference contact", n_bad, 0,
                                n_bad == 0, f"of {m // 2}; largest event time difference {dt:.3g} s, "
                                f"contacts last {np.min(a[1:m:2] - a[:m:2]):.3g} s or more"))
    return checks


def _motor_torque(case) -> float:
    """Constant motor torque of a torque-driven scene without a speed slope (0 otherwise)."""
    sc = _scene(case)
    d = sc.driver
    if d is None or d.mode != "torque" or d.torque_slope != 0.0 or sc.loads:
        return 0.0
    return float(d.torque)


def _check_energy(case, res, revs) -> list[Check]:
    tab = res.table
    E = tab["energy.total"].to_numpy()
    t = tab["t"].to_numpy()
    scale = max(float(np.abs(E).max()), float(np.abs(tab["energy.kinetic"]).max()))
    n_contacts = int((res.events.direction == 1).sum())
    if len(res.events) < res.stats["events"]:      # the event log is capped (1e6 entries)
        n_contacts = res.stats["events"] // 2
    T0 = _motor_torque(case)
    if T0 == 0.0:
        P = (tab["power.driver"] + tab["power.loads"]).to_numpy()
        ok_p = bool(np.all(P == 0.0))
        drift = float(np.abs(E - E[0]).max() / scale)
        return [Check("relative energy drift max|E - E0| / E", drift, case.check_bound,
                      drift < case.check_bound,
                      f"over {revs:g} nominal revolutions, {n_contacts} impacts"),
                Check("no power input (power.driver + power.loads == 0)", float(np.abs(P).max()), 0.0, ok_p)]
    # constant motor torque: the work done is T0 * (theta - theta0), exactly
    th = tab["driver.angle"].to_numpy()
    W = T0 * (th - th[0])
    balance = float(np.abs(E - E[0] - W).max() / scale)
    P = (tab["power.driver"] + tab["power.loads"]).to_numpy()
    Wp = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(t))])
    quad = float(np.abs(Wp - W).max() / scale)
    return [Check("power balance max|E - E0 - T0 (theta - theta0)| / E", balance, case.check_bound,
                  balance < case.check_bound,
                  f"over {revs:g} nominal revolutions, {n_contacts} impacts, work {W[-1]:.4g} J"),
            Check("power column: |int P dt - T0 (theta - theta0)| / E (trapezoid)", quad,
                  10 * case.check_bound, quad < 10 * case.check_bound)]


def run_case(name: str, *, revs: float | None = None, quick: bool = False,
             compare: bool = True) -> CaseReport:
    """Run the named case and check it; see the module doc. ``quick``: its shortened variant;
    ``revs`` overrides the length."""
    if name not in CASES:
        raise KeyError(f"unknown hard case {name!r}: {', '.join(CASES)}")
    case = CASES[name]
    if revs is None:
        revs = case.quick_revs if (quick and case.quick_revs is not None) else case.revs
    start = time.perf_counter()
    per = crank_period(_scene(case))
    kw = dict(overrides=list(case.overrides), samples_per_rev=case.samples_per_rev,
              max_steps=case.max_steps)
    if case.check == "grazing":
        # outputs every 2 us of simulated time: the contacts last tens of us
        kw["samples_per_rev"] = int(math.ceil(per / 2e-6))
    res = simulate(case.scene, revs=revs, rtol=case.rtol, method=case.method, **kw)
    report = CaseReport(name, case, revs, res)
    if case.quick_check_bound is not None and revs != case.revs:
        case = replace(case, check_bound=case.quick_check_bound)
        report.case = case
    checks = report.checks
    finite = bool(np.all(np.isfinite(res.table.to_numpy()))) and bool(np.all(np.isfinite(res.y_final)))
    if case.expectation == "success":
        ok = res.status == 0
        checks.append(Check("status (0: reached t_end)", res.status, 0, ok, "" if ok else res.message))
        checks.append(Check("all outputs finite", float(finite), 1.0, finite))
    else:
        frag = case.expectation.split(":", 1)[1]
        ok = res.status < 0 and frag in res.message
        checks.append(Check(f"stops with a message containing {frag!r}", res.status, -1, ok))
        checks.append(Check("outputs before the stop finite", float(finite), 1.0, finite))
        report.wall = time.perf_counter() - start
        return report

    ref = None
    n_win = 0
    if compare and res.status == 0:
        t = res.table["t"].to_numpy()
        t_win = t[0] + min(case.ref_revs, revs) * per
        te = t[t <= t_win * (1 + 1e-12)]
        n_win = len(te)
        head = res.table.iloc[:n_win]
        if n_win < 50:
            # sparse output (long runs): the window again with dense output; the steps do not
            # depend on the output times, so this is the start of the same run
            te = np.linspace(t[0], t_win, 201)
            head = simulate(case.scene, t_end=float(te[-1]), t_eval=te, rtol=case.rtol,
                            method=case.method, overrides=list(case.overrides),
                            max_steps=case.max_steps).table
        ref = simulate(case.scene, t_end=float(te[-1]), t_eval=te, rtol=case.ref_rtol,
                       method=case.ref_method, overrides=list(case.overrides), max_steps=case.max_steps)
        report.reference = ref
        if ref.status != 0:
            checks.append(Check("reference run", ref.status, 0, False, ref.message))
            ref = None
        else:
            cols = _journal_cols(res)
            err = float(np.abs(head[cols].to_numpy() - ref.table[cols].to_numpy()).max())
            checks.append(Check(f"journal position vs {case.ref_method} rtol {case.ref_rtol:g} (m)",
                                err, case.ref_bound, err <= case.ref_bound,
                                f"on the first {min(case.ref_revs, revs):g} revolutions"))
    if case.check == "slip_reversal":
        checks += _check_slip_reversal(case, res, ref, n_win)
    elif case.check == "grazing":
        checks += _check_grazing(case, res, ref)
    elif case.check == "energy":
        checks += _check_energy(case, res, revs)
    report.wall = time.perf_counter() - start
    return report


def _scene(case: HardCase):
    from nld.model.scene import load_scene
    return load_scene(case.scene, list(case.overrides))
