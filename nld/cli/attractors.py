"""``nld attractors``: the attractor census of a scene (which motions coexist, their basin
fractions, λ1 and contact onsets), or with --param/--values the census across a parameter with
the attractors matched between neighbouring values (nld.analysis.attractors;
docs/attractors.md)."""
from __future__ import annotations

import json
import math
from pathlib import Path

from nld.cli.args import count_arg, number_arg, rtol_arg, scene_args, values_of, json_plain, pool_args
from nld.errors import InputError
from nld.settings import LYAPUNOV

def _defaults():
    from nld.analysis.attractors import DEFAULTS
    return DEFAULTS


def add_parser(sub):
    """``nld attractors``."""
    d = _defaults()
    sp = sub.add_parser(
        "attractors", help="which motions coexist: attractors, basin fractions, λ1",
        description="Attractor census: integrate the scene from --starts seeded starting states "
                    "(the assembled state with each journal placed across its clearance circle, "
                    "sampled rates and contact memories), classify each run's motion on its "
                    "stroboscopic section (periodic of period p, quasi-periodic, chaotic, "
                    "permanent contact, escaping; unsettled runs are counted, never classed), "
                    "group the runs by attractor and print one line per attractor: kind, basin "
                    "fraction with its Wilson 95 %% interval, λ1 per revolution ± its "
                    "uncertainty, contact onsets per revolution. With --param and --values: the "
                    "census at every value, attractors matched across values, one file per "
                    "value in --out (resumable), --plot draws the stacked basin fractions.")
    scene_args(sp)
    sp.add_argument("--starts", type=count_arg("--starts", 1), default=d["starts"], metavar="N",
                    help=f"starting states (default {d['starts']})")
    sp.add_argument("--transient", type=count_arg("--transient", 0), default=d["transient"],
                    metavar="REVS", help=f"revolutions discarded per run (default "
                                         f"{d['transient']})")
    sp.add_argument("--revs", type=count_arg("--revs", 16), default=d["record"], metavar="REVS",
                    help=f"revolutions recorded per run, and averaged by each λ1 (default "
                         f"{d['record']})")
    sp.add_argument("--seed", type=count_arg("--seed", 0), default=d["seed"], metavar="S",
                    help=f"seed of the starting states (default {d['seed']})")
    sp.add_argument("--rtol", type=rtol_arg, default=LYAPUNOV.rtol, metavar="R",
                    help=f"relative tolerance (default {LYAPUNOV.rtol:g})")
    sp.add_argument("--max-period", type=count_arg("--max-period", 1), default=d["max_period"],
                    metavar="P", help=f"longest period recognised (default {d['max_period']})")
    pool_args(sp)
    sp.add_argument("--json", action="store_true", help="print the result as JSON")
    sp.add_argument("--param", default=None, metavar="KEY",
                    help="sweep this scene key (with --values and --out)")
    sp.add_argument("--values", type=values_of("--values"), default=None,
                    metavar="A:B:N|V1,V2,...", help="values of --param (ends included)")
    sp.add_argument("--out", default=None, metavar="DIR",
                    help="the sweep's directory: one file per finished value + provenance.json")
    sp.add_argument("--resume", action="store_true", help="skip the values already in --out")
    sp.add_argument("--plot", default=None, metavar="FILE",
                    help="with --param: write the basin fractions and λ1 against the parameter "
                         "(.png, .pdf, .svg)")
    sp.set_defaults(func=cmd_attractors)
    return sp


def _settings(args) -> dict:
    return dict(starts=args.starts, seed=args.seed, transient=args.transient, record=args.revs,
                rtol=args.rtol, max_period=args.max_period)


def cmd_attractors(args) -> int:
    sweep = args.param is not None or args.values is not None
    if sweep:
        return _cmd_sweep(args)
    if args.out is not None or args.plot is not None or args.resume:
        raise InputError("--out/--plot/--resume: only with --param KEY --values A:B:N")
    from nld.analysis.attractors import census
    from nld.run.simulate import provenance
    from nld.systems.core import SceneSystem
    system = SceneSystem(args.scene, args.overrides)
    if system.period is None:
        raise InputError(f"scene {system.name!r} has no crank speed: the census samples the "
                         f"stroboscopic section of a driven crank")
    res = census(system, workers=args.workers, dask=args.dask, progress=args.progress,
                 **_settings(args))
    prov = provenance(system.scene, system.kernel, rtol=args.rtol,
                      command=getattr(args, "command_line", None))
    prov.pop("scene_parameters", None)
    if args.json:
        out = {"attractors": [_json_attractor(a) for a in res.attractors],
               "unsettled": res.unsettled, "failed": res.failed, "verdict": res.verdict,
               "settings": res.settings, "provenance": prov}
        print(json.dumps(out, indent=2, default=json_plain))
    else:
        print(str(res))
    return 0


def _json_attractor(a) -> dict:
    d = a.to_dict()
    keys = ("kind", "fraction", "fraction_interval", "lambda1_per_revolution",
            "lambda1_uncertainty", "onsets_per_period", "period", "count",
            "conditional_on_memory", "note", "verdict", "lambda1_check",
            "lambda1_check_uncertainty", "onsets_per_orbit", "multipliers", "multiplier_error",
            "orbit_residual", "orbit_points", "lambda1_tangent", "lambda1_tangent_uncertainty")
    return {k: d[k] for k in keys}




def _cmd_sweep(args) -> int:
    if args.param is None or args.values is None or args.out is None:
        raise InputError("--param, --values and --out go together (the census across a "
                         "parameter)")
    from nld.analysis.attractors import census_sweep
    from nld.output.io import check_figure_path, save_figure, save_table
    plot = check_figure_path(args.plot) if args.plot else None
    table, records = census_sweep(args.scene, args.param, args.values,
                                  overrides=args.overrides, out=args.out, resume=args.resume,
                                  workers=args.workers, dask=args.dask, progress=args.progress,
                                  provenance=_sweep_provenance(args),
                                  **_settings(args))
    out = Path(args.out)
    prov = dict(param=args.param, values=list(args.values), scene=args.scene,
                overrides=list(args.overrides), **_settings(args))
    save_table(table, out / "attractors.csv", prov)
    for v in sorted(set(table["value"])):
        g = table[table["value"] == v]
        parts = [(f"#{int(r.label)} " if r.label >= 0 else "") + f"{r.kind} {r.fraction:.2f}" + (
            f" (λ1 {r.lambda1:.3g} ± {r.lambda1_uncertainty:.2g})"
            if math.isfinite(r.lambda1) else "") for r in g.itertuples() if r.label >= -1]
        why = next((r.get("message") for r in records if r.get("value") == v and r.get("message")), "")
        print(f"{args.param} = {v:g}: " + ("; ".join(parts) if parts else
                                            f"failed: {why}" if why else "failed"))
    print(f"wrote {out / 'attractors.csv'} ({len(records)} values)")
    if plot is not None:
        from nld.output.plots import basin_fractions
        save_figure(basin_fractions(table, args.param), plot, dpi=150)
    return 0


def _sweep_provenance(args) -> dict:
    from nld.model.scene import resolve_scene
    from nld.run.simulate import provenance
    prov = provenance(resolve_scene(args.scene, args.overrides),
                      command=getattr(args, "command_line", None))
    prov.pop("scene_parameters", None)
    return prov
