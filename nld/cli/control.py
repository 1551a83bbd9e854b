"""``nld control``: chaos control of a scene by a torque on one of its bodies -- delayed feedback
(Pyragas, EDFC) or OGY -- with the evidence that it worked (closed-loop lambda1, effort, distance to
the unstable orbit, contact onsets), or with --gains the stability domain lambda1(K)
(nld.analysis.control; docs/control.md, "Control of a clearance mechanism").

The torque is the scene's ``[controller]`` (docs/scene-format.md): a torque load on ``body`` whose
value ``loads.N.value`` the controller drives (a parameter input of nld.analysis.control). A scene
without one gets one here (``--body``), so the uncontrolled mechanism is the scene itself.

The workflow is the library's (:func:`nld.analysis.scene_control.control_scene`); this module
parses the options (defaults: :data:`nld.settings.CONTROL`), calls it and prints the result."""
from __future__ import annotations

import json
import math
import sys

from nld.analysis.scene_control import JSON_KEYS, METHODS
from nld.cli.args import count_arg, number_arg, rtol_arg, scene_args, values_of, json_plain
from nld.settings import CONTROL

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
    d = CONTROL
    sp = sub.add_parser("control", help="chaos control: delayed feedback (Pyragas, EDFC) or OGY, "
                                         "with the evidence", description=HELP)
    scene_args(sp)
    sp.add_argument("--method", choices=METHODS, default=None,
                    help=f"control method (default: the scene's [controller], else "
                         f"{d.method})")
    sp.add_argument("--signal", default=None, metavar="NAME",
                    help="measured state for delayed feedback, e.g. rod.phi_dot or slider.s_dot "
                         "(default: the [controller]'s, else BODY.phi_dot)")
    sp.add_argument("--body", default=None, metavar="NAME",
                    help="body the control torque acts on (default: the [controller]'s, else the "
                         "bearing body of the first clearance joint)")
    sp.add_argument("--gain", type=number_arg("--gain", positive=False), default=None,
                    metavar="K", help=f"delayed-feedback gain, N m per unit of the signal "
                                      f"(default {d.gain:g})")
    sp.add_argument("--memory", type=number_arg("--memory", positive=False), default=None,
                    metavar="R", help=f"EDFC memory R in [0, 1) (default {d.memory:g}; "
                                      f"pyragas: 0)")
    sp.add_argument("--delay", type=number_arg("--delay", positive=False), default=None,
                    metavar="S", help="tau in s (default: the target period in s)")
    sp.add_argument("--target-period", type=count_arg("--target-period", 1), default=None,
                    metavar="P", help=f"period of the target orbit in revolutions "
                                      f"(default {d.target_period})")
    sp.add_argument("--transient", type=count_arg("--transient", 0), default=d.transient,
                    metavar="REVS", help=f"free revolutions before control "
                                         f"(default {d.transient})")
    sp.add_argument("--revs", type=count_arg("--revs", 2), default=d.revs, metavar="REVS",
                    help=f"controlled revolutions (default {d.revs})")
    sp.add_argument("--lyapunov-revs", type=count_arg("--lyapunov-revs", 2),
                    default=d.lyapunov_revs, metavar="REVS",
                    help=f"revolutions averaged by each lambda1, after a quarter as many run "
                         f"first and not counted (alignment) (default {d.lyapunov_revs})")
    sp.add_argument("--gains", type=values_of("--gains"), default=None, metavar="A:B:N",
                    help="stability domain: lambda1 of the closed loop at each gain (START:STOP:NUM "
                         "or K1,K2,...), each from the end of the controlled run, after "
                         "--scan-transient revolutions under that gain")
    sp.add_argument("--scan-transient", type=count_arg("--scan-transient", 0),
                    default=d.scan_transient, metavar="REVS",
                    help=f"revolutions under each gain before its lambda1 "
                         f"(default {d.scan_transient})")
    sp.add_argument("--dp-max", type=number_arg("--dp-max"), default=d.dp_max, metavar="NM",
                    help=f"ogy: largest torque perturbation, N m (default {d.dp_max:g})")
    sp.add_argument("--radius", type=number_arg("--radius"), default=d.radius, metavar="D",
                    help=f"ogy: scaled distance to the orbit within which it acts "
                         f"(default {d.radius:g})")
    sp.add_argument("--rtol", type=rtol_arg, default=d.rtol, metavar="R",
                    help=f"relative tolerance (default {d.rtol:g})")
    sp.add_argument("--json", action="store_true",
                    help="print the result as JSON: " + ", ".join(JSON_KEYS)
                         + " (with --gains also stability_domain)")
    sp.set_defaults(func=cmd_control)
    return sp


# ---------------------------------------------------------------------------------------------------
# the command: parse -> nld.analysis.scene_control.control_scene -> print

# how the library's messages name its arguments on the command line
OPTION_NAMES = {"method": "--method", "signal": "--signal", "gain": "--gain", "memory": "--memory",
                "delay": "--delay", "target_period": "--target-period", "transient": "--transient",
                "revs": "--revs", "lyapunov_revs": "--lyapunov-revs", "gains": "--gains",
                "scan_transient": "--scan-transient", "dp_max": "--dp-max", "radius": "--radius",
                "rtol": "--rtol"}


def cmd_control(args) -> int:
    from nld.progress import progress_enabled
    shown = progress_enabled(args.progress) or (args.progress is None and sys.stderr.isatty())

    def say(text):
        if shown:
            print(f"  {text}", file=sys.stderr, flush=True)
    r = run_control(args, say)
    if args.json:
        print(json.dumps(r.out, indent=2, default=json_plain))
    else:
        _print(r.out, r.system)
    return 0


def run_control(args, say=lambda text: None):
    """:func:`nld.analysis.scene_control.control_scene` with the parsed ``nld control``
    arguments (``add_parser``'s namespace); ``say``: the progress lines. Returns its
    :class:`~nld.analysis.scene_control.SceneControl`."""
    from nld.analysis.scene_control import control_scene
    return control_scene(args.scene, args.overrides, method=args.method, signal=args.signal,
                         body=args.body, gain=args.gain, memory=args.memory, delay=args.delay,
                         target_period=args.target_period, transient=args.transient,
                         revs=args.revs, lyapunov_revs=args.lyapunov_revs, gains=args.gains,
                         scan_transient=args.scan_transient, dp_max=args.dp_max,
                         radius=args.radius, rtol=args.rtol, progress=args.progress, say=say,
                         command=getattr(args, "command_line", None), names=OPTION_NAMES)


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


