"""``nld chaos-map``: the largest Lyapunov exponent (and the 0-1 test) over a grid of two scene
values."""
from __future__ import annotations

import math
from pathlib import Path

from nld.cli.args import count_arg, number_arg, rtol_arg, values_of, pool_args
from nld.errors import InputError
from nld.settings import BENETTIN, CHAOS_MAP_SPANS, LYAPUNOV


def add_parser(sub):
    """Add ``nld chaos-map`` to the sub-commands of nld's parser; returns the sub-parser."""
    sp = sub.add_parser(
        "chaos-map", help="largest Lyapunov exponent over a grid of two scene parameters",
        description="Two-parameter chaos map: for every cell of the grid --x-values x --y-values "
                    "(any two --set keys, e.g. joints.B.clearance and joints.B.friction.mu) a "
                    "stroboscopic section, the largest Lyapunov exponent (Benettin) from its end "
                    "and the 0-1 test of the section; one parquet file per cell in --out DIR "
                    "(resumable), optionally a heat map with the onset boundary lambda = 0.")
    sp.add_argument("scene", metavar="SCENE", help="built-in scene name or path of a .toml file")
    sp.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="override a scene value before the grid, e.g. driver.speed=300 (repeatable)")
    sp.add_argument("--x", required=True, metavar="KEY[,KEY...]",
                    help="x parameter: a --set key, or comma-separated keys set to the same value "
                         "(e.g. joints.A.clearance,joints.B.clearance)")
    sp.add_argument("--x-values", required=True, type=values_of("--x-values"),
                    metavar="START:STOP:NUM|V1,V2,...", help="x values (ends included) or a list")
    sp.add_argument("--y", required=True, metavar="KEY[,KEY...]", help="y parameter (as --x)")
    sp.add_argument("--y-values", required=True, type=values_of("--y-values"),
                    metavar="START:STOP:NUM|V1,V2,...", help="y values")
    sp.add_argument("--out", required=True, metavar="DIR",
                    help="output directory (parquet per cell + provenance.json)")
    sp.add_argument("--transient-revs", type=count_arg("--transient-revs", 0), default=CHAOS_MAP_SPANS.transient_revs, metavar="N",
                    help=f"revolutions discarded per cell (default {CHAOS_MAP_SPANS.transient_revs})")
    sp.add_argument("--revs", type=count_arg("--revs", 1), default=CHAOS_MAP_SPANS.revs, metavar="N",
                    help=f"section points per cell (default {CHAOS_MAP_SPANS.revs}; the 0-1 test needs >= 30)")
    sp.add_argument("--lyapunov-revs", type=count_arg("--lyapunov-revs", 2), default=None,
                    metavar="N", help="revolutions of the exponent estimate (default --revs)")
    sp.add_argument("--rtol", type=rtol_arg, default=LYAPUNOV.rtol, metavar="R",
                    help=f"relative tolerance (default {LYAPUNOV.rtol:g}; see docs/analysis.md before raising it)")
    sp.add_argument("--lyapunov-rtol", type=rtol_arg, default=None, metavar="R",
                    help="relative tolerance of the exponent (default --rtol)")
    sp.add_argument("--rtol-check", type=rtol_arg, default=None, metavar="R",
                    help="recompute each exponent at this second tolerance; cells where the two "
                         "disagree are 'not established' (default: no check)")
    sp.add_argument("--check-span", type=number_arg("--check-span"), default=1.0, metavar="F",
                    help="with --rtol-check: average the check over F times the exponent's span "
                         "(default 1; 2 checks a change of averaging time too)")
    sp.add_argument("--estimator", choices=("tangent", "benettin"), default="tangent",
                    help="estimator of the exponent: tangent dynamics with saltation (default) "
                         "or two trajectories (benettin)")
    sp.add_argument("--lyapunov-method", choices=("dopri5", "dop853", "rodas"), default=LYAPUNOV.method,
                    help=f"integrator of the exponent (default {LYAPUNOV.method}; dop853 and rodas only with "
                         "--estimator benettin; rodas is experimental and slow on contact "
                         "scenes, see docs/lyapunov.md)")
    sp.add_argument("--d0", type=number_arg("--d0"), default=None, metavar="D0",
                    help=f"initial separation of --estimator benettin, scaled norm (default {BENETTIN.d0:g})")
    sp.add_argument("--seed", type=count_arg("--seed", 0), default=0,
                    help="seed of the perturbation direction, a whole number >= 0 (default 0)")
    sp.add_argument("--observable", default=None, metavar="COL",
                    help="section observable of the 0-1 test (default <first clearance joint>.ex)")
    pool_args(sp)
    sp.add_argument("--resume", action="store_true", help="skip the cells already in --out")
    sp.add_argument("--plot", default=None, metavar="FILE",
                    help="also write the heat map (lambda per revolution, lambda = 0 contour) to "
                         "FILE (.png, .pdf, .svg)")
    sp.set_defaults(func=cmd_chaos_map)
    return sp


def split_keys(text: str) -> list[str]:
    keys = [k.strip() for k in str(text).split(",") if k.strip()]
    if not keys:
        raise InputError(f"parameter = {text!r}: give a --set key such as joints.B.clearance")
    return keys


def cmd_chaos_map(args) -> int:
    """``nld chaos-map``: run the map, print one line per cell and a summary; exit 1 only when
    every cell failed."""
    import sys

    from nld.analysis.bifurcation import check_values
    from nld.analysis.chaos_map import chaos_map, chaos_map_plot, param_label
    kx, ky = split_keys(args.x), split_keys(args.y)
    lx, ly = param_label(kx), param_label(ky)
    if args.plot is not None:          # refused before the (long) map, not after it
        from nld.output.io import check_figure_path
        check_figure_path(args.plot, "--plot")

    from nld.progress import write

    def on_point(k, n, rec):
        t = rec["table"].iloc[0]
        if rec["status"] == "ok":
            res = (f"lambda = {t['per_revolution']:.3g} +- {t['uncertainty_per_revolution']:.2g} "
                   f"per rev ({t['verdict']})" + (f", K = {t['K']:.2f}" if math.isfinite(t["K"]) else ""))
        else:
            res = f"failed: {rec['message']}"
        x, y = rec["value"]
        write(f"[{k}/{n}] {lx} = {x!s}, {ly} = {y!s}: {res} ({rec['wall']:.3g} s)")

    if not (math.isfinite(args.check_span) and 1.0 <= args.check_span <= 100.0):
        raise InputError(f"--check-span = {args.check_span:g}: must be a number in [1, 100] (the "
                         "check's averaging span over the exponent's)")
    check_values(args.scene, args.overrides, kx, args.x_values, "--x-values")
    check_values(args.scene, args.overrides, ky, args.y_values, "--y-values")

    df = chaos_map(args.scene, kx if len(kx) > 1 else kx[0], args.x_values,
                   ky if len(ky) > 1 else ky[0], args.y_values,
                   transient_revs=args.transient_revs, revs=args.revs,
                   lyapunov_revs=args.lyapunov_revs, rtol=args.rtol,
                   lyapunov_rtol=args.lyapunov_rtol, rtol_check=args.rtol_check,
                   check_span=args.check_span, d0=args.d0,
                   lyapunov_method=args.lyapunov_method, estimator=args.estimator,
                   seed=args.seed,
                   observable=args.observable, workers=args.workers, dask=args.dask,
                   out=args.out, resume=args.resume, base_overrides=args.overrides,
                   progress=args.progress, on_point=on_point)
    counts = df["verdict"].value_counts()
    print(f"wrote {len(df)} cells to {args.out} (read with nld.analysis.chaos_map.load_chaos_map): "
          + ", ".join(f"{counts.get(v, 0)} {v}" for v in ("chaotic", "regular", "uncertain", "not established",
                                                             "failed")))
    if args.plot is not None:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        from nld.output.io import save_figure
        fig = chaos_map_plot(df, title=f"{df.attrs['provenance'].get('scene', args.scene)}: "
                                       "largest Lyapunov exponent")
        try:
            save_figure(fig, args.plot, dpi=150, bbox_inches="tight")
        except InputError as e:
            raise InputError(f"{e}; the {len(df)} cells are kept in {args.out} (plot them with "
                             "nld.analysis.chaos_map.chaos_map_plot, or run again with --resume "
                             "and another --plot)") from None
        finally:
            plt.close(fig)
        print(f"wrote {args.plot}")
    n_failed = int((df["status"] != "ok").sum())
    if n_failed:
        print(f"nld: warning: {n_failed} of {len(df)} cells failed (status 'failed' in the table)",
              file=sys.stderr)
    return 1 if n_failed == len(df) else 0
