"""The one verdict rule: chaotic, regular, permanent contact, coexisting or not established.

Every place that turns an exponent into a word calls this module (the studies through
``nld.study``, the chaos maps, the bifurcation sweeps, the attractor census and the command line;
tests/test_architecture.py checks that no other module defines a verdict).

The rule (docs/attractors.md, "Verdicts"):

* ``failed``: the run failed or the exponent is not a number.
* ``permanent contact``: the measured span had no contact onset under a contact law with memory
  (the Lankarani-Nikravesh onset velocity): the exponent is conditional on the memory value
  recorded at the last onset, long before, and another transient ends on another value
  (docs/contact-laws.md, "Memory"). Such a motion is its own class, whatever the sign of λ1.
* ``chaotic``: λ1 − u > 0 over a section of at least ``min_points`` points (fewer: ``SHORT``,
  "λ1 > 0, short": a section that short cannot tell an attractor from a transient);
  ``regular``: λ1 + u < 0; else ``uncertain`` (u: the exponent's uncertainty, the interval
  ``nld lyapunov`` calls about 95 %).
* With a check (the same motion at a tighter tolerance over a longer averaging span): the verdict
  holds only if both give the same word *and* the two exponents agree within ``CHECK_FACTOR``
  times their combined uncertainty; otherwise ``not established`` (an intermittent or
  tolerance-dependent motion, or one of several coexisting motions reached at one setting and
  not the other: the attractor census decides, :func:`census_verdict`).
* An attractor census with more than one attractor: ``coexisting``; with one: that attractor's
  class (periodic and quasi-periodic are regular).
"""
from __future__ import annotations

import math

__all__ = ["CHAOTIC", "REGULAR", "UNCERTAIN", "PERMANENT_CONTACT", "COEXISTING", "NOT_ESTABLISHED",
           "FAILED", "SHORT", "CHECK_FACTOR", "VERDICTS", "exponent_verdict", "verdict",
           "checked_verdict", "census_verdict", "kind_verdict"]

CHAOTIC = "chaotic"
REGULAR = "regular"
UNCERTAIN = "uncertain"
PERMANENT_CONTACT = "permanent contact"
COEXISTING = "coexisting"
NOT_ESTABLISHED = "not established"
FAILED = "failed"
SHORT = "λ1 > 0, short"
VERDICTS = (CHAOTIC, REGULAR, UNCERTAIN, PERMANENT_CONTACT, COEXISTING, NOT_ESTABLISHED, FAILED,
            SHORT)

# two exponents of one motion agree when they differ by at most CHECK_FACTOR x the sum of their
# uncertainties (the uncertainty is a ~95 % half-width, so 3x their sum is far outside chance)
CHECK_FACTOR = 3.0


def _finite(u) -> float:
    return float(u) if u is not None and math.isfinite(u) else 0.0


def exponent_verdict(lam, unc, n_points: int | None = None, min_points: int = 0,
                     failed: bool | None = None, *, permanent_contact: bool = False) -> str:
    """The verdict of one exponent lam ± unc (any unit: per second, per revolution, per
    iteration; only signs and ratios matter). n_points / min_points: the section length behind
    the run and the least that a chaotic verdict needs (None: not checked). failed: the run failed
    (default: lam is NaN). permanent_contact: no contact onset under a law with memory over the
    span."""
    if failed if failed is not None else not (lam is not None and lam == lam):
        return FAILED
    if permanent_contact:
        return PERMANENT_CONTACT
    u = _finite(unc)
    if lam + u < 0:
        return REGULAR
    if lam - u > 0:
        return CHAOTIC if n_points is None or n_points >= min_points else SHORT
    return UNCERTAIN


def checked_verdict(main: str, check: str | None, *, lam=None, unc=None, lam_check=None,
                    unc_check=None) -> str:
    """The verdict that survives the check, or ``not established``.

    main / check: the verdicts (:func:`exponent_verdict`) at the run's settings and at a tighter
    tolerance over a longer span (check None: not checked, main is returned). Equal words are
    kept when the exponents (if given) also agree within CHECK_FACTOR x (unc + unc_check);
    'failed' on either side is 'failed'; any other disagreement is 'not established'."""
    if check is None or check == "":
        return main
    if FAILED in (main, check):
        return FAILED
    if check != main:
        return NOT_ESTABLISHED
    if lam is not None and lam_check is not None and math.isfinite(lam) \
            and math.isfinite(lam_check):
        if abs(lam - lam_check) > CHECK_FACTOR * (_finite(unc) + _finite(unc_check)):
            return NOT_ESTABLISHED
    return main


def verdict(lam, unc, *, lam_check=math.nan, unc_check=math.nan, n_points: int | None = None,
            min_points: int = 0, failed: bool | None = None,
            permanent_contact: bool = False) -> str:
    """:func:`exponent_verdict` of (lam, unc), checked against (lam_check, unc_check) when that
    is a number (:func:`checked_verdict`)."""
    main = exponent_verdict(lam, unc, n_points=n_points, min_points=min_points, failed=failed,
                            permanent_contact=permanent_contact)
    if lam_check is None or not math.isfinite(lam_check):
        return main
    chk = exponent_verdict(lam_check, unc_check, n_points=n_points, min_points=min_points,
                           permanent_contact=permanent_contact)
    return checked_verdict(main, chk, lam=lam, unc=unc, lam_check=lam_check, unc_check=unc_check)


def kind_verdict(kind: str) -> str:
    """The verdict of one attractor of a census by its kind: periodic and quasi-periodic are
    regular; chaotic and permanent contact are themselves; escaping is 'failed'."""
    if kind in ("periodic", "quasi-periodic"):
        return REGULAR
    if kind in (CHAOTIC, PERMANENT_CONTACT):
        return kind
    return FAILED if kind == "escaping" else UNCERTAIN


def census_verdict(kinds) -> str:
    """The verdict of an attractor census from its attractors' kinds: 'coexisting' for more than
    one, the attractor's class for one, 'not established' for none (every run unsettled)."""
    kinds = list(kinds)
    if len(kinds) > 1:
        return COEXISTING
    if not kinds:
        return NOT_ESTABLISHED
    return kind_verdict(kinds[0])
