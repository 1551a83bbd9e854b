"""Locating a section crossing by landing integrations: the one routine behind the hyperplane
sections of ``nld.analysis.poincare`` and the Poincaré map of ``nld.systems.derived``.

A crossing of a section g(t, y, z) = 0 is first bracketed on a run's dense output (two states
(t0, y0, z0) and t1 with g changing sign between them); :func:`locate_crossing` then finds the
crossing time by Brent's method (``scipy.optimize.brentq``: inverse quadratic interpolation,
secant and bisection, guaranteed to converge on a bracket), evaluating g on *landing*
integrations from the bracket's left end: the flow's own integrator is restarted at (t0, y0, z0)
and lands exactly on each trial time. The located point is then as accurate as the integration
itself (no interpolation error); its time to |dt| <= XTOL_REL * max(1, |t1|) + 4 eps |t| s.

Units: times in s, states in the flow's SI units.
"""
from __future__ import annotations

import numpy as np

from nld.systems.core import advance

__all__ = ["land", "locate_crossing", "XTOL_REL"]

XTOL_REL = 1e-13       # Brent's absolute time tolerance, relative to max(1, |t1|) (s)


def land(system, y, z, t0: float, t1: float, rtol: float, atol, hmax: float, max_steps: int,
         max_log: int = 1):
    """(y(t1), z(t1)) from (t0, y, z): the system's integrator landing exactly on t1 (copies; the
    inputs are not modified): ``nld.systems.core.advance``, and for t1 <= t0 the start itself.
    SolveError when the integration fails."""
    if t1 <= t0:
        return np.array(y, dtype=float), np.array(z, dtype=float)
    return advance(system, y, z, t0, t1, rtol, atol=atol, hmax=hmax, max_steps=max_steps,
                   max_log=max_log)


def locate_crossing(system, g, t0: float, y0, z0, t1: float, *, rtol: float, atol=None,
                    hmax: float | None = None, max_steps: int = 50_000_000):
    """The crossing of g(t, y, z) = 0 in [t0, t1] of the motion from (t0, y0, z0).

    g: a scalar function of time and state (a hyperplane n . y - offset, an observable minus its
    level); it must change sign over the bracket. Brent's method (``scipy.optimize.brentq``,
    ``xtol = XTOL_REL * max(1, |t1|)``, ``rtol = 4 eps``) on the time, g evaluated on
    integrations of ``system`` (its ``solve``, at ``rtol`` / ``atol``, default
    ``system.tolerance(rtol)``; hmax default ``system.hmax``) from (t0, y0, z0) landing exactly
    on each trial time.

    Returns (tc, y(tc), z(tc)). When the landing integrations do not bracket a sign change (the
    bracket came from another integration's dense output, and g at t1 is within that run's error
    of 0), the crossing lies within the integration error of t1: (t1, y(t1), z(t1)) is returned.
    SolveError when a landing integration fails.
    """
    from scipy.optimize import brentq
    atol = system.tolerance(rtol) if atol is None else atol
    hmax = float(system.hmax if hmax is None else hmax)
    cache = {}

    def G(t):
        yt, zt = land(system, y0, z0, t0, t, rtol, atol, hmax, max_steps)
        cache[t] = (yt, zt)
        return g(t, yt, zt)
    try:
        tc = brentq(G, t0, t1, xtol=XTOL_REL * max(1.0, abs(t1)), rtol=4 * np.finfo(float).eps)
    except ValueError:          # no sign change on the landing integrations: the end itself
        tc = t1
    yc, zc = cache[tc] if tc in cache else land(system, y0, z0, t0, tc, rtol, atol, hmax,
                                                max_steps)
    return tc, yc, zc
