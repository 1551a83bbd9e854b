"""``nld simulate``: simulate a scene (or evaluate its ideal-joint twin) and print a summary or
write the table."""
from __future__ import annotations

import time

from nld.cli.args import count_arg, number_arg, print_error, rtol_arg, scene_args
from nld.errors import InputError, Interrupted
from nld.settings import SIMULATE


def add_parser(sub) -> None:
    sp = sub.add_parser("simulate", help="simulate a scene",
                        description="Simulate a scene (adaptive Dormand-Prince 5(4)); with --ideal, "
                                    "evaluate its ideal-joint twin at the same output times instead.")
    scene_args(sp)
    g = sp.add_mutually_exclusive_group()
    g.add_argument("--revs", type=number_arg("--revs"), metavar="N",
                   help="crank revolutions to simulate (default 1)")
    g.add_argument("--t-end", type=number_arg("--t-end"), metavar="T", help="end time (s)")
    sp.add_argument("--rtol", type=rtol_arg, default=None, metavar="R",
                    help=f"relative tolerance (default: the scene's recommended rtol, else {SIMULATE.rtol:g})")
    sp.add_argument("--samples-per-rev", type=count_arg("--samples-per-rev", 1),
                    default=SIMULATE.samples_per_rev, metavar="N",
                    help=f"output samples per crank revolution (default {SIMULATE.samples_per_rev})")
    sp.add_argument("--ideal", action="store_true",
                    help="ideal-joint reference solution (nld.model.ideal) at the same output times")
    sp.add_argument("--out", metavar="FILE", help="write the table to FILE.csv or FILE.parquet "
                                                 "(provenance in FILE.json / parquet metadata)")
    sp.set_defaults(func=cmd_simulate)


def output_times(scene, *, revs=None, t_end=None, samples_per_rev: int):
    """Output times (s) of a run, as :func:`nld.run.simulate.simulate` chooses them by default
    (InputError naming --revs / --t-end when the table would be too large for memory)."""
    import numpy as np
    from nld.run.simulate import crank_period, output_rows
    if t_end is None:
        t_end = (1.0 if revs is None else revs) * crank_period(scene, "--revs")
    n = output_rows(scene, t_end, samples_per_rev, None, "--t-end" if revs is None else "--revs")
    return np.linspace(0.0, t_end, n)


def cmd_simulate(args) -> int:
    from nld.output.io import check_table_path, save_table
    from nld.model.scene import load_scene
    out = check_table_path(args.out) if args.out else None       # fail before the (long) run
    if out is not None:
        try:
            out.parent.mkdir(parents=True, exist_ok=True)
        except OSError as e:
            why = "a file is in the way" if isinstance(e, (FileExistsError, NotADirectoryError)) \
                else (e.strerror or e)
            raise InputError(f"--out {args.out!r}: cannot create its directory ({why})") from None
    scene = load_scene(args.scene, args.overrides)
    times = output_times(scene, revs=args.revs, t_end=args.t_end, samples_per_rev=args.samples_per_rev)
    t_end = float(times[-1])
    start = time.perf_counter()
    interrupted = None
    if args.ideal:
        from nld.model.ideal import ideal_solution
        from nld.run.simulate import provenance
        table = ideal_solution(scene, times)
        wall = time.perf_counter() - start
        status, message, stats, events = 0, "ideal joints: position, velocity, acceleration and " \
                                            "inverse-dynamics analysis (nld.model.ideal)", None, None
        prov = provenance(scene, None, integrator="ideal (nld.model.ideal.ideal_solution)", t_end=t_end, wall=wall)
    else:
        from nld.run.simulate import simulate
        try:
            res = simulate(scene, t_eval=times, rtol=args.rtol, samples_per_rev=args.samples_per_rev,
                           progress=args.progress)
        except Interrupted as e:
            if e.partial is None:
                raise
            res, interrupted = e.partial, e
        wall = time.perf_counter() - start
        table, status, message, stats, events = res.table, res.status, res.message, res.stats, res.events
        prov = dict(res.provenance)
        prov.update(status=int(status), message=message, t_reached=float(res.t_reached),
                    stats=dict(stats))
    prov.update(kind="ideal" if args.ideal else "simulate", samples_per_rev=args.samples_per_rev,
                revs=args.revs if args.t_end is None else None, command=args.command_line)
    failed = interrupted is None and status < 0
    path = None
    if out is not None:
        # the target is replaced only by a complete, successful run; anything else goes beside it
        path = save_table(table, out, prov, partial=interrupted is not None or failed)
    if interrupted is not None:
        if path is not None:
            kept = (f"wrote the partial table ({interrupted.kept}) to {path}, marked partial in its "
                    f"provenance ({out} not replaced)")
        else:
            kept = f"nothing written (no --out); {interrupted.kept} computed"
        raise Interrupted(f"simulate stopped at t = {res.t_reached:.6g} s of {t_end:.6g} s",
                          kept=f"simulate stopped at t = {res.t_reached:.6g} s of {t_end:.6g} s: {kept}",
                          partial=res) from None
    if path is not None and not failed:
        print(f"wrote {len(table)} rows x {table.shape[1]} columns to {path} "
              f"(provenance in {path.name}.json); wall time {wall:.3g} s")
    elif path is None:
        print_summary(table, message, stats, events, wall, None if args.ideal else prov.get("wall"))
    if failed:
        where = (f"; the partial table ({len(table)} rows, up to t = {prov.get('t_reached', float('nan')):.6g} s) "
                 f"is in {path}, marked partial ({out} not replaced)" if path is not None else "")
        print_error(f"integration failed: {message}{where}")
        return 1
    return 0


def print_summary(table, message, stats, events, wall, integration_wall) -> None:
    import numpy as np
    import pandas as pd
    print(message)
    if stats:
        print("stats: " + ", ".join(f"{k} {v}" for k, v in stats.items()))
    print(f"rows: {len(table)}" + (f" (t = {table['t'].iloc[0]:.6g} .. {table['t'].iloc[-1]:.6g} s)"
                                   if len(table) else ""))
    if len(table):
        fn_cols = [c for c in table.columns if c.endswith(".Fn")]
        for c in fn_cols:
            print(f"max |{c}|: {np.nanmax(np.abs(table[c].to_numpy())):.6g} N")
        if not fn_cols:     # ideal twin: joint reaction magnitudes
            for c in table.columns:
                if c.endswith(".Fx") and c[:-3] + ".Fy" in table.columns:
                    f = np.hypot(table[c].to_numpy(), table[c[:-3] + ".Fy"].to_numpy())
                    print(f"max |{c[:-3]}.F|: {np.nanmax(f):.6g} N")
        if "driver.torque" in table.columns:
            print(f"max |driver.torque|: {np.nanmax(np.abs(table['driver.torque'].to_numpy())):.6g} N m")
    if events is not None and len(events):
        print(f"contact events: {len(events)}")
    extra = f" (integration {integration_wall:.3g} s)" if integration_wall is not None else ""
    print(f"wall time: {wall:.3g} s{extra}")
    if len(table):
        rows = table.iloc[[0, -1]] if len(table) > 1 else table.iloc[[0]]
        shown = pd.DataFrame(rows.to_numpy().T, index=table.columns,
                             columns=["first", "last"][: len(rows)])
        print(shown.to_string(float_format=lambda v: f"{v:.6g}"))
