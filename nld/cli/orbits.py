"""``nld orbits``: periodic orbits of a scene's stroboscopic map (one crank revolution), with their
Floquet multipliers; ``nld continue``: an orbit followed in one scene parameter, bifurcations named
(nld.analysis.orbits, nld.analysis.continuation; docs/orbits.md)."""
from __future__ import annotations

import json
import math

import numpy as np

from nld.cli.args import count_arg, number_arg, rtol_arg, scene_args, values_of, json_plain
from nld.errors import InputError, Interrupted
from nld.settings import LYAPUNOV

DEFAULT_TRANSIENT = 10


def add_parser(sub):
    """``nld orbits`` and ``nld continue``."""
    sp = sub.add_parser(
        "orbits", help="periodic orbits of a scene and their Floquet multipliers",
        description="Periodic orbits of the scene's stroboscopic map (one crank revolution): "
                    "Newton shooting with the monodromy matrix (tangent integration with "
                    "saltation at every contact event) from the state after a transient; with "
                    "--max-period, every distinct orbit of periods 1..P found from close returns "
                    "of the section. Where Newton from the transient does not converge, --period "
                    "searches the section's close returns for an orbit of that prime period. "
                    "Prints each orbit's section point, residual, Floquet "
                    "multipliers (with their uncertainty from a second evaluation at 10 rtol), "
                    "stability (stable / unstable / neutral: within its uncertainty of |mu| = 1; "
                    "decided by the multipliers other than the contact memory's neutral one, "
                    "which is named), contact onsets per period and the smallest approach speed "
                    "at an onset (distance to grazing). Exit 1 when no orbit converged.")
    scene_args(sp)
    sp.add_argument("--period", type=count_arg("--period", 1), default=1, metavar="P",
                    help="the orbit's period in revolutions (default 1)")
    sp.add_argument("--max-period", type=count_arg("--max-period", 1), default=None, metavar="P",
                    help="search every orbit of periods 1..P instead (unstable ones included)")
    sp.add_argument("--transient", type=count_arg("--transient", 0), default=DEFAULT_TRANSIENT,
                    metavar="REVS", help=f"revolutions from the assembly to the first guess "
                                         f"(default {DEFAULT_TRANSIENT})")
    sp.add_argument("--rtol", type=rtol_arg, default=LYAPUNOV.rtol, metavar="R",
                    help=f"relative tolerance of the integrations (default {LYAPUNOV.rtol:g})")
    sp.add_argument("--json", action="store_true", help="print the result as JSON")
    sp.set_defaults(func=cmd_orbits)

    sc = sub.add_parser(
        "continue", help="follow a periodic orbit in one parameter, bifurcations named",
        description="Continuation of a periodic orbit in one scene parameter: the orbit at the "
                    "first of --values (found after --transient revolutions there), followed by "
                    "pseudo-arclength over the whole range of --values (default: adaptive step, "
                    "through folds and contact changes, both directions from the start), or "
                    "with --natural at exactly the values given. Multipliers along the branch; "
                    "period doublings, folds, Neimark-Sacker and grazing (a contact appearing or "
                    "lost) located; each end of the branch with its reason. Writes "
                    "DIR/branch.parquet and DIR/bifurcations.parquet (provenance in their JSON "
                    "sidecars) with --out; draws the branch with --plot. With --follow KIND "
                    "--param2 KEY2 --values2 A:B:N, the first located bifurcation of KIND is "
                    "followed in KEY2 (its curve in DIR/curve.parquet and "
                    "DIR/curve_special_points.parquet; --plot draws the curve in the (KEY, KEY2) "
                    "plane; docs/codim2.md). Every option is checked "
                    "before the first integration (docs/continuation.md).")
    scene_args(sc)
    sc.add_argument("--param", required=True, metavar="KEY",
                    help="the scene key to vary, e.g. joints.B.clearance or driver.speed")
    sc.add_argument("--values", required=True, type=values_of("--values"), metavar="A:B:N",
                    help="values of KEY: START:STOP:NUM (ends included) or V1,V2,... ; the start "
                         "orbit is found at the first, the branch followed to the last (the "
                         "scene's own value need not be among them)")
    sc.add_argument("--period", type=count_arg("--period", 1), default=1, metavar="P",
                    help="the orbit's period in revolutions (default 1)")
    sc.add_argument("--transient", type=count_arg("--transient", 0), default=DEFAULT_TRANSIENT,
                    metavar="REVS", help=f"revolutions to the start orbit's guess "
                                         f"(default {DEFAULT_TRANSIENT})")
    how = sc.add_mutually_exclusive_group()
    how.add_argument("--arclength", action="store_true",
                     help="pseudo-arclength continuation (the default: passes folds; adaptive "
                          "step, first step the mean spacing of --values)")
    how.add_argument("--natural", action="store_true",
                     help="natural continuation at exactly the values given (stops at a fold)")
    sc.add_argument("--rtol", type=rtol_arg, default=LYAPUNOV.rtol, metavar="R",
                    help=f"relative tolerance (default {LYAPUNOV.rtol:g})")
    sc.add_argument("--out", metavar="DIR", help="write branch.parquet and bifurcations.parquet "
                                                 "(and curve.parquet, curve_special_points.parquet "
                                                 "with --follow)")
    sc.add_argument("--plot", metavar="FILE", help="draw the branch (.png, .pdf or .svg)")
    sc.add_argument("--observable", default=None, metavar="COL",
                    help="table column drawn by --plot (default: <first clearance joint>.ex)")
    from nld.cli import codim2
    codim2.add_args(sc)              # --follow KIND --param2 KEY2 --values2 A:B:N (issue 41)
    sc.set_defaults(func=cmd_continue)
    return sp


def _orbit_line(o, scale_names) -> str:
    mu = ", ".join(f"{m.real:.6g}{m.imag:+.3g}j" if abs(m.imag) > 0 else f"{m.real:.6g}"
                   for m in o.multipliers)
    appr = ("no onset" if not math.isfinite(o.min_approach_speed)
            else f"min approach {o.min_approach_speed:.4g} m/s")
    extra = " (history-dependent: the memory value is the history's)" if o.continuum else ""
    u = o.multiplier_uncertainty
    dec = o.deciding_multipliers
    amax = float(np.max(np.abs(dec))) if dec.size else math.nan
    return (f"period {o.period}: {o.stability_text}, "
            f"{'max |mu| of the others' if o.continuum else 'max |mu|'} {amax:.6g} ± "
            f"{u if math.isfinite(u) else 0:.2g}; "
            f"{o.onsets_per_period} onsets per period, {appr}; residual {o.residual:.2g} "
            f"(tolerance {o.tolerance:.2g}){extra}\n    multipliers: {mu}\n    point: "
            + ", ".join(f"{n} = {x:.9g}" for n, x in zip(scale_names, o.points[0])))


def cmd_orbits(args) -> int:
    from nld.analysis.orbits import find_orbits, periodic_orbit
    from nld.run.simulate import provenance
    from nld.systems.core import SceneSystem
    system = SceneSystem(args.scene, args.overrides)
    if system.period is None:
        raise InputError(f"scene {system.name!r} has no crank speed: orbits are found on the "
                         "stroboscopic map of a driven crank")
    prog = _newton_progress(args)
    check_sizes(args, system)
    if args.max_period is not None:
        orbits = find_orbits(system, args.max_period, transient=args.transient, rtol=args.rtol,
                             progress=_search_progress(args))
    else:
        orbits = [_orbit_or_search(system, args, prog)]
    settings = {"period": args.period, "max_period": args.max_period,
                "transient_revs": args.transient, "rtol": args.rtol,
                "tolerance": orbits[0].tolerance if orbits else 1e3 * args.rtol,
                "shooting": "multiple for period >= 2", "overrides": list(args.overrides)}
    prov = provenance(system.scene, system.kernel, rtol=args.rtol,
                      command=getattr(args, "command_line", None))
    ok = [o for o in orbits if o.converged]
    if args.json:
        out = {"orbits": [o.to_dict() for o in orbits], "settings": settings,
               "provenance": {k: v for k, v in prov.items() if k != "scene_parameters"}}
        print(json.dumps(out, indent=2, default=json_plain))
    else:
        print(f"{system.name}: {len(ok)} converged orbit{'s' if len(ok) != 1 else ''} "
              f"(rtol {args.rtol:g}; section at t = 0 mod {system.period:.6g} s)")
        for o in orbits:
            print(("  " if o.converged else "  NOT CONVERGED: ") + _orbit_line(o, o.state_names))
            if not o.converged:
                print(f"    {o.message}")
    if not ok:
        from nld.cli.args import print_error
        print_error("no periodic orbit converged" + (f": {orbits[0].message}" if orbits else ""))
        return 1
    return 0




def check_sizes(args, system) -> None:
    """--period / --max-period refused before any integration when the shooting would not fit
    (nld.analysis.orbits.MAX_SHOOTING_UNKNOWNS) or, for --max-period, when the section it seeds
    from is too short (find_orbits' close returns), each with the largest value that fits."""
    from nld.analysis.orbits import check_size, default_points
    from nld.systems.derived import as_map
    m = as_map(system, args.rtol)
    if args.max_period is not None:
        n = default_points(m)
        if args.max_period >= n:
            raise InputError(f"--max-period = {args.max_period}: the section it seeds from has "
                             f"{n} points and close returns of period p need more than p: at "
                             f"most {n - 1}")
        check_size(args.max_period, m.n, "--max-period")
    else:
        check_size(args.period, m.n, "--period")


def _orbit_or_search(system, args, prog):
    """Newton from the state after --transient revolutions; where it does not converge (a far
    guess: an unstable orbit inside a chaotic motion), the close returns of the section for an
    orbit of prime period --period (find_orbits, the search ``nld control`` makes for its target).
    The orbit, or the first Newton's unconverged one with both failures in its message."""
    import sys
    from dataclasses import replace
    from nld.analysis.orbits import find_orbits, periodic_orbit
    from nld.errors import SolveError
    try:
        o = periodic_orbit(system, args.period, transient=args.transient, rtol=args.rtol,
                           progress=prog)
        if o.converged:
            return o
        first, why = o, o.message
    except SolveError as e:          # the guess itself cannot be integrated
        first, why = None, str(e)
    if prog is not None:
        print(f"  Newton from the transient did not converge ({why}); searching the section's "
              f"close returns", file=sys.stderr, flush=True)
    found = find_orbits(system, args.period, min_period=args.period, transient=args.transient,
                        rtol=args.rtol, progress=_search_progress(args))
    if found:
        o = found[-1]                   # the least unstable
        return replace(o, message=f"{o.message} from a close return of the section (Newton from "
                                  f"the transient: {why})")
    if first is None:
        raise SolveError(f"no period-{args.period} orbit: Newton from the transient: {why}; close "
                         f"returns of the section: none converged")
    return replace(first, message=f"{why}; close returns of the section: none converged")


def _newton_progress(args):
    if getattr(args, "progress", None) is False:
        return None
    import sys

    def prog(it, res):
        if sys.stderr.isatty() or getattr(args, "progress", None):
            print(f"  Newton step {it}: residual {res:.3g}", file=sys.stderr, flush=True)
    return prog


def _search_progress(args):
    """One stderr line per period searched and every 5th seed (a terminal, or --progress)."""
    import sys
    if getattr(args, "progress", None) is False:
        return None
    shown = sys.stderr.isatty() or getattr(args, "progress", None)

    def prog(period, k, n):
        if shown and (k == 0 or (k + 1) % 5 == 0 or k + 1 == n):
            print(f"  period {period}: seed {k + 1} of {n}", file=sys.stderr, flush=True)
    return prog


def _check_out_dir(path, option: str = "--out"):
    """The output directory, checked before any work: not a file, creatable, writable."""
    import os
    from pathlib import Path
    p = Path(path).expanduser()
    if p.exists() and not p.is_dir():
        raise InputError(f"{option} = {str(path)!r}: is a file; give a directory (branch.parquet "
                         f"and bifurcations.parquet are written into it)")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        why = "a file is in the way" if isinstance(e, (FileExistsError, NotADirectoryError)) \
            else (e.strerror or str(e))
        raise InputError(f"{option} = {str(path)!r}: cannot create the directory ({why})") from None
    if not os.access(p, os.W_OK):
        raise InputError(f"{option} = {str(path)!r}: the directory is not writable")
    return p


def cmd_continue(args) -> int:
    from nld.analysis.continuation import Family, check_values, continue_orbit
    from nld.analysis.orbits import periodic_orbit
    from nld.output.io import check_figure_path, save_table
    from nld.run.simulate import provenance
    from nld.systems.core import SceneSystem
    values = np.array(args.values, dtype=float)
    # every option before the first integration: the figure and output paths, the key, every value
    # (the parameter's domain) and the scene's structure at the values' ends
    plot = check_figure_path(args.plot) if args.plot else None
    out = _check_out_dir(args.out) if args.out else None
    base = SceneSystem(args.scene, args.overrides)
    if base.period is None:
        raise InputError(f"scene {base.name!r} has no crank speed: orbits are found on the "
                         "stroboscopic map of a driven crank")
    fam = Family(base, args.param)               # checks the key
    check_values(values, values[0], "--values")
    for v in values:
        fam.check(v, "--values:")
    system = fam.at(values[0])                   # the start: the first value asked for
    fam.at(values[-1])                           # the same structure at the other end
    from nld.cli import codim2
    fam2 = codim2.check(args, base, fam)         # --follow's options (None without it)
    if plot is not None and args.observable is not None:
        _observable_check(system, args.observable)
    natural = bool(args.natural)
    o = periodic_orbit(system, args.period, transient=args.transient, rtol=args.rtol)
    if not o.converged:
        raise InputError(f"no period-{args.period} orbit at {args.param} = {values[0]:g} to start "
                         f"from ({o.message}); try another --transient or --period, or start "
                         f"--values elsewhere")
    done = []
    prov = provenance(system.scene, system.kernel, rtol=args.rtol, param=args.param,
                      values=values.tolist(), period=args.period, transient_revs=args.transient,
                      method="natural" if natural else "arclength", start_value=float(values[0]),
                      command=getattr(args, "command_line", None))
    prov.pop("scene_parameters", None)
    from nld.progress import progress_bar
    span = abs(values[-1] - values[0])
    step = span / (len(values) - 1)
    max_points = max(200, 4 * len(values))
    with progress_bar(total=len(values), desc="continuation", unit="point",
                      enabled=args.progress) as pb:
        def on_point(v, orb):
            done.append((v, orb))
            pb.update(1)
        try:
            if natural:
                br = continue_orbit(system, o, args.param, values, method="natural",
                                    on_point=on_point)
            else:
                br = continue_orbit(system, o, args.param, range=(values[0], values[-1]),
                                    step=step, max_points=max_points, on_point=on_point)
        except KeyboardInterrupt:
            kept = f"{len(done)} branch points computed"
            if out is not None and done:
                from nld.analysis.continuation import Branch
                part = Branch(args.param, o.period, [v for v, _ in done], [b for _, b in done], [],
                              "interrupted")
                path = save_table(part.table(), out / "branch.parquet", prov, partial=True)
                kept += f"; written to {path}, marked partial"
            raise Interrupted("interrupted", kept=kept) from None
    tab = br.table()
    bifs = br.bifurcation_table()
    prov["ends"] = [e.to_dict() for e in br.ends]
    prov["completed"] = br.completed
    print(f"{system.name}: period-{o.period} branch in {args.param}, {len(br.values)} points "
          f"({min(br.values):g} ... {max(br.values):g}); {br.message}")
    for e in br.ends:
        way = "larger" if e.direction > 0 else "smaller"
        print(f"  end towards {way} values: {e.reason} at {e.value:g} ({e.detail})")
    for b in br.bifurcations:
        print(f"  {b.detail}")
    if not br.bifurcations:
        print("  no bifurcation on the branch")
    cols = ["value", "stable", "max_abs_deciding", "multiplier_uncertainty",
            "onsets_per_period", "min_approach_speed"]
    print(tab[cols].to_string(index=False, float_format=lambda v: f"{v:.6g}"))
    if out is not None:
        p1 = save_table(tab, out / "branch.parquet", prov)
        p2 = save_table(bifs, out / "bifurcations.parquet", prov)
        print(f"wrote {p1} and {p2}")
    if fam2 is not None:                         # the curve, drawn by --plot instead
        return codim2.follow(args, system, br, out, plot, prov)
    if plot is not None:
        from nld.output.io import save_figure
        from nld.analysis.continuation import branch_curves
        from nld.output.plots import branch_diagram
        obs = args.observable or _default_observable(system)
        fig = branch_diagram(branch_curves([br], system, obs), obs, args.param)
        print(f"wrote {save_figure(fig, plot)}")
    return 0


def _default_observable(system) -> str:
    from nld.analysis.poincare import default_observables
    return default_observables(system.kernel)[0]


def _observable_check(system, name):
    cols = list(system.kernel.columns)
    if name not in cols:
        raise InputError(f"--observable {name!r}: no such column; available: {', '.join(cols)}")
