"""``nld hard-cases [--quick] [--list] [NAME ...]``: the integrators' hard regression cases
(``nld.run.hard_cases``), one report per case; exit status 1 when a case fails its check."""
from __future__ import annotations

from nld.errors import InputError


def add_parser(sub) -> None:
    sp = sub.add_parser("hard-cases", help="run the named hard regression cases of the integrators",
                        description="Run the hard cases (nld.run.hard_cases: very stiff contact, tiny and "
                                    "large clearances, friction reversal, grazing contact, 10^4 "
                                    "revolutions, 10 000 rpm) and print a report per case; exit "
                                    "status 1 when a case fails its check.")
    sp.add_argument("names", nargs="*", metavar="NAME", help="cases to run (default: all)")
    sp.add_argument("--quick", action="store_true", help="the short variant of the long cases")
    sp.add_argument("--list", action="store_true", help="list the cases and exit")
    sp.set_defaults(func=cmd_hard_cases)


def cmd_hard_cases(args) -> int:
    from nld.run.hard_cases import CASES, run_case
    unknown = [n for n in args.names if n not in CASES]
    if unknown:
        raise InputError(f"hard case {unknown[0]!r}: choose from {', '.join(CASES)}")
    if args.list:
        for n, c in CASES.items():
            q = f", quick {c.quick_revs:g}" if c.has_long_variant else ""
            print(f"{n}: {c.description} ({c.scene}, {c.revs:g} revs{q}, {c.method}, "
                  f"rtol {c.rtol:g}, expects {c.expectation})")
        return 0
    bad = 0
    for n in args.names or list(CASES):
        rep = run_case(n, quick=args.quick)
        print(rep.summary(), flush=True)
        bad += not rep.passed
    return 1 if bad else 0
