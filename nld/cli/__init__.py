"""Command line of nld.

    nld scenes                                   built-in scenes, one per line
    nld show SCENE [--set KEY=VALUE ...]         resolved parameters with units
    nld simulate SCENE [--set ...] [--revs N | --t-end T] [--rtol R] [--samples-per-rev N]
                 [--ideal] [--out FILE.csv|FILE.parquet]
    nld poincare SCENE [--set ...] --transient N --revs M [--observables A,B] --out FILE
    nld bifurcation SCENE --param KEY --values START:STOP:COUNT [...] --out DIR [--resume] [--dask ADDR]
    nld spectrum SCENE [--set ...] [--observable NAME] [--out FILE]
    nld lyapunov SCENE [--set ...] [--transient N] [--revs M] [--json]
    nld chaos-map SCENE --x KEY --x-values A:B:N --y KEY --y-values A:B:N --out DIR [--resume]
    nld hard-cases [--quick] [--list] [NAME ...]  the integrators' hard regression cases
    nld study NAME [--quick] [--out-dir DIR]     run studies/NAME.py, print the PDF path
    nld --version

Exit status: 0 success, 1 failed integration or solve (the message on stderr; what was computed
is still written), 2 bad input (one line ``nld: error: <message>`` on stderr, no traceback),
130 interrupted by Ctrl-C (SIGINT; one line ``nld: interrupted: <what was kept>``: a simulate
writes its partial table to --out, a sweep, chaos map or study keeps its finished points and
resumes), 141 when the reader of stdout went away (``nld scenes | head -1``: no message, as
``yes | head -1``; 128 + SIGPIPE, the status of a program killed by SIGPIPE).
``main(argv)`` returns the status instead of exiting, for tests.

Every command takes ``--quiet`` (no progress bars) and ``--progress`` (progress bars on stderr
even when it is not a terminal); by default long work shows a bar only on a terminal
(``nld.progress``).
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import os
import re
import shlex
import sys
import time
from pathlib import Path

from nld.version import __version__
from nld.errors import InputError, Interrupted, SceneError, SolveError

PROG = "nld"
STUDIES_ENV = "NLD_STUDIES_DIR"
DEFAULT_STUDY_OUT = "nld-out"


class _UsageError(Exception):
    """An argparse error, turned into the one-line message of :func:`main`."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):       # one line instead of usage + message, see main()
        message = _one_line(message)
        m = re.match(r"argument (\S+): (\1 = .*)", message)    # our type checks name the option
        if m:
            message = m.group(2)
        cmd = self.prog.split(" ", 1)[1] if " " in self.prog else ""
        hint = f" (see '{PROG}{' ' + cmd if cmd else ''} --help')"
        raise _UsageError(message + hint)


def _one_line(text) -> str:
    return " ".join(str(text).split())


def _err(message) -> None:
    print(f"{PROG}: error: {_one_line(message)}", file=sys.stderr)


# ---------------------------------------------------------------------------------------------------
# argument parser


def _number_arg(name: str, *, positive: bool = True):
    """argparse type: a finite float (> 0 if ``positive``); the message names the option."""
    def conv(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} = {text!r}: not a number") from None
        if not math.isfinite(v):
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be a finite number")
        if positive and not v > 0:
            raise argparse.ArgumentTypeError(f"{name} = {text}: must be > 0")
        return v
    conv.__name__ = name
    return conv


def _rtol_arg(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--rtol = {text!r}: not a number") from None
    if not (math.isfinite(v) and 1e-14 <= v < 1):
        raise argparse.ArgumentTypeError(f"--rtol = {text}: must be a number in [1e-14, 1)")
    return v


def _samples_arg(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--samples-per-rev = {text!r}: not an integer") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"--samples-per-rev = {text}: must be >= 1")
    return v


def build_parser() -> argparse.ArgumentParser:
    from nld.run.simulate import DEFAULT_RTOL, DEFAULT_SAMPLES_PER_REV
    p = _Parser(prog=PROG, description="Nonlinear dynamics of planar mechanisms with clearance joints.")
    p.add_argument("--version", action="version", version=f"{PROG} {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    sub.required = True

    sp = sub.add_parser("scenes", help="list the built-in scenes", description="List the built-in scenes.")
    sp.set_defaults(func=cmd_scenes)

    def scene_args(sp):
        sp.add_argument("scene", metavar="SCENE", help="built-in scene name or path of a .toml file")
        sp.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="override a scene value, e.g. joints.B.clearance=2e-4 (repeatable)")

    sp = sub.add_parser("show", help="print the resolved scene parameters with units",
                        description="Print the resolved scene parameters with units.")
    scene_args(sp)
    sp.set_defaults(func=cmd_show)

    sp = sub.add_parser("simulate", help="simulate a scene",
                        description="Simulate a scene (adaptive Dormand-Prince 5(4)); with --ideal, "
                                    "evaluate its ideal-joint twin at the same output times instead.")
    scene_args(sp)
    g = sp.add_mutually_exclusive_group()
    g.add_argument("--revs", type=_number_arg("--revs"), metavar="N",
                   help="crank revolutions to simulate (default 1)")
    g.add_argument("--t-end", type=_number_arg("--t-end"), metavar="T", help="end time (s)")
    sp.add_argument("--rtol", type=_rtol_arg, default=None, metavar="R",
                    help=f"relative tolerance (default: the scene's recommended rtol, else {DEFAULT_RTOL:g})")
    sp.add_argument("--samples-per-rev", type=_samples_arg, default=DEFAULT_SAMPLES_PER_REV, metavar="N",
                    help=f"output samples per crank revolution (default {DEFAULT_SAMPLES_PER_REV})")
    sp.add_argument("--ideal", action="store_true",
                    help="ideal-joint reference solution (nld.model.ideal) at the same output times")
    sp.add_argument("--out", metavar="FILE", help="write the table to FILE.csv or FILE.parquet "
                                                 "(provenance in FILE.json / parquet metadata)")
    sp.set_defaults(func=cmd_simulate)

    from nld.analysis import bifurcation
    from nld.analysis import chaos_map
    from nld.analysis import poincare
    from nld.analysis import spectrum
    poincare.add_arguments(sub)
    bifurcation.add_arguments(sub)
    spectrum.add_arguments(sub)
    chaos_map.add_arguments(sub)

    sp = sub.add_parser("lyapunov", help="Lyapunov exponents of a scene (tangent dynamics)",
                        description="Largest Lyapunov exponent (or the first K with --k) from the "
                                    "tangent dynamics with saltation at every contact event "
                                    "(nld.analysis.lyapunov.lyapunov_tangent), in 1/s and per crank "
                                    "revolution, with its uncertainty (about 95 %%) and the settings "
                                    "that produced it. --estimator benettin uses the two-trajectory "
                                    "method instead; --check computes both and says whether they agree.")
    sp.add_argument("scene", metavar="SCENE", help="built-in scene name or path to a TOML file")
    sp.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="override a scene value (repeatable)")
    sp.add_argument("--transient", type=float, default=20.0, metavar="REVS",
                    help="transient in crank revolutions (default 20)")
    sp.add_argument("--revs", type=float, default=200.0, metavar="REVS",
                    help="averaging length in crank revolutions (default 200; the minimum with "
                         "--target-uncertainty)")
    sp.add_argument("--rtol", type=float, default=1e-10, help="relative tolerance (default 1e-10)")
    sp.add_argument("--estimator", choices=("tangent", "benettin"), default="tangent",
                    help="tangent dynamics with saltation (default) or two trajectories (Benettin)")
    sp.add_argument("--k", type=int, default=1, metavar="K",
                    help="number of exponents (tangent estimator; default 1)")
    sp.add_argument("--renorm", type=float, default=None, metavar="REVS",
                    help="re-orthonormalisation interval in revolutions (default 1/8 for the "
                         "tangent estimator, 1 with 32 checks for Benettin)")
    sp.add_argument("--target-uncertainty", type=float, default=None, metavar="REL",
                    help="average until the relative uncertainty of lambda1 is REL (e.g. 0.05) or "
                         "--max-revs is reached, and say which")
    sp.add_argument("--max-revs", type=float, default=None, metavar="REVS",
                    help="limit of the averaging with --target-uncertainty (default 10 x --revs)")
    sp.add_argument("--check", action="store_true",
                    help="also compute lambda1 with the other estimator and report the agreement")
    sp.add_argument("--state-error-only", action="store_true",
                    help="tangent estimator: only the state takes part in the step-size control "
                         "(about half the CPU time; same exponents on every case of "
                         "benchmarks/results/lyapunov.md)")
    sp.add_argument("--d0", type=float, default=1e-4,
                    help="initial separation of the Benettin estimator, scaled norm (default 1e-4)")
    sp.add_argument("--seed", type=int, default=0, help="seed of the initial perturbation (default 0)")
    sp.add_argument("--method", choices=("dopri5", "dop853", "rodas"), default="dopri5",
                    help="integrator of the Benettin trajectories (default dopri5; the tangent "
                         "estimator always uses its DOPRI5; rodas is experimental)")
    sp.add_argument("--spectrum", type=int, default=0, metavar="K",
                    help="also the first K exponents by the perturbation-vector method")
    sp.add_argument("--json", action="store_true", help="print the result as JSON")
    sp.set_defaults(func=cmd_lyapunov)

    sp = sub.add_parser("hard-cases", help="run the named hard regression cases of the integrators",
                        description="Run the hard cases (nld.run.hard_cases: very stiff contact, tiny and "
                                    "large clearances, friction reversal, grazing contact, 10^4 "
                                    "revolutions, 10 000 rpm) and print a report per case; exit "
                                    "status 1 when a case fails its check.")
    sp.add_argument("names", nargs="*", metavar="NAME", help="cases to run (default: all)")
    sp.add_argument("--quick", action="store_true", help="the short variant of the long cases")
    sp.add_argument("--list", action="store_true", help="list the cases and exit")
    sp.set_defaults(func=cmd_hard_cases)

    sp = sub.add_parser("study", help="run a study (studies/NAME.py) and print its PDF path",
                        description="Run studies/NAME.py (or the unique studies/NAME*.py) by calling its "
                                    f"main(quick, out_dir); the studies directory is ${STUDIES_ENV} "
                                    "if set, else studies/ in the repository root. The report and its "
                                    f"data go to ./{DEFAULT_STUDY_OUT}/ unless --out names another "
                                    "directory (--out reports/ for the committed full-mode reports; "
                                    "a --quick run is refused there).")
    sp.add_argument("name", metavar="NAME", help="study name, or a unique prefix of one")
    sp.add_argument("--quick", action="store_true", help="short variant (fewer runs, shorter runs)")
    sp.add_argument("--out", "--out-dir", dest="out_dir", metavar="DIR", type=Path, default=None,
                    help=f"output directory (default ./{DEFAULT_STUDY_OUT}/ in the current directory)")
    sp.set_defaults(func=cmd_study)
    for sp in sub.choices.values():
        _progress_args(sp)
    return p


def _progress_args(sp) -> None:
    g = sp.add_mutually_exclusive_group()
    g.add_argument("--quiet", "-q", dest="progress", action="store_const", const=False, default=None,
                   help="no progress bars")
    g.add_argument("--progress", dest="progress", action="store_const", const=True,
                   help="progress bars on stderr even when it is not a terminal")


# ---------------------------------------------------------------------------------------------------
# commands


def cmd_scenes(args) -> int:
    from nld.model.scene import builtin_scenes
    scenes = builtin_scenes()
    width = max((len(n) for n in scenes), default=0)
    for name, desc in scenes.items():
        print(f"{name:<{width}}  {desc}".rstrip())
    return 0


def cmd_show(args) -> int:
    from nld.model.scene import format_scene, load_scene
    scene = load_scene(args.scene, args.overrides)
    print(format_scene(scene))
    return 0


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
            raise InputError(f"--out {args.out!r}: cannot create its directory ({e.strerror or e})") from None
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
    if interrupted is not None:
        if out is not None:
            path = save_table(table, out, prov)
            kept = f"wrote the partial table ({interrupted.kept}) to {path}, marked partial in its provenance"
        else:
            kept = f"nothing written (no --out); {interrupted.kept} computed"
        _interrupted(f"simulate stopped at t = {res.t_reached:.6g} s of {t_end:.6g} s: {kept}")
        return 130
    if out is not None:
        path = save_table(table, out, prov)
        print(f"wrote {len(table)} rows x {table.shape[1]} columns to {path} "
              f"(provenance in {path.name}.json); wall time {wall:.3g} s")
    else:
        _print_summary(table, message, stats, events, wall, None if args.ideal else prov.get("wall"))
    if status < 0:
        _err(f"integration failed: {message}")
        return 1
    return 0


def _interrupted(what: str) -> None:
    print(f"{PROG}: interrupted: {_one_line(what)}", file=sys.stderr, flush=True)


def _print_summary(table, message, stats, events, wall, integration_wall) -> None:
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


# ----------------------------------------------------------------------------------- studies


def studies_dir() -> Path:
    """``$NLD_STUDIES_DIR`` if set, else ``studies/`` in the repository root (parent of ``nld/``)."""
    env = os.environ.get(STUDIES_ENV)
    if env:
        return Path(env).expanduser()
    return Path(__file__).resolve().parents[2] / "studies"


def available_studies(d: Path | None = None) -> list[str]:
    d = studies_dir() if d is None else d
    if not d.is_dir():
        return []
    return sorted(p.stem for p in d.glob("*.py") if not p.name.startswith(("_", ".")) and p.is_file())


def cmd_hard_cases(args) -> int:
    from nld.run.hard_cases import CASES, main as hard_main
    unknown = [n for n in args.names if n not in CASES]
    if unknown:
        raise InputError(f"hard case {unknown[0]!r}: choose from {', '.join(CASES)}")
    return hard_main((["--quick"] if args.quick else []) + (["--list"] if args.list else [])
                     + list(args.names))


def cmd_lyapunov(args) -> int:
    import json

    from nld.analysis.lyapunov import lyapunov_benettin, lyapunov_spectrum, lyapunov_tangent
    from nld.systems.core import SceneSystem
    from nld.run.simulate import provenance
    for name in ("transient", "revs", "rtol", "d0"):
        v = getattr(args, name)
        if not (math.isfinite(v) and v > 0):
            raise InputError(f"--{name.replace('_', '-')} = {v!r}: must be a positive number")
    if args.revs < 1:
        raise InputError(f"--revs = {args.revs!r}: must be at least 1 revolution")
    if args.renorm is not None and not (math.isfinite(args.renorm) and args.renorm > 0):
        raise InputError(f"--renorm = {args.renorm!r}: must be a positive number of revolutions")
    if args.estimator == "benettin" and args.state_error_only:
        raise InputError("--state-error-only: an option of the tangent estimator, not of benettin")
    if args.estimator == "benettin" and (args.k != 1 or args.target_uncertainty is not None):
        raise InputError("--estimator benettin: gives lambda1 only, without --k or "
                         "--target-uncertainty (use the tangent estimator)")
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
                               progress=args.progress, check=args.check and args.k == 1,
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
                               **_progress_kw(lyapunov_spectrum, args.progress))
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
    if out.get("check"):
        c = out["check"]
        print(f"check: tangent {c['tangent'] * T:.4g} +- {c['tangent_uncertainty'] * T:.2g}, "
              f"benettin {c['benettin'] * T:.4g} +- {c['benettin_uncertainty'] * T:.2g} per "
              f"revolution: {'agree' if c['agree'] else 'DISAGREE'} within their uncertainties")
    if args.spectrum > 0:
        print("spectrum (1/s): " + ", ".join(f"{x:.4g} +- {u:.2g}" for x, u in
                                            zip(out["spectrum_per_s"], out["spectrum_uncertainty_per_s"])))
    return 0


def _progress_kw(func, progress) -> dict:
    """``{"progress": progress}`` when ``func`` takes a ``progress`` argument (the Lyapunov
    estimators gain one in issue 13; until then the command runs without a bar), else {}."""
    import inspect
    try:
        params = inspect.signature(func).parameters
    except (TypeError, ValueError):
        return {}
    if "progress" in params or any(p.kind is p.VAR_KEYWORD for p in params.values()):
        return {"progress": progress}
    return {}


def find_study(name: str, d: Path | None = None) -> Path:
    """``d/NAME.py``, or the unique ``d/NAME*.py``, or a path to a ``.py`` file; else InputError."""
    d = studies_dir() if d is None else d
    given = Path(name).expanduser()
    if given.suffix == ".py" and given.is_file():
        return given
    names = available_studies(d)
    listing = ", ".join(names) if names else f"(none in {d})"
    if not name or "/" in name or "\\" in name or name.startswith((".", "_")):
        raise InputError(f"unknown study {name!r}; available: {listing}")
    exact = d / f"{name}.py"
    if exact.is_file():
        return exact
    matches = [n for n in names if n.startswith(name)]
    if len(matches) == 1:
        return d / f"{matches[0]}.py"
    if matches:
        raise InputError(f"ambiguous study name {name!r}: matches {', '.join(matches)}")
    raise InputError(f"unknown study {name!r}; available: {listing}")


def _import_study(path: Path):
    folder = str(path.resolve().parent)
    if folder not in sys.path:           # studies may import helper modules next to them
        sys.path.insert(0, folder)
    mod_name = f"nld_study_{path.stem}"
    spec = importlib.util.spec_from_file_location(mod_name, path)
    if spec is None or spec.loader is None:
        raise InputError(f"cannot import study {path}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(mod_name, None)
        raise
    return module


def committed_reports_dir(d: Path | None = None) -> Path:
    """reports/ next to the studies directory: where the committed full-mode reports live."""
    d = studies_dir() if d is None else d
    return d.resolve().parent / "reports"


def cmd_study(args) -> int:
    from nld import progress
    d = studies_dir()
    path = find_study(args.name, d)
    out_dir = Path(args.out_dir if args.out_dir is not None else DEFAULT_STUDY_OUT).expanduser()
    if args.quick and _same_dir(out_dir, committed_reports_dir(d)):
        raise InputError(f"--out = {str(args.out_dir)!r}: a --quick run must not overwrite the committed "
                         f"full-mode reports in {committed_reports_dir(d)}; use another directory "
                         f"(default ./{DEFAULT_STUDY_OUT}/)")
    module = _import_study(path)
    run = getattr(module, "main", None)
    if not callable(run):
        raise InputError(f"study {path} has no function main(quick: bool, out_dir: Path) -> Path")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InputError(f"--out {str(out_dir)!r}: cannot create it ({e.strerror or e})") from None
    from nld.output.report import study_started
    start = time.perf_counter()
    study_started(start)
    progress.reset_stage()
    if progress.progress_enabled():
        progress.write(f"study {path.stem}: {'quick' if args.quick else 'full'} mode, writing to "
                       f"{out_dir}", file=sys.stderr)
    try:
        pdf = run(quick=bool(args.quick), out_dir=out_dir)
    except KeyboardInterrupt as e:
        stage = progress.last_stage()
        where = f" during '{stage}'" if stage else ""
        keeps = getattr(module, "INTERRUPT_KEEPS", None) or (
            "nothing kept: the report and its data are written only at the end (no partial PDF); "
            "run the study again")
        raise Interrupted(f"study {path.stem} interrupted",
                          kept=f"study {path.stem} stopped after {time.perf_counter() - start:.3g} s"
                               f"{where}: {keeps}") from None
    finally:
        study_started(None)
    wall = time.perf_counter() - start
    print(pdf)
    print(f"study {path.stem} done in {wall:.3g} s", file=sys.stderr)
    return 0


def _same_dir(a: Path, b: Path) -> bool:
    try:
        return a.expanduser().resolve() == b.expanduser().resolve()
    except OSError:
        return False


# ---------------------------------------------------------------------------------------------------
# entry point


def main(argv=None) -> int:
    """Run the command line ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    from nld import interrupt
    from nld import progress
    argv = list(sys.argv[1:] if argv is None else argv)
    interrupt.install()
    try:
        try:
            args = build_parser().parse_args(_values_with_minus(argv))
        except SystemExit as e:          # --help, --version
            return e.code if isinstance(e.code, int) else (0 if e.code is None else 2)
        args.command_line = shlex.join([PROG] + [str(a) for a in argv])
        progress.set_default(getattr(args, "progress", None))
        try:
            return int(args.func(args))
        finally:
            progress.set_default(None)
            sys.stdout.flush()
    except _UsageError as e:
        _err(e)
        return 2
    except (SceneError, InputError) as e:
        _err(e)
        return 2
    except SolveError as e:
        _err(e)
        return 1
    except Interrupted as e:
        _interrupted(e.kept or str(e) or "nothing kept")
        return 130
    except KeyboardInterrupt:
        _interrupted("nothing kept (the command had not finished a result yet)")
        return 130
    except BrokenPipeError:               # e.g. `nld scenes | head -1`
        _quiet_stdout()
        return 141
    except MemoryError:
        _err("out of memory: the run is too large for this machine (fewer revolutions or samples)")
        return 2


def _quiet_stdout() -> None:
    """After EPIPE: point stdout at /dev/null so the interpreter's final flush stays silent."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        try:
            sys.stdout = open(os.devnull, "w")
        except OSError:
            pass


_NEG_VALUE_OPTS = ("--values", "--x-values", "--y-values", "--angle", "--set")


def _values_with_minus(argv: list[str]) -> list[str]:
    """``--values -1:-5:2`` -> ``--values=-1:-5:2``: argparse takes a value starting with '-'
    for an option unless it looks like a plain negative number."""
    out, i = [], 0
    while i < len(argv):
        a = argv[i]
        if a == "--":
            out.extend(argv[i:])
            break
        if a in _NEG_VALUE_OPTS and i + 1 < len(argv) and argv[i + 1].startswith("-") \
                and len(argv[i + 1]) > 1 and (argv[i + 1][1].isdigit() or argv[i + 1][1] == "."):
            out.append(f"{a}={argv[i + 1]}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


if __name__ == "__main__":
    sys.exit(main())
