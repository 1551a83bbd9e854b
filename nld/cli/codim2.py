"""``nld continue ... --follow KIND --param2 KEY2 --values2 A:B:N``: the first located bifurcation of
KIND on the one-parameter branch followed in a second scene parameter
(nld.analysis.codim2.continue_bifurcation; docs/codim2.md). The options are added to ``nld
continue``'s parser by :func:`add_args` and checked by :func:`check` before any integration;
:func:`follow` runs after the branch and writes DIR/curve.parquet and
DIR/curve_special_points.parquet (provenance in their sidecars) and, with --plot, draws the curve
in the (KEY, KEY2) plane."""
from __future__ import annotations

import argparse

from nld.errors import InputError, SolveError

# the command line's names of the kinds a curve follows -> the API's
FOLLOW_KINDS = {"period-doubling": "period_doubling", "fold": "fold",
                "neimark-sacker": "neimark_sacker", "grazing": "grazing"}


def follow_arg(text: str) -> str:
    """argparse type of --follow: one of FOLLOW_KINDS (the API's name with '_' is taken too)."""
    t = text.strip().lower().replace("_", "-")
    if t not in FOLLOW_KINDS:
        raise argparse.ArgumentTypeError(f"--follow = {text!r}: must be one of "
                                         f"{', '.join(FOLLOW_KINDS)}")
    return t


def add_args(sc) -> None:
    """--follow, --param2, --values2, --max-points2 on ``nld continue``'s parser."""
    from nld.cli.args import count_arg, values_of
    sc.add_argument("--follow", type=follow_arg, default=None, metavar="KIND",
                    help="follow the first located bifurcation of this kind on the branch in "
                         "--param2: " + ", ".join(FOLLOW_KINDS) + " (writes DIR/curve.parquet; "
                         "--plot then draws the curve in the (KEY, KEY2) plane)")
    sc.add_argument("--param2", default=None, metavar="KEY2",
                    help="the second scene key of --follow, e.g. joints.B.friction.mu")
    sc.add_argument("--values2", type=values_of("--values2"), default=None, metavar="A:B:N",
                    help="the range of KEY2 for --follow (it must contain the scene's value of "
                         "KEY2); the values inside it are landed on exactly")
    sc.add_argument("--max-points2", type=count_arg("--max-points2", 2), default=100,
                    metavar="N", help="at most N curve points per direction (default 100)")


def check(args, base, fam1):
    """--follow's options, before any integration: all three given together, KEY2 a scene key
    other than --param, every value of --values2 inside KEY2's domain and the range containing
    the scene's value of KEY2. Returns KEY2's Family (None without --follow)."""
    import numpy as np
    from nld.analysis.continuation import Family, check_values
    given = [o for o, v in (("--follow", args.follow), ("--param2", args.param2),
                            ("--values2", args.values2)) if v is not None]
    if not given:
        return None
    missing = [o for o in ("--follow", "--param2", "--values2") if o not in given]
    if missing:
        raise InputError(f"{given[0]} = {_shown(args, given[0])}: needs {' and '.join(missing)} "
                         f"(--follow KIND --param2 KEY2 --values2 A:B:N go together)")
    if args.param2 == args.param:
        raise InputError(f"--param2 = {args.param2!r}: must differ from --param")
    try:
        fam2 = Family(base, args.param2)
    except InputError as e:
        raise InputError(f"--param2 = {args.param2!r}: {str(e).split(': ', 1)[-1]}") from None
    v2 = np.array(args.values2, dtype=float)
    for v in v2:
        fam2.check(v, "--values2:")
    check_values(v2, v2[0], "--values2", contain=False)
    lo, hi = min(v2[0], v2[-1]), max(v2[0], v2[-1])
    if not lo <= fam2.value0 <= hi:
        raise InputError(f"--values2 = {v2[0]:g}:{v2[-1]:g}: must contain the scene's value of "
                         f"{args.param2}, {fam2.value0:g} (the curve starts there; change it "
                         f"with --set {args.param2}=VALUE)")
    for x in (v2[0], v2[-1]):
        fam2.at(x)                               # the same structure at the range's ends
    return fam2


def _shown(args, option):
    v = getattr(args, option.lstrip("-").replace("-", "_"))
    return repr(v) if not isinstance(v, list) else ":".join(f"{x:g}" for x in (v[0], v[-1]))


def follow(args, system, br, out, plot, prov):
    """The curve from the branch ``br`` (of ``system`` in --param); prints it, writes it, draws
    it. Exit status 0; SolveError (exit 1) where the branch has no located bifurcation of KIND or
    the curve's start did not converge."""
    import numpy as np
    from nld.analysis.codim2 import continue_bifurcation
    from nld.output.io import save_table
    kind = FOLLOW_KINDS[args.follow]
    cands = [b for b in br.bifurcations if b.kind == kind and b.located and b.orbit is not None]
    if not cands:
        found = ", ".join(sorted({b.kind for b in br.bifurcations})) or "none"
        raise SolveError(f"--follow {args.follow}: no located {kind} on the branch in "
                         f"{args.param} (bifurcations found: {found})")
    bif = cands[0]
    v2 = np.array(args.values2, dtype=float)
    lo, hi = min(v2[0], v2[-1]), max(v2[0], v2[-1])
    stops = [float(v) for v in v2 if lo < v < hi]
    # the branch's system at the bifurcation: its --param value is bif.value (replaced inside)
    curve = continue_bifurcation(system, bif, args.param2, (v2[0], v2[-1]), param=args.param,
                                 stops=stops, max_points=args.max_points2)
    tab = curve.table()
    sp = curve.special_table()
    sp["between"] = sp["between"].astype(str)
    cprov = dict(prov)
    cprov.update({"follow": kind, "param2": args.param2, "values2": v2.tolist(),
                  "bifurcation": bif.to_dict() if hasattr(bif, "to_dict") else bif.kind,
                  "curve_settings": curve.settings, "curve_ends": [e.to_dict() for e in curve.ends],
                  "curve_completed": curve.completed, "curve_message": curve.message})
    s = curve.settings
    print(f"{kind} curve from {args.param} = {bif.value:.9g} ± {bif.tolerance:.2g} in "
          f"{args.param2} over {v2[0]:g} ... {v2[-1]:g}: {len(curve.values1)} points; "
          f"{curve.message} ({s.get('wall_s', float('nan')):.1f} s)")
    for sp_ in curve.special_points:
        print(f"  {sp_.kind} at {args.param} = {sp_.value1:.6g} ± {sp_.uncertainty1:.2g}, "
              f"{args.param2} = {sp_.value2:.6g} ± {sp_.uncertainty2:.2g}: {sp_.detail}")
    if not curve.special_points:
        print("  no codim-2 point on the curve")
    cols = ["value1", "value2", "tolerance1", "distance", "onsets_per_period"]
    print(tab[cols].rename(columns={"value1": args.param, "value2": args.param2})
          .to_string(index=False, float_format=lambda v: f"{v:.9g}"))
    if out is not None:
        p1 = save_table(tab, out / "curve.parquet", cprov)
        p2 = save_table(sp, out / "curve_special_points.parquet", cprov)
        print(f"wrote {p1} and {p2}")
    if plot is not None:
        from nld.analysis.codim2 import plot_curves
        from nld.output.io import save_figure
        fig = plot_curves([curve], x_label=args.param, y_label=args.param2,
                          title=f"{kind.replace('_', ' ')} curve of the period-{br.period} orbit")
        print(f"wrote {save_figure(fig, plot)}")
    return 0
