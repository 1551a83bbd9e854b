"""``nld poincare``: the Poincaré section of a scene (stroboscopic or crank-angle) and its period."""
from __future__ import annotations

from nld.analysis.poincare import DEFAULT_PERIOD_TOL
from nld.cli.args import count_arg, number_arg, print_error, rtol_arg, scene_args
from nld.errors import Interrupted
from nld.settings import POINCARE_SPANS, SECTIONS


def add_parser(sub):
    """Add ``nld poincare`` to the sub-commands of nld's parser; returns the sub-parser."""
    sp = sub.add_parser(
        "poincare", help="Poincaré section of a scene (stroboscopic or crank-angle)",
        description="Poincaré section: the observables at every crank revolution after a transient "
                    "(stroboscopic, speed-driven crank) or at each crossing of crank angle = "
                    "THETA0 mod 2 pi (--angle, e.g. a torque-driven crank); prints the points and "
                    "the detected period.")
    scene_args(sp)
    sp.add_argument("--transient-revs", type=count_arg("--transient-revs", 0), default=POINCARE_SPANS.transient_revs, metavar="N",
                    help=f"crank revolutions discarded first (default {POINCARE_SPANS.transient_revs})")
    sp.add_argument("--revs", type=count_arg("--revs", 1), default=POINCARE_SPANS.revs, metavar="N",
                    help=f"section points / revolutions after the transient (default {POINCARE_SPANS.revs})")
    sp.add_argument("--observables", default=None, metavar="COLS",
                    help="comma-separated table columns (default: <first clearance joint>.ex,.ey)")
    sp.add_argument("--rtol", type=rtol_arg, default=SECTIONS.rtol, metavar="R",
                    help=f"relative tolerance (default {SECTIONS.rtol:g})")
    sp.add_argument("--angle", type=number_arg("--angle", positive=False), default=None,
                    metavar="THETA0", help="crank-angle section at THETA0 (rad) mod 2 pi instead "
                                           "of the stroboscopic one")
    sp.add_argument("--period-tol", type=number_arg("--period-tol"), default=DEFAULT_PERIOD_TOL,
                    metavar="TOL", help=f"relative tolerance of the period detection "
                                        f"(default {DEFAULT_PERIOD_TOL:g})")
    sp.add_argument("--out", metavar="FILE", help="write the points to FILE.csv or FILE.parquet "
                                                 "(provenance in FILE.json / parquet metadata)")
    sp.set_defaults(func=cmd_poincare)
    return sp


def cmd_poincare(args) -> int:
    """``nld poincare``: print (or write) the section points and the detected period."""
    from nld.analysis.poincare import hyperplane_section, period_of, section_scales, stroboscopic
    from nld.output.io import check_table_path, save_table
    out = check_table_path(args.out) if args.out else None
    try:
        if args.angle is None:
            sec = stroboscopic(args.scene, transient_revs=args.transient_revs, revs=args.revs,
                               observables=args.observables, overrides=args.overrides,
                               rtol=args.rtol, progress=args.progress)
        else:
            sec = hyperplane_section(args.scene, observable="driver.angle", level=args.angle,
                                     transient_revs=args.transient_revs, revs=args.revs,
                                     observables=args.observables, overrides=args.overrides,
                                     rtol=args.rtol, progress=args.progress)
    except Interrupted as e:
        if e.partial is None or out is None:
            raise
        prov = dict(e.partial.provenance)
        prov.update(command=getattr(args, "command_line", None))
        path = save_table(e.partial.table, out, prov, partial=True)
        raise Interrupted(str(e), kept=f"wrote the partial section ({e.kept}) to {path}, marked "
                                       f"partial in its provenance ({out} not replaced)") from None
    from nld.model.scene import load_scene
    n = period_of(sec.points, tol=args.period_tol,
                  scale=section_scales(load_scene(args.scene, args.overrides), sec.observables))
    prov = dict(sec.provenance)
    prov.update(period_detected=n, period_tol=args.period_tol,
                command=getattr(args, "command_line", None))
    if out is not None:
        # a failed run writes what it has beside the target (out itself is left alone)
        path = save_table(sec.table, out, prov, partial=not sec.success)
        print(f"wrote {len(sec.table)} section points to {path}"
              + ("" if sec.success else f", marked partial ({out} not replaced)"))
    else:
        print(sec.table.to_string(index=False, float_format=lambda v: f"{v:.9g}"))
    print(f"period: {n if n else 'none found (aperiodic or longer than 16)'} "
          f"(tolerance {args.period_tol:g}); {sec.message}")
    if not sec.success:
        print_error(f"integration failed: {sec.message}")
        return 1
    return 0
