"""Chaos control of a crank-driven scene by a torque on one of its bodies, with the evidence that it
worked: the workflow of ``nld control`` as a library function (:func:`control_scene`), below the
command line (issue 39: the CLI parses, calls it and prints; studies call it directly).

Methods (nld.analysis.control; docs/control.md, "Control of a clearance mechanism"): delayed
feedback (Pyragas, Phys. Lett. A 170 (1992) 421, eq. 2; EDFC: Socolar, Sukow & Gauthier, Phys.
Rev. E 50 (1994) 3245, eq. 2) u = K [(1 - R) sum R^(k-1) s(t - k tau) - s(t)] on a measured state
s (SI: rad/s for a body's phi_dot), u a torque in N m, K in N m per unit of s, tau = the target
period in s; or OGY (Ott, Grebogi & Yorke, Phys. Rev. Lett. 64 (1990) 1196, its parameter
perturbation), a per-revolution perturbation of the torque offset from the target
orbit's Jacobian. The torque is the scene's ``[controller]`` (docs/scene-format.md): a torque load
on ``body`` whose value ``loads.N.value`` the controller drives. A scene without one gets one here
(``body``), so the uncontrolled mechanism is the scene itself.

What it computes: the target orbit (Newton from the state after the transient, else the close
returns of the section), lambda1 of the free and of the controlled system (per revolution, two
trajectories, with their uncertainties), the control effort (rms over the first and last period),
the capture revolution, the distance to the orbit of the controlled motion (Newton from its last
state) and to the target, the contact onsets per period, the odd-number verdict (Nakajima 1997),
and with ``gains`` the stability domain lambda1(K) from the end of the controlled run. Defaults:
:data:`nld.settings.CONTROL`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

from nld.errors import InputError, Interrupted
from nld.settings import CONTROL, check_rtol

__all__ = ["SceneControl", "control_scene", "controlled_scene", "default_body", "target_orbit",
           "orbit_dict", "largest_multiplier", "METHODS", "JSON_KEYS"]

METHODS = ("pyragas", "edfc", "ogy")
# the keys of SceneControl.out (``nld control --json``)
JSON_KEYS = ("lambda1_uncontrolled", "lambda1_controlled", "lambda1_controlled_uncertainty",
             "lambda1_uncontrolled_uncertainty",
             "lambda1_uncertainty (deprecated: the larger of the two)", "effort_rms_initial",
             "effort_rms_final", "captured_at_revolution", "orbit_distance", "onsets_per_period",
             "status (controlled, not controlled, nothing to control)", "settings", "provenance")


@dataclass
class SceneControl:
    """The result of :func:`control_scene`.

    out: the report, a plain dict (``nld control --json``; keys :data:`JSON_KEYS`, with
    ``gains`` also ``stability_domain``): lambda1 per crank revolution, effort in N m, distances in
    scaled states, its ``settings`` (everything that produced it, units in
    ``settings["units"]``) and ``provenance``. result: the
    :class:`nld.analysis.control.ControlResult` of delayed feedback (its ``run``: the controlled
    run's samples), None for OGY. system: the controlled SceneSystem (the scene with its
    ``[controller]``)."""

    out: dict
    result: Any
    system: Any

    @property
    def status(self) -> str:
        """controlled, not controlled or nothing to control (OGY: its own status words)."""
        return self.out["status"]


# ---------------------------------------------------------------------------------------------------
# the scene with its controller


def controlled_scene(scene, overrides=(), body=None):
    """The scene (a name, path or Scene; ``overrides`` "KEY=VALUE" applied) with a
    ``[controller]``: the file's, its body replaced by ``body`` when given, or a new one on
    ``body`` (default: :func:`default_body`). Returns (scene, had_controller). SceneError for an
    unknown body."""
    from nld.model.scene import resolve_scene, scene_from_dict, scene_to_dict
    scene = resolve_scene(scene, list(overrides))
    had = scene.controller is not None
    if had and (body is None or body == scene.controller.body):
        return scene, had
    raw = scene_to_dict(scene)
    ctl = raw.get("controller", {})
    ctl["body"] = body if body is not None else default_body(scene)
    raw["controller"] = ctl
    return scene_from_dict(raw, scene.source), had


def default_body(scene) -> str:
    """The bearing body of the first clearance joint (slider_crank_olyaei: the rod), else the
    last body."""
    for j in scene.clearance_joints:
        if j.bodies[1] != "ground":
            return j.bodies[1]
        return j.bodies[0]
    if not scene.bodies:
        raise InputError(f"scene {scene.name!r} has no bodies: nothing to control")
    return list(scene.bodies)[-1]


def _settings(scene, had, *, method, gain, memory, signal, delay, target_period, name) -> dict:
    """The controller's settings: the arguments, else the scene's [controller] (when the file had
    one), else nld.settings.CONTROL. ``name``: how the messages name each argument."""
    ctl = scene.controller
    file = ctl if had else None

    def pick(given, from_file, default):
        if given is not None:
            return given
        if file is not None and from_file not in (None, ""):
            return from_file
        return default
    method = pick(method, ctl.method, CONTROL.method)
    gain = gain if gain is not None else (
        file.gain if file is not None and file.gain != 0.0 else CONTROL.gain)
    memory_default = 0.0 if method == "pyragas" else CONTROL.memory
    src = name("memory") if memory is not None else "controller.memory (the scene's)"
    memory = memory if memory is not None else (
        file.memory if file is not None and file.memory != 0.0 else memory_default)
    if method == "pyragas" and memory != 0.0:
        raise InputError(f"{src} = {memory!r}: Pyragas control has R = 0; use {name('method')} "
                         f"edfc for R > 0")
    if not 0.0 <= memory < 1.0:
        raise InputError(f"{src} = {memory!r}: R must be in [0, 1) (0: Pyragas; EDFC weights "
                         f"period k by R^(k-1))")
    signal = pick(signal, ctl.signal, f"{ctl.body}.phi_dot")
    delay = delay if delay is not None else (file.delay if file is not None else None)
    if delay is not None and not delay > 0:
        raise InputError(f"{name('delay')} = {delay!r}: tau must be a positive time in s (the "
                         f"target orbit's period)")
    return {"method": method, "gain": float(gain), "memory": float(memory), "signal": signal,
            "delay": delay, "body": ctl.body, "load": ctl.load, "offset": ctl.offset,
            "u_max": ctl.u_max, "target_period": target_period or CONTROL.target_period}


def _check_arguments(name, *, method, gain, memory, delay, target_period, transient, revs,
                     lyapunov_revs, gains, scan_transient, dp_max, radius, rtol) -> list | None:
    """The arguments' own checks, before any work (the command line's option types do the same);
    returns the gains as a list of floats (None: no stability domain)."""
    if method is not None and method not in METHODS:
        raise InputError(f"{name('method')} = {method!r}: must be one of {', '.join(METHODS)}")
    for key, v in (("gain", gain), ("memory", memory), ("delay", delay)):
        if v is not None and (isinstance(v, bool) or not isinstance(v, (int, float, np.number))
                              or not math.isfinite(v)):
            raise InputError(f"{name(key)} = {v!r}: must be a finite number")
    for key, v in (("dp_max", dp_max), ("radius", radius)):
        if isinstance(v, bool) or not isinstance(v, (int, float, np.number)) \
                or not math.isfinite(v) or not v > 0:
            raise InputError(f"{name(key)} = {v!r}: must be a finite number > 0")
    for key, v, least in (("target_period", target_period, 1), ("transient", transient, 0),
                          ("revs", revs, 2), ("lyapunov_revs", lyapunov_revs, 2),
                          ("scan_transient", scan_transient, 0)):
        if key == "target_period" and v is None:
            continue
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < least:
            raise InputError(f"{name(key)} = {v!r}: must be an integer >= {least}")
    check_rtol(rtol, name("rtol"))
    if gains is None:
        return None
    try:
        out = [float(k) for k in gains]
    except (TypeError, ValueError):
        raise InputError(f"{name('gains')} = {gains!r}: must be a list of numbers") from None
    if not out or not all(math.isfinite(k) for k in out):
        raise InputError(f"{name('gains')} = {gains!r}: must be a non-empty list of finite numbers")
    return out


# ---------------------------------------------------------------------------------------------------
# the target orbit


def target_orbit(S, period, transient, rtol, say=lambda text: None, *, name="target_period"):
    """The period-``period`` orbit to control: Newton from the state after ``transient``
    revolutions, else the close returns of the section (find_orbits, a light search). Returns
    (orbit, how it was found). InputError (naming ``name``) when none of prime period ``period``
    is found."""
    from nld.analysis.orbits import find_orbits, periodic_orbit
    from nld.errors import SolveError
    say(f"target: period-{period} orbit by Newton from the state after {transient} revolutions")
    try:
        o = periodic_orbit(S, period, transient=transient, rtol=rtol)
        msg = o.message
        if o.converged and _prime_period(o) == period:
            return o, "newton from the transient"
        if o.converged:
            msg = f"converged on an orbit of prime period < {period}"
    except SolveError as e:         # a Newton step into a motion the integrator cannot follow
        msg = str(e)
    say(f"target: not converged ({msg}); searching the section's close returns")
    found = [x for x in find_orbits(S, period, transient=transient, rtol=rtol, n_points=60,
                                    seeds_per_period=4)
             if x.converged and x.period == period]
    if not found:
        raise InputError(f"{name} = {period}: no period-{period} orbit found (Newton from "
                         f"the state after {transient} revolutions: {msg}; close returns of "
                         f"60 section points: none of prime period {period})")
    return found[-1], "close returns of the section"


def largest_multiplier(o) -> float:
    """max |mu| of an orbit, the neutral contact-memory multiplier of a continuum left out."""
    amu = np.sort(np.abs(np.asarray(o.multipliers)))[::-1]
    if o.continuum and amu.size > 1:
        amu = np.delete(amu, int(np.argmin(np.abs(amu - 1.0))))
    return float(amu[0]) if amu.size else 0.0


def _prime_period(o) -> int:
    """The orbit's prime period (``nld.analysis.orbits.prime_period``)."""
    from nld.analysis.orbits import prime_period
    return prime_period(o.map, o.points, o.tolerance)


def orbit_dict(o) -> dict:
    """An orbit as the report's plain dict: period, multipliers ([re, im]), stable, residual,
    onsets per period, continuum, its first point by state name, the odd-number verdict."""
    from nld.analysis.control import odd_number_limitation
    v = odd_number_limitation(o)
    return {"period": int(o.period), "multipliers": [[float(m.real), float(m.imag)]
                                                     for m in o.multipliers],
            "stable": o.stable, "residual": float(o.residual),
            "onsets_per_period": int(o.onsets_per_period),
            "continuum": bool(o.continuum),
            "point": dict(zip(o.state_names, map(float, o.points[0]))),
            "odd_number_limitation": {"n_real_above_one": v.n_real_above_one,
                                      "limited": v.limited, "message": v.message}}


# ---------------------------------------------------------------------------------------------------
# the workflow


def control_scene(scene, overrides: Sequence[str] = (), *, method: str | None = None,
                  signal: str | None = None, body: str | None = None, gain: float | None = None,
                  memory: float | None = None, delay: float | None = None,
                  target_period: int | None = None, transient: int = CONTROL.transient,
                  revs: int = CONTROL.revs, lyapunov_revs: int = CONTROL.lyapunov_revs,
                  gains: Sequence[float] | None = None,
                  scan_transient: int = CONTROL.scan_transient, dp_max: float = CONTROL.dp_max,
                  radius: float = CONTROL.radius, rtol: float = CONTROL.rtol,
                  progress: bool | None = None, say: Callable[[str], None] | None = None,
                  command: str | None = None,
                  names: Mapping[str, str] | None = None) -> SceneControl:
    """Chaos control of ``scene`` by a torque on one body, with the evidence (module docstring).

    scene: a built-in scene name, a .toml path or a Scene; overrides: "KEY=VALUE" scene
    overrides. A None argument takes the scene's ``[controller]`` value when it has one, else
    :data:`nld.settings.CONTROL`'s.

    method: pyragas, edfc or ogy. signal: the measured state of delayed feedback (a state name,
    e.g. rod.phi_dot; default BODY.phi_dot). body: the body the torque acts on (default: the
    bearing body of the first clearance joint). gain: K, N m per unit of the signal. memory: EDFC
    R in [0, 1). delay: tau in s (default: the target period in s). target_period: the target
    orbit's period, crank revolutions. transient: free revolutions before control; revs:
    controlled revolutions; lyapunov_revs: revolutions averaged by each lambda1. gains: the
    stability domain, lambda1 of the closed loop at each gain (N m per unit of the signal), each
    after ``scan_transient`` revolutions under that gain from the end of the controlled run
    (delayed feedback only). dp_max: OGY's largest torque perturbation, N m; radius: OGY's scaled
    distance to the orbit within which it acts. rtol: relative tolerance.

    progress: progress bars (None: on a terminal, nld.progress). say: a callable given the
    progress lines (what is being computed). command: the command line recorded in the
    provenance. names: how error messages name each argument ({"delay": "--delay", ...}; default
    the keyword's name).

    Every argument is checked before any work (InputError naming it). Returns a
    :class:`SceneControl`; Interrupted on Ctrl-C (its ``kept``: what had finished)."""
    from nld.run.simulate import provenance
    from nld.systems.core import SceneSystem
    names = dict(names or {})

    def name(key):
        return names.get(key, key)
    say = say or (lambda text: None)
    gains = _check_arguments(name, method=method, gain=gain, memory=memory, delay=delay,
                             target_period=target_period, transient=transient, revs=revs,
                             lyapunov_revs=lyapunov_revs, gains=gains,
                             scan_transient=scan_transient, dp_max=dp_max, radius=radius,
                             rtol=rtol)
    scene, had = controlled_scene(scene, overrides, body)
    st = _settings(scene, had, method=method, gain=gain, memory=memory, signal=signal,
                   delay=delay, target_period=target_period, name=name)
    if st["method"] == "ogy" and gains is not None:
        raise InputError(f"{name('gains')}: the stability domain is of delayed feedback "
                         f"({name('method')} pyragas or edfc); OGY's closed-loop multipliers are "
                         f"printed instead")
    S = SceneSystem(scene)
    if S.period is None:
        raise InputError(f"scene {S.name!r} has no crank speed: nld control needs a driven crank "
                         f"(the target orbit is one of its stroboscopic map)")
    T = float(S.period)
    P = int(st["target_period"])
    target_param = f"loads.{st['load']}.value"
    fb = None
    if st["method"] != "ogy" and st["signal"] not in S.state_names:
        raise InputError(f"{name('signal')} = {st['signal']!r}: no such state of {S.name}; "
                         f"states: {', '.join(S.state_names)}")
    if st["method"] != "ogy":
        from nld.analysis.control import delayed_feedback
        tau = float(st["delay"]) if st["delay"] is not None else P * T
        fb = delayed_feedback(S, st["gain"], tau, st["signal"], memory=st["memory"],
                              input="param", target=target_param,
                              u_max=math.inf if st["u_max"] is None else st["u_max"])
    if fb is not None:
        # a tiny delay: the samples and the steps (capped at the delay) of the whole run, before
        # any work (issue 37: --delay 1e-9 grew to 24 GB)
        from nld.analysis.control import check_delay_size
        check_delay_size(S, fb, (transient + revs) * T, CONTROL.samples_per_delay,
                         field=name("delay") if delay is not None or st["delay"] is None
                         else "controller.delay (the scene's)")
    run = dict(transient=transient, revs=revs, lyapunov_revs=lyapunov_revs, gains=gains,
               scan_transient=scan_transient, dp_max=dp_max, radius=radius, rtol=rtol,
               progress=progress)
    kept = ["nothing kept (no result finished)"]
    try:
        target, how = target_orbit(S, P, transient, rtol, say, name=name("target_period"))
        res = None
        if st["method"] == "ogy":
            out = _run_ogy(run, S, st, target, target_param, say)
        else:
            out, res = _run_delayed(run, S, st, fb, target, say, kept)
    except KeyboardInterrupt:
        raise Interrupted("interrupted", kept=kept[0]) from None
    out["settings"].update({"scene_overrides": list(overrides), "target_found_by": how,
                            "target_orbit": orbit_dict(target)})
    prov = provenance(S.scene, S.kernel, rtol=rtol, command=command)
    prov.pop("scene_parameters", None)
    out["provenance"] = prov
    return SceneControl(out=out, result=res, system=S)


def _run_delayed(a: dict, S, st, fb, target, say, kept) -> tuple:
    from nld.analysis import control as C
    from nld.analysis.orbits import periodic_orbit
    from nld.progress import progress_bar
    T = float(S.period)
    tau = fb.delay
    revs = a["transient"] + a["revs"]
    with progress_bar(total=revs, desc=f"{st['method']} control", unit="rev",
                      enabled=a["progress"]) as pb:
        def prog(stage, t_done, t_total):
            done = t_done / T + (a["transient"] if stage == "control" else 0)
            pb.update(done - pb.n)
        say(f"lambda1 of the free and of the controlled system: 2 x {a['lyapunov_revs']} "
            f"revolutions, two trajectories each")
        res = C.control_delayed(S, fb, transient=a["transient"] * T, duration=a["revs"] * T,
                                lyapunov_span=a["lyapunov_revs"] * T, target=target,
                                rtol=a["rtol"], lyapunov_interval=CONTROL.lyapunov_interval * T,
                                d0=CONTROL.d0, chunk=CONTROL.chunk_revs * T, progress=prog,
                                samples_per_delay=CONTROL.samples_per_delay)
    run = res.run
    status, message = res.status, res.message
    if target.stable is True:
        # issue 37: nothing to control -- the motion needs no controller; the closed loop's
        # numbers below are of a controller acting on a stable motion, not of a control that
        # stabilised anything
        status = "nothing to control"
        message = (f"nothing to control: the target period-{int(st['target_period'])} orbit is "
                   f"stable without control (largest |multiplier| "
                   f"{largest_multiplier(target):.3g}); the closed loop was run anyway: "
                   + res.message)
    # the orbit the controlled motion is on, by Newton from its last state: for a scene in
    # permanent contact each orbit is one of a continuum labelled by the contact memory, so the
    # captured one can be another member than the target found before control
    captured_orbit, d_captured = None, None
    try:
        say("the orbit of the controlled motion: Newton from its last state (free system)")
        o = periodic_orbit(S, int(st["target_period"]), guess=run.y, z=run.z, rtol=a["rtol"])
        if o.converged:
            captured_orbit = o
            d_captured = C.distance_to_orbit(S, run.Y[-int(res.settings["samples_per_delay"]) - 1:],
                                             o)
    except Exception as e:     # noqa: BLE001 - the evidence says it could not be found
        say(f"no orbit from the controlled motion: {e}")
    spd = int(res.settings["samples_per_delay"])
    per_rev = tau / T
    out = {
        "lambda1_uncontrolled": res.lambda1_uncontrolled * T,
        "lambda1_controlled": res.lambda1_controlled * T,
        "lambda1_controlled_uncertainty": res.uncertainty_controlled * T,
        "lambda1_uncontrolled_uncertainty": res.uncertainty_uncontrolled * T,
        # deprecated (issue 38): the larger of the two above, kept for old readers
        "lambda1_uncertainty": res.lambda1_uncertainty * T,
        "effort_rms_initial": res.effort_rms_initial,
        "effort_rms_final": res.effort_rms_final,
        "captured_at_revolution": None if res.captured_at is None else res.captured_at * per_rev,
        "orbit_distance": d_captured if d_captured is not None else res.orbit_distance,
        "onsets_per_period": res.onsets_per_period if res.onsets_per_period is not None else 0.0,
        "status": status,
        "settings": {
            "method": st["method"], "body": st["body"], "signal": st["signal"],
            "gain": fb.gain, "memory": fb.memory, "delay": tau, "delay_revolutions": per_rev,
            "torque_parameter": fb.target_name, "offset": st["offset"], "u_max": st["u_max"],
            "target_period": int(st["target_period"]), "transient_revs": a["transient"],
            "revs": a["revs"], "lyapunov_revs": a["lyapunov_revs"],
            "lyapunov_interval_revs": CONTROL.lyapunov_interval, "d0": CONTROL.d0,
            "rtol": a["rtol"],
            "lyapunov_align_revs": res.settings["lyapunov_align_intervals"]
            * CONTROL.lyapunov_interval,
            "effort_decay_per_revolution": _num(res.effort_decay_rate * T),
            "lyapunov_controlled_memory": res.settings["lyapunov_controlled_memory"],
            "samples_per_delay": spd, "capture_fraction": C.CAPTURE_FRACTION,
            "units": {"lambda1": "per crank revolution", "effort": "N m",
                      "orbit_distance": "scaled state (clearance-based scales, angles mod 2 pi)",
                      "onsets_per_period": "contact onsets per delay period"},
            "status": status, "message": message,
            "uncertainty_uncontrolled": res.uncertainty_uncontrolled * T,
            "uncertainty_controlled": res.uncertainty_controlled * T,
            "periodicity": res.periodicity,
            "distance_to_target": res.orbit_distance,
            "orbit_distance_to": "orbit of the controlled motion" if d_captured is not None
            else "target",
            "controlled_orbit": None if captured_orbit is None else orbit_dict(captured_orbit),
            "effort_per_period": res.effort_per_period.tolist(),
        },
    }
    kept[0] = (f"the controlled run finished (lambda1 {out['lambda1_uncontrolled']:.3g} -> "
               f"{out['lambda1_controlled']:.3g} per revolution); the stability domain not")
    if a["gains"] is not None:
        out["stability_domain"] = _scan(a, S, fb, run, kept)
    return out, res


def _scan(a: dict, S, fb, run, kept) -> dict:
    """The stability domain: lambda1 of the closed loop at each gain, from the end of the
    controlled run."""
    from nld.analysis import control as C
    from nld.progress import progress_bar
    T = float(S.period)
    gains = np.asarray(a["gains"], dtype=float)
    lam, se = [], []
    with progress_bar(total=len(gains), desc="stability domain", unit="gain",
                      enabled=a["progress"]) as pb:
        for K in gains:
            sc = C.stability_domain(S, fb, [K], y0=run.y, z0=run.z, history=run.history,
                                    t0=run.t[-1], transient=a["scan_transient"] * T,
                                    span=a["lyapunov_revs"] * T, rtol=a["rtol"],
                                    interval=CONTROL.lyapunov_interval * T, d0=CONTROL.d0)
            lam.append(float(sc.lambda1[0, 0]) * T)
            se.append(float(sc.uncertainty[0, 0]) * T)
            pb.update(1)
            kept[0] = (f"{len(lam)} of {len(gains)} gains of the stability domain finished: "
                       + ", ".join(f"K={k:g}: {x:.3g}" for k, x in zip(gains, lam))
                       + " per revolution")
    lam_a, se_a = np.array(lam), np.array(se)
    return {"gains": gains.tolist(), "memory": fb.memory,
            "lambda1": [None if not math.isfinite(x) else x for x in lam],
            "uncertainty": [None if not math.isfinite(x) else x for x in se],
            "stable": [bool(a_ + (b if math.isfinite(b) else 0.0) < 0)
                       for a_, b in zip(lam_a, se_a)],
            "start": "end of the controlled run at the --gain",
            "transient_revs": a["scan_transient"], "span_revs": a["lyapunov_revs"],
            "unit": "per crank revolution"}


def _run_ogy(a: dict, S, st, target, param, say) -> dict:
    from nld.analysis import control as C
    n_iter = a["transient"] + a["revs"]
    say(f"ogy on {param}: {n_iter} revolutions from the assembly")
    r = C.ogy(S, param, orbit=target, dp_max=a["dp_max"], radius=a["radius"], n_iter=n_iter,
              lyapunov_iter=min(200, n_iter))
    m = target.map
    win = int(r.settings["window"])
    ons = 0
    pi = S.kernel.layout.index[param]
    p0 = float(S.p[pi])
    for k in range(n_iter - min(win, 10), n_iter):
        x = r.x[k]
        _, zz = m.unpack(x, m.z0)
        S.p[pi] = p0 + float(r.dp[k])          # the map's flow is S: the perturbation it had
        try:
            st_ = m.step(x, zz)
        finally:
            S.p[pi] = p0
        ons += int(np.sum(st_.onsets)) if st_.onsets.size else 0
    nwin = min(win, 10)
    return {
        "lambda1_uncontrolled": r.lambda1_uncontrolled,
        "lambda1_controlled": None if not math.isfinite(r.lambda1_controlled)
        else r.lambda1_controlled,
        "lambda1_controlled_uncertainty": None,
        "lambda1_uncontrolled_uncertainty": None,
        "lambda1_uncertainty": None,
        "effort_rms_initial": r.effort_rms_initial,
        "effort_rms_final": r.effort_rms_final,
        "captured_at_revolution": r.captured_at,
        "orbit_distance": r.orbit_distance,
        "status": r.status,
        "onsets_per_period": ons / nwin * int(target.period),
        "settings": {"method": "ogy", "body": st["body"], "torque_parameter": param,
                     "offset": st["offset"], "dp_max": a["dp_max"], "radius": a["radius"],
                     "target_period": int(target.period), "revolutions": n_iter,
                     "rtol": a["rtol"], "status": r.status, "message": r.message,
                     "closed_loop_multipliers": [[float(m_.real), float(m_.imag)]
                                                 for m_ in r.closed_loop_multipliers],
                     "gains": r.gains.tolist(), "active_revolutions": int(r.active.sum()),
                     "lambda1_note": "of the map: free from the Jacobian product over "
                                     f"{r.settings['lyapunov_iter']} revolutions, controlled "
                                     "from the closed-loop Jacobians over the last window; no "
                                     "uncertainty",
                     "units": {"lambda1": "per crank revolution", "effort": "N m (|dp|)",
                               "orbit_distance": "scaled state at the section"}},
    }


def _num(x):
    """A float for the report, None where not finite."""
    return None if x is None or not math.isfinite(x) else float(x)
