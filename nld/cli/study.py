"""``nld study NAME``: run ``studies/NAME.py`` (its ``main(quick, out_dir)``) and print its PDF path."""
from __future__ import annotations

import importlib.util
import os
import sys
import time
from pathlib import Path

from nld.errors import InputError, Interrupted

STUDIES_ENV = "NLD_STUDIES_DIR"
# names that stand for one study although they are a prefix of several (the README's main job)
ALIASES = {"zhang2013": "zhang2013_excavator"}
DEFAULT_STUDY_OUT = "nld-out"


def add_parser(sub) -> None:
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
    if name in ALIASES and ALIASES[name] in names:
        return d / f"{ALIASES[name]}.py"
    matches = [n for n in names if n.startswith(name)]
    if len(matches) == 1:
        return d / f"{matches[0]}.py"
    if matches:
        raise InputError(f"ambiguous study name {name!r}: matches {', '.join(matches)}")
    raise InputError(f"unknown study {name!r}; available: {listing}")


def import_study(path: Path):
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
    from nld.output.report import source_date_epoch
    from nld.study import full_mode_outputs, staged_outputs
    source_date_epoch()                       # a malformed SOURCE_DATE_EPOCH: refused before the run
    d = studies_dir()
    path = find_study(args.name, d)
    out_dir = Path(args.out_dir if args.out_dir is not None else DEFAULT_STUDY_OUT).expanduser()
    if args.quick and same_dir(out_dir, committed_reports_dir(d)):
        raise InputError(f"--out = {str(args.out_dir)!r}: a --quick run must not overwrite the committed "
                         f"full-mode reports in {committed_reports_dir(d)}; use another directory "
                         f"(default ./{DEFAULT_STUDY_OUT}/)")
    module = import_study(path)
    run = getattr(module, "main", None)
    if not callable(run):
        raise InputError(f"study {path} has no function main(quick: bool, out_dir: Path) -> Path")
    stem = str(getattr(module, "STEM", path.stem))
    if args.quick:
        full = full_mode_outputs(out_dir, stem)
        if full:
            raise InputError(f"--out = {str(out_dir)!r}: holds the full-mode outputs of study {stem} "
                             f"({full[0].name}: full mode in its provenance); a --quick run must not "
                             f"overwrite them: use another directory (default ./{DEFAULT_STUDY_OUT}/)")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        why = "a file of that name is in the way" if isinstance(e, (FileExistsError, NotADirectoryError)) \
            else (e.strerror or e)
        raise InputError(f"--out {str(out_dir)!r}: cannot create it ({why})") from None
    from nld.output.report import study_started
    start = time.perf_counter()
    study_started(start)
    progress.reset_stage()
    if progress.progress_enabled():
        progress.write(f"study {path.stem}: {'quick' if args.quick else 'full'} mode, writing to "
                       f"{out_dir}", file=sys.stderr)
    staged = None
    try:
        with staged_outputs(out_dir, stem, getattr(args, "command_line", None)) as staged:
            pdf = run(quick=bool(args.quick), out_dir=out_dir)
    except KeyboardInterrupt:
        stage = progress.last_stage()
        where = f" during '{stage}'" if stage else ""
        keeps = getattr(module, "INTERRUPT_KEEPS", None) or (
            "nothing kept: the report and its data are written only at the end (no partial PDF); "
            "run the study again")
        if staged is not None and staged.partial is not None:
            keeps += (f"; the outputs it had written are in {staged.partial} (partial), those in "
                      f"{out_dir} are unchanged")
        raise Interrupted(f"study {path.stem} interrupted",
                          kept=f"study {path.stem} stopped after {time.perf_counter() - start:.3g} s"
                               f"{where}: {keeps}") from None
    except Exception:
        if staged is not None and staged.partial is not None:
            print(f"nld: study {path.stem} did not finish: the outputs it had written are in "
                  f"{staged.partial} (partial); those in {out_dir} are unchanged", file=sys.stderr)
        raise
    finally:
        study_started(None)
    wall = time.perf_counter() - start
    print(pdf)
    print(f"study {path.stem} done in {wall:.3g} s", file=sys.stderr)
    return 0


def same_dir(a: Path, b: Path) -> bool:
    try:
        return a.expanduser().resolve() == b.expanduser().resolve()
    except OSError:
        return False
