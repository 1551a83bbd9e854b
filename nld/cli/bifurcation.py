"""``nld bifurcation``: a bifurcation sweep of one scene value (stroboscopic points per value)."""
from __future__ import annotations

from nld.cli.args import count_arg, rtol_arg, scene_args, values_arg, pool_args
from nld.errors import InputError
from nld.settings import BIFURCATION_SPANS, SECTIONS


def add_parser(sub):
    """Add ``nld bifurcation`` to the sub-commands of nld's parser; returns the sub-parser."""
    sp = sub.add_parser(
        "bifurcation", help="bifurcation sweep of a scene parameter (stroboscopic points)",
        description="Sweep one scene value (any --set key) and record the stroboscopic Poincaré "
                    "points after a transient, a period estimate and optionally the largest "
                    "Lyapunov exponent, one parquet file per point in --out DIR.")
    scene_args(sp)
    sp.add_argument("--param", required=True, metavar="KEY",
                    help="the swept value, a --set key such as driver.speed")
    sp.add_argument("--values", required=True, type=values_arg, metavar="START:STOP:NUM|V1,V2,...",
                    help="values: START:STOP:NUM (ends included) or a comma-separated list")
    sp.add_argument("--out", required=True, metavar="DIR", help="output directory (parquet per point)")
    sp.add_argument("--transient-revs", type=count_arg("--transient-revs", 0), default=BIFURCATION_SPANS.transient_revs, metavar="N",
                    help=f"revolutions discarded per point (default {BIFURCATION_SPANS.transient_revs})")
    sp.add_argument("--revs", type=count_arg("--revs", 1), default=BIFURCATION_SPANS.revs, metavar="N",
                    help=f"section points per value (default {BIFURCATION_SPANS.revs})")
    sp.add_argument("--observables", default=None, metavar="COLS",
                    help="comma-separated table columns (default <first clearance joint>.ex,.ey)")
    sp.add_argument("--rtol", type=rtol_arg, default=SECTIONS.rtol, metavar="R",
                    help=f"relative tolerance (default {SECTIONS.rtol:g})")
    sp.add_argument("--continuation", action="store_true",
                    help="start each point from the previous point's final state (sequential)")
    sp.add_argument("--up-down", action="store_true",
                    help="sweep up then down (hysteresis; use with --continuation)")
    pool_args(sp)
    sp.add_argument("--resume", action="store_true", help="skip the points already in --out")
    sp.add_argument("--lyapunov", action="store_true",
                    help="also the largest Lyapunov exponent of every point (slower)")
    sp.add_argument("--estimator", choices=("tangent", "benettin"), default="tangent",
                    help="estimator of --lyapunov: tangent dynamics with saltation (default) or "
                         "two trajectories (benettin)")
    sp.set_defaults(func=cmd_bifurcation)
    return sp


def cmd_bifurcation(args) -> int:
    """``nld bifurcation``: run the sweep, print one line per point and the output directory."""
    import sys

    from nld.analysis.bifurcation import check_values, sweep
    from nld.progress import write

    def on_point(k, n, rec):
        per = rec["table"]["period"].iloc[0]
        write(f"[{k}/{n}] {args.param} = {rec['value']!s} ({rec['direction']}): {rec['status']}, "
              f"period {per if per else '-'} ({rec['wall']:.3g} s)"
              + (f": {rec['message']}" if rec["status"] != "ok" else ""))

    check_values(args.scene, args.overrides, [args.param], args.values, "--values")
    if args.observables is not None:     # refused before the sweep, not as a failure of every point
        from nld.analysis.poincare import check_scene_observables
        try:
            check_scene_observables(args.scene, args.observables, args.overrides)
        except InputError as e:
            raise InputError(f"--observables: {e}") from None
    df = sweep(args.scene, args.param, args.values, transient_revs=args.transient_revs,
               revs=args.revs, observables=args.observables, rtol=args.rtol,
               continuation=args.continuation, up_down=args.up_down, workers=args.workers,
               dask=args.dask, out=args.out, resume=args.resume, lyapunov=args.lyapunov,
               lyapunov_estimator=args.estimator, overrides=args.overrides,
               progress=args.progress, on_point=on_point)
    pts = df.drop_duplicates(["direction", "index"])
    n_failed = int((pts["status"] != "ok").sum())
    print(f"wrote {len(pts)} points to {args.out} (read with nld.analysis.bifurcation.load_sweep)")
    if n_failed:
        print(f"nld: warning: {n_failed} of {len(pts)} points failed (status 'failed' in the table)",
              file=sys.stderr)
    return 1 if n_failed == len(pts) else 0
