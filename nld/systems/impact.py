"""A forced oscillator against a damped elastic stop: the impact oscillator of the orbit checks.

    x'' + 2 zeta x' + x = F cos(omega t) - [x > d] (k (x - d) + c x')

(nondimensional time and length; the stop at x = d is a linear spring k with a dashpot c that act
only in contact). The piecewise-linear soft-impact oscillator is the standard test case of
non-smooth periodic-orbit and grazing analysis (Shaw & Holmes 1983; di Bernardo et al. 2008,
"Piecewise-smooth Dynamical Systems", ch. 1.2 and 2.5; Ing et al. 2008): between contact events it
is linear, so its periodic orbits and their monodromy have closed forms (matrix exponentials per
segment and a saltation matrix at each event), and it grazes where the free orbit's amplitude
reaches d. The dashpot makes the vector field jump at x = d (by c x'), so the saltation
matrices are not the identity.

State [x, x']; discrete state z = [contact flag]; event g = x - d (upward: contact onset, with
|dg/dt| = |x'| the approach speed). Parameters p = [zeta, omega, F, d, k, c].
"""
from __future__ import annotations

import math

from numba import njit

__all__ = ["impact_oscillator", "impact_rhs", "impact_events", "impact_on_event",
           "impact_init_modes"]


@njit(cache=True)
def impact_rhs(t, y, p, z, dy):
    """x'' + 2 zeta x' + x = F cos(omega t) - z0 (k (x - d) + c x'); p = [zeta, omega, F, d, k, c]."""
    dy[0] = y[1]
    a = -2.0 * p[0] * y[1] - y[0] + p[2] * math.cos(p[1] * t)
    if z[0] > 0.5:
        a = a - p[4] * (y[0] - p[3]) - p[5] * y[1]
    dy[1] = a


@njit(cache=True)
def impact_events(t, y, p, z, g):
    g[0] = y[0] - p[3]


@njit(cache=True)
def impact_on_event(k, direction, t, y, p, z):
    if k == 0:
        if direction > 0:
            z[0] = 1.0
        else:
            z[0] = 0.0
    return 0


@njit(cache=True)
def impact_init_modes(t, y, p, z):
    z[0] = 1.0 if y[0] > p[3] else 0.0


def impact_oscillator(zeta: float = 0.05, omega: float = 0.8, F: float = 1.0, d: float = 1.5,
                      k: float = 10.0, c: float = 0.5, y0=(1.0, 0.5)):
    """The impact oscillator (module docstring) as a forced ContinuousSystem (period 2 pi/omega).

    The defaults have a stable period-1 orbit with one contact per period."""
    from nld.systems.core import ContinuousSystem
    from nld.errors import InputError
    for name, v in (("zeta", zeta), ("omega", omega), ("F", F), ("d", d), ("k", k), ("c", c)):
        if not math.isfinite(v):
            raise InputError(f"{name} = {v!r}: must be finite")
    if omega <= 0:
        raise InputError(f"omega = {omega!r}: must be > 0")
    if k < 0 or c < 0:
        raise InputError(f"k = {k!r}, c = {c!r}: the stop's stiffness and damping must be >= 0")
    z0 = [1.0 if y0[0] > d else 0.0]
    s = ContinuousSystem(impact_rhs, y0, [zeta, omega, F, d, k, c],
                         f"impact_oscillator(zeta={zeta:g}, omega={omega:g}, F={F:g}, d={d:g}, "
                         f"k={k:g}, c={c:g})", ["x", "x_dot"], period=2.0 * math.pi / omega,
                         z0=z0, events=impact_events, on_event=impact_on_event, n_events=1,
                         init_modes=impact_init_modes)
    s.contact_events = [0]
    s.param_names = ["zeta", "omega", "F", "d", "k", "c"]
    s.period_index = 1
    return s
