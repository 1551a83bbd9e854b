"""``nld spectrum``: the largest peaks of the spectrum of a scene observable (or of a saved run)."""
from __future__ import annotations

from nld.analysis.spectrum import METHODS
from nld.cli.args import count_arg, number_arg, rtol_arg
from nld.errors import InputError
from nld.settings import SPECTRUM, SPECTRUM_SPANS


def add_parser(sub):
    """Add ``nld spectrum`` to the sub-commands of nld's parser; returns the sub-parser."""
    sp = sub.add_parser(
        "spectrum", help="frequency spectrum of a scene observable (default the contact force)",
        description="Simulate a scene (or read a run table with --table) and print the largest "
                    "peaks of the spectrum of an observable, in Hz and crank orders.")
    sp.add_argument("scene", metavar="SCENE", nargs="?", default=None,
                    help="built-in scene name or path of a .toml file (omit with --table)")
    sp.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                    help="override a scene value, e.g. joints.B.clearance=2e-4 (repeatable)")
    sp.add_argument("--table", metavar="FILE", default=None,
                    help="analyse a saved run (FILE.csv / FILE.parquet of nld simulate --out)")
    sp.add_argument("--observable", default=None, metavar="COL",
                    help="table column (default: <first clearance joint>.Fn)")
    sp.add_argument("--revs", type=number_arg("--revs"), default=float(SPECTRUM_SPANS.revs),
                    metavar="N", help=f"revolutions analysed after the transient (default {SPECTRUM_SPANS.revs:g})")
    sp.add_argument("--transient-revs", type=number_arg("--transient-revs", positive=False),
                    default=float(SPECTRUM_SPANS.transient_revs), metavar="N",
                    help=f"revolutions dropped first (default {SPECTRUM_SPANS.transient_revs:g})")
    sp.add_argument("--samples-per-rev", type=count_arg("--samples-per-rev", 2), default=SPECTRUM.samples_per_rev,
                    metavar="N", help=f"output samples per revolution (default {SPECTRUM.samples_per_rev}: "
                                      f"orders up to {SPECTRUM.samples_per_rev // 2})")
    sp.add_argument("--rtol", type=rtol_arg, default=SPECTRUM.rtol, metavar="R",
                    help=f"relative tolerance (default {SPECTRUM.rtol:g})")
    sp.add_argument("--method", choices=METHODS, default="welch", help="welch (default) or fft")
    sp.add_argument("--window", default="hann", help="scipy window name (default hann)")
    sp.add_argument("--nperseg", type=count_arg("--nperseg", 8), default=None, metavar="N",
                    help="Welch segment length (default: largest power of 2 <= N/4)")
    sp.add_argument("--peaks", type=count_arg("--peaks", 1), default=10, metavar="N",
                    help="number of peaks printed (default 10)")
    sp.add_argument("--out", metavar="FILE", help="write the full spectrum to FILE.csv or "
                                                 "FILE.parquet (provenance alongside)")
    sp.set_defaults(func=cmd_spectrum)
    return sp


def cmd_spectrum(args) -> int:
    """``nld spectrum``: print the largest peaks (and write the spectrum with --out)."""
    from nld.analysis.spectrum import crank_frequency_of, peaks, scene_spectrum, table_spectrum
    from nld.output.io import check_table_path, load_table, save_table
    out = check_table_path(args.out) if args.out else None
    if args.table is not None:
        if args.scene is not None:
            raise InputError("give either SCENE or --table, not both")
        table, prov = load_table(args.table)
        spec = table_spectrum(table, args.observable, transient_revs=args.transient_revs
                              if crank_frequency_of(table) else None, method=args.method,
                              window=args.window, nperseg=args.nperseg)
        prov = dict(prov, source_table=str(args.table))
    else:
        if args.scene is None:
            raise InputError("give a SCENE or --table FILE")
        spec, res = scene_spectrum(args.scene, args.observable, overrides=args.overrides,
                                   revs=args.revs, transient_revs=args.transient_revs,
                                   samples_per_rev=args.samples_per_rev, rtol=args.rtol,
                                   method=args.method, window=args.window, nperseg=args.nperseg)
        prov = dict(res.provenance)
    prov.update(kind="spectrum", **{k: v for k, v in spec.attrs.items()},
                command=getattr(args, "command_line", None))
    pk = peaks(spec, args.peaks)
    a = spec.attrs
    print(f"spectrum of {a['observable']} ({a['method']}, {a['window']} window, "
          f"resolution {a['resolution_hz']:.4g} Hz"
          + (f", crank frequency {a['crank_frequency']:.6g} Hz" if a.get("crank_frequency") else "")
          + ")")
    print(pk.to_string(index=False, float_format=lambda v: f"{v:.6g}"))
    if out is not None:
        path = save_table(spec, out, prov)
        print(f"wrote {len(spec)} frequencies to {path}")
    return 0
