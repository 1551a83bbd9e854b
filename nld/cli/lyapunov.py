"""``nld lyapunov``: Lyapunov exponents of a scene (tangent dynamics with saltation, or Benettin)."""
from __future__ import annotations

import math

from nld.cli.args import count_arg, number_arg, progress_kw
from nld.errors import InputError
from nld.settings import BENETTIN, LYAPUNOV, TANGENT, TANGENT_SPANS


def add_parser(sub) -> None:
    sp = sub.add_parser("lyapunov", help="Lyapunov exponents of a scene (tangent dynamics)",
                        description="Largest Lyapunov exponent (or the first K with --k) from the "
                                    "tangent dynamics with saltation at every contact event "
                                    "(nld.analysis.lyapunov.lyapunov_tangent), in 1/s and per crank "
                                    "revolution, with its uncertainty (about 95 %) and the settings "
                                    "that produced it. --estimator benettin uses the two-trajectory "
                                    "method instead; --check computes both and says whether they agree.")
    sp.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a TOML file")
    sp.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="override a scene value (repeatable)")
    sp.add_argument("--transient", type=number_arg("--transient", positive=False),
                    default=TANGENT_SPANS.transient_revs, metavar="REVS",
                    help=f"transient in crank revolutions, >= 0 (default {TANGENT_SPANS.transient_revs:g}; "
                         "0: measure from the start)")
    sp.add_argument("--revs", type=float, default=TANGENT_SPANS.revs, metavar="REVS",
                    help=f"averaging length in crank revolutions (default {TANGENT_SPANS.revs:g}; the minimum with "
                         "--target-uncertainty)")
    sp.add_argument("--rtol", type=float, default=LYAPUNOV.rtol,
                    help=f"relative tolerance (default {LYAPUNOV.rtol:g})")
    sp.add_argument("--estimator", choices=("tangent", "benettin"), default="tangent",
                    help="tangent dynamics with saltation (default) or two trajectories (Benettin)")
    sp.add_argument("--k", type=count_arg("--k", 1), default=1, metavar="K",
                    help="number of exponents (tangent estimator; default 1)")
    sp.add_argument("--renorm", type=float, default=None, metavar="REVS",
                    help=f"re-orthonormalisation interval in revolutions (default "
                         f"{TANGENT.interval_revs:g} for the tangent estimator, "
                         f"{BENETTIN.interval_revs:g} with {BENETTIN.checks_per_period} checks for "
                         "Benettin)")
    sp.add_argument("--target-uncertainty", type=float, default=TANGENT.target_uncertainty,
                    metavar="REL",
                    help="average until the relative uncertainty of lambda1 is REL (e.g. 0.05) or "
                         "--max-revs is reached, and say which")
    sp.add_argument("--max-revs", type=float, default=None, metavar="REVS",
                    help=f"limit of the averaging with --target-uncertainty (default "
                         f"{TANGENT.max_total_factor:g} x --revs)")
    sp.add_argument("--check", action="store_true",
                    help="also compute lambda1 with the other estimator and report the agreement")
    sp.add_argument("--state-error-only", action="store_true",
                    help="tangent estimator: only the state takes part in the step-size control "
                         "(about half the CPU time; same exponents on every case of "
                         "benchmarks/results/lyapunov.md)")
    sp.add_argument("--d0", type=float, default=BENETTIN.d0,
                    help=f"initial separation of the Benettin estimator, scaled norm (default {BENETTIN.d0:g})")
    sp.add_argument("--seed", type=count_arg("--seed", 0), default=0,
                    help="seed of the initial perturbation, a whole number >= 0 (default 0)")
    sp.add_argument("--method", choices=("dopri5", "dop853", "rodas"), default=LYAPUNOV.method,
                    help=f"integrator of the Benettin trajectories (default {LYAPUNOV.method}; the tangent "
                         "estimator always uses its DOPRI5; rodas is experimental)")
    sp.add_argument("--spectrum", type=count_arg("--spectrum", 0), default=0, metavar="K",
                    help="also the first K exponents by the perturbation-vector method")
    sp.add_argument("--json", action="store_true", help="print the result as JSON")
    sp.set_defaults(func=cmd_lyapunov)


def check_revs(args) -> None:
    """InputError naming --revs (or --max-revs) when the record of the local rates would not fit
    in memory (nld.analysis.lyapunov.MAX_RECORD_BYTES), with the largest possible value."""
    from nld.analysis.lyapunov import MAX_RECORD_BYTES, max_intervals
    if args.estimator == "tangent":
        per_rev = 1.0 / (args.renorm if args.renorm is not None else TANGENT.interval_revs)
    else:
        per_rev = 1.0 / (args.renorm if args.renorm is not None else BENETTIN.interval_revs)
    name, revs = "--revs", args.revs
    if args.estimator == "tangent" and args.target_uncertainty is not None:
        name, revs = ("--max-revs", args.max_revs) if args.max_revs is not None else \
            ("--revs", TANGENT.max_total_factor * args.revs)
    k = max(args.k, args.spectrum)
    most = max_intervals(k) / per_rev
    if name == "--revs" and revs != args.revs:
        most /= TANGENT.max_total_factor        # --target-uncertainty averages up to 10 x --revs
    if revs * per_rev > max_intervals(k):
        raise InputError(f"{name} = {getattr(args, name[2:].replace('-', '_')):g}: too long to record: "
                         f"{revs * per_rev:.3g} renormalisation intervals ({per_rev:g} per revolution"
                         f"{f', k = {k}' if k > 1 else ''}) would need "
                         f"{revs * per_rev * 8 * k / 2**30:.3g} GiB; at most {most:.3g} revolutions "
                         f"({MAX_RECORD_BYTES / 2**30:g} GiB)")


def cmd_lyapunov(args) -> int:
    import json

    from nld.analysis.lyapunov import lyapunov_benettin, lyapunov_spectrum, lyapunov_tangent
    from nld.systems.core import SceneSystem
    from nld.run.simulate import provenance
    for name in ("revs", "rtol", "d0"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"--{name.replace('_', '-')} = {v!r}: must be a positive number")
    if not (math.isfinite(args.transient) and args.transient >= 0):
        raise InputError(f"--transient = {args.transient!r}: must be a number of revolutions >= 0")
    if args.revs < 1:
        raise InputError(f"--revs = {args.revs!r}: must be at least 1 revolution")
    if args.renorm is not None and not (math.isfinite(args.renorm) and args.renorm > 0):
        raise InputError(f"--renorm = {args.renorm!r}: must be a positive number of revolutions")
    if args.max_revs is not None and not (math.isfinite(args.max_revs) and args.max_revs >= args.revs):
        raise InputError(f"--max-revs = {args.max_revs!r}: must be a number of revolutions >= --revs "
                         f"({args.revs:g})")
    if args.target_uncertainty is not None and not (math.isfinite(args.target_uncertainty)
                                                    and 0 < args.target_uncertainty < 1):
        raise InputError(f"--target-uncertainty = {args.target_uncertainty!r}: must be a relative "
                         "uncertainty in (0, 1), e.g. 0.05")
    if args.estimator == "benettin" and args.state_error_only:
        raise InputError("--state-error-only: an option of the tangent estimator, not of benettin")
    if args.estimator == "benettin" and (args.k != 1 or args.target_uncertainty is not None):
        raise InputError("--estimator benettin: gives lambda1 only, without --k or "
                         "--target-uncertainty (use the tangent estimator)")
    if args.check and args.k != 1:
        raise InputError(f"--check with --k {args.k}: the check compares lambda1 of the two "
                         "estimators; run it without --k (or with --k 1)")
    check_revs(args)
    system = SceneSystem(args.scene, args.overrides, method=args.method)
    if system.period is None:
        raise InputError(f"scene {system.name!r} has no crank speed: --revs needs a driven crank")
    T = system.period
    renorm = None if args.renorm is None else args.renorm * T
    if args.estimator == "tangent":
        res = lyapunov_tangent(system, args.k, transient=args.transient * T, total=args.revs * T,
                               rtol=args.rtol, seed=args.seed, renorm_interval=renorm,
                               target_uncertainty=args.target_uncertainty,
                               max_total=None if args.max_revs is None else args.max_revs * T,
                               progress=args.progress, check=args.check,
                               tangent_err=not args.state_error_only)
    else:
        res = lyapunov_benettin(system, transient=args.transient * T, total=args.revs * T,
                                d0=args.d0, rtol=args.rtol, seed=args.seed, renorm_interval=renorm)
        if args.check:
            tg = lyapunov_tangent(system, transient=args.transient * T, total=args.revs * T,
                                  rtol=args.rtol, seed=args.seed, progress=args.progress)
            diff = abs(tg.exponent - res.exponent)
            res.check = dict(tangent=tg.exponent, tangent_uncertainty=tg.uncertainty,
                             benettin=res.exponent, benettin_uncertainty=res.uncertainty,
                             difference=diff, agree=bool(diff <= tg.uncertainty + res.uncertainty))
    import numpy as np
    ex = [float(x) for x in np.atleast_1d(getattr(res, "exponents", res.exponent))]
    un = [float(x) for x in np.atleast_1d(res.uncertainty)]
    out = {"scene": system.scene.name, "overrides": list(args.overrides),
           "estimator": res.settings.get("estimator", "benettin"),
           "exponent_per_s": ex[0], "uncertainty_per_s": un[0],
           "exponent_per_revolution": ex[0] * T, "uncertainty_per_revolution": un[0] * T,
           "method": res.method, "transient_revs": args.transient,
           "averaged_revs": res.settings["total"] / T, "rtol": args.rtol, "seed": args.seed,
           "settings": {k: v for k, v in res.settings.items() if k != "scales"},
           "diagnostics": getattr(res, "diagnostics", {})}
    if len(ex) > 1:
        out["exponents_per_s"] = ex
        out["uncertainties_per_s"] = un
    if getattr(res, "check", None):
        out["check"] = {k: v for k, v in res.check.items() if not k.endswith("settings")}
    if args.spectrum > 0:
        sp = lyapunov_spectrum(system, args.spectrum, transient=args.transient * T,
                               total=args.revs * T, rtol=args.rtol,
                               **progress_kw(lyapunov_spectrum, args.progress))
        out["spectrum_per_s"] = [float(x) for x in sp.exponents]
        out["spectrum_uncertainty_per_s"] = [float(x) for x in sp.uncertainty]
    prov = provenance(system.scene, system.kernel, rtol=args.rtol)
    if args.json:
        out["provenance"] = {k: v for k, v in prov.items() if k != "scene_parameters"}
        print(json.dumps(out, indent=2, default=float))
        return 0
    lab = "lambda1" if len(ex) == 1 else "lambda"
    for j, (e, u) in enumerate(zip(ex, un)):
        name = lab if len(ex) == 1 else f"lambda{j + 1}"
        print(f"{name} = {e:.6g} +- {u:.2g} 1/s = {e * T:.4g} +- {u * T:.2g} per revolution")
    st = res.settings
    line = (f"estimator {out['estimator']}, rtol {args.rtol:g}, transient {args.transient:g} rev, "
            f"averaged over {out['averaged_revs']:.4g} rev")
    if out["estimator"] == "tangent":
        line += f", re-orthonormalised every {st['renorm_interval'] / T:.4g} rev"
        if st.get("tangent_err") is False:
            line += ", state-only error control"
        dg = out["diagnostics"]
        if "onsets_per_period" in dg:
            line += f"; {dg['onsets_per_period']:.3g} contact onsets per revolution"
        if dg.get("grazing"):
            line += f", {dg['grazing']} grazing events"
        if st.get("target_uncertainty") is not None:
            line += ("; target uncertainty reached" if st.get("target_reached")
                     else f"; target uncertainty NOT reached within {st['max_total'] / T:.4g} rev")
    else:
        line += f", d0 {st['d0']:g}, {st['checks']} checks per revolution"
    print(line)
    if out["diagnostics"].get("permanent_contact"):
        mem = ", ".join(f"{k} = {v:.4g} m/s" for k, v in out["diagnostics"]["conditional_on_memory"].items())
        import sys
        print("nld: warning: permanent contact over the averaging span (no contact onset): the "
              f"exponent is conditional on the recorded approach velocity {mem}, which the history "
              "set; another transient gives another value (docs/orbits.md, 'Memory state')",
              file=sys.stderr)
    if out.get("check"):
        c = out["check"]
        print(f"check: tangent {c['tangent'] * T:.4g} +- {c['tangent_uncertainty'] * T:.2g}, "
              f"benettin {c['benettin'] * T:.4g} +- {c['benettin_uncertainty'] * T:.2g} per "
              f"revolution: {'agree' if c['agree'] else 'DISAGREE'} within their uncertainties")
    if args.spectrum > 0:
        print("spectrum (1/s): " + ", ".join(f"{x:.4g} +- {u:.2g}" for x, u in
                                            zip(out["spectrum_per_s"], out["spectrum_uncertainty_per_s"])))
    return 0
