"""``nld control``: chaos control of a scene by a torque on one of its bodies -- delayed feedback
(Pyragas, EDFC) or OGY -- with the evidence that it worked (closed-loop lambda1, effort, distance to
the unstable orbit, contact onsets), or with --gains the stability domain lambda1(K)
(nld.analysis.control; docs/control.md, "Control of a clearance mechanism").

The torque is the scene's ``[controller]`` (docs/scene-format.md): a torque load on ``body`` whose
value ``loads.N.value`` the controller drives (a parameter input of nld.analysis.control). A scene
without one gets one here (``--body``), so the uncontrolled mechanism is the scene itself."""
from __future__ import annotations

import json
import math
import sys

import numpy as np

from nld.cli.args import count_arg, number_arg, rtol_arg, scene_args, values_of, json_plain
from nld.errors import InputError, Interrupted

# defaults that work on the chaotic slider_crank_olyaei --set joints.B.clearance=2e-4 --set
# joints.B.friction.mu=0 (docs/control.md, "Control of a clearance mechanism": measured, not assumed)
DEFAULTS = {"method": "edfc", "gain": 1.0, "memory": 0.9, "target_period": 1, "transient": 10,
            "revs": 300, "lyapunov_revs": 32, "rtol": 1e-8, "dp_max": 1.0, "radius": 1.0,
            "scan_transient": 20}
LYAPUNOV_INTERVAL = 0.25      # renormalisation interval of the closed-loop lambda1, revolutions
LYAPUNOV_D0 = 1e-5            # its separation (scaled), far above the integration's noise
CHUNK_REVS = 5                # revolutions per integration chunk (Ctrl-C, progress)
SAMPLES_PER_DELAY = 50        # samples of the controlled run per delay (control_delayed's default)
JSON_KEYS = ("lambda1_uncontrolled", "lambda1_controlled", "lambda1_controlled_uncertainty",
             "lambda1_uncontrolled_uncertainty",
             "lambda1_uncertainty (deprecated: the larger of the two)", "effort_rms_initial",
             "effort_rms_final", "captured_at_revolution", "orbit_distance", "onsets_per_period",
             "status (controlled, not controlled, nothing to control)", "settings", "provenance")

HELP = """\
Chaos control of a crank-driven scene by a torque on one body (the scene's [controller], added
with --body when the scene has none). Methods: pyragas / edfc: delayed feedback u = K [(1 - R) sum
R^(k-1) s(t - k tau) - s(t)] on the measured state s (--signal), tau = the target period (its
revolutions x the crank period), non-invasive on any tau-periodic motion; ogy: a per-revolution
perturbation of the torque offset from the target orbit's Jacobian (pole placement), only near the
orbit. WHICH WORKS WHERE (measured, docs/control.md): on slider_crank_olyaei --set
joints.B.clearance=2e-4 --set joints.B.friction.mu=0 (chaotic, lambda1 about 4 per revolution,
about 4 contact onsets per revolution) the defaults -- edfc on rod.phi_dot, torque on the rod,
K = 1 N m s/rad, R = 0.9, tau = 1 revolution -- capture a period-1 orbit in permanent contact
(an unstable orbit of the free mechanism, flip multiplier -8 to -16) with the effort falling to
under 2 % of its first value: 8 of 8 starts within 300 revolutions (after 31 to 273; when is
chance: the chaotic motion must pass near the orbit); pyragas (R = 0) does not (the flip
multiplier is too large for R = 0), and ogy does not capture there (the chaotic motion, with its
impacts, never comes near that permanent-contact orbit). On a permanent-contact motion the
controlled lambda1 is conditional on the contact memory (a neutral direction there). Delayed feedback cannot stabilise an
orbit with an odd number of real multipliers > 1 (Nakajima 1997): the target's verdict is
printed. Prints lambda1 of the free and the controlled system (per revolution; two trajectories,
whole-segment renormalisation), the effort (rms of u over the first and the last period), the
revolution from which the effort stays below 5 % of its first value, the distance (scaled by the
state scales) of the last period to the orbit periodic_orbit finds from the controlled motion
and to the target found before control, and the contact onsets per period."""


def add_parser(sub):
    """``nld control``."""
    d = DEFAULTS
    sp = sub.add_parser("control", help="chaos control: delayed feedback (Pyragas, EDFC) or OGY, "
                                         "with the evidence", description=HELP)
    scene_args(sp)
    sp.add_argument("--method", choices=("pyragas", "edfc", "ogy"), default=None,
                    help=f"control method (default: the scene's [controller], else "
                         f"{d['method']})")
    sp.add_argument("--signal", default=None, metavar="NAME",
                    help="measured state for delayed feedback, e.g. rod.phi_dot or slider.s_dot "
                         "(default: the [controller]'s, else BODY.phi_dot)")
    sp.add_argument("--body", default=None, metavar="NAME",
                    help="body the control torque acts on (default: the [controller]'s, else the "
                         "bearing body of the first clearance joint)")
    sp.add_argument("--gain", type=number_arg("--gain", positive=False), default=None,
                    metavar="K", help=f"delayed-feedback gain, N m per unit of the signal "
                                      f"(default {d['gain']:g})")
    sp.add_argument("--memory", type=number_arg("--memory", positive=False), default=None,
                    metavar="R", help=f"EDFC memory R in [0, 1) (default {d['memory']:g}; "
                                      f"pyragas: 0)")
    sp.add_argument("--delay", type=number_arg("--delay", positive=False), default=None,
                    metavar="S", help="tau in s (default: the target period in s)")
    sp.add_argument("--target-period", type=count_arg("--target-period", 1), default=None,
                    metavar="P", help=f"period of the target orbit in revolutions "
                                      f"(default {d['target_period']})")
    sp.add_argument("--transient", type=count_arg("--transient", 0), default=d["transient"],
                    metavar="REVS", help=f"free revolutions before control "
                                         f"(default {d['transient']})")
    sp.add_argument("--revs", type=count_arg("--revs", 2), default=d["revs"], metavar="REVS",
                    help=f"controlled revolutions (default {d['revs']})")
    sp.add_argument("--lyapunov-revs", type=count_arg("--lyapunov-revs", 2),
                    default=d["lyapunov_revs"], metavar="REVS",
                    help=f"revolutions averaged by each lambda1, after a quarter as many run "
                         f"first and not counted (alignment) (default {d['lyapunov_revs']})")
    sp.add_argument("--gains", type=values_of("--gains"), default=None, metavar="A:B:N",
                    help="stability domain: lambda1 of the closed loop at each gain (START:STOP:NUM "
                         "or K1,K2,...), each from the end of the controlled run, after "
                         "--scan-transient revolutions under that gain")
    sp.add_argument("--scan-transient", type=count_arg("--scan-transient", 0),
                    default=d["scan_transient"], metavar="REVS",
                    help=f"revolutions under each gain before its lambda1 "
                         f"(default {d['scan_transient']})")
    sp.add_argument("--dp-max", type=number_arg("--dp-max"), default=d["dp_max"], metavar="NM",
                    help=f"ogy: largest torque perturbation, N m (default {d['dp_max']:g})")
    sp.add_argument("--radius", type=number_arg("--radius"), default=d["radius"], metavar="D",
                    help=f"ogy: scaled distance to the orbit within which it acts "
                         f"(default {d['radius']:g})")
    sp.add_argument("--rtol", type=rtol_arg, default=d["rtol"], metavar="R",
                    help=f"relative tolerance (default {d['rtol']:g})")
    sp.add_argument("--json", action="store_true",
                    help="print the result as JSON: " + ", ".join(JSON_KEYS)
                         + " (with --gains also stability_domain)")
    sp.set_defaults(func=cmd_control)
    return sp


# ---------------------------------------------------------------------------------------------------
# the scene with its controller


def controlled_scene(scene_arg, overrides, body=None):
    """The scene (``--set`` applied) with a ``[controller]``: the file's, its body replaced by
    ``body`` when given, or a new one on ``body`` (default: :func:`default_body`). Returns
    (scene, had_controller). SceneError (exit 2) for an unknown body."""
    from nld.model.scene import resolve_scene, scene_from_dict, scene_to_dict
    scene = resolve_scene(scene_arg, overrides)
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


def _settings(args, scene, had):
    """The controller's settings: command line, else the scene's [controller] (when the file had
    one), else DEFAULTS."""
    ctl = scene.controller
    file = ctl if had else None

    def pick(name, cli, default):
        if cli is not None:
            return cli
        if file is not None and getattr(file, name) not in (None, ""):
            return getattr(file, name)
        return default
    method = pick("method", args.method, DEFAULTS["method"])
    gain = args.gain if args.gain is not None else (
        file.gain if file is not None and file.gain != 0.0 else DEFAULTS["gain"])
    memory_default = 0.0 if method == "pyragas" else DEFAULTS["memory"]
    memory = args.memory if args.memory is not None else (
        file.memory if file is not None and file.memory != 0.0 else memory_default)
    src = "--memory" if args.memory is not None else "controller.memory (the scene's)"
    if method == "pyragas" and memory != 0.0:
        raise InputError(f"{src} = {memory!r}: Pyragas control has R = 0; use --method edfc "
                         f"for R > 0")
    if not 0.0 <= memory < 1.0:
        raise InputError(f"{src} = {memory!r}: R must be in [0, 1) (0: Pyragas; EDFC weights "
                         f"period k by R^(k-1))")
    signal = pick("signal", args.signal, f"{ctl.body}.phi_dot")
    delay = args.delay if args.delay is not None else (file.delay if file is not None else None)
    if delay is not None and not delay > 0:
        raise InputError(f"--delay = {delay!r}: tau must be a positive time in s (the target "
                         f"orbit's period)")
    return {"method": method, "gain": float(gain), "memory": float(memory), "signal": signal,
            "delay": delay, "body": ctl.body, "load": ctl.load, "offset": ctl.offset,
            "u_max": ctl.u_max, "target_period": args.target_period or DEFAULTS["target_period"]}


# ---------------------------------------------------------------------------------------------------
# the target orbit


def target_orbit(S, period, transient, rtol, say):
    """The period-``period`` orbit to control: Newton from the state after ``transient``
    revolutions, else the close returns of the section (find_orbits, a light search). InputError
    when none of prime period ``period`` is found (a one-line error, exit 2)."""
    from nld.analysis.orbits import find_orbits, periodic_orbit
    say(f"target: period-{period} orbit by Newton from the state after {transient} revolutions")
    from nld.errors import SolveError
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
        raise InputError(f"--target-period = {period}: no period-{period} orbit found (Newton from "
                         f"the state after {transient} revolutions: {msg}; close returns of "
                         f"60 section points: none of prime period {period})")
    return found[-1], "close returns of the section"


def _largest_multiplier(o) -> float:
    """max |mu| of an orbit, the neutral contact-memory multiplier of a continuum left out."""
    amu = np.sort(np.abs(np.asarray(o.multipliers)))[::-1]
    if getattr(o, "continuum", False) and amu.size > 1:
        amu = np.delete(amu, int(np.argmin(np.abs(amu - 1.0))))
    return float(amu[0]) if amu.size else 0.0


def _prime_period(o) -> int:
    """The orbit's prime period (``nld.analysis.orbits.prime_period``)."""
    from nld.analysis.orbits import prime_period
    return prime_period(o.map, o.points, o.tolerance)


def _orbit_dict(o, autonomous=False) -> dict:
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
# the command


def cmd_control(args) -> int:
    from nld.progress import progress_enabled
    shown = progress_enabled(args.progress) or (args.progress is None and sys.stderr.isatty())

    def say(text):
        if shown:
            print(f"  {text}", file=sys.stderr, flush=True)
    out, _, S = run_control(args, say)
    if args.json:
        print(json.dumps(out, indent=2, default=json_plain))
    else:
        _print(out, S)
    return 0


def run_control(args, say=lambda text: None) -> tuple:
    """What ``nld control`` computes, without printing (for studies): ``(out, res, S)`` with
    ``out`` the ``--json`` dict, ``res`` the :class:`nld.analysis.control.ControlResult` of
    delayed feedback (its ``run``: the controlled run's samples; None for OGY) and ``S`` the
    controlled SceneSystem. ``args``: the parsed
    ``nld control`` arguments (``add_parser``'s namespace); ``say``: the progress lines."""
    from nld.run.simulate import provenance
    from nld.systems.core import SceneSystem
    scene, had = controlled_scene(args.scene, args.overrides, args.body)
    st = _settings(args, scene, had)
    if st["method"] == "ogy" and args.gains is not None:
        raise InputError("--gains: the stability domain is of delayed feedback (--method pyragas "
                         "or edfc); OGY's closed-loop multipliers are printed instead")
    S = SceneSystem(scene)
    if S.period is None:
        raise InputError(f"scene {S.name!r} has no crank speed: nld control needs a driven crank "
                         f"(the target orbit is one of its stroboscopic map)")
    T = float(S.period)
    P = int(st["target_period"])
    target_param = f"loads.{st['load']}.value"
    fb = None
    if st["method"] != "ogy" and st["signal"] not in S.state_names:
        raise InputError(f"--signal = {st['signal']!r}: no such state of {S.name}; states: "
                         f"{', '.join(S.state_names)}")
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
        check_delay_size(S, fb, (args.transient + args.revs) * T, SAMPLES_PER_DELAY,
                         field="--delay" if args.delay is not None or st["delay"] is None
                         else "controller.delay (the scene's)")
    kept = ["nothing kept (no result finished)"]
    try:
        target, how = target_orbit(S, P, args.transient, args.rtol, say)
        res = None
        if st["method"] == "ogy":
            out = _run_ogy(args, S, st, target, target_param, say)
        else:
            out, res = _run_delayed(args, S, st, fb, target, say, kept)
    except KeyboardInterrupt:
        raise Interrupted("interrupted", kept=kept[0]) from None
    out["settings"].update({"scene_overrides": list(args.overrides), "target_found_by": how,
                            "target_orbit": _orbit_dict(target)})
    prov = provenance(S.scene, S.kernel, rtol=args.rtol,
                      command=getattr(args, "command_line", None))
    prov.pop("scene_parameters", None)
    out["provenance"] = prov
    return out, res, S


def _run_delayed(args, S, st, fb, target, say, kept) -> tuple:
    from nld.analysis import control as C
    from nld.progress import progress_bar
    T = float(S.period)
    tau = fb.delay
    revs = args.transient + args.revs
    with progress_bar(total=revs, desc=f"{st['method']} control", unit="rev",
                      enabled=args.progress) as pb:
        def prog(stage, t_done, t_total):
            done = t_done / T + (args.transient if stage == "control" else 0)
            pb.update(done - pb.n)
        say(f"lambda1 of the free and of the controlled system: 2 x {args.lyapunov_revs} "
            f"revolutions, two trajectories each")
        res = C.control_delayed(S, fb, transient=args.transient * T, duration=args.revs * T,
                                lyapunov_span=args.lyapunov_revs * T, target=target,
                                rtol=args.rtol, lyapunov_interval=LYAPUNOV_INTERVAL * T,
                                d0=LYAPUNOV_D0, chunk=CHUNK_REVS * T, progress=prog,
                                samples_per_delay=SAMPLES_PER_DELAY)
    run = res.run
    status, message = res.status, res.message
    if target.stable is True:
        # issue 37: nothing to control -- the motion needs no controller; the closed loop's
        # numbers below are of a controller acting on a stable motion, not of a control that
        # stabilised anything
        status = "nothing to control"
        message = (f"nothing to control: the target period-{int(st['target_period'])} orbit is "
                   f"stable without control (largest |multiplier| "
                   f"{_largest_multiplier(target):.3g}); the closed loop was run anyway: "
                   + res.message)
    # the orbit the controlled motion is on, by Newton from its last state: for a scene in
    # permanent contact each orbit is one of a continuum labelled by the contact memory, so the
    # captured one can be another member than the target found before control
    from nld.analysis.orbits import periodic_orbit
    captured_orbit, d_captured = None, None
    try:
        say("the orbit of the controlled motion: Newton from its last state (free system)")
        o = periodic_orbit(S, int(st["target_period"]), guess=run.y, z=run.z, rtol=args.rtol)
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
            "target_period": int(st["target_period"]), "transient_revs": args.transient,
            "revs": args.revs, "lyapunov_revs": args.lyapunov_revs,
            "lyapunov_interval_revs": LYAPUNOV_INTERVAL, "d0": LYAPUNOV_D0, "rtol": args.rtol,
            "lyapunov_align_revs": res.settings["lyapunov_align_intervals"] * LYAPUNOV_INTERVAL,
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
            "controlled_orbit": None if captured_orbit is None else _orbit_dict(captured_orbit),
            "effort_per_period": res.effort_per_period.tolist(),
        },
    }
    kept[0] = (f"the controlled run finished (lambda1 {out['lambda1_uncontrolled']:.3g} -> "
               f"{out['lambda1_controlled']:.3g} per revolution); the stability domain not")
    if args.gains is not None:
        out["stability_domain"] = _scan(args, S, fb, run, say, kept)
    return out, res


def _scan(args, S, fb, run, say, kept) -> dict:
    from nld.analysis import control as C
    from nld.progress import progress_bar
    T = float(S.period)
    gains = np.asarray(args.gains, dtype=float)
    lam, se = [], []
    with progress_bar(total=len(gains), desc="stability domain", unit="gain",
                      enabled=args.progress) as pb:
        for K in gains:
            sc = C.stability_domain(S, fb, [K], y0=run.y, z0=run.z, history=run.history,
                                    t0=run.t[-1], transient=args.scan_transient * T,
                                    span=args.lyapunov_revs * T, rtol=args.rtol,
                                    interval=LYAPUNOV_INTERVAL * T, d0=LYAPUNOV_D0)
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
            "stable": [bool(a + (b if math.isfinite(b) else 0.0) < 0) for a, b in zip(lam_a, se_a)],
            "start": "end of the controlled run at the --gain", "transient_revs": args.scan_transient,
            "span_revs": args.lyapunov_revs, "unit": "per crank revolution"}


def _run_ogy(args, S, st, target, param, say) -> dict:
    from nld.analysis import control as C
    n_iter = args.transient + args.revs
    say(f"ogy on {param}: {n_iter} revolutions from the assembly")
    r = C.ogy(S, param, orbit=target, dp_max=args.dp_max, radius=args.radius, n_iter=n_iter,
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
                     "offset": st["offset"], "dp_max": args.dp_max, "radius": args.radius,
                     "target_period": int(target.period), "revolutions": n_iter,
                     "rtol": args.rtol, "status": r.status, "message": r.message,
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
    """A float for the JSON, None where not finite."""
    return None if x is None or not math.isfinite(x) else float(x)


def _fmt(x, spec=".3g"):
    return "n/a" if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, spec)


def _print(out, S):
    s = out["settings"]
    print(f"{S.name}: {s['method']} on {s.get('torque_parameter')} (torque on {s['body']})"
          + (f", signal {s['signal']}, K = {s['gain']:g}, R = {s['memory']:g}, tau = "
             f"{s['delay']:.6g} s" if s["method"] != "ogy" else
             f", dp_max {s['dp_max']:g} N m, radius {s['radius']:g}"))
    print(f"  {s['message']}")
    if out.get("status") == "nothing to control":
        print("  NOTHING TO CONTROL: the target orbit is stable without control; the figures "
              "below are not those of a control that stabilised it")
    unc = out["lambda1_uncertainty"]
    uu, uc = out.get("lambda1_uncontrolled_uncertainty"), out.get("lambda1_controlled_uncertainty")
    print(f"  lambda1 free {_fmt(out['lambda1_uncontrolled'])}"
          + (f" +- {_fmt(uu, '.2g')}" if uu is not None else "")
          + f" -> controlled {_fmt(out['lambda1_controlled'])}"
          + (f" +- {_fmt(uc, '.2g')}" if uc is not None else
             f" +- {_fmt(unc, '.2g')}" if unc is not None else "") + " per revolution"
          + ("; controlled: conditional on the contact memory (permanent contact)"
             if str(s.get("lyapunov_controlled_memory", "")).startswith("held") else ""))
    dec = s.get("effort_decay_per_revolution")
    print(f"  effort rms {_fmt(out['effort_rms_initial'])} -> {_fmt(out['effort_rms_final'])} N m; "
          f"captured at revolution {_fmt(out['captured_at_revolution'], 'g')}"
          + (f"; effort decays at {dec:.3g} per revolution after capture (a second estimate of "
             f"the controlled lambda1)" if dec is not None else ""))
    print(f"  distance to the orbit {_fmt(out['orbit_distance'])} (scaled; "
          f"{s.get('orbit_distance_to', 'target')}); {_fmt(out['onsets_per_period'])} contact "
          f"onsets per period")
    t = s["target_orbit"]
    mu = ", ".join(f"{a:.4g}" + (f"{b:+.2g}j" if abs(b) > 1e-12 else "") for a, b in t["multipliers"])
    print(f"  target orbit ({s['target_found_by']}): multipliers {mu}; "
          f"{t['onsets_per_period']} onsets per period; {t['odd_number_limitation']['message']}")
    c = s.get("controlled_orbit")
    if c is not None:
        mu = ", ".join(f"{a:.4g}" + (f"{b:+.2g}j" if abs(b) > 1e-12 else "")
                       for a, b in c["multipliers"])
        print(f"  orbit of the controlled motion: multipliers {mu} "
              f"({'unstable' if c['stable'] is False else 'stable' if c['stable'] else 'undecided'}"
              f" without control); distance to the target {_fmt(s['distance_to_target'])}")
    sd = out.get("stability_domain")
    if sd is not None:
        print(f"  stability domain (R = {sd['memory']:g}; lambda1 per revolution):")
        for k, l_, e, ok in zip(sd["gains"], sd["lambda1"], sd["uncertainty"], sd["stable"]):
            print(f"    K = {k:<10.4g} lambda1 = {_fmt(l_):>8} +- {_fmt(e, '.2g'):<6} "
                  f"{'stable' if ok else ''}")


