"""Chaos control: time-delayed feedback (Pyragas), its extended form (EDFC) and OGY, with the
evidence that control worked (closed-loop lambda1, control effort, distance to the target orbit).

**Delayed feedback** (Pyragas 1992, Phys. Lett. A 170:421; extended: Socolar, Sukow & Gauthier
1994, Phys. Rev. E 50:3245) on a measured signal s(t) = y_c(t) (a state component):

    u(t) = K [ (1 - R) sum_{k>=1} R^(k-1) s(t - k tau) - s(t) ],    R in [0, 1)

computed in the exact recursive form u = K (v - s), v(t) = (1 - R) s(t - tau) + R v(t - tau)
(nld.integrators.delay). u enters either **added to one state derivative** (Pyragas' Rössler
example: on dy/dt) or **added to one parameter** of p (a scene's load value, driven the same way).
u vanishes on any tau-periodic motion: control that captures an unstable period-tau orbit is
non-invasive, its effort falls to a small fraction. ``u_max`` clips |u| (Pyragas 1992 limited the
perturbation the same way). R = 0 is Pyragas' control.

**Closed-loop lambda1** (:func:`delayed_lyapunov`). The state of a delay equation is the function
segment y on [t - tau_max, t] (with the EDFC channel v on it), an infinite-dimensional state
(Farmer 1982, Physica D 4:366). Its tangent dynamics are the linear delay equation

    w'(t) = D_y f w(t) + sum_i b_i K [ (1 - R) sum_k R^(k-1) w_c(t - k tau) - w_c(t) ]

(b_i the input direction; for a parameter input b = D_p f), whose largest exponent is lambda1.
Here it is estimated by two trajectories (Benettin et al. 1980, as Farmer did for the
Mackey-Glass equation): a perturbed copy carries its *own* history; every renormalisation
interval the distance is measured over the whole segment (RMS of the scaled difference on
``SEGMENT_SAMPLES`` + 1 points of [t - tau_max, t]), and the copy's *whole history segment* (state
and channel pieces) is pulled back to ref + (d0 / d)(copy - ref), exactly (nld.integrators.delay.
combine_histories: both are piecewise quartics). lambda1 = mean of ln(d / d0) per unit time;
the first intervals (a quarter of the span) are not counted (alignment); its uncertainty the
standard error of batch means (4 or more batches) combined with the difference of the two
halves' means.

**OGY** (Ott, Grebogi & Yorke 1990, PRL 64:1196) on a map x_{n+1} = P(x_n, p): a DiscreteMap (the
Hénon map) or a flow's StroboscopicMap (one forcing period; a scene: one crank revolution). The
target is a period-q orbit x_i* from nld.analysis.orbits.periodic_orbit; A_i the map's Jacobian
(step(jacobian=True): the monodromy for a flow), w_i = dP/dp by central finite differences in the
parameter. Near x_i* (scaled distance < ``radius``) the parameter is perturbed for one
iteration (then left alone for the q - 1 after it) by dp = -k_i . (x - x_i*), k_i by pole placement (Ackermann's formula;
Romeiras, Grebogi, Ott & Dayawansa 1992, Physica D 58:165) on the q-step map M_i with input
w~_i = A_{i+q-1} ... A_{i+1} w_i that moves every unstable eigenvalue to 0 and keeps the stable
ones. With one unstable real eigenvalue lambda_u (left eigenvector f_u) this is OGY's formula
dp = -lambda_u (f_u . dx) / (f_u . w~). Where the required |dp| exceeds ``dp_max`` there is no
control (dp = 0), as in OGY 1990: the chaotic motion itself brings the state close enough.

**Odd-number limitation** (:func:`odd_number_limitation`): an orbit with an odd number of real
Floquet multipliers > 1 cannot be stabilised by delayed feedback with tau = its period in a
non-autonomous system (Nakajima 1997, Phys. Lett. A 232:207; analysis: Just, Bernard, Ostheimer,
Reibold & Benner 1997, PRL 78:203). For autonomous systems the claim is not general (Fiedler,
Flunkert, Georgi, Hövel & Schöll 2007, PRL 98:114101): the function says which case applies.

Units: time in the system's time unit (s for a scene), rates per that unit; lambda1 of a flow
per time unit (and per delay tau in ``per_delay``), of a map per iteration; u in the unit of the
quantity it is added to (a state derivative or the parameter); gains in unit(u) / unit(s).
docs/control.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numba import njit

from nld.errors import InputError, SolveError
from nld.systems.rossler import rossler  # noqa: F401  (the reference flow; defined with the built-in systems)
from nld.integrators import method_status_message
from nld.integrators.delay import (PARAM, STATE, DelayLaw, History, combine_histories,
                                   constant_history, dde, history_eval)

__all__ = ["DelayedFeedback", "delayed_feedback", "pyragas", "edfc", "DelayedRun",
           "run_delayed", "DelayLyapunov", "delayed_lyapunov", "ControlResult",
           "control_delayed", "effort_decay_rate", "DomainScan", "stability_domain", "OddNumberVerdict",
           "odd_number_limitation", "OGYResult", "ogy", "orbit_states", "distance_to_orbit",
           "RTOL", "D0", "SEGMENT_SAMPLES", "CAPTURE_FRACTION"]

RTOL = 1e-9               # relative tolerance of the delay integrations (atol: system.tolerance)
D0 = 1e-7                 # Benettin: separation after each renormalisation (scaled RMS)
SEGMENT_SAMPLES = 64      # points of the history segment in the separation norm
CAPTURE_FRACTION = 0.05   # captured: per-period effort rms below this fraction of the first's
MAX_STEPS = 10_000_000


# ---------------------------------------------------------------- input checks
def _finite(name: str, value, allowed: str) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(f"{name} = {value!r}: {allowed}") from None
    if not math.isfinite(v):
        raise InputError(f"{name} = {value!r}: {allowed}")
    return v


def _count(name: str, value, minimum: int, what: str) -> int:
    """A whole number >= minimum (InputError naming ``name``, the value and what is allowed)."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        raise InputError(f"{name} = {value!r}: must be a whole number >= {minimum} ({what})")
    return int(value)


def _state_index(system, value, field_name: str) -> tuple[int, str]:
    names = list(system.state_names)
    if isinstance(value, str):
        if value not in names:
            raise InputError(f"{field_name} = {value!r}: no such state of {system.name}; "
                             f"states: {', '.join(names)}")
        return names.index(value), value
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool) and 0 <= value < len(names):
        return int(value), names[int(value)]
    raise InputError(f"{field_name} = {value!r}: a state name ({', '.join(names)}) or an index "
                     f"0..{len(names) - 1}")


def _param_index(system, value, field_name: str) -> tuple[int, str]:
    """(index of p, label) of the parameter ``value`` of ``system`` (``System.parameter_index``)."""
    i = system.parameter_index(value, field_name)
    names = list(system.param_names)
    return i, value if isinstance(value, str) else (names[i] if i < len(names) else f"p[{i}]")


# ---------------------------------------------------------------- delayed feedback
@dataclass(frozen=True)
class DelayedFeedback:
    """A delayed-feedback controller u = K [(1 - R) sum R^(k-1) s(t - k tau) - s(t)] (module
    docstring). gain K (unit(u) / unit(s)); delay tau (system time unit, > 0); memory R in
    [0, 1) (0: Pyragas); signal: state index (and name) of s; input "state" (u added to the
    derivative of state ``target``) or "param" (u added to parameter ``target`` of p); u_max:
    |u| clip (inf: none). Made by :func:`delayed_feedback` (checked)."""
    gain: float
    delay: float
    memory: float
    signal: int
    signal_name: str
    input: str
    target: int
    target_name: str
    u_max: float = math.inf

    def law(self, system, gain: float | None = None) -> DelayLaw:
        """The nld.integrators.delay law of this controller for ``system`` (gain overridable:
        a gain sweep reuses everything else)."""
        K = self.gain if gain is None else float(gain)
        n = system.n
        gy = np.zeros((1, n))
        gy[0, self.signal] = -K
        return DelayLaw.make(n, system.p.size, [self.delay], [self.signal], [self.memory],
                             gd=[[K]], gy=gy, u0=[0.0], u_max=[self.u_max],
                             kinds=[STATE if self.input == "state" else PARAM],
                             targets=[self.target])

    def with_(self, **changes) -> "DelayedFeedback":
        d = dict(self.__dict__)
        d.update(changes)
        return DelayedFeedback(**d)

    def to_dict(self) -> dict:
        return {"gain": self.gain, "delay": self.delay, "memory": self.memory,
                "signal": self.signal_name, "input": self.input, "target": self.target_name,
                "u_max": None if math.isinf(self.u_max) else self.u_max,
                "method": "pyragas" if self.memory == 0 else "edfc"}


def delayed_feedback(system, gain, delay, signal, *, memory=0.0, input: str = "state",
                     target=None, u_max=math.inf) -> DelayedFeedback:
    """A checked :class:`DelayedFeedback` for ``system`` (a ContinuousSystem or a scene system).

    signal: a state name or index; input "state" with target a state name/index (default the
    signal's own derivative) or "param" with target a parameter name (``system.param_names``) or
    index of p (a scene: an entry of its parameter vector, e.g. ``loads.0.value``,
    ``driver.torque``). InputError (one line: field, value, what is allowed) for a negative or zero
    delay, an unknown signal or target, R outside [0, 1), a gain that is not finite."""
    K = _finite("gain", gain, "K must be a finite number (unit of u per unit of the signal)")
    tau = _finite("delay", delay, "tau must be a positive finite time (the target orbit's "
                                  "period)")
    if tau <= 0:
        raise InputError(f"delay = {delay!r}: tau must be a positive finite time (the target "
                         f"orbit's period)")
    R = _finite("memory", memory, "R must be in [0, 1) (0: Pyragas)")
    if not 0.0 <= R < 1.0:
        raise InputError(f"memory = {memory!r}: R must be in [0, 1) (0: Pyragas; EDFC weights "
                         f"period k by R^(k-1))")
    si, sn = _state_index(system, signal, "signal")
    if input == "state":
        ti, tn = _state_index(system, si if target is None else target, "target")
    elif input == "param":
        if target is None:
            raise InputError("target = None: input 'param' needs a parameter name or index")
        ti, tn = _param_index(system, target, "target")
    else:
        raise InputError(f"input = {input!r}: 'state' (u added to a state derivative) or 'param' "
                         f"(u added to a parameter)")
    um = float(u_max)
    if not um > 0:
        raise InputError(f"u_max = {u_max!r}: must be > 0 (inf: no limit)")
    return DelayedFeedback(K, tau, R, si, sn, input, ti, tn, um)


def pyragas(system, gain, delay, signal, **kw) -> DelayedFeedback:
    """Pyragas' control u = K (s(t - tau) - s(t)) (:func:`delayed_feedback` with R = 0)."""
    return delayed_feedback(system, gain, delay, signal, memory=0.0, **kw)


def edfc(system, gain, delay, signal, memory, **kw) -> DelayedFeedback:
    """Extended delayed feedback (Socolar et al. 1994) with memory R (:func:`delayed_feedback`)."""
    return delayed_feedback(system, gain, delay, signal, memory=memory, **kw)


@dataclass
class DelayedRun:
    """A run of the delayed closed loop.

    t (k,) sample times; Y (k, n) states; u (k,) the control input there (effort); v (k,) the
    channel (delayed / EDFC-filtered signal); z the final discrete state; history the final
    history segment (continue a run from it); t_break0 the breaking points' origin; h_last the
    next step; events (k_ev,) event indices with direction (+1 up) ``ev_dir`` and times ``ev_t``;
    status 0 ok (else the integrator's status), message."""
    t: np.ndarray
    Y: np.ndarray
    u: np.ndarray
    v: np.ndarray
    z: np.ndarray
    history: History
    t_break0: float
    h_last: float
    ev_t: np.ndarray
    ev_k: np.ndarray
    ev_dir: np.ndarray
    status: int
    message: str
    settings: dict = field(default_factory=dict)

    @property
    def y(self) -> np.ndarray:
        return self.Y[-1]


def run_delayed(system, fb: DelayedFeedback, duration: float, *, y0=None, z0=None, t0=None,
                history=None, rtol: float = RTOL, samples_per_delay: int = 50,
                t_break0: float | None = None, h0: float = 0.0, gain: float | None = None,
                keep: float | None = None, max_log: int = 100_000,
                chunk: float | None = None, progress=None) -> DelayedRun:
    """Integrate ``system`` under ``fb`` for ``duration`` from (t0, y0, z0) (defaults: the
    system's) with ``history`` (None: constant y0; a History, e.g. ``run.history`` of an earlier
    run, to continue it). Samples every tau / samples_per_delay. ``gain`` overrides fb.gain
    (0: the uncontrolled system, history still recorded). chunk: integrate in pieces of about
    this time, each continuing the last from its history (the same run: control returns to
    Python between pieces, so Ctrl-C is honoured and ``progress(t_done, duration)`` is called
    after each)."""
    dur = _finite("duration", duration, "must be a positive time")
    if dur <= 0:
        raise InputError(f"duration = {duration!r}: must be a positive time")
    samples_per_delay = _count("samples_per_delay", samples_per_delay, 1,
                               "output samples per delay tau")
    check_delay_size(system, fb, dur, samples_per_delay)
    t0 = float(system.t0 if t0 is None else t0)
    y = np.array(system.y0 if y0 is None else y0, dtype=float)
    z = np.array(system.z0 if z0 is None else z0, dtype=float)
    law = fb.law(system, gain)
    dt = fb.delay / int(samples_per_delay)
    k = max(1, int(math.ceil(dur / dt - 1e-9)))
    te = t0 + np.minimum(np.arange(k + 1) * dt, dur)
    per = k if chunk is None else max(1, int(round(float(chunk) / dt)))
    tb0 = float(t0 if t_break0 is None else t_break0)
    Ys, Us, Ss, evt, evk, evd = [], [], [], [], [], []
    i0, h, hist = 0, float(h0), history
    while True:
        i1 = min(k, i0 + per)
        out = dde(system.rhs, system.events, system.on_event, float(te[i0]), y, te[i0:i1 + 1],
                  False, system.p, z, float(rtol), system.tolerance(rtol), h,
                  float(system.hmax), MAX_STEPS, int(system.n_events), int(max_log), law, hist,
                  event_samples=int(system.event_samples), t_break0=tb0, keep=keep)
        sl = slice(0 if i0 == 0 else 1, None)
        Ys.append(out.Y[sl])
        Us.append(out.U[sl, 0])
        Ss.append(out.S[sl, 0])
        n_ev = min(int(out.n_ev), int(max_log))
        evt.append(out.ev_t[:n_ev].copy())
        evk.append(out.ev_k[:n_ev].copy())
        evd.append(out.ev_dir[:n_ev].copy())
        if out.status != 0 or i1 >= k:
            break
        y, h, hist, i0 = out.Y[-1].copy(), out.h_last, out.history, i1
        if progress is not None:
            progress(float(te[i1] - t0), dur)
    msg = method_status_message("dopri5", out.status, out.t, out.stats)
    if out.status != 0:
        te = te[: sum(len(a) for a in Us)]
    if progress is not None and out.status == 0:
        progress(dur, dur)
    return DelayedRun(te, np.vstack(Ys), np.concatenate(Us), np.concatenate(Ss), z,
                      out.history, tb0, out.h_last, np.concatenate(evt), np.concatenate(evk),
                      np.concatenate(evd),
                      int(out.status), "delay DOPRI5 (dde): " + msg.split(": ", 1)[-1],
                      {"controller": fb.to_dict(), "rtol": rtol, "duration": dur,
                       "samples_per_delay": int(samples_per_delay)})


def delay_run_size(system, delay: float, duration: float, samples_per_delay: int) -> tuple:
    """(bytes, steps, shortest_delay) of a delayed run of ``duration`` with delay ``delay``
    (time units): the samples' bytes (one row per tau / samples_per_delay: the state, u, v and
    t, held twice while the pieces are joined), the fewest steps (the step is capped at the
    delay, nld.integrators.delay) and the shortest delay whose run fits both MAX_OUTPUT_BYTES
    and MAX_STEPS."""
    from nld.run.simulate import MAX_OUTPUT_BYTES
    row = 2 * 8 * (int(system.n) + 3)
    rows = float(duration) * int(samples_per_delay) / float(delay) + 1.0
    steps = float(duration) / float(delay)
    shortest = max(float(duration) * int(samples_per_delay) * row / MAX_OUTPUT_BYTES,
                   float(duration) / MAX_STEPS)
    return rows * row, steps, shortest


def check_delay_size(system, fb: DelayedFeedback, duration: float, samples_per_delay: int,
                      field: str = "delay"):
    """InputError naming the delay when a run of ``duration`` under ``fb`` would not fit the
    output limit or MAX_STEPS (checked before any work: a delay of 1e-9 s on a 3.7 s run asked
    for 1.9e11 samples and grew to 24 GB before the system killed it)."""
    from nld.run.simulate import MAX_OUTPUT_BYTES
    need, steps, shortest = delay_run_size(system, fb.delay, duration, samples_per_delay)
    if need > MAX_OUTPUT_BYTES or steps > MAX_STEPS:
        why = (f"{need / 2**30:.3g} GiB of samples at {samples_per_delay} per delay (limit "
               f"{MAX_OUTPUT_BYTES / 2**30:g} GiB)" if need > MAX_OUTPUT_BYTES else
               f"at least {steps:.3g} steps, the step being capped at the delay (limit "
               f"{MAX_STEPS:.3g})")
        raise InputError(f"{field} = {fb.delay!r}: a delay that short makes the {duration:.6g} "
                         f"{system.time_unit} run need {why}; the shortest "
                         f"delay that fits is {shortest:.3g} {system.time_unit}")


def _check_run(run: DelayedRun, what: str):
    if run.status != 0:
        raise SolveError(f"{what}: {run.message}")


# ---------------------------------------------------------------- closed-loop lambda1
@dataclass
class DelayLyapunov:
    """lambda1 of the delayed closed loop (per time unit; ``per_delay`` = lambda1 * tau) with
    its uncertainty (standard error of batch means with the halves' drift), the renormalisation
    intervals counted (n_intervals; ``settings["align"]`` more were run first) and
    the settings."""
    lambda1: float
    uncertainty: float
    per_delay: float
    n_intervals: int
    logs: np.ndarray
    status: str
    message: str
    settings: dict = field(default_factory=dict)


def _segment_difference(system, ref: History, other: History, t: float, span: float,
                        yr, yo, n_samples: int, transverse: bool):
    """(d, c): the scaled RMS distance of two history segments on [t - span, t] (n_samples + 1
    points, the last the current states), after removing the time-shift component c ref'
    (least squares over the segment) when ``transverse``; c = 0 otherwise."""
    ts = np.linspace(t - span, t, n_samples + 1)
    A, _ = history_eval(ref, ts)
    B, _ = history_eval(other, ts)
    A[-1], B[-1] = yr, yo
    D = (B - A) / system.scales
    c = 0.0
    if transverse:
        F, _ = history_eval(ref, ts, derivative=True)
        F /= system.scales
        ff = float(np.sum(F * F))
        if ff > 0:
            c = float(np.sum(D * F)) / ff
            D = D - c * F
    return float(np.sqrt(np.mean(np.sum(D * D, axis=1)))), c


def _field_at(system, fb, law, hist, t, y, z) -> np.ndarray:
    """y'(t) of the closed loop: the last history piece's derivative at its end."""
    return history_eval(hist, [t], derivative=True)[0][0]


def _batch_se(logs: np.ndarray, dt: float) -> float:
    nb = min(10, logs.size // 2)
    if nb < 4:
        return math.nan
    m = logs.size // nb
    means = logs[: nb * m].reshape(nb, m).mean(axis=1) / dt
    return float(np.std(means, ddof=1) / math.sqrt(nb))


def _uncertainty(logs: np.ndarray, dt: float) -> float:
    """The uncertainty of lambda1 = mean(logs) / dt: the standard error of batch means combined
    (in quadrature) with the difference between the means of the two halves of the span. The
    batch means see the scatter but not a drift: on a slowly converging estimate (a stable
    closed loop whose perturbation is still turning into its slowest mode, slow beating of a
    complex pair, a reference still settling) the two halves differ and the batches do not; the
    bias of the whole span's mean is of the order of that difference (docs/control.md, "The
    evidence")."""
    se = _batch_se(logs, dt)
    h = logs.size // 2
    if not math.isfinite(se) or h < 2:
        return se
    drift = abs(float(np.mean(logs[:h]) - np.mean(logs[h:]))) / dt
    return float(math.hypot(se, drift))


def delayed_lyapunov(system, fb: DelayedFeedback, span: float, *, y0=None, z0=None,
                     t0: float | None = None, history=None, t_break0: float | None = None,
                     gain: float | None = None, rtol: float = RTOL, d0: float = D0,
                     interval: float | None = None, segment_samples: int = SEGMENT_SAMPLES,
                     direction=None, transverse: bool | None = None,
                     align: int | None = None, hold_memory: bool = False) -> DelayLyapunov:
    """lambda1 of the closed loop over ``span`` (time units) by two trajectories with whole-
    segment renormalisation (module docstring), from (t0, y0, z0, history) (a run's end: pass
    ``run.t[-1], run.y, run.z, run.history, run.t_break0``). interval: renormalisation interval
    (default tau); d0: the separation (scaled RMS over the segment); direction: the initial
    perturbation of the state (default: all ones, scaled). gain overrides fb.gain (0: the
    uncontrolled system). transverse (default: for an autonomous system, ``system.period`` None):
    remove the time-shift direction (the segment's derivative) from the separation at every
    renormalisation, so that the exponent is the largest *non-trivial* one: on a periodic orbit
    of an autonomous flow (or autonomous delay equation) the trivial one is exactly 0, and a
    captured orbit shows as lambda1 = 0 without this. align: intervals run first and not
    counted (the perturbation turning into the most unstable direction; default None: a quarter
    of the counted ones, at least 2: on a stable closed loop the slowest mode's rate is close to
    the next ones', and the early intervals, where the perturbation still decays in the fast
    modes, biased lambda1 of the captured slider_crank_olyaei orbit to -0.128 per revolution
    against -0.058 from the effort's decay, docs/control.md). The uncertainty is the standard
    error of batch means combined with the difference of the two halves' means (a drift the
    batches do not see). hold_memory: give the
    copy the reference's contact memory at every renormalisation (where both are in contact):
    lambda1 *conditional on the memory*, the convention of lyapunov_tangent in permanent contact,
    where the memory is never reset and its direction is neutral (multiplier 1 exactly:
    docs/orbits.md, "Memory state"); default False: the memory follows the state (Benettin)."""
    if transverse is None:
        transverse = system.period is None
    tau = fb.delay
    interval = float(tau if interval is None else interval)
    n_int = int(round(float(span) / interval))
    if n_int < 8:
        raise InputError(f"span = {span!r}: need at least 8 renormalisation intervals of "
                         f"{interval:g}")
    if align is None:
        align = max(2, n_int // 4)
    elif isinstance(align, bool) or not isinstance(align, (int, np.integer)) or align < 0:
        raise InputError(f"align = {align!r}: a whole number of renormalisation intervals >= 0 "
                         f"(None: a quarter of the span's)")
    steps = 2.0 * (n_int + int(align)) * interval / tau
    if steps > MAX_STEPS:
        raise InputError(f"delay = {tau!r}: a delay that short makes lambda1 over "
                         f"{(n_int + int(align)) * interval:.6g} {system.time_unit}"
                         f" need at least {steps:.3g} steps of its two trajectories, the step "
                         f"being capped at the delay (limit {MAX_STEPS:.3g}); the shortest delay "
                         f"that fits is {steps * tau / MAX_STEPS:.3g} "
                         f"{system.time_unit}")
    t = float(system.t0 if t0 is None else t0)
    y = np.array(system.y0 if y0 is None else y0, dtype=float)
    z = np.array(system.z0 if z0 is None else z0, dtype=float)
    law = fb.law(system, gain)
    span_seg = law.tau_max
    hist = constant_history(y, t, law) if history is None else history
    tb0 = t if t_break0 is None else float(t_break0)
    dirn = np.ones(system.n) if direction is None else np.asarray(direction, dtype=float)
    dirn = dirn / np.sqrt(np.mean(dirn ** 2))        # scaled RMS 1: d = d0 on the segment
    yo = y + d0 * dirn * system.scales
    # the copy's history: the reference's, shifted by the same perturbation on the whole segment
    ho = History(hist.t0.copy(), hist.h.copy(), hist.t1.copy(), hist.cont.copy(),
                 hist.chan.copy())
    ho.cont[:, 0, :] += d0 * dirn * system.scales
    ho.chan[:, 0, :] += (d0 * dirn * system.scales)[law.signals]
    zo = z.copy()
    atol = system.tolerance(rtol)
    logs = np.empty(n_int + int(align))
    h_r = h_o = 0.0
    for i in range(n_int + int(align)):
        te = np.array([t + interval])
        args = (system.rhs, system.events, system.on_event)
        r = dde(*args, t, y, te, True, system.p, z, rtol, atol, h_r, float(system.hmax),
                MAX_STEPS, int(system.n_events), 1, law, hist,
                event_samples=int(system.event_samples), t_break0=tb0)
        o = dde(*args, t, yo, te, True, system.p, zo, rtol, atol, h_o, float(system.hmax),
                MAX_STEPS, int(system.n_events), 1, law, ho,
                event_samples=int(system.event_samples), t_break0=tb0)
        if r.status != 0 or o.status != 0:
            bad = r if r.status != 0 else o
            msg = method_status_message("dopri5", bad.status, bad.t, bad.stats)
            return DelayLyapunov(math.nan, math.nan, math.nan, i, logs[:i], "failed",
                                 f"{system.name}: interval {i}: {msg}")
        t = t + interval
        y, yn_o = r.Y[0].copy(), o.Y[0].copy()
        d, c = _segment_difference(system, r.history, o.history, t, span_seg, y, yn_o,
                                   segment_samples, transverse)
        if not (d > 0 and math.isfinite(d)):
            return DelayLyapunov(math.nan, math.nan, math.nan, i, logs[:i], "failed",
                                 f"{system.name}: separation {d!r} at t = {t:g}")
        logs[i] = math.log(d / d0)
        a = d0 / d
        hist = r.history
        ho = combine_histories(r.history, o.history, a, t - span_seg, shift=c)
        yo = y + a * (yn_o - y - c * _field_at(system, fb, law, r.history, t, y, z))
        if system.memory.size:
            # a contact law's memory (approach velocity at onset) follows the state, and a
            # pull-back across an event surface is reported as the integrator would
            # (nld.analysis.lyapunov: without it every renormalisation injected a force
            # difference and lambda1 of slider_crank_olyaei came out 3-7x too large)
            from nld.analysis.lyapunov import cross_events, rescale_memory
            rescale_memory(system, z, zo, 0.0 if hold_memory else a)
            cross_events(system, t, yn_o, yo, zo)
        h_r, h_o = r.h_last, o.h_last
    logs = logs[int(align):]
    lam = float(np.mean(logs) / interval)
    se = _uncertainty(logs, interval)
    return DelayLyapunov(lam, se, lam * tau, n_int, logs, "ok",
                         f"lambda1 = {lam:.4g} +- {se:.2g} per time unit over {n_int} intervals",
                         {"span": n_int * interval, "interval": interval, "d0": d0, "rtol": rtol,
                          "segment_samples": int(segment_samples), "transverse": bool(transverse),
                          "align": int(align), "hold_memory": bool(hold_memory),
                          "gain": fb.gain if gain is None else float(gain),
                          "controller": fb.to_dict()})


# ---------------------------------------------------------------- the whole evidence
@dataclass
class ControlResult:
    """Evidence of delayed-feedback control (the fields of ``nld control --json`` that apply):

    lambda1_uncontrolled / lambda1_controlled (per time unit), each with its own uncertainty
    (``lambda1_uncontrolled_uncertainty`` / ``lambda1_controlled_uncertainty``, the same numbers
    as the fields uncertainty_uncontrolled / uncertainty_controlled; lambda1_uncertainty,
    deprecated, is the larger of the two); effort_rms_initial / effort_rms_final: rms of u over the
    first and the last delay period of the controlled run (unit of u); captured_at: the delay
    periods after which every period's effort rms stays below CAPTURE_FRACTION of the first's
    (None: never); orbit_distance: the largest scaled distance of the last period's states to
    the target orbit's curve (None without a target; else ``periodicity`` is the largest scaled
    |y(t) - y(t - tau)| over the last period); onsets_per_period: upward crossings of the
    events per delay period in the last quarter (None without events); run: the controlled
    :class:`DelayedRun`; effort_decay_rate: :func:`effort_decay_rate` of the effort per period
    after capture (per time unit; NaN when not captured long enough), a second estimate of
    lambda1_controlled."""
    lambda1_uncontrolled: float
    lambda1_controlled: float
    lambda1_uncertainty: float
    effort_rms_initial: float
    effort_rms_final: float
    captured_at: int | None
    orbit_distance: float | None
    periodicity: float
    onsets_per_period: float | None
    status: str
    message: str
    settings: dict
    run: DelayedRun = field(repr=False, default=None)
    effort_per_period: np.ndarray = field(repr=False, default=None)
    uncertainty_uncontrolled: float = math.nan
    uncertainty_controlled: float = math.nan
    effort_decay_rate: float = math.nan

    @property
    def lambda1_controlled_uncertainty(self) -> float:
        return self.uncertainty_controlled

    @property
    def lambda1_uncontrolled_uncertainty(self) -> float:
        return self.uncertainty_uncontrolled

    def to_dict(self) -> dict:
        return {"lambda1_uncontrolled": self.lambda1_uncontrolled,
                "lambda1_controlled": self.lambda1_controlled,
                "lambda1_uncertainty": self.lambda1_uncertainty,
                "lambda1_controlled_uncertainty": self.lambda1_controlled_uncertainty,
                "lambda1_uncontrolled_uncertainty": self.lambda1_uncontrolled_uncertainty,
                "effort_rms_initial": self.effort_rms_initial,
                "effort_rms_final": self.effort_rms_final, "captured_at": self.captured_at,
                "orbit_distance": self.orbit_distance, "periodicity": self.periodicity,
                "onsets_per_period": self.onsets_per_period,
                "uncertainty_uncontrolled": self.uncertainty_uncontrolled,
                "uncertainty_controlled": self.uncertainty_controlled,
                "effort_decay_rate": self.effort_decay_rate, "status": self.status,
                "message": self.message, "settings": self.settings}


def _is_orbit(x) -> bool:
    """Whether x is a PeriodicOrbit (else: an array of states or of multipliers)."""
    from nld.analysis.orbits import PeriodicOrbit
    return isinstance(x, PeriodicOrbit)


def orbit_states(orbit, n: int = 2000) -> np.ndarray:
    """States along a PeriodicOrbit (n per period of its map): a StroboscopicMap orbit by its
    trajectory; a PoincareMap orbit by integrating the flow from its first point over its
    return time; a map orbit: its points."""
    m = orbit.map
    from nld.systems.derived import PoincareMap, StroboscopicMap
    if isinstance(m, StroboscopicMap):
        return orbit.trajectory(n)[1]
    if isinstance(m, PoincareMap):
        Ys = []
        for i in range(orbit.period):
            st = m.step(orbit.points[i], orbit.z[i])
            y, z = m.unpack(orbit.points[i], orbit.z[i])
            te = m.t0 + st.time * np.arange(n + 1) / n
            out, _, _ = m._plain(y, z, m.t0, te[-1], t_eval=te)
            Ys.append(out.Y[:n])
        return np.vstack(Ys)
    return np.asarray(orbit.points)


def orbit_period_time(orbit) -> float:
    """The orbit's period in time units: q return times of a PoincareMap orbit, q T of a
    stroboscopic one (NaN for a map)."""
    from nld.systems.derived import PoincareMap, StroboscopicMap
    m = orbit.map
    if isinstance(m, StroboscopicMap):
        return orbit.period * m.T
    if isinstance(m, PoincareMap):
        return float(sum(m.step(orbit.points[i], orbit.z[i]).time for i in range(orbit.period)))
    return math.nan


def _wrap_angles(system, D: np.ndarray) -> np.ndarray:
    """Differences D (..., n) with the system's angle states (``angle_states``: a scene's crank
    and joint angles, whole turns one state) brought into [-pi, pi); others unchanged."""
    idx = np.asarray(system.angle_states, dtype=np.int64)
    if idx.size:
        D = np.array(D, dtype=float)
        D[..., idx] -= 2.0 * math.pi * np.floor((D[..., idx] + math.pi) / (2.0 * math.pi))
    return D


def _distance_to_curve(system, Y, curve) -> float:
    """Largest over Y of the smallest scaled distance to the closed polyline through the points
    of ``curve`` (each state projected on the two segments at its nearest vertex). Angle states
    are compared modulo 2 pi (each state is moved by whole turns to the curve's first point)."""
    s = system.scales
    C = np.asarray(curve, dtype=float)
    Y = np.asarray(Y, dtype=float)
    Y = C[0] + _wrap_angles(system, Y - C[0])
    C = C[0] + _wrap_angles(system, C - C[0])
    C = C / s
    k = C.shape[0]
    best = 0.0
    for yy in Y / s:
        j = int(np.argmin(np.linalg.norm(C - yy, axis=1)))
        dmin = float(np.linalg.norm(C[j] - yy))
        for a, b in ((C[j - 1], C[j]), (C[j], C[(j + 1) % k])):
            ab = b - a
            L = float(ab @ ab)
            if L > 0:
                lam = min(1.0, max(0.0, float((yy - a) @ ab) / L))
                dmin = min(dmin, float(np.linalg.norm(a + lam * ab - yy)))
        best = max(best, dmin)
    return best


def distance_to_orbit(system, Y, target) -> float:
    """The largest scaled distance of the states Y (k, n) to a target orbit's curve (a
    PeriodicOrbit, or an (m, n) array of its states), angles modulo 2 pi: the ``orbit_distance``
    of :class:`ControlResult`."""
    curve = orbit_states(target) if _is_orbit(target) else np.asarray(target, dtype=float)
    return _distance_to_curve(system, Y, curve)


def control_delayed(system, fb: DelayedFeedback, *, transient: float = 0.0,
                    duration: float | None = None, lyapunov_span: float | None = None,
                    target=None, y0=None, z0=None, rtol: float = RTOL,
                    samples_per_delay: int = 50, uncontrolled: bool = True,
                    capture_fraction: float = CAPTURE_FRACTION,
                    lyapunov_interval: float | None = None, d0: float = D0,
                    chunk: float | None = None, progress=None) -> ControlResult:
    """Delayed-feedback control of ``system`` and its evidence (:class:`ControlResult`).

    From (y0, z0) (default the system's) the uncontrolled system runs ``transient`` (its history
    recorded: the controller measures the real past), then the controlled one ``duration``
    (default 60 tau); lambda1 of the closed loop over ``lyapunov_span`` (default 40 tau) from the
    run's end, and of the uncontrolled system from the transient's end (``uncontrolled``).
    target: the orbit to compare with (a PeriodicOrbit, or an (k, n) array of its states).
    lyapunov_interval (default tau) and d0: :func:`delayed_lyapunov`'s renormalisation interval
    and separation (a scene: intervals of a fraction of a revolution and d0 well above the
    integration's noise, docs/control.md "Control of a clearance mechanism"). chunk, progress:
    as :func:`run_delayed` (progress(stage, t_done, t_total), stage "transient" or "control")."""
    tau = fb.delay
    duration = 60.0 * tau if duration is None else float(duration)
    lspan = 40.0 * tau if lyapunov_span is None else float(lyapunov_span)
    t0 = float(system.t0)
    y = np.array(system.y0 if y0 is None else y0, dtype=float)
    z = np.array(system.z0 if z0 is None else z0, dtype=float)
    hist, tb0, h0 = None, None, 0.0
    lam_u = DelayLyapunov(math.nan, math.nan, math.nan, 0, np.zeros(0), "skipped", "")
    if transient > 0:
        # the free transient runs the channel with R = 0 (v = s(t - tau) exactly), so an EDFC
        # starts from the last period's signal, not from the constant history before t0, whose
        # error would decay only as R^k (R = 0.9: 35 % left after 10 periods; on
        # slider_crank_olyaei an initial effort of 94 N m instead of 5)
        pre = run_delayed(system, fb.with_(memory=0.0), transient, y0=y, z0=z, t0=t0, rtol=rtol,
                          gain=0.0,
                          samples_per_delay=samples_per_delay, chunk=chunk,
                          progress=None if progress is None else
                          (lambda a, b: progress("transient", a, b)))
        _check_run(pre, f"{system.name}: uncontrolled transient")
        y, z, hist, tb0, h0 = pre.y.copy(), pre.z.copy(), pre.history, pre.t_break0, pre.h_last
        t0 = t0 + float(transient)
    if uncontrolled:
        lam_u = delayed_lyapunov(system, fb, lspan, y0=y, z0=z, t0=t0, history=hist,
                                 t_break0=tb0, gain=0.0, rtol=rtol, interval=lyapunov_interval,
                                 d0=d0)
    run = run_delayed(system, fb, duration, y0=y, z0=z, t0=t0, history=hist, rtol=rtol,
                      samples_per_delay=samples_per_delay, t_break0=tb0, h0=h0, chunk=chunk,
                      progress=None if progress is None else
                      (lambda a, b: progress("control", a, b)))
    _check_run(run, f"{system.name}: controlled run")
    spd = int(samples_per_delay)
    n_per = (run.u.size - 1) // spd
    U = run.u[1: 1 + n_per * spd].reshape(n_per, spd)
    eff = np.sqrt(np.mean(U ** 2, axis=1))
    e0, e1 = float(eff[0]), float(eff[-1])
    below = eff < capture_fraction * e0
    captured = None
    if below[-1]:
        k = n_per - 1
        while k > 0 and below[k - 1]:
            k -= 1
        captured = int(k)
    decay = effort_decay_rate(eff, captured, tau)
    last = run.Y[-spd - 1:]
    prev = run.Y[-2 * spd - 1: -spd]
    periodicity = float(np.max(np.abs(_wrap_angles(system, last - prev) / system.scales))) \
        if run.Y.shape[0] > 2 * spd else math.nan
    dist = None
    if target is not None:
        curve = orbit_states(target) if _is_orbit(target) else np.asarray(target, dtype=float)
        dist = _distance_to_curve(system, last, curve)
    onsets = None
    if int(system.n_events) > 0:
        onsets = 0.0
    if int(system.n_events) > 0 and run.ev_t.size:
        tq = run.t[-1] - 0.25 * duration
        sel = (run.ev_t >= tq) & (run.ev_dir > 0)
        onsets = float(np.count_nonzero(sel)) / (0.25 * duration / tau)
    # permanent contact on the controlled motion (no onset in the last quarter, a contact law
    # with memory): lambda1 conditional on the memory, whose direction is neutral there
    hold = bool(system.memory.size) and onsets == 0.0
    lam_c = delayed_lyapunov(system, fb, lspan, y0=run.y, z0=run.z, t0=run.t[-1],
                             history=run.history, t_break0=run.t_break0, rtol=rtol,
                             interval=lyapunov_interval, d0=d0, hold_memory=hold)
    unc = np.nanmax([lam_c.uncertainty, lam_u.uncertainty]) if uncontrolled else lam_c.uncertainty
    ok = lam_c.status == "ok" and (lam_c.lambda1 + (lam_c.uncertainty or 0) < 0) \
        and captured is not None
    status = "controlled" if ok else "not controlled"
    msg = (f"{system.name}: {fb.to_dict()['method']} K = {fb.gain:g}, tau = {tau:g}"
           + (f", R = {fb.memory:g}" if fb.memory else "")
           + f": lambda1 {lam_u.lambda1:.3g} -> {lam_c.lambda1:.3g} +- {lam_c.uncertainty:.2g} "
           f"per {system.time_unit}, effort rms {e0:.3g} -> {e1:.3g}"
           + (f" (captured after {captured} periods)" if captured is not None else
              " (not captured)"))
    settings = {"controller": fb.to_dict(), "transient": float(transient),
                "duration": duration, "lyapunov_span": lspan, "rtol": rtol, "d0": d0,
                "lyapunov_interval": tau if lyapunov_interval is None else lyapunov_interval,
                "lyapunov_controlled_memory": "held (conditional on the contact memory: "
                "permanent contact)" if hold else "follows the state",
                "samples_per_delay": spd, "capture_fraction": capture_fraction,
                "segment_samples": SEGMENT_SAMPLES,
                "lyapunov_align_intervals": lam_c.settings.get("align")}
    return ControlResult(lam_u.lambda1, lam_c.lambda1, float(unc), e0, e1, captured, dist,
                         periodicity, onsets, status, msg, settings, run, eff,
                         lam_u.uncertainty, lam_c.uncertainty, decay)


def effort_decay_rate(effort_per_period, captured_at, tau: float, min_periods: int = 8) -> float:
    """The decay rate of the control effort after capture (per time unit): the least-squares
    slope of ln(rms of u per delay period) over the later half of the periods after
    ``captured_at`` (at least ``min_periods`` of them; NaN otherwise), divided by tau. On a
    captured orbit u = K (v - s) is linear in the deviation from the orbit, which decays in the
    closed loop's slowest mode: the rate is lambda1 of the closed loop, a second estimate
    independent of the two-trajectory one (docs/control.md, "The evidence")."""
    e = np.asarray(effort_per_period, dtype=float)
    if captured_at is None:
        return math.nan
    k0 = max(int(captured_at), (int(captured_at) + e.size) // 2)
    seg = e[k0:]
    if seg.size < int(min_periods) or not np.all(seg > 0) or not np.all(np.isfinite(seg)):
        return math.nan
    x = np.arange(seg.size, dtype=float)
    return float(np.polyfit(x, np.log(seg), 1)[0]) / float(tau)


# ---------------------------------------------------------------- stability domain
@dataclass
class DomainScan:
    """lambda1 of the closed loop over gains K (and memories R): lambda1[iR, iK] (per time
    unit), its uncertainty, and the settings; ``stable`` where lambda1 + uncertainty < 0."""
    gains: np.ndarray
    memories: np.ndarray
    lambda1: np.ndarray
    uncertainty: np.ndarray
    settings: dict

    @property
    def stable(self) -> np.ndarray:
        return self.lambda1 + np.nan_to_num(self.uncertainty) < 0


def stability_domain(system, fb: DelayedFeedback, gains, memories=None, *, y0=None, z0=None,
                     history=None, t0=None, transient: float | None = None,
                     span: float | None = None, rtol: float = RTOL,
                     progress=None, interval: float | None = None,
                     d0: float = D0) -> DomainScan:
    """lambda1 of the closed loop against the gain K (and memory R), the classic figure of the
    delayed-feedback literature (Pyragas 1992, fig. 3; Socolar et al. 1994). Each point starts
    from the same (y0, z0, history) (best: a point on the target orbit with its own past as the
    history, e.g. a controlled run's end), runs ``transient`` (default 20 tau) under control and
    estimates lambda1 over ``span`` (default 20 tau). progress: optional callable (done, total).
    interval, d0: :func:`delayed_lyapunov`'s renormalisation interval and separation. Where the
    transient's second half has no contact onset (permanent contact) lambda1 is conditional on
    the contact memory (``hold_memory``)."""
    gains = np.atleast_1d(np.asarray(gains, dtype=float))
    if not np.all(np.isfinite(gains)):
        raise InputError(f"gains = {gains.tolist()!r}: must be finite numbers")
    mems = np.array([fb.memory] if memories is None else memories, dtype=float).ravel()
    for R in mems:
        if not 0.0 <= R < 1.0:
            raise InputError(f"memory = {R!r}: R must be in [0, 1) (0: Pyragas)")
    tau = fb.delay
    transient = 20.0 * tau if transient is None else float(transient)
    span = 20.0 * tau if span is None else float(span)
    lam = np.full((mems.size, gains.size), np.nan)
    se = np.full_like(lam, np.nan)
    total, done = lam.size, 0
    for a, R in enumerate(mems):
        for b, K in enumerate(gains):
            f = fb.with_(memory=float(R), gain=float(K))
            y, z, h, tt, tb0 = y0, z0, history, t0, None
            hold = False
            try:
                if transient > 0:
                    run = run_delayed(system, f, transient, y0=y0, z0=z0, t0=t0, history=history,
                                      rtol=rtol, samples_per_delay=8)
                    if run.status == 0:
                        y, z, h, tt, tb0 = run.y, run.z, run.history, run.t[-1], run.t_break0
                        # permanent contact over the transient's second half: lambda1
                        # conditional on the contact memory (control_delayed, docs/control.md)
                        late = run.ev_t >= run.t[-1] - 0.5 * transient
                        hold = bool(system.memory.size) and \
                            int(system.n_events) > 0 and not np.any(late & (run.ev_dir > 0))
                    else:
                        y = None
                if y is not None or transient <= 0:
                    r = delayed_lyapunov(system, f, span, y0=y, z0=z, t0=tt, history=h,
                                         t_break0=tb0, rtol=rtol, interval=interval, d0=d0,
                                         hold_memory=hold)
                    lam[a, b], se[a, b] = r.lambda1, r.uncertainty
            except SolveError:
                pass
            done += 1
            if progress is not None:
                progress(done, total)
    return DomainScan(gains, mems, lam, se, {"controller": fb.to_dict(), "transient": transient,
                                            "span": span, "rtol": rtol, "d0": d0,
                                            "interval": tau if interval is None else interval})


# ---------------------------------------------------------------- Nakajima
@dataclass
class OddNumberVerdict:
    """n_real_above_one: real Floquet multipliers > 1 (|Im| <= tol |mu|); limited: True when that
    number is odd and the limitation applies (a non-autonomous system: a stroboscopic map or a
    map), None when it is odd but the orbit is of an autonomous flow (Poincaré map: Fiedler et
    al. 2007 showed stabilisation is possible there), False when even; message."""
    n_real_above_one: int
    limited: bool | None
    message: str


def odd_number_limitation(orbit_or_multipliers, *, autonomous: bool | None = None,
                          tol: float = 1e-9) -> OddNumberVerdict:
    """Nakajima's odd-number limitation (module docstring) for a PeriodicOrbit or its
    multipliers. ``autonomous``: whether the orbit is of an autonomous flow (default: from the
    orbit's map; multipliers alone: False)."""
    mu = orbit_or_multipliers
    if _is_orbit(mu):
        from nld.systems.derived import PoincareMap
        if autonomous is None:
            autonomous = isinstance(mu.map, PoincareMap)
        mu = mu.multipliers
    mu = np.atleast_1d(np.asarray(mu, dtype=complex))
    real = np.abs(mu.imag) <= tol * np.maximum(np.abs(mu), 1.0)
    k = int(np.count_nonzero(real & (mu.real > 1.0 + tol)))
    if k % 2 == 0:
        return OddNumberVerdict(k, False, f"{k} real multipliers > 1 (even): delayed feedback "
                                          f"is not ruled out")
    if autonomous:
        return OddNumberVerdict(k, None, f"{k} real multiplier(s) > 1 (odd) on an autonomous "
                                         f"flow's orbit: Nakajima's limitation does not hold in "
                                         f"general there (Fiedler et al. 2007)")
    return OddNumberVerdict(k, True, f"{k} real multiplier(s) > 1 (odd): delayed feedback with "
                                     f"tau = the period cannot stabilise this orbit (Nakajima "
                                     f"1997); use OGY or another method")


# ---------------------------------------------------------------- OGY
@dataclass
class OGYResult:
    """OGY control of a map: x (N + 1, n) the controlled iterates, dp (N,) the parameter
    perturbation applied at each iteration (0 where off), active (N,) where it was on;
    captured_at: the iteration after which every iterate stays within ``radius`` of the orbit
    (None: never); orbit_distance: the largest scaled distance of the last ``window`` iterates to
    the orbit's points; effort_rms_initial / final: rms of dp over the first ``window``
    iterations after the first activation and over the last ``window`` (parameter unit);
    lambda1_uncontrolled: from the Jacobian product along the free run (per iteration);
    lambda1_controlled: from the closed-loop Jacobians A - w k^T along the last window;
    closed_loop_multipliers: eigenvalues of M - w~ k^T at the first orbit point; gains k (q, n);
    status ("controlled", "not controlled", or "nothing to control": a target stable without
    control, where no perturbation is applied and captured_at is None, lambda1_controlled NaN),
    message, settings."""
    x: np.ndarray
    dp: np.ndarray
    active: np.ndarray
    captured_at: int | None
    orbit_distance: float
    effort_rms_initial: float
    effort_rms_final: float
    lambda1_uncontrolled: float
    lambda1_controlled: float
    closed_loop_multipliers: np.ndarray
    gains: np.ndarray
    status: str
    message: str
    settings: dict
    orbit: object = field(repr=False, default=None)


def _ackermann(M: np.ndarray, w: np.ndarray) -> np.ndarray:
    """k with eig(M - w k^T) = the eigenvalues of M with every |mu| > 1 moved to 0 (Ackermann's
    formula k^T = e_n^T C^-1 phi(M), C = [w, M w, ...]); InputError when (M, w) is not
    controllable."""
    n = M.shape[0]
    mu = np.linalg.eigvals(M)
    if not np.any(np.abs(mu) > 1.0):
        return np.zeros(n)          # a stable orbit: nothing to move, no feedback
    want = np.where(np.abs(mu) > 1.0, 0.0, mu)
    C = np.column_stack([np.linalg.matrix_power(M, j) @ w for j in range(n)])
    if np.linalg.cond(C) > 1e12:
        # not controllable as a whole (a scene in permanent contact: the contact memory is a
        # neutral direction no parameter reaches), but one real unstable eigenvalue may still be:
        # OGY's own formula k = lambda_u f_u / (f_u . w) (f_u its left eigenvector) moves it to 0
        # and keeps every other eigenvalue (f_u is orthogonal to their right eigenvectors)
        lam, F = np.linalg.eig(M.T)
        unstable = np.flatnonzero(np.abs(lam) > 1.0)
        if unstable.size == 1 and abs(lam[unstable[0]].imag) <= 1e-12 * abs(lam[unstable[0]]):
            fu = np.real(F[:, unstable[0]])
            fw = float(fu @ w)
            if abs(fw) > 1e-9 * float(np.linalg.norm(fu) * np.linalg.norm(w)):
                return float(np.real(lam[unstable[0]])) * fu / fw
        raise InputError("parameter: the orbit is not controllable through this parameter (its "
                         "sensitivity has no component along an unstable direction)")
    coeffs = np.real(np.poly(want))            # phi(x) = x^n + c1 x^(n-1) + ...
    phi = np.zeros_like(M)
    for c in coeffs:
        phi = phi @ M + c * np.eye(n)
    en = np.zeros(n)
    en[-1] = 1.0
    return np.linalg.solve(C.T, en) @ phi


def _step_p(mp, pi, value0, x, z, dp):
    """One step of ``mp`` (the controller's own copy of the map, ``with_parameter``) with
    parameter ``pi`` (an index of p, ``parameter_index``) at value0 + dp: set in its p (a new
    copy per step would cost more than a Hénon step)."""
    mp.p[pi] = value0 + dp
    return mp.step(x, z)


def ogy(system, param, *, period: int = 1, orbit=None, dp_max: float, radius: float,
        n_iter: int = 2000, x0=None, z0=None, fd_step: float | None = None,
        window: int = 50, lyapunov_iter: int = 200) -> OGYResult:
    """OGY control (module docstring) of ``system``: a DiscreteMap, a StroboscopicMap, or a
    forced flow (its one-period StroboscopicMap); ``param`` a name (``param_names``) or index
    of p, whose value must not change the map's period. dp_max (parameter unit) and radius
    (scaled distance: |(x - x*) / scales|) bound the control; n_iter iterations from x0 (default
    the system's initial state, i.e. the chaotic motion). orbit: the target PeriodicOrbit
    (default ``periodic_orbit(system, period)``)."""
    from nld.analysis.orbits import map_source, periodic_orbit
    from nld.systems.derived import as_map
    m = as_map(system)
    src = map_source(m)
    pi, pname = _param_index(src, param, "param")
    if src.period_index is not None and src.period_index == pi and src.period is not None:
        raise InputError(f"param = {param!r}: the forcing frequency sets the map's period; OGY "
                         f"perturbs a parameter that does not")
    dp_max = _finite("dp_max", dp_max, "must be a positive number (parameter unit)")
    if dp_max <= 0:
        raise InputError(f"dp_max = {dp_max!r}: must be a positive number (parameter unit)")
    radius = _finite("radius", radius, "must be a positive scaled distance")
    if radius <= 0:
        raise InputError(f"radius = {radius!r}: must be a positive scaled distance")
    n_iter = _count("n_iter", n_iter, 1, "iterations of the map under control")
    window = _count("window", window, 1, "iterations of the final effort and distance")
    lyapunov_iter = _count("lyapunov_iter", lyapunov_iter, 1,
                           "iterations of the free lambda1's Jacobian product")
    if orbit is None:
        orbit = periodic_orbit(m, period)
    if not orbit.converged:
        raise InputError(f"period = {period!r}: no orbit of that period found ({orbit.message})")
    q = orbit.period
    v0 = m.parameter(pi)
    mp = m.with_parameter(pi, v0)          # the copy whose p the control perturbs
    h = float(fd_step) if fd_step is not None else 1e-6 * max(1.0, abs(v0))
    A, W = [], []
    for i in range(q):
        st = m.step(orbit.points[i], orbit.z[i], jacobian=True)
        A.append(st.M)
        xp = _step_p(mp, pi, v0, orbit.points[i], orbit.z[i], h).x
        xm = _step_p(mp, pi, v0, orbit.points[i], orbit.z[i], -h).x
        W.append(m.difference(xp, xm) / (2 * h))
    K = np.zeros((q, m.n))
    Wq = []
    for i in range(q):
        M = np.eye(m.n)
        for j in range(q):
            M = A[(i + j) % q] @ M
        w = W[i]
        for j in range(1, q):
            w = A[(i + j) % q] @ w
        Wq.append((M, w))
        K[i] = _ackermann(M, w)
    if orbit.stable is True:
        # stable without control (a neutral contact-memory multiplier of a continuum excepted,
        # nld.analysis.orbits): nothing to place, whatever rounding says of |mu| = 1
        K[:] = 0.0
    M0, w0 = Wq[0]
    cl_mu = np.linalg.eigvals(M0 - np.outer(w0, K[0]))
    s = m.scales
    x = np.array(m.y0 if x0 is None else x0, dtype=float)
    z = m.z0.copy() if z0 is None else np.array(z0, dtype=float)
    X = np.empty((n_iter + 1, m.n))
    X[0] = x
    Zs = [None if z is None else np.array(z, dtype=float)]      # the discrete state at each X[k]
    dps = np.zeros(n_iter)
    act = np.zeros(n_iter, dtype=bool)
    near = np.zeros(n_iter + 1)
    hold = 0
    for k in range(n_iter):
        dist = [float(np.linalg.norm(m.difference(x, orbit.points[i]) / s)) for i in range(q)]
        i = int(np.argmin(dist))
        near[k] = dist[i]
        dp = 0.0
        if hold > 0:
            hold -= 1
        elif dist[i] < radius and np.any(K[i]):
            dp = -float(K[i] @ m.difference(x, orbit.points[i]))
            if abs(dp) > dp_max:
                dp = 0.0
            else:
                act[k] = True
                hold = q - 1
        dps[k] = dp
        st = _step_p(mp, pi, v0, x, z, dp) if dp != 0.0 else m.step(x, z)
        x, z = st.x, st.z
        X[k + 1] = x
        Zs.append(None if z is None else np.array(z, dtype=float))
    near[n_iter] = min(float(np.linalg.norm(m.difference(x, orbit.points[i]) / s))
                       for i in range(q))
    inside = near < radius
    captured = None
    if inside[-1]:
        k = n_iter
        while k > 0 and inside[k - 1]:
            k -= 1
        captured = int(k)
    win = max(1, min(int(window), n_iter // 4))
    dist_final = float(np.max(near[-win:]))
    first = int(np.argmax(act)) if act.any() else None
    e0 = float(np.sqrt(np.mean(dps[first:first + win] ** 2))) if first is not None else 0.0
    e1 = float(np.sqrt(np.mean(dps[-win:] ** 2)))
    # lambda1 from Jacobian products: free run from x0, closed loop over the last window
    lam_u = _jacobian_lambda(m, X[0], z0 if z0 is not None else m.z0, int(lyapunov_iter))
    lam_c = math.nan
    if captured is not None and captured <= n_iter - win:
        v = np.ones(m.n) / math.sqrt(m.n)
        acc = 0.0
        for k in range(n_iter - win, n_iter):
            i = int(np.argmin([np.linalg.norm(m.difference(X[k], orbit.points[j]) / s)
                               for j in range(q)]))
            # the Jacobian at the iterate with its own discrete state (contact modes, memory):
            # the orbit's z at another point gave a scene's map the wrong contact mode
            J = m.step(X[k], None if not m.z0.size else Zs[k], jacobian=True).M
            if act[k]:
                J = J - np.outer(W[i], K[i])
            v = J @ v
            nv = float(np.linalg.norm(v))
            acc += math.log(nv) if nv > 0 else -745.0
            v = v / nv if nv > 0 else np.ones(m.n) / math.sqrt(m.n)
        lam_c = acc / win
    ok = captured is not None and dist_final < radius
    status = "controlled" if ok else "not controlled"
    name = f"{system.name}: OGY on {pname}, period {q}: "
    applied = bool(np.any(dps != 0.0))
    if not np.any(K):
        # a stable target: the pole placement moves nothing, no perturbation is ever applied;
        # whatever the motion does is the free system's (issue 37): no controlled run to report
        status = "nothing to control"
        amu = np.sort(np.abs(np.asarray(orbit.multipliers)))[::-1]
        cont = bool(orbit.continuum) and amu.size > 1
        if cont:      # the neutral contact-memory multiplier (1) left out, as orbits does
            amu = np.delete(amu, int(np.argmin(np.abs(amu - 1.0))))
        mu_max = float(amu[0]) if amu.size else 0.0
        msg = name + (f"nothing to control: the target orbit is stable without control "
                      f"(largest |multiplier| {mu_max:.3g}"
                      + (", the neutral contact memory's left out" if cont else "")
                      + "), no perturbation applied; "
                      + ("the free motion reaches it" if ok else "the free motion does not "
                         f"reach it in {n_iter} iterations"))
        captured, lam_c, e0, e1 = None, math.nan, 0.0, 0.0
    elif not applied:
        status = "not controlled"
        msg = name + (f"no control applied in {n_iter} iterations: the motion never came within "
                      f"the radius {radius:g} with a perturbation |dp| <= dp_max {dp_max:g}")
        captured, lam_c = None, math.nan
    else:
        msg = name + (f"captured at iteration {captured}, final distance {dist_final:.2g}, "
                      f"|dp| rms {e0:.3g} -> {e1:.3g}" if ok else
                      f"not captured in {n_iter} iterations (radius {radius:g}, dp_max "
                      f"{dp_max:g})")
    settings = {"param": pname, "period": q, "dp_max": dp_max, "radius": radius,
                "n_iter": int(n_iter), "fd_step": h, "window": win,
                "lyapunov_iter": int(lyapunov_iter), "pole_placement": "unstable -> 0"}
    return OGYResult(X, dps, act, captured, dist_final, e0, e1, lam_u, lam_c, cl_mu, K, status,
                     msg, settings, orbit)


def _jacobian_lambda(m, x, z, n: int) -> float:
    v = np.ones(m.n) / math.sqrt(m.n)
    acc = 0.0
    x = np.array(x, dtype=float)
    for _ in range(n):
        st = m.step(x, z, jacobian=True)
        v = st.M @ v
        nv = float(np.linalg.norm(v))
        acc += math.log(nv)
        v /= nv
        x, z = st.x, st.z
    return acc / n
